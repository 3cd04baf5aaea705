//! AGC linearisation on the simulated Gen III camera, as the README's
//! rehearsal runs it: a LUT made on the same camera over the gains its AGC
//! visits linearises the AGC frames to the source's true radiance, and a
//! LUT from another camera or gain range is refused, saying why.

use std::path::{Path, PathBuf};

use gloam_calib::CalibError;
use gloam_calib::agc::{AgcOptions, AgcReport, agc_linearisation};
use gloam_calib::radiance::{Lut, RadianceOptions, calibrate_radiance};
use gloam_calib::source::open_for_grabber;

const GEN3: &str = "sim:gen3-gaas-iccd?size=64x64";
/// The Gen III camera's lowest gain (MCP at 500 V), the overridden run's.
const GEN3_MIN_GAIN: f64 = 14.552;
const LEVELS: usize = 5;

fn sphere() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../sims/calibration/sphere.toml")
}

/// `gloam calibrate radiance --grabber URI --source sphere.toml --gains G
/// --levels 10 --frames 8 --auto-range 0.8`.
fn lut(uri: &str, gains: &[f64]) -> Lut {
    let mut g = gloam_simcam::open(uri).unwrap();
    let top = gains.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let mut s = open_for_grabber(
        &sphere(),
        Some(10),
        Some(0.8),
        g.as_mut(),
        Some(top),
        &gloam_io::ReadLog::off(),
    )
    .unwrap()
    .source;
    let opts = RadianceOptions {
        gains: gains.to_vec(),
        frames: 8,
        ..Default::default()
    };
    calibrate_radiance(g.as_mut(), s.as_mut(), &opts, &mut |_, _| {}).unwrap()
}

/// `gloam calibrate agc --grabber gen3 --source sphere.toml --levels 5
/// --fixed-gain 14.552 --auto-range 0.5 --lut …`.
fn agc(lut: &Lut) -> Result<AgcReport, CalibError> {
    let mut g = gloam_simcam::open(GEN3).unwrap();
    let mut s = open_for_grabber(
        &sphere(),
        Some(LEVELS),
        Some(0.5),
        g.as_mut(),
        Some(GEN3_MIN_GAIN),
        &gloam_io::ReadLog::off(),
    )
    .unwrap()
    .source;
    let opts = AgcOptions {
        fixed_gain: Some(GEN3_MIN_GAIN),
        ..Default::default()
    };
    agc_linearisation(g.as_mut(), s.as_mut(), &opts, Some(lut), &mut |_, _| {})
}

#[test]
fn a_lut_of_the_same_camera_over_the_agc_gains_linearises_to_the_true_radiance() {
    let r = agc(&lut(GEN3, &[GEN3_MIN_GAIN, 20.0, 25.0, 32.0])).unwrap();
    // The truth: aperture dimming with no list gives levels i/N of the
    // brightest, up the staircase and back down.
    let top = r.steps[LEVELS - 1].band_radiance_w_m2_sr;
    for s in &r.steps {
        let i = if s.step < LEVELS {
            s.step + 1
        } else {
            2 * LEVELS - 1 - s.step
        };
        let want = top * i as f64 / LEVELS as f64;
        assert!(
            (s.band_radiance_w_m2_sr / want - 1.0).abs() < 1e-12,
            "{s:?}"
        );
    }
    let (rms, max) = (
        r.linearised_rms_error_percent.unwrap(),
        r.linearised_max_error_percent.unwrap(),
    );
    println!(
        "AGC gains {:?}, LUT gains {:?}: linearised RMS {rms:.3} %, max {max:.3} % over {} frames",
        r.agc_gain_range, r.lut_gain_range, r.frames_linearised
    );
    // The AGC does visit several gains (else the LUT is not exercised).
    assert!(r.agc_gain_range[0] == GEN3_MIN_GAIN && r.agc_gain_range[1] > 25.0);
    assert_eq!(r.frames_outside_lut, 0);
    // Every settled frame: the last quarter of 60 frames, 9 steps.
    assert_eq!(r.frames_linearised, 9 * 15);
    // Per-frame residual: the frame mean's temporal noise (MCP excess
    // noise at low light) dominates; the fit and interpolation add < 0.3 %.
    assert!(rms < 1.5 && max < 3.5, "RMS {rms} %, max {max} %");
}

#[test]
fn a_lut_of_another_camera_is_refused_naming_both_cameras() {
    let foreign = lut("sim:scientific-ccd?size=64x64", &[1.0, 2.0, 4.0]);
    let e = agc(&foreign).unwrap_err();
    let m = e.to_string();
    println!("{m}");
    assert!(matches!(e, CalibError::LutNotForCamera { .. }), "{m}");
    assert!(m.contains("'simulated scientific-ccd'"), "{m}");
    assert!(m.contains("'simulated gen3-gaas-iccd'"), "{m}");
    assert!(m.contains("another camera"), "{m}");
}

#[test]
fn a_lut_of_another_bit_depth_is_refused() {
    let mut l = lut(GEN3, &[GEN3_MIN_GAIN, 32.0]);
    // As if made on the camera's 16-bit output.
    l.digitizer_max_dn = 65_535.0;
    let m = agc(&l).unwrap_err().to_string();
    println!("{m}");
    assert!(m.contains("top code is 65535 DN"), "{m}");
    assert!(m.contains("12-bit frames (top code 4095 DN)"), "{m}");
}

#[test]
fn a_lut_over_other_gains_is_refused_with_the_gains_the_agc_visited() {
    let e = agc(&lut(GEN3, &[40.0, 50.0])).unwrap_err();
    let m = e.to_string();
    println!("{m}");
    assert!(matches!(e, CalibError::LutNotForCamera { .. }), "{m}");
    assert!(m.contains("135 of 135 settled AGC frames"), "{m}");
    assert!(m.contains("calibrated gains 40–50"), "{m}");
    assert!(m.contains("the AGC visited 14.552–"), "{m}");
    // Round 12 of issue 46: one camera is not named as two, and no gain
    // runs to 17 digits.
    assert!(m.starts_with("this LUT of '"), "{m}");
    let longest = (m.split(|c: char| !(c.is_ascii_digit() || c == '.')))
        .map(str::len)
        .max()
        .unwrap_or(0);
    assert!(longest <= 10, "{m}");
}
