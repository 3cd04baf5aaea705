#![doc = include_str!("../README.md")]

mod input;

pub use input::{
    FileRead, MAX_IMAGE_FILE_BYTES, MAX_MESH_FILE_BYTES, MAX_RECORDED_READS, MAX_TEXT_FILE_BYTES,
    collect_reads, open_bounded, read_bounded, read_text, reads, reads_not_recorded, record_reads,
    sha256_hex, unrecorded,
};

/// The README's Rust example, compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
