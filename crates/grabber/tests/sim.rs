//! The simulated grabber, and bit-identity with the emulator over a link.

use gloam_grabber::emulator::{EmulatorConfig, EmulatorHandle};
use gloam_grabber::memory::{MemoryOptions, memory_link};
use gloam_grabber::{
    ClientOptions, FrameGrabber, Framing, ProtocolGrabber, SensorSource, SimGrabber, Stimulus, open,
};

#[test]
fn sim_uri_opens_and_grabs() {
    let mut g = open("sim:gen2-s20-iccd?size=64x48&seed=3").unwrap();
    assert_eq!(g.frame_size(), (64, 48));
    assert_eq!(g.set_bits(12).unwrap(), 12);
    let f = g.grab().unwrap();
    assert_eq!(f.meta.seq, 0);
    assert_eq!(f.pixels.len(), 64 * 48);
    assert!(f.pixels.iter().all(|&p| p < 4096));
    assert!(
        f.pixels.iter().any(|&p| p > 0),
        "uniform rig should give signal"
    );
    assert_eq!(
        f.meta.pixels_crc32c,
        gloam_grabber::pixels_crc32c(&f.pixels)
    );
    assert!(g.present(&Stimulus::Dark).unwrap());
    let d = g.grab().unwrap();
    let mean = |p: &[u16]| p.iter().map(|&v| f64::from(v)).sum::<f64>() / p.len() as f64;
    assert!(mean(&d.pixels) < mean(&f.pixels));
    assert!(open("sim:no-such-preset").is_err());
}

#[test]
fn same_seed_same_frames_in_process_and_over_the_link() {
    for framing in [Framing::Cobs, Framing::UsbTransfers] {
        let mut sim = SimGrabber::from_preset("gen3-gaas-iccd", "sine", 11, (48, 32)).unwrap();
        let src = SensorSource::new("gen3-gaas-iccd", "sine", 11, (48, 32)).unwrap();
        let (host, dev, _ctl) = memory_link(MemoryOptions::new(framing));
        let emu = EmulatorHandle::spawn(
            dev,
            src,
            EmulatorConfig {
                baud: None,
                ..Default::default()
            },
        );
        let mut wire = ProtocolGrabber::connect(host, ClientOptions::default()).unwrap();
        for g in [&mut sim as &mut dyn FrameGrabber, &mut wire] {
            g.set_bits(16).unwrap();
            g.set_gain(1.5).unwrap();
        }
        for _ in 0..4 {
            let a = sim.grab().unwrap();
            let b = wire.grab().unwrap();
            assert_eq!(a.meta.seq, b.meta.seq);
            assert_eq!(
                a.meta.pixels_crc32c, b.meta.pixels_crc32c,
                "{framing:?} seq {}",
                a.meta.seq
            );
            assert_eq!(a.pixels, b.pixels);
            assert_eq!(a.meta.gain, b.meta.gain);
            assert_eq!((a.meta.bits, a.meta.agc), (b.meta.bits, b.meta.agc));
        }
        drop(wire);
        emu.stop().unwrap();
    }
}
