//! `gloam calibrate …` / `gloam scope` and Python's `calibrate_radiance`,
//! `photon_transfer`, `agc_linearity`, `mtf` and `scope` make one request
//! each (gloam-calib's `request.rs`) and refuse a bad one with one
//! message: for one bad input per flow, the CLI's `error: …` line is word
//! for word the message of the request as python/src/calib.rs builds it.
//! (python/tests/test_requests.py checks the same through the Python
//! package itself.)

use std::path::PathBuf;
use std::process::Command;

use gloam_calib::mtf_flow::{DEFAULT_MODULATION, DEFAULT_SPECTRUM, GrabberTarget, MtfRequest};
use gloam_calib::request::{
    AgcRequest, MtfCalibration, PtcRequest, RadianceRequest, ScopeRequest, SourceRequest,
};

const SOURCE: &str = "sims/calibration/sphere.toml";
const CAM: &str = "sim:scientific-ccd?size=32x32";

/// The CLI's stderr for `args`, which must be refused.
fn cli_error(args: &[&str]) -> String {
    let out = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_gloam"))
        .args(args)
        .arg("--out")
        .arg(out.path().join("o"))
        .output()
        .expect("run gloam");
    assert!(!o.status.success(), "{args:?} was accepted");
    // Refused before the output set opened.
    assert!(!out.path().join("o").exists(), "{args:?} left an output");
    String::from_utf8_lossy(&o.stderr).trim_end().to_string()
}

fn source(levels: Option<usize>) -> SourceRequest {
    SourceRequest {
        source: PathBuf::from(SOURCE),
        levels,
        auto_range: None,
    }
}

#[test]
fn each_calibration_flow_refuses_a_bad_input_with_one_message_from_both_front_ends() {
    let cases: Vec<(&[&str], Result<(), gloam_calib::CalibError>)> = vec![
        (
            &[
                "calibrate",
                "radiance",
                "--grabber",
                CAM,
                "--source",
                SOURCE,
                "--gains",
                "1,-2",
            ],
            // `calibrate_radiance(g, source, gains=[1, -2])`
            RadianceRequest {
                source: source(None),
                gains: vec![1.0, -2.0],
                frames: gloam_calib::radiance::DEFAULT_FRAMES,
                exposure_s: None,
            }
            .validate(),
        ),
        (
            &[
                "calibrate",
                "ptc",
                "--grabber",
                CAM,
                "--source",
                SOURCE,
                "--gain",
                "-1",
            ],
            // `photon_transfer(g, source, gain=-1)`
            PtcRequest {
                source: source(Some(gloam_calib::ptc::DEFAULT_LEVELS)),
                grabber: CAM.into(),
                gain: -1.0,
                spatial_frames: gloam_calib::ptc::DEFAULT_SPATIAL_FRAMES,
                exposure_s: None,
                dataset_dir: None,
            }
            .validate(),
        ),
        (
            &[
                "calibrate",
                "agc",
                "--grabber",
                CAM,
                "--source",
                SOURCE,
                "--fixed-gain",
                "0",
            ],
            // `agc_linearity(g, source, fixed_gain=0)`
            AgcRequest {
                source: source(None),
                fixed_gain: Some(0.0),
                frames: gloam_calib::agc::DEFAULT_FRAMES_PER_STEP,
                lut: None,
                allow_unsettled: false,
            }
            .validate(),
        ),
        (
            &[
                "calibrate",
                "mtf",
                "--target",
                "sine",
                "--grabber",
                CAM,
                "--frequencies",
                "0.1,0.7",
            ],
            // `mtf(g, target="sine", frequencies=[0.1, 0.7])`
            MtfCalibration {
                mtf: MtfRequest {
                    target: GrabberTarget::Sine,
                    gain: None,
                    radiance_w_m2_sr: None,
                    modulation: DEFAULT_MODULATION,
                    angle_deg: None,
                    frequencies_cy_per_px: vec![0.1, 0.7],
                    frames: gloam_calib::mtf_flow::DEFAULT_FRAMES,
                    spectrum: DEFAULT_SPECTRUM.into(),
                },
                voltage: None,
            }
            .validate(),
        ),
        (
            &["scope"],
            // `scope()`
            ScopeRequest {
                frequency_cy_per_px: 0.05,
                level_fraction: 0.4,
                frames: 1,
                ..ScopeRequest::default()
            }
            .validate()
            .map(|_| ()),
        ),
    ];
    for (args, request) in cases {
        let python = request.expect_err("the request refuses it").to_string();
        assert_eq!(cli_error(args), format!("error: {python}"), "{args:?}");
    }
}

/// The messages say what is wrong and with which value: checked against
/// the values given, not only for equality between the front ends.
#[test]
fn the_refusals_name_the_flag_and_the_value() {
    let radiance = cli_error(&[
        "calibrate",
        "radiance",
        "--grabber",
        CAM,
        "--source",
        SOURCE,
        "--gains",
        "1,-2",
    ]);
    assert_eq!(
        radiance,
        "error: --gains: -2 is not a gain (each must be a finite number > 0)"
    );
    let scope = cli_error(&["scope"]);
    assert_eq!(
        scope,
        "error: give --sensor PRESET_OR_FILE or --grabber sim:…"
    );
}
