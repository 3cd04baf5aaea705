//! `cargo run -p gloam-sensor --example digest > digest.txt`
//!
//! Prints a digest (FNV-1a of the pixels, exact pixel sum, frame metadata
//! and the chain's derived figures as bit patterns) of every preset at
//! several gains, seeds and capture paths. Run it before and after a
//! refactor of the chain and `diff` the two outputs: any change in any
//! result shows as a changed line.

use gloam_sensor::{Camera, Frame, SensorConfig, bench::test_scene};
use gloam_spectra::Spectrum;
use ndarray::{Array2, Array3};

fn fnv1a(pixels: &Array2<u16>) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for &p in pixels.iter() {
        for b in p.to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

fn line(tag: &str, f: &Frame) {
    let sum: u64 = f.pixels.iter().map(|&p| p as u64).sum();
    println!(
        "{tag}: fnv={:016x} sum={sum} mean={:016x} sat={:016x} gain={:016x} agc={:?} v={:?}",
        fnv1a(&f.pixels),
        f.meta.mean_dn.to_bits(),
        f.meta.saturated_fraction.to_bits(),
        f.meta.gain_in_effect.to_bits(),
        f.meta.agc_state,
        f.meta.control_voltage_v.map(f64::to_bits),
    );
}

fn main() {
    let band = Spectrum::new(vec![400.0, 900.0], vec![1.0, 1.0]).expect("band");
    let band2 = Spectrum::new(vec![500.0, 600.0, 700.0], vec![0.2, 1.0, 0.4]).expect("band");
    for (name, _) in gloam_sensor::PRESETS {
        let base = SensorConfig::preset(name).expect("preset").expect("valid");
        let probe = Camera::new(base.clone()).expect("camera");
        let ch = probe.chain();
        let (gmin, gref, gmax) = (ch.gain_min, ch.reference_gain, ch.gain_max);
        // The chain's derived figures.
        for g in [gmin, gref, gmax] {
            let mtf: Vec<u64> = [0.05, 0.2, 0.45]
                .iter()
                .map(|&f| ch.mtf(f, g).to_bits())
                .collect();
            println!(
                "{name} chain g={:016x}: dn/pe={:016x} enf={:016x} read={:016x} sat={:016x} \
                 black={:016x} clip={:016x} ebi={:016x} mtf={mtf:?} pe/L={:?}",
                g.to_bits(),
                ch.mean_dn_per_photoelectron(g).to_bits(),
                ch.excess_noise_factor(g).to_bits(),
                ch.read_noise_dn(g).to_bits(),
                ch.saturation_dn(g).to_bits(),
                ch.black_dn(g).to_bits(),
                ch.clip_dn(g).to_bits(),
                ch.ebi_pe(g).to_bits(),
                ch.pe_per_radiance(&band).map(f64::to_bits),
            );
        }
        for seed in [1u64, 7] {
            for (gi, gain) in [Some(gmin * 1.5), None, Some(gmax * 0.8)]
                .into_iter()
                .enumerate()
            {
                for noise in [true, false] {
                    let mut cfg = base.clone();
                    cfg.noise.seed = seed;
                    cfg.noise.enabled = noise;
                    let mut cam = Camera::new(cfg).expect("camera");
                    if gain.is_some() {
                        cam.set_override_gain(gain).expect("gain");
                    }
                    // A sequence: AGC and persistence carry state.
                    for (i, level) in [0.3, 2.0, 40.0, 2.0].into_iter().enumerate() {
                        let scene = test_scene(96, 64, level);
                        let f = cam.capture_photoelectrons(scene.view()).expect("capture");
                        line(
                            &format!("{name} s{seed} g{gi} n{} pe#{i} L{level}", noise as u8),
                            &f,
                        );
                    }
                    // Radiance paths: two bands, mono, detected.
                    let k = cam.chain().pe_per_radiance(&band).expect("k");
                    let rad = test_scene(80, 48, 3.0).mapv(|v| v / k);
                    let mut rad3 = Array3::<f64>::zeros((2, 48, 80));
                    rad3.index_axis_mut(ndarray::Axis(0), 0).assign(&rad);
                    rad3.index_axis_mut(ndarray::Axis(0), 1)
                        .assign(&rad.mapv(|v| 0.5 * v));
                    let f = cam
                        .capture(rad3.view(), &[band.clone(), band2.clone()])
                        .expect("capture");
                    line(&format!("{name} s{seed} g{gi} n{} bands", noise as u8), &f);
                    let f = cam.capture_mono(rad.view(), &band).expect("capture");
                    line(&format!("{name} s{seed} g{gi} n{} mono", noise as u8), &f);
                    let det = rad.mapv(|v| v * 1e12);
                    let f = cam.capture_detected(det.view()).expect("capture");
                    line(
                        &format!("{name} s{seed} g{gi} n{} detected", noise as u8),
                        &f,
                    );
                    // Strided input (not standard layout).
                    let t = test_scene(64, 96, 1.0);
                    let f = cam.capture_photoelectrons(t.t()).expect("capture");
                    line(
                        &format!("{name} s{seed} g{gi} n{} strided", noise as u8),
                        &f,
                    );
                }
            }
        }
        // Blooming and saturation: a bright, blooming-on variant.
        let mut cfg = base.clone();
        cfg.ccd.blooming = true;
        let mut cam = Camera::new(cfg).expect("camera");
        cam.set_override_gain(Some(gmax)).expect("gain");
        for level in [50.0, 5000.0] {
            let scene = test_scene(96, 64, level);
            let f = cam.capture_photoelectrons(scene.view()).expect("capture");
            line(&format!("{name} bloom L{level}"), &f);
        }
    }
}
