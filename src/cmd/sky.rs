//! `gloam sky`: illuminance on the ground from the Moon (direct and
//! sky-scattered) and the night sky at one instant and site, with the
//! spectral irradiance tables written to CSV on request. The arguments and
//! the query are [`gloam_sky::cli`]; the checks, the report and the CSV are
//! `gloam_sky::report`.

pub use gloam_sky::cli::SkyArgs;

use super::print_json;
use gloam_pipeline::output::write_atomic;

pub fn run(args: SkyArgs) -> anyhow::Result<()> {
    let mut report = args.report()?;
    if let (Some(path), Some(csv)) = (&args.spectra_out, report.spectra_csv()) {
        write_atomic(path, csv.as_bytes())?;
        report.spectra_out = Some(path.display().to_string());
    }
    if report.twilight_not_modelled && !args.json {
        eprintln!(
            "warning: the Sun is at {:.1}° (above −18°): twilight and daylight are NOT included",
            report.sun_elevation_deg
        );
    }
    if args.json {
        return print_json(&report);
    }
    outln!("{report}");
    Ok(())
}
