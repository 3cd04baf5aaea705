//! The protocol client against the emulator over in-memory links.

use std::time::{Duration, Instant};

use gloam_grabber::emulator::{EmulatorConfig, EmulatorHandle};
use gloam_grabber::memory::{MemoryOptions, memory_link};
use gloam_grabber::source::SyntheticSource;
use gloam_grabber::{ClientOptions, DeviceControl, FrameStream, Framing, ProtocolGrabber};

#[test]
fn clean_serial_link_delivers_frames() {
    let (host, dev, _ctl) = memory_link(MemoryOptions::new(Framing::Cobs));
    let emu = EmulatorHandle::spawn(
        dev,
        SyntheticSource::new(64, 48, 7),
        EmulatorConfig {
            baud: None,
            ..Default::default()
        },
    );
    let mut g = ProtocolGrabber::connect(host, ClientOptions::default()).unwrap();
    assert_eq!(g.frame_size(), (64, 48));
    g.set_gain(2.0).unwrap();
    let t = Instant::now();
    for i in 0..50 {
        let f = g.grab().unwrap();
        assert_eq!(f.meta.seq, i);
        assert_eq!(f.pixels.len(), 64 * 48);
    }
    assert!(t.elapsed() < Duration::from_secs(10));
    drop(g);
    emu.stop().unwrap();
}

/// `present` over the wire: the emulator renders the stimulus, and no frame
/// captured before the change is ever handed out after `present` returns.
#[test]
fn present_over_the_wire_never_returns_stale_frames() {
    use gloam_grabber::Stimulus;
    let src = gloam_grabber::SyntheticSource::new(16, 12, 5);
    let (host, dev, _ctl) = memory_link(MemoryOptions::new(Framing::Cobs));
    let emu = EmulatorHandle::spawn(
        dev,
        src,
        EmulatorConfig {
            baud: None,
            ..Default::default()
        },
    );
    let mut g = ProtocolGrabber::connect(host, ClientOptions::default()).unwrap();
    g.set_gain(2.0).unwrap();
    let bright = Stimulus::Uniform {
        radiance_w_m2_sr: 1.0,
        spectrum: "cie-a".into(),
    };
    let mean = |p: &[u16]| p.iter().map(|&v| f64::from(v)).sum::<f64>() / p.len() as f64;
    for round in 0..30 {
        let dark = round % 2 == 0;
        assert!(
            g.present(if dark { &Stimulus::Dark } else { &bright })
                .unwrap()
        );
        for _ in 0..3 {
            let f = g.grab().unwrap();
            let m = mean(&f.pixels);
            // Synthetic source: dark ≈ noise only (< 1 % FS), uniform ≈ 50 % FS at gain 2.
            assert_eq!(
                m < 2000.0,
                dark,
                "round {round}: frame {} mean {m} shows the old stimulus",
                f.meta.seq
            );
        }
    }
    assert!(g.stats().frames_stale > 0, "{:?}", g.stats());
    drop(g);
    emu.stop().unwrap();
}
