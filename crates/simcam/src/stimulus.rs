//! The calibration rigs and stimuli as radiance: what the simulated camera
//! looks at when it is not looking at a traced scene.

use ndarray::Array2;

use crate::uri::RIGS;
use gloam_grabber::{GrabError, Stimulus};
use gloam_spectra::Spectrum;

/// Default rig image size (pixels): small enough for quick serial tests
/// (153 600 bytes per 16-bit frame, 0.5 s at 3 Mbaud).
pub const DEFAULT_RIG_SIZE: (u32, u32) = (320, 240);

/// Default lamp spectrum of the rigs.
pub const DEFAULT_SPECTRUM: &str = "cie-a";

/// The stimulus of a built-in rig at mean band radiance `level`.
pub fn rig_stimulus(rig: &str, level_w_m2_sr: f64) -> Result<Stimulus, GrabError> {
    let spectrum = DEFAULT_SPECTRUM.to_string();
    Ok(match rig {
        "uniform" => Stimulus::Uniform {
            radiance_w_m2_sr: level_w_m2_sr,
            spectrum,
        },
        "sine" => Stimulus::Sine {
            mean_radiance_w_m2_sr: level_w_m2_sr,
            modulation: 0.8,
            cycles_per_pixel: 0.05,
            angle_deg: 5.0,
            spectrum,
        },
        "edge" => Stimulus::Edge {
            dark_radiance_w_m2_sr: level_w_m2_sr * 2.0 / 11.0,
            bright_radiance_w_m2_sr: level_w_m2_sr * 20.0 / 11.0,
            angle_deg: 5.0,
            spectrum,
        },
        "dark" => Stimulus::Dark,
        other => {
            return Err(GrabError::InvalidSetting(format!(
                "unknown rig '{other}' (known: {})",
                RIGS.iter().map(|r| r.0).collect::<Vec<_>>().join(", ")
            )));
        }
    })
}

/// Band radiance image (row × column, W m⁻² sr⁻¹ over 400–1000 nm) of a
/// stimulus, and its relative spectrum restricted to that band.
pub fn render_stimulus(
    stimulus: &Stimulus,
    width: u32,
    height: u32,
) -> Result<(Array2<f64>, Spectrum), GrabError> {
    let (w, h) = (width as usize, height as usize);
    let spectrum_name = match stimulus {
        Stimulus::Dark => DEFAULT_SPECTRUM,
        Stimulus::Uniform { spectrum, .. }
        | Stimulus::Sine { spectrum, .. }
        | Stimulus::Edge { spectrum, .. } => spectrum.as_str(),
    };
    // Unlogged: a stimulus's spectrum file was noted when the source file
    // naming it was read (`gloam_calib::source`).
    let lamp = gloam_spectra::lookup(spectrum_name, &gloam_io::ReadLog::off())
        .map_err(|e| GrabError::InvalidSetting(format!("stimulus spectrum: {e}")))?;
    let window =
        Spectrum::constant(400.0, 1000.0, 1.0).map_err(|e| GrabError::CameraModel(Box::new(e)))?;
    let shape = lamp.product(&window);
    let bad = |what: &str, v: f64| {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(GrabError::InvalidSetting(format!(
                "{what} = {v}: must be finite and ≥ 0"
            )))
        }
    };
    let img = match stimulus {
        Stimulus::Dark => Array2::zeros((h, w)),
        Stimulus::Uniform {
            radiance_w_m2_sr, ..
        } => {
            bad("radiance_w_m2_sr", *radiance_w_m2_sr)?;
            Array2::from_elem((h, w), *radiance_w_m2_sr)
        }
        Stimulus::Sine {
            mean_radiance_w_m2_sr,
            modulation,
            cycles_per_pixel,
            angle_deg,
            ..
        } => {
            bad("mean_radiance_w_m2_sr", *mean_radiance_w_m2_sr)?;
            if !(0.0..=1.0).contains(modulation) {
                return Err(GrabError::InvalidSetting(format!(
                    "modulation {modulation} must lie in 0..=1"
                )));
            }
            bad("cycles_per_pixel", *cycles_per_pixel)?;
            let a = angle_deg.to_radians();
            let (c, s) = (a.cos(), a.sin());
            Array2::from_shape_fn((h, w), |(r, col)| {
                let xp = col as f64 * c + r as f64 * s;
                mean_radiance_w_m2_sr
                    * (1.0 + modulation * (std::f64::consts::TAU * cycles_per_pixel * xp).cos())
            })
        }
        Stimulus::Edge {
            dark_radiance_w_m2_sr,
            bright_radiance_w_m2_sr,
            angle_deg,
            ..
        } => {
            bad("dark_radiance_w_m2_sr", *dark_radiance_w_m2_sr)?;
            bad("bright_radiance_w_m2_sr", *bright_radiance_w_m2_sr)?;
            let t = angle_deg.to_radians().tan();
            let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
            // Area-weighted coverage of each pixel (4×4 supersampling) so
            // the edge profile is well defined for MTF work.
            Array2::from_shape_fn((h, w), |(r, col)| {
                let mut bright = 0u32;
                for sy in 0..4 {
                    for sx in 0..4 {
                        let y = r as f64 + (f64::from(sy) + 0.5) / 4.0;
                        let x = col as f64 + (f64::from(sx) + 0.5) / 4.0;
                        if x - cx > (y - cy) * t {
                            bright += 1;
                        }
                    }
                }
                let f = f64::from(bright) / 16.0;
                dark_radiance_w_m2_sr * (1.0 - f) + bright_radiance_w_m2_sr * f
            })
        }
    };
    Ok((img, shape))
}
