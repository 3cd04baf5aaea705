//! Civil, nautical and astronomical twilight times: when the Sun's centre
//! (geometric, refraction-free — the almanac convention for twilight)
//! crosses −6°, −12° and −18°.
//!
//! Why a scan and then bisection: the Sun's elevation over a day is smooth
//! but not monotonic, so the day is first sampled every 10 minutes to find
//! the brackets where it crosses the threshold, and each bracket is then
//! narrowed by bisection on the crate's ephemeris (at most 40 halvings,
//! i.e. well under a second). The day is the site's local mean-solar day
//! (midnight to midnight at the site's longitude) that holds the instant,
//! so one evening's dusk and the next morning's dawn are not split across
//! UTC dates in the Americas or Asia.

use serde::Serialize;

use crate::ephemeris::{Refraction, Site, ephemeris};
use crate::time::UtcInstant;

/// Sun elevations that end civil, nautical and astronomical twilight, degrees.
pub const TWILIGHT_LIMITS_DEG: [(&str, f64); 3] = [
    ("civil", -6.0),
    ("nautical", -12.0),
    ("astronomical", -18.0),
];

const SCAN_STEP_S: f64 = 600.0;
const MAX_BISECTIONS: usize = 40;

/// The morning and evening crossings of one threshold (None when the Sun
/// does not cross it that day: polar day or night).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TwilightCrossings {
    /// Sun elevation threshold, degrees.
    pub sun_elevation_deg: f64,
    /// Morning: the Sun rises through the threshold (start of twilight).
    pub dawn: Option<String>,
    /// Evening: the Sun sets through the threshold (end of twilight).
    pub dusk: Option<String>,
}

/// The three twilights of one local day.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TwilightTimes {
    /// The local mean-solar date, YYYY-MM-DD.
    pub local_date: String,
    /// Sun at −6°.
    pub civil: TwilightCrossings,
    /// Sun at −12°.
    pub nautical: TwilightCrossings,
    /// Sun at −18°.
    pub astronomical: TwilightCrossings,
    /// Part of the day lies outside the sky model's years, where no
    /// crossing is looked for (a missing one is then not polar day or night).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub past_model_years: bool,
}

fn sun_el(t: UtcInstant, site: &Site) -> f64 {
    ephemeris(t, site, Refraction::None)
        .sun
        .elevation_geometric_deg
}

/// Bisects `[a, b]` (elevation − threshold changes sign across it) to the
/// crossing instant.
fn bisect(site: &Site, threshold: f64, a: UtcInstant, b: UtcInstant) -> UtcInstant {
    let (mut lo, mut hi) = (a, b);
    let f_lo = sun_el(lo, site) - threshold;
    for _ in 0..MAX_BISECTIONS {
        let span = hi.seconds_since(&lo);
        if span < 0.5 {
            break;
        }
        let mid = lo.plus_seconds(0.5 * span);
        if (sun_el(mid, site) - threshold).signum() == f_lo.signum() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo.plus_seconds(0.5 * hi.seconds_since(&lo))
}

/// Twilight times for the local mean-solar day at `site` that holds `t`.
pub fn twilight_times(t: UtcInstant, site: &Site) -> TwilightTimes {
    let shift_s = site.longitude_east_deg.clamp(-180.0, 360.0) / 15.0 * 3600.0;
    let shift_s = if shift_s > 12.0 * 3600.0 {
        shift_s - 86_400.0
    } else {
        shift_s
    };
    // The local day by the calendar alone: near the ends of the model's
    // years it may reach past them (a saturated shift took the wrong day).
    let (y, m, d, hh, mm, ss) = t.calendar_shifted(shift_s);
    let since_midnight = f64::from(hh) * 3600.0 + f64::from(mm) * 60.0 + ss;
    let n = (86_400.0 / SCAN_STEP_S) as usize;
    // Only the instants within the model's years are scanned.
    let samples: Vec<(UtcInstant, f64)> = (0..=n)
        .filter_map(|i| {
            let ti = t
                .checked_plus_seconds(i as f64 * SCAN_STEP_S - since_midnight)
                .ok()?;
            Some((ti, sun_el(ti, site)))
        })
        .collect();
    let past_model_years = samples.len() <= n;
    let crossings = |threshold: f64| {
        let (mut dawn, mut dusk) = (None, None);
        for w in samples.windows(2) {
            let (a, b) = (w[0].1 - threshold, w[1].1 - threshold);
            if a < 0.0 && b >= 0.0 && dawn.is_none() {
                dawn = Some(bisect(site, threshold, w[0].0, w[1].0).to_iso8601());
            } else if a >= 0.0 && b < 0.0 && dusk.is_none() {
                dusk = Some(bisect(site, threshold, w[0].0, w[1].0).to_iso8601());
            }
        }
        TwilightCrossings {
            sun_elevation_deg: threshold,
            dawn,
            dusk,
        }
    };
    let [(_, c), (_, n), (_, a)] = TWILIGHT_LIMITS_DEG;
    TwilightTimes {
        local_date: format!("{y:04}-{m:02}-{d:02}"),
        civil: crossings(c),
        nautical: crossings(n),
        astronomical: crossings(a),
        past_model_years,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossings_are_where_the_sun_is_at_the_limit() {
        let site = Site::new(43.0844, -77.6749, 170.0).unwrap();
        let t = UtcInstant::parse_iso8601("2025-10-07T17:00:00Z").unwrap();
        let tw = twilight_times(t, &site);
        assert_eq!(tw.local_date, "2025-10-07");
        for c in [&tw.civil, &tw.nautical, &tw.astronomical] {
            for s in [&c.dawn, &c.dusk] {
                let when = UtcInstant::parse_iso8601(s.as_deref().unwrap()).unwrap();
                let el = sun_el(when, &site);
                assert!((el - c.sun_elevation_deg).abs() < 0.01, "{c:?}: {el}");
            }
        }
        // civil dusk in Rochester in early October ≈ 19:20 EDT = 23:20 UTC
        let dusk = tw.civil.dusk.unwrap();
        assert!(dusk.starts_with("2025-10-07T23:"), "{dusk}");
        // polar summer: the Sun never reaches −6°
        let polar = Site::new(78.0, 15.0, 0.0).unwrap();
        let june = UtcInstant::parse_iso8601("2025-06-21T12:00:00Z").unwrap();
        let p = twilight_times(june, &polar);
        assert!(p.civil.dawn.is_none() && p.civil.dusk.is_none());
        assert!(!tw.past_model_years && !p.past_model_years);
    }

    #[test]
    fn a_local_day_past_the_models_years_is_that_day_and_says_so() {
        // 20:00 UTC on 3000-12-31 is 07:20 on 3001-01-01 at 170° E: the
        // shift once saturated, naming 3000-12-31 with its dawn after dusk.
        let site = Site::new(43.0, 170.0, 0.0).unwrap();
        let t = UtcInstant::parse_iso8601("3000-12-31T20:00:00Z").unwrap();
        let tw = twilight_times(t, &site);
        assert_eq!(tw.local_date, "3001-01-01");
        assert!(
            tw.civil
                .dawn
                .as_deref()
                .unwrap()
                .starts_with("3000-12-31T19:")
        );
        assert!(tw.civil.dusk.is_none() && tw.past_model_years);
        let west = Site::new(43.0, -170.0, 0.0).unwrap();
        let t = UtcInstant::parse_iso8601("1000-01-01T03:00:00Z").unwrap();
        let tw = twilight_times(t, &west);
        assert_eq!(tw.local_date, "0999-12-31");
        assert!(tw.civil.dawn.is_none() && tw.past_model_years);
    }
}
