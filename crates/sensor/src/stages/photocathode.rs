//! Photocathode: spectral QE, luminous sensitivity to 2856 K light, dark
//! emission (EBI) and the proximity-focus spread of the gap behind it.

use gloam_spectra::{KM_PHOTOPIC_LM_W, Spectrum, library, photons_per_joule};

use super::mtf::{MtfStage, MtfTerm};
use crate::config::Photocathode;

/// Elementary charge, C.
pub const ELEMENTARY_CHARGE_C: f64 = 1.602_176_634e-19;

/// Luminous sensitivity of a cathode of quantum efficiency `qe` to CIE
/// illuminant A (2856 K), A/lm: `S = q ∫QE·P_A·λ/hc dλ / (K_m ∫V·P_A dλ)`.
pub fn luminous_sensitivity_a_lm(qe: &Spectrum) -> f64 {
    let a = library::get("cie-a").expect("built-in");
    let v = library::photopic_v();
    let electrons_per_w = a
        .map_all(|w, x| x * photons_per_joule(w))
        .integrate_weighted(qe);
    let lumens = KM_PHOTOPIC_LM_W * a.integrate_weighted(v);
    ELEMENTARY_CHARGE_C * electrons_per_w / lumens
}

/// Dark-emission photoelectrons per pixel per frame at the reference gain:
/// the spec-sheet EBI (lm cm⁻²) times the sensitivity `s_a_lm`, over a pixel
/// of `pitch_mm` at the cathode, for the gated part of `exposure_s`.
pub fn ebi_pe_per_frame(p: &Photocathode, s_a_lm: f64, pitch_mm: f64, exposure_s: f64) -> f64 {
    let a_pix_cm2 = (pitch_mm * 0.1).powi(2);
    p.ebi_lm_cm2 * s_a_lm / ELEMENTARY_CHARGE_C * a_pix_cm2 * exposure_s * p.gate_duty
}

/// The proximity-focus spread of a gap of `gap_mm` at `voltage_v` for
/// electrons leaving with transverse energy `energy_ev`: per axis a Gaussian
/// of `σ = L √(2ε/V)` (Csorba, *Image Tubes*, 1985, ch. 4), as an MTF stage
/// in pixels of `pitch_mm`. None when the gap, energy or voltage is zero.
pub fn proximity_gap(
    name: &'static str,
    gap_mm: f64,
    energy_ev: f64,
    voltage_v: f64,
    pitch_mm: f64,
    after_noise: bool,
) -> Option<MtfStage> {
    (gap_mm > 0.0 && energy_ev > 0.0 && voltage_v > 0.0).then(|| {
        let sigma_mm = gap_mm * (2.0 * energy_ev / voltage_v).sqrt();
        MtfStage {
            name,
            term: MtfTerm::Gaussian {
                sigma_px: sigma_mm / pitch_mm,
            },
            after_noise,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gen3_gaas_sensitivity_is_in_the_datasheet_class() {
        // Gen III GaAs cathodes: 1 350 µA/lm minimum (MIL-PRF-49052 class),
        // 1 800–2 200 µA/lm typical in tube datasheets (e.g. Photonis/Exosens
        // "Gen III" product notes, ITT F9800 series).
        let qe = gloam_spectra::library::get("qe-gen3-gaas").unwrap();
        let s_ua = luminous_sensitivity_a_lm(&qe) * 1e6;
        assert!((1000.0..2600.0).contains(&s_ua), "{s_ua} µA/lm");
    }

    #[test]
    fn sensitivity_is_linear_in_qe() {
        // S ∝ ∫ QE P_A λ/hc dλ: halving the QE halves the sensitivity.
        let one = Spectrum::constant(200.0, 1200.0, 1.0).unwrap();
        let half = Spectrum::constant(200.0, 1200.0, 0.5).unwrap();
        let r = luminous_sensitivity_a_lm(&half) / luminous_sensitivity_a_lm(&one);
        assert!((r - 0.5).abs() < 1e-12);
    }

    #[test]
    fn gap_spread_closed_form() {
        // 0.2 mm at 600 V with 0.1 eV electrons: σ = 0.2 √(0.2/600) mm = 3.651 µm.
        let s = proximity_gap("gap", 0.2, 0.1, 600.0, 1e-3, false).unwrap();
        let MtfTerm::Gaussian { sigma_px } = s.term else {
            panic!("gaussian")
        };
        assert!((sigma_px - 3.651_483_7).abs() < 1e-6, "{sigma_px}");
        assert!(proximity_gap("gap", 0.0, 0.1, 600.0, 1e-3, false).is_none());
    }
}
