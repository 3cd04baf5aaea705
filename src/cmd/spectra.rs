//! `gloam spectra list|integrate`.

use clap::{Args, Subcommand};
use gloam_spectra::{library, lookup};
use serde::Serialize;

use super::output::print_json;

#[derive(Subcommand)]
pub enum SpectraCommand {
    /// List the built-in spectra with their provenance.
    List {
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Integrate a spectrum over a band, optionally weighted by a response.
    Integrate(IntegrateArgs),
}

#[derive(Args)]
pub struct IntegrateArgs {
    /// A built-in name (see `gloam spectra list`) or a CSV file
    /// (`wavelength_nm,value` rows, `line,wavelength_nm,value` for lines).
    pub spectrum: String,
    /// The band, `LO:HI` in nm (half-open: lines at HI are excluded).
    #[arg(long, value_parser = parse_band)]
    pub band: (f64, f64),
    /// Weight by this response (built-in name or CSV), e.g. `v-photopic`;
    /// the product of the two is integrated exactly.
    #[arg(long)]
    pub weight: Option<String>,
    /// Print `{"integral": …, "units": …}`.
    #[arg(long)]
    pub json: bool,
}

/// Parses `LO:HI` in nm.
pub fn parse_band(s: &str) -> Result<(f64, f64), String> {
    let (lo, hi) = s
        .split_once(':')
        .ok_or_else(|| format!("band '{s}' must be LO:HI in nm, e.g. 400:700"))?;
    let lo: f64 = lo
        .trim()
        .parse()
        .map_err(|_| format!("band low edge '{lo}' is not a number"))?;
    let hi: f64 = hi
        .trim()
        .parse()
        .map_err(|_| format!("band high edge '{hi}' is not a number"))?;
    if !(lo.is_finite() && hi.is_finite() && hi > lo && lo >= 0.0) {
        return Err(format!("band {lo}:{hi} must have 0 <= LO < HI"));
    }
    Ok((lo, hi))
}

#[derive(Serialize)]
struct IntegralReport {
    integral: f64,
    units: &'static str,
    spectrum: String,
    band_nm: [f64; 2],
    weight: Option<String>,
}

pub fn run(cmd: SpectraCommand) -> anyhow::Result<()> {
    match cmd {
        SpectraCommand::List { json } => {
            if json {
                print_json(&library::ENTRIES)?;
            } else {
                for e in library::ENTRIES {
                    outln!(
                        "{:<24} {:<13} {}",
                        e.name,
                        format!("{:?}", e.kind),
                        e.description
                    );
                    outln!("{:<24} {:<13} source: {}", "", "", e.provenance);
                }
            }
            Ok(())
        }
        SpectraCommand::Integrate(a) => {
            let s = lookup(&a.spectrum)?;
            let (lo, hi) = a.band;
            // Exact for both: the weighted integral integrates the quadratic
            // product of the two continua, and both count lines in [LO, HI).
            let integral = match &a.weight {
                Some(w) => s.integrate_weighted_band(&lookup(w)?, lo, hi),
                None => s.integrate_band(lo, hi),
            };
            let units = if a.weight.is_some() {
                "spectrum units x weight units x nm"
            } else {
                "spectrum units x nm"
            };
            let report = IntegralReport {
                integral,
                units,
                spectrum: a.spectrum,
                band_nm: [lo, hi],
                weight: a.weight,
            };
            if a.json {
                print_json(&report)
            } else {
                outln!("{} ({})", report.integral, report.units);
                Ok(())
            }
        }
    }
}
