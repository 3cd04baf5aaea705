//! Full Gen III ICCD chain (noise and MTF on) on 1024×768 frames.
//! Target: ≥ 60 frames/s on 2 cores.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use gloam_sensor::{Camera, SensorConfig, bench::test_scene};

fn chain(c: &mut Criterion) {
    let (w, h) = (1024, 768);
    // The throughput figure the CLI reports, printed once.
    let t = gloam_sensor::throughput("gen3-gaas-iccd", w, h, 60).expect("preset");
    println!(
        "gen3-gaas-iccd {w}x{h}: {:.1} frames/s on {} threads ({} photoelectrons/pixel/frame scene)",
        t.frames_per_s, t.threads, t.mean_photoelectrons
    );

    let cfg = SensorConfig::load_preset_or_file("gen3-gaas-iccd").expect("preset");
    let mut cam = Camera::new(cfg).expect("valid");
    let scene = test_scene(w, h, 2.0);
    let mut g = c.benchmark_group("sensor");
    g.throughput(Throughput::Elements(1));
    g.sample_size(30);
    g.bench_function("gen3_iccd_1024x768_frame", |b| {
        b.iter(|| cam.capture_photoelectrons(scene.view()).expect("capture"))
    });
    g.finish();
}

criterion_group!(benches, chain);
criterion_main!(benches);
