//! Does a calibration source's `[rig]` describe the simulated camera it is
//! pointed at? Photon transfer divides responsivity by the photon count the
//! rig predicts, so a rig with another lens, pixel or exposure than the
//! simulated camera's biases the quantum efficiency by exactly the ratio of
//! the two photon counts. The CLI prints the mismatch as a warning and
//! Python returns it in the result's `warnings`, from this one check.

use crate::source::Rig;

/// Relative photon-count difference below which the two rigs agree.
pub const RIG_TOLERANCE: f64 = 1e-3;

/// A source rig that counts a different number of photons than the
/// simulated camera receives. `Display` is the warning, naming the QE bias
/// and the fix.
#[derive(Clone, Debug, PartialEq)]
pub struct RigMismatch {
    /// The simulated camera's preset or file, from the grabber URI.
    pub preset: String,
    /// The source file's rig.
    pub source_rig: Rig,
    /// The rig of the simulated camera (its own lens, pixel and exposure).
    pub camera_rig: Rig,
    /// Photons per pixel the source rig counts / the camera receives.
    pub photon_ratio: f64,
}

impl RigMismatch {
    /// How far the measured QE is off, as a fraction: `1/ratio − 1`.
    pub fn qe_bias(&self) -> f64 {
        1.0 / self.photon_ratio - 1.0
    }
}

impl std::fmt::Display for RigMismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (rig, cam, ratio, preset) = (
            &self.source_rig,
            &self.camera_rig,
            self.photon_ratio,
            &self.preset,
        );
        write!(
            f,
            "the source's [rig] (pitch {} µm, f/{}, τ {}, {} s) counts {:.2} % {} photons than the simulated '{preset}' receives (pitch {:.4} µm, f/{}, τ {}, {} s): its QE will read {:.2} % {}; use camera = \"{preset}\" in [rig]",
            rig.pixel_pitch_um,
            rig.f_number,
            rig.optics_transmission,
            rig.exposure_s,
            100.0 * (ratio - 1.0).abs(),
            if ratio > 1.0 { "more" } else { "fewer" },
            cam.pixel_pitch_um,
            cam.f_number,
            cam.optics_transmission,
            cam.exposure_s,
            100.0 * self.qe_bias().abs(),
            if ratio > 1.0 { "low" } else { "high" },
        )
    }
}

/// Photons per pixel per unit radiance the rig counts (up to the spectral
/// integral both rigs share): pixel area × exposure × `E/L`.
fn photons_per_radiance(r: &Rig) -> f64 {
    (r.pixel_pitch_um * 1e-6).powi(2) * r.exposure_s * r.irradiance_factor()
}

/// The mismatch between the source's `rig` and the simulated camera behind
/// grabber `uri` (at `exposure_s` when the run overrides it); `None` when
/// they agree within [`RIG_TOLERANCE`], there is no rig, or the grabber is
/// not a simulated camera whose preset loads.
pub fn rig_mismatch(uri: &str, rig: Option<&Rig>, exposure_s: Option<f64>) -> Option<RigMismatch> {
    let rig = rig?;
    let gloam_simcam::SimUri { preset, .. } = gloam_simcam::SimUri::parse(uri).ok()?;
    // The grabber's open noted a sensor file; this is the same one again.
    let mut cfg = gloam_sensor::load_preset_or_file(&preset, &gloam_io::ReadLog::off()).ok()?;
    if let Some(e) = exposure_s {
        cfg.timing.exposure_s = e;
    }
    let cam = Rig::from_camera(&cfg, &preset).ok()?;
    let ratio = photons_per_radiance(rig) / photons_per_radiance(&cam);
    ((ratio - 1.0).abs() > RIG_TOLERANCE).then(|| RigMismatch {
        preset,
        source_rig: rig.clone(),
        camera_rig: cam,
        photon_ratio: ratio,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ccd_rig() -> Rig {
        let cfg =
            gloam_sensor::load_preset_or_file("scientific-ccd", &gloam_io::ReadLog::off()).unwrap();
        Rig::from_camera(&cfg, "scientific-ccd").unwrap()
    }

    #[test]
    fn the_cameras_own_rig_agrees() {
        let r = ccd_rig();
        assert_eq!(rig_mismatch("sim:scientific-ccd", Some(&r), None), None);
        assert_eq!(rig_mismatch("sim:scientific-ccd", None, None), None);
        // Not a simulated camera: nothing to compare with.
        assert_eq!(rig_mismatch("serial:/dev/null", Some(&r), None), None);
    }

    #[test]
    fn a_rig_without_the_lens_transmission_counts_one_over_tau_more() {
        // The CCD preset's lens has τ = 0.9; a rig with τ = 1 counts
        // 1/0.9 − 1 = 11.1 % more photons, so QE reads 10 % low.
        let mut r = ccd_rig();
        let tau = r.optics_transmission;
        r.optics_transmission = 1.0;
        let m = rig_mismatch("sim:scientific-ccd?size=32x32", Some(&r), None).unwrap();
        assert!(
            (m.photon_ratio - 1.0 / tau).abs() < 1e-12,
            "{}",
            m.photon_ratio
        );
        assert!((m.qe_bias() + (1.0 - tau)).abs() < 1e-12);
        let w = m.to_string();
        assert!(
            w.contains("11.11 % more photons") && w.contains("10.00 % low"),
            "{w}"
        );
        assert!(
            w.ends_with("use camera = \"scientific-ccd\" in [rig]"),
            "{w}"
        );
    }

    #[test]
    fn an_exposure_override_is_the_cameras_exposure() {
        let mut r = ccd_rig();
        r.exposure_s *= 2.0;
        let m = rig_mismatch("sim:scientific-ccd", Some(&r), None).unwrap();
        assert!((m.photon_ratio - 2.0).abs() < 1e-12);
        assert_eq!(
            rig_mismatch("sim:scientific-ccd", Some(&r), Some(r.exposure_s)),
            None
        );
    }
}
