//! Photon transfer on the simulated cameras, against figures computed
//! outside the flow: the preset's QE table under Planck's CIE A, and the
//! sensor chain's analytic mean and variance.

use std::path::Path;

use gloam_calib::ptc::{PtcOptions, PtcResult, photon_transfer};
use gloam_calib::source::open_for_grabber;
use reference::preset_qe_under_cie_a;

#[path = "shared/reference.rs"]
mod reference;

fn sphere(dir: &Path, camera: &str) -> std::path::PathBuf {
    let p = dir.join("sphere.toml");
    std::fs::write(&p, reference::sphere_toml(camera)).unwrap();
    p
}

/// `gloam calibrate ptc --grabber URI --source (sphere, rig = camera)
/// --levels 50 --gain GAIN --auto-range 1.4`, with the EMVA dataset in `dataset`.
fn run(uri: &str, camera: &str, gain: f64, dataset: Option<&Path>) -> PtcResult {
    let dir = tempfile::tempdir().unwrap();
    let src = sphere(dir.path(), camera);
    let mut g = gloam_simcam::open(uri).unwrap();
    let mut s = open_for_grabber(
        &src,
        Some(50),
        Some(1.4),
        g.as_mut(),
        Some(gain),
        &gloam_io::ReadLog::off(),
    )
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

#[test]
fn scientific_ccd_eta_is_the_presets_qe() {
    let qe_true = preset_qe_under_cie_a("scientific-ccd");
    let k_true =
        gloam_sensor::Camera::from_preset_or_file("scientific-ccd", &gloam_io::ReadLog::off())
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
    let cam =
        gloam_sensor::Camera::from_preset_or_file("gen3-gaas-iccd", &gloam_io::ReadLog::off())
            .unwrap();
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
