//! Applying a radiance LUT to a captured frame file: the frame's gain (as
//! recorded in `frames.jsonl` beside it, or given), and the checks that
//! the LUT was made for the camera and bit depth that took the frame — a
//! LUT from another camera would turn counts into wrong radiances silently.

use std::path::{Path, PathBuf};

use crate::error::CalibError;
use crate::radiance::Lut;

/// The file beside a capture's frames naming the camera that took them
/// ([`CameraRecord`]).
pub const CAMERA_FILE: &str = "camera.json";

/// [`CAMERA_FILE`]'s document: the grabber's description of the camera
/// and the URI it was opened with.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CameraRecord {
    /// `FrameGrabber::describe()`: what [`camera_identity`] compares.
    pub camera: String,
    /// The grabber URI (not needed to check a LUT).
    #[serde(default)]
    pub grabber: String,
}

/// Reads a `lut.json` written by the radiance flow and checks it
/// ([`Lut::check`]): a LUT whose numbers leave physics is refused at the
/// line holding the bad value, before it converts a count. `reads` notes
/// the file.
pub fn load_lut(path: &Path, reads: &gloam_io::ReadLog) -> Result<Lut, CalibError> {
    let text =
        gloam_io::read_text(path, gloam_io::MAX_TEXT_FILE_BYTES, reads).map_err(|source| {
            CalibError::Read {
                path: path.to_path_buf(),
                source,
            }
        })?;
    // A BOM (an editor's) is taken, as TOML and CSV take one: it was "not
    // a gloam LUT: expected value at line 1 column 1".
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let lut: Lut = serde_json::from_str(text).map_err(|source| CalibError::NotJson {
        path: path.to_path_buf(),
        what: "LUT",
        source,
    })?;
    lut.check().map_err(|p| CalibError::Line {
        path: path.to_path_buf(),
        line: p.line_in(text),
        message: format!("--lut: {p}"),
    })?;
    Ok(lut)
}

/// The camera in a grabber's description, without the scene, rig, seed or
/// firmware details: `simulated gen3 looking at rig …` → `simulated gen3`.
pub fn camera_identity(described: &str) -> &str {
    let cut = [" looking at ", " ("]
        .iter()
        .filter_map(|m| described.find(m))
        .min()
        .unwrap_or(described.len());
    described[..cut].trim()
}

fn frames_jsonl(frame: &Path) -> PathBuf {
    gloam_io::frames::beside(frame)
}

/// The gain to apply to `frame`: `given` when it agrees with the gain
/// recorded in `record` (its `frames.jsonl` line, see
/// [`crate::io::frame_record`]), else the recorded one; refuses a `given`
/// gain the record contradicts. `reads` notes a `frames.jsonl` read.
pub fn frame_gain(
    frame: &Path,
    given: Option<f64>,
    record: Option<&crate::io::FrameLine>,
    reads: &gloam_io::ReadLog,
) -> Result<f64, CalibError> {
    let recorded = record.and_then(|l| Some((l.line, l.number("gain")?)));
    match (given, recorded) {
        (Some(g), Some((line, r))) if (g - r).abs() > 1e-6 * r.abs().max(1e-12) => {
            Err(CalibError::GainMismatch {
                gain: g,
                recorded: r,
                frames_jsonl: frames_jsonl(frame),
                line,
                frame: frame.to_path_buf(),
            })
        }
        (Some(g), _) => Ok(g),
        (None, Some((_, r))) => Ok(r),
        (None, None) => crate::io::gain_from_frames_jsonl(frame, None, reads),
    }
}

/// Refuses a LUT made for another camera or bit depth than the frame's
/// (from [`CAMERA_FILE`] and `frames.jsonl` beside the frame), or a frame
/// holding counts above the LUT's digitizer maximum. What cannot be
/// checked (no record beside the frame) comes back as a warning.
pub fn check_lut_fits_frame(
    lut: &Lut,
    lut_path: &Path,
    frame: &Path,
    record: Option<&crate::io::FrameLine>,
    px: &[u16],
    reads: &gloam_io::ReadLog,
) -> Result<Option<String>, CalibError> {
    let dir = frame.parent().unwrap_or(Path::new("."));
    let cam_file = dir.join(CAMERA_FILE);
    let lut_camera = camera_identity(&lut.grabber);
    let mut unchecked = Vec::new();
    if cam_file.is_file() {
        let text = gloam_io::read_text(&cam_file, gloam_io::MAX_TEXT_FILE_BYTES, reads).map_err(
            |source| CalibError::Read {
                path: cam_file.clone(),
                source,
            },
        )?;
        let cam: CameraRecord =
            serde_json::from_str(&text).map_err(|source| CalibError::NotJson {
                path: cam_file.clone(),
                what: "camera record",
                source,
            })?;
        let camera = &cam.camera;
        if camera_identity(camera) != lut_camera {
            return Err(CalibError::LutCamera {
                lut: lut_path.to_path_buf(),
                lut_camera: lut_camera.to_string(),
                frame: frame.to_path_buf(),
                frame_camera: camera_identity(camera).to_string(),
                camera_file: cam_file,
            });
        }
    } else {
        unchecked.push("camera");
    }
    let lut_max = lut.digitizer_max_dn;
    match record.and_then(|l| Some((l.line, l.get("bits")?.as_u64()?))) {
        Some((line, bits)) if lut_max > 0.0 => {
            let frame_max = 2f64.powi(bits.min(32) as i32) - 1.0;
            if frame_max != lut_max {
                return Err(CalibError::LutBitDepth {
                    lut: lut_path.to_path_buf(),
                    lut_max_dn: lut_max,
                    frames_jsonl: frames_jsonl(frame),
                    line,
                    frame: frame.to_path_buf(),
                    bits,
                    frame_max_dn: frame_max,
                });
            }
        }
        _ => unchecked.push("bit depth"),
    }
    if lut_max > 0.0
        && let Some(&top) = px.iter().max()
        && f64::from(top) > lut_max
    {
        return Err(CalibError::CountsAboveLut {
            frame: frame.to_path_buf(),
            top_dn: top,
            lut_max_dn: lut_max,
            lut: lut_path.to_path_buf(),
        });
    }
    Ok((!unchecked.is_empty()).then(|| {
        format!(
            "{}: no {} beside it, so its {} cannot be checked against {}",
            frame.display(),
            if record.is_none() {
                "frames.jsonl line or camera.json"
            } else {
                "camera.json"
            },
            unchecked.join(" and "),
            lut_path.display()
        )
    }))
}

/// What `--gains` a LUT for a camera must span, said before the camera's
/// gains are known.
const GAINS_OF_THE_RUN: &str = "gains spanning the ones the frames are taken at";

/// Refuses a LUT made on another camera than `described` (a grabber's
/// [`describe`](gloam_grabber::FrameGrabber::describe)) or for another
/// digitizer than `bits` deep: a LUT only converts the counts of the camera
/// and bit depth it was made on.
pub fn check_lut_fits_camera(lut: &Lut, described: &str, bits: u8) -> Result<(), CalibError> {
    let (lut_camera, camera) = (camera_identity(&lut.grabber), camera_identity(described));
    let refuse = |reason: String| CalibError::LutNotForCamera {
        lut_camera: lut_camera.to_string(),
        camera: camera.to_string(),
        reason,
        gains: GAINS_OF_THE_RUN.into(),
    };
    if lut_camera != camera {
        return Err(refuse(
            "it was made on another camera, whose counts mean other radiances".into(),
        ));
    }
    let top = 2f64.powi(i32::from(bits.min(32))) - 1.0;
    if lut.digitizer_max_dn > 0.0 && lut.digitizer_max_dn != top {
        return Err(refuse(format!(
            "it is for a digitizer whose top code is {} DN, but the camera delivers {bits}-bit frames (top code {top} DN)",
            lut.digitizer_max_dn
        )));
    }
    Ok(())
}

/// The LUT's gains as messages print them (`40–50`, or `none`).
pub(crate) fn lut_gains_text(lut: &Lut) -> String {
    lut_gain_range(lut).map_or("none".into(), |(a, b)| {
        format!(
            "{}–{}",
            crate::error::gain_text(a),
            crate::error::gain_text(b)
        )
    })
}

/// The lowest and highest gain a LUT was calibrated at (`None`: no gains).
pub fn lut_gain_range(lut: &Lut) -> Option<(f64, f64)> {
    let g = lut.gains.iter().map(|c| c.gain);
    let lo = g.clone().fold(f64::INFINITY, f64::min);
    let hi = g.fold(f64::NEG_INFINITY, f64::max);
    (lo <= hi).then_some((lo, hi))
}

/// What [`apply_lut_file`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Applied {
    pub width: usize,
    pub height: usize,
    pub gain: f64,
    /// Saturated pixels, set to NaN.
    pub saturated_pixels: usize,
}

/// Turns the digital-count image `input` into the radiance image `output`
/// (32-bit float TIFF, W m⁻² sr⁻¹, saturated pixels NaN) through the LUT
/// at `lut_path`, at `gain` or the gain recorded beside the frame. What
/// cannot be checked (see [`check_lut_fits_frame`]) goes to `warn` before
/// the LUT is applied, so it is said even when applying then fails.
pub fn apply_lut_file(
    lut_path: &Path,
    input: &Path,
    output: &Path,
    gain: Option<f64>,
    warn: &mut dyn FnMut(&str),
) -> Result<Applied, CalibError> {
    apply_lut_to_frame(lut_path, input, None, output, gain, warn)
}

/// [`apply_lut_file`] on any frame file gloam writes (`--frame-format
/// png|fits|tiff`): PNG, FITS, or page `page` of a TIFF stack
/// (`frames.tiff`; its `frames.jsonl` line is the one whose
/// `stored.page` is `page`, and its samples are shifted back by that
/// line's `stored.sample_shift`). A TIFF of more than one page must be
/// given its page.
pub fn apply_lut_to_frame(
    lut_path: &Path,
    input: &Path,
    page: Option<u64>,
    output: &Path,
    gain: Option<f64>,
    warn: &mut dyn FnMut(&str),
) -> Result<Applied, CalibError> {
    let dir = input.parent().unwrap_or(Path::new("."));
    crate::report::refuse_output_over_inputs(
        "OUTPUT",
        output,
        &[
            ("INPUT", input),
            ("--lut", lut_path),
            ("INPUT's", &dir.join("frames.jsonl")),
            ("INPUT's", &dir.join(CAMERA_FILE)),
        ],
    )?;
    // Nothing gloam did not create is replaced: an existing OUTPUT must be
    // a radiance image this command wrote (links, directories and devices
    // are refused when writing).
    if std::fs::symlink_metadata(output).is_ok_and(|m| m.is_file())
        && crate::io::tiff_description(output).as_deref() != Some(crate::io::APPLIED_DESCRIPTION)
    {
        return Err(CalibError::Usage(format!(
            "OUTPUT {}: exists and is not a radiance image `gloam calibrate apply` wrote; gloam replaces only what it created — remove it or choose another path",
            output.display()
        )));
    }
    // One image out and no manifest: nothing lists what apply read.
    let reads = gloam_io::ReadLog::off();
    let lut = load_lut(lut_path, &reads)?;
    let record = crate::io::frame_record(input, page, &reads)?;
    if let (Some(p), None) = (page, &record) {
        // Without a frames.jsonl beside the image there is no record to
        // miss a line: the record itself is what is missing.
        if !frames_jsonl(input).exists() {
            return Err(CalibError::file(
                input,
                format!(
                    "--page {p}: no frames.jsonl beside it, so no record of its pages' gains and scale; --page applies a page of a stack `gloam capture` wrote (a single image: leave --page out)"
                ),
            ));
        }
        return Err(CalibError::file(
            frames_jsonl(input),
            format!(
                "no line for page {p} of {} (a TIFF stack's page is applied with its recorded gain and scale)",
                input.display()
            ),
        ));
    }
    let at = crate::io::StoredAt {
        page,
        ..record
            .as_ref()
            .map(crate::io::FrameLine::stored)
            .unwrap_or_default()
    };
    let (w, h, px) = crate::io::read_frame_counts(input, &at, &reads)?;
    if let Some(l) = &record {
        crate::io::check_record_fits_frame(input, &frames_jsonl(input), l, w, h)?;
    }
    // The counts first: a frame that is not the one its line records (a
    // renamed or altered file) must not be given that line's gain.
    if let Some(l) = &record
        && !crate::io::check_frame_crc(input, &frames_jsonl(input), l, &px)?
    {
        warn(&format!(
            "{}:{} records no pixels_crc32c for {}, so the frame cannot be checked against its capture",
            frames_jsonl(input).display(),
            l.line,
            input.display()
        ));
    }
    let gain = frame_gain(input, gain, record.as_ref(), &reads)?;
    if let Some(w) = check_lut_fits_frame(&lut, lut_path, input, record.as_ref(), &px, &reads)? {
        warn(&w);
    }
    let out = lut.apply(gain, &px)?;
    crate::io::write_tiff_f32_described(output, w, h, &out, crate::io::APPLIED_DESCRIPTION)?;
    Ok(Applied {
        width: w,
        height: h,
        gain,
        saturated_pixels: out.iter().filter(|v| v.is_nan()).count(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_identity_drops_scene_and_details() {
        assert_eq!(
            camera_identity("simulated gen3 looking at rig sine (seed 3)"),
            "simulated gen3"
        );
        assert_eq!(camera_identity("serial cam (fw 1.2)"), "serial cam");
        assert_eq!(camera_identity(" plain "), "plain");
    }

    /// A directory with a LUT over gains 1 and 2 and two 2×2 frames,
    /// `a.png` at gain 1 and `b.png` at gain 2, recorded with their CRCs.
    fn bench() -> (tempfile::TempDir, [u32; 2]) {
        let d = tempfile::tempdir().unwrap();
        let px = [vec![1u16, 2, 3, 4], vec![5u16, 6, 7, 8]];
        let crc = [
            gloam_grabber::pixels_crc32c(&px[0]),
            gloam_grabber::pixels_crc32c(&px[1]),
        ];
        let mut jl = String::new();
        for (i, name) in ["a.png", "b.png"].iter().enumerate() {
            image::ImageBuffer::<image::Luma<u16>, _>::from_raw(2, 2, px[i].clone())
                .unwrap()
                .save(d.path().join(name))
                .unwrap();
            jl += &format!(
                "{{\"file\":\"{name}\",\"gain\":{},\"pixels_crc32c\":{}}}\n",
                i + 1,
                crc[i]
            );
        }
        std::fs::write(d.path().join("frames.jsonl"), jl).unwrap();
        let gain = |g: f64| {
            serde_json::json!({"gain": g, "g_w_m2_sr_per_dn": 1e-6 / g, "b_w_m2_sr": 0.0,
                "r_squared": 1.0, "fit_range_dn": [0.0, 100.0], "dark_dn": 0.0, "dark_std_dn": 1.0,
                "saturation_dn": null, "n_fit_points": 3, "max_abs_residual_percent": 0.0,
                "levels": [], "warnings": []})
        };
        let lut = serde_json::json!({"grabber": "simulated x", "source": "s", "band_nm": [400.0, 900.0],
            "digitizer_max_dn": 65535.0, "gains": [gain(1.0), gain(2.0)]});
        std::fs::write(
            d.path().join("lut.json"),
            serde_json::to_string_pretty(&lut).unwrap(),
        )
        .unwrap();
        (d, crc)
    }

    #[test]
    fn a_frame_that_is_not_the_one_recorded_is_refused_by_its_crc() {
        let (d, crc) = bench();
        let p = |n: &str| d.path().join(n);
        let apply = |frame: &str| {
            apply_lut_file(&p("lut.json"), &p(frame), &p("o.tiff"), None, &mut |_| {})
        };
        assert_eq!(apply("a.png").unwrap().gain, 1.0);
        assert_eq!(apply("b.png").unwrap().gain, 2.0);
        // The gain-1 frame renamed to the gain-2 frame's name.
        std::fs::copy(p("a.png"), p("b.png")).unwrap();
        let e = apply("b.png").unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: its counts have CRC-32C {:#010x}, but {}:2 records {:#010x} for it; the frame was altered or is another frame's file under its name (another gain's?), so its recorded gain and settings are not its own",
                p("b.png").display(),
                crc[0],
                p("frames.jsonl").display(),
                crc[1]
            )
        );
        // A CRC that is not one is named at its line.
        std::fs::write(
            p("frames.jsonl"),
            "{\"file\":\"a.png\",\"gain\":1,\"pixels_crc32c\":-1}\n",
        )
        .unwrap();
        let e = apply("a.png").unwrap_err().to_string();
        assert!(
            e.contains("frames.jsonl:1: \"pixels_crc32c\" -1 is not a CRC-32C"),
            "{e}"
        );
        // A line without a CRC cannot be checked: said, not refused.
        std::fs::write(p("frames.jsonl"), "{\"file\":\"a.png\",\"gain\":1}\n").unwrap();
        let mut warned = Vec::new();
        apply_lut_file(&p("lut.json"), &p("a.png"), &p("o.tiff"), None, &mut |w| {
            warned.push(w.to_string())
        })
        .unwrap();
        assert!(
            warned
                .iter()
                .any(|w| w.contains("records no pixels_crc32c")),
            "{warned:?}"
        );
    }

    #[test]
    fn an_output_that_is_an_input_is_refused_however_spelled() {
        let (d, _) = bench();
        let p = |n: &str| d.path().join(n);
        std::fs::create_dir(p("sub")).unwrap();
        std::os::unix::fs::symlink(p("lut.json"), p("link.tiff")).unwrap();
        std::fs::hard_link(p("a.png"), p("hard.tiff")).unwrap();
        let before: Vec<Vec<u8>> = ["a.png", "lut.json", "frames.jsonl"]
            .iter()
            .map(|n| std::fs::read(p(n)).unwrap())
            .collect();
        for (out, flag, input) in [
            ("a.png", "INPUT", "a.png"),
            ("lut.json", "--lut", "lut.json"),
            ("sub/../a.png", "INPUT", "a.png"),
            ("./sub/../lut.json", "--lut", "lut.json"),
            ("link.tiff", "--lut", "lut.json"),
            ("hard.tiff", "INPUT", "a.png"),
            ("frames.jsonl", "INPUT's", "frames.jsonl"),
        ] {
            let e = apply_lut_file(&p("lut.json"), &p("a.png"), &p(out), None, &mut |_| {})
                .unwrap_err()
                .to_string();
            assert_eq!(
                e,
                format!(
                    "OUTPUT {}: is the same file as {flag} {}; gloam never writes over its own inputs — choose another output",
                    p(out).display(),
                    p(input).display()
                ),
                "{out}"
            );
        }
        let after: Vec<Vec<u8>> = ["a.png", "lut.json", "frames.jsonl"]
            .iter()
            .map(|n| std::fs::read(p(n)).unwrap())
            .collect();
        assert_eq!(before, after);
        // Beside the input is where outputs go, and what apply wrote it
        // may replace.
        let apply =
            |out: &str| apply_lut_file(&p("lut.json"), &p("a.png"), &p(out), None, &mut |_| {});
        apply("sub/../o.tiff").unwrap();
        apply("o.tiff").unwrap();
        // Anything else already there is not its to replace: a user's file,
        // or a TIFF it did not write.
        std::fs::write(p("notes.tiff"), "mine").unwrap();
        crate::io::write_tiff_f32(&p("other.tiff"), 2, 2, &[0.0; 4]).unwrap();
        for out in ["notes.tiff", "other.tiff"] {
            let before = std::fs::read(p(out)).unwrap();
            let e = apply(out).unwrap_err().to_string();
            assert_eq!(
                e,
                format!(
                    "OUTPUT {}: exists and is not a radiance image `gloam calibrate apply` wrote; gloam replaces only what it created — remove it or choose another path",
                    p(out).display()
                )
            );
            assert_eq!(std::fs::read(p(out)).unwrap(), before);
        }
    }

    #[test]
    fn a_given_gain_must_agree_with_the_record() {
        let rec = crate::io::FrameLine {
            line: 3,
            value: serde_json::json!({"file": "f.png", "gain": 20.0}),
        };
        let f = Path::new("d/f.png");
        assert_eq!(
            frame_gain(f, None, Some(&rec), &gloam_io::ReadLog::off()).unwrap(),
            20.0
        );
        assert_eq!(
            frame_gain(f, Some(20.0), Some(&rec), &gloam_io::ReadLog::off()).unwrap(),
            20.0
        );
        let e = frame_gain(f, Some(10.0), Some(&rec), &gloam_io::ReadLog::off()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--gain 10: d/frames.jsonl:3 records gain 20 for d/f.png; the frame was not taken at gain 10 (omit --gain to use the recorded gain)"
        );
    }
}
