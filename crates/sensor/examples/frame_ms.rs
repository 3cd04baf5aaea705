//! `cargo run --release -p gloam-sensor --example frame_ms [PRESET] [FRAMES] [LAYERS.npy]`
//!
//! Per-frame wall time of the camera chain (AGC on, noise on) as a live
//! device or `gloam sequence` runs it: median and quartiles over FRAMES
//! (default 60) frames at 640 × 480 and 1024 × 768, on the bench's test
//! scene (a starlit field, 0.5 photoelectrons/pixel/frame, with a lamp:
//! a bright source in view). With LAYERS.npy (a `gloam sequence`
//! `layers.npy`, radiance W m⁻² sr⁻¹ per light group), the sum of its
//! layers at the size it was rendered instead, through a flat 400–700 nm
//! band. Compare two builds by running both alternately: the wall times
//! depend on whatever else the cores are doing; the CPU time per frame
//! (all threads) much less.

use std::time::Instant;

/// User + system CPU time of this process, s (Linux; fields 14 and 15 of
/// `/proc/self/stat`, in 100 Hz ticks): robust to other work on the cores.
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let rest = stat.rfind(')').map_or("", |i| &stat[i + 2..]);
    let f: Vec<f64> = rest
        .split_whitespace()
        .map(|v| v.parse().unwrap_or(f64::NAN))
        .collect();
    (f.get(11).copied().unwrap_or(f64::NAN) + f.get(12).copied().unwrap_or(f64::NAN)) / 100.0
}

use gloam_sensor::{Camera, SensorConfig, bench::test_scene};
use gloam_spectra::Spectrum;
use ndarray::{Array2, ArrayD, Axis, Ix2};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = args.get(1).map_or("gen2-s20-iccd", |s| s.as_str());
    let frames: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(60);
    let scenes: Vec<(String, Array2<f64>, bool)> = match args.get(3) {
        Some(path) => {
            let a: ArrayD<f64> = ndarray_npy::read_npy(path).expect("a float64 .npy");
            let mut a = a;
            while a.ndim() > 2 {
                a = a.sum_axis(Axis(0));
            }
            let img = a.into_dimensionality::<Ix2>().expect("2-D");
            vec![(path.clone(), img, true)]
        }
        None => [(640, 480), (1024, 768)]
            .into_iter()
            .map(|(w, h)| (format!("{w}x{h}"), test_scene(w, h, 0.5), false))
            .collect(),
    };
    let band = Spectrum::constant(400.0, 700.0, 1.0).expect("band");
    for (label, img, radiance) in scenes {
        let mut cam = Camera::new(
            SensorConfig::load_preset_or_file(preset, &gloam_io::ReadLog::off()).expect("preset"),
        )
        .expect("valid");
        let mut ms = Vec::with_capacity(frames);
        let mut cpu0 = 0.0;
        for i in 0..frames.max(1) + 2 {
            if i == 2 {
                cpu0 = cpu_s();
            }
            let t = Instant::now();
            if radiance {
                cam.capture_mono(img.view(), &band).expect("capture");
            } else {
                cam.capture_photoelectrons(img.view()).expect("capture");
            }
            ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let cpu_ms = (cpu_s() - cpu0) * 1e3 / frames.max(1) as f64;
        // The first two frames build the caches (patterns, kernels).
        let mut ms = ms.split_off(2);
        ms.sort_by(f64::total_cmp);
        let q = |p: f64| ms[((ms.len() - 1) as f64 * p).round() as usize];
        println!(
            "{preset} {label}: {:.1} ms per frame (quartiles {:.1}–{:.1}), {cpu_ms:.1} CPU-ms per frame; {} frames, {} threads",
            q(0.5),
            q(0.25),
            q(0.75),
            ms.len(),
            rayon::current_num_threads()
        );
    }
}
