//! A night that changes, through the camera: `gloam sequence`.
//!
//! The scene is rendered once into one detected-radiance layer per light
//! group (radiance is linear in each group's emission); frame `i` is the
//! layers mixed with the sequence file's weights for its exposure window
//! ([`gloam_scene::sequence`]), captured by one camera whose AGC, lag and
//! bright-source protection run across the frames at the sequence's frame
//! rate. Mixing costs one multiply-add per pixel and group, so a sequence
//! costs the layered render plus the camera's time per frame.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use gloam_scene::sequence::Sequence;
use ndarray::Array2;

use crate::frames::{CaptureError, FrameCapture, FrameContext, FrameWriter};

/// Why a sequence was not captured.
#[derive(Debug, thiserror::Error)]
pub enum SequenceError {
    #[error(transparent)]
    Scene(#[from] gloam_scene::SceneError),
    #[error(transparent)]
    Capture(#[from] CaptureError),
    #[error(
        "{} layers for {} light groups: the layered render and the scene disagree",
        layers,
        groups
    )]
    LayerCount { layers: usize, groups: usize },
    #[error("layer {index} is {got:?}, the first layer {want:?}: layers must share one image size")]
    LayerShape {
        index: usize,
        got: (usize, usize),
        want: (usize, usize),
    },
    #[error("writing the sequence's plot")]
    Plot(#[source] gloam_calib::CalibError),
}

/// `Σ_g w_g · layer_g` into `out` (resized to the layers' shape), summed in
/// group order in f64.
pub fn mix(layers: &[Array2<f64>], weights: &[f64], out: &mut Array2<f64>) {
    let Some(first) = layers.first() else {
        out.fill(0.0);
        return;
    };
    if out.dim() != first.dim() {
        *out = Array2::zeros(first.dim());
    }
    out.fill(0.0);
    for (layer, &w) in layers.iter().zip(weights) {
        if w == 0.0 {
            continue;
        }
        ndarray::Zip::from(&mut *out)
            .and(layer)
            .for_each(|o, &l| *o += w * l);
    }
}

/// One frame's place in the sequence (added to its `frames.jsonl` line).
#[derive(Clone, Debug, serde::Serialize)]
pub struct SequenceFrame {
    /// Start of the frame's exposure window, s from the sequence's start.
    pub time_s: f64,
    /// The window's length, s (the camera's exposure time).
    pub window_s: f64,
    /// Each light group's mean relative intensity over the window.
    pub light_groups: BTreeMap<String, f64>,
}

/// What a captured sequence tells its user and records.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SequenceReport {
    pub frames: u32,
    pub frame_rate_hz: f64,
    pub groups: Vec<String>,
    /// Wall time spent mixing layers, s (all frames).
    pub mix_s: f64,
    /// Wall time in the camera model and writing frames, s (all frames).
    pub camera_s: f64,
    /// The capture's `sensor_capture` (fit, per-frame levels, saturation).
    pub sensor_capture: serde_json::Value,
    #[serde(skip)]
    pub notes: Vec<String>,
    /// (time s, gain in effect) per frame: what `gain-over-time.png` draws.
    pub gain_over_time: Vec<(f64, f64)>,
}

/// Captures `sequence` from the layers (`groups[i]`'s detected radiance,
/// e⁻ s⁻¹ m⁻² sr⁻¹, is `layers[i]`) through `capture`'s camera into `out`:
/// the frames, `frames.jsonl` (each line with its `sequence` place),
/// `frames-preview.png` and `gain-over-time.png`.
pub fn capture_sequence(
    sequence: &Sequence,
    groups: &[String],
    layers: &[Array2<f64>],
    capture: &FrameCapture<'_>,
    out: &Path,
    context: FrameContext,
) -> Result<SequenceReport, SequenceError> {
    sequence.check_groups(groups.iter().map(String::as_str))?;
    if layers.len() != groups.len() {
        return Err(SequenceError::LayerCount {
            layers: layers.len(),
            groups: groups.len(),
        });
    }
    let want = layers.first().map_or((0, 0), Array2::dim);
    for (index, l) in layers.iter().enumerate() {
        if l.dim() != want {
            return Err(SequenceError::LayerShape {
                index,
                got: l.dim(),
                want,
            });
        }
    }
    let names = || groups.iter().map(String::as_str);
    // The camera runs at the sequence's frame rate; its exposure time is
    // each frame's window (clamped to the frame period).
    let window_s = RefCell::new(sequence.frame_period_s());
    let mut configure = |c: &mut gloam_sensor::SensorConfig| {
        c.timing.frame_rate_hz = sequence.frame_rate_hz;
        c.timing.exposure_s = c.timing.exposure_s.min(sequence.frame_period_s());
        *window_s.borrow_mut() = c.timing.exposure_s;
        Ok(())
    };
    let place = |i: u32| {
        let t0 = sequence.frame_start_s(i);
        let w = *window_s.borrow();
        let weights = sequence.weights(names(), t0, t0 + w);
        (t0, w, weights)
    };
    let mut first = Array2::zeros(want);
    {
        // The configured window is known once the camera is configured;
        // the fit judges frame 0 with the preset's exposure, as a lab
        // would set up on the opening scene.
        let mut c = gloam_sensor::load_preset_or_file(capture.sensor)
            .map_err(|source| crate::frames::CaptureOptionsError::Sensor {
                sensor: capture.sensor.to_string(),
                source,
            })
            .map_err(CaptureError::from)?;
        configure(&mut c)?;
        mix(layers, &place(0).2, &mut first);
    }
    let places: RefCell<Vec<SequenceFrame>> = RefCell::new(Vec::new());
    let mix_s = RefCell::new(0.0f64);
    let mut image = |i: u32| {
        let t = Instant::now();
        let (time_s, w, weights) = place(i);
        let mut img = Array2::zeros(want);
        mix(layers, &weights, &mut img);
        places.borrow_mut().push(SequenceFrame {
            time_s,
            window_s: w,
            light_groups: groups.iter().cloned().zip(weights).collect(),
        });
        *mix_s.borrow_mut() += t.elapsed().as_secs_f64();
        img
    };
    let mut writer = None;
    let mut gain_over_time = Vec::new();
    let t_capture = Instant::now();
    let captured =
        capture.capture_changing(&first, Some(&mut image), &mut configure, &mut |mut f| {
            let i = f.record.index as usize;
            if let Some(p) = places.borrow().get(i) {
                gain_over_time.push((p.time_s, f.record.gain));
                f.record.sequence = Some(p.clone());
            }
            let w = match &mut writer {
                Some(w) => w,
                None => writer.insert(FrameWriter::with_format(
                    out,
                    capture.frame_format,
                    context.clone(),
                )?),
            };
            Ok(w.write(&f.record, &f.pixels)?)
        })?;
    if let Some(w) = writer {
        w.finish().map_err(CaptureError::from)?;
    }
    let mix_s = *mix_s.borrow();
    let camera_s = t_capture.elapsed().as_secs_f64() - mix_s;
    gloam_calib::plot::xy_plot_scaled(
        &out.join("gain-over-time.png"),
        &format!(
            "gain in effect, {} frames at {} Hz ({})",
            sequence.frames, sequence.frame_rate_hz, capture.sensor
        ),
        ("time, s", gloam_calib::plot::Scale::Linear),
        ("gain in effect", gloam_calib::plot::Scale::Log10),
        &[gloam_calib::plot::Series::new(
            "gain",
            gain_over_time.clone(),
            gloam_calib::plot::Mark::Line,
        )],
    )
    .map_err(SequenceError::Plot)?;
    Ok(SequenceReport {
        frames: sequence.frames,
        frame_rate_hz: sequence.frame_rate_hz,
        groups: groups.to_vec(),
        mix_s,
        camera_s,
        sensor_capture: captured.report,
        notes: captured.notes,
        gain_over_time,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mixing_is_the_weighted_sum_in_f64() {
        let a = Array2::from_shape_fn((3, 4), |(r, c)| (r * 4 + c) as f64);
        let b = Array2::from_elem((3, 4), 0.5);
        let mut out = Array2::zeros((1, 1));
        mix(&[a.clone(), b.clone()], &[2.0, 4.0], &mut out);
        assert_eq!(out, &a * 2.0 + 2.0);
        mix(&[a.clone(), b], &[1.0, 0.0], &mut out);
        assert_eq!(out, a);
    }

    /// A street lamp switching on at 2 s over a moonlit ground: the Gen III
    /// camera's AGC (`time_constant_s = 0.5` in the preset) brings the gain
    /// down with the loop's first-order decay. The decay constant fitted
    /// to the gains in effect is the independent check (within 5 %).
    #[test]
    fn the_agc_answers_a_lamp_switching_on_with_its_time_constant() {
        let dir = tempfile::tempdir().unwrap();
        let seq = gloam_scene::sequence::parse_sequence(
            "scene = \"street.toml\"\nframe_rate_hz = 25\nframes = 125\n[groups.lamp]\nkeys = [[0, 0], [2, 0], [2, 1]]\n",
            &dir.path().join("seq.toml"),
        )
        .unwrap();
        let groups = vec!["moon".to_string(), "lamp".to_string()];
        let layers = vec![
            Array2::from_elem((36, 48), 1e12),
            Array2::from_elem((36, 48), 2e12),
        ];
        let capture = FrameCapture {
            sensor: "gen3-gaas-iccd",
            frames: seq.frames,
            gain: None,
            agc: true,
            noise: false,
            seed: 1,
            auto_exposure: None,
            frame_format: crate::FrameFormat::Png,
        };
        let r = capture_sequence(
            &seq,
            &groups,
            &layers,
            &capture,
            dir.path(),
            FrameContext {
                camera: None,
                seed: None,
                provenance: None,
            },
        )
        .unwrap();
        let g = &r.gain_over_time;
        assert_eq!(g.len(), 125);
        let on = g.iter().position(|&(t, _)| t >= 2.0).unwrap();
        let g_end = g.last().unwrap().1;
        // Before the lamp the loop had settled on the moonlit ground; after,
        // a third of that gain (the signal tripled).
        let before = g[on].1;
        assert!((before / g_end - 3.0).abs() < 0.15, "{before} → {g_end}");
        // ln g − ln g_∞ decays as e^{−t/τ}: fit τ over the decay's first
        // 95 % (the frames whose error is still > 5 % of its start).
        let y0 = (g[on + 1].1 / g_end).ln();
        let pts: Vec<(f64, f64)> = g[on + 1..]
            .iter()
            .map(|&(t, gain)| (t, (gain / g_end).ln()))
            .take_while(|&(_, y)| y > 0.05 * y0)
            .map(|(t, y)| (t, y.ln()))
            .collect();
        assert!(pts.len() >= 10, "{pts:?}");
        let n = pts.len() as f64;
        let (mx, my) = (
            pts.iter().map(|p| p.0).sum::<f64>() / n,
            pts.iter().map(|p| p.1).sum::<f64>() / n,
        );
        let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
            / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
        let tau = -1.0 / slope;
        eprintln!(
            "AGC after a lamp switched on: fitted τ = {tau:.4} s over {} frames (preset 0.5 s)",
            pts.len()
        );
        assert!((tau / 0.5 - 1.0).abs() < 0.05, "fitted τ = {tau} s");
        // Every frame's line says where it sits in the sequence.
        let text = std::fs::read_to_string(dir.path().join("frames.jsonl")).unwrap();
        let line: serde_json::Value = serde_json::from_str(text.lines().nth(on).unwrap()).unwrap();
        assert_eq!(line["sequence"]["light_groups"]["lamp"], 1.0);
        assert_eq!(line["sequence"]["light_groups"]["moon"], 1.0);
        assert!(dir.path().join("gain-over-time.png").is_file());
    }
}
