//! What the binary's tests share: reading the `frames.jsonl` a render or a
//! capture wrote. (Each test crate includes this module and uses part of
//! it.)
#![allow(dead_code)]

use std::path::Path;

/// The keys every `frames.jsonl` record carries (`FrameRecord`'s contract).
pub const FRAME_RECORD_KEYS: [&str; 7] = [
    "seq",
    "timestamp",
    "gain",
    "agc",
    "bits",
    "pixels_crc32c",
    "status",
];

/// The records of `out/frames.jsonl`, one JSON value a line, in order.
pub fn records(out: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out.join("frames.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}
