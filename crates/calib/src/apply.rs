//! Applying a radiance LUT to a captured frame file: the frame's gain (as
//! recorded in `frames.jsonl` beside it, or given), and the checks that
//! the LUT was made for the camera and bit depth that took the frame — a
//! LUT from another camera would turn counts into wrong radiances silently.

use std::path::{Path, PathBuf};

use crate::error::CalibError;
use crate::radiance::Lut;

/// The file beside a capture's frames naming the camera that took them
/// (`{"camera": describe(), "grabber": uri}`).
pub const CAMERA_FILE: &str = "camera.json";

/// Reads a `lut.json` written by the radiance flow and checks it
/// ([`Lut::check`]): a LUT whose numbers leave physics is refused at the
/// line holding the bad value, before it converts a count.
pub fn load_lut(path: &Path) -> Result<Lut, CalibError> {
    let text = gloam_spectra::input::read_text(path, gloam_spectra::input::MAX_TEXT_FILE_BYTES)
        .map_err(|source| CalibError::Read {
            path: path.to_path_buf(),
            source,
        })?;
    let lut: Lut = serde_json::from_str(&text).map_err(|source| CalibError::NotJson {
        path: path.to_path_buf(),
        what: "LUT",
        source,
    })?;
    lut.check().map_err(|p| CalibError::Line {
        path: path.to_path_buf(),
        line: p.line_in(&text),
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
    frame
        .parent()
        .unwrap_or(Path::new("."))
        .join("frames.jsonl")
}

/// The gain to apply to `frame`: `given` when it agrees with the gain
/// recorded in `record` (its `frames.jsonl` line, see
/// [`crate::io::frame_record`]), else the recorded one; refuses a `given`
/// gain the record contradicts.
pub fn frame_gain(
    frame: &Path,
    given: Option<f64>,
    record: Option<&(usize, serde_json::Value)>,
) -> Result<f64, CalibError> {
    let recorded = record.and_then(|(line, v)| Some((*line, v.get("gain")?.as_f64()?)));
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
        (None, None) => crate::io::gain_from_frames_jsonl(frame),
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
    record: Option<&(usize, serde_json::Value)>,
    px: &[u16],
) -> Result<Option<String>, CalibError> {
    let dir = frame.parent().unwrap_or(Path::new("."));
    let cam_file = dir.join(CAMERA_FILE);
    let lut_camera = camera_identity(&lut.grabber);
    let mut unchecked = Vec::new();
    if cam_file.is_file() {
        let text =
            gloam_spectra::input::read_text(&cam_file, gloam_spectra::input::MAX_TEXT_FILE_BYTES)
                .map_err(|source| CalibError::Read {
                path: cam_file.clone(),
                source,
            })?;
        let v: serde_json::Value =
            serde_json::from_str(&text).map_err(|source| CalibError::NotJson {
                path: cam_file.clone(),
                what: "camera record",
                source,
            })?;
        let camera = v
            .get("camera")
            .and_then(|c| c.as_str())
            .ok_or_else(|| CalibError::file(&cam_file, "no \"camera\""))?;
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
    match record.and_then(|(line, v)| Some((*line, v.get("bits")?.as_u64()?))) {
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
    let lut = load_lut(lut_path)?;
    let record = crate::io::frame_record(input)?;
    let gain = frame_gain(input, gain, record.as_ref())?;
    let (w, h, px) = crate::io::read_counts(input)?;
    if let Some(w) = check_lut_fits_frame(&lut, lut_path, input, record.as_ref(), &px)? {
        warn(&w);
    }
    let out = lut.apply(gain, &px)?;
    crate::io::write_tiff_f32(output, w, h, &out)?;
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

    #[test]
    fn a_given_gain_must_agree_with_the_record() {
        let rec = (3, serde_json::json!({"file": "f.png", "gain": 20.0}));
        let f = Path::new("d/f.png");
        assert_eq!(frame_gain(f, None, Some(&rec)).unwrap(), 20.0);
        assert_eq!(frame_gain(f, Some(20.0), Some(&rec)).unwrap(), 20.0);
        let e = frame_gain(f, Some(10.0), Some(&rec)).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--gain 10: d/frames.jsonl:3 records gain 20 for d/f.png; the frame was not taken at gain 10 (omit --gain to use the recorded gain)"
        );
    }
}
