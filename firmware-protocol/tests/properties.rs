//! Property tests: arbitrary bytes, arbitrary chunking and random corruption
//! never panic and never produce a corrupted message or frame as valid.

mod common;

use common::{FRAME_BUF_LEN, MockHal, VecSink, config, sample_packets};
use firmware_protocol::*;
use proptest::prelude::*;

/// Encode a sample of every message kind as one serial byte stream.
fn sample_stream(chunk_data: &[u8]) -> (Vec<u8>, Vec<Vec<u8>>) {
    let mut stream = Vec::new();
    let mut raws = Vec::new();
    for p in sample_packets(chunk_data) {
        let mut wire = vec![0u8; MAX_COBS_FRAME_LEN];
        let n = p.encode_cobs(&mut wire).unwrap();
        stream.extend_from_slice(&wire[..n]);
        let mut raw = vec![0u8; MAX_MESSAGE_LEN];
        let m = p.encode(&mut raw).unwrap();
        raws.push(raw[..m].to_vec());
    }
    (stream, raws)
}

/// Feed `stream` in pieces of the given sizes; return every message that
/// decoded successfully (as raw bytes) and the number of frame errors.
fn receive(stream: &[u8], sizes: &[usize], cap: usize) -> (Vec<Vec<u8>>, usize) {
    let mut buf = vec![0u8; cap];
    let mut acc = CobsAccumulator::new(&mut buf[..]);
    let mut good = Vec::new();
    let mut errors = 0;
    let mut pos = 0;
    let mut i = 0;
    while pos < stream.len() {
        let size = sizes
            .get(i % sizes.len().max(1))
            .copied()
            .unwrap_or(1)
            .max(1);
        i += 1;
        let mut piece = &stream[pos..(pos + size).min(stream.len())];
        pos += piece.len();
        while !piece.is_empty() {
            let (used, feed) = acc.feed(piece);
            assert!(used >= 1 && used <= piece.len());
            piece = &piece[used..];
            match feed {
                Feed::Frame(f) => {
                    assert!(f.len() <= cap);
                    if decode_message(f).is_ok() {
                        good.push(f.to_vec());
                    }
                }
                Feed::Error(_) => errors += 1,
                Feed::NeedMore => {}
            }
        }
    }
    (good, errors)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2048),
                                   sizes in proptest::collection::vec(1usize..64, 1..8),
                                   cap in 0usize..300) {
        let _ = decode_message(&bytes);
        let _ = receive(&bytes, &sizes, cap);
        let mut out = vec![0u8; bytes.len()];
        let _ = cobs::decode_frame(&bytes, &mut out);
        firmware_protocol::fuzzing::decode_message(&bytes);
        firmware_protocol::fuzzing::cobs_accumulator(&bytes);
        firmware_protocol::fuzzing::frame_reassembly(&bytes);
    }

    #[test]
    fn any_chunking_delivers_every_message(data in proptest::collection::vec(any::<u8>(), 0..600),
                                           sizes in proptest::collection::vec(1usize..400, 1..10)) {
        let (stream, raws) = sample_stream(&data);
        let (good, errors) = receive(&stream, &sizes, MAX_MESSAGE_LEN);
        prop_assert_eq!(errors, 0);
        prop_assert_eq!(good, raws);
    }

    #[test]
    fn cobs_round_trips(data in proptest::collection::vec(prop_oneof![Just(0u8), any::<u8>()], 0..1200)) {
        let mut wire = vec![0u8; cobs::max_encoded_len(data.len()) + 1];
        let n = cobs::encode_frame(&data, &mut wire).unwrap();
        prop_assert!(!wire[..n - 1].contains(&0));
        prop_assert_eq!(wire[n - 1], 0);
        let mut back = vec![0u8; data.len()];
        if !data.is_empty() {
            let m = cobs::decode_frame(&wire[..n - 1], &mut back).unwrap();
            prop_assert_eq!(&back[..m], &data[..]);
        }
    }

    /// The device state machine never panics and only ever emits well-formed
    /// messages, whatever bytes arrive, interleaved with polls; mixing valid
    /// requests into the noise drives it through every state.
    #[test]
    fn device_survives_arbitrary_input(noise in proptest::collection::vec(any::<u8>(), 0..400),
                                       picks in proptest::collection::vec((0usize..15, any::<u32>(), any::<u8>()), 0..30),
                                       usb in any::<bool>()) {
        let transport = if usb { Transport::Usb } else { Transport::Serial };
        let mut tx = vec![0u8; 300];
        let mut frame = vec![0u8; FRAME_BUF_LEN];
        let hal = MockHal { mcp_eta_ms: Some(1), pending_polls_left: 2, ..MockHal::default() };
        let mut dev = Device::new(hal, config(), transport, DeviceBuffers { tx: &mut tx, frame: &mut frame }).unwrap();
        let mut sink = VecSink::default();
        let controls = Control::ALL;
        for (i, (pick, value, byte)) in picks.into_iter().enumerate() {
            let control = controls[usize::from(byte) % controls.len()];
            let msg = match pick {
                0 | 1 => Message::Hello(Hello { version_major: 1, version_minor: 0, host_max_message_len: u16::from(byte) * 64 }),
                2 => Message::GetControl { control },
                3..=5 => Message::SetControl { control, value: value % 2_000_000 },
                6 => Message::StartStream { frame_count: value % 3 },
                7 => Message::StopStream,
                8 => Message::GetStatus,
                _ => Message::Ack { request_kind: byte },
            };
            let p = Packet::new(i as u16 + 1, msg);
            let mut b = [0u8; 64];
            let start = noise.len() * i / 30;
            let junk = &noise[start.min(noise.len())..(start + usize::from(byte % 8)).min(noise.len())];
            match transport {
                Transport::Serial => {
                    let n = p.encode_cobs(&mut b).unwrap();
                    let _ = dev.handle_bytes(junk, &mut sink);
                    let _ = dev.handle_bytes(&b[..n], &mut sink);
                }
                Transport::Usb => {
                    let n = p.encode(&mut b).unwrap();
                    let _ = dev.handle_message(junk, &mut sink);
                    let _ = dev.handle_message(&b[..n], &mut sink);
                }
            }
            for _ in 0..(byte % 5) {
                let _ = dev.poll(&mut sink);
            }
        }
        for m in sink.messages(transport) {
            prop_assert!(m.len() <= 300);
            let p = decode_message(&m);
            prop_assert!(p.is_ok(), "device emitted an undecodable message");
        }
    }

    /// Streaming decode of frames with every zero density (long 0xFF runs
    /// included), under arbitrary chunking and with a buffer that is exactly
    /// big enough — or one byte short, which must be an overrun.
    #[test]
    fn cobs_stream_round_trips(len in 0usize..3000,
                               zero_every in prop_oneof![Just(0usize), 1usize..4, 200usize..400],
                               seed in any::<u64>(),
                               sizes in proptest::collection::vec(1usize..700, 1..6)) {
        let mut x = seed | 1;
        let data: Vec<u8> = (0..len).map(|_| {
            x ^= x << 13; x ^= x >> 7; x ^= x << 17;
            if zero_every > 0 && (x as usize) % zero_every == 0 { 0 } else { (x >> 8) as u8 | 1 }
        }).collect();
        let mut wire = vec![0u8; cobs::max_encoded_len(len) + 1];
        let n = cobs::encode_frame(&data, &mut wire).unwrap();
        let mut stream = vec![0u8, 0u8];
        stream.extend_from_slice(&wire[..n]);
        stream.extend_from_slice(&wire[..n]);
        for (cap, expect_ok) in [(len, true), (len.wrapping_sub(1), false)] {
            if cap > len || (len == 0) { continue; }
            let mut buf = vec![0u8; cap];
            let mut acc = CobsAccumulator::new(&mut buf[..]);
            let mut frames = 0;
            let mut errors = 0;
            let mut pos = 0;
            let mut i = 0;
            while pos < stream.len() {
                let end = (pos + sizes[i % sizes.len()]).min(stream.len());
                i += 1;
                let mut piece = &stream[pos..end];
                pos = end;
                while !piece.is_empty() {
                    let (used, feed) = acc.feed(piece);
                    piece = &piece[used..];
                    match feed {
                        Feed::Frame(f) => { prop_assert_eq!(f, &data[..]); frames += 1; }
                        Feed::Error(e) => { prop_assert_eq!(e, FrameError::Overrun); errors += 1; }
                        Feed::NeedMore => {}
                    }
                }
            }
            if expect_ok { prop_assert_eq!((frames, errors), (2, 0)); } else { prop_assert_eq!((frames, errors), (0, 2)); }
        }
    }

    /// Corrupt a valid stream (flip, drop, insert bytes): every message that
    /// still decodes must be byte-identical to one that was sent, and the
    /// receiver recovers all messages after the damage.
    #[test]
    fn corruption_never_yields_a_bad_message(data in proptest::collection::vec(any::<u8>(), 0..300),
                                             edits in proptest::collection::vec((any::<prop::sample::Index>(), 0u8..3, any::<u8>()), 1..6),
                                             sizes in proptest::collection::vec(1usize..200, 1..6)) {
        let (mut stream, raws) = sample_stream(&data);
        for (idx, op, byte) in edits {
            let i = idx.index(stream.len());
            match op {
                0 => stream[i] ^= byte | 1,
                1 => { stream.remove(i); }
                _ => stream.insert(i, byte),
            }
        }
        let (good, _) = receive(&stream, &sizes, MAX_MESSAGE_LEN);
        for g in &good {
            prop_assert!(raws.contains(g), "accepted a message that was never sent");
        }
        // Resync: a clean copy appended after the damage is fully received.
        let (clean, _) = sample_stream(&data);
        let mut both = stream.clone();
        both.push(0);
        both.extend_from_slice(&clean);
        let (good2, _) = receive(&both, &sizes, MAX_MESSAGE_LEN);
        prop_assert!(good2.len() >= raws.len());
        prop_assert_eq!(&good2[good2.len() - raws.len()..], &raws[..]);
    }

    /// Stream a frame through the assembler with random chunk losses,
    /// duplicates, reorders and payload corruptions that pass the message
    /// CRC (as if device memory were bad): a yielded frame is always exactly
    /// the original.
    #[test]
    fn damaged_frames_are_never_yielded(pixels in proptest::collection::vec(any::<u8>(), 2..400),
                                        chunk_len in 1usize..64,
                                        damage in proptest::collection::vec((any::<prop::sample::Index>(), 0u8..5, any::<u8>()), 0..4)) {
        let pixels = &pixels[..pixels.len() & !1];
        let leader = FrameLeader {
            seq: 3, timestamp_us: 0, width_px: (pixels.len() / 2) as u16, height_px: 1,
            pixel_format: PixelFormat::Mono16, agc_enabled: false, test_pattern: 0,
            gain_milli: 1000, mcp_voltage_mv: 0, agc_setpoint_ppm: 0, exposure_us: 1,
            gate_ns: 1, payload_len_bytes: pixels.len() as u32,
        };
        let mut msgs: Vec<Message<'_>> = vec![Message::FrameLeader(leader)];
        for (k, c) in pixels.chunks(chunk_len).enumerate() {
            msgs.push(Message::FrameChunk(FrameChunk { seq: 3, offset_bytes: (k * chunk_len) as u32, data: c }));
        }
        msgs.push(Message::FrameTrailer(FrameTrailer {
            seq: 3, status: ErrorCode::OK, valid_len_bytes: pixels.len() as u32, crc32c: crc32c(pixels),
        }));
        // Work on encoded messages so damage can be anything bytes allow.
        let mut raws: Vec<Vec<u8>> = msgs.iter().map(|m| {
            let mut b = vec![0u8; MAX_MESSAGE_LEN];
            let n = Packet::new(0, *m).encode(&mut b).unwrap();
            b.truncate(n);
            b
        }).collect();
        let mut damaged = false;
        for (idx, op, byte) in &damage {
            let i = idx.index(raws.len());
            match op {
                0 => { raws.remove(i); damaged = true; }
                1 => { let m = raws[i].clone(); raws.insert(i, m); damaged = true; }
                2 if i + 1 < raws.len() => { raws.swap(i, i + 1); damaged = true; }
                _ => {
                    // Flip a body byte (not the kind) and re-seal the CRC.
                    let r = &mut raws[i];
                    let n = r.len() - 4;
                    if n > 3 {
                        let at = 3 + usize::from(*byte) % (n - 3);
                        r[at] ^= byte | 1;
                        let c = crc32c(&r[..n]);
                        r[n..].copy_from_slice(&c.to_le_bytes());
                        damaged = true;
                    }
                }
            }
        }
        let mut buf = vec![0u8; 512];
        let mut asm = FrameAssembler::new(&mut buf[..]);
        let mut yielded = 0;
        for r in &raws {
            let Ok(p) = decode_message(r) else { continue };
            if let AssemblyEvent::Frame { data, info } = asm.push(&p.message) {
                prop_assert_eq!(data, pixels);
                prop_assert_eq!(info.leader.payload_len_bytes, leader.payload_len_bytes);
                yielded += 1;
            }
        }
        if !damaged {
            prop_assert_eq!(yielded, 1);
        }
        prop_assert!(yielded <= 1);
    }
}
