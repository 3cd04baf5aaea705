//! Emulator link efficiency: pixel payload bytes per second delivered to the
//! client as good frames, over the line rate (baud / 10 for 8N1), with the
//! emulator pacing itself to the baud. Target ≥ 98 %.
//!
//! `cargo bench -p gloam-grabber --bench link` (env `GLOAM_LINK_BAUD`,
//! `GLOAM_LINK_SECONDS` to change the defaults 3 000 000 baud, 4 s).

use std::time::{Duration, Instant};

use gloam_grabber::emulator::{EmulatorConfig, EmulatorHandle};
use gloam_grabber::memory::{MemoryOptions, memory_link};
use gloam_grabber::source::SyntheticSource;
use gloam_grabber::{ClientOptions, FrameStream, Framing, ProtocolGrabber, Transport};

fn measure<T: Transport>(g: &mut ProtocolGrabber<T>, seconds: f64) -> (f64, u64, u64) {
    // Warm up: handshake, stream start, first frame.
    g.grab().expect("first frame");
    let before = g.stats();
    let t = Instant::now();
    let mut frames = 0;
    while t.elapsed().as_secs_f64() < seconds {
        if g.grab().is_ok() {
            frames += 1;
        }
    }
    let dt = t.elapsed().as_secs_f64();
    let after = g.stats();
    let bytes = after.payload_bytes_ok - before.payload_bytes_ok;
    let bad =
        (after.frames_damaged - before.frames_damaged) + (after.frames_lost - before.frames_lost);
    (bytes as f64 / dt, frames, bad)
}

fn report(name: &str, baud: u32, (rate, frames, bad): (f64, u64, u64)) {
    let line = f64::from(baud) / 10.0;
    println!(
        "link efficiency, {name} @ {baud} baud (8N1, {line:.0} B/s): {rate:.0} payload B/s over {frames} frames = {:.2} % ({bad} frames lost or damaged)",
        100.0 * rate / line
    );
}

fn main() {
    let baud: u32 = std::env::var("GLOAM_LINK_BAUD")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3_000_000);
    let seconds: f64 = std::env::var("GLOAM_LINK_SECONDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(4.0);
    let config = EmulatorConfig {
        baud: Some(baud),
        ..EmulatorConfig::default()
    };
    // 320×240 16-bit frames, as `gloam device` serves by default.
    let source = || SyntheticSource::new(320, 240, 1);

    #[cfg(unix)]
    {
        let pty = gloam_grabber::serial::PtyDevice::open().expect("pty");
        let path = pty.slave_path().to_string();
        let emu = EmulatorHandle::spawn(pty, source(), config.clone());
        let t = gloam_grabber::serial::SerialTransport::open(&path, baud).expect("open pty");
        let mut g = ProtocolGrabber::connect(t, ClientOptions::default()).expect("connect");
        report("emulator over a PTY", baud, measure(&mut g, seconds));
        drop(g);
        std::thread::sleep(Duration::from_millis(50));
        drop(emu);
    }

    let (host, dev, _ctl) = memory_link(MemoryOptions::new(Framing::Cobs));
    let emu = EmulatorHandle::spawn(dev, source(), config);
    let mut g = ProtocolGrabber::connect(host, ClientOptions::default()).expect("connect");
    report(
        "emulator over the in-memory serial link",
        baud,
        measure(&mut g, seconds),
    );
    drop(g);
    drop(emu);
}
