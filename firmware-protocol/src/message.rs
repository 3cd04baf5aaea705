//! Message types and their byte layout (see `PROTOCOL.md` §3–§5).
//!
//! Every message is `kind: u8 | tag: u16 LE | body | crc32c: u32 LE`, the CRC
//! covering kind, tag and body. All multi-byte integers are little-endian
//! because every target we build for (Cortex-M, x86-64, AArch64) is, so
//! neither side byte-swaps pixel data or fields.

use core::fmt;

use crate::cobs::CobsEncoder;
use crate::crc32c::{Crc32c, crc32c};
use crate::error::{DecodeError, EncodeError};

/// Protocol major version: a device only talks to hosts with the same major.
pub const PROTOCOL_VERSION_MAJOR: u8 = 1;
/// Protocol minor version: backwards-compatible additions.
pub const PROTOCOL_VERSION_MINOR: u8 = 0;

/// `kind` + `tag`.
pub const HEADER_LEN: usize = 3;
/// Trailing CRC-32C.
pub const CRC_LEN: usize = 4;
/// Fixed part of a chunk body (`seq`, `offset_bytes`) before the pixel data.
pub const CHUNK_FIXED_LEN: usize = 8;
/// Largest pixel-data slice in one [`FrameChunk`]. 16 KiB keeps a chunk
/// cheap to buffer on a microcontroller and a lost chunk cheap on serial,
/// while amortising the 15 bytes of per-chunk overhead to < 0.1 %.
pub const MAX_CHUNK_DATA_LEN: usize = 16 * 1024;
/// Largest message of any kind, un-framed (a full chunk).
pub const MAX_MESSAGE_LEN: usize = HEADER_LEN + CHUNK_FIXED_LEN + MAX_CHUNK_DATA_LEN + CRC_LEN;
/// Largest host→device request. Devices may size their receive buffer to this.
pub const MAX_REQUEST_LEN: usize = 16;
/// Largest COBS frame on the wire, delimiter included.
pub const MAX_COBS_FRAME_LEN: usize = crate::cobs::max_encoded_len(MAX_MESSAGE_LEN) + 1;
/// Tag reserved for device-initiated messages (stream data, unsolicited
/// errors). Hosts use tags 1..=65535 for requests.
pub const UNSOLICITED_TAG: u16 = 0;

/// Message kind byte. Requests are 0x01–0x3F, replies 0x41–0x7F, stream
/// messages 0x81–0xBF.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Kind {
    Hello = 0x01,
    GetControl = 0x02,
    SetControl = 0x03,
    StartStream = 0x04,
    StopStream = 0x05,
    GetStatus = 0x06,
    Capabilities = 0x41,
    Ack = 0x42,
    Nak = 0x43,
    ControlValue = 0x44,
    Pending = 0x45,
    Status = 0x46,
    FrameLeader = 0x81,
    FrameChunk = 0x82,
    FrameTrailer = 0x83,
}

impl Kind {
    /// Every kind, in code order (for tests and documentation).
    pub const ALL: [Kind; 15] = [
        Kind::Hello,
        Kind::GetControl,
        Kind::SetControl,
        Kind::StartStream,
        Kind::StopStream,
        Kind::GetStatus,
        Kind::Capabilities,
        Kind::Ack,
        Kind::Nak,
        Kind::ControlValue,
        Kind::Pending,
        Kind::Status,
        Kind::FrameLeader,
        Kind::FrameChunk,
        Kind::FrameTrailer,
    ];

    /// Parse a kind byte.
    #[must_use]
    pub fn from_u8(code: u8) -> Option<Self> {
        Self::ALL.iter().copied().find(|k| *k as u8 == code)
    }

    /// Body length for fixed-size kinds; `None` for [`Kind::FrameChunk`],
    /// whose body is `CHUNK_FIXED_LEN` + 0..=`MAX_CHUNK_DATA_LEN` bytes.
    #[must_use]
    pub const fn body_len(self) -> Option<usize> {
        Some(match self {
            Kind::Hello => 4,
            Kind::GetControl => 1,
            Kind::SetControl => 5,
            Kind::StartStream => 4,
            Kind::StopStream | Kind::GetStatus => 0,
            Kind::Capabilities => 22,
            Kind::Ack => 1,
            Kind::Nak => 6,
            Kind::ControlValue => 5,
            Kind::Pending => 5,
            Kind::Status => 21,
            Kind::FrameLeader => 43,
            Kind::FrameChunk => return None,
            Kind::FrameTrailer => 13,
        })
    }

    /// True for host→device requests.
    #[must_use]
    pub const fn is_request(self) -> bool {
        (self as u8) < 0x40
    }
}

/// A control the host can get and set. All values travel as `u32`; the unit
/// is in the variant name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Control {
    /// CCD/analog gain in thousandths (1000 = ×1). Under AGC this is the
    /// manual value; the gain in effect is reported per frame.
    GainMilli = 0x01,
    /// Micro-channel-plate voltage in millivolts. Slow: may reply `Pending`.
    McpVoltageMv = 0x02,
    /// Automatic gain control: 0 = off, 1 = on.
    AgcEnabled = 0x03,
    /// AGC target mean level, parts per million of full scale (0..=1_000_000).
    AgcSetpointPpm = 0x04,
    /// CCD integration (exposure) time in microseconds.
    ExposureUs = 0x05,
    /// Intensifier gate width in nanoseconds.
    GateNs = 0x06,
    /// Digitiser bit depth: 8, 12 or 16. Not settable while streaming.
    BitDepth = 0x07,
    /// Frame size, `width | height << 16` (pixels). Not settable while streaming.
    FrameSize = 0x08,
    /// Test pattern: see [`TestPattern`].
    TestPattern = 0x09,
}

impl Control {
    /// Every control, in code order.
    pub const ALL: [Control; 9] = [
        Control::GainMilli,
        Control::McpVoltageMv,
        Control::AgcEnabled,
        Control::AgcSetpointPpm,
        Control::ExposureUs,
        Control::GateNs,
        Control::BitDepth,
        Control::FrameSize,
        Control::TestPattern,
    ];

    /// Parse a control id.
    #[must_use]
    pub fn from_u8(code: u8) -> Option<Self> {
        Self::ALL.iter().copied().find(|c| *c as u8 == code)
    }
}

/// Values of [`Control::TestPattern`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum TestPattern {
    /// Real sensor data.
    Off = 0,
    /// Pixel value = (x + y) mod 2^bits.
    Ramp = 1,
    /// 8×8-pixel checkerboard of 0 and full scale.
    Checkerboard = 2,
    /// Every pixel at half scale.
    Flat = 3,
}

impl TestPattern {
    /// Parse a test-pattern value.
    #[must_use]
    pub fn from_u32(v: u32) -> Option<Self> {
        Some(match v {
            0 => Self::Off,
            1 => Self::Ramp,
            2 => Self::Checkerboard,
            3 => Self::Flat,
            _ => return None,
        })
    }
}

/// Pixel layout of a frame payload. Row-major, top row first, no padding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum PixelFormat {
    /// One byte per pixel.
    Mono8 = 0x08,
    /// 12-bit values in the low bits of a `u16` LE (top 4 bits zero).
    Mono12 = 0x0C,
    /// `u16` LE.
    Mono16 = 0x10,
}

impl PixelFormat {
    /// Parse a pixel-format code.
    #[must_use]
    pub fn from_u8(code: u8) -> Option<Self> {
        Some(match code {
            0x08 => Self::Mono8,
            0x0C => Self::Mono12,
            0x10 => Self::Mono16,
            _ => return None,
        })
    }

    /// The format for a bit depth of 8, 12 or 16.
    #[must_use]
    pub fn from_bit_depth(bits: u32) -> Option<Self> {
        Self::from_u8(u8::try_from(bits).ok()?)
    }

    /// Significant bits per pixel.
    #[must_use]
    pub const fn bit_depth(self) -> u32 {
        self as u32
    }

    /// Bytes each pixel occupies in the payload.
    #[must_use]
    pub const fn bytes_per_pixel(self) -> usize {
        match self {
            Self::Mono8 => 1,
            Self::Mono12 | Self::Mono16 => 2,
        }
    }
}

/// Status / error code used in `Nak` and `FrameTrailer`.
///
/// A newtype over `u8` rather than an enum so that a host can carry codes
/// added by a newer minor version without failing to decode the message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ErrorCode(pub u8);

impl ErrorCode {
    /// Success (trailer status only).
    pub const OK: Self = Self(0x00);
    /// The request kind is not known to this device.
    pub const UNKNOWN_MESSAGE: Self = Self(0x01);
    /// The request body has the wrong length or an invalid field.
    pub const MALFORMED: Self = Self(0x02);
    /// A frame failed COBS or CRC checks; sent with tag 0 because the real tag
    /// is untrustworthy. The host should resend its outstanding request.
    pub const CORRUPT_REQUEST: Self = Self(0x03);
    /// A request other than `Hello` arrived before a successful handshake.
    pub const HANDSHAKE_REQUIRED: Self = Self(0x04);
    /// `Hello` carried a different major version; detail = device major<<8|minor.
    pub const UNSUPPORTED_VERSION: Self = Self(0x05);
    /// The control id is not known.
    pub const UNKNOWN_CONTROL: Self = Self(0x06);
    /// The value is outside the control's range; detail = the rejected value.
    pub const OUT_OF_RANGE: Self = Self(0x07);
    /// Not allowed in the current state (streaming, or a slow operation pending).
    pub const BUSY: Self = Self(0x08);
    /// The device lacks the hardware for this control.
    pub const NOT_SUPPORTED: Self = Self(0x09);
    /// A slow operation did not finish by its deadline.
    pub const TIMEOUT: Self = Self(0x0A);
    /// The hardware reported a fault.
    pub const HARDWARE_FAULT: Self = Self(0x0B);
    /// Trailer: the capture failed; `valid_len_bytes` bytes were sent.
    pub const CAPTURE_FAILED: Self = Self(0x0C);
    /// Trailer: fewer bytes than `payload_len_bytes` were captured.
    pub const TRUNCATED: Self = Self(0x0D);
    /// Trailer: the stream was stopped (`StopStream` or `Hello`) mid-frame.
    pub const ABORTED: Self = Self(0x0E);

    /// Symbolic name, or `None` for a code this version does not define.
    #[must_use]
    pub const fn name(self) -> Option<&'static str> {
        Some(match self.0 {
            0x00 => "OK",
            0x01 => "UNKNOWN_MESSAGE",
            0x02 => "MALFORMED",
            0x03 => "CORRUPT_REQUEST",
            0x04 => "HANDSHAKE_REQUIRED",
            0x05 => "UNSUPPORTED_VERSION",
            0x06 => "UNKNOWN_CONTROL",
            0x07 => "OUT_OF_RANGE",
            0x08 => "BUSY",
            0x09 => "NOT_SUPPORTED",
            0x0A => "TIMEOUT",
            0x0B => "HARDWARE_FAULT",
            0x0C => "CAPTURE_FAILED",
            0x0D => "TRUNCATED",
            0x0E => "ABORTED",
            _ => return None,
        })
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.name() {
            Some(n) => write!(f, "{n} ({:#04x})", self.0),
            None => write!(f, "unknown code {:#04x}", self.0),
        }
    }
}

/// Device state as reported in [`Status`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum DeviceState {
    /// Power-up: only `Hello` (and `GetStatus`) accepted.
    AwaitingHello = 0,
    /// Handshake done, not streaming.
    Ready = 1,
    /// Emitting frames.
    Streaming = 2,
}

impl DeviceState {
    fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::AwaitingHello,
            1 => Self::Ready,
            2 => Self::Streaming,
            _ => return None,
        })
    }
}

/// Bit set of supported bit depths in [`Capabilities::bit_depths`].
pub mod bit_depths {
    pub const MONO8: u8 = 1 << 0;
    pub const MONO12: u8 = 1 << 1;
    pub const MONO16: u8 = 1 << 2;
}

/// Bit set of optional hardware in [`Capabilities::features`].
pub mod features {
    /// Has an MCP power supply ([`crate::Control::McpVoltageMv`]).
    pub const MCP: u8 = 1 << 0;
    /// Has AGC.
    pub const AGC: u8 = 1 << 1;
    /// Has a gateable intensifier ([`crate::Control::GateNs`]).
    pub const GATE: u8 = 1 << 2;
    /// Can generate test patterns.
    pub const TEST_PATTERN: u8 = 1 << 3;
    /// Has a temperature sensor.
    pub const TEMPERATURE: u8 = 1 << 4;
}

/// Host's opening request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Hello {
    pub version_major: u8,
    pub version_minor: u8,
    /// Largest message the host can receive; the device sizes chunks to fit.
    pub host_max_message_len: u16,
}

/// Device's reply to `Hello`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Capabilities {
    pub version_major: u8,
    pub version_minor: u8,
    /// Pixel bytes per `FrameChunk` the device will send this session.
    pub chunk_data_len: u16,
    pub max_width_px: u16,
    pub max_height_px: u16,
    /// See [`bit_depths`].
    pub bit_depths: u8,
    /// See [`features`].
    pub features: u8,
    /// Firmware version, `major << 16 | minor << 8 | patch`.
    pub firmware_version: u32,
    pub serial_number: u32,
    /// Largest frame payload the device can buffer.
    pub frame_buffer_len_bytes: u32,
}

/// Device status (reply to `GetStatus`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Status {
    pub state: DeviceState,
    /// Sensor temperature in milli-degrees Celsius (`i32::MIN` = unavailable).
    pub temperature_milli_c: i32,
    /// Frames emitted since power-up (wraps).
    pub frames_sent: u32,
    /// Corrupt or overrun request frames received since power-up (wraps).
    pub rx_errors: u32,
    /// Device clock, microseconds since power-up: same clock as frame timestamps.
    pub device_time_us: u64,
}

/// First message of every frame: what the frame is and the settings that
/// were in effect when it was captured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameLeader {
    /// Frame sequence number, +1 per frame (wraps), starting at 0 each stream.
    pub seq: u32,
    /// Start of exposure, device clock in microseconds.
    pub timestamp_us: u64,
    pub width_px: u16,
    pub height_px: u16,
    pub pixel_format: PixelFormat,
    pub agc_enabled: bool,
    pub test_pattern: u8,
    /// Gain in effect (AGC may have changed it), thousandths.
    pub gain_milli: u32,
    pub mcp_voltage_mv: u32,
    pub agc_setpoint_ppm: u32,
    pub exposure_us: u32,
    pub gate_ns: u32,
    /// `width * height * bytes_per_pixel`: bytes the chunks will carry.
    pub payload_len_bytes: u32,
}

/// A slice of a frame's pixel bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameChunk<'a> {
    pub seq: u32,
    /// Position of `data[0]` within the frame payload.
    pub offset_bytes: u32,
    pub data: &'a [u8],
}

/// Last message of every frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameTrailer {
    pub seq: u32,
    /// [`ErrorCode::OK`] or why the frame is incomplete.
    pub status: ErrorCode,
    /// Payload bytes actually sent (== `payload_len_bytes` when OK).
    pub valid_len_bytes: u32,
    /// CRC-32C of the first `valid_len_bytes` payload bytes.
    pub crc32c: u32,
}

/// Every message of the protocol.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Message<'a> {
    Hello(Hello),
    GetControl {
        control: Control,
    },
    SetControl {
        control: Control,
        value: u32,
    },
    /// `frame_count` = 0: stream until `StopStream`.
    StartStream {
        frame_count: u32,
    },
    StopStream,
    GetStatus,
    Capabilities(Capabilities),
    /// Request succeeded; `request_kind` echoes the request's kind byte.
    Ack {
        request_kind: u8,
    },
    /// Request failed.
    Nak {
        request_kind: u8,
        code: ErrorCode,
        detail: u32,
    },
    ControlValue {
        control: Control,
        value: u32,
    },
    /// The request was accepted but takes a while; the final `Ack`/`Nak` with
    /// the same tag follows within `eta_ms` + [`crate::PENDING_GRACE_MS`].
    Pending {
        request_kind: u8,
        eta_ms: u32,
    },
    Status(Status),
    FrameLeader(FrameLeader),
    FrameChunk(FrameChunk<'a>),
    FrameTrailer(FrameTrailer),
}

impl Message<'_> {
    /// The kind byte of this message.
    #[must_use]
    pub const fn kind(&self) -> Kind {
        match self {
            Message::Hello(_) => Kind::Hello,
            Message::GetControl { .. } => Kind::GetControl,
            Message::SetControl { .. } => Kind::SetControl,
            Message::StartStream { .. } => Kind::StartStream,
            Message::StopStream => Kind::StopStream,
            Message::GetStatus => Kind::GetStatus,
            Message::Capabilities(_) => Kind::Capabilities,
            Message::Ack { .. } => Kind::Ack,
            Message::Nak { .. } => Kind::Nak,
            Message::ControlValue { .. } => Kind::ControlValue,
            Message::Pending { .. } => Kind::Pending,
            Message::Status(_) => Kind::Status,
            Message::FrameLeader(_) => Kind::FrameLeader,
            Message::FrameChunk(_) => Kind::FrameChunk,
            Message::FrameTrailer(_) => Kind::FrameTrailer,
        }
    }
}

/// A message with its tag: what travels in one frame / USB transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Packet<'a> {
    /// Request tag echoed by replies; [`UNSOLICITED_TAG`] for stream data.
    pub tag: u16,
    pub message: Message<'a>,
}

/// Fixed-size staging area for header + fixed body fields.
struct Head {
    buf: [u8; 64],
    len: usize,
}

impl Head {
    fn new() -> Self {
        Self {
            buf: [0; 64],
            len: 0,
        }
    }
    fn put(&mut self, bytes: &[u8]) {
        // Largest fixed part is 3 + 43 = 46 bytes < 64, so this never clips.
        let end = (self.len + bytes.len()).min(self.buf.len());
        let n = end - self.len;
        self.buf[self.len..end].copy_from_slice(&bytes[..n]);
        self.len = end;
    }
    fn u8(&mut self, v: u8) {
        self.put(&[v]);
    }
    fn u16(&mut self, v: u16) {
        self.put(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.put(&v.to_le_bytes());
    }
    fn i32(&mut self, v: i32) {
        self.put(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.put(&v.to_le_bytes());
    }
}

impl<'a> Packet<'a> {
    /// A packet with the given tag.
    #[must_use]
    pub const fn new(tag: u16, message: Message<'a>) -> Self {
        Self { tag, message }
    }

    /// Split into (header + fixed fields, variable tail), the CRC still to
    /// be appended. The tail is non-empty only for chunks.
    fn parts(&self) -> Result<(Head, &'a [u8]), EncodeError> {
        let mut h = Head::new();
        h.u8(self.message.kind() as u8);
        h.u16(self.tag);
        let mut tail: &'a [u8] = &[];
        match self.message {
            Message::Hello(m) => {
                h.u8(m.version_major);
                h.u8(m.version_minor);
                h.u16(m.host_max_message_len);
            }
            Message::GetControl { control } => h.u8(control as u8),
            Message::SetControl { control, value } | Message::ControlValue { control, value } => {
                h.u8(control as u8);
                h.u32(value);
            }
            Message::StartStream { frame_count } => h.u32(frame_count),
            Message::StopStream | Message::GetStatus => {}
            Message::Capabilities(c) => {
                h.u8(c.version_major);
                h.u8(c.version_minor);
                h.u16(c.chunk_data_len);
                h.u16(c.max_width_px);
                h.u16(c.max_height_px);
                h.u8(c.bit_depths);
                h.u8(c.features);
                h.u32(c.firmware_version);
                h.u32(c.serial_number);
                h.u32(c.frame_buffer_len_bytes);
            }
            Message::Ack { request_kind } => h.u8(request_kind),
            Message::Nak {
                request_kind,
                code,
                detail,
            } => {
                h.u8(request_kind);
                h.u8(code.0);
                h.u32(detail);
            }
            Message::Pending {
                request_kind,
                eta_ms,
            } => {
                h.u8(request_kind);
                h.u32(eta_ms);
            }
            Message::Status(s) => {
                h.u8(s.state as u8);
                h.i32(s.temperature_milli_c);
                h.u32(s.frames_sent);
                h.u32(s.rx_errors);
                h.u64(s.device_time_us);
            }
            Message::FrameLeader(l) => {
                h.u32(l.seq);
                h.u64(l.timestamp_us);
                h.u16(l.width_px);
                h.u16(l.height_px);
                h.u8(l.pixel_format as u8);
                h.u8(u8::from(l.agc_enabled));
                h.u8(l.test_pattern);
                h.u32(l.gain_milli);
                h.u32(l.mcp_voltage_mv);
                h.u32(l.agc_setpoint_ppm);
                h.u32(l.exposure_us);
                h.u32(l.gate_ns);
                h.u32(l.payload_len_bytes);
            }
            Message::FrameChunk(c) => {
                if c.data.len() > MAX_CHUNK_DATA_LEN {
                    return Err(EncodeError::ChunkTooLong {
                        data_len: c.data.len(),
                    });
                }
                h.u32(c.seq);
                h.u32(c.offset_bytes);
                tail = c.data;
            }
            Message::FrameTrailer(t) => {
                h.u32(t.seq);
                h.u8(t.status.0);
                h.u32(t.valid_len_bytes);
                h.u32(t.crc32c);
            }
        }
        Ok((h, tail))
    }

    /// Length of [`Packet::encode`]'s output.
    #[must_use]
    pub fn encoded_len(&self) -> usize {
        match self.message {
            Message::FrameChunk(c) => HEADER_LEN + CHUNK_FIXED_LEN + c.data.len() + CRC_LEN,
            m => HEADER_LEN + m.kind().body_len().unwrap_or(0) + CRC_LEN,
        }
    }

    /// Encode un-framed (as sent in one USB bulk transfer). Returns the length.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, EncodeError> {
        let (head, tail) = self.parts()?;
        let n = head.len + tail.len() + CRC_LEN;
        let Some(dst) = out.get_mut(..n) else {
            return Err(EncodeError::BufferTooSmall { needed_len: n });
        };
        let (h, rest) = dst.split_at_mut(head.len);
        h.copy_from_slice(&head.buf[..head.len]);
        let (t, c) = rest.split_at_mut(tail.len());
        t.copy_from_slice(tail);
        let mut crc = Crc32c::new();
        crc.update(&head.buf[..head.len]);
        crc.update(tail);
        c.copy_from_slice(&crc.value().to_le_bytes());
        Ok(n)
    }

    /// Encode as a COBS frame including the trailing `0x00` delimiter (serial
    /// link). Single pass: header, data and CRC are stuffed straight into
    /// `out`. Returns the length written.
    pub fn encode_cobs(&self, out: &mut [u8]) -> Result<usize, EncodeError> {
        let (head, tail) = self.parts()?;
        let mut crc = Crc32c::new();
        crc.update(&head.buf[..head.len]);
        crc.update(tail);
        let mut enc = CobsEncoder::new(out);
        enc.push(&head.buf[..head.len]);
        enc.push(tail);
        enc.push(&crc.value().to_le_bytes());
        enc.finish_with_delimiter()
    }

    /// Decode an un-framed message (a COBS-decoded frame or a USB transfer),
    /// checking its CRC first. Errors other than `TooShort`, `TooLong` and
    /// `BadCrc` mean the bytes are authentic, so `bytes[1..3]` is a
    /// trustworthy tag to answer with.
    pub fn decode(bytes: &'a [u8]) -> Result<Self, DecodeError> {
        decode_message(bytes)
    }
}

/// Little-endian field reader over a body whose length was already checked.
struct Rd<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Rd<'a> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut a = [0u8; N];
        if let Some(s) = self.b.get(self.pos..self.pos + N) {
            a.copy_from_slice(s);
        }
        self.pos += N;
        a
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn rest(&self) -> &'a [u8] {
        self.b.get(self.pos..).unwrap_or(&[])
    }
}

/// Decode an un-framed message; see [`Packet::decode`].
pub fn decode_message(bytes: &[u8]) -> Result<Packet<'_>, DecodeError> {
    let len_bytes = bytes.len();
    if len_bytes < HEADER_LEN + CRC_LEN {
        return Err(DecodeError::TooShort { len_bytes });
    }
    if len_bytes > MAX_MESSAGE_LEN {
        return Err(DecodeError::TooLong { len_bytes });
    }
    let (covered, crc_bytes) = bytes.split_at(len_bytes - CRC_LEN);
    let mut crc_arr = [0u8; 4];
    crc_arr.copy_from_slice(crc_bytes);
    let received = u32::from_le_bytes(crc_arr);
    let computed = crc32c(covered);
    if received != computed {
        return Err(DecodeError::BadCrc { received, computed });
    }
    let kind_byte = covered[0];
    let tag = u16::from_le_bytes([covered[1], covered[2]]);
    let body = &covered[HEADER_LEN..];
    let kind = Kind::from_u8(kind_byte).ok_or(DecodeError::UnknownKind { kind: kind_byte })?;
    let bad_len = DecodeError::BadLength {
        kind: kind_byte,
        body_len: body.len(),
    };
    match kind.body_len() {
        Some(n) if n != body.len() => return Err(bad_len),
        None if body.len() < CHUNK_FIXED_LEN => return Err(bad_len),
        _ => {}
    }
    let bad = |field_offset| DecodeError::BadField {
        kind: kind_byte,
        field_offset,
    };
    let mut r = Rd { b: body, pos: 0 };
    let control = |code: u8| Control::from_u8(code).ok_or(bad(0));
    let message = match kind {
        Kind::Hello => Message::Hello(Hello {
            version_major: r.u8(),
            version_minor: r.u8(),
            host_max_message_len: r.u16(),
        }),
        Kind::GetControl => Message::GetControl {
            control: control(r.u8())?,
        },
        Kind::SetControl => Message::SetControl {
            control: control(r.u8())?,
            value: r.u32(),
        },
        Kind::ControlValue => Message::ControlValue {
            control: control(r.u8())?,
            value: r.u32(),
        },
        Kind::StartStream => Message::StartStream {
            frame_count: r.u32(),
        },
        Kind::StopStream => Message::StopStream,
        Kind::GetStatus => Message::GetStatus,
        Kind::Capabilities => Message::Capabilities(Capabilities {
            version_major: r.u8(),
            version_minor: r.u8(),
            chunk_data_len: r.u16(),
            max_width_px: r.u16(),
            max_height_px: r.u16(),
            bit_depths: r.u8(),
            features: r.u8(),
            firmware_version: r.u32(),
            serial_number: r.u32(),
            frame_buffer_len_bytes: r.u32(),
        }),
        Kind::Ack => Message::Ack {
            request_kind: r.u8(),
        },
        Kind::Nak => Message::Nak {
            request_kind: r.u8(),
            code: ErrorCode(r.u8()),
            detail: r.u32(),
        },
        Kind::Pending => Message::Pending {
            request_kind: r.u8(),
            eta_ms: r.u32(),
        },
        Kind::Status => Message::Status(Status {
            state: DeviceState::from_u8(r.u8()).ok_or(bad(0))?,
            temperature_milli_c: r.i32(),
            frames_sent: r.u32(),
            rx_errors: r.u32(),
            device_time_us: r.u64(),
        }),
        Kind::FrameLeader => {
            let seq = r.u32();
            let timestamp_us = r.u64();
            let width_px = r.u16();
            let height_px = r.u16();
            let pixel_format = PixelFormat::from_u8(r.u8()).ok_or(bad(16))?;
            let agc_enabled = match r.u8() {
                0 => false,
                1 => true,
                _ => return Err(bad(17)),
            };
            Message::FrameLeader(FrameLeader {
                seq,
                timestamp_us,
                width_px,
                height_px,
                pixel_format,
                agc_enabled,
                test_pattern: r.u8(),
                gain_milli: r.u32(),
                mcp_voltage_mv: r.u32(),
                agc_setpoint_ppm: r.u32(),
                exposure_us: r.u32(),
                gate_ns: r.u32(),
                payload_len_bytes: r.u32(),
            })
        }
        Kind::FrameChunk => {
            let seq = r.u32();
            let offset_bytes = r.u32();
            Message::FrameChunk(FrameChunk {
                seq,
                offset_bytes,
                data: r.rest(),
            })
        }
        Kind::FrameTrailer => Message::FrameTrailer(FrameTrailer {
            seq: r.u32(),
            status: ErrorCode(r.u8()),
            valid_len_bytes: r.u32(),
            crc32c: r.u32(),
        }),
    };
    Ok(Packet { tag, message })
}
