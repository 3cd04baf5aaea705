//! `gloam ephem`: Moon and Sun positions and the lunar phase for one instant
//! and site, or (`--from/--to/--find`) the good collection nights in a date
//! range. The checks, the search and the report are `gloam_sky::report`;
//! this module only parses and prints.

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use gloam_sky::report::{EphemReport, InputNames, NightsReport, checked_site, parse_instant};
use gloam_sky::{NightSearch, PhaseTarget};

use super::output::print_json;

/// Target phase for `--find`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FindPhase {
    /// Near full (illuminated fraction ≥ 1 − tolerance), Moon up.
    Full,
    /// Near a quarter (fraction within tolerance of 0.5), Moon up.
    Half,
    /// Moonless: Moon below the horizon or a crescent of ≤ 1 %.
    New,
}

impl From<FindPhase> for PhaseTarget {
    fn from(p: FindPhase) -> Self {
        match p {
            FindPhase::Full => PhaseTarget::Full,
            FindPhase::Half => PhaseTarget::Half,
            FindPhase::New => PhaseTarget::New,
        }
    }
}

#[derive(Args, Debug)]
#[command(group(
    clap::ArgGroup::new("mode").required(true).args(["utc", "find"])
))]
pub struct EphemArgs {
    /// Site latitude, degrees north (−90..90).
    #[arg(long, allow_negative_numbers = true)]
    pub lat: f64,
    /// Site longitude, degrees east positive (−180..360).
    #[arg(long, allow_negative_numbers = true)]
    pub lon: f64,
    /// Site height above sea level, metres.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub height_m: f64,
    /// The instant, ISO 8601 (`2024-12-15T07:20:00Z`; no zone = UTC).
    #[arg(long, conflicts_with_all = ["from", "to", "find"])]
    pub utc: Option<String>,
    /// Start of the search window (ISO 8601; a date alone is 00:00 UTC).
    #[arg(long, requires_all = ["to", "find"])]
    pub from: Option<String>,
    /// End of the search window (ISO 8601; a date alone means the end of
    /// that UTC day, 24:00).
    #[arg(long, requires_all = ["from", "find"])]
    pub to: Option<String>,
    /// List good collection nights for this phase (needs --from and --to).
    #[arg(long, value_enum, requires_all = ["from", "to"])]
    pub find: Option<FindPhase>,
    /// --find: lowest Moon elevation for full/half, degrees.
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true)]
    pub min_moon_elevation_deg: f64,
    /// --find: highest Sun elevation that counts as dark, degrees.
    #[arg(long, default_value_t = -18.0, allow_negative_numbers = true)]
    pub max_sun_elevation_deg: f64,
    /// --find: tolerance on the illuminated fraction for full/half.
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true)]
    pub fraction_tolerance: f64,
    /// --find: shortest usable run worth reporting, hours.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub min_hours: f64,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: EphemArgs) -> anyhow::Result<()> {
    let names = InputNames::CLI;
    let site = checked_site(args.lat, args.lon, args.height_m, &names)?;
    match (&args.utc, args.find) {
        (Some(utc), None) => {
            let report = EphemReport::at(parse_instant(names.utc, utc)?, &site);
            if args.json {
                return print_json(&report);
            }
            outln!("{report}");
        }
        (None, Some(phase)) => {
            let from = args.from.as_deref().context("--find needs --from")?;
            let to = args.to.as_deref().context("--find needs --to")?;
            let mut search = NightSearch::new(phase.into());
            search.min_moon_elevation_deg = args.min_moon_elevation_deg;
            search.max_sun_elevation_deg = args.max_sun_elevation_deg;
            search.fraction_tolerance = args.fraction_tolerance;
            search.min_usable_hours = args.min_hours;
            let report = NightsReport::find(&site, from, to, &search, &names)?;
            if args.json {
                return print_json(&report);
            }
            outln!("{report}");
        }
        _ => bail!("give either --utc, or --from, --to and --find"),
    }
    Ok(())
}
