//! Primary and shadow rays per second on the office room
//! (`sims/office-room/scene.toml`), plus one whole default render.
//!
//! `cargo bench -p gloam-trace --bench rays`; criterion prints the
//! throughput in rays (elements) per second.

use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use gloam_trace::{DVec3, RenderSettings, Tracer};

fn office() -> gloam_scene::Scene {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../sims/office-room/scene.toml");
    gloam_scene::load(&p, &gloam_io::ReadLog::off()).expect("loading the office room")
}

fn rays(c: &mut Criterion) {
    let scene = office();
    let tracer = Tracer::new(&scene, &RenderSettings::default()).unwrap();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let primary: Vec<(DVec3, DVec3)> = (0..h)
        .flat_map(|r| (0..w).map(move |c| (c, r)))
        .map(|(c, r)| tracer.camera_ray(c as f64 + 0.5, r as f64 + 0.5))
        .collect();
    let g = tracer.geometry();
    // Shadow rays: from every primary hit to every emitter centroid.
    let targets = tracer.emitter_centroids();
    let mut shadow = Vec::new();
    for &(o, d) in &primary {
        if let Some(hit) = g.intersect(o, d, 0.0, f64::INFINITY, u32::MAX) {
            let p = o + d * hit.t;
            for &t in &targets {
                let v = t - p;
                let dist = v.length();
                shadow.push((p, v / dist, dist, hit.facet));
            }
        }
    }

    let mut group = c.benchmark_group("office-room");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    group.throughput(Throughput::Elements(primary.len() as u64));
    group.bench_function("primary rays (closest hit)", |b| {
        b.iter(|| {
            primary
                .iter()
                .filter(|(o, d)| g.intersect(*o, *d, 0.0, f64::INFINITY, u32::MAX).is_some())
                .count()
        })
    });
    group.throughput(Throughput::Elements(shadow.len() as u64));
    group.bench_function("shadow rays (any opaque hit)", |b| {
        b.iter(|| {
            shadow
                .iter()
                .filter(|(p, d, dist, f)| {
                    let eps = g.epsilon(*p);
                    matches!(
                        g.visibility(*p, *d, eps, dist * (1.0 - 1e-9) - eps, [*f, u32::MAX]),
                        gloam_trace::geometry::Visibility::Clear(_)
                    )
                })
                .count()
        })
    });
    group.finish();

    let mut group = c.benchmark_group("office-room render");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10))
        .warm_up_time(Duration::from_secs(1));
    group.bench_function("default settings, all threads", |b| {
        b.iter(|| tracer.render(&|_, _| {}).unwrap().stats.rays.total())
    });
    group.finish();
}

criterion_group!(benches, rays);
criterion_main!(benches);
