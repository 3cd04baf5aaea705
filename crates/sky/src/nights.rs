//! Finding good nights for collecting imagery at a given lunar phase.
//!
//! The search steps through `[from, to]` (default every 10 minutes),
//! evaluating the ephemeris (standard refraction). A *dark period* is a run
//! of samples with the Sun at or below `max_sun_elevation_deg` (default
//! −18°, astronomical night). Within it a sample is *usable* when
//!
//! * `Full`: illuminated fraction ≥ 1 − `fraction_tolerance` (default 0.9)
//!   and Moon elevation ≥ `min_moon_elevation_deg` (default 20°);
//! * `Half`: |fraction − 0.5| ≤ `fraction_tolerance` and Moon elevation ≥
//!   `min_moon_elevation_deg`;
//! * `New` (moonless sky): the Moon's apparent elevation is below 0°, or its
//!   illuminated fraction is ≤ `new_max_fraction` (default 0.01).
//!
//! Each dark period whose longest usable run lasts at least
//! `min_usable_hours` (default 1 h) is reported as a [`Night`]. Times are
//! sample instants, so they are resolved to the step; `usable_hours` counts
//! each usable sample as one step.

use serde::Serialize;

use crate::ephemeris::{Refraction, Site, ephemeris};
use crate::error::{Result, SkyError, check_range};
use crate::time::UtcInstant;

/// Target lunar phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PhaseTarget {
    /// Near full moon, Moon well up.
    Full,
    /// Near a quarter (half illuminated), Moon well up.
    Half,
    /// Moonless: Moon down or a thin crescent.
    New,
}

impl std::str::FromStr for PhaseTarget {
    type Err = SkyError;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "full" => Ok(PhaseTarget::Full),
            "half" | "quarter" => Ok(PhaseTarget::Half),
            "new" => Ok(PhaseTarget::New),
            other => Err(SkyError::Invalid(format!(
                "phase must be full, half or new, got {other:?}"
            ))),
        }
    }
}

/// Search settings; see the module docs for the meaning of each.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NightSearch {
    /// Target phase.
    pub phase: PhaseTarget,
    /// Lowest Moon elevation for Full/Half, degrees (default 20).
    pub min_moon_elevation_deg: f64,
    /// Highest Sun elevation that counts as dark, degrees (default −18).
    pub max_sun_elevation_deg: f64,
    /// Tolerance on the illuminated fraction for Full/Half (default 0.1).
    pub fraction_tolerance: f64,
    /// Largest fraction that counts as moonless for New (default 0.01).
    pub new_max_fraction: f64,
    /// Shortest usable run worth reporting, hours (default 1).
    pub min_usable_hours: f64,
    /// Sampling step, minutes (default 10, 1..=60).
    pub step_minutes: f64,
}

impl NightSearch {
    /// Defaults for a target phase.
    pub fn new(phase: PhaseTarget) -> Self {
        Self {
            phase,
            min_moon_elevation_deg: 20.0,
            max_sun_elevation_deg: -18.0,
            fraction_tolerance: 0.1,
            new_max_fraction: 0.01,
            min_usable_hours: 1.0,
            step_minutes: 10.0,
        }
    }

    pub(crate) fn validate(&self) -> Result<()> {
        check_range(
            "min_moon_elevation_deg",
            self.min_moon_elevation_deg,
            -5.0,
            90.0,
        )?;
        check_range(
            "max_sun_elevation_deg",
            self.max_sun_elevation_deg,
            -90.0,
            0.0,
        )?;
        check_range("fraction_tolerance", self.fraction_tolerance, 0.0, 0.5)?;
        check_range("new_max_fraction", self.new_max_fraction, 0.0, 1.0)?;
        check_range("min_usable_hours", self.min_usable_hours, 0.0, 24.0)?;
        check_range("step_minutes", self.step_minutes, 1.0, 60.0)?;
        Ok(())
    }
}

/// A good collection night.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Night {
    /// Local (mean solar time) date of the evening the night begins, YYYY-MM-DD.
    pub evening_date: String,
    /// Start of astronomical darkness (or of the search window).
    pub dark_start: UtcInstant,
    /// End of astronomical darkness (or of the search window).
    pub dark_end: UtcInstant,
    /// Start of the longest usable run.
    pub usable_start: UtcInstant,
    /// End of the longest usable run.
    pub usable_end: UtcInstant,
    /// Length of the usable run, hours.
    pub usable_hours: f64,
    /// Illuminated fraction in the middle of the usable run.
    pub illuminated_fraction: f64,
    /// Phase angle in the middle of the usable run, degrees.
    pub phase_angle_deg: f64,
    /// Highest apparent Moon elevation during the usable run, degrees.
    pub max_moon_elevation_deg: f64,
}

/// Longest search span accepted, days (≈ 20 years).
pub const MAX_SEARCH_DAYS: f64 = 7305.0;

struct Sample {
    t: UtcInstant,
    dark: bool,
    usable: bool,
    moon_el: f64,
    k: f64,
    i: f64,
}

/// List good collection nights at `site` between `from` and `to`.
pub fn find_collection_nights(
    site: &Site,
    from: UtcInstant,
    to: UtcInstant,
    search: &NightSearch,
) -> Result<Vec<Night>> {
    search.validate()?;
    let site = Site::new(site.latitude_deg, site.longitude_east_deg, site.height_m)?;
    let span_s = to.seconds_since(&from);
    if span_s.is_nan() || span_s <= 0.0 {
        return Err(SkyError::Invalid(format!(
            "search window is empty: from {from} is not before to {to}"
        )));
    }
    if span_s > MAX_SEARCH_DAYS * 86_400.0 {
        return Err(SkyError::Invalid(format!(
            "search window of {:.0} days exceeds the limit of {MAX_SEARCH_DAYS} days",
            span_s / 86_400.0
        )));
    }
    let step_s = search.step_minutes * 60.0;
    let n = (span_s / step_s).floor() as usize + 1;
    let sample = |t: UtcInstant| -> Sample {
        let e = ephemeris(t, &site, Refraction::STANDARD);
        let dark = e.sun.elevation_deg <= search.max_sun_elevation_deg;
        let k = e.illuminated_fraction;
        let el = e.moon.elevation_deg;
        let moon_ok = match search.phase {
            PhaseTarget::Full => {
                k >= 1.0 - search.fraction_tolerance && el >= search.min_moon_elevation_deg
            }
            PhaseTarget::Half => {
                (k - 0.5).abs() <= search.fraction_tolerance && el >= search.min_moon_elevation_deg
            }
            PhaseTarget::New => el < 0.0 || k <= search.new_max_fraction,
        };
        Sample {
            t,
            dark,
            usable: dark && moon_ok,
            moon_el: el,
            k,
            i: e.phase_angle_deg,
        }
    };
    let mut nights = Vec::new();
    let mut period: Vec<Sample> = Vec::new();
    let mut flush = |period: &mut Vec<Sample>| {
        if let Some(night) = summarise(period, &site, step_s, search) {
            nights.push(night);
        }
        period.clear();
    };
    for j in 0..n {
        let t = from.plus_seconds(j as f64 * step_s);
        let s = sample(t);
        if s.dark {
            period.push(s);
        } else if !period.is_empty() {
            flush(&mut period);
        }
    }
    flush(&mut period);
    Ok(nights)
}

fn summarise(period: &[Sample], site: &Site, step_s: f64, search: &NightSearch) -> Option<Night> {
    let (first, last) = (period.first()?, period.last()?);
    // longest run of usable samples
    let (mut best, mut cur_start) = ((0usize, 0usize), None::<usize>);
    for (i, s) in period.iter().enumerate() {
        match (s.usable, cur_start) {
            (true, None) => cur_start = Some(i),
            (false, Some(a)) => {
                if i - a > best.1 - best.0 {
                    best = (a, i);
                }
                cur_start = None;
            }
            _ => {}
        }
    }
    if let Some(a) = cur_start
        && period.len() - a > best.1 - best.0
    {
        best = (a, period.len());
    }
    let (a, b) = best;
    if b <= a {
        return None;
    }
    let usable_hours = (b - a) as f64 * step_s / 3600.0;
    if usable_hours < search.min_usable_hours {
        return None;
    }
    let run = &period[a..b];
    let mid = &run[run.len() / 2];
    let max_el = run
        .iter()
        .map(|s| s.moon_el)
        .fold(f64::NEG_INFINITY, f64::max);
    // local mean solar date of the evening: shift by longitude, back 12 h
    // By the calendar alone: on 1000-01-01 west of Greenwich the evening
    // is 0999-12-31's (a saturated shift named the wrong date).
    let (y, m, d, ..) = first
        .t
        .calendar_shifted(site.longitude_east_deg / 15.0 * 3600.0 - 12.0 * 3600.0);
    Some(Night {
        evening_date: format!("{y:04}-{m:02}-{d:02}"),
        dark_start: first.t,
        dark_end: last.t,
        usable_start: run[0].t,
        usable_end: run[run.len() - 1].t,
        usable_hours,
        illuminated_fraction: mid.k,
        phase_angle_deg: mid.i,
        max_moon_elevation_deg: max_el,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(s: &str) -> UtcInstant {
        UtcInstant::parse_iso8601(s).unwrap()
    }

    #[test]
    fn full_moon_nights_around_2024_12_15() {
        let site = Site::new(32.2, -110.95, 750.0).unwrap();
        let nights = find_collection_nights(
            &site,
            t("2024-12-01T00:00Z"),
            t("2025-01-01T00:00Z"),
            &NightSearch::new(PhaseTarget::Full),
        )
        .unwrap();
        for n in &nights {
            println!(
                "{} usable {}..{} {:.1} h k={:.3} max el {:.1}",
                n.evening_date,
                n.usable_start,
                n.usable_end,
                n.usable_hours,
                n.illuminated_fraction,
                n.max_moon_elevation_deg
            );
        }
        assert!(!nights.is_empty());
        assert!(nights.iter().any(|n| n.evening_date == "2024-12-14"));
        for n in &nights {
            assert!(
                n.evening_date.as_str() >= "2024-12-11" && n.evening_date.as_str() <= "2024-12-19"
            );
            assert!(n.illuminated_fraction >= 0.9 && n.max_moon_elevation_deg >= 20.0);
            assert!(n.usable_hours >= 1.0);
        }
    }

    #[test]
    fn new_and_half_nights() {
        let site = Site::new(-30.2, -70.7, 2200.0).unwrap();
        let new = find_collection_nights(
            &site,
            t("2024-11-25T00:00Z"),
            t("2024-12-08T00:00Z"),
            &NightSearch::new(PhaseTarget::New),
        )
        .unwrap();
        // new moon 2024-12-01: that night must be listed, with the Moon down
        assert!(
            new.iter()
                .any(|n| n.evening_date == "2024-11-30" || n.evening_date == "2024-12-01")
        );
        let half = find_collection_nights(
            &site,
            t("2024-12-01T00:00Z"),
            t("2024-12-31T00:00Z"),
            &NightSearch::new(PhaseTarget::Half),
        )
        .unwrap();
        assert!(!half.is_empty());
        for n in &half {
            assert!((n.illuminated_fraction - 0.5).abs() <= 0.1, "{n:?}");
        }
    }

    #[test]
    fn bad_windows_are_errors() {
        let site = Site::new(0.0, 0.0, 0.0).unwrap();
        let s = NightSearch::new(PhaseTarget::Full);
        assert!(find_collection_nights(&site, t("2024-12-02"), t("2024-12-01"), &s).is_err());
        assert!(find_collection_nights(&site, t("1950-01-01"), t("2024-12-01"), &s).is_err());
        let mut bad = s;
        bad.step_minutes = 0.0;
        assert!(find_collection_nights(&site, t("2024-12-01"), t("2024-12-02"), &bad).is_err());
        assert!("gibbous".parse::<PhaseTarget>().is_err());
        // polar summer: no astronomical night at all
        let polar = Site::new(70.0, 20.0, 0.0).unwrap();
        let n = find_collection_nights(
            &polar,
            t("2024-06-01"),
            t("2024-06-30"),
            &NightSearch::new(PhaseTarget::New),
        )
        .unwrap();
        assert!(n.is_empty());
    }
}
