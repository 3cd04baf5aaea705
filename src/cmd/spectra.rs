//! `gloam spectra list|integrate` (arguments: [`gloam_spectra::cli`]).

pub use gloam_spectra::cli::SpectraCommand;
use gloam_spectra::{BandIntegral, library};

use super::print_json;

pub fn run(cmd: SpectraCommand) -> anyhow::Result<()> {
    match cmd {
        SpectraCommand::List { json: true } => print_json(&library::ENTRIES)?,
        SpectraCommand::List { json: false } => {
            for e in library::ENTRIES {
                let kind = format!("{:?}", e.kind);
                outln!("{:<24} {kind:<13} {}", e.name, e.description);
                outln!("{:<24} {:<13} source: {}", "", "", e.provenance);
            }
        }
        SpectraCommand::Integrate(a) => {
            let report = BandIntegral::of(
                &a.spectrum,
                a.band,
                a.weight.as_deref(),
                &gloam_io::ReadLog::off(),
            )?;
            if a.json {
                return print_json(&report);
            }
            outln!("{} ({})", gloam_spectra::num(report.integral), report.units);
        }
    }
    Ok(())
}
