//! `gloam render SCENE --out DIR …`: spectral radiance images of a scene.
//!
//! Writes `DIR/radiance.tiff` (float32, one page per band),
//! `DIR/radiance.npy` (float64, band × row × column, W m⁻² sr⁻¹),
//! `DIR/preview.png` (tone-mapped first band, for people) and
//! `DIR/report.json` (settings, effect plan, timings, rays, rays/s, and
//! `target_error_source`), each atomically. The arguments are
//! [`gloam_pipeline::cli::RenderArgs`]; they make a
//! [`gloam_pipeline::RenderRequest`], whose checks and recipe are the
//! Python `render`'s too. This file only draws progress and prints.

use std::time::Instant;

pub use gloam_pipeline::cli::RenderArgs;

use super::progress::Terminal;

pub fn run(args: RenderArgs, guard: &gloam_io::RunGuard) -> anyhow::Result<()> {
    // The wall time the user waits, preparation and writing included.
    let t_start = Instant::now();
    let done =
        (args.request().validate(&gloam_io::ReadLog::new())?).run(&Terminal::default(), guard)?;
    for line in done.lines(&args.out, t_start.elapsed().as_secs_f64()) {
        eprintln!("{line}");
    }
    Ok(())
}
