//! The device emulator: the firmware state machine from `firmware-protocol`
//! with a [`FrameSource`] as its hardware, driven over any [`DeviceLink`]
//! (a pseudo-terminal for `gloam device --pty`, or an in-memory link in
//! tests), rate-limited to a configured baud and with fault injection.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use firmware_protocol::{
    Applied, CaptureInfo, CobsAccumulator, Control, Device, DeviceBuffers, DeviceConfig,
    DeviceState, ErrorCode, Feed, Hal, MAX_COBS_FRAME_LEN, MAX_MESSAGE_LEN, PixelFormat, Settings,
    Sink, SinkError, TestPattern, bit_depths, features,
};

pub use crate::faults::FaultCounts;
use crate::faults::{FaultConfig, FaultInjector, FaultStats, Verdict};
use crate::interface::Stimulus;
use crate::source::{CaptureSettings, FrameSource, SourceInfo};
use crate::transport::{DeviceLink, Framing, LinkError};

/// Default emulated line rate: fast enough for quick tests, slow enough to
/// be a real UART speed (FTDI FT232H / CP2102N class).
pub const DEFAULT_BAUD: u32 = 3_000_000;

/// Emulator settings.
#[derive(Clone, Debug)]
pub struct EmulatorConfig {
    /// Line rate to pace output to (8N1: 10 bits per byte). `None`: as fast as the link takes it.
    pub baud: Option<u32>,
    /// Faults on the device→host units.
    pub faults: FaultConfig,
    /// Power-cycle the device in the middle of every N-th frame.
    pub reset_every: Option<u64>,
    /// Reported in `Capabilities`.
    pub serial_number: u32,
}

impl Default for EmulatorConfig {
    fn default() -> Self {
        Self {
            baud: Some(DEFAULT_BAUD),
            faults: FaultConfig::none(),
            reset_every: None,
            serial_number: 1,
        }
    }
}

/// Counters the emulator keeps (shared, readable while it runs).
#[derive(Debug, Default)]
pub struct EmulatorStats {
    /// Frames captured (leaders emitted) since start, across resets.
    pub frames: AtomicU64,
    /// Bytes written to the link (after faults).
    pub bytes_sent: AtomicU64,
    /// Emulated power cycles (`reset_every`).
    pub resets: AtomicU64,
    /// Faults injected on output units.
    pub faults: Arc<FaultStats>,
}

/// Why the emulator stopped other than by being asked to.
#[derive(Debug, thiserror::Error)]
pub enum EmulatorError {
    /// The protocol device could not be set up (its buffers do not fit).
    #[error("device init")]
    DeviceInit(#[source] firmware_protocol::EncodeError),
    /// The link failed with something other than the host going away.
    #[error("link")]
    Link(#[source] LinkError),
    #[error("emulator thread panicked")]
    Panicked,
}

/// Emulator-only request kind (in the request range, unused by protocol
/// 1.0): `EmulatorStimulus`, body = the [`Stimulus`] as JSON (≤ 1024
/// bytes), reply `Ack { request_kind: 0x3F }` once the stimulus applies to
/// every frame captured after it, or `Nak(MALFORMED)`. Real devices answer
/// `Nak(UNKNOWN_MESSAGE)`, so hosts can probe for it.
pub const KIND_EMULATOR_STIMULUS: u8 = 0x3F;
/// Largest `EmulatorStimulus` body.
pub const MAX_STIMULUS_JSON_LEN: usize = 1024;

/// Firmware version the emulator reports (0.1.0).
pub const FIRMWARE_VERSION: u32 = 0x00_01_00;

/// The protocol's fixed device facts for a source.
pub fn device_config(info: &SourceInfo, serial_number: u32) -> DeviceConfig {
    let mut feats = features::TEST_PATTERN | features::TEMPERATURE;
    if info.has_agc {
        feats |= features::AGC;
    }
    if info.has_mcp {
        feats |= features::MCP;
    }
    if info.has_gate {
        feats |= features::GATE;
    }
    DeviceConfig {
        max_width_px: info.max_width.min(u32::from(u16::MAX)) as u16,
        max_height_px: info.max_height.min(u32::from(u16::MAX)) as u16,
        bit_depths: bit_depths::MONO8 | bit_depths::MONO12 | bit_depths::MONO16,
        features: feats,
        firmware_version: FIRMWARE_VERSION,
        serial_number,
        max_gain_milli: info.max_gain_milli,
        max_mcp_voltage_mv: 1_200_000,
        max_exposure_us: info.max_exposure_us,
        initial_settings: to_wire_settings(&info.defaults),
    }
}

/// Protocol settings from capture settings.
pub fn to_wire_settings(c: &CaptureSettings) -> Settings {
    Settings {
        gain_milli: c.gain_milli,
        mcp_voltage_mv: c.mcp_voltage_mv,
        agc_enabled: c.agc,
        agc_setpoint_ppm: c.agc_setpoint_ppm,
        exposure_us: c.exposure_us,
        gate_ns: c.gate_ns,
        pixel_format: PixelFormat::from_bit_depth(u32::from(c.bits)).unwrap_or(PixelFormat::Mono16),
        width_px: c.width.min(65535) as u16,
        height_px: c.height.min(65535) as u16,
        test_pattern: TestPattern::Off,
    }
}

/// Capture settings from protocol settings.
pub fn from_wire_settings(s: &Settings) -> CaptureSettings {
    CaptureSettings {
        gain_milli: s.gain_milli,
        agc: s.agc_enabled,
        agc_setpoint_ppm: s.agc_setpoint_ppm,
        exposure_us: s.exposure_us,
        gate_ns: s.gate_ns,
        mcp_voltage_mv: s.mcp_voltage_mv,
        bits: s.pixel_format.bit_depth() as u8,
        width: u32::from(s.width_px),
        height: u32::from(s.height_px),
    }
}

/// A [`Hal`] backed by a [`FrameSource`].
pub struct SourceHal<'s, S: FrameSource> {
    source: &'s mut S,
    clock: Instant,
    pixels: Vec<u16>,
    mcp_target: Option<(u32, Instant)>,
    captures: u64,
    /// Device clock at the start of the current stream (frame timestamps
    /// count from here).
    stream_start_us: u64,
}

impl<'s, S: FrameSource> SourceHal<'s, S> {
    pub fn new(source: &'s mut S) -> Self {
        Self {
            source,
            clock: Instant::now(),
            pixels: Vec::new(),
            mcp_target: None,
            captures: 0,
            stream_start_us: 0,
        }
    }
}

/// MCP supply slew time the emulator models (a `Pending` reply).
const MCP_SLEW_MS: u32 = 30;

impl<S: FrameSource> Hal for SourceHal<'_, S> {
    fn now_us(&mut self) -> u64 {
        self.clock.elapsed().as_micros() as u64
    }

    fn read_temperature_milli_c(&mut self) -> Option<i32> {
        Some(21_500)
    }

    fn set_gain(&mut self, gain_milli: u32) -> Result<(), ErrorCode> {
        let info = self.source.info();
        if (info.min_gain_milli..=info.max_gain_milli).contains(&gain_milli) {
            Ok(())
        } else {
            Err(ErrorCode::OUT_OF_RANGE)
        }
    }

    fn apply_control(
        &mut self,
        control: Control,
        value: u32,
        _settings: &Settings,
    ) -> Result<Applied, ErrorCode> {
        if control == Control::McpVoltageMv {
            self.mcp_target = Some((
                value,
                Instant::now() + Duration::from_millis(u64::from(MCP_SLEW_MS)),
            ));
            return Ok(Applied::InProgress {
                eta_ms: MCP_SLEW_MS,
            });
        }
        Ok(Applied::Done)
    }

    fn poll_pending(&mut self) -> Option<Result<(), ErrorCode>> {
        match self.mcp_target {
            Some((_, t)) if Instant::now() < t => None,
            _ => {
                self.mcp_target = None;
                Some(Ok(()))
            }
        }
    }

    fn capture_frame(
        &mut self,
        settings: &Settings,
        frame: &mut [u8],
    ) -> Result<Option<CaptureInfo>, ErrorCode> {
        let timestamp_us = self.now_us().saturating_sub(self.stream_start_us);
        self.captures += 1;
        let c = from_wire_settings(settings);
        let n = (c.width as usize) * (c.height as usize);
        let bpp = settings.pixel_format.bytes_per_pixel();
        if frame.len() < n * bpp {
            return Err(ErrorCode::HARDWARE_FAULT);
        }
        if settings.test_pattern != TestPattern::Off {
            let written = firmware_protocol::fill_test_pattern(
                settings.test_pattern,
                settings.pixel_format,
                settings.width_px,
                settings.height_px,
                frame,
            );
            return Ok(Some(CaptureInfo {
                timestamp_us,
                gain_milli: settings.gain_milli,
                mcp_voltage_mv: settings.mcp_voltage_mv,
                valid_len_bytes: written,
            }));
        }
        self.pixels.resize(n, 0);
        let r = self
            .source
            .render(&c, &mut self.pixels)
            .map_err(|_| ErrorCode::HARDWARE_FAULT)?;
        pack_pixels(&self.pixels, bpp, frame);
        Ok(Some(CaptureInfo {
            timestamp_us,
            gain_milli: r.gain_milli,
            mcp_voltage_mv: settings.mcp_voltage_mv,
            valid_len_bytes: n * bpp,
        }))
    }
}

/// Pixels to payload bytes: one byte each (8-bit) or u16 little-endian.
pub fn pack_pixels(pixels: &[u16], bytes_per_pixel: usize, out: &mut [u8]) {
    if bytes_per_pixel == 1 {
        for (o, p) in out.iter_mut().zip(pixels) {
            *o = *p as u8;
        }
    } else {
        for (o, p) in out.chunks_exact_mut(2).zip(pixels) {
            o.copy_from_slice(&p.to_le_bytes());
        }
    }
}

/// Paces output to a line rate: each write "occupies the wire" for
/// `bytes × 10 / baud` seconds; the caller sleeps while the wire is busy,
/// exactly like a blocking UART driver.
struct Pacer {
    bytes_per_s: Option<f64>,
    wire_free_at: Instant,
}

impl Pacer {
    fn new(baud: Option<u32>) -> Self {
        Self {
            bytes_per_s: baud.filter(|b| *b > 0).map(|b| f64::from(b) / 10.0),
            wire_free_at: Instant::now(),
        }
    }

    fn occupy(&mut self, n: usize) {
        let Some(rate) = self.bytes_per_s else { return };
        let now = Instant::now();
        let begin = self.wire_free_at.max(now);
        self.wire_free_at = begin + Duration::from_secs_f64(n as f64 / rate);
        // Stay up to SLACK ahead of the wire (a UART's transmit buffer), so
        // the time spent capturing the next frame does not leave the line
        // idle; the long-run rate is exact because the clock accumulates.
        let ahead = self.wire_free_at.saturating_duration_since(Instant::now());
        if ahead > Self::SLACK {
            thread::sleep(ahead - Self::SLACK);
        }
    }
}

impl Pacer {
    const SLACK: Duration = Duration::from_millis(3);
}

struct EmuSink<'l, L: DeviceLink> {
    link: &'l mut L,
    pacer: &'l mut Pacer,
    faults: &'l mut FaultInjector,
    stats: &'l EmulatorStats,
    buf: &'l mut Vec<u8>,
    host_gone: bool,
}

impl<L: DeviceLink> Sink for EmuSink<'_, L> {
    fn send(&mut self, wire_bytes: &[u8]) -> Result<(), SinkError> {
        self.buf.clear();
        self.buf.extend_from_slice(wire_bytes);
        match self.faults.apply(self.buf) {
            Verdict::Drop => {
                // The bytes still took their time on the wire.
                self.pacer.occupy(wire_bytes.len());
                return Ok(());
            }
            Verdict::Deliver(Some(d)) => thread::sleep(d),
            Verdict::Deliver(None) => {}
        }
        let r = self.link.send(self.buf);
        self.pacer.occupy(self.buf.len());
        match r {
            Ok(()) => {
                self.stats
                    .bytes_sent
                    .fetch_add(self.buf.len() as u64, Ordering::Relaxed);
                Ok(())
            }
            Err(LinkError::Disconnected { .. }) => {
                self.host_gone = true;
                Err(SinkError)
            }
            Err(LinkError::Io { .. }) => Err(SinkError),
        }
    }
}

/// Run the emulator until `stop` is set. `source` is the hardware; it is
/// restarted at every stream start so frame `k` of every stream is the
/// same as frame `k` of an in-process `gloam_simcam::SimGrabber` stream.
pub fn run_emulator<L: DeviceLink, S: FrameSource>(
    mut link: L,
    source: &mut S,
    config: &EmulatorConfig,
    stats: &EmulatorStats,
    stop: &AtomicBool,
) -> Result<(), EmulatorError> {
    let framing = link.framing();
    let transport = match framing {
        Framing::Cobs => firmware_protocol::Transport::Serial,
        Framing::UsbTransfers => firmware_protocol::Transport::Usb,
    };
    let info = source.info();
    let dev_config = device_config(&info, config.serial_number);
    let frame_len = (info.max_width as usize) * (info.max_height as usize) * 2;
    let mut tx = vec![
        0u8;
        match framing {
            Framing::Cobs => MAX_COBS_FRAME_LEN,
            Framing::UsbTransfers => MAX_MESSAGE_LEN,
        }
    ];
    let mut frame = vec![0u8; frame_len];
    let mut rx = vec![0u8; 64 * 1024];
    // Room for the emulator's own (larger) stimulus request.
    let mut cobs = CobsAccumulator::new(vec![0u8; MAX_STIMULUS_JSON_LEN + 16]);
    let mut pacer = Pacer::new(config.baud);
    let mut faults = FaultInjector::with_stats(config.faults.clone(), stats.faults.clone());
    let fault_stats = faults.stats();
    let mut sink_buf = Vec::with_capacity(MAX_COBS_FRAME_LEN);
    'power: loop {
        cobs.reset();
        let hal = SourceHal::new(source);
        let mut device = Device::new(
            hal,
            dev_config,
            transport,
            DeviceBuffers {
                tx: &mut tx,
                frame: &mut frame,
            },
        )
        .map_err(EmulatorError::DeviceInit)?;
        let mut reset_armed: Option<u32> = None;
        loop {
            if stop.load(Ordering::Relaxed) {
                return Ok(());
            }
            let streaming = device.state() == DeviceState::Streaming;
            let wait = if streaming {
                Duration::ZERO
            } else {
                Duration::from_millis(2)
            };
            let mut sink = EmuSink {
                link: &mut link,
                pacer: &mut pacer,
                faults: &mut faults,
                stats,
                buf: &mut sink_buf,
                host_gone: false,
            };
            match sink.link.recv(&mut rx, wait) {
                Err(LinkError::Disconnected { .. }) => {
                    thread::sleep(Duration::from_millis(5));
                    continue;
                }
                Err(e @ LinkError::Io { .. }) => return Err(EmulatorError::Link(e)),
                Ok(n) => {
                    // A host that (re)appears always opens with `Hello`,
                    // which resets the session; no power cycle needed.
                    let mut input = &rx[..n];
                    match framing {
                        Framing::UsbTransfers => {
                            if n > 0 {
                                deliver(&mut device, input, &mut sink, transport);
                            }
                        }
                        Framing::Cobs => {
                            while !input.is_empty() {
                                let (used, feed) = cobs.feed(input);
                                input = &input[used..];
                                match feed {
                                    Feed::NeedMore => {}
                                    Feed::Frame(f) => {
                                        let msg = f.to_vec();
                                        deliver(&mut device, &msg, &mut sink, transport);
                                    }
                                    // Let the device count and NAK it.
                                    Feed::Error(_) => {
                                        deliver(&mut device, &[], &mut sink, transport)
                                    }
                                }
                            }
                        }
                    }
                }
            }
            let before = device.hal_mut().captures;
            let _ = device.poll(&mut sink);
            let after = device.hal_mut().captures;
            if after > before {
                let total = stats.frames.fetch_add(1, Ordering::Relaxed) + 1;
                if let Some(every) = config.reset_every
                    && every > 0
                    && total % every == 0
                {
                    // Let the leader and one chunk out, then lose power.
                    reset_armed = Some(1);
                }
            } else if let Some(left) = reset_armed {
                if left == 0 {
                    stats.resets.fetch_add(1, Ordering::Relaxed);
                    fault_stats.resets.fetch_add(1, Ordering::Relaxed);
                    continue 'power;
                }
                reset_armed = Some(left - 1);
            }
            if sink.host_gone {
                thread::sleep(Duration::from_millis(1));
            }
        }
    }
}

/// Hand one un-framed message to the device (or, for the emulator's own
/// `EmulatorStimulus` request, to the frame source); restart the source's
/// stream when the message started one.
fn deliver<H: Hal + RestartSource, K: Sink>(
    device: &mut Device<'_, H>,
    msg: &[u8],
    sink: &mut K,
    transport: firmware_protocol::Transport,
) {
    if msg.first() == Some(&KIND_EMULATOR_STIMULUS) && msg.len() >= 7 {
        let (covered, crc) = msg.split_at(msg.len() - 4);
        if firmware_protocol::crc32c(covered).to_le_bytes() == crc {
            let tag = u16::from_le_bytes([covered[1], covered[2]]);
            let ok = serde_json::from_slice::<Stimulus>(&covered[3..])
                .ok()
                .is_some_and(|st| device.hal_mut().present_stimulus(&st));
            let reply = if ok {
                firmware_protocol::Message::Ack {
                    request_kind: KIND_EMULATOR_STIMULUS,
                }
            } else {
                firmware_protocol::Message::Nak {
                    request_kind: KIND_EMULATOR_STIMULUS,
                    code: ErrorCode::MALFORMED,
                    detail: 0,
                }
            };
            let p = firmware_protocol::Packet::new(tag, reply);
            let mut buf = [0u8; 64];
            let n = match transport {
                firmware_protocol::Transport::Serial => p.encode_cobs(&mut buf),
                firmware_protocol::Transport::Usb => p.encode(&mut buf),
            };
            if let Ok(n) = n {
                let _ = sink.send(&buf[..n]);
            }
            return;
        }
    }
    let before = device.state();
    let _ = device.handle_message(msg, sink);
    if before != DeviceState::Streaming && device.state() == DeviceState::Streaming {
        device.hal_mut().restart_source();
    }
}

/// Lets `deliver` restart the frame source behind a HAL.
pub trait RestartSource {
    fn restart_source(&mut self);
    /// Apply a stimulus to every frame captured from now on.
    fn present_stimulus(&mut self, stimulus: &Stimulus) -> bool;
}

impl<S: FrameSource> RestartSource for SourceHal<'_, S> {
    fn present_stimulus(&mut self, stimulus: &Stimulus) -> bool {
        self.source.present(stimulus).unwrap_or(false)
    }

    fn restart_source(&mut self) {
        self.stream_start_us = self.now_us();
        self.source.restart();
    }
}

/// A running emulator thread.
pub struct EmulatorHandle {
    stop: Arc<AtomicBool>,
    thread: Option<thread::JoinHandle<Result<(), EmulatorError>>>,
    pub stats: Arc<EmulatorStats>,
}

impl EmulatorHandle {
    /// Start an emulator on its own thread.
    pub fn spawn<L, S>(link: L, mut source: S, config: EmulatorConfig) -> Self
    where
        L: DeviceLink + 'static,
        S: FrameSource + 'static,
    {
        let stop = Arc::new(AtomicBool::new(false));
        let stats = Arc::new(EmulatorStats::default());
        let (stop2, stats2) = (stop.clone(), stats.clone());
        let thread = thread::Builder::new()
            .name("gloam-emulator".into())
            .spawn(move || run_emulator(link, &mut source, &config, &stats2, &stop2))
            .expect("spawn emulator thread");
        Self {
            stop,
            thread: Some(thread),
            stats,
        }
    }

    /// Stop and join; returns the emulator's result.
    pub fn stop(mut self) -> Result<(), EmulatorError> {
        self.stop.store(true, Ordering::Relaxed);
        match self.thread.take().map(thread::JoinHandle::join) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(EmulatorError::Panicked),
            None => Ok(()),
        }
    }
}

impl Drop for EmulatorHandle {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
