//! The analogue video path: the RS-170 line a scope shows, and the video
//! amplifier's bandwidth as a horizontal-only MTF of the digitised frame.

mod common;

use common::*;
use gloam_sensor::scope::{read_line, scope_lines};
use gloam_sensor::stages::video_bandwidth::FilterKind;
use gloam_sensor::stages::video_timing::{LineTiming, VideoFormat};
use gloam_sensor::{SensorConfig, sensor_effects};
use ndarray::Array2;

const G: f64 = 30.0;

/// Gen III with the video stage at `bandwidth_hz` (None: flat), noise off.
fn gen3(format: VideoFormat, bandwidth_hz: Option<f64>) -> SensorConfig {
    let mut c = clean("gen3-gaas-iccd");
    c.noise.enabled = false;
    let v = c.video.as_mut().unwrap();
    v.format = format;
    v.bandwidth_hz = bandwidth_hz;
    v.bandwidth_filter = FilterKind::Butterworth2;
    c
}

/// Photoelectrons per pixel that put the mean at 40 % of the range.
fn mid_grey(cfg: &SensorConfig) -> f64 {
    let cam = camera(cfg.clone(), Some(G));
    let ch = cam.chain();
    0.4 * (ch.saturation_dn(G) - ch.black_dn(G)) / ch.mean_dn_per_photoelectron(G)
}

#[test]
fn scope_shows_a_correct_rs170_line() {
    let mut cfg = gen3(VideoFormat::Rs170, Some(4.2e6));
    cfg.noise.enabled = true;
    let pe = mid_grey(&cfg);
    let mut cam = camera(cfg.clone(), Some(G));
    let (rows, cols) = (64, 640);
    let scene = Array2::from_shape_fn((rows, cols), |(_, x)| {
        pe * (1.0 + 0.8 * (std::f64::consts::TAU * 0.05 * x as f64).cos())
    });
    cam.set_scope_rows(vec![31, 32]);
    cam.capture_photoelectrons(scene.view()).unwrap();
    let lines = scope_lines(&cam, rows).unwrap();
    assert_eq!(lines.len(), 2);
    // Adjacent rows go to different fields.
    assert_ne!(lines[0].field, lines[1].field);
    let std = LineTiming::of(VideoFormat::Rs170);
    let v = cfg.video.as_ref().unwrap();
    for l in &lines {
        let r = read_line(l).unwrap();
        println!("{r:?}");
        assert!(r.sync_tip_v.abs() < 0.005, "sync tip {}", r.sync_tip_v);
        assert!(
            (r.blanking_v - v.black_level_v).abs() < 0.005,
            "{}",
            r.blanking_v
        );
        // Active video between black and the white clip (the amplifier's
        // 4.3 % overshoot on a 0.6 V swing aside).
        assert!(
            r.active_min_v > v.black_level_v - 0.03,
            "{}",
            r.active_min_v
        );
        assert!(
            r.active_max_v < v.white_clip_v.unwrap() + 0.03,
            "{}",
            r.active_max_v
        );
        assert!(
            r.active_max_v - r.active_min_v > 0.2,
            "the sine pattern is on the line"
        );
        // Timing at half sync height within 1 % of SMPTE 170M.
        assert!(
            (r.sync_width_s / std.sync_s - 1.0).abs() < 0.01,
            "{}",
            r.sync_width_s
        );
        assert!(
            (r.line_period_s / 63.556e-6 - 1.0).abs() < 0.01,
            "{}",
            r.line_period_s
        );
    }
    // A frame taller than the picture cannot be sent as RS-170.
    let tall = Array2::from_elem((600, 64), pe);
    cam.set_scope_rows(vec![0]);
    cam.capture_photoelectrons(tall.view()).unwrap();
    let e = scope_lines(&cam, 600).unwrap_err();
    assert_eq!(
        e,
        gloam_sensor::ScopeError::Line(gloam_sensor::LineError::FrameTooTall {
            rows: 600,
            picture_lines: 485,
            format: "RS-170 (525/60)",
        })
    );
    assert!(e.to_string().contains("485"), "{e}");
}

/// Modulation above black of a sine at `f` cycles/pixel along columns
/// (`vertical`: along rows), by least squares, skipping `margin` pixels.
fn modulation(
    img: &ndarray::ArrayView2<u16>,
    f: f64,
    black: f64,
    vertical: bool,
    margin: usize,
) -> f64 {
    let (rows, cols) = img.dim();
    let (mut s0, mut n) = (0.0, 0.0);
    let (mut sc, mut ss, mut cc, mut csn, mut sn2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for y in margin..rows - margin {
        for x in margin..cols - margin {
            let v = img[[y, x]] as f64 - black;
            let p = if vertical { y } else { x } as f64;
            let ph = std::f64::consts::TAU * f * p;
            let (c, s) = (ph.cos(), ph.sin());
            s0 += v;
            sc += v * c;
            ss += v * s;
            cc += c * c;
            csn += c * s;
            sn2 += s * s;
            n += 1.0;
        }
    }
    let det = cc * sn2 - csn * csn;
    let a = (sc * sn2 - ss * csn) / det;
    let b = (ss * cc - sc * csn) / det;
    a.hypot(b) / (s0 / n)
}

fn measure(cfg: &SensorConfig, f: f64, vertical: bool) -> (f64, f64) {
    let pe = mid_grey(cfg);
    let mut cam = camera(cfg.clone(), Some(G));
    let (rows, cols) = (160, 640);
    let m_in = 0.6;
    let scene = Array2::from_shape_fn((rows, cols), |(y, x)| {
        let p = if vertical { y } else { x } as f64;
        pe * (1.0 + m_in * (std::f64::consts::TAU * f * p).cos())
    });
    let frame = cam.capture_photoelectrons(scene.view()).unwrap();
    let black = cam.chain().black_dn(G);
    let measured = modulation(&frame.view().unwrap(), f, black, vertical, 20) / m_in;
    let analytic = if vertical {
        cam.chain().mtf(f, G)
    } else {
        cam.chain().mtf_horizontal(f, G, cols)
    };
    (measured, analytic)
}

#[test]
fn bandwidth_narrows_horizontal_mtf_only_and_the_plan_says_so() {
    let wide = gen3(VideoFormat::Ccir, Some(8e6));
    let narrow = gen3(VideoFormat::Ccir, Some(2e6));
    for f in [0.05, 0.1, 0.2, 0.3] {
        let (hw, aw) = measure(&wide, f, false);
        let (hn, an) = measure(&narrow, f, false);
        let (vw, _) = measure(&wide, f, true);
        let (vn, avn) = measure(&narrow, f, true);
        println!(
            "f {f}: H wide {hw:.4} ({aw:.4}) narrow {hn:.4} ({an:.4}); V {vw:.4} {vn:.4} ({avn:.4})"
        );
        // The digitised horizontal MTF is the chain's × the sampled line.
        assert!((hw - aw).abs() < 0.02, "wide f {f}: {hw} vs {aw}");
        assert!((hn - an).abs() < 0.02, "narrow f {f}: {hn} vs {an}");
        // Narrower bandwidth: visibly lower horizontally (from 1.2 MHz on
        // the line, f ≥ 0.1) …
        if f >= 0.1 {
            assert!(hn < hw - 0.04, "f {f}: {hn} vs {hw}");
        }
        // … and the vertical MTF does not move.
        assert!((vw - vn).abs() < 1e-3, "f {f}: vertical {vw} vs {vn}");
        assert!((vn - avn).abs() < 0.02);
    }
    // The effect plan lists the stage with its figure at 0.25 cy/px.
    let entry = |c: &SensorConfig| {
        sensor_effects(c)
            .into_iter()
            .find(|e| e.name == "video bandwidth")
            .unwrap()
    };
    let (w, n) = (entry(&wide), entry(&narrow));
    assert!(w.enabled && n.enabled);
    assert!(
        n.reason.contains("2.00 MHz") && w.reason.contains("8.00 MHz"),
        "{} / {}",
        n.reason,
        w.reason
    );
    let factor = |s: &str| -> f64 {
        let i = s.find('×').unwrap() + '×'.len_utf8();
        s[i..].split_whitespace().next().unwrap().parse().unwrap()
    };
    assert!(factor(&n.reason) < factor(&w.reason) - 0.1);
    let flat = entry(&gen3(VideoFormat::Ccir, None));
    assert!(!flat.enabled && flat.reason.contains("not set"));
    let timing = sensor_effects(&gen3(VideoFormat::Rs170, None))
        .into_iter()
        .find(|e| e.name == "video line timing")
        .unwrap();
    assert!(timing.reason.contains("63.556"), "{}", timing.reason);
}

#[test]
fn without_a_bandwidth_frames_are_bit_identical_to_the_plain_digitizer() {
    // The flat amplifier leaves the fused row path untouched: same frame
    // as before the video stage had a bandwidth field at all.
    let cfg = clean("gen3-gaas-iccd");
    assert!(cfg.video.as_ref().unwrap().bandwidth_hz.is_none());
    let scene = uniform(32, 48, 3.0);
    let mut a = camera(cfg.clone(), Some(G));
    let mut sampled = cfg.clone();
    // A bandwidth far above the pixel clock samples the staircase back.
    sampled.video.as_mut().unwrap().bandwidth_hz = Some(1e11);
    let mut b = camera(sampled, Some(G));
    let fa = a.capture_photoelectrons(scene.view()).unwrap();
    let fb = b.capture_photoelectrons(scene.view()).unwrap();
    let diff = fa
        .pixels
        .iter()
        .zip(fb.pixels.iter())
        .map(|(x, y)| (i32::from(*x) - i32::from(*y)).abs())
        .max()
        .unwrap();
    assert!(diff <= 1, "max difference {diff} DN");
}
