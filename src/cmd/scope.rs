//! `gloam scope`: scan lines of a simulated camera's video as an
//! oscilloscope shows them (CSV, PNG, cursor readings) — a thin wrapper
//! over `gloam_calib::scope_run`. See docs/video.md.

pub use gloam_calib::cli::ScopeArgs;
use gloam_calib::scope_run::{run_scope, write_scope};
use gloam_io::OutputSet;

pub fn run(a: ScopeArgs) -> anyhow::Result<()> {
    let opts = a.options()?;
    let set = OutputSet::begin(&a.out, a.force, false)?;
    let r = run_scope(&opts)?;
    write_scope(set.dir(), &r)?;
    gloam_pipeline::cli::calibrate::publish(set, "scope.json")?;
    for (row, l) in &r.readouts {
        outln!(
            "row {row}: sync {:.3} V, blanking {:.3} V, active {:.3}–{:.3} V, sync {:.3} µs, line {:.3} µs",
            l.sync_tip_v,
            l.blanking_v,
            l.active_min_v,
            l.active_max_v,
            l.sync_width_s * 1e6,
            l.line_period_s * 1e6
        );
    }
    eprintln!(
        "{} ({}, {:.2} MHz pixel clock): wrote {}",
        r.sensor,
        r.format,
        r.pixel_clock_hz / 1e6,
        a.out.join("scope.png").display()
    );
    Ok(())
}
