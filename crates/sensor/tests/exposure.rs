//! Exposure controls in the sensor file: f-number, ND filter and the
//! photocathode's gating duty cycle, against the closed form
//! `signal ∝ duty · 10^−D / N²` through the chain's mean signal.

use gloam_sensor::{Camera, SensorConfig, load_preset_or_file};
use ndarray::Array2;

/// Mean DN above the dark frame of a uniform field of band radiance `l`
/// (CIE A over 400–1000 nm), noise off, at gain `g`.
fn mean_signal(cfg: &SensorConfig, l: f64, g: f64) -> f64 {
    let shape = gloam_spectra::library::get("cie-a")
        .unwrap()
        .product(&gloam_spectra::Spectrum::constant(400.0, 1000.0, 1.0).unwrap());
    let mut cam = Camera::new(cfg.clone()).unwrap();
    cam.set_noise(false);
    cam.set_override_gain(Some(g)).unwrap();
    let mut mean = |l: f64| {
        let f = cam
            .capture_mono(Array2::from_elem((32, 32), l).view(), &shape)
            .unwrap();
        f.pixels.iter().map(|&p| f64::from(p)).sum::<f64>() / f.pixels.len() as f64
    };
    let dark = mean(0.0);
    mean(l) - dark
}

#[test]
fn nd_and_f_number_scale_the_signal_as_ten_to_minus_d_over_n_squared() {
    let base = load_preset_or_file("scientific-ccd", &gloam_io::ReadLog::off()).unwrap();
    let l = 4e-4; // ~16 000 DN above black at f/2, gain 1: linear, far from clipping
    let s0 = mean_signal(&base, l, 1.0);
    assert!(s0 > 5_000.0 && s0 < 40_000.0, "{s0}");
    for (n, d) in [(2.0, 0.3), (2.8, 0.0), (1.4, 1.0), (4.0, 0.5)] {
        let mut c = base.clone();
        c.optics.f_number = n;
        c.optics.nd_density = d;
        let want = 10f64.powf(-d) * (2.0 / n).powi(2);
        // Scale the radiance so every case sits near the same signal, where
        // rounding to whole DN (± 0.5) is a 3e-5 relative effect.
        let got = mean_signal(&c, l / want, 1.0) / s0;
        assert!(
            (got - 1.0).abs() < 2e-4,
            "f/{n}, ND {d}: signal ratio {got} (want 10^-D (2/N)² = {want} of the light)"
        );
        // And the analytic transfer agrees: photoelectrons scale exactly.
        let pe = |cfg: &SensorConfig| {
            let ch = gloam_sensor::Chain::new(cfg).unwrap();
            ch.etendue_m2_sr_s
        };
        assert!((pe(&c) / pe(&base) / want - 1.0).abs() < 1e-12);
    }
}

#[test]
fn gate_duty_scales_an_intensified_camera_signal() {
    let mut base = load_preset_or_file("gen2-s20-iccd", &gloam_io::ReadLog::off()).unwrap();
    base.agc = None;
    base.mcp.as_mut().unwrap().output_current_limit_a_cm2 = None; // linear MCP
    base.photocathode.as_mut().unwrap().ebi_lm_cm2 = 0.0;
    let chain = gloam_sensor::Chain::new(&base).unwrap();
    let g = chain.gain_min;
    let shape = gloam_spectra::library::get("cie-a")
        .unwrap()
        .product(&gloam_spectra::Spectrum::constant(400.0, 1000.0, 1.0).unwrap());
    // Radiance for ~30 % of the range above black at the lowest gain.
    let span = chain.saturation_dn(g) - chain.black_dn(g);
    let l =
        0.3 * span / (chain.pe_per_radiance(&shape).unwrap() * chain.mean_dn_per_photoelectron(g));
    let s1 = mean_signal(&base, l, g);
    for duty in [0.5, 0.1, 0.01] {
        let mut c = base.clone();
        c.photocathode.as_mut().unwrap().gate_duty = duty;
        let got = mean_signal(&c, l / duty, g) / s1;
        assert!((got - 1.0).abs() < 1e-3, "duty {duty}: ratio {got}");
        let e = |cfg: &SensorConfig| gloam_sensor::Chain::new(cfg).unwrap().etendue_m2_sr_s;
        assert!((e(&c) / e(&base) / duty - 1.0).abs() < 1e-12);
    }
    // Out of range: refused with the field named.
    let mut c = base.clone();
    c.photocathode.as_mut().unwrap().gate_duty = 1.5;
    let e = Camera::new(c).err().unwrap().to_string();
    assert!(e.contains("photocathode.gate_duty"), "{e}");
    let mut c = base;
    c.optics.nd_density = -1.0;
    let e = Camera::new(c).err().unwrap().to_string();
    assert!(e.contains("optics.nd_density"), "{e}");
}
