//! The saturated-pixel fraction a frame reports, against frames built with a
//! known number of clipped pixels.

use gloam_sensor::{Camera, load_preset_or_file};
use ndarray::Array2;

/// The scientific CCD with nothing that moves charge between pixels
/// (no blur, no blooming, no vignetting, no DSNU), so a pixel clips exactly when its
/// own charge passes full well.
fn sharp_ccd(noise: bool) -> Camera {
    let mut cfg = load_preset_or_file("scientific-ccd", &gloam_io::ReadLog::off()).unwrap();
    cfg.optics.diffraction = false;
    cfg.optics.vignetting = false;
    cfg.ccd.diffusion_um = 0.0;
    cfg.ccd.blooming = false;
    cfg.ccd.dsnu_e = 0.0; // added after the clip: keeps a clipped pixel exactly at saturation
    cfg.noise.enabled = noise;
    Camera::new(cfg).unwrap()
}

/// 64 × 64 pixels at 1000 e⁻, of which `k` (every 31st) at 10× full well.
fn frame_with_clipped(k: usize) -> Array2<f64> {
    let mut pe = Array2::from_elem((64, 64), 1000.0);
    for i in 0..k {
        let j = i * 31;
        pe[(j / 64, j % 64)] = 1e6;
    }
    pe
}

#[test]
fn saturated_fraction_counts_the_clipped_pixels() {
    for k in [0usize, 1, 41, 123] {
        let pe = frame_with_clipped(k);
        // Noise off: a clipped pixel sits exactly at saturation
        // (offset 500 + 100 000 e⁻ / 1.6 e⁻/DN = 63 000 DN).
        let mut cam = sharp_ccd(false);
        assert_eq!(cam.chain().saturation_dn(1.0), 63_000.0);
        let f = cam.capture_photoelectrons(pe.view()).unwrap();
        assert_eq!(
            f.sensor().unwrap().saturated_fraction,
            k as f64 / 4096.0,
            "k = {k}"
        );
        let px: Vec<u16> = f.pixels.to_vec();
        assert_eq!(px.iter().filter(|&&p| p == 63_000).count(), k);
        // The same count from the pixels through the shared definition.
        let at = cam.chain().saturated_threshold_dn(1.0);
        assert_eq!(
            gloam_sensor::levels::saturated_fraction(&px, at),
            k as f64 / 4096.0
        );
        // Noise on: read noise (3 e⁻ = 1.9 DN) is added after the clip and
        // the threshold is 3 σ below saturation, so a clipped pixel is missed
        // with probability 0.13 %, and an unclipped one (at 1000 e⁻) never counts.
        let mut cam = sharp_ccd(true);
        let f = cam.capture_photoelectrons(pe.view()).unwrap();
        let n = (f.sensor().unwrap().saturated_fraction * 4096.0).round() as usize;
        assert!(n <= k && n + 2 >= k, "k = {k}: counted {n}");
    }
    // The 1 % warning: 40 of 4096 (0.977 %) is below it, 41 (1.001 %) above.
    let warn = |k: usize| {
        let mut cam = sharp_ccd(false);
        let f = cam
            .capture_photoelectrons(frame_with_clipped(k).view())
            .unwrap();
        let c = cam.chain();
        gloam_sensor::levels::warning_kinds(
            f.sensor().unwrap().mean_dn,
            f.sensor().unwrap().saturated_fraction,
            Some(c.black_dn(1.0)),
            c.saturation_dn(1.0),
        )
    };
    assert!(warn(40).is_empty());
    assert_eq!(warn(41), vec![gloam_sensor::levels::WarningKind::Saturated]);
}
