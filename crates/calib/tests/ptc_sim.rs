//! Photon transfer on the simulated cameras, against figures computed
//! outside the flow: the preset's QE table under Planck's CIE A, and the
//! sensor chain's analytic mean and variance.

use std::path::Path;

use gloam_calib::ptc::{PtcOptions, PtcResult, photon_transfer};
use gloam_calib::source::open_for_grabber;

fn sphere(dir: &Path, camera: &str) -> std::path::PathBuf {
    let p = dir.join("sphere.toml");
    std::fs::write(
        &p,
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
        ),
    )
    .unwrap();
    p
}

/// `gloam calibrate ptc --grabber URI --source (sphere, rig = camera)
/// --levels 50 --gain GAIN --auto-range 1.4`, with the EMVA dataset in `dataset`.
fn run(uri: &str, camera: &str, gain: f64, dataset: Option<&Path>) -> PtcResult {
    let dir = tempfile::tempdir().unwrap();
    let src = sphere(dir.path(), camera);
    let mut g = gloam_simcam::open(uri).unwrap();
    let mut s = open_for_grabber(&src, Some(50), Some(1.4), g.as_mut(), Some(gain))
        .unwrap()
        .source;
    let opts = PtcOptions {
        gain,
        exposure_s: None,
        spatial_frames: 16,
        dataset_dir: dataset.map(Path::to_path_buf),
    };
    photon_transfer(g.as_mut(), s.as_mut(), &opts, &mut |_, _| {}).unwrap()
}

/// The photon-weighted mean QE `∫ P(λ) λ QE(λ) dλ / ∫ P(λ) λ dλ` over
/// 400–1000 nm of a plain-CCD preset's QE table under CIE illuminant A
/// (a 2856 K Planckian radiator, c₂ = 1.435e7 nm K), linear interpolation of
/// the table: independent of the spectra crate and the camera chain. The
/// rig takes the camera's lens transmission into the photon count, so this
/// is the QE·T photon transfer must recover.
fn preset_qe_under_cie_a(preset: &str) -> f64 {
    let cfg = gloam_sensor::load_preset_or_file(preset).unwrap();
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

#[test]
fn scientific_ccd_eta_is_the_presets_qe() {
    let qe_true = preset_qe_under_cie_a("scientific-ccd");
    let k_true = gloam_sensor::Camera::from_preset_or_file("scientific-ccd")
        .unwrap()
        .chain()
        .mean_dn_per_photoelectron(1.0);
    for seed in [0, 1, 2] {
        let r = run(
            &format!("sim:scientific-ccd?size=128x128&seed={seed}"),
            "scientific-ccd",
            1.0,
            None,
        );
        let qe = r.quantum_efficiency.unwrap();
        let k = r.system_gain_dn_per_e;
        eprintln!(
            "seed {seed}: η {qe:.5} vs QE·T {qe_true:.5} ({:+.3} %), K {k:.5} vs {k_true:.5} ({:+.3} %)",
            100.0 * (qe / qe_true - 1.0),
            100.0 * (k / k_true - 1.0)
        );
        assert!((qe / qe_true - 1.0).abs() < 0.005, "seed {seed}: η {qe}");
        // A plain CCD: K_eff is K, F_pix = 1, g = K.
        assert_eq!(r.pixel_noise_factor, Some(1.0));
        assert_eq!(r.conversion_gain_dn_per_pe, Some(k));
        assert!(r.excess_noise_relation.is_some());
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    }
}

#[test]
fn gen3_reports_k_eff_and_conversion_gain() {
    // 256²: the post-gain blur keeps more of the excess noise in the border
    // pixels (fewer neighbours), which raises K_eff by ~1.8 % at 128², ~0.9 %
    // at 256² (seeds 0–6).
    let gain = 56.0;
    let r = run(
        "sim:gen3-gaas-iccd?size=256x256",
        "gen3-gaas-iccd",
        gain,
        None,
    );
    let cam = gloam_sensor::Camera::from_preset_or_file("gen3-gaas-iccd").unwrap();
    let chain = cam.chain();
    // The analytic K_eff by another path: the chain's variance and mean of a
    // uniform field, differenced between 1 and 6 photoelectrons per pixel
    // (the linear range; saturation is ~12).
    let (a, b) = (1.0, 6.0);
    let k_eff_true = (chain.temporal_variance_dn2_from_pe(b, gain)
        - chain.temporal_variance_dn2_from_pe(a, gain))
        / (chain.expected_mean_dn_from_pe(b, gain) - chain.expected_mean_dn_from_pe(a, gain));
    let g_true = chain.mean_dn_per_photoelectron(gain);
    let k = r.effective_system_gain_dn_per_e;
    let g = r.conversion_gain_dn_per_pe.unwrap();
    eprintln!(
        "Gen III at {gain}: K_eff {k:.2} vs {k_eff_true:.2} ({:+.2} %), g {g:.2} vs {g_true:.2} DN/pe ({:+.2} %), F {:.4}, F_pix {:.4}, QE(g) {:?}, η_EMVA {:?}",
        100.0 * (k / k_eff_true - 1.0),
        100.0 * (g / g_true - 1.0),
        r.excess_noise_factor.unwrap(),
        r.pixel_noise_factor.unwrap(),
        r.quantum_efficiency_from_conversion_gain,
        r.quantum_efficiency,
    );
    assert_eq!(r.system_gain_dn_per_e, k);
    assert!((k / k_eff_true - 1.0).abs() < 0.02);
    assert!((g / g_true - 1.0).abs() < 0.02);
    let rel = r.excess_noise_relation.as_deref().unwrap();
    assert!(
        rel.contains("K_eff = g·F_pix") && rel.contains("EMVA"),
        "{rel}"
    );
    assert!(r.warnings.iter().any(|w| w == rel));
}

#[test]
fn a_rig_camera_without_the_runs_gain_is_named_not_used() {
    // The calibration sphere's rig is the scientific CCD (gains 1–4): on a
    // Gen III at gain 56 it cannot declare the noise, and says so.
    let r = run(
        "sim:gen3-gaas-iccd?size=64x64",
        "scientific-ccd",
        56.0,
        None,
    );
    assert!(r.conversion_gain_dn_per_pe.is_none());
    assert!(
        r.warnings
            .iter()
            .any(|w| w.contains("'scientific-ccd' gives none at gain 56")),
        "{:?}",
        r.warnings
    );
}
