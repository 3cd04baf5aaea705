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
