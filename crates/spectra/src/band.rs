//! A wavelength band as typed on a command line (`LO:HI` in nm) and the
//! integral of a named spectrum over it, so `gloam spectra integrate` and
//! any other front end parse and report bands the same way.

use serde::Serialize;

use crate::{LookupError, lookup};

/// Why a band's text was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BandError {
    /// No `:` between the edges.
    #[error("band '{0}' must be LO:HI in nm, e.g. 400:700")]
    NoColon(String),
    /// The low edge is not a number.
    #[error("band low edge '{0}' is not a number")]
    Low(String),
    /// The high edge is not a number.
    #[error("band high edge '{0}' is not a number")]
    High(String),
    /// The edges are not `0 <= LO < HI`.
    #[error("band {0}:{1} must have 0 <= LO < HI")]
    Order(f64, f64),
}

/// Parses `LO:HI` in nm (`400:700`), `0 <= LO < HI`, both finite.
pub fn parse_band(s: &str) -> Result<(f64, f64), BandError> {
    let (lo, hi) = s
        .split_once(':')
        .ok_or_else(|| BandError::NoColon(s.to_string()))?;
    let lo: f64 = lo.trim().parse().map_err(|_| BandError::Low(lo.into()))?;
    let hi: f64 = hi.trim().parse().map_err(|_| BandError::High(hi.into()))?;
    if !(lo.is_finite() && hi.is_finite() && hi > lo && lo >= 0.0) {
        return Err(BandError::Order(lo, hi));
    }
    Ok((lo, hi))
}

/// A spectrum's integral over a band, optionally weighted by a response.
#[derive(Clone, Debug, Serialize)]
pub struct BandIntegral {
    /// The integral, in [`Self::units`].
    pub integral: f64,
    /// Units of the integral, in words.
    pub units: &'static str,
    /// The spectrum, as named (built-in name or CSV path).
    pub spectrum: String,
    /// The band `[LO, HI)`, nm.
    pub band_nm: [f64; 2],
    /// The weighting response, as named, if any.
    pub weight: Option<String>,
}

impl BandIntegral {
    /// Integrates `spectrum` (a built-in name or CSV path) over `[lo, hi)`
    /// nm, weighted by `weight` if given. Exact for both: the weighted
    /// integral integrates the quadratic product of the two continua, and
    /// both count lines in `[lo, hi)`.
    pub fn of(
        spectrum: &str,
        (lo, hi): (f64, f64),
        weight: Option<&str>,
        reads: &gloam_io::ReadLog,
    ) -> Result<Self, LookupError> {
        let s = lookup(spectrum, reads)?;
        let (integral, units) = match weight {
            Some(w) => (
                s.integrate_weighted_band(&lookup(w, reads)?, lo, hi),
                "spectrum units x weight units x nm",
            ),
            None => (s.integrate_band(lo, hi), "spectrum units x nm"),
        };
        // Values of 1e308 over 100 nm printed `inf` (JSON `null`), exit 0.
        if !integral.is_finite() {
            return Err(LookupError::Overflow {
                spectrum: spectrum.to_string(),
                lo,
                hi,
            });
        }
        Ok(Self {
            integral,
            units,
            spectrum: spectrum.to_string(),
            band_nm: [lo, hi],
            weight: weight.map(str::to_string),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_parse_and_refuse_with_the_reason() {
        assert_eq!(parse_band(" 400 : 700 "), Ok((400.0, 700.0)));
        assert_eq!(
            parse_band("400-700"),
            Err(BandError::NoColon("400-700".into()))
        );
        assert_eq!(parse_band("x:700"), Err(BandError::Low("x".into())));
        assert_eq!(parse_band("700:400"), Err(BandError::Order(700.0, 400.0)));
        assert!(parse_band("0:inf").is_err());
    }

    /// An integral past the largest float is refused, not `inf`.
    #[test]
    fn an_overflowing_integral_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("huge.csv");
        std::fs::write(&p, "500,1e308\n600,1e308\n").unwrap();
        let e = BandIntegral::of(
            p.to_str().unwrap(),
            (400.0, 700.0),
            None,
            &gloam_io::ReadLog::off(),
        )
        .unwrap_err();
        assert!(
            e.to_string().ends_with("huge.csv over 400:700 nm is past the largest number (1.8e308): its values are too large to integrate"),
            "{e}"
        );
    }

    #[test]
    fn a_flat_spectrum_integrates_to_its_width() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("flat.csv");
        std::fs::write(&p, "300,2\n1100,2\n").unwrap();
        let r = BandIntegral::of(
            p.to_str().unwrap(),
            (400.0, 700.0),
            None,
            &gloam_io::ReadLog::off(),
        )
        .unwrap();
        assert!((r.integral - 600.0).abs() < 1e-9, "{}", r.integral);
        assert_eq!(r.units, "spectrum units x nm");
    }
}
