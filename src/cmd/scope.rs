//! `gloam scope`: scan lines of a simulated camera's video as an
//! oscilloscope shows them (CSV, PNG, cursor readings) — over
//! `gloam_calib::scope_run`, run by `gloam_pipeline::cli::calibrate`.
//! See docs/video.md.

pub use gloam_calib::cli::ScopeArgs;

pub fn run(a: ScopeArgs, guard: &gloam_io::RunGuard) -> anyhow::Result<()> {
    let (readouts, wrote) = gloam_pipeline::cli::calibrate::run_scope_command(&a, guard)?;
    for line in readouts {
        outln!("{line}");
    }
    eprintln!("{wrote}");
    Ok(())
}
