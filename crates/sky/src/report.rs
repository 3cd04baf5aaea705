//! The answers `gloam ephem` and `gloam sky` give, as serialisable reports
//! with their text form, so the CLI and Python share one set of input
//! checks and one output schema instead of restating them in each front end.
//!
//! Inputs are checked under the names the caller gives ([`InputNames`]), so
//! an error says `--lat 95 is out of range` to a shell user and
//! `lat 95 is out of range` to a Python one.

use std::fmt::{self, Write as _};

use serde::Serialize;

use crate::{
    Cloud, Ephemeris, GroundSpectra, IlluminanceLux, Night, NightSearch, PhaseTarget, Refraction,
    Site, SkyError, TwilightOptions, TwilightSky, TwilightTimes, UtcInstant, ephemeris,
    find_collection_nights, ground_illuminance, twilight_times,
};

/// What the caller calls each input, for error messages.
#[derive(Clone, Copy, Debug)]
pub struct InputNames {
    /// Site latitude.
    pub lat: &'static str,
    /// Site longitude.
    pub lon: &'static str,
    /// Site height.
    pub height_m: &'static str,
    /// The instant.
    pub utc: &'static str,
    /// Start of a search window.
    pub from: &'static str,
    /// End of a search window.
    pub to: &'static str,
    /// Meteorological visibility.
    pub visibility_km: &'static str,
}

impl InputNames {
    /// The command line's flag names.
    pub const CLI: Self = Self {
        lat: "--lat",
        lon: "--lon",
        height_m: "--height-m",
        utc: "--utc",
        from: "--from",
        to: "--to",
        visibility_km: "--visibility-km",
    };
    /// The Python keyword names.
    pub const PYTHON: Self = Self {
        lat: "lat",
        lon: "lon",
        height_m: "height_m",
        utc: "utc",
        from: "from",
        to: "to",
        visibility_km: "visibility_km",
    };
}

/// A query input that was refused, named as the caller spelled it.
#[derive(Debug, thiserror::Error)]
pub enum QueryError {
    /// A number outside the range this query accepts.
    #[error("{name} {} is out of range: {rule}", gloam_spectra::num(*value))]
    OutOfRange {
        /// The input's name (`--lat`).
        name: &'static str,
        /// The value given.
        value: f64,
        /// The accepted range, in words.
        rule: &'static str,
    },
    /// A timestamp that does not parse.
    #[error("{name} {text:?}")]
    Instant {
        /// The input's name (`--utc`).
        name: &'static str,
        /// The text given.
        text: String,
        /// Why it does not parse.
        #[source]
        source: SkyError,
    },
    /// A search window that ends before it starts.
    #[error("{from_name} {from} must be before {to_name} {to}")]
    EmptyWindow {
        /// Name of the start input.
        from_name: &'static str,
        /// The start as given.
        from: String,
        /// Name of the end input.
        to_name: &'static str,
        /// The end as given.
        to: String,
    },
    /// A refusal from the model itself.
    #[error(transparent)]
    Sky(#[from] SkyError),
}

fn in_range(
    name: &'static str,
    value: f64,
    range: std::ops::RangeInclusive<f64>,
    rule: &'static str,
) -> Result<f64, QueryError> {
    if value.is_finite() && range.contains(&value) {
        Ok(value)
    } else {
        Err(QueryError::OutOfRange { name, value, rule })
    }
}

/// The site, each coordinate checked with an error naming it.
pub fn checked_site(
    lat: f64,
    lon: f64,
    height_m: f64,
    names: &InputNames,
) -> Result<Site, QueryError> {
    let rule = "latitude must be within -90..90 degrees north";
    in_range(names.lat, lat, -90.0..=90.0, rule)?;
    let rule = "longitude must be within -180..360 degrees (east positive)";
    in_range(names.lon, lon, -180.0..=360.0, rule)?;
    let rule = "height must be within -500..10000 m";
    in_range(names.height_m, height_m, -500.0..=10_000.0, rule)?;
    Ok(Site::new(lat, lon, height_m)?)
}

/// Parses an ISO-8601 instant given as input `name`.
pub fn parse_instant(name: &'static str, text: &str) -> Result<UtcInstant, QueryError> {
    UtcInstant::parse_iso8601(text).map_err(|source| QueryError::Instant {
        name,
        text: text.to_string(),
        source,
    })
}

/// `12.3456° N, 110.9500° W, 1200 m`.
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
        // `1e-300`, not 300 zeros.
        gloam_spectra::num(s.height_m)
    )
}

/// The site as reported.
#[derive(Clone, Debug, Serialize)]
pub struct SiteReport {
    /// Degrees north.
    pub latitude_deg: f64,
    /// Degrees east.
    pub longitude_east_deg: f64,
    /// Metres above sea level.
    pub height_m: f64,
}

impl From<&Site> for SiteReport {
    fn from(s: &Site) -> Self {
        Self {
            latitude_deg: s.latitude_deg,
            longitude_east_deg: s.longitude_east_deg,
            height_m: s.height_m,
        }
    }
}

/// The Moon as reported: position and phase.
#[derive(Clone, Debug, Serialize)]
pub struct MoonReport {
    /// Apparent (refracted) elevation, degrees.
    pub elevation_deg: f64,
    /// Geometric elevation, degrees.
    pub elevation_geometric_deg: f64,
    /// Azimuth from north through east, degrees.
    pub azimuth_deg: f64,
    /// Topocentric distance, km.
    pub distance_km: f64,
    /// Sun–Moon elongation, degrees.
    pub elongation_deg: f64,
    /// Sun–Moon–observer angle, degrees.
    pub phase_angle_deg: f64,
    /// Illuminated fraction of the disc, 0..1.
    pub illuminated_fraction: f64,
    /// True while the Moon waxes.
    pub waxing: bool,
}

impl From<&Ephemeris> for MoonReport {
    fn from(e: &Ephemeris) -> Self {
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

/// The Sun as reported.
#[derive(Clone, Debug, Serialize)]
pub struct SunReport {
    /// Apparent (refracted) elevation, degrees.
    pub elevation_deg: f64,
    /// Geometric elevation, degrees.
    pub elevation_geometric_deg: f64,
    /// Azimuth from north through east, degrees.
    pub azimuth_deg: f64,
}

/// `gloam ephem --utc`: Moon and Sun at one instant and site.
#[derive(Clone, Debug, Serialize)]
pub struct EphemReport {
    /// The instant, ISO 8601.
    pub utc: String,
    /// The site.
    pub site: SiteReport,
    /// The Moon.
    pub moon: MoonReport,
    /// The Sun.
    pub sun: SunReport,
    /// TT − UT used, seconds.
    pub delta_t_s: f64,
    /// Civil, nautical and astronomical twilight (Sun at −6°, −12°, −18°)
    /// on the site's local mean-solar date holding the instant.
    pub twilight: TwilightTimes,
    #[serde(skip)]
    site_text: String,
}

impl EphemReport {
    /// Moon and Sun at `t` seen from `site`, with standard refraction.
    pub fn at(t: UtcInstant, site: &Site) -> Self {
        let e = ephemeris(t, site, Refraction::STANDARD);
        Self {
            utc: t.to_iso8601(),
            site: site.into(),
            moon: (&e).into(),
            sun: SunReport {
                elevation_deg: e.sun.elevation_deg,
                elevation_geometric_deg: e.sun.elevation_geometric_deg,
                azimuth_deg: e.sun.azimuth_deg,
            },
            delta_t_s: e.delta_t_s,
            twilight: twilight_times(t, site),
            site_text: fmt_site(site),
        }
    }
}

impl fmt::Display for EphemReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (m, s) = (&self.moon, &self.sun);
        writeln!(f, "{} at {}", self.utc, self.site_text)?;
        writeln!(
            f,
            "moon  elevation {:7.3}°  azimuth {:7.3}°  distance {:.0} km",
            m.elevation_deg, m.azimuth_deg, m.distance_km
        )?;
        writeln!(
            f,
            "      elongation {:.3}°  phase angle {:.3}°  illuminated {:.1} % ({})",
            m.elongation_deg,
            m.phase_angle_deg,
            100.0 * m.illuminated_fraction,
            if m.waxing { "waxing" } else { "waning" }
        )?;
        let night = if s.elevation_deg <= -18.0 {
            "  (astronomical night)"
        } else {
            ""
        };
        write!(
            f,
            "sun   elevation {:7.3}°  azimuth {:7.3}°{night}",
            s.elevation_deg, s.azimuth_deg
        )?;
        let tw = &self.twilight;
        write!(
            f,
            "\ntwilight on {} (local mean solar date), UTC:",
            tw.local_date
        )?;
        for (name, c) in [
            ("civil (-6°)", &tw.civil),
            ("nautical (-12°)", &tw.nautical),
            ("astronomical (-18°)", &tw.astronomical),
        ] {
            let at = |x: &Option<String>| x.clone().unwrap_or_else(|| "none".to_string());
            write!(
                f,
                "\n  {name:<20} dawn {:<24}  dusk {}",
                at(&c.dawn),
                at(&c.dusk)
            )?;
        }
        if tw.past_model_years {
            write!(
                f,
                "\n  (part of this local day lies outside the sky model's years {}–{}: crossings there are not found)",
                crate::time::MIN_YEAR,
                crate::time::MAX_YEAR
            )?;
        }
        Ok(())
    }
}

/// `gloam ephem --find`: the good collection nights in a window.
#[derive(Clone, Debug, Serialize)]
pub struct NightsReport {
    /// The site.
    pub site: SiteReport,
    /// Start of the window, ISO 8601.
    pub from: String,
    /// End of the window, ISO 8601.
    pub to: String,
    /// The criteria used (serialised field by field as the search's).
    pub criteria: NightSearch,
    /// The nights found, in order.
    pub nights: Vec<Night>,
    #[serde(skip)]
    site_text: String,
}

impl NightsReport {
    /// Searches `from`..`to` (ISO 8601 text; a `to` that is a date alone
    /// means the end of that UTC day) at `site`.
    pub fn find(
        site: &Site,
        from: &str,
        to: &str,
        search: &NightSearch,
        names: &InputNames,
    ) -> Result<Self, QueryError> {
        let from_t = parse_instant(names.from, from)?;
        let mut to_t = parse_instant(names.to, to)?;
        if to.trim().len() == 10 {
            // a date alone: include the whole UTC day
            // (past 3000-12-31 the day's end is the model's last instant)
            to_t = to_t.plus_seconds(86_400.0);
        }
        if to_t.seconds_since(&from_t) <= 0.0 {
            return Err(QueryError::EmptyWindow {
                from_name: names.from,
                from: from.to_string(),
                to_name: names.to,
                to: to.to_string(),
            });
        }
        let nights = find_collection_nights(site, from_t, to_t, search)?;
        Ok(Self {
            site: site.into(),
            from: from_t.to_iso8601(),
            to: to_t.to_iso8601(),
            criteria: *search,
            nights,
            site_text: fmt_site(site),
        })
    }

    /// The phase criterion in words: `illuminated ≥ 90 %, Moon ≥ 20°`.
    pub fn criterion_text(&self) -> String {
        let c = &self.criteria;
        match c.phase {
            PhaseTarget::Full => format!(
                "illuminated ≥ {:.0} %, Moon ≥ {}°",
                100.0 * (1.0 - c.fraction_tolerance),
                c.min_moon_elevation_deg
            ),
            PhaseTarget::Half => format!(
                "illuminated {:.0}–{:.0} %, Moon ≥ {}°",
                100.0 * (0.5 - c.fraction_tolerance),
                100.0 * (0.5 + c.fraction_tolerance),
                c.min_moon_elevation_deg
            ),
            PhaseTarget::New => format!(
                "Moon down or ≤ {:.0} % illuminated",
                100.0 * c.new_max_fraction
            ),
        }
    }
}

fn phase_name(p: PhaseTarget) -> &'static str {
    match p {
        PhaseTarget::Full => "full",
        PhaseTarget::Half => "half",
        PhaseTarget::New => "new",
    }
}

impl fmt::Display for NightsReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = &self.criteria;
        writeln!(
            f,
            "{}-moon collection nights at {}, {} .. {}",
            phase_name(c.phase),
            self.site_text,
            self.from,
            self.to
        )?;
        write!(
            f,
            "criteria: {}; Sun ≤ {}°; usable run ≥ {} h (sampled every {} min)",
            self.criterion_text(),
            c.max_sun_elevation_deg,
            c.min_usable_hours,
            c.step_minutes
        )?;
        if self.nights.is_empty() {
            return write!(f, "\nno nights found");
        }
        write!(
            f,
            "\n{:<10}  {:<24}  {:<24}  {:>5}  {:>6}  {:>7}  {:>8}",
            "evening", "usable from (UTC)", "usable to (UTC)", "hours", "illum", "phase", "max el"
        )?;
        for n in &self.nights {
            write!(
                f,
                "\n{:<10}  {:<24}  {:<24}  {:>5.1}  {:>5.1}%  {:>6.1}°  {:>7.1}°",
                n.evening_date,
                n.usable_start.to_iso8601(),
                n.usable_end.to_iso8601(),
                n.usable_hours,
                100.0 * n.illuminated_fraction,
                n.phase_angle_deg,
                n.max_moon_elevation_deg
            )?;
        }
        Ok(())
    }
}

/// The conditions a sky report assumed.
#[derive(Clone, Debug, Serialize)]
pub struct ConditionsReport {
    /// Meteorological visibility, km.
    pub visibility_km: f64,
    /// Cloud cover.
    pub cloud: Cloud,
    /// Site height, m.
    pub height_m: f64,
}

/// Horizontal illuminance from the Sun (direct and sky-scattered, from
/// [`TwilightSky`]) and the grand total with the Moon and night sky.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct TwilightLux {
    /// Direct sunlight (clear sky, Sun's centre above the horizon).
    pub sun_direct: f64,
    /// Sunlight scattered by the sky (or passed by an overcast deck).
    pub sun_sky: f64,
    /// `illuminance_lux.total` + the two sunlight terms.
    pub total_with_moon_and_night_sky: f64,
}

impl TwilightLux {
    /// Sunlight for the Sun at `t` over `site`; an overcast deck passes
    /// `overcast_transmittance` of the clear-sky direct + diffuse light as
    /// diffuse light, as it does for moonlight.
    pub fn at(
        t: UtcInstant,
        site: &Site,
        visibility_km: f64,
        cloud: Cloud,
        moon_and_night_lux: f64,
    ) -> Result<Self, SkyError> {
        let e = ephemeris(t, site, Refraction::None);
        let (mut direct, mut sky) = (0.0, 0.0);
        if e.sun.elevation_geometric_deg >= crate::twilight::TWILIGHT_MIN_SUN_ELEVATION_DEG {
            let tw = TwilightSky::at(t, site, visibility_km, TwilightOptions::default())?;
            (direct, sky) = tw.horizontal_illuminance_lux()?;
        }
        if cloud == Cloud::Overcast {
            sky = crate::nightsky::OVERCAST_FACTOR * (direct + sky);
            direct = 0.0;
        }
        Ok(Self {
            sun_direct: direct,
            sun_sky: sky,
            total_with_moon_and_night_sky: moon_and_night_lux + direct + sky,
        })
    }
}

/// `gloam sky`: ground illuminance at one instant and site.
#[derive(Clone, Debug, Serialize)]
pub struct SkyReport {
    /// The instant, ISO 8601.
    pub utc: String,
    /// Illuminance components, lux.
    pub illuminance_lux: IlluminanceLux,
    /// The Moon.
    pub moon: MoonReport,
    /// Apparent Sun elevation, degrees.
    pub sun_elevation_deg: f64,
    /// Kept for compatibility: false, since the twilight model covers every
    /// Sun elevation ≥ −18° (below it there is no twilight to model).
    pub twilight_not_modelled: bool,
    /// Sunlight on the ground from the twilight model, lux (zero with the
    /// Sun below −18°).
    pub twilight_lux: TwilightLux,
    /// The conditions assumed.
    pub conditions: ConditionsReport,
    /// Where the spectral table was written, if it was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spectra_out: Option<String>,
    /// The spectral irradiance tables, when asked for.
    #[serde(skip)]
    pub spectra: Option<GroundSpectra>,
    #[serde(skip)]
    site_text: String,
}

impl SkyReport {
    /// Ground illuminance at `t` and `site` for a visibility (checked here
    /// under `names.visibility_km`) and cloud cover; with `with_spectra`
    /// the spectral tables too.
    pub fn at(
        t: UtcInstant,
        site: &Site,
        visibility_km: f64,
        cloud: Cloud,
        with_spectra: bool,
        names: &InputNames,
    ) -> Result<Self, QueryError> {
        let rule = "visibility must be within 0.05..1000 km";
        in_range(names.visibility_km, visibility_km, 0.05..=1000.0, rule)?;
        let g = ground_illuminance(t, site, visibility_km, cloud, with_spectra)?;
        let twilight_lux = TwilightLux::at(t, site, visibility_km, cloud, g.illuminance_lux.total)?;
        let e = &g.ephemeris;
        Ok(Self {
            utc: t.to_iso8601(),
            illuminance_lux: g.illuminance_lux,
            moon: e.into(),
            sun_elevation_deg: e.sun.elevation_deg,
            twilight_not_modelled: false,
            twilight_lux,
            conditions: ConditionsReport {
                visibility_km,
                cloud,
                height_m: site.height_m,
            },
            spectra_out: None,
            spectra: g.spectra,
            site_text: fmt_site(site),
        })
    }

    fn cloud_word(&self) -> &'static str {
        match self.conditions.cloud {
            Cloud::Overcast => "overcast",
            Cloud::Clear => "clear",
        }
    }

    /// The `--spectra-out` CSV: a header comment, a header row and one row
    /// per wavelength, or `None` if the spectra were not computed. Each
    /// column after the first loads as a spectrum with
    /// `gloam_spectra::read_csv` once the others are dropped.
    pub fn spectra_csv(&self) -> Option<String> {
        let s = self.spectra.as_ref()?;
        let m = &self.moon;
        let header = format!(
            "gloam sky: horizontal spectral irradiance on the ground, W m-2 nm-1\n\
             {} at {}; visibility {} km; {}\n\
             Moon elevation {:.3} deg, azimuth {:.3} deg, illuminated {:.4}, phase angle {:.3} deg",
            self.utc,
            self.site_text,
            self.conditions.visibility_km,
            self.cloud_word(),
            m.elevation_deg,
            m.azimuth_deg,
            m.illuminated_fraction,
            m.phase_angle_deg
        );
        Some(spectra_csv(s, &header))
    }
}

/// `0`, or four significant figures in scientific notation.
fn fmt_lux(x: f64) -> String {
    if x == 0.0 {
        "0".to_string()
    } else {
        format!("{x:.3e}")
    }
}

impl fmt::Display for SkyReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (m, l) = (&self.moon, &self.illuminance_lux);
        writeln!(
            f,
            "{} at {}; visibility {} km, {}",
            self.utc,
            self.site_text,
            self.conditions.visibility_km,
            self.cloud_word()
        )?;
        writeln!(
            f,
            "moon elevation {:.2}°, azimuth {:.2}°, {:.1} % illuminated; sun {:.2}°",
            m.elevation_deg,
            m.azimuth_deg,
            100.0 * m.illuminated_fraction,
            self.sun_elevation_deg
        )?;
        writeln!(f, "ground illuminance (horizontal):")?;
        writeln!(f, "  moon direct  {} lux", fmt_lux(l.moon_direct))?;
        writeln!(f, "  moon sky     {} lux", fmt_lux(l.moon_sky))?;
        writeln!(f, "  night sky    {} lux", fmt_lux(l.night_sky))?;
        writeln!(f, "  total        {} lux", fmt_lux(l.total))?;
        let t = &self.twilight_lux;
        if t.sun_direct + t.sun_sky > 0.0 {
            writeln!(f, "  sun direct   {} lux", fmt_lux(t.sun_direct))?;
            writeln!(
                f,
                "  sun sky      {} lux (twilight model)",
                fmt_lux(t.sun_sky)
            )?;
            write!(
                f,
                "  with the sun {} lux",
                fmt_lux(t.total_with_moon_and_night_sky)
            )?;
        } else {
            write!(f, "  sun          0 lux (below -18°: no twilight)")?;
        }
        if let Some(p) = &self.spectra_out {
            write!(f, "\nspectral irradiance written to {p}")?;
        }
        Ok(())
    }
}

/// The spectral table as CSV under a `# `-commented `header`.
pub fn spectra_csv(s: &GroundSpectra, header: &str) -> String {
    let mut out = String::new();
    for line in header.lines() {
        let _ = writeln!(out, "# {line}");
    }
    out.push_str(
        "wavelength_nm,moon_exo_normal_w_m2_nm,moon_direct_horizontal_w_m2_nm,\
         moon_sky_horizontal_w_m2_nm,night_sky_horizontal_w_m2_nm,total_horizontal_w_m2_nm\n",
    );
    let cols = [
        &s.moon_exo_normal_w_m2_nm,
        &s.moon_direct_horizontal_w_m2_nm,
        &s.moon_sky_horizontal_w_m2_nm,
        &s.night_sky_horizontal_w_m2_nm,
        &s.total_horizontal_w_m2_nm,
    ];
    for (i, &(w, _)) in s.total_horizontal_w_m2_nm.iter().enumerate() {
        let _ = write!(out, "{w}");
        for c in cols {
            let v = c.get(i).map_or(0.0, |p| p.1);
            let _ = write!(out, ",{v:.6e}");
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn site_out_of_range_names_the_input() {
        let e = checked_site(95.0, 0.0, 0.0, &InputNames::CLI).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--lat 95 is out of range: latitude must be within -90..90 degrees north"
        );
        let e = checked_site(0.0, 0.0, f64::NAN, &InputNames::PYTHON).unwrap_err();
        assert!(e.to_string().starts_with("height_m NaN is out of range"));
    }

    #[test]
    fn west_longitudes_print_as_west() {
        let s = Site::new(-33.5, 250.0, 12.0).unwrap();
        assert_eq!(fmt_site(&s), "33.5000° S, 110.0000° W, 12 m");
    }

    #[test]
    fn a_date_alone_ends_the_window_at_midnight_after() {
        let site = Site::new(43.0, 0.0, 0.0).unwrap();
        let search = NightSearch::new(PhaseTarget::New);
        let r = NightsReport::find(&site, "2025-01-01", "2025-01-01", &search, &InputNames::CLI)
            .unwrap();
        assert_eq!(r.to, "2025-01-02T00:00:00.000Z");
        let e = NightsReport::find(
            &site,
            "2025-01-03",
            "2025-01-01T00:00:00Z",
            &search,
            &InputNames::CLI,
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "--from 2025-01-03 must be before --to 2025-01-01T00:00:00Z"
        );
    }

    #[test]
    fn visibility_is_checked_before_the_model_runs() {
        let site = Site::new(43.0, 0.0, 0.0).unwrap();
        let t = parse_instant("utc", "2025-10-07T05:00:00Z").unwrap();
        let e = SkyReport::at(t, &site, 0.0, Cloud::Clear, false, &InputNames::PYTHON).unwrap_err();
        assert!(e.to_string().starts_with("visibility_km 0 is out of range"));
    }
}
