//! Untrusted input never panics and results stay finite.

use gloam_sky::{Cloud, Refraction, Site, SkyConditions, SkyModel, UtcInstant, ephemeris};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn iso_parser_never_panics(s in "\\PC{0,40}") {
        let _ = UtcInstant::parse_iso8601(&s);
    }

    #[test]
    fn iso_like_strings_never_panic(s in "[0-9]{4}-[0-9]{2}-[0-9]{2}([T ][0-9:.,]{0,14}(Z|[+-][0-9:]{0,5})?)?") {
        if let Ok(t) = UtcInstant::parse_iso8601(&s) {
            prop_assert!(t.julian_date_ut().is_finite());
        }
    }

    #[test]
    fn ephemeris_is_finite_and_in_range(
        jd in 2_415_020.5f64..2_488_434.5,
        lat in -90.0f64..=90.0,
        lon in -180.0f64..=360.0,
        h in -500.0f64..=10_000.0,
    ) {
        let t = UtcInstant::from_julian_date(jd).unwrap();
        let site = Site::new(lat, lon, h).unwrap();
        let e = ephemeris(t, &site, Refraction::STANDARD);
        for p in [e.moon, e.sun] {
            prop_assert!(p.elevation_deg.is_finite() && p.elevation_deg.abs() <= 91.0);
            prop_assert!((0.0..360.0).contains(&p.azimuth_deg));
        }
        prop_assert!((0.0..=1.0).contains(&e.illuminated_fraction));
        prop_assert!(e.moon.distance_km > 340_000.0 && e.moon.distance_km < 420_000.0);
    }

    #[test]
    fn sky_model_is_finite(
        jd in 2_451_545.0f64..2_470_000.0,
        lat in -80.0f64..=80.0,
        vis in 0.05f64..=1000.0,
        overcast in any::<bool>(),
        dx in -1.0f64..1.0, dy in -1.0f64..1.0, dz in -1.0f64..1.0,
        w in 250.0f64..1200.0,
    ) {
        let t = UtcInstant::from_julian_date(jd).unwrap();
        let site = Site::new(lat, 10.0, 100.0).unwrap();
        let cloud = if overcast { Cloud::Overcast } else { Cloud::Clear };
        let c = SkyConditions::new(vis, cloud).unwrap();
        let m = SkyModel::new(t, &site, &c).unwrap();
        let l = m.sky_radiance_w_m2_sr_nm([dx, dy, dz], w);
        prop_assert!(l.is_finite() && l >= 0.0);
        let g = m.illuminance(false).unwrap();
        prop_assert!(g.illuminance_lux.total.is_finite() && g.illuminance_lux.total > 0.0);
        prop_assert!(g.illuminance_lux.total < 0.6);
    }
}
