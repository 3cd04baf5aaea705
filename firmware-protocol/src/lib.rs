#![no_std]
#![forbid(unsafe_code)]
//! gloam's device wire protocol: message types, COBS framing, CRC-32C, USB
//! bulk helpers, frame reassembly and the device-side state machine.
//!
//! `no_std` and allocation-free so the *same* code runs in the camera's
//! microcontroller firmware, in the host driver (`gloam-grabber`) and in the
//! device emulator; every buffer is provided by the caller. The normative
//! description of the bytes on the wire is `PROTOCOL.md` next to this crate.
//!
//! Layers, bottom up:
//! - [`crc32c()`]: the one checksum used everywhere.
//! - [`cobs`]: serial framing ([`CobsAccumulator`] for the receive side).
//! - [`usb`]: bulk-transfer splitting/reassembly (short packet / ZLP).
//! - [`message`]: [`Packet`]/[`Message`] encode/decode.
//! - [`assembly`]: [`FrameAssembler`] turns stream messages into checked frames.
//! - [`device`]: [`Device`], the sans-IO firmware core over a [`Hal`].
//! - [`fuzzing`]: entry points shared by the fuzzers and the corpus-replay test.
//!
//! A host talking to a device over serial, end to end (the device here is
//! the crate's own state machine behind a trivial HAL):
//!
//! ```
//! use firmware_protocol::*;
//!
//! # struct NullHal;
//! # impl Hal for NullHal {
//! #     fn now_us(&mut self) -> u64 { 0 }
//! #     fn read_temperature_milli_c(&mut self) -> Option<i32> { None }
//! #     fn set_gain(&mut self, _: u32) -> Result<(), ErrorCode> { Ok(()) }
//! #     fn apply_control(&mut self, _: Control, _: u32, _: &Settings) -> Result<Applied, ErrorCode> {
//! #         Ok(Applied::Done)
//! #     }
//! #     fn capture_frame(&mut self, _: &Settings, _: &mut [u8]) -> Result<Option<CaptureInfo>, ErrorCode> {
//! #         Ok(None)
//! #     }
//! # }
//! # struct Wire([u8; 256], usize);
//! # impl Sink for Wire {
//! #     fn send(&mut self, b: &[u8]) -> Result<(), SinkError> {
//! #         self.0[self.1..self.1 + b.len()].copy_from_slice(b);
//! #         self.1 += b.len();
//! #         Ok(())
//! #     }
//! # }
//! # let config = DeviceConfig {
//! #     max_width_px: 64, max_height_px: 64, bit_depths: bit_depths::MONO16, features: 0,
//! #     firmware_version: 1, serial_number: 1, max_gain_milli: 10_000,
//! #     max_mcp_voltage_mv: 0, max_exposure_us: 1_000_000, initial_settings: Settings::default(),
//! # };
//! let (mut tx, mut frame) = ([0u8; 512], [0u8; 64 * 64 * 2]);
//! let buffers = DeviceBuffers { tx: &mut tx, frame: &mut frame };
//! let mut device = Device::new(NullHal, config, Transport::Serial, buffers).unwrap();
//!
//! // Host: encode a request as a COBS frame and "send" it.
//! let hello = Packet::new(1, Message::Hello(Hello {
//!     version_major: PROTOCOL_VERSION_MAJOR,
//!     version_minor: PROTOCOL_VERSION_MINOR,
//!     host_max_message_len: MAX_MESSAGE_LEN as u16,
//! }));
//! let mut request = [0u8; 32];
//! let n = hello.encode_cobs(&mut request).unwrap();
//! let mut link = Wire([0; 256], 0);
//! device.handle_bytes(&request[..n], &mut link).unwrap();
//!
//! // Host: accumulate whatever bytes arrive, decode each frame.
//! let mut rx_buf = [0u8; 64];
//! let mut rx = CobsAccumulator::new(&mut rx_buf[..]);
//! let (_, feed) = rx.feed(&link.0[..link.1]);
//! let Feed::Frame(bytes) = feed else { panic!("no reply") };
//! let reply = decode_message(bytes).unwrap();
//! assert_eq!(reply.tag, 1);
//! assert!(matches!(reply.message, Message::Capabilities(c) if c.version_major == 1));
//! ```
//!
//! For throughput measurement (`gloam bench throughput`) time
//! [`Packet::encode_cobs`] and [`CobsAccumulator::feed`] + [`decode_message`]
//! on a full [`MAX_CHUNK_DATA_LEN`] chunk, as `benches/codec.rs` does.

pub mod assembly;
pub mod cobs;
mod crc32c;
pub mod device;
mod error;
pub mod fuzzing;
pub mod message;
pub mod usb;

pub use assembly::{AssemblyEvent, DropReason, FrameAssembler, FrameInfo};
pub use cobs::{CobsAccumulator, CobsEncoder, Feed};
pub use crc32c::{Crc32c, crc32c};
pub use device::{
    Activity, Applied, CaptureInfo, Device, DeviceBuffers, DeviceConfig, Hal, Settings, Sink,
    SinkError, Transport, fill_test_pattern,
};
pub use error::{DecodeError, EncodeError, FrameError};
pub use message::{
    Capabilities, Control, DeviceState, ErrorCode, FrameChunk, FrameLeader, FrameTrailer, Hello,
    Kind, MAX_CHUNK_DATA_LEN, MAX_COBS_FRAME_LEN, MAX_MESSAGE_LEN, MAX_REQUEST_LEN, Message,
    PROTOCOL_VERSION_MAJOR, PROTOCOL_VERSION_MINOR, Packet, PixelFormat, Status, TestPattern,
    UNSOLICITED_TAG, bit_depths, decode_message, features,
};

/// Host: how long to wait for the reply to a request, counted from the last
/// byte of the request leaving the host, before retrying with a new tag.
pub const REPLY_TIMEOUT_MS: u32 = 250;
/// Extra time beyond a `Pending` reply's `eta_ms` within which the final
/// reply arrives; the device gives up and sends `Nak(TIMEOUT)` at
/// `eta_ms + PENDING_GRACE_MS`, the host should wait `eta_ms + 2 *
/// PENDING_GRACE_MS`.
pub const PENDING_GRACE_MS: u32 = 500;
/// Host: drop a partially received frame when no stream message arrived for
/// this long (plus the exposure time).
pub const FRAME_IDLE_TIMEOUT_MS: u32 = 1000;
