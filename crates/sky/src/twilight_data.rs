//! Measured tables the twilight sky needs, embedded at compile time from
//! `crates/sky/data/` (each file's header gives its source, citation and
//! how it was reduced), so the model never reads files at run time:
//!
//! * the extraterrestrial solar spectrum (ASTM G173-03 ETR, Gueymard 2004),
//!   5-nm bin means on the crate's 300–1100 nm grid — the blackbody of
//!   [`crate::spectral::solar_irradiance_1au_w_m2_nm`] lacks the Fraunhofer
//!   lines and is 10–20 % high in the blue, which matters for twilight colour;
//! * the ozone absorption cross-section (Daumont–Brion–Malicet 243 K in the
//!   Huggins band, Serdyuchenko et al. 2014 233 K across the Chappuis band).

use std::sync::OnceLock;

use crate::error::{Result, SkyError};
use crate::spectral::{self, Samples};

const SOLAR_CSV: &str = include_str!("../data/solar_etr_astm_g173.csv");
const OZONE_CSV: &str = include_str!("../data/ozone_cross_section.csv");

/// Parses a two-column CSV (`#` comments, one header row) into ascending
/// `(x, y)` pairs; an error names the table and the line that is wrong.
pub fn parse_two_column_csv(name: &str, text: &str) -> Result<Samples> {
    let mut out: Samples = Vec::new();
    let rows = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .skip(1);
    for (i, line) in rows {
        let bad = || SkyError::Invalid(format!("{name} line {}: {line:?}", i + 1));
        let mut cols = line.split(',').map(|c| c.trim().parse::<f64>());
        let (Some(Ok(x)), Some(Ok(y)), None) = (cols.next(), cols.next(), cols.next()) else {
            return Err(bad());
        };
        if !x.is_finite() || !y.is_finite() || out.last().is_some_and(|p| p.0 >= x) {
            return Err(bad());
        }
        out.push((x, y));
    }
    if out.len() < 2 {
        return Err(SkyError::Invalid(format!("{name}: fewer than two rows")));
    }
    Ok(out)
}

fn cached(
    cell: &'static OnceLock<std::result::Result<Samples, SkyError>>,
    name: &str,
    text: &str,
) -> Result<&'static [(f64, f64)]> {
    cell.get_or_init(|| parse_two_column_csv(name, text))
        .as_deref()
        .map_err(Clone::clone)
}

/// ASTM G173-03 extraterrestrial solar spectral irradiance at 1 AU,
/// W m⁻² nm⁻¹, 5-nm bin means at 300, 305, …, 1100 nm.
pub fn solar_etr_table() -> Result<&'static [(f64, f64)]> {
    static T: OnceLock<std::result::Result<Samples, SkyError>> = OnceLock::new();
    cached(&T, "solar_etr_astm_g173.csv", SOLAR_CSV)
}

/// Ozone absorption cross-section table, cm² per molecule.
pub fn ozone_cross_section_table() -> Result<&'static [(f64, f64)]> {
    static T: OnceLock<std::result::Result<Samples, SkyError>> = OnceLock::new();
    cached(&T, "ozone_cross_section.csv", OZONE_CSV)
}

/// Measured extraterrestrial solar irradiance at 1 AU, W m⁻² nm⁻¹ (linear
/// interpolation; 0 outside 300–1100 nm).
pub fn solar_etr_w_m2_nm(wavelength_nm: f64) -> Result<f64> {
    Ok(spectral::interpolate(solar_etr_table()?, wavelength_nm))
}

/// Ozone cross-section at a wavelength, cm²: linear between the table's
/// points, the end values held beyond them (the Wulf band beyond 835 nm is
/// weaker than 1e-22 cm², so holding the last value is a bound, not a fit).
pub fn ozone_cross_section_cm2(wavelength_nm: f64) -> Result<f64> {
    let t = ozone_cross_section_table()?;
    let (first, last) = (t[0], t[t.len() - 1]);
    if !wavelength_nm.is_finite() {
        return Ok(0.0);
    }
    Ok(if wavelength_nm <= first.0 {
        first.1
    } else if wavelength_nm >= last.0 {
        last.1
    } else {
        spectral::interpolate(t, wavelength_nm)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_load_with_their_published_landmarks() {
        let s = solar_etr_table().unwrap();
        assert_eq!(s.len(), 161);
        assert_eq!((s[0].0, s[160].0), (300.0, 1100.0));
        // the reduction keeps the band's energy: ∫ 300–1100 nm of the native
        // G173 ETR table is 1001.93 W m⁻² (of its 1348 W m⁻² from 280 nm to 4 µm)
        let total = spectral::integrate(s);
        assert!((total / 1001.93 - 1.0).abs() < 2e-3, "{total}");
        // Chappuis maximum near 600 nm ≈ 5e-21 cm² (Serdyuchenko 2014)
        let peak = ozone_cross_section_cm2(605.0).unwrap();
        assert!((4.5e-21..5.5e-21).contains(&peak), "{peak}");
        // Huggins band: ≈ 3.7e-19 cm² at 300 nm, a minimum near 375 nm
        assert!(ozone_cross_section_cm2(300.0).unwrap() > 3e-19);
        assert!(ozone_cross_section_cm2(375.0).unwrap() < 1e-23);
        assert!(ozone_cross_section_cm2(1100.0).unwrap() < 1e-22);
    }

    #[test]
    fn bad_tables_are_errors_not_panics() {
        assert!(parse_two_column_csv("t", "x,y\n1,2\n").is_err());
        assert!(parse_two_column_csv("t", "x,y\n1,2\n1,3\n").is_err());
        assert!(parse_two_column_csv("t", "x,y\n1,2\n2,nope\n").is_err());
        assert!(parse_two_column_csv("t", "x,y\n1,2\n2,3,4\n").is_err());
        let ok = parse_two_column_csv("t", "# c\nx,y\n1,2\n2,3\n").unwrap();
        assert_eq!(ok, vec![(1.0, 2.0), (2.0, 3.0)]);
    }
}
