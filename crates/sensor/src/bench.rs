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
    /// Median wall time of one frame, ms: robust to other work stealing
    /// the cores for part of the run.
    pub median_frame_ms: f64,
    /// 1000 / `median_frame_ms`.
    pub median_frames_per_s: f64,
    pub threads: usize,
    /// Mean photoelectrons per pixel per frame of the test scene.
    pub mean_photoelectrons: f64,
    /// Process CPU time over the timed frames (Linux `/proc/self/stat`), s.
    pub cpu_seconds: Option<f64>,
    /// Frames per CPU-second: on n dedicated cores expect up to n × this
    /// (the wall-clock figure drops when other work shares the cores).
    pub frames_per_cpu_s: Option<f64>,
}

/// User + system CPU time of this process, s (Linux only).
fn cpu_time_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are
    // fields 14 and 15 (1-based), in clock ticks (100 Hz on Linux).
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ut: f64 = f.get(11)?.parse().ok()?;
    let st: f64 = f.get(12)?.parse().ok()?;
    Some((ut + st) / 100.0)
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
/// on a `width × height` test scene of 2 photoelectrons/pixel/frame (a
/// heavy case for an ICCD: every pixel draws gain noise), after one
/// warm-up frame.
pub fn throughput(
    preset: &str,
    width: usize,
    height: usize,
    frames: usize,
) -> Result<Throughput, ConfigError> {
    throughput_at(preset, width, height, frames, 2.0)
}

/// [`throughput`] at a chosen scene level, photoelectrons/pixel/frame
/// (0.3 is a starlit scene at the Gen III preset's AGC set-point).
pub fn throughput_at(
    preset: &str,
    width: usize,
    height: usize,
    frames: usize,
    level: f64,
) -> Result<Throughput, ConfigError> {
    // A timing, not a run whose inputs are recorded.
    let mut cfg = SensorConfig::load_preset_or_file(preset, &gloam_io::ReadLog::off())?;
    cfg.noise.enabled = true;
    let mut cam = Camera::new(cfg)?;
    let scene = test_scene(width, height, level);
    cam.capture_photoelectrons(scene.view())
        .expect("valid test scene");
    let cpu0 = cpu_time_s();
    let t = Instant::now();
    let mut frame_s = Vec::with_capacity(frames);
    for _ in 0..frames {
        let t_frame = Instant::now();
        cam.capture_photoelectrons(scene.view())
            .expect("valid test scene");
        frame_s.push(t_frame.elapsed().as_secs_f64());
    }
    let seconds = t.elapsed().as_secs_f64();
    frame_s.sort_by(f64::total_cmp);
    let median_frame_s = frame_s.get(frames / 2).copied().unwrap_or(f64::NAN);
    let cpu_seconds = match (cpu0, cpu_time_s()) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    Ok(Throughput {
        preset: preset.to_string(),
        width,
        height,
        frames,
        seconds,
        frames_per_s: frames as f64 / seconds,
        median_frame_ms: median_frame_s * 1e3,
        median_frames_per_s: 1.0 / median_frame_s,
        threads: rayon::current_num_threads(),
        mean_photoelectrons: level,
        cpu_seconds,
        frames_per_cpu_s: cpu_seconds.filter(|&c| c > 0.0).map(|c| frames as f64 / c),
    })
}
