//! `gloam ephem`: Moon and Sun positions and the lunar phase for one instant
//! and site, or (`--from/--to/--find`) the good collection nights in a date
//! range. Everything is computed by `gloam_sky`; this module only parses,
//! validates and prints.

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use gloam_sky::{
    Ephemeris, Night, NightSearch, PhaseTarget, Refraction, Site, UtcInstant, ephemeris,
    find_collection_nights,
};
use serde::Serialize;

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

/// Validated site from CLI flags, with errors naming the flag.
pub fn site_from_flags(lat: f64, lon: f64, height_m: f64) -> anyhow::Result<Site> {
    if !(lat.is_finite() && (-90.0..=90.0).contains(&lat)) {
        bail!("--lat {lat} is out of range: latitude must be within -90..90 degrees north");
    }
    if !(lon.is_finite() && (-180.0..=360.0).contains(&lon)) {
        bail!(
            "--lon {lon} is out of range: longitude must be within -180..360 degrees (east positive)"
        );
    }
    if !(height_m.is_finite() && (-500.0..=10_000.0).contains(&height_m)) {
        bail!("--height-m {height_m} is out of range: height must be within -500..10000 m");
    }
    Ok(Site::new(lat, lon, height_m)?)
}

/// Parses an ISO-8601 instant for flag `flag`.
pub fn parse_instant(flag: &str, text: &str) -> anyhow::Result<UtcInstant> {
    UtcInstant::parse_iso8601(text).with_context(|| format!("{flag} {text:?}"))
}

/// `moon` block of the JSON output.
#[derive(Serialize)]
pub struct MoonJson {
    pub elevation_deg: f64,
    pub elevation_geometric_deg: f64,
    pub azimuth_deg: f64,
    pub distance_km: f64,
    pub elongation_deg: f64,
    pub phase_angle_deg: f64,
    pub illuminated_fraction: f64,
    pub waxing: bool,
}

/// `sun` block of the JSON output.
#[derive(Serialize)]
pub struct SunJson {
    pub elevation_deg: f64,
    pub elevation_geometric_deg: f64,
    pub azimuth_deg: f64,
}

#[derive(Serialize)]
struct SiteJson {
    latitude_deg: f64,
    longitude_east_deg: f64,
    height_m: f64,
}

impl From<&Site> for SiteJson {
    fn from(s: &Site) -> Self {
        Self {
            latitude_deg: s.latitude_deg,
            longitude_east_deg: s.longitude_east_deg,
            height_m: s.height_m,
        }
    }
}

#[derive(Serialize)]
struct EphemJson {
    utc: String,
    site: SiteJson,
    moon: MoonJson,
    sun: SunJson,
    delta_t_s: f64,
}

impl MoonJson {
    pub fn from_ephemeris(e: &Ephemeris) -> Self {
        Self {
            elevation_deg: e.moon.elevation_deg,
            elevation_geometric_deg: e.moon.elevation_geometric_deg,
            azimuth_deg: e.moon.azimuth_deg,
            distance_km: e.moon.distance_km,
            elongation_deg: e.elongation_deg,
            phase_angle_deg: e.phase_angle_deg,
            illuminated_fraction: e.illuminated_fraction,
            waxing: e.waxing,
        }
    }
}

#[derive(Serialize)]
struct CriteriaJson {
    phase: &'static str,
    min_moon_elevation_deg: f64,
    max_sun_elevation_deg: f64,
    fraction_tolerance: f64,
    new_max_fraction: f64,
    min_usable_hours: f64,
    step_minutes: f64,
}

#[derive(Serialize)]
struct FindJson<'a> {
    site: SiteJson,
    from: String,
    to: String,
    criteria: CriteriaJson,
    nights: &'a [Night],
}

/// `12.3456° N, 110.9500° W`.
pub fn fmt_site(s: &Site) -> String {
    let ns = if s.latitude_deg >= 0.0 { 'N' } else { 'S' };
    let lon = if s.longitude_east_deg > 180.0 {
        s.longitude_east_deg - 360.0
    } else {
        s.longitude_east_deg
    };
    let ew = if lon >= 0.0 { 'E' } else { 'W' };
    format!(
        "{:.4}° {ns}, {:.4}° {ew}, {} m",
        s.latitude_deg.abs(),
        lon.abs(),
        s.height_m
    )
}

pub fn run(args: EphemArgs) -> anyhow::Result<()> {
    let site = site_from_flags(args.lat, args.lon, args.height_m)?;
    match (&args.utc, args.find) {
        (Some(utc), None) => one_instant(&site, utc, args.json),
        (None, Some(phase)) => {
            let from = args.from.as_deref().context("--find needs --from")?;
            let to = args.to.as_deref().context("--find needs --to")?;
            find(&site, from, to, phase, &args)
        }
        _ => bail!("give either --utc, or --from, --to and --find"),
    }
}

fn one_instant(site: &Site, utc: &str, json: bool) -> anyhow::Result<()> {
    let t = parse_instant("--utc", utc)?;
    let e = ephemeris(t, site, Refraction::STANDARD);
    if json {
        return print_json(&EphemJson {
            utc: t.to_iso8601(),
            site: site.into(),
            moon: MoonJson::from_ephemeris(&e),
            sun: SunJson {
                elevation_deg: e.sun.elevation_deg,
                elevation_geometric_deg: e.sun.elevation_geometric_deg,
                azimuth_deg: e.sun.azimuth_deg,
            },
            delta_t_s: e.delta_t_s,
        });
    }
    outln!("{} at {}", t.to_iso8601(), fmt_site(site));
    outln!(
        "moon  elevation {:7.3}°  azimuth {:7.3}°  distance {:.0} km",
        e.moon.elevation_deg,
        e.moon.azimuth_deg,
        e.moon.distance_km
    );
    outln!(
        "      elongation {:.3}°  phase angle {:.3}°  illuminated {:.1} % ({})",
        e.elongation_deg,
        e.phase_angle_deg,
        100.0 * e.illuminated_fraction,
        if e.waxing { "waxing" } else { "waning" }
    );
    outln!(
        "sun   elevation {:7.3}°  azimuth {:7.3}°{}",
        e.sun.elevation_deg,
        e.sun.azimuth_deg,
        if e.sun.elevation_deg <= -18.0 {
            "  (astronomical night)"
        } else {
            ""
        }
    );
    Ok(())
}

fn find(
    site: &Site,
    from: &str,
    to: &str,
    phase: FindPhase,
    args: &EphemArgs,
) -> anyhow::Result<()> {
    let from_t = parse_instant("--from", from)?;
    let mut to_t = parse_instant("--to", to)?;
    if to.trim().len() == 10 {
        // a date alone: include the whole UTC day
        to_t = to_t.plus_seconds(86_400.0);
    }
    if to_t.seconds_since(&from_t) <= 0.0 {
        bail!("--from {from} must be before --to {to}");
    }
    let mut search = NightSearch::new(phase.into());
    search.min_moon_elevation_deg = args.min_moon_elevation_deg;
    search.max_sun_elevation_deg = args.max_sun_elevation_deg;
    search.fraction_tolerance = args.fraction_tolerance;
    search.min_usable_hours = args.min_hours;
    let nights = find_collection_nights(site, from_t, to_t, &search)?;
    let phase_name = match phase {
        FindPhase::Full => "full",
        FindPhase::Half => "half",
        FindPhase::New => "new",
    };
    if args.json {
        return print_json(&FindJson {
            site: site.into(),
            from: from_t.to_iso8601(),
            to: to_t.to_iso8601(),
            criteria: CriteriaJson {
                phase: phase_name,
                min_moon_elevation_deg: search.min_moon_elevation_deg,
                max_sun_elevation_deg: search.max_sun_elevation_deg,
                fraction_tolerance: search.fraction_tolerance,
                new_max_fraction: search.new_max_fraction,
                min_usable_hours: search.min_usable_hours,
                step_minutes: search.step_minutes,
            },
            nights: &nights,
        });
    }
    let criterion = match phase {
        FindPhase::Full => format!(
            "illuminated ≥ {:.0} %, Moon ≥ {}°",
            100.0 * (1.0 - search.fraction_tolerance),
            search.min_moon_elevation_deg
        ),
        FindPhase::Half => format!(
            "illuminated {:.0}–{:.0} %, Moon ≥ {}°",
            100.0 * (0.5 - search.fraction_tolerance),
            100.0 * (0.5 + search.fraction_tolerance),
            search.min_moon_elevation_deg
        ),
        FindPhase::New => format!(
            "Moon down or ≤ {:.0} % illuminated",
            100.0 * search.new_max_fraction
        ),
    };
    outln!(
        "{phase_name}-moon collection nights at {}, {} .. {}",
        fmt_site(site),
        from_t.to_iso8601(),
        to_t.to_iso8601()
    );
    outln!(
        "criteria: {criterion}; Sun ≤ {}°; usable run ≥ {} h (sampled every {} min)",
        search.max_sun_elevation_deg,
        search.min_usable_hours,
        search.step_minutes
    );
    if nights.is_empty() {
        outln!("no nights found");
        return Ok(());
    }
    outln!(
        "{:<10}  {:<24}  {:<24}  {:>5}  {:>6}  {:>7}  {:>8}",
        "evening",
        "usable from (UTC)",
        "usable to (UTC)",
        "hours",
        "illum",
        "phase",
        "max el"
    );
    for n in &nights {
        outln!(
            "{:<10}  {:<24}  {:<24}  {:>5.1}  {:>5.1}%  {:>6.1}°  {:>7.1}°",
            n.evening_date,
            n.usable_start.to_iso8601(),
            n.usable_end.to_iso8601(),
            n.usable_hours,
            100.0 * n.illuminated_fraction,
            n.phase_angle_deg,
            n.max_moon_elevation_deg
        );
    }
    Ok(())
}
