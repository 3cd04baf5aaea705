//! Codec throughput: COBS + CRC-32C of full-size frame chunks.
//!
//! `encode` = `Packet::encode_cobs` of a 16 KiB chunk (CRC + stuffing in one
//! pass into the wire buffer); `decode` = `CobsAccumulator::feed` of the wire
//! bytes + `decode_message` (CRC check + parse). Criterion reports GB/s of
//! pixel data (decimal GB). Two payloads: typical 12-bit low-light pixels in
//! `u16` containers (many zero high bytes → many short COBS blocks, the
//! realistic worst case) and dense random bytes.

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use firmware_protocol::{
    CobsAccumulator, Feed, FrameChunk, MAX_CHUNK_DATA_LEN, MAX_COBS_FRAME_LEN, MAX_MESSAGE_LEN,
    Message, Packet, decode_message,
};

fn payloads() -> [(&'static str, Vec<u8>); 2] {
    // xorshift so the bench needs no RNG crate and is reproducible.
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    let low_light: Vec<u8> = (0..MAX_CHUNK_DATA_LEN / 2)
        .flat_map(|_| ((next() % 600) as u16 + 40).to_le_bytes())
        .collect();
    let dense: Vec<u8> = (0..MAX_CHUNK_DATA_LEN).map(|_| next() as u8).collect();
    [("mono12_low_light", low_light), ("random_bytes", dense)]
}

fn chunk(data: &[u8]) -> Packet<'_> {
    Packet::new(
        0,
        Message::FrameChunk(FrameChunk {
            seq: 1,
            offset_bytes: 0,
            data,
        }),
    )
}

fn decode_once(wire: &[u8], rx: &mut CobsAccumulator<&mut [u8]>) -> usize {
    let (_, feed) = rx.feed(wire);
    match feed {
        Feed::Frame(f) => match decode_message(f) {
            Ok(Packet {
                message: Message::FrameChunk(c),
                ..
            }) => c.data.len(),
            _ => 0,
        },
        _ => 0,
    }
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("codec");
    for (name, data) in payloads() {
        let p = chunk(&data);
        let mut wire = vec![0u8; MAX_COBS_FRAME_LEN];
        let n = p.encode_cobs(&mut wire).unwrap();
        let mut rx_buf = vec![0u8; MAX_MESSAGE_LEN];
        group.throughput(Throughput::Bytes(data.len() as u64));
        group.bench_function(format!("encode_cobs/{name}"), |b| {
            let mut out = vec![0u8; MAX_COBS_FRAME_LEN];
            b.iter(|| black_box(black_box(&p).encode_cobs(&mut out).unwrap()));
        });
        group.bench_function(format!("decode_cobs/{name}"), |b| {
            let mut rx = CobsAccumulator::new(&mut rx_buf[..]);
            b.iter(|| black_box(decode_once(black_box(&wire[..n]), &mut rx)));
        });
        let mut raw = vec![0u8; MAX_MESSAGE_LEN];
        let m = p.encode(&mut raw).unwrap();
        group.bench_function(format!("encode_raw_usb/{name}"), |b| {
            b.iter(|| black_box(black_box(&p).encode(&mut raw).unwrap()));
        });
        group.bench_function(format!("decode_raw_usb/{name}"), |b| {
            b.iter(|| black_box(decode_message(black_box(&raw[..m])).is_ok()));
        });
    }
    group.finish();
    print_gbps();
}

/// Plain wall-clock summary in GB/s, printed once after criterion's output
/// so the figure is visible without parsing criterion's report.
fn print_gbps() {
    for (name, data) in payloads() {
        let p = chunk(&data);
        let mut wire = vec![0u8; MAX_COBS_FRAME_LEN];
        let n = p.encode_cobs(&mut wire).unwrap();
        let reps = 20_000u32;
        let t = Instant::now();
        for _ in 0..reps {
            black_box(black_box(&p).encode_cobs(&mut wire).unwrap());
        }
        let enc = t.elapsed().as_secs_f64();
        let mut rx_buf = vec![0u8; MAX_MESSAGE_LEN];
        let mut rx = CobsAccumulator::new(&mut rx_buf[..]);
        let t = Instant::now();
        for _ in 0..reps {
            black_box(decode_once(black_box(&wire[..n]), &mut rx));
        }
        let dec = t.elapsed().as_secs_f64();
        let bytes = data.len() as f64 * f64::from(reps);
        println!(
            "codec {name}: encode {:.2} GB/s, decode {:.2} GB/s (COBS + CRC-32C, {} B chunks)",
            bytes / enc / 1e9,
            bytes / dec / 1e9,
            data.len()
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
