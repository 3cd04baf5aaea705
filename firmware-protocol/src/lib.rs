#![no_std]
#![forbid(unsafe_code)]
#![doc = include_str!("../README.md")]

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
