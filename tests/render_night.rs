//! The six night validation scenarios (`sims/night-*`) render: small
//! images (`resolution_scale`), low sample counts, checked for finite,
//! non-negative radiance, the moon-phase ordering of the ground's mean
//! radiance, and lamps brightening the ground near them.

use std::path::Path;
use std::time::Instant;

use gloam_trace::{DVec3, RenderOutput, RenderSettings, Tracer};

const SCALE: f64 = 0.25; // 768 × 576 → 192 × 144

fn settings() -> RenderSettings {
    RenderSettings {
        spp: 1,
        sky_samples: 8,
        resolution_scale: SCALE,
        recursion: 2,
        ..Default::default()
    }
}

struct Night {
    name: &'static str,
    out: RenderOutput,
    /// Per pixel: the ground point its centre ray hits (world frame), if any.
    ground: Vec<Option<DVec3>>,
    lamps: Vec<DVec3>,
    seconds: f64,
}

fn render(name: &'static str) -> Night {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("sims")
        .join(name)
        .join("scene.toml");
    let scene = gloam_scene::load(&path, &gloam_io::ReadLog::off())
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    // A lamp inside a closed housing would light nothing: every lamp must
    // sit outside every lamp-head box (they hang below open-bottomed heads).
    let lamps: Vec<DVec3> = scene.point_sources.iter().map(|p| p.position).collect();
    for f in scene.facets.iter().filter(|f| f.object.ends_with("-head")) {
        let vs: Vec<DVec3> = scene
            .facets
            .iter()
            .filter(|g| g.object == f.object)
            .flat_map(|g| g.vertices.clone())
            .collect();
        let lo = vs.iter().fold(DVec3::INFINITY, |a, v| a.min(*v));
        let hi = vs.iter().fold(DVec3::NEG_INFINITY, |a, v| a.max(*v));
        assert!(
            !lamps.iter().any(|l| l.cmpgt(lo).all() && l.cmplt(hi).all()),
            "{name}: a lamp sits inside housing '{}'",
            f.object
        );
    }
    let t0 = Instant::now();
    let tracer = Tracer::new(&scene, &settings()).unwrap_or_else(|e| panic!("{name}: {e}"));
    let out = tracer.render(&|_, _| {}).unwrap();
    let seconds = t0.elapsed().as_secs_f64();
    let (w, h) = (out.stats.width, out.stats.height);
    assert_eq!(
        (w, h),
        (
            (scene.camera.width as f64 * SCALE).round() as u32,
            (scene.camera.height as f64 * SCALE).round() as u32
        )
    );
    let origin = tracer.geometry().origin;
    let mut ground = Vec::with_capacity((w * h) as usize);
    for row in 0..h {
        for col in 0..w {
            let (o, d) = tracer.camera_ray(col as f64 + 0.5, row as f64 + 0.5);
            let hit = tracer
                .geometry()
                .intersect(o, d, 0.0, f64::INFINITY, u32::MAX);
            ground.push(hit.and_then(|hit| {
                (scene.facets[hit.facet as usize].object == "ground")
                    .then(|| o + d * hit.t + origin)
            }));
        }
    }
    Night {
        name,
        lamps: scene.point_sources.iter().map(|p| p.position).collect(),
        out,
        ground,
        seconds,
    }
}

impl Night {
    /// Mean band-0 radiance over ground pixels that pass `keep`.
    fn ground_mean(&self, keep: impl Fn(DVec3) -> bool) -> f64 {
        let w = self.out.stats.width as usize;
        let (mut sum, mut n) = (0.0, 0usize);
        for (i, g) in self.ground.iter().enumerate() {
            if let Some(p) = g
                && keep(*p)
            {
                sum += self.out.radiance[[0, i / w, i % w]];
                n += 1;
            }
        }
        assert!(n > 0, "{}: no ground pixels selected", self.name);
        sum / n as f64
    }
}

fn near(lamps: &[DVec3], p: DVec3, r: f64) -> bool {
    lamps
        .iter()
        .any(|l| (DVec3::new(l.x, l.y, 0.0) - DVec3::new(p.x, p.y, 0.0)).length() < r)
}

#[test]
fn six_night_scenarios_render() {
    let names = [
        "night-full-moon",
        "night-half-moon",
        "night-new-moon",
        "night-full-moon-lamps",
        "night-half-moon-lamps",
        "night-new-moon-lamps",
    ];
    let nights: Vec<Night> = names.iter().map(|n| render(n)).collect();
    for n in &nights {
        assert!(
            n.out.radiance.iter().all(|v| v.is_finite() && *v >= 0.0),
            "{}: non-finite or negative radiance",
            n.name
        );
        assert!(n.out.stats.sky.is_some(), "{}: no sky", n.name);
        eprintln!(
            "{:<22} {:>3}×{:<3} {:.2} s, mean ground radiance {:.4e} W m⁻² sr⁻¹ ({}), {} rays",
            n.name,
            n.out.stats.width,
            n.out.stats.height,
            n.seconds,
            n.ground_mean(|_| true),
            n.out.band_names[0],
            n.out.stats.rays.total()
        );
    }
    let mean = |i: usize| nights[i].ground_mean(|_| true);
    // Moon phase: full > half > new, with and without lamps.
    for k in [0, 3] {
        assert!(
            mean(k) > mean(k + 1) && mean(k + 1) > mean(k + 2),
            "{} {} {}",
            mean(k),
            mean(k + 1),
            mean(k + 2)
        );
    }
    // Lamps: the ground within 6 m of a lamp is brighter than without.
    for k in 0..3 {
        let (plain, lit) = (&nights[k], &nights[k + 3]);
        let lamps = &lit.lamps;
        assert!(!lamps.is_empty());
        let a = plain.ground_mean(|p| near(lamps, p, 6.0));
        let b = lit.ground_mean(|p| near(lamps, p, 6.0));
        eprintln!("{}: near the lamps {a:.4e} → {b:.4e}", lit.name);
        assert!(b > 1.5 * a, "{}: {b} vs {a}", lit.name);
    }
}
