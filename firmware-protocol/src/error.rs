//! Error types. Hand-written (no `thiserror`) because the crate is `no_std`;
//! every enum implements [`core::fmt::Display`] and [`core::error::Error`].

use core::fmt;

/// Why a message could not be encoded into the caller's buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncodeError {
    /// The output buffer is shorter than the encoded form; `needed_len` bytes
    /// would have been enough.
    BufferTooSmall { needed_len: usize },
    /// A chunk's pixel data exceeds [`crate::MAX_CHUNK_DATA_LEN`].
    ChunkTooLong { data_len: usize },
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BufferTooSmall { needed_len } => {
                write!(f, "output buffer too small: {needed_len} bytes needed")
            }
            Self::ChunkTooLong { data_len } => write!(
                f,
                "chunk data of {data_len} bytes exceeds the {} byte limit",
                crate::MAX_CHUNK_DATA_LEN
            ),
        }
    }
}

impl core::error::Error for EncodeError {}

/// Why a received message (already un-framed) was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecodeError {
    /// Shorter than header + CRC (`len_bytes` < 7).
    TooShort { len_bytes: usize },
    /// Longer than [`crate::MAX_MESSAGE_LEN`].
    TooLong { len_bytes: usize },
    /// The trailing CRC-32C does not match the bytes before it.
    BadCrc { received: u32, computed: u32 },
    /// The kind byte is not one this protocol version defines.
    UnknownKind { kind: u8 },
    /// The body length is wrong for the kind.
    BadLength { kind: u8, body_len: usize },
    /// A field holds a value outside its defined set (e.g. pixel format 0x07).
    BadField { kind: u8, field_offset: usize },
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooShort { len_bytes } => write!(f, "message too short ({len_bytes} bytes)"),
            Self::TooLong { len_bytes } => write!(f, "message too long ({len_bytes} bytes)"),
            Self::BadCrc { received, computed } => write!(
                f,
                "CRC-32C mismatch: received {received:#010x}, computed {computed:#010x}"
            ),
            Self::UnknownKind { kind } => write!(f, "unknown message kind {kind:#04x}"),
            Self::BadLength { kind, body_len } => {
                write!(
                    f,
                    "wrong body length {body_len} for message kind {kind:#04x}"
                )
            }
            Self::BadField { kind, field_offset } => write!(
                f,
                "invalid field value at body offset {field_offset} of message kind {kind:#04x}"
            ),
        }
    }
}

impl core::error::Error for DecodeError {}

/// A problem in the COBS-framed serial byte stream. After reporting one of
/// these the accumulator has already resynchronised: the next byte after the
/// offending `0x00` starts a new frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// The frame decoded to more bytes than the accumulator's buffer holds; it
    /// was discarded up to and including its `0x00` delimiter.
    Overrun,
    /// A `0x00` arrived inside a COBS block, i.e. bytes were lost or damaged.
    Corrupt,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Overrun => f.write_str("COBS frame longer than the receive buffer; discarded"),
            Self::Corrupt => f.write_str("corrupt COBS frame (delimiter inside a block)"),
        }
    }
}

impl core::error::Error for FrameError {}
