//! What the photon-transfer tests share (gloam-calib's `ptc_sim` and the
//! binary's `cli_calibrate` include this file by path): the sphere source
//! they calibrate with and an independent reference for the QE it finds.

/// A CIE A integrating sphere dimmed by aperture, its rig the camera
/// `camera` (so photon counts use that preset's optics).
pub fn sphere_toml(camera: &str) -> String {
    format!(
        r#"
[source]
kind = "sphere"
lamp = "cie-a"
lamp_flux_w = 1.0
sphere_diameter_m = 0.5
reflectance = 0.98
port_fraction = 0.02

[dimming]
method = "aperture"

[rig]
camera = "{camera}"
"#
    )
}

/// The photon-weighted mean QE `∫ P(λ) λ QE(λ) dλ / ∫ P(λ) λ dλ` over
/// 400–1000 nm of a plain-CCD preset's QE table under CIE illuminant A,
/// computed here from Planck's law (CIE A is a 2856 K Planckian radiator with
/// c₂ = 1.435e7 nm K) and linear interpolation of the table: independent of
/// the spectra crate and the camera chain. The rig takes the camera's lens
/// transmission into the photon count, so this is the QE·T photon transfer
/// must recover.
pub fn preset_qe_under_cie_a(preset: &str) -> f64 {
    let cfg = gloam_sensor::load_preset_or_file(preset, &gloam_io::ReadLog::off()).unwrap();
    let Some(gloam_sensor::config::SpectrumRef::Table {
        wavelength_nm,
        value,
    }) = cfg.ccd.qe
    else {
        panic!("{preset}: QE is not a table");
    };
    let qe = |l: f64| {
        let i = wavelength_nm
            .partition_point(|&w| w <= l)
            .clamp(1, wavelength_nm.len() - 1);
        let (w0, w1) = (wavelength_nm[i - 1], wavelength_nm[i]);
        value[i - 1] + (value[i] - value[i - 1]) * (l - w0) / (w1 - w0)
    };
    let planck = |l: f64| l.powi(-5) / ((1.435e7 / (l * 2856.0)).exp() - 1.0);
    let (mut num, mut den) = (0.0, 0.0);
    let n = 60_000;
    for i in 0..=n {
        let l = 400.0 + 600.0 * i as f64 / n as f64;
        let w = if i == 0 || i == n { 0.5 } else { 1.0 };
        let p = w * planck(l) * l;
        num += p * qe(l);
        den += p;
    }
    num / den
}
