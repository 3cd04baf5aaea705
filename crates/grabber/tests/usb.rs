//! USB code through the in-memory link with USB packet semantics (512-byte
//! packets, transfers ended by a short packet or a zero-length packet), and
//! a clear failure where the machine has no USB bus.

use std::time::Duration;

use gloam_grabber::emulator::{EmulatorConfig, EmulatorHandle};
use gloam_grabber::memory::{MemoryOptions, USB_MAX_PACKET_LEN, memory_link};
use gloam_grabber::source::SyntheticSource;
use gloam_grabber::{
    ClientOptions, DeviceControl, DeviceLink, FrameStream, Framing, ProtocolGrabber, Transport,
};

const T: Duration = Duration::from_millis(200);

#[test]
fn transfers_keep_their_boundaries() {
    let (mut host, mut dev, _ctl) = memory_link(MemoryOptions::new(Framing::UsbTransfers));
    let mut buf = vec![0u8; 4096];
    // Exact multiples of the packet size need a ZLP; others end short.
    for len in [1usize, 511, 512, 513, 1024, 1500, 2048] {
        let msg: Vec<u8> = (0..len).map(|i| (i * 7 + len) as u8).collect();
        dev.send(&msg).unwrap();
        dev.send(b"next").unwrap();
        let n = host.recv(&mut buf, T).unwrap();
        assert_eq!(&buf[..n], &msg[..], "transfer of {len} bytes");
        let n = host.recv(&mut buf, T).unwrap();
        assert_eq!(&buf[..n], b"next");
    }
    // Host → device likewise.
    let msg = vec![0xA5u8; 2 * USB_MAX_PACKET_LEN];
    host.send(&msg, T).unwrap();
    let n = dev.recv(&mut buf, T).unwrap();
    assert_eq!(n, msg.len());
    // Nothing pending: a timeout, not a hang.
    assert_eq!(host.recv(&mut buf, Duration::from_millis(20)).unwrap(), 0);
}

#[test]
fn a_lost_short_packet_merges_transfers_and_the_crc_catches_it() {
    use gloam_grabber::faults::FaultConfig;
    let mut o = MemoryOptions::new(Framing::UsbTransfers);
    o.to_host = FaultConfig {
        drop: 1.0,
        ..FaultConfig::none()
    };
    let (mut host, mut dev, _ctl) = memory_link(o);
    let mut buf = vec![0u8; 8192];
    // A 100-byte transfer is one short packet: dropping it loses it.
    dev.send(&[1u8; 100]).unwrap();
    assert_eq!(host.recv(&mut buf, Duration::from_millis(20)).unwrap(), 0);
    // A 1000-byte transfer whose short packet is lost runs on into the next.
    dev.send(&[2u8; 1000]).unwrap();
    let n = host.recv(&mut buf, Duration::from_millis(20)).unwrap();
    assert!(
        n == 0 || n != 1000,
        "a damaged transfer must not look whole"
    );
}

/// 8-bit frames of 71×7 pixels: the single chunk message is exactly 512
/// bytes, so every frame's chunk transfer ends with a zero-length packet.
#[test]
fn protocol_over_usb_with_zlp_terminated_chunks() {
    let (host, dev, _ctl) = memory_link(MemoryOptions::new(Framing::UsbTransfers));
    let emu = EmulatorHandle::spawn(
        dev,
        SyntheticSource::new(71, 7, 1),
        EmulatorConfig {
            baud: None,
            ..Default::default()
        },
    );
    let mut g = ProtocolGrabber::connect(host, ClientOptions::default()).unwrap();
    g.set_bits(8).unwrap();
    for i in 0..100 {
        let f = g.grab().unwrap();
        assert_eq!(f.meta.seq, i);
        assert_eq!(f.pixels.len(), 71 * 7);
        assert!(f.pixels.iter().all(|&p| p < 256));
    }
    assert_eq!(g.stats().frames_damaged, 0);
    drop(g);
    emu.stop().unwrap();
}

#[test]
fn no_usb_bus_is_a_clear_error() {
    match gloam_grabber::usb::list_usb() {
        Err(e) => {
            assert!(e.to_string().contains("no USB bus"), "{e}");
            let err = gloam_grabber::open("usb:1d50:6018")
                .err()
                .expect("no bus: open fails");
            assert!(err.to_string().contains("no USB bus"), "{err}");
        }
        Ok(_) => {
            // A machine with USB: an absent device is "not found".
            let err = gloam_grabber::open("usb:ffff:fffe:no-such-serial")
                .err()
                .expect("absent device");
            assert!(err.to_string().contains("not found"), "{err}");
        }
    }
}
