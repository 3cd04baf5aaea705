//! `gloam render SCENE --out DIR …`: spectral radiance images of a scene.
//!
//! Writes `DIR/radiance.tiff` (float32, one page per band),
//! `DIR/radiance.npy` (float64, band × row × column, W m⁻² sr⁻¹),
//! `DIR/preview.png` (tone-mapped first band, for people) and
//! `DIR/report.json` (settings, effect plan, timings, rays, rays/s, and
//! `target_error_source`: `"default"` when no sampling was named and the
//! render sampled to [`DEFAULT_TARGET_ERROR`], `"given"`, or null for a
//! fixed spp), each atomically. The arguments are
//! [`gloam_pipeline::cli::RenderArgs`]; they make a
//! [`gloam_pipeline::RenderRequest`], whose checks and recipe are the
//! Python `render`'s too. This file only draws progress and prints.

use std::sync::OnceLock;
use std::time::Instant;

pub use gloam_pipeline::cli::RenderArgs;
use gloam_pipeline::{DEFAULT_TARGET_ERROR, Events, TargetErrorSource};
use gloam_trace::PrepObserver;

use super::progress::{TileBar, prep_spinner};

/// A spinner for the preparation, a bar over the tiles, notes on stderr.
#[derive(Default)]
struct Terminal {
    bar: OnceLock<TileBar>,
}

impl Events for Terminal {
    fn preparation(&self) -> Option<PrepObserver> {
        prep_spinner()
    }
    fn tiles(&self, done: u64, total: u64) {
        self.bar.get_or_init(TileBar::new).progress(done, total);
    }
    fn traced(&self) {
        if let Some(b) = self.bar.get() {
            b.finish();
        }
    }
    fn note(&self, line: &str) {
        eprintln!("{line}");
    }
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    // The wall time the user waits, preparation and writing included.
    let t_start = Instant::now();
    let done = args.request().validate()?.run(&Terminal::default())?;
    let (rendered, report) = (&done.rendered, &done.report);
    if report.target_error_source == Some(TargetErrorSource::Default) {
        let e = &rendered.radiance.error;
        eprintln!(
            "no --spp or --target-error: sampled to the default per-pixel error {:.0} % (--target-error {DEFAULT_TARGET_ERROR}): estimated RMS {:.2} %, mean {:.1} spp; --spp N renders a fixed count",
            100.0 * DEFAULT_TARGET_ERROR,
            100.0
                * e.rel_std_error_rms_target_pixels
                    .unwrap_or(e.rel_std_error_rms),
            e.mean_spp,
        );
    }
    if let Some(t) = &report.camera_target {
        let f = |k: &str| t[k].as_f64().unwrap_or(f64::NAN);
        eprintln!(
            "--target-error camera:{}: each pixel rendered until its variance is under {:.0} % of the camera's frame variance at gain {:.4}: added {:.1} % (median), {:.1} % (99th percentile); mean {:.1} spp",
            f("k"),
            100.0 * f("asked_added_variance_fraction"),
            f("gain"),
            100.0 * f("added_variance_fraction_median"),
            100.0 * f("added_variance_fraction_p99"),
            f("mean_spp"),
        );
    }
    if let Some(b) = &rendered.radiance.error.bias
        && let Some(band) = b.bands.first()
    {
        eprintln!(
            "radiosity cache bias ({}): {:+.2} % ± {:.2} % of the signal, measured against path tracing at {} pixels (report.json: error.bias); the per-pixel errors above and in stderr.npy are noise only",
            band.band,
            100.0 * band.relative_bias,
            100.0 * band.relative_bias_std_error,
            b.pixels
        );
    }
    let s = &rendered.radiance.stats;
    let (total_s, prep_s) = (t_start.elapsed().as_secs_f64(), done.prepare_s);
    eprintln!(
        "rendered {}×{}×{} bands in {:.2} s ({} rays, {:.3e} rays/s); {:.2} s in all, {:.2} s ({:.0} %) of it preparation (scene, BVH, pilot, cache) → {}",
        s.width,
        s.height,
        s.bands,
        s.trace_seconds,
        s.rays.total(),
        s.rays_per_second,
        total_s,
        prep_s,
        100.0 * prep_s / total_s.max(1e-9),
        args.out.display()
    );
    Ok(())
}
