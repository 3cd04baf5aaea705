//! The protocol client against the emulator over in-memory links.

use std::time::{Duration, Instant};

use gloam_grabber::emulator::{EmulatorConfig, EmulatorHandle};
use gloam_grabber::memory::{MemoryOptions, memory_link};
use gloam_grabber::source::SyntheticSource;
use gloam_grabber::{ClientOptions, FrameGrabber, Framing, ProtocolGrabber};

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
