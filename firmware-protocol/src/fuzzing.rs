//! Fuzz entry points, kept in the library so that plain `cargo test`
//! (`tests/fuzz_corpus.rs`) replays the cargo-fuzz corpus and any crash
//! artifacts on stable Rust, and the `fuzz/` crate stays a thin wrapper.
//!
//! Each function panics only if a protocol invariant is violated (that is
//! the point of fuzzing); on well-behaved code every input returns normally.

use crate::assembly::{AssemblyEvent, FrameAssembler};
use crate::cobs::{CobsAccumulator, Feed};
use crate::crc32c::crc32c;
use crate::message::{MAX_COBS_FRAME_LEN, MAX_MESSAGE_LEN, Message, decode_message as decode};

/// Decode arbitrary bytes as a message; if that succeeds, re-encoding must
/// reproduce the input exactly (both raw and through COBS).
pub fn decode_message(data: &[u8]) {
    let Ok(packet) = decode(data) else {
        return;
    };
    let mut out = [0u8; MAX_MESSAGE_LEN];
    let n = packet.encode(&mut out).expect("decoded message re-encodes");
    assert_eq!(&out[..n], data, "re-encoding is not the identity");
    let mut wire = [0u8; MAX_COBS_FRAME_LEN];
    let w = packet.encode_cobs(&mut wire).expect("fits a COBS frame");
    let mut back = [0u8; MAX_MESSAGE_LEN];
    let m = crate::cobs::decode_frame(&wire[..w - 1], &mut back).expect("own COBS decodes");
    assert_eq!(&back[..m], data);
}

/// First byte picks a chunk size (1..=256) and the receive-buffer size; the
/// rest is a serial byte stream fed in pieces of that size. Checks that the
/// accumulator never panics, never returns more than its buffer, and never
/// returns a frame containing `0x00`-delimited garbage that decodes as a
/// message with a bad CRC *and* is accepted (decode must check the CRC).
pub fn cobs_accumulator(data: &[u8]) {
    let Some((&sel, stream)) = data.split_first() else {
        return;
    };
    let chunk_len = usize::from(sel) + 1;
    let cap = 16 + usize::from(sel) * 2;
    let mut buf = [0u8; 16 + 255 * 2];
    let mut acc = CobsAccumulator::new(&mut buf[..cap]);
    for piece in stream.chunks(chunk_len) {
        let mut rest = piece;
        while !rest.is_empty() {
            let (used, feed) = acc.feed(rest);
            assert!(used >= 1 && used <= rest.len(), "feed must make progress");
            rest = &rest[used..];
            if let Feed::Frame(f) = feed {
                assert!(f.len() <= cap);
                if let Ok(p) = decode(f) {
                    // Accepted messages must carry a matching CRC.
                    let (body, crc) = f.split_at(f.len() - 4);
                    assert_eq!(crc32c(body).to_le_bytes(), crc);
                    let _ = p;
                }
            }
        }
    }
}

/// Interpret the input as a stream of COBS frames, decode each, and feed
/// stream messages to a [`FrameAssembler`]. Every frame it yields must match
/// its trailer's CRC and its leader's size.
pub fn frame_reassembly(data: &[u8]) {
    let mut rx = [0u8; 1024];
    let mut acc = CobsAccumulator::new(&mut rx[..]);
    let mut frame_buf = [0u8; 4096];
    let mut asm = FrameAssembler::new(&mut frame_buf[..]);
    let mut rest = data;
    while !rest.is_empty() {
        let (used, feed) = acc.feed(rest);
        rest = &rest[used..];
        let Feed::Frame(f) = feed else { continue };
        let Ok(p) = decode(f) else { continue };
        let trailer_crc = match p.message {
            Message::FrameTrailer(t) => Some(t.crc32c),
            _ => None,
        };
        if let AssemblyEvent::Frame { info, data } = asm.push(&p.message) {
            assert_eq!(data.len(), info.leader.payload_len_bytes as usize);
            assert_eq!(Some(crc32c(data)), trailer_crc);
        }
    }
}
