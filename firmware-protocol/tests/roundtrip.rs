//! Every message kind survives encode → decode over both framings, and the
//! decoder rejects damaged or ill-formed input with the right error.

mod common;

use common::sample_packets;
use firmware_protocol::*;

#[test]
fn every_kind_is_sampled() {
    let data = [1u8, 0, 2, 0];
    let kinds: Vec<Kind> = sample_packets(&data)
        .iter()
        .map(|p| p.message.kind())
        .collect();
    assert_eq!(kinds, Kind::ALL.to_vec());
}

#[test]
fn raw_and_cobs_round_trip() {
    let data: Vec<u8> = (0..MAX_CHUNK_DATA_LEN).map(|i| (i % 7) as u8).collect();
    for chunk in [&data[..0], &data[..5], &data[..]] {
        for p in sample_packets(chunk) {
            let mut raw = vec![0u8; MAX_MESSAGE_LEN];
            let n = p.encode(&mut raw).unwrap();
            assert_eq!(n, p.encoded_len());
            assert_eq!(decode_message(&raw[..n]).unwrap(), p);

            let mut wire = vec![0u8; MAX_COBS_FRAME_LEN];
            let w = p.encode_cobs(&mut wire).unwrap();
            assert!(w <= MAX_COBS_FRAME_LEN);
            assert_eq!(wire[w - 1], 0);
            assert!(!wire[..w - 1].contains(&0));
            let mut back = vec![0u8; MAX_MESSAGE_LEN];
            let m = cobs::decode_frame(&wire[..w - 1], &mut back).unwrap();
            assert_eq!(&back[..m], &raw[..n], "COBS path equals raw path");
        }
    }
}

#[test]
fn requests_fit_max_request_len() {
    for p in sample_packets(&[]) {
        if p.message.kind().is_request() {
            assert!(p.encoded_len() <= MAX_REQUEST_LEN, "{p:?}");
        }
    }
}

#[test]
fn encode_errors() {
    let data = vec![1u8; MAX_CHUNK_DATA_LEN + 1];
    let p = Packet::new(
        0,
        Message::FrameChunk(FrameChunk {
            seq: 0,
            offset_bytes: 0,
            data: &data,
        }),
    );
    let mut out = vec![0u8; MAX_COBS_FRAME_LEN + 10];
    assert_eq!(
        p.encode(&mut out),
        Err(EncodeError::ChunkTooLong {
            data_len: MAX_CHUNK_DATA_LEN + 1
        })
    );
    for p in sample_packets(&[1, 2, 3]) {
        let need = p.encoded_len();
        let mut small = vec![0u8; need - 1];
        assert_eq!(
            p.encode(&mut small),
            Err(EncodeError::BufferTooSmall { needed_len: need })
        );
        let mut wire = vec![0u8; 64];
        let w = p.encode_cobs(&mut wire).unwrap();
        for short in 0..w {
            let mut s = vec![0u8; short];
            match p.encode_cobs(&mut s) {
                Err(EncodeError::BufferTooSmall { needed_len }) => assert_eq!(needed_len, w),
                r => panic!("{short}: {r:?}"),
            }
        }
    }
}

#[test]
fn decode_errors() {
    assert_eq!(
        decode_message(&[1, 2, 3]),
        Err(DecodeError::TooShort { len_bytes: 3 })
    );
    let big = vec![0u8; MAX_MESSAGE_LEN + 1];
    assert!(matches!(
        decode_message(&big),
        Err(DecodeError::TooLong { .. })
    ));
    let with_crc = |mut v: Vec<u8>| {
        let c = crc32c(&v);
        v.extend_from_slice(&c.to_le_bytes());
        v
    };
    assert_eq!(
        decode_message(&with_crc(vec![0x99, 0, 0])),
        Err(DecodeError::UnknownKind { kind: 0x99 })
    );
    assert_eq!(
        decode_message(&with_crc(vec![Kind::GetStatus as u8, 0, 0, 1])),
        Err(DecodeError::BadLength {
            kind: Kind::GetStatus as u8,
            body_len: 1
        })
    );
    assert_eq!(
        decode_message(&with_crc(vec![Kind::FrameChunk as u8, 0, 0, 1, 2, 3])),
        Err(DecodeError::BadLength {
            kind: Kind::FrameChunk as u8,
            body_len: 3
        })
    );
    assert_eq!(
        decode_message(&with_crc(vec![Kind::GetControl as u8, 0, 0, 0x55])),
        Err(DecodeError::BadField {
            kind: Kind::GetControl as u8,
            field_offset: 0
        })
    );
    // Every single-bit flip of every sample message is caught.
    for p in sample_packets(&[9, 8, 7, 6, 5]) {
        let mut raw = vec![0u8; 128];
        let n = p.encode(&mut raw).unwrap();
        for bit in 0..n * 8 {
            let mut m = raw[..n].to_vec();
            m[bit / 8] ^= 1 << (bit % 8);
            assert!(decode_message(&m).is_err(), "{p:?} bit {bit}");
        }
    }
}

#[test]
fn error_display_is_informative() {
    let s = format!(
        "{}",
        DecodeError::BadCrc {
            received: 1,
            computed: 2
        }
    );
    assert!(s.contains("0x00000001"), "{s}");
    assert_eq!(format!("{}", ErrorCode::BUSY), "BUSY (0x08)");
    assert_eq!(format!("{}", ErrorCode(0xEE)), "unknown code 0xee");
    assert!(format!("{}", FrameError::Overrun).contains("discarded"));
    assert!(format!("{}", EncodeError::BufferTooSmall { needed_len: 9 }).contains('9'));
}

#[test]
fn usb_transfer_round_trip() {
    let data: Vec<u8> = (0..1009u32).map(|i| (i * 7) as u8).collect();
    for len in [0usize, 1, 497, 512 - 15, 1009] {
        let p = Packet::new(
            0,
            Message::FrameChunk(FrameChunk {
                seq: 1,
                offset_bytes: 0,
                data: &data[..len],
            }),
        );
        let mut raw = vec![0u8; 2048];
        let n = p.encode(&mut raw).unwrap();
        let mut asm = usb::TransferAssembler::new(vec![0u8; 2048], usb::USB_HS_MAX_PACKET_LEN);
        let mut out = None;
        let mut count = 0;
        for pkt in usb::packets(&raw[..n], usb::USB_HS_MAX_PACKET_LEN) {
            count += 1;
            if let Some(m) = asm.push_packet(pkt).unwrap() {
                out = Some(m.to_vec());
            }
        }
        assert_eq!(count, usb::packet_count(n, 512));
        assert_eq!(decode_message(&out.unwrap()).unwrap(), p);
    }
}

/// The sizes quoted in PROTOCOL.md §3.
#[test]
fn documented_constants() {
    assert_eq!(MAX_MESSAGE_LEN, 16_399);
    assert_eq!(MAX_COBS_FRAME_LEN, 16_465);
    assert_eq!(MAX_CHUNK_DATA_LEN, 16_384);
    assert_eq!(MAX_REQUEST_LEN, 16);
    let doc = include_str!("../PROTOCOL.md");
    for needle in [
        "| `MAX_MESSAGE_LEN` | 16 399 |",
        "| `MAX_COBS_FRAME_LEN` | 16 465 |",
        "| `MAX_CHUNK_DATA_LEN` | 16 384 |",
        "| `MAX_REQUEST_LEN` | 16 |",
        "`REPLY_TIMEOUT_MS` = 250 ms",
        "PENDING_GRACE_MS` (500 ms)",
        "`FRAME_IDLE_TIMEOUT_MS` (1000 ms)",
    ] {
        assert!(doc.contains(needle), "PROTOCOL.md lacks {needle:?}");
    }
    assert_eq!(REPLY_TIMEOUT_MS, 250);
    assert_eq!(PENDING_GRACE_MS, 500);
    assert_eq!(FRAME_IDLE_TIMEOUT_MS, 1000);
    // Body lengths in the §4 table.
    for (kind, len) in [
        (Kind::Hello, 4),
        (Kind::GetControl, 1),
        (Kind::SetControl, 5),
        (Kind::StartStream, 4),
        (Kind::Capabilities, 22),
        (Kind::Nak, 6),
        (Kind::Status, 21),
        (Kind::FrameLeader, 43),
        (Kind::FrameTrailer, 13),
    ] {
        let row = format!("| `{:#04x}` |", kind as u8);
        let line = doc.lines().find(|l| l.starts_with(&row)).unwrap();
        assert!(line.contains(&format!("| {len} |")), "{line}");
        assert_eq!(kind.body_len(), Some(len));
    }
}
