#![doc = include_str!("../README.md")]

mod atomic;
pub mod fits;
pub mod frame;
pub mod frames;
pub mod guard;
mod hash;
mod input;
pub mod json;
pub mod npy;
pub mod output_set;
pub mod png;
pub mod tiff;
pub mod toml_place;

pub use atomic::{EncodeError, FileError, write_atomic};
pub use guard::RunGuard;
pub use hash::{InputFile, MAX_HASHED_BYTES, hash_file};
pub use input::{
    FileRead, MAX_IMAGE_FILE_BYTES, MAX_MESH_FILE_BYTES, MAX_RECORDED_READS, MAX_TEXT_FILE_BYTES,
    ReadLog, open_bounded, read_bounded, read_text, sha256_hex, shown,
};
pub use output_set::{ManifestProvenance, OutputSet, OutputSetError};

/// The README's Rust example, compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
