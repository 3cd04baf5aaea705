//! Replays every fuzz corpus seed and crash artifact through the same entry
//! points the cargo-fuzz targets use, so regressions found by fuzzing stay
//! fixed under plain `cargo test` on stable Rust.
//!
//! `GLOAM_BLESS=1` (re)writes the `seed-*` files from the real encoder.

use std::path::{Path, PathBuf};

use firmware_protocol::*;

type Target = fn(&[u8]);

const TARGETS: [(&str, Target); 3] = [
    ("decode_message", fuzzing::decode_message),
    ("cobs_accumulator", fuzzing::cobs_accumulator),
    ("frame_reassembly", fuzzing::frame_reassembly),
];

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

fn raw(p: &Packet<'_>) -> Vec<u8> {
    let mut b = vec![0u8; MAX_MESSAGE_LEN];
    let n = p.encode(&mut b).unwrap();
    b.truncate(n);
    b
}

fn cobs(p: &Packet<'_>) -> Vec<u8> {
    let mut b = vec![0u8; MAX_COBS_FRAME_LEN];
    let n = p.encode_cobs(&mut b).unwrap();
    b.truncate(n);
    b
}

/// A complete 8×4 Mono16 frame as a serial stream (leader, 3 chunks, trailer).
fn frame_stream() -> Vec<u8> {
    let pixels: Vec<u8> = (0..64u8).map(|i| i.wrapping_mul(37)).collect();
    let leader = FrameLeader {
        seq: 0,
        timestamp_us: 5,
        width_px: 8,
        height_px: 4,
        pixel_format: PixelFormat::Mono16,
        agc_enabled: false,
        test_pattern: 0,
        gain_milli: 1000,
        mcp_voltage_mv: 0,
        agc_setpoint_ppm: 500_000,
        exposure_us: 100,
        gate_ns: 100,
        payload_len_bytes: 64,
    };
    let mut s = cobs(&Packet::new(0, Message::FrameLeader(leader)));
    for (k, c) in pixels.chunks(24).enumerate() {
        s.extend(cobs(&Packet::new(
            0,
            Message::FrameChunk(FrameChunk {
                seq: 0,
                offset_bytes: (k * 24) as u32,
                data: c,
            }),
        )));
    }
    s.extend(cobs(&Packet::new(
        0,
        Message::FrameTrailer(FrameTrailer {
            seq: 0,
            status: ErrorCode::OK,
            valid_len_bytes: 64,
            crc32c: crc32c(&pixels),
        }),
    )));
    s
}

fn seeds() -> Vec<(&'static str, &'static str, Vec<u8>)> {
    let hello = Packet::new(
        1,
        Message::Hello(Hello {
            version_major: 1,
            version_minor: 0,
            host_max_message_len: 4096,
        }),
    );
    let set = Packet::new(
        2,
        Message::SetControl {
            control: Control::FrameSize,
            value: 8 | (4 << 16),
        },
    );
    let chunk_data = [0u8, 1, 0, 2, 255, 0];
    let chunk = Packet::new(
        0,
        Message::FrameChunk(FrameChunk {
            seq: 9,
            offset_bytes: 0,
            data: &chunk_data,
        }),
    );
    let mut stream = vec![7u8]; // chunk size 8
    stream.extend(cobs(&hello));
    stream.extend(cobs(&set));
    stream.push(0);
    stream.extend([0x05, 0x11, 0x00]); // a corrupt frame
    stream.extend(cobs(&chunk));
    vec![
        ("decode_message", "seed-hello", raw(&hello)),
        ("decode_message", "seed-set-frame-size", raw(&set)),
        ("decode_message", "seed-chunk", raw(&chunk)),
        ("cobs_accumulator", "seed-mixed-stream", stream),
        ("frame_reassembly", "seed-one-frame", frame_stream()),
    ]
}

#[test]
fn seeds_are_current() {
    let bless = std::env::var_os("GLOAM_BLESS").is_some();
    for (target, name, bytes) in seeds() {
        let path = fuzz_dir().join("corpus").join(target).join(name);
        if bless {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, &bytes).unwrap();
        }
        let on_disk = std::fs::read(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (run with GLOAM_BLESS=1)", path.display()));
        assert_eq!(on_disk, bytes, "{} is stale", path.display());
    }
}

#[test]
fn replay_corpus_and_artifacts() {
    for (target, run) in TARGETS {
        let mut replayed = 0;
        for kind in ["corpus", "artifacts"] {
            let dir = fuzz_dir().join(kind).join(target);
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for entry in entries {
                let path = entry.unwrap().path();
                if path.is_file() {
                    let bytes = std::fs::read(&path).unwrap();
                    let r = std::panic::catch_unwind(|| run(&bytes));
                    assert!(r.is_ok(), "{target} panicked on {}", path.display());
                    replayed += 1;
                }
            }
        }
        assert!(replayed > 0, "no corpus found for {target}");
    }
}

/// The frame seed really contains a good frame (so the fuzzer starts from
/// the interesting path), and every single-byte corruption of it is either
/// still a good identical frame or not a frame at all.
#[test]
fn frame_seed_yields_exactly_one_frame_and_corruptions_none_bad() {
    let stream = frame_stream();
    let count = |s: &[u8]| {
        let mut rx = vec![0u8; 1024];
        let mut acc = CobsAccumulator::new(&mut rx[..]);
        let mut fb = vec![0u8; 4096];
        let mut asm = FrameAssembler::new(&mut fb[..]);
        let mut frames = Vec::new();
        let mut rest = s;
        while !rest.is_empty() {
            let (used, feed) = acc.feed(rest);
            rest = &rest[used..];
            let Feed::Frame(f) = feed else { continue };
            let Ok(p) = decode_message(f) else { continue };
            if let AssemblyEvent::Frame { data, .. } = asm.push(&p.message) {
                frames.push(data.to_vec());
            }
        }
        frames
    };
    let good = count(&stream);
    assert_eq!(good.len(), 1);
    for i in 0..stream.len() {
        for flip in [0x01u8, 0x80, 0xFF] {
            let mut s = stream.clone();
            s[i] ^= flip;
            for f in count(&s) {
                assert_eq!(f, good[0], "byte {i} ^ {flip:#x} produced a bad frame");
            }
        }
    }
}
