//! Optics: the camera equation, the cos⁴θ fall-off and the objective's MTF
//! (pupil diffraction, defocus blur circle).

use rayon::prelude::*;

use super::mtf::{MtfStage, MtfTerm};
use crate::config::Optics;

/// Image-plane irradiance per unit scene radiance on axis, sr: the camera
/// equation `E / L = π τ / (4 N²)` for a distant scene (working f-number N,
/// optics transmission τ). The one place this factor is computed: the camera
/// chain's étendue and the calibration rig's photon count both use it.
pub fn image_irradiance_per_radiance(f_number: f64, transmission: f64) -> f64 {
    std::f64::consts::PI * transmission / (4.0 * f_number * f_number)
}

/// The cos⁴θ natural vignetting of a `rows × cols` image whose pixels are
/// `pitch_mm` apart at the image plane of a lens of focal length
/// `focal_length_mm`: `cos⁴θ = 1/(1 + tan²θ)²`, θ measured from the centre.
pub fn cos4_falloff(rows: usize, cols: usize, pitch_mm: f64, focal_length_mm: f64) -> Vec<f32> {
    let (cy, cx) = ((rows as f64 - 1.0) / 2.0, (cols as f64 - 1.0) / 2.0);
    let mut v = vec![0f32; rows * cols];
    v.par_chunks_mut(cols).enumerate().for_each(|(r, out)| {
        for (c, o) in out.iter_mut().enumerate() {
            let rr = ((r as f64 - cy).powi(2) + (c as f64 - cx).powi(2)).sqrt() * pitch_mm;
            let t2 = (rr / focal_length_mm).powi(2);
            *o = (1.0 / (1.0 + t2).powi(2)) as f32;
        }
    });
    v
}

/// Multiplies the photoelectron means by the fall-off, in place.
pub fn apply_falloff(pe: &mut [f32], falloff: &[f32]) {
    pe.par_iter_mut()
        .zip(falloff.par_iter())
        .for_each(|(p, &w)| *p *= w);
}

/// The objective's MTF stages at the cathode plane (pixel pitch `pitch_mm`
/// there): circular-pupil diffraction and the geometric defocus blur circle
/// `d = δz / N`.
pub fn mtf_stages(o: &Optics, pitch_mm: f64) -> Vec<MtfStage> {
    let mut stages = Vec::new();
    if o.diffraction {
        let cutoff_cy_mm = 1.0 / (o.diffraction_wavelength_nm * 1e-6 * o.f_number);
        stages.push(MtfStage {
            name: "optics diffraction",
            term: MtfTerm::Diffraction {
                cutoff_cy_px: cutoff_cy_mm * pitch_mm,
            },
            after_noise: false,
        });
    }
    if o.defocus_um > 0.0 {
        stages.push(MtfStage {
            name: "optics defocus",
            term: MtfTerm::Jinc {
                diameter_px: o.defocus_um * 1e-3 / o.f_number / pitch_mm,
            },
            after_noise: false,
        });
    }
    stages
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_equation_at_f1() {
        // f/1, τ = 1: E = π L / 4 (e.g. Smith, Modern Optical Engineering, §9.3).
        assert!(
            (image_irradiance_per_radiance(1.0, 1.0) - std::f64::consts::FRAC_PI_4).abs() < 1e-15
        );
        // Halving the aperture (one f-number doubling) quarters the light.
        let r = image_irradiance_per_radiance(2.8, 0.9) / image_irradiance_per_radiance(1.4, 0.9);
        assert!((r - 0.25).abs() < 1e-15);
    }

    #[test]
    fn falloff_is_cos4_of_the_field_angle() {
        // A 1×3 row with 10 mm pixels behind a 10 mm lens: the outer pixels
        // sit at 45°, so cos⁴45° = ¼; the centre is 1.
        let v = cos4_falloff(1, 3, 10.0, 10.0);
        assert_eq!(v[1], 1.0);
        assert!((v[0] as f64 - 0.25).abs() < 1e-7 && (v[2] as f64 - 0.25).abs() < 1e-7);
    }
}
