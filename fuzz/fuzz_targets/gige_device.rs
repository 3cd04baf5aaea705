//! Fuzz target `gige_device`: random datagrams from two clients into the
//! GigE Vision device state machine (`gloam_gige::fuzzing::device_datagrams`,
//! replayed by `cargo test -p gloam-gige`, `crates/gige/tests/fuzz_corpus.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| gloam_gige::fuzzing::device_datagrams(data));
