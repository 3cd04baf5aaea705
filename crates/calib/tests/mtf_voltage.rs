//! The §5.9.2 procedure on a simulated RS-170 camera with a stated video
//! bandwidth: voltage-space MTF (scope + grey-scale curve) against the
//! chain's analytic MTF on the line, and the digital-count MTF against
//! the analytic MTF of the sampled line.

use gloam_calib::capture::agc_off;
use gloam_calib::mtf::{SineOptions, sine_mtf};
use gloam_calib::mtf_voltage::{VoltageOptions, analytic_curves, voltage_sine_mtf};
use gloam_grabber::{DeviceControl, Stimulus};
use gloam_sensor::{Camera, SensorConfig};
use gloam_simcam::SimGrabber;
use gloam_simcam::render_stimulus;

const FILE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../sims/video/gen3-rs170.toml"
);
const G: f64 = 30.0;
const SIZE: (u32, u32) = (640, 32);
const SEED: u64 = 5;

#[test]
fn voltage_and_digital_mtf_agree_with_the_analytic_chain() {
    let mut cfg = SensorConfig::load_preset_or_file(FILE, &gloam_io::ReadLog::off()).unwrap();
    cfg.noise.seed = SEED;
    let bandwidth = cfg.video.as_ref().unwrap().bandwidth_hz.unwrap();
    let mut cam = Camera::new(cfg).unwrap();
    cam.set_override_gain(Some(G)).unwrap();
    // Mean radiance at ~35 % of the range.
    let (_, shape) = render_stimulus(
        &Stimulus::Uniform {
            radiance_w_m2_sr: 1.0,
            spectrum: "cie-a".into(),
        },
        2,
        2,
    )
    .unwrap();
    let ch = cam.chain();
    let dn_per_radiance = ch.pe_per_radiance(&shape).unwrap() * ch.mean_dn_per_photoelectron(G);
    let level = 0.35 * (ch.saturation_dn(G) - ch.black_dn(G)) / dn_per_radiance;
    let freqs = vec![0.05, 0.1, 0.15, 0.2, 0.25, 0.3];
    let opts = VoltageOptions {
        frequencies_cy_per_px: freqs.clone(),
        mean_radiance_w_m2_sr: level,
        modulation: 0.6,
        spectrum: "cie-a".into(),
        frames: 2,
        rows: vec![14, 15, 16, 17],
        magnification: 0.02,
        size: SIZE,
    };
    let v = voltage_sine_mtf(&mut cam, &opts, &mut |_, _| {}).unwrap();
    let analytic = analytic_curves(&cam, &freqs, G, SIZE.0 as usize);
    let tp = 1.0 / v.pixel_clock_hz;
    for (i, p) in v.points.iter().enumerate() {
        let on_line = analytic[0].mtf[i];
        println!(
            "f {:.2} ({:.2} MHz, {:.1} lp/mm image, {:.2} lp/mm object): voltage {:.4} analytic {:.4}",
            p.cycles_per_pixel,
            p.line_frequency_mhz,
            p.image_lp_per_mm,
            p.object_lp_per_mm,
            p.mtf,
            on_line
        );
        // Below the bandwidth, within 0.02.
        assert!(p.cycles_per_pixel / tp < bandwidth);
        assert!(
            (p.mtf - on_line).abs() < 0.02,
            "f {}: {} vs {on_line}",
            p.cycles_per_pixel,
            p.mtf
        );
        assert!((p.object_lp_per_mm / p.image_lp_per_mm - 0.02).abs() < 1e-12);
    }

    // The digital-count half: the ordinary sine flow through a grabber on
    // the same camera file, against the analytic MTF of the sampled line.
    let mut g =
        SimGrabber::from_preset(FILE, "uniform", SEED, SIZE, &gloam_io::ReadLog::off()).unwrap();
    agc_off(&mut g).unwrap();
    g.set_gain(G).unwrap();
    let d = sine_mtf(
        &mut g,
        &SineOptions {
            frequencies_cy_per_px: freqs.clone(),
            mean_radiance_w_m2_sr: level,
            modulation: 0.6,
            angle_deg: 0.0,
            spectrum: "cie-a".into(),
            frames: 2,
        },
        &mut |_, _| {},
    )
    .unwrap();
    for (i, &f) in freqs.iter().enumerate() {
        let (dig, want) = (d.mtf[i], analytic[1].mtf[i]);
        println!("f {f:.2}: digital {dig:.4} analytic sampled {want:.4}");
        assert!((dig - want).abs() < 0.02, "f {f}: {dig} vs {want}");
    }
    // The sampling is in it: near the top of the range the digitised MTF
    // is well below the stages × |H(ν)| alone (the held steps' images
    // alias back with their own phase).
    let amp = cam.chain().amplifier().unwrap();
    for i in [4, 5] {
        let f = freqs[i];
        let unsampled = cam.chain().mtf(f, G) * amp.kind.magnitude(amp.bandwidth_hz, f / tp);
        println!(
            "f {f}: stages × |H| {unsampled:.4}, digital {:.4}",
            d.mtf[i]
        );
        assert!(
            unsampled - d.mtf[i] > 0.03,
            "f {f}: {unsampled} vs {}",
            d.mtf[i]
        );
    }
}
