//! Fault tests: thousands of small frames through the emulator over the
//! in-memory link with injected corruption, drops, truncation, delays,
//! disconnects and device resets. Zero damaged frames may be accepted,
//! every loss must be reported, nothing may hang.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use gloam_grabber::emulator::{EmulatorConfig, EmulatorHandle};
use gloam_grabber::faults::FaultConfig;
use gloam_grabber::memory::{MemoryOptions, memory_link};
use gloam_grabber::source::{CaptureSettings, FrameSource, SyntheticSource};
use gloam_grabber::{
    ClientOptions, DeviceControl, FrameStream, Framing, GrabError, ProtocolGrabber,
};

const W: u32 = 24;
const H: u32 = 16;
const SEED: u64 = 99;

/// Expected CRC of frame `seq` of a stream (the synthetic source restarts
/// at every stream start, so frame `seq` is always the same picture).
struct Reference {
    src: SyntheticSource,
    crcs: HashMap<u64, u32>,
    settings: CaptureSettings,
}

impl Reference {
    fn new(gain_milli: u32) -> Self {
        let src = SyntheticSource::new(W, H, SEED);
        let settings = CaptureSettings {
            gain_milli,
            agc: false,
            ..src.info().defaults
        };
        Self {
            src,
            crcs: HashMap::new(),
            settings,
        }
    }
    fn crc(&mut self, seq: u64) -> u32 {
        if self.crcs.is_empty() || !self.crcs.contains_key(&seq) {
            self.src.restart();
            let mut px = vec![0u16; (W * H) as usize];
            for s in 0..=seq.max(self.crcs.len() as u64 * 2) {
                self.src.render(&self.settings, &mut px).unwrap();
                self.crcs.insert(s, gloam_grabber::pixels_crc32c(&px));
            }
        }
        self.crcs[&seq]
    }
}

#[derive(Debug, Default)]
struct Tally {
    ok: u64,
    damaged: u64,
    lost: u64,
    interrupted: u64,
    interrupted_unknown: u64,
    other_errors: u64,
}

fn options() -> ClientOptions {
    ClientOptions {
        reply_timeout: Duration::from_millis(100),
        retries: 10,
        reconnect_timeout: Duration::from_secs(5),
        frame_idle_timeout: Duration::from_millis(60),
        // Small messages: several chunks per frame, so chunk loss is exercised.
        max_message_len: Some(160),
    }
}

fn run(
    framing: Framing,
    good_frames: u64,
    link: MemoryOptions,
    emu: EmulatorConfig,
) -> (Tally, u64, Option<u64>, String) {
    let (host, dev, ctl) = memory_link(link);
    let emu = EmulatorHandle::spawn(dev, SyntheticSource::new(W, H, SEED), emu);
    let t0 = Instant::now();
    let mut g = ProtocolGrabber::connect(host, options())
        .unwrap_or_else(|e| panic!("connect over a faulty {framing:?} link failed: {e}"));
    g.set_bits(16).unwrap();
    g.set_gain(1.25).unwrap();
    let mut reference = Reference::new(1250);
    let mut tally = Tally::default();
    while tally.ok < good_frames {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "fault test too slow: {tally:?}"
        );
        let t = Instant::now();
        let r = g.grab();
        assert!(
            t.elapsed() < Duration::from_secs(10),
            "grab blocked for {:?}",
            t.elapsed()
        );
        match r {
            Ok(f) => {
                tally.ok += 1;
                assert_eq!(
                    f.meta.pixels_crc32c,
                    gloam_grabber::pixels_crc32c(&f.pixels)
                );
                assert_eq!(
                    f.meta.pixels_crc32c,
                    reference.crc(f.meta.seq),
                    "damaged frame {} accepted as good",
                    f.meta.seq
                );
                assert_eq!((f.meta.width, f.meta.height, f.meta.bits), (W, H, 16));
                assert_eq!(f.meta.gain, 1.25);
            }
            Err(GrabError::FrameDamaged { .. }) => tally.damaged += 1,
            Err(GrabError::FramesLost { count, .. }) => tally.lost += count,
            Err(GrabError::Interrupted { frames_lost, .. }) => {
                tally.interrupted += 1;
                match frames_lost {
                    Some(n) => tally.lost += n,
                    None => tally.interrupted_unknown += 1,
                }
            }
            Err(e) => {
                tally.other_errors += 1;
                panic!("unexpected error after {tally:?}: {e}");
            }
        }
    }
    let tail = g.finish().unwrap();
    let stats = format!(
        "client {:?}; link to host {:?}; to device {:?}; emulator frames {} resets {} faults {:?}",
        g.stats(),
        ctl.to_host_stats(),
        ctl.to_device_stats(),
        emu.stats.frames.load(std::sync::atomic::Ordering::Relaxed),
        emu.stats.resets.load(std::sync::atomic::Ordering::Relaxed),
        emu.stats.faults.snapshot(),
    );
    let frames = emu.stats.frames.load(std::sync::atomic::Ordering::Relaxed);
    drop(g);
    emu.stop().unwrap();
    (tally, frames, tail, stats)
}

fn faulty_link(framing: Framing, seed: u64) -> MemoryOptions {
    let mut o = MemoryOptions::new(framing);
    o.to_host = FaultConfig {
        drop: 0.01,
        corrupt: 0.01,
        truncate: 0.005,
        delay_p: 0.002,
        delay: Duration::from_millis(5),
        seed,
    };
    o.to_device = FaultConfig {
        drop: 0.03,
        corrupt: 0.03,
        truncate: 0.01,
        seed: seed + 1,
        ..FaultConfig::none()
    };
    o.disconnect_every = Some(7919);
    o.disconnect_for = Duration::from_millis(30);
    o
}

fn no_resets() -> EmulatorConfig {
    EmulatorConfig {
        baud: None,
        ..EmulatorConfig::default()
    }
}

/// Without device resets every frame the device produced is accounted for
/// exactly: delivered good, reported damaged, reported lost, or in flight at
/// the end.
fn exact_accounting(framing: Framing) {
    let (t, frames, tail, stats) = run(framing, 2000, faulty_link(framing, 5), no_resets());
    eprintln!("{framing:?}: {t:?}, tail {tail:?}\n  {stats}");
    let tail = tail.expect("device did not reset, so the tail is known");
    assert_eq!(
        t.ok + t.damaged + t.lost + tail,
        frames,
        "every frame accounted for: {t:?} tail {tail} device {frames}\n{stats}"
    );
    assert!(t.damaged > 20, "faults were injected and detected: {t:?}");
    assert!(
        t.interrupted >= 1,
        "disconnects happened and were reported: {t:?}\n{stats}"
    );
    assert_eq!(t.interrupted_unknown, 0);
}

#[test]
fn serial_faults_exact_accounting() {
    exact_accounting(Framing::Cobs);
}

#[test]
fn usb_faults_exact_accounting() {
    exact_accounting(Framing::UsbTransfers);
}

/// Device power cycles mid-frame: capture resumes; each reset is reported.
#[test]
fn device_resets_are_reported_and_capture_resumes() {
    for framing in [Framing::Cobs, Framing::UsbTransfers] {
        let emu = EmulatorConfig {
            baud: None,
            reset_every: Some(211),
            faults: FaultConfig {
                drop: 0.005,
                corrupt: 0.005,
                seed: 3,
                ..FaultConfig::none()
            },
            ..EmulatorConfig::default()
        };
        let (t, frames, _tail, stats) = run(framing, 1000, MemoryOptions::new(framing), emu);
        eprintln!("{framing:?} resets: {t:?}\n  {stats}");
        assert!(
            t.interrupted_unknown >= 3,
            "each reset reported: {t:?}\n{stats}"
        );
        assert!(t.ok + t.damaged + t.lost <= frames);
    }
}

/// A port that closes and comes back (scripted, not periodic).
#[test]
fn closed_and_reopened_port_resumes() {
    let (host, dev, ctl) = memory_link(MemoryOptions::new(Framing::Cobs));
    let emu = EmulatorHandle::spawn(dev, SyntheticSource::new(W, H, SEED), no_resets());
    let mut g = ProtocolGrabber::connect(host, options()).unwrap();
    let mut seqs = Vec::new();
    let mut interruptions = 0;
    for i in 0..400 {
        if i == 100 || i == 250 {
            ctl.disconnect(Duration::from_millis(200));
        }
        match g.grab() {
            Ok(f) => seqs.push(f.meta.seq),
            Err(GrabError::Interrupted { frames_lost, .. }) => {
                assert!(frames_lost.is_some());
                interruptions += 1;
            }
            Err(e) if e.is_frame_loss() => {}
            Err(e) => panic!("{e}"),
        }
    }
    // Reported only when frames were lost; always counted in the stats.
    assert!(
        g.stats().interruptions >= 2,
        "{:?} ({interruptions} reported)",
        g.stats()
    );
    assert!(seqs.len() > 300);
    drop(g);
    emu.stop().unwrap();
}

/// A device that never comes back: a clear error within the reconnect timeout.
#[test]
fn device_gone_for_good_times_out_clearly() {
    let (host, dev, ctl) = memory_link(MemoryOptions::new(Framing::Cobs));
    let emu = EmulatorHandle::spawn(dev, SyntheticSource::new(W, H, SEED), no_resets());
    let mut opts = options();
    opts.reconnect_timeout = Duration::from_millis(300);
    let mut g = ProtocolGrabber::connect(host, opts).unwrap();
    g.grab().unwrap();
    ctl.disconnect(Duration::from_secs(3600));
    let t = Instant::now();
    let err = loop {
        match g.grab() {
            Ok(_) => {}
            Err(e) if e.is_frame_loss() => {}
            Err(e) => break e,
        }
        assert!(t.elapsed() < Duration::from_secs(5));
    };
    // The last reconnect attempt's link error travels as the source.
    match &err {
        GrabError::StillAway { source, .. } => assert!(source.is_disconnect(), "{source}"),
        e => panic!("expected StillAway, got {e}"),
    }
    assert!(err.to_string().contains("still away"), "{err}");
    drop(g);
    emu.stop().unwrap();
}
