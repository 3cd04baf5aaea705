//! Fuzz target `frame_reassembly`: a thin wrapper so the same entry point,
//! `firmware_protocol::fuzzing::frame_reassembly`, is replayed by plain `cargo test`
//! (`firmware-protocol/tests/fuzz_corpus.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| firmware_protocol::fuzzing::frame_reassembly(data));
