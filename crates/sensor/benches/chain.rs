//! Full Gen III ICCD chain (noise and MTF on) on 1024×768 frames.
//! Target: ≥ 60 frames/s on 2 cores.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use gloam_sensor::{Camera, SensorConfig, bench::test_scene};

fn chain(c: &mut Criterion) {
    let (w, h) = (1024, 768);
    // The throughput figures `gloam bench throughput` reports, printed once:
    // a heavy scene (2 photoelectrons/pixel/frame) and a starlit one (0.3).
    for level in [2.0, 0.3] {
        let t = gloam_sensor::throughput_at("gen3-gaas-iccd", w, h, 60, level).expect("preset");
        println!(
            "gen3-gaas-iccd {w}x{h} at {level} pe/pixel/frame: {:.1} frames/s on {} threads \
             ({:.1} frames per CPU-second)",
            t.frames_per_s,
            t.threads,
            t.frames_per_cpu_s.unwrap_or(f64::NAN)
        );
    }

    let cfg = SensorConfig::load_preset_or_file("gen3-gaas-iccd", &gloam_io::ReadLog::off())
        .expect("preset");
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
