//! The device side as a sans-IO state machine.
//!
//! [`Device`] owns no I/O: bytes (or already-decoded requests) go in through
//! [`Device::handle_bytes`] / [`Device::handle_message`] /
//! [`Device::handle_packet`], and every outgoing message leaves as one call
//! of [`Sink::send`] carrying exactly one wire unit (a COBS frame with its
//! delimiter on serial, one bulk transfer's bytes on USB). Hardware is
//! reached only through [`Hal`]. That is what lets the same core run on the
//! camera's microcontroller and, with the `sensor` simulation behind the HAL,
//! inside the host-side emulator.
//!
//! Driving loop (firmware main loop or emulator thread):
//! ```text
//! loop {
//!     if let Some(bytes) = link.try_read() { device.handle_bytes(bytes, &mut link)?; }
//!     while device.poll(&mut link)? == Activity::Busy {}   // or interleave reads
//! }
//! ```
//! `poll` emits at most one stream message per call so requests such as
//! `StopStream` are served between chunks of a large frame.

use crate::PENDING_GRACE_MS;
use crate::cobs::{CobsAccumulator, Feed, max_encoded_len};
use crate::crc32c::Crc32c;
use crate::error::{DecodeError, EncodeError};
use crate::message::{
    CHUNK_FIXED_LEN, CRC_LEN, Capabilities, Control, DeviceState, ErrorCode, FrameChunk,
    FrameLeader, FrameTrailer, HEADER_LEN, Hello, Kind, MAX_CHUNK_DATA_LEN, MAX_REQUEST_LEN,
    Message, PROTOCOL_VERSION_MAJOR, PROTOCOL_VERSION_MINOR, Packet, PixelFormat, Status,
    TestPattern, UNSOLICITED_TAG, bit_depths, decode_message, features,
};

/// The sink refused the bytes (link down, buffer full). The message is lost;
/// the protocol's CRCs, sequence numbers and timeouts cover the loss.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SinkError;

impl core::fmt::Display for SinkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("output sink refused the message")
    }
}

impl core::error::Error for SinkError {}

/// Where the device's encoded output goes.
pub trait Sink {
    /// Send one complete wire unit (COBS frame incl. delimiter, or one USB
    /// transfer's bytes — split with [`crate::usb::packets`]).
    fn send(&mut self, wire_bytes: &[u8]) -> Result<(), SinkError>;
}

/// Which framing the device speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transport {
    /// COBS frames with `0x00` delimiters (UART, CDC-ACM, pty).
    Serial,
    /// One message per USB bulk transfer, no stuffing.
    Usb,
}

/// Outcome of [`Hal::apply_control`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Applied {
    /// Took effect already.
    Done,
    /// Started; completion is reported by [`Hal::poll_pending`]. The device
    /// replies `Pending { eta_ms }` and fails with `TIMEOUT` after
    /// `eta_ms + PENDING_GRACE_MS`.
    InProgress { eta_ms: u32 },
}

/// What the HAL reports about a captured frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CaptureInfo {
    /// Start of exposure, on the [`Hal::now_us`] clock.
    pub timestamp_us: u64,
    /// Gain actually in effect (AGC may differ from the manual setting).
    pub gain_milli: u32,
    /// MCP voltage actually in effect.
    pub mcp_voltage_mv: u32,
    /// Bytes written to the frame buffer; less than the buffer length means
    /// the frame is sent with status `TRUNCATED`.
    pub valid_len_bytes: usize,
}

/// Current control values, validated by the device before reaching the HAL.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Settings {
    pub gain_milli: u32,
    pub mcp_voltage_mv: u32,
    pub agc_enabled: bool,
    pub agc_setpoint_ppm: u32,
    pub exposure_us: u32,
    pub gate_ns: u32,
    pub pixel_format: PixelFormat,
    pub width_px: u16,
    pub height_px: u16,
    pub test_pattern: TestPattern,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            gain_milli: 1000,
            mcp_voltage_mv: 0,
            agc_enabled: false,
            agc_setpoint_ppm: 500_000,
            exposure_us: 20_000,
            gate_ns: 20_000_000,
            pixel_format: PixelFormat::Mono16,
            width_px: 640,
            height_px: 480,
            test_pattern: TestPattern::Off,
        }
    }
}

impl Settings {
    /// Bytes of one frame's payload at these settings.
    #[must_use]
    pub fn payload_len_bytes(&self) -> usize {
        usize::from(self.width_px)
            * usize::from(self.height_px)
            * self.pixel_format.bytes_per_pixel()
    }

    /// The wire value of `control`.
    #[must_use]
    pub fn get(&self, control: Control) -> u32 {
        match control {
            Control::GainMilli => self.gain_milli,
            Control::McpVoltageMv => self.mcp_voltage_mv,
            Control::AgcEnabled => u32::from(self.agc_enabled),
            Control::AgcSetpointPpm => self.agc_setpoint_ppm,
            Control::ExposureUs => self.exposure_us,
            Control::GateNs => self.gate_ns,
            Control::BitDepth => self.pixel_format.bit_depth(),
            Control::FrameSize => u32::from(self.width_px) | (u32::from(self.height_px) << 16),
            Control::TestPattern => self.test_pattern as u32,
        }
    }

    /// Store an already validated wire value.
    fn set(&mut self, control: Control, value: u32) {
        match control {
            Control::GainMilli => self.gain_milli = value,
            Control::McpVoltageMv => self.mcp_voltage_mv = value,
            Control::AgcEnabled => self.agc_enabled = value != 0,
            Control::AgcSetpointPpm => self.agc_setpoint_ppm = value,
            Control::ExposureUs => self.exposure_us = value,
            Control::GateNs => self.gate_ns = value,
            Control::BitDepth => {
                if let Some(f) = PixelFormat::from_bit_depth(value) {
                    self.pixel_format = f;
                }
            }
            Control::FrameSize => {
                self.width_px = (value & 0xFFFF) as u16;
                self.height_px = (value >> 16) as u16;
            }
            Control::TestPattern => {
                if let Some(p) = TestPattern::from_u32(value) {
                    self.test_pattern = p;
                }
            }
        }
    }
}

/// The hardware the state machine drives.
pub trait Hal {
    /// Monotonic microsecond clock (frame timestamps, pending deadlines).
    fn now_us(&mut self) -> u64;
    /// Sensor temperature in milli-°C, `None` if there is no sensor.
    fn read_temperature_milli_c(&mut self) -> Option<i32>;
    /// Set the manual gain. Fast; used for [`Control::GainMilli`].
    fn set_gain(&mut self, gain_milli: u32) -> Result<(), ErrorCode>;
    /// Apply any other (already range-checked) control. `settings` holds the
    /// values *before* the change.
    fn apply_control(
        &mut self,
        control: Control,
        value: u32,
        settings: &Settings,
    ) -> Result<Applied, ErrorCode>;
    /// Completion of an [`Applied::InProgress`] operation: `None` while it
    /// is still running.
    fn poll_pending(&mut self) -> Option<Result<(), ErrorCode>> {
        Some(Ok(()))
    }
    /// Capture one frame at `settings` into `frame` (exactly
    /// `settings.payload_len_bytes()` long). `Ok(None)` = no frame ready yet
    /// (the device asks again on the next poll); `Err` = capture failed.
    fn capture_frame(
        &mut self,
        settings: &Settings,
        frame: &mut [u8],
    ) -> Result<Option<CaptureInfo>, ErrorCode>;
}

/// Fixed facts about the device, reported in `Capabilities`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeviceConfig {
    pub max_width_px: u16,
    pub max_height_px: u16,
    /// See [`bit_depths`].
    pub bit_depths: u8,
    /// See [`features`].
    pub features: u8,
    pub firmware_version: u32,
    pub serial_number: u32,
    pub max_gain_milli: u32,
    pub max_mcp_voltage_mv: u32,
    pub max_exposure_us: u32,
    /// Power-up control values.
    pub initial_settings: Settings,
}

/// Caller-provided memory for [`Device::new`].
pub struct DeviceBuffers<'a> {
    /// Encode buffer for one outgoing wire unit. Its size sets the chunk
    /// size: at least 64 bytes; [`crate::MAX_COBS_FRAME_LEN`] (serial) or
    /// [`crate::MAX_MESSAGE_LEN`] (USB) gives full 16 KiB chunks.
    pub tx: &'a mut [u8],
    /// Frame buffer; its length caps width × height × bytes per pixel.
    pub frame: &'a mut [u8],
}

/// Whether [`Device::poll`] has more to send right away.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Activity {
    /// Nothing to emit now; poll again later (e.g. next tick).
    Idle,
    /// A frame is being sent: poll again immediately.
    Busy,
}

#[derive(Debug, Clone, Copy)]
struct PendingOp {
    tag: u16,
    control: Control,
    value: u32,
    deadline_us: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Leader,
    Chunks,
    Trailer,
}

#[derive(Clone)]
struct InFlight {
    leader: FrameLeader,
    valid_len: usize,
    status: ErrorCode,
    sent_len: usize,
    /// Running CRC of the bytes sent so far.
    crc: Crc32c,
    phase: Phase,
}

#[derive(Clone)]
struct Stream {
    next_seq: u32,
    /// `None` = unbounded.
    frames_remaining: Option<u32>,
    in_flight: Option<InFlight>,
}

/// Smallest `tx` buffer accepted by [`Device::new`].
pub const MIN_TX_LEN: usize = 64;

/// The firmware core. See the module docs for the driving loop.
pub struct Device<'a, H: Hal> {
    hal: H,
    config: DeviceConfig,
    transport: Transport,
    rx: CobsAccumulator<[u8; MAX_REQUEST_LEN]>,
    tx: &'a mut [u8],
    frame: &'a mut [u8],
    /// Largest chunk the tx buffer can carry.
    tx_chunk_len: usize,
    /// Chunk size negotiated at `Hello`.
    chunk_len: usize,
    state: DeviceState,
    settings: Settings,
    pending: Option<PendingOp>,
    stream: Option<Stream>,
    frames_sent: u32,
    rx_errors: u32,
}

impl<'a, H: Hal> Device<'a, H> {
    /// Build a device. Fails if `tx` is shorter than [`MIN_TX_LEN`].
    pub fn new(
        hal: H,
        config: DeviceConfig,
        transport: Transport,
        buffers: DeviceBuffers<'a>,
    ) -> Result<Self, EncodeError> {
        if buffers.tx.len() < MIN_TX_LEN {
            return Err(EncodeError::BufferTooSmall {
                needed_len: MIN_TX_LEN,
            });
        }
        let tx_chunk_len = max_chunk_for_tx(buffers.tx.len(), transport);
        Ok(Self {
            hal,
            config,
            transport,
            rx: CobsAccumulator::new([0; MAX_REQUEST_LEN]),
            tx: buffers.tx,
            frame: buffers.frame,
            tx_chunk_len,
            chunk_len: tx_chunk_len,
            state: DeviceState::AwaitingHello,
            settings: config.initial_settings,
            pending: None,
            stream: None,
            frames_sent: 0,
            rx_errors: 0,
        })
    }

    /// Current protocol state.
    pub fn state(&self) -> DeviceState {
        self.state
    }

    /// Current control values.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The HAL (e.g. for an emulator to inspect or drive it).
    pub fn hal_mut(&mut self) -> &mut H {
        &mut self.hal
    }

    /// Pixel bytes per chunk in this session.
    pub fn chunk_data_len(&self) -> usize {
        self.chunk_len
    }

    /// Serial transport: feed raw received bytes (any chunking). Each
    /// complete frame is decoded and handled; corrupt ones are counted and
    /// answered with `Nak(CORRUPT_REQUEST)` on tag 0.
    pub fn handle_bytes(
        &mut self,
        mut bytes: &[u8],
        sink: &mut impl Sink,
    ) -> Result<(), SinkError> {
        let mut result = Ok(());
        while !bytes.is_empty() {
            let (used, feed) = self.rx.feed(bytes);
            bytes = bytes.get(used..).unwrap_or(&[]);
            let mut copy = [0u8; MAX_REQUEST_LEN];
            let len = match feed {
                Feed::NeedMore => continue,
                Feed::Frame(f) => {
                    copy[..f.len()].copy_from_slice(f);
                    f.len()
                }
                Feed::Error(_) => {
                    result = result.and(self.corrupt_request(sink));
                    continue;
                }
            };
            let r = self.handle_message(&copy[..len], sink);
            result = result.and(r);
        }
        result
    }

    /// Handle one un-framed message (a COBS-decoded frame, or one USB
    /// transfer).
    pub fn handle_message(&mut self, bytes: &[u8], sink: &mut impl Sink) -> Result<(), SinkError> {
        match decode_message(bytes) {
            Ok(p) => self.handle_packet(&p, sink),
            Err(
                DecodeError::TooShort { .. }
                | DecodeError::TooLong { .. }
                | DecodeError::BadCrc { .. },
            ) => self.corrupt_request(sink),
            Err(e) => {
                // CRC passed, so the header is authentic: answer on its tag.
                let kind = bytes.first().copied().unwrap_or(0);
                let tag = match bytes.get(1..3) {
                    Some(t) => u16::from_le_bytes([t[0], t[1]]),
                    None => UNSOLICITED_TAG,
                };
                let code = match e {
                    DecodeError::UnknownKind { .. } => ErrorCode::UNKNOWN_MESSAGE,
                    DecodeError::BadField {
                        field_offset: 0, ..
                    } if kind == Kind::GetControl as u8 || kind == Kind::SetControl as u8 => {
                        ErrorCode::UNKNOWN_CONTROL
                    }
                    _ => ErrorCode::MALFORMED,
                };
                self.nak(tag, kind, code, 0, sink)
            }
        }
    }

    /// Handle one decoded packet (any transport).
    pub fn handle_packet(
        &mut self,
        packet: &Packet<'_>,
        sink: &mut impl Sink,
    ) -> Result<(), SinkError> {
        let tag = packet.tag;
        let kind = packet.message.kind() as u8;
        match packet.message {
            Message::Hello(h) => self.on_hello(tag, h, sink),
            Message::GetStatus => {
                let status = Status {
                    state: self.state,
                    temperature_milli_c: self.hal.read_temperature_milli_c().unwrap_or(i32::MIN),
                    frames_sent: self.frames_sent,
                    rx_errors: self.rx_errors,
                    device_time_us: self.hal.now_us(),
                };
                self.reply(tag, Message::Status(status), sink)
            }
            m if !m.kind().is_request() => self.nak(tag, kind, ErrorCode::UNKNOWN_MESSAGE, 0, sink),
            _ if self.state == DeviceState::AwaitingHello => {
                self.nak(tag, kind, ErrorCode::HANDSHAKE_REQUIRED, 0, sink)
            }
            Message::GetControl { control } => {
                if let Err(code) = self.supported(control) {
                    return self.nak(tag, kind, code, 0, sink);
                }
                let value = self.settings.get(control);
                self.reply(tag, Message::ControlValue { control, value }, sink)
            }
            Message::SetControl { control, value } => self.on_set(tag, control, value, sink),
            Message::StartStream { frame_count } => {
                if self.stream.is_some() {
                    return self.nak(tag, kind, ErrorCode::BUSY, 0, sink);
                }
                self.stream = Some(Stream {
                    next_seq: 0,
                    frames_remaining: if frame_count == 0 {
                        None
                    } else {
                        Some(frame_count)
                    },
                    in_flight: None,
                });
                self.state = DeviceState::Streaming;
                self.ack(tag, kind, sink)
            }
            Message::StopStream => {
                let r = self.stop_stream(sink);
                r.and(self.ack(tag, kind, sink))
            }
            // Replies and stream kinds were handled by the `is_request` arm.
            _ => self.nak(tag, kind, ErrorCode::UNKNOWN_MESSAGE, 0, sink),
        }
    }

    fn on_hello(&mut self, tag: u16, h: Hello, sink: &mut impl Sink) -> Result<(), SinkError> {
        if h.version_major != PROTOCOL_VERSION_MAJOR {
            let detail = u32::from(PROTOCOL_VERSION_MAJOR) << 8 | u32::from(PROTOCOL_VERSION_MINOR);
            return self.nak(
                tag,
                Kind::Hello as u8,
                ErrorCode::UNSUPPORTED_VERSION,
                detail,
                sink,
            );
        }
        // A new session: stop any stream so both sides start clean.
        let r = self.stop_stream(sink);
        let host_chunk = usize::from(h.host_max_message_len)
            .saturating_sub(HEADER_LEN + CHUNK_FIXED_LEN + CRC_LEN)
            & !1;
        self.chunk_len = self.tx_chunk_len.min(host_chunk).max(2);
        self.state = DeviceState::Ready;
        let caps = Capabilities {
            version_major: PROTOCOL_VERSION_MAJOR,
            version_minor: PROTOCOL_VERSION_MINOR,
            chunk_data_len: u16::try_from(self.chunk_len).unwrap_or(u16::MAX),
            max_width_px: self.config.max_width_px,
            max_height_px: self.config.max_height_px,
            bit_depths: self.config.bit_depths,
            features: self.config.features,
            firmware_version: self.config.firmware_version,
            serial_number: self.config.serial_number,
            frame_buffer_len_bytes: u32::try_from(self.frame.len()).unwrap_or(u32::MAX),
        };
        r.and(self.reply(tag, Message::Capabilities(caps), sink))
    }

    /// Is `control` backed by hardware on this device?
    fn supported(&self, control: Control) -> Result<(), ErrorCode> {
        let need = match control {
            Control::McpVoltageMv => features::MCP,
            Control::AgcEnabled | Control::AgcSetpointPpm => features::AGC,
            Control::GateNs => features::GATE,
            _ => 0,
        };
        if self.config.features & need == need {
            Ok(())
        } else {
            Err(ErrorCode::NOT_SUPPORTED)
        }
    }

    /// Range and state checks for a `SetControl`.
    fn validate(&self, control: Control, value: u32) -> Result<(), ErrorCode> {
        self.supported(control)?;
        let streaming = self.stream.is_some();
        let ok = match control {
            Control::GainMilli => (1..=self.config.max_gain_milli).contains(&value),
            Control::McpVoltageMv => value <= self.config.max_mcp_voltage_mv,
            Control::AgcEnabled => value <= 1,
            Control::AgcSetpointPpm => value <= 1_000_000,
            Control::ExposureUs => (1..=self.config.max_exposure_us).contains(&value),
            Control::GateNs => value >= 1,
            Control::BitDepth => {
                if streaming {
                    return Err(ErrorCode::BUSY);
                }
                let bit = match value {
                    8 => bit_depths::MONO8,
                    12 => bit_depths::MONO12,
                    16 => bit_depths::MONO16,
                    _ => return Err(ErrorCode::OUT_OF_RANGE),
                };
                if self.config.bit_depths & bit == 0 {
                    return Err(ErrorCode::NOT_SUPPORTED);
                }
                let mut s = self.settings;
                s.set(control, value);
                s.payload_len_bytes() <= self.frame.len()
            }
            Control::FrameSize => {
                if streaming {
                    return Err(ErrorCode::BUSY);
                }
                let (w, h) = (value & 0xFFFF, value >> 16);
                let mut s = self.settings;
                s.set(control, value);
                (1..=u32::from(self.config.max_width_px)).contains(&w)
                    && (1..=u32::from(self.config.max_height_px)).contains(&h)
                    && s.payload_len_bytes() <= self.frame.len()
            }
            Control::TestPattern => match TestPattern::from_u32(value) {
                None => false,
                Some(TestPattern::Off) => true,
                Some(_) if self.config.features & features::TEST_PATTERN == 0 => {
                    return Err(ErrorCode::NOT_SUPPORTED);
                }
                Some(_) => true,
            },
        };
        if ok {
            Ok(())
        } else {
            Err(ErrorCode::OUT_OF_RANGE)
        }
    }

    fn on_set(
        &mut self,
        tag: u16,
        control: Control,
        value: u32,
        sink: &mut impl Sink,
    ) -> Result<(), SinkError> {
        let kind = Kind::SetControl as u8;
        if self.pending.is_some() {
            return self.nak(tag, kind, ErrorCode::BUSY, 0, sink);
        }
        if let Err(code) = self.validate(control, value) {
            let detail = if code == ErrorCode::OUT_OF_RANGE {
                value
            } else {
                0
            };
            return self.nak(tag, kind, code, detail, sink);
        }
        let applied = if control == Control::GainMilli {
            self.hal.set_gain(value).map(|()| Applied::Done)
        } else {
            self.hal.apply_control(control, value, &self.settings)
        };
        match applied {
            Ok(Applied::Done) => {
                self.settings.set(control, value);
                self.ack(tag, kind, sink)
            }
            Ok(Applied::InProgress { eta_ms }) => {
                let deadline_us = self
                    .hal
                    .now_us()
                    .saturating_add(u64::from(eta_ms.saturating_add(PENDING_GRACE_MS)) * 1000);
                self.pending = Some(PendingOp {
                    tag,
                    control,
                    value,
                    deadline_us,
                });
                self.reply(
                    tag,
                    Message::Pending {
                        request_kind: kind,
                        eta_ms,
                    },
                    sink,
                )
            }
            Err(code) => self.nak(tag, kind, code, 0, sink),
        }
    }

    /// Abort the frame in flight (trailer `ABORTED`) and leave streaming.
    fn stop_stream(&mut self, sink: &mut impl Sink) -> Result<(), SinkError> {
        let Some(stream) = self.stream.take() else {
            return Ok(());
        };
        if self.state == DeviceState::Streaming {
            self.state = DeviceState::Ready;
        }
        match stream.in_flight {
            Some(f) if f.phase != Phase::Leader => {
                let trailer = FrameTrailer {
                    seq: f.leader.seq,
                    status: ErrorCode::ABORTED,
                    valid_len_bytes: f.sent_len as u32,
                    crc32c: f.crc.value(),
                };
                self.frames_sent = self.frames_sent.wrapping_add(1);
                self.reply(UNSOLICITED_TAG, Message::FrameTrailer(trailer), sink)
            }
            _ => Ok(()),
        }
    }

    /// Advance time-driven work: pending slow operations and streaming. Emits
    /// at most one stream message per call.
    pub fn poll(&mut self, sink: &mut impl Sink) -> Result<Activity, SinkError> {
        let mut result = Ok(());
        if let Some(p) = self.pending {
            let outcome = match self.hal.poll_pending() {
                Some(r) => Some(r),
                None if self.hal.now_us() >= p.deadline_us => Some(Err(ErrorCode::TIMEOUT)),
                None => None,
            };
            if let Some(r) = outcome {
                self.pending = None;
                let kind = Kind::SetControl as u8;
                result = match r {
                    Ok(()) => {
                        self.settings.set(p.control, p.value);
                        self.ack(p.tag, kind, sink)
                    }
                    Err(code) => self.nak(p.tag, kind, code, 0, sink),
                };
            }
        }
        let activity = self.poll_stream(sink);
        result.and(activity)
    }

    fn poll_stream(&mut self, sink: &mut impl Sink) -> Result<Activity, SinkError> {
        let Some(mut stream) = self.stream.take() else {
            return Ok(Activity::Idle);
        };
        let mut f = match stream.in_flight.take() {
            Some(f) => f,
            None => {
                if stream.frames_remaining == Some(0) {
                    self.state = DeviceState::Ready;
                    return Ok(Activity::Idle);
                }
                let payload_len = self.settings.payload_len_bytes().min(self.frame.len());
                let (info, status) = match self
                    .hal
                    .capture_frame(&self.settings, &mut self.frame[..payload_len])
                {
                    Ok(None) => {
                        self.stream = Some(stream);
                        return Ok(Activity::Idle);
                    }
                    Ok(Some(info)) => {
                        let status = if info.valid_len_bytes < payload_len {
                            ErrorCode::TRUNCATED
                        } else {
                            ErrorCode::OK
                        };
                        (info, status)
                    }
                    Err(code) => {
                        let now = self.hal.now_us();
                        let info = CaptureInfo {
                            timestamp_us: now,
                            gain_milli: self.settings.gain_milli,
                            mcp_voltage_mv: self.settings.mcp_voltage_mv,
                            valid_len_bytes: 0,
                        };
                        (info, code)
                    }
                };
                let s = &self.settings;
                InFlight {
                    leader: FrameLeader {
                        seq: stream.next_seq,
                        timestamp_us: info.timestamp_us,
                        width_px: s.width_px,
                        height_px: s.height_px,
                        pixel_format: s.pixel_format,
                        agc_enabled: s.agc_enabled,
                        test_pattern: s.test_pattern as u8,
                        gain_milli: info.gain_milli,
                        mcp_voltage_mv: info.mcp_voltage_mv,
                        agc_setpoint_ppm: s.agc_setpoint_ppm,
                        exposure_us: s.exposure_us,
                        gate_ns: s.gate_ns,
                        payload_len_bytes: payload_len as u32,
                    },
                    valid_len: info.valid_len_bytes.min(payload_len),
                    status,
                    sent_len: 0,
                    crc: Crc32c::new(),
                    phase: Phase::Leader,
                }
            }
        };
        let (transport, tx) = (self.transport, &mut *self.tx);
        let result = match f.phase {
            Phase::Leader => {
                f.phase = if f.valid_len > 0 {
                    Phase::Chunks
                } else {
                    Phase::Trailer
                };
                emit(
                    transport,
                    tx,
                    sink,
                    &Packet::new(UNSOLICITED_TAG, Message::FrameLeader(f.leader)),
                )
            }
            Phase::Chunks => {
                let end = (f.sent_len + self.chunk_len).min(f.valid_len);
                let data = self.frame.get(f.sent_len..end).unwrap_or(&[]);
                let chunk = FrameChunk {
                    seq: f.leader.seq,
                    offset_bytes: f.sent_len as u32,
                    data,
                };
                let r = emit(
                    transport,
                    tx,
                    sink,
                    &Packet::new(UNSOLICITED_TAG, Message::FrameChunk(chunk)),
                );
                f.crc.update(data);
                f.sent_len = end;
                if end >= f.valid_len {
                    f.phase = Phase::Trailer;
                }
                r
            }
            Phase::Trailer => {
                let trailer = FrameTrailer {
                    seq: f.leader.seq,
                    status: f.status,
                    valid_len_bytes: f.sent_len as u32,
                    crc32c: f.crc.value(),
                };
                let r = emit(
                    transport,
                    tx,
                    sink,
                    &Packet::new(UNSOLICITED_TAG, Message::FrameTrailer(trailer)),
                );
                self.frames_sent = self.frames_sent.wrapping_add(1);
                stream.next_seq = stream.next_seq.wrapping_add(1);
                stream.frames_remaining = stream.frames_remaining.map(|n| n.saturating_sub(1));
                stream.in_flight = None;
                self.stream = Some(stream);
                return r.map(|()| Activity::Busy);
            }
        };
        stream.in_flight = Some(f);
        self.stream = Some(stream);
        result.map(|()| Activity::Busy)
    }

    /// A request frame failed framing/length/CRC checks: its tag cannot be
    /// trusted, so answer on tag 0 and let the host resend.
    fn corrupt_request(&mut self, sink: &mut impl Sink) -> Result<(), SinkError> {
        self.rx_errors = self.rx_errors.wrapping_add(1);
        self.reply(
            UNSOLICITED_TAG,
            Message::Nak {
                request_kind: 0,
                code: ErrorCode::CORRUPT_REQUEST,
                detail: 0,
            },
            sink,
        )
    }

    fn ack(&mut self, tag: u16, request_kind: u8, sink: &mut impl Sink) -> Result<(), SinkError> {
        self.reply(tag, Message::Ack { request_kind }, sink)
    }

    fn nak(
        &mut self,
        tag: u16,
        request_kind: u8,
        code: ErrorCode,
        detail: u32,
        sink: &mut impl Sink,
    ) -> Result<(), SinkError> {
        self.reply(
            tag,
            Message::Nak {
                request_kind,
                code,
                detail,
            },
            sink,
        )
    }

    fn reply(
        &mut self,
        tag: u16,
        message: Message<'_>,
        sink: &mut impl Sink,
    ) -> Result<(), SinkError> {
        emit(self.transport, self.tx, sink, &Packet::new(tag, message))
    }
}

/// Encode `p` for `transport` into `tx` and hand it to `sink`.
fn emit(
    transport: Transport,
    tx: &mut [u8],
    sink: &mut impl Sink,
    p: &Packet<'_>,
) -> Result<(), SinkError> {
    match encode_for(transport, p, tx) {
        Ok(n) => sink.send(&tx[..n]),
        // Unreachable in practice: `tx` was sized for the largest message
        // and chunks are cut to fit it. Reported as a lost message.
        Err(_) => Err(SinkError),
    }
}

fn encode_for(transport: Transport, p: &Packet<'_>, out: &mut [u8]) -> Result<usize, EncodeError> {
    match transport {
        Transport::Serial => p.encode_cobs(out),
        Transport::Usb => p.encode(out),
    }
}

/// Largest even chunk data length whose worst-case wire form fits `tx_len`.
fn max_chunk_for_tx(tx_len: usize, transport: Transport) -> usize {
    let overhead = HEADER_LEN + CHUNK_FIXED_LEN + CRC_LEN;
    let fits = |c: usize| match transport {
        Transport::Serial => max_encoded_len(overhead + c) < tx_len,
        Transport::Usb => overhead + c <= tx_len,
    };
    let mut c = MAX_CHUNK_DATA_LEN.min(tx_len.saturating_sub(overhead)) & !1;
    while c > 2 && !fits(c) {
        c -= 2;
    }
    c
}

/// Fill `frame` with `pattern` at the given geometry (helper for HALs and
/// emulators; [`TestPattern::Off`] leaves the buffer untouched). Returns the
/// bytes written.
pub fn fill_test_pattern(
    pattern: TestPattern,
    format: PixelFormat,
    width_px: u16,
    height_px: u16,
    frame: &mut [u8],
) -> usize {
    let bpp = format.bytes_per_pixel();
    let max = (1u32 << format.bit_depth()) - 1;
    let w = usize::from(width_px);
    let mut written = 0;
    for (i, px) in frame
        .chunks_exact_mut(bpp)
        .take(w * usize::from(height_px))
        .enumerate()
    {
        let (x, y) = ((i % w.max(1)) as u32, (i / w.max(1)) as u32);
        let v = match pattern {
            TestPattern::Off => return 0,
            TestPattern::Ramp => (x + y) & max,
            TestPattern::Checkerboard => {
                if ((x / 8) + (y / 8)) % 2 == 0 {
                    0
                } else {
                    max
                }
            }
            TestPattern::Flat => max / 2 + 1,
        };
        if bpp == 1 {
            px[0] = v as u8;
        } else {
            px.copy_from_slice(&(v as u16).to_le_bytes());
        }
        written += bpp;
    }
    written
}
