//! `cargo run -p gloam-sensor --example digest > digest.txt`
//!
//! Prints a digest (FNV-1a of the pixels, exact pixel sum, frame metadata
//! and the chain's derived figures as bit patterns) of every preset at
//! several gains, seeds and capture paths. Run it before and after a
//! refactor of the chain and `diff` the two outputs: any change in any
//! result shows as a changed line.

use gloam_sensor::{Camera, Frame, SensorConfig, bench::test_scene};
use gloam_spectra::Spectrum;
use ndarray::Array3;

fn fnv1a(pixels: &[u16]) -> u64 {
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
        f.sensor().unwrap().mean_dn.to_bits(),
        f.sensor().unwrap().saturated_fraction.to_bits(),
        f.sensor().unwrap().gain_in_effect.to_bits(),
        f.sensor().unwrap().agc_state,
        f.sensor().unwrap().control_voltage_v.map(f64::to_bits),
    );
    // The bright-source stages' account (shortest round-trip floats, so
    // exact).
    println!(
        "  {:?} mcp_v={:?}",
        f.sensor().unwrap().saturation,
        f.sensor().unwrap().mcp_voltage_v
    );
}

/// FNV-1a of the scope lines' electrons (bit patterns).
fn scope_digest(cam: &Camera) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for (r, v) in cam.scope_electrons() {
        for x in std::iter::once(*r as u64).chain(v.iter().map(|x| x.to_bits())) {
            for b in x.to_le_bytes() {
                h ^= b as u64;
                h = h.wrapping_mul(0x0100_0000_01b3);
            }
        }
    }
    h
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
                    cam.set_scope_rows(vec![5, 30, 63]);
                    // A sequence: AGC and persistence carry state.
                    for (i, level) in [0.3, 2.0, 40.0, 2.0].into_iter().enumerate() {
                        let scene = test_scene(96, 64, level);
                        let f = cam.capture_photoelectrons(scene.view()).expect("capture");
                        line(
                            &format!("{name} s{seed} g{gi} n{} pe#{i} L{level}", noise as u8),
                            &f,
                        );
                        println!("  scope={:016x}", scope_digest(&cam));
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
        // Variants: the analogue line band-limited (with clock jitter and
        // an RS-170 line), the bright-source stages off, no vignetting, no
        // video; each with its effect plan.
        let mut variants = vec![("base", base.clone())];
        if let Some(video) = &base.video {
            let mut cfg = base.clone();
            let mut v = video.clone();
            v.bandwidth_hz = Some(4.2e6);
            v.format = gloam_sensor::stages::video_timing::VideoFormat::Rs170;
            cfg.video = Some(v.clone());
            cfg.digitizer.clock_jitter_s = 5e-9;
            cfg.digitizer.sample_phase = 0.3;
            variants.push(("line", cfg.clone()));
            v.bandwidth_filter = gloam_sensor::stages::video_bandwidth::FilterKind::SinglePole;
            cfg.video = Some(v);
            cfg.digitizer.clock_jitter_s = 0.0;
            variants.push(("line1", cfg));
        }
        let mut cfg = base.clone();
        cfg.bright_source.halo.enabled = false;
        cfg.bright_source.mcp_depletion.enabled = false;
        cfg.bright_source.abc.enabled = false;
        cfg.optics.vignetting = false;
        cfg.noise.enabled = false;
        variants.push(("plain", cfg));
        let mut cfg = base.clone();
        cfg.optics.f_number = -1.0;
        variants.push(("invalid", cfg));
        for (tag, cfg) in variants {
            println!(
                "{name} {tag} effects {:?}",
                gloam_sensor::sensor_effects(&cfg)
            );
            let Ok(mut cam) = Camera::new(cfg) else {
                continue;
            };
            cam.set_scope_rows(vec![2, 40]);
            for (i, level) in [0.5, 3.0, 300.0].into_iter().enumerate() {
                let scene = test_scene(100, 60, level);
                let f = cam.capture_photoelectrons(scene.view()).expect("capture");
                line(&format!("{name} {tag} #{i} L{level}"), &f);
                println!("  scope={:016x}", scope_digest(&cam));
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
