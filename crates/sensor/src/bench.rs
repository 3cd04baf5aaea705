//! Throughput measurement shared by the criterion bench and `gloam bench`.

use std::time::Instant;

use ndarray::Array2;

use crate::camera::Camera;
use crate::config::SensorConfig;
use crate::error::ConfigError;

/// Result of [`throughput`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct Throughput {
    pub preset: String,
    pub width: usize,
    pub height: usize,
    pub frames: usize,
    pub seconds: f64,
    pub frames_per_s: f64,
    pub threads: usize,
    /// Mean photoelectrons per pixel per frame of the test scene.
    pub mean_photoelectrons: f64,
}

/// A test scene: a starlit field (`level` photoelectrons/pixel/frame) with
/// a sine pattern and a bright lamp.
pub fn test_scene(width: usize, height: usize, level: f64) -> Array2<f64> {
    Array2::from_shape_fn((height, width), |(r, c)| {
        let x = c as f64 / width as f64;
        let mut v = level * (1.0 + 0.5 * (2.0 * std::f64::consts::PI * 40.0 * x).sin());
        let (dy, dx) = (
            r as f64 - height as f64 * 0.3,
            c as f64 - width as f64 * 0.7,
        );
        if dx * dx + dy * dy < 100.0 {
            v += 1e4;
        }
        v
    })
}

/// Times `frames` captures of the full chain of `preset` (noise and MTF on)
/// on a `width × height` test scene, after one warm-up frame.
pub fn throughput(
    preset: &str,
    width: usize,
    height: usize,
    frames: usize,
) -> Result<Throughput, ConfigError> {
    let mut cfg = SensorConfig::load_preset_or_file(preset)?;
    cfg.noise.enabled = true;
    let mut cam = Camera::new(cfg)?;
    let level = 2.0;
    let scene = test_scene(width, height, level);
    cam.capture_photoelectrons(scene.view())
        .expect("valid test scene");
    let t = Instant::now();
    for _ in 0..frames {
        cam.capture_photoelectrons(scene.view())
            .expect("valid test scene");
    }
    let seconds = t.elapsed().as_secs_f64();
    Ok(Throughput {
        preset: preset.to_string(),
        width,
        height,
        frames,
        seconds,
        frames_per_s: frames as f64 / seconds,
        threads: rayon::current_num_threads(),
        mean_photoelectrons: level,
    })
}
