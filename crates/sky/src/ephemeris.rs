//! Sun and Moon ephemeris after J. Meeus, *Astronomical Algorithms*, 2nd ed.
//! (Willmann-Bell 1998):
//!
//! * Moon: chapter 47, the full tables 47.A (60 longitude/distance terms)
//!   and 47.B (60 latitude terms) plus the additive Venus/Jupiter/flattening
//!   terms; stated accuracy ≈ 10″ in longitude, 4″ in latitude.
//! * Sun: chapter 25 ("higher accuracy" is not used; the low-precision
//!   series, ≈ 0.01°), with aberration −20.4898″/R and nutation in longitude.
//! * Nutation and obliquity: chapter 22, the four main terms (≈ 0.5″) and
//!   the IAU 1980 mean obliquity (eq. 22.2).
//! * Sidereal time: chapter 12 (eq. 12.4) plus the equation of the equinoxes.
//! * Topocentric parallax: exact vector subtraction of the observer's
//!   geocentric position (chapter 11 `ρ sin φ'`, `ρ cos φ'`, IAU 1976
//!   ellipsoid a = 6378.14 km, b/a = 0.99664719); it moves the Moon by up
//!   to ≈ 1°.
//! * Refraction: Sæmundsson (1986), *Sky & Telescope* 72, 70, the
//!   true → apparent form of Bennett's formula (Meeus eq. 16.4), scaled by
//!   `(P/1010 hPa)·(283 K/T)`; see [`refraction_saemundsson_deg`].
//! * Phase: geocentric elongation (eq. 48.2 generalised to latitude), phase
//!   angle (eq. 48.3) and illuminated fraction `k = (1 + cos i)/2` (eq. 48.1).
//!
//! Checked against PyEphem 4.2.1 over 1900–2100 in
//! `tests/ephem_reference.rs`; see the crate README for measured errors.

// Constants are transcribed from Meeus digit for digit; some keep his
// grouping, which clippy finds inconsistent.
#![allow(clippy::inconsistent_digit_grouping)]

use serde::Serialize;

use crate::error::{Result, SkyError, check_range};
use crate::time::UtcInstant;

/// Astronomical unit in km (IAU 2012).
pub const AU_KM: f64 = 149_597_870.7;
/// Earth equatorial radius used for parallax (IAU 1976), km.
pub const EARTH_EQUATORIAL_RADIUS_KM: f64 = 6378.14;
/// Polar/equatorial axis ratio b/a (IAU 1976), Meeus ch. 11.
const EARTH_AXIS_RATIO: f64 = 0.996_647_19;

const DEG: f64 = std::f64::consts::PI / 180.0;

/// An observing site on the Earth (geodetic coordinates).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Site {
    /// Geodetic latitude, degrees north (−90..=90).
    pub latitude_deg: f64,
    /// Longitude, degrees east positive (−180..=360 accepted).
    pub longitude_east_deg: f64,
    /// Height above the ellipsoid (≈ sea level), metres (−500..=10000).
    pub height_m: f64,
}

impl Site {
    /// Validated site. Errors name the bad field.
    pub fn new(latitude_deg: f64, longitude_east_deg: f64, height_m: f64) -> Result<Self> {
        check_range("latitude_deg", latitude_deg, -90.0, 90.0)?;
        check_range("longitude_east_deg", longitude_east_deg, -180.0, 360.0)?;
        check_range("height_m", height_m, -500.0, 10_000.0)?;
        Ok(Self {
            latitude_deg,
            longitude_east_deg,
            height_m,
        })
    }

    /// Observer's geocentric position in the Earth-fixed frame (x to
    /// Greenwich meridian, z to the north pole), km.
    fn geocentric_km(&self) -> [f64; 3] {
        let phi = self.latitude_deg * DEG;
        let u = (EARTH_AXIS_RATIO * phi.tan()).atan();
        let h = self.height_m / 1000.0 / EARTH_EQUATORIAL_RADIUS_KM;
        let rho_sin = EARTH_AXIS_RATIO * u.sin() + h * phi.sin();
        let rho_cos = u.cos() + h * phi.cos();
        let lam = self.longitude_east_deg * DEG;
        [
            EARTH_EQUATORIAL_RADIUS_KM * rho_cos * lam.cos(),
            EARTH_EQUATORIAL_RADIUS_KM * rho_cos * lam.sin(),
            EARTH_EQUATORIAL_RADIUS_KM * rho_sin,
        ]
    }
}

/// How to correct elevations for atmospheric refraction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Refraction {
    /// Geometric (airless) topocentric elevation.
    None,
    /// Sæmundsson's formula for the given surface pressure and temperature.
    Atmosphere {
        /// Surface pressure, hPa (mbar).
        pressure_hpa: f64,
        /// Surface air temperature, °C.
        temperature_c: f64,
    },
}

impl Refraction {
    /// The standard atmosphere of Sæmundsson/Bennett: 1010 hPa, 10 °C.
    pub const STANDARD: Refraction = Refraction::Atmosphere {
        pressure_hpa: 1010.0,
        temperature_c: 10.0,
    };

    /// Validated refraction conditions (pressure 0..=1100 hPa, −90..=60 °C).
    pub fn atmosphere(pressure_hpa: f64, temperature_c: f64) -> Result<Self> {
        check_range("pressure_hpa", pressure_hpa, 0.0, 1100.0)?;
        check_range("temperature_c", temperature_c, -90.0, 60.0)?;
        Ok(Refraction::Atmosphere {
            pressure_hpa,
            temperature_c,
        })
    }

    /// Refraction (apparent − true elevation) in degrees at a true
    /// elevation `true_elevation_deg`.
    pub fn correction_deg(&self, true_elevation_deg: f64) -> f64 {
        match *self {
            Refraction::None => 0.0,
            Refraction::Atmosphere {
                pressure_hpa,
                temperature_c,
            } => refraction_saemundsson_deg(true_elevation_deg, pressure_hpa, temperature_c),
        }
    }
}

/// Atmospheric refraction R = apparent − true elevation, degrees, from
/// Sæmundsson's formula (Meeus eq. 16.4):
/// `R = 1.02′ / tan(h + 10.3°/(h + 5.11°)) · (P/1010)·(283/(273 + T))`,
/// with h the true (airless) elevation in degrees. This is the inverse of
/// Bennett's apparent → true formula and agrees with it to ≈ 4″.
///
/// Below the horizon the formula is only meaningful to about −1°; from −1°
/// to −2° R is tapered linearly to 0 and it is 0 lower down (the object is
/// then below the horizon whatever the refraction). Above 89.9° R → 0.
pub fn refraction_saemundsson_deg(
    true_elevation_deg: f64,
    pressure_hpa: f64,
    temperature_c: f64,
) -> f64 {
    let scale = (pressure_hpa / 1010.0) * (283.0 / (273.0 + temperature_c));
    if !scale.is_finite() || scale <= 0.0 || !true_elevation_deg.is_finite() {
        return 0.0;
    }
    let r = |h: f64| -> f64 {
        let arg = (h + 10.3 / (h + 5.11)) * DEG;
        (1.02 / 60.0 / arg.tan()).max(0.0)
    };
    let h = true_elevation_deg;
    let value = if h >= 89.9 {
        0.0
    } else if h >= -1.0 {
        r(h)
    } else if h > -2.0 {
        r(-1.0) * (h + 2.0)
    } else {
        0.0
    };
    value * scale
}

/// Bennett's formula (Meeus eq. 16.3): refraction in degrees from the
/// apparent elevation (standard 1010 hPa, 10 °C). Provided for users who
/// start from an observed elevation.
pub fn refraction_bennett_deg(apparent_elevation_deg: f64) -> f64 {
    let h = apparent_elevation_deg.clamp(-1.0, 90.0);
    let arg = (h + 7.31 / (h + 4.4)) * DEG;
    (1.0 / 60.0 / arg.tan()).max(0.0)
}

/// Geocentric apparent ecliptic coordinates (equinox and ecliptic of date).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct EclipticPosition {
    /// Apparent ecliptic longitude, degrees in [0, 360).
    pub longitude_deg: f64,
    /// Ecliptic latitude, degrees.
    pub latitude_deg: f64,
    /// Geocentric distance, km.
    pub distance_km: f64,
}

/// Nutation in longitude Δψ and obliquity Δε plus the true obliquity ε,
/// all degrees (Meeus ch. 22, main terms; mean obliquity eq. 22.2).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Nutation {
    /// Δψ, degrees.
    pub longitude_deg: f64,
    /// Δε, degrees.
    pub obliquity_deg: f64,
    /// True obliquity ε = ε₀ + Δε, degrees.
    pub true_obliquity_deg: f64,
}

fn centuries_tt(jd_tt: f64) -> f64 {
    (jd_tt - 2_451_545.0) / 36_525.0
}

fn norm360(x: f64) -> f64 {
    x.rem_euclid(360.0)
}

/// Nutation (Meeus ch. 22, main terms, accuracy ≈ 0.5″ in Δψ, 0.1″ in Δε).
pub fn nutation(jd_tt: f64) -> Nutation {
    let t = centuries_tt(jd_tt);
    let omega = (125.044_52 - 1934.136_261 * t + 0.002_070_8 * t * t + t.powi(3) / 450_000.0) * DEG;
    let l_sun = (280.4665 + 36_000.7698 * t) * DEG;
    let l_moon = (218.3165 + 481_267.8813 * t) * DEG;
    let dpsi_arcsec =
        -17.20 * omega.sin() - 1.32 * (2.0 * l_sun).sin() - 0.23 * (2.0 * l_moon).sin()
            + 0.21 * (2.0 * omega).sin();
    let deps_arcsec = 9.20 * omega.cos() + 0.57 * (2.0 * l_sun).cos() + 0.10 * (2.0 * l_moon).cos()
        - 0.09 * (2.0 * omega).cos();
    let eps0_arcsec = 84_381.448 - 46.8150 * t - 0.000_59 * t * t + 0.001_813 * t.powi(3);
    Nutation {
        longitude_deg: dpsi_arcsec / 3600.0,
        obliquity_deg: deps_arcsec / 3600.0,
        true_obliquity_deg: (eps0_arcsec + deps_arcsec) / 3600.0,
    }
}

/// Greenwich apparent sidereal time, degrees in [0, 360) (Meeus eq. 12.4
/// with the equation of the equinoxes Δψ cos ε).
pub fn greenwich_apparent_sidereal_time_deg(instant: &UtcInstant) -> f64 {
    let jd = instant.julian_date_ut();
    let t = (jd - 2_451_545.0) / 36_525.0;
    let mean = 280.460_618_37 + 360.985_647_366_29 * (jd - 2_451_545.0) + 0.000_387_933 * t * t
        - t.powi(3) / 38_710_000.0;
    let n = nutation(instant.julian_date_tt());
    norm360(mean + n.longitude_deg * (n.true_obliquity_deg * DEG).cos())
}

/// Table 47.A: multiples of D, M, M', F; Σl coefficient (1e-6 °);
/// Σr coefficient (1e-3 km).
#[rustfmt::skip]
const MOON_LR: [(i8, i8, i8, i8, f64, f64); 60] = [
    (0, 0, 1, 0, 6288774.0, -20905355.0), (2, 0, -1, 0, 1274027.0, -3699111.0),
    (2, 0, 0, 0, 658314.0, -2955968.0), (0, 0, 2, 0, 213618.0, -569925.0),
    (0, 1, 0, 0, -185116.0, 48888.0), (0, 0, 0, 2, -114332.0, -3149.0),
    (2, 0, -2, 0, 58793.0, 246158.0), (2, -1, -1, 0, 57066.0, -152138.0),
    (2, 0, 1, 0, 53322.0, -170733.0), (2, -1, 0, 0, 45758.0, -204586.0),
    (0, 1, -1, 0, -40923.0, -129620.0), (1, 0, 0, 0, -34720.0, 108743.0),
    (0, 1, 1, 0, -30383.0, 104755.0), (2, 0, 0, -2, 15327.0, 10321.0),
    (0, 0, 1, 2, -12528.0, 0.0), (0, 0, 1, -2, 10980.0, 79661.0),
    (4, 0, -1, 0, 10675.0, -34782.0), (0, 0, 3, 0, 10034.0, -23210.0),
    (4, 0, -2, 0, 8548.0, -21636.0), (2, 1, -1, 0, -7888.0, 24208.0),
    (2, 1, 0, 0, -6766.0, 30824.0), (1, 0, -1, 0, -5163.0, -8379.0),
    (1, 1, 0, 0, 4987.0, -16675.0), (2, -1, 1, 0, 4036.0, -12831.0),
    (2, 0, 2, 0, 3994.0, -10445.0), (4, 0, 0, 0, 3861.0, -11650.0),
    (2, 0, -3, 0, 3665.0, 14403.0), (0, 1, -2, 0, -2689.0, -7003.0),
    (2, 0, -1, 2, -2602.0, 0.0), (2, -1, -2, 0, 2390.0, 10056.0),
    (1, 0, 1, 0, -2348.0, 6322.0), (2, -2, 0, 0, 2236.0, -9884.0),
    (0, 1, 2, 0, -2120.0, 5751.0), (0, 2, 0, 0, -2069.0, 0.0),
    (2, -2, -1, 0, 2048.0, -4950.0), (2, 0, 1, -2, -1773.0, 4130.0),
    (2, 0, 0, 2, -1595.0, 0.0), (4, -1, -1, 0, 1215.0, -3958.0),
    (0, 0, 2, 2, -1110.0, 0.0), (3, 0, -1, 0, -892.0, 3258.0),
    (2, 1, 1, 0, -810.0, 2616.0), (4, -1, -2, 0, 759.0, -1897.0),
    (0, 2, -1, 0, -713.0, -2117.0), (2, 2, -1, 0, -700.0, 2354.0),
    (2, 1, -2, 0, 691.0, 0.0), (2, -1, 0, -2, 596.0, 0.0),
    (4, 0, 1, 0, 549.0, -1423.0), (0, 0, 4, 0, 537.0, -1117.0),
    (4, -1, 0, 0, 520.0, -1571.0), (1, 0, -2, 0, -487.0, -1739.0),
    (2, 1, 0, -2, -399.0, 0.0), (0, 0, 2, -2, -381.0, -4421.0),
    (1, 1, 1, 0, 351.0, 0.0), (3, 0, -2, 0, -340.0, 0.0),
    (4, 0, -3, 0, 330.0, 0.0), (2, -1, 2, 0, 327.0, 0.0),
    (0, 2, 1, 0, -323.0, 1165.0), (1, 1, -1, 0, 299.0, 0.0),
    (2, 0, 3, 0, 294.0, 0.0), (2, 0, -1, -2, 0.0, 8752.0),
];

/// Table 47.B: multiples of D, M, M', F; Σb coefficient (1e-6 °).
#[rustfmt::skip]
const MOON_B: [(i8, i8, i8, i8, f64); 60] = [
    (0, 0, 0, 1, 5128122.0), (0, 0, 1, 1, 280602.0), (0, 0, 1, -1, 277693.0),
    (2, 0, 0, -1, 173237.0), (2, 0, -1, 1, 55413.0), (2, 0, -1, -1, 46271.0),
    (2, 0, 0, 1, 32573.0), (0, 0, 2, 1, 17198.0), (2, 0, 1, -1, 9266.0),
    (0, 0, 2, -1, 8822.0), (2, -1, 0, -1, 8216.0), (2, 0, -2, -1, 4324.0),
    (2, 0, 1, 1, 4200.0), (2, 1, 0, -1, -3359.0), (2, -1, -1, 1, 2463.0),
    (2, -1, 0, 1, 2211.0), (2, -1, -1, -1, 2065.0), (0, 1, -1, -1, -1870.0),
    (4, 0, -1, -1, 1828.0), (0, 1, 0, 1, -1794.0), (0, 0, 0, 3, -1749.0),
    (0, 1, -1, 1, -1565.0), (1, 0, 0, 1, -1491.0), (0, 1, 1, 1, -1475.0),
    (0, 1, 1, -1, -1410.0), (0, 1, 0, -1, -1344.0), (1, 0, 0, -1, -1335.0),
    (0, 0, 3, 1, 1107.0), (4, 0, 0, -1, 1021.0), (4, 0, -1, 1, 833.0),
    (0, 0, 1, -3, 777.0), (4, 0, -2, 1, 671.0), (2, 0, 0, -3, 607.0),
    (2, 0, 2, -1, 596.0), (2, -1, 1, -1, 491.0), (2, 0, -2, 1, -451.0),
    (0, 0, 3, -1, 439.0), (2, 0, 2, 1, 422.0), (2, 0, -3, -1, 421.0),
    (2, 1, -1, 1, -366.0), (2, 1, 0, 1, -351.0), (4, 0, 0, 1, 331.0),
    (2, -1, 1, 1, 315.0), (2, -2, 0, -1, 302.0), (0, 0, 1, 3, -283.0),
    (2, 1, 1, -1, -229.0), (1, 1, 0, -1, 223.0), (1, 1, 0, 1, 223.0),
    (0, 1, -2, -1, -220.0), (2, 1, -1, -1, -220.0), (1, 0, 1, 1, -185.0),
    (2, -1, -2, -1, 181.0), (0, 1, 2, 1, -177.0), (4, 0, -2, -1, 176.0),
    (4, -1, -1, -1, 166.0), (1, 0, 1, -1, -164.0), (4, 0, 1, -1, 132.0),
    (1, 0, -1, -1, -119.0), (4, -1, 0, -1, 115.0), (2, -2, 0, 1, 107.0),
];

/// Geocentric apparent ecliptic position of the Moon (Meeus ch. 47),
/// including nutation in longitude. `jd_tt` is a Julian ephemeris date.
pub fn moon_geocentric(jd_tt: f64) -> EclipticPosition {
    let t = centuries_tt(jd_tt);
    let t2 = t * t;
    let t3 = t2 * t;
    let t4 = t3 * t;
    let lp = 218.316_447_7 + 481_267.881_234_21 * t - 0.001_578_6 * t2 + t3 / 538_841.0
        - t4 / 65_194_000.0;
    let d = 297.850_192_1 + 445_267.111_403_4 * t - 0.001_881_9 * t2 + t3 / 545_868.0
        - t4 / 113_065_000.0;
    let m = 357.529_109_2 + 35_999.050_290_9 * t - 0.000_153_6 * t2 + t3 / 24_490_000.0;
    let mp = 134.963_396_4 + 477_198.867_505_5 * t + 0.008_741_4 * t2 + t3 / 69_699.0
        - t4 / 14_712_000.0;
    let f = 93.272_095_0 + 483_202.017_523_3 * t - 0.003_653_9 * t2 - t3 / 3_526_000.0
        + t4 / 863_310_000.0;
    let a1 = (119.75 + 131.849 * t) * DEG;
    let a2 = (53.09 + 479_264.290 * t) * DEG;
    let a3 = (313.45 + 481_266.484 * t) * DEG;
    let e = 1.0 - 0.002_516 * t - 0.000_007_4 * t2;
    let (dr, mr, mpr, fr, lpr) = (
        norm360(d) * DEG,
        norm360(m) * DEG,
        norm360(mp) * DEG,
        norm360(f) * DEG,
        norm360(lp) * DEG,
    );
    let efac = |km: i8| match km.abs() {
        1 => e,
        2 => e * e,
        _ => 1.0,
    };
    let (mut sl, mut sr, mut sb) = (0.0, 0.0, 0.0);
    for &(cd, cm, cmp, cf, l, r) in MOON_LR.iter() {
        let arg = cd as f64 * dr + cm as f64 * mr + cmp as f64 * mpr + cf as f64 * fr;
        let k = efac(cm);
        sl += l * k * arg.sin();
        sr += r * k * arg.cos();
    }
    for &(cd, cm, cmp, cf, b) in MOON_B.iter() {
        let arg = cd as f64 * dr + cm as f64 * mr + cmp as f64 * mpr + cf as f64 * fr;
        sb += b * efac(cm) * arg.sin();
    }
    sl += 3958.0 * a1.sin() + 1962.0 * (lpr - fr).sin() + 318.0 * a2.sin();
    sb += -2235.0 * lpr.sin()
        + 382.0 * a3.sin()
        + 175.0 * (a1 - fr).sin()
        + 175.0 * (a1 + fr).sin()
        + 127.0 * (lpr - mpr).sin()
        - 115.0 * (lpr + mpr).sin();
    let nut = nutation(jd_tt);
    EclipticPosition {
        longitude_deg: norm360(lp + sl / 1e6 + nut.longitude_deg),
        latitude_deg: sb / 1e6,
        distance_km: 385_000.56 + sr / 1000.0,
    }
}

/// Geocentric apparent ecliptic position of the Sun (Meeus ch. 25,
/// with aberration and nutation in longitude). Latitude is taken as 0
/// (< 1.2″).
pub fn sun_geocentric(jd_tt: f64) -> EclipticPosition {
    let t = centuries_tt(jd_tt);
    let l0 = 280.466_46 + 36_000.769_83 * t + 0.000_303_2 * t * t;
    let m = (357.529_11 + 35_999.050_29 * t - 0.000_153_7 * t * t) * DEG;
    let e = 0.016_708_634 - 0.000_042_037 * t - 0.000_000_126_7 * t * t;
    let c = (1.914_602 - 0.004_817 * t - 0.000_014 * t * t) * m.sin()
        + (0.019_993 - 0.000_101 * t) * (2.0 * m).sin()
        + 0.000_289 * (3.0 * m).sin();
    let true_long = l0 + c;
    let nu = m + c * DEG;
    let r_au = 1.000_001_018 * (1.0 - e * e) / (1.0 + e * nu.cos());
    let nut = nutation(jd_tt);
    let aberration_deg = -20.4898 / 3600.0 / r_au;
    EclipticPosition {
        longitude_deg: norm360(true_long + nut.longitude_deg + aberration_deg),
        latitude_deg: 0.0,
        distance_km: r_au * AU_KM,
    }
}

/// Apparent topocentric horizontal position of a body.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct HorizontalPosition {
    /// Apparent elevation above the horizon including refraction (equal
    /// to `elevation_geometric_deg` with [`Refraction::None`]), degrees.
    pub elevation_deg: f64,
    /// Topocentric elevation without refraction, degrees.
    pub elevation_geometric_deg: f64,
    /// Azimuth from north through east, degrees in [0, 360).
    pub azimuth_deg: f64,
    /// Topocentric distance, km.
    pub distance_km: f64,
}

impl HorizontalPosition {
    /// Unit vector towards the body in the local east-north-up frame,
    /// using the apparent (refracted) elevation.
    pub fn direction_enu(&self) -> [f64; 3] {
        enu_from_elevation_azimuth(self.elevation_deg, self.azimuth_deg)
    }
}

/// Unit east-north-up vector for an elevation and azimuth (north through
/// east), degrees.
pub fn enu_from_elevation_azimuth(elevation_deg: f64, azimuth_deg: f64) -> [f64; 3] {
    let (se, ce) = (elevation_deg * DEG).sin_cos();
    let (sa, ca) = (azimuth_deg * DEG).sin_cos();
    [ce * sa, ce * ca, se]
}

/// Elevation and azimuth (degrees, azimuth north through east in [0, 360))
/// of an east-north-up vector. Errors on a zero or non-finite vector.
pub fn elevation_azimuth_from_enu(v: [f64; 3]) -> Result<(f64, f64)> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if !n.is_finite() || n == 0.0 {
        return Err(SkyError::Invalid(
            "direction vector must be finite and non-zero".to_string(),
        ));
    }
    let el = (v[2] / n).clamp(-1.0, 1.0).asin() / DEG;
    let az = norm360(v[0].atan2(v[1]) / DEG);
    Ok((el, az))
}

/// Everything `gloam ephem` reports for one instant and site.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Ephemeris {
    /// The instant (UTC).
    pub instant: UtcInstant,
    /// The site.
    pub site: Site,
    /// Refraction model used for the apparent elevations.
    pub refraction: Refraction,
    /// Topocentric apparent Moon position.
    pub moon: HorizontalPosition,
    /// Topocentric apparent Sun position.
    pub sun: HorizontalPosition,
    /// Geocentric Moon position (apparent, ecliptic of date).
    pub moon_geocentric: EclipticPosition,
    /// Geocentric Sun position (apparent, ecliptic of date).
    pub sun_geocentric: EclipticPosition,
    /// Geocentric Sun–Moon elongation ψ, degrees in [0, 180].
    pub elongation_deg: f64,
    /// Phase angle i (Sun–Moon–Earth), degrees in [0, 180] (Meeus 48.3).
    pub phase_angle_deg: f64,
    /// Illuminated fraction k = (1 + cos i)/2.
    pub illuminated_fraction: f64,
    /// True between new and full moon (Moon east of the Sun).
    pub waxing: bool,
    /// ΔT = TT − UT used, seconds.
    pub delta_t_s: f64,
}

/// Earth-fixed geocentric vector of a body at apparent RA/Dec-of-date and
/// distance, given Greenwich apparent sidereal time; all angles radians.
fn earth_fixed_from_ecliptic(pos: &EclipticPosition, eps_rad: f64, gast_rad: f64) -> [f64; 3] {
    let (sl, cl) = (pos.longitude_deg * DEG).sin_cos();
    let (sb, cb) = (pos.latitude_deg * DEG).sin_cos();
    let (se, ce) = eps_rad.sin_cos();
    // ecliptic → equatorial (of date)
    let x = cb * cl;
    let y = cb * sl * ce - sb * se;
    let z = cb * sl * se + sb * ce;
    // rotate by −GAST about z: hour-angle-like Earth-fixed frame
    let (sg, cg) = gast_rad.sin_cos();
    let xe = x * cg + y * sg;
    let ye = -x * sg + y * cg;
    let d = pos.distance_km;
    [d * xe, d * ye, d * z]
}

fn topocentric(
    body_ef_km: [f64; 3],
    site: &Site,
    observer_ef_km: [f64; 3],
    refraction: Refraction,
) -> HorizontalPosition {
    let t = [
        body_ef_km[0] - observer_ef_km[0],
        body_ef_km[1] - observer_ef_km[1],
        body_ef_km[2] - observer_ef_km[2],
    ];
    let dist = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
    let (sp, cp) = (site.latitude_deg * DEG).sin_cos();
    let (sl, cl) = (site.longitude_east_deg * DEG).sin_cos();
    let east = -sl * t[0] + cl * t[1];
    let north = -sp * cl * t[0] - sp * sl * t[1] + cp * t[2];
    let up = cp * cl * t[0] + cp * sl * t[1] + sp * t[2];
    let el = (up / dist).clamp(-1.0, 1.0).asin() / DEG;
    let az = norm360(east.atan2(north) / DEG);
    HorizontalPosition {
        elevation_deg: el + refraction.correction_deg(el),
        elevation_geometric_deg: el,
        azimuth_deg: az,
        distance_km: dist,
    }
}

/// Full ephemeris of Moon and Sun for an instant and site.
pub fn ephemeris(instant: UtcInstant, site: &Site, refraction: Refraction) -> Ephemeris {
    let jd_tt = instant.julian_date_tt();
    let moon = moon_geocentric(jd_tt);
    let sun = sun_geocentric(jd_tt);
    let nut = nutation(jd_tt);
    let eps = nut.true_obliquity_deg * DEG;
    let gast = greenwich_apparent_sidereal_time_deg(&instant) * DEG;
    let obs = site.geocentric_km();
    let moon_h = topocentric(
        earth_fixed_from_ecliptic(&moon, eps, gast),
        site,
        obs,
        refraction,
    );
    let sun_h = topocentric(
        earth_fixed_from_ecliptic(&sun, eps, gast),
        site,
        obs,
        refraction,
    );

    // geocentric elongation: angle between the two geocentric directions
    let (bm, lm) = (moon.latitude_deg * DEG, moon.longitude_deg * DEG);
    let (bs, ls) = (sun.latitude_deg * DEG, sun.longitude_deg * DEG);
    let cos_psi = (bm.sin() * bs.sin() + bm.cos() * bs.cos() * (lm - ls).cos()).clamp(-1.0, 1.0);
    let psi = cos_psi.acos();
    let r = sun.distance_km;
    let delta = moon.distance_km;
    let i = (r * psi.sin()).atan2(delta - r * psi.cos());
    let waxing = norm360(moon.longitude_deg - sun.longitude_deg) < 180.0;
    Ephemeris {
        instant,
        site: *site,
        refraction,
        moon: moon_h,
        sun: sun_h,
        moon_geocentric: moon,
        sun_geocentric: sun,
        elongation_deg: psi / DEG,
        phase_angle_deg: i / DEG,
        illuminated_fraction: 0.5 * (1.0 + i.cos()),
        waxing,
        delta_t_s: instant.delta_t_s(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meeus_example_47a() {
        // 1992 April 12, 0h TD: λ = 133.162655°, β = −3.229126°, Δ = 368409.7 km
        // (λ there includes Δψ = +0.004610°).
        let jde = 2_448_724.5;
        let p = moon_geocentric(jde);
        assert!((p.longitude_deg - 133.167265).abs() < 0.001, "{p:?}");
        assert!((p.latitude_deg + 3.229126).abs() < 0.0005, "{p:?}");
        assert!((p.distance_km - 368_409.7).abs() < 0.5, "{p:?}");
    }

    #[test]
    fn meeus_example_25a() {
        // 1992 Oct 13.0 TD: apparent λ = 199.90895° (high accuracy 199.907372),
        // R = 0.99766 AU
        let p = sun_geocentric(2_448_908.5);
        assert!((p.longitude_deg - 199.90895).abs() < 0.002, "{p:?}");
        assert!((p.distance_km / AU_KM - 0.99766).abs() < 1e-4);
    }

    #[test]
    fn meeus_example_12b_sidereal_time() {
        // 1987 April 10, 19:21:00 UT: mean 128.7378734°, apparent adds ≈ −0.0011°
        let t = UtcInstant::from_calendar(1987, 4, 10, 19, 21, 0.0).unwrap();
        let g = greenwich_apparent_sidereal_time_deg(&t);
        assert!((g - 128.7378734).abs() < 0.002, "{g}");
    }

    #[test]
    fn refraction_values() {
        // Sæmundsson at true elevation 0: ≈ 28.9′; at 45°: ≈ 1′
        let r0 = refraction_saemundsson_deg(0.0, 1010.0, 10.0) * 60.0;
        assert!((r0 - 28.9).abs() < 0.5, "{r0}");
        let r45 = refraction_saemundsson_deg(45.0, 1010.0, 10.0) * 60.0;
        assert!((r45 - 0.99).abs() < 0.05, "{r45}");
        assert_eq!(refraction_saemundsson_deg(-5.0, 1010.0, 10.0), 0.0);
        assert_eq!(refraction_saemundsson_deg(90.0, 1010.0, 10.0), 0.0);
        assert_eq!(refraction_saemundsson_deg(10.0, 0.0, 10.0), 0.0);
        // Bennett inverts Sæmundsson to a few arcseconds
        for h in [0.0, 2.0, 10.0, 30.0, 60.0] {
            let app = h + refraction_saemundsson_deg(h, 1010.0, 10.0);
            assert!((app - refraction_bennett_deg(app) - h).abs() < 0.002, "{h}");
        }
        assert!(Refraction::atmosphere(-1.0, 10.0).is_err());
        assert!(Site::new(91.0, 0.0, 0.0).is_err());
        assert!(Site::new(0.0, f64::NAN, 0.0).is_err());
    }

    #[test]
    fn enu_round_trip() {
        let v = enu_from_elevation_azimuth(30.0, 120.0);
        let (e, a) = elevation_azimuth_from_enu(v).unwrap();
        assert!((e - 30.0).abs() < 1e-12 && (a - 120.0).abs() < 1e-12);
        assert!(elevation_azimuth_from_enu([0.0, 0.0, 0.0]).is_err());
    }
}
