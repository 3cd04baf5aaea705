//! Replays the `gige_device` fuzz corpus (`fuzz/corpus/gige_device`, and any
//! crash artifacts in `fuzz/artifacts/gige_device`) through the fuzz entry
//! point on stable Rust, plus random datagram sequences from proptest.

use std::path::Path;

use proptest::prelude::*;

#[test]
fn corpus_and_artifacts_replay_cleanly() {
    let fuzz = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz");
    let mut n = 0;
    for dir in ["corpus/gige_device", "artifacts/gige_device"] {
        let Ok(entries) = std::fs::read_dir(fuzz.join(dir)) else {
            continue;
        };
        for e in entries.flatten() {
            let data = std::fs::read(e.path()).expect("read seed");
            gloam_gige::fuzzing::device_datagrams(&data);
            n += 1;
        }
    }
    assert!(
        n >= 6,
        "only {n} corpus files found under {}",
        fuzz.display()
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]
    #[test]
    fn random_datagram_sequences_never_panic(data in proptest::collection::vec(any::<u8>(), 0..2048)) {
        gloam_gige::fuzzing::device_datagrams(&data);
    }

    /// Well-formed headers with random commands and payloads reach the
    /// command handlers (random bytes rarely start with the 0x42 key).
    #[test]
    fn random_commands_never_panic(
        cmds in proptest::collection::vec(
            (any::<u8>(), prop_oneof![Just(0x80u16), Just(0x82), Just(0x84), Just(0x86), Just(0x40), Just(2), any::<u16>()],
             proptest::collection::vec(any::<u8>(), 0..600), any::<bool>()),
            1..20)
    ) {
        let mut data = Vec::new();
        for (flags, cmd, payload, second) in cmds {
            let d = gloam_gige::gvcp::encode_command(flags, cmd, 1, &payload);
            let n = d.len().div_ceil(5).min(127);
            data.push(((n as u8) << 1) | u8::from(second));
            data.extend_from_slice(&d);
            data.resize(data.len() + (n * 5).saturating_sub(d.len()), 0);
        }
        gloam_gige::fuzzing::device_datagrams(&data);
    }
}
