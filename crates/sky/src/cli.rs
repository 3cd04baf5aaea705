//! The command line's arguments for `gloam ephem` and `gloam sky`
//! (feature `cli`) and the queries they make, so the binary only prints.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use serde::Serialize;

use crate::report::{
    EphemReport, InputNames, NightsReport, QueryError, SkyReport, checked_site, parse_instant,
};
use crate::{Cloud, NightSearch, PhaseTarget, Site, SkyError};

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

// The observing site, shared by `ephem` and `sky` (a plain comment: a doc
// comment on a flattened struct would become the command's about text).
#[derive(Args, Debug)]
pub struct SiteArgs {
    /// Site latitude, degrees north (−90..90).
    #[arg(long, allow_negative_numbers = true)]
    pub lat: f64,
    /// Site longitude, degrees east positive (−180..360).
    #[arg(long, allow_negative_numbers = true)]
    pub lon: f64,
    /// Site height above sea level, metres.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub height_m: f64,
}

impl SiteArgs {
    /// The site, each coordinate checked under its flag's name.
    fn checked(&self, names: &InputNames) -> Result<Site, QueryError> {
        checked_site(self.lat, self.lon, self.height_m, names)
    }
}

#[derive(Args, Debug)]
#[command(group(
    clap::ArgGroup::new("mode").required(true).args(["utc", "find"])
))]
pub struct EphemArgs {
    #[command(flatten)]
    pub site: SiteArgs,
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

/// A search criterion refused under its flag's name: the search's own
/// check names its fields, and `--min-hours -1` was "min_usable_hours = -1
/// is outside the valid range".
fn as_flag(e: SkyError) -> SkyError {
    let flag = |name| match name {
        "min_moon_elevation_deg" => "--min-moon-elevation-deg",
        "max_sun_elevation_deg" => "--max-sun-elevation-deg",
        "fraction_tolerance" => "--fraction-tolerance",
        "min_usable_hours" => "--min-hours",
        other => other,
    };
    match e {
        SkyError::OutOfRange {
            name,
            value,
            min,
            max,
        } => SkyError::OutOfRange {
            name: flag(name),
            value,
            min,
            max,
        },
        SkyError::NotFinite { name, value } => SkyError::NotFinite {
            name: flag(name),
            value,
        },
        e => e,
    }
}

/// What `gloam ephem` found: one instant, or the nights of a window.
#[derive(Serialize)]
#[serde(untagged)]
pub enum Ephem {
    At(EphemReport),
    Nights(NightsReport),
}

impl std::fmt::Display for Ephem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Ephem::At(r) => r.fmt(f),
            Ephem::Nights(r) => r.fmt(f),
        }
    }
}

impl EphemArgs {
    /// The report at `--utc`, or the `--find` search over `--from`..`--to`
    /// (clap lets exactly one of the two through).
    pub fn report(&self) -> Result<Ephem, QueryError> {
        let names = InputNames::CLI;
        let site = self.site.checked(&names)?;
        let Some(phase) = self.find else {
            let utc = self.utc.as_deref().unwrap_or_default();
            return Ok(Ephem::At(EphemReport::at(
                parse_instant(names.utc, utc)?,
                &site,
            )));
        };
        let mut search = NightSearch::new(phase.into());
        search.min_moon_elevation_deg = self.min_moon_elevation_deg;
        search.max_sun_elevation_deg = self.max_sun_elevation_deg;
        search.fraction_tolerance = self.fraction_tolerance;
        search.min_usable_hours = self.min_hours;
        search.validate().map_err(as_flag)?;
        let (from, to) = (self.from.as_deref(), self.to.as_deref());
        let (from, to) = (from.unwrap_or_default(), to.unwrap_or_default());
        Ok(Ephem::Nights(NightsReport::find(
            &site, from, to, &search, &names,
        )?))
    }
}

#[derive(Args, Debug)]
pub struct SkyArgs {
    #[command(flatten)]
    pub site: SiteArgs,
    /// The instant, ISO 8601 (`2024-12-15T07:20:00Z`; no zone = UTC).
    #[arg(long)]
    pub utc: String,
    /// Meteorological visibility, km (Koschmieder; sets the aerosol load).
    #[arg(long, default_value_t = 23.0, allow_negative_numbers = true)]
    pub visibility_km: f64,
    /// Complete overcast: no direct beam; 10 % of the clear-sky moonlight
    /// and night-sky light passes the cloud deck as a uniform dome.
    #[arg(long)]
    pub overcast: bool,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write the spectral irradiance (W m⁻² nm⁻¹, 300–1100 nm at 5 nm) to
    /// this CSV file.
    #[arg(long, value_name = "FILE.csv")]
    pub spectra_out: Option<PathBuf>,
}

impl SkyArgs {
    /// The ground illuminance (with the spectral tables if `--spectra-out`).
    pub fn report(&self) -> Result<SkyReport, QueryError> {
        let names = InputNames::CLI;
        let site = self.site.checked(&names)?;
        let t = parse_instant(names.utc, &self.utc)?;
        let cloud = if self.overcast {
            Cloud::Overcast
        } else {
            Cloud::Clear
        };
        let spectra = self.spectra_out.is_some();
        SkyReport::at(t, &site, self.visibility_km, cloud, spectra, &names)
    }
}
