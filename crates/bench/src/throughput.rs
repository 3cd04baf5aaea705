//! `gloam bench throughput`: rays/s, sensor-chain frames/s and protocol
//! codec GB/s — every performance figure the README quotes.

use std::path::Path;
use std::time::Instant;

use gloam_trace::{RenderSettings, Tracer};

use super::BenchError;
use serde::Serialize;

// throughput

#[derive(Serialize)]
pub struct RenderFigures {
    scene: String,
    width: u32,
    height: u32,
    spp: u32,
    threads: usize,
    trace_s: f64,
    primary_rays: u64,
    shadow_rays: u64,
    secondary_rays: u64,
    primary_rays_per_s: f64,
    shadow_rays_per_s: f64,
    rays_per_s: f64,
}

#[derive(Serialize)]
pub struct CodecFigures {
    payload: &'static str,
    chunk_bytes: usize,
    encode_gb_per_s: f64,
    decode_gb_per_s: f64,
}

/// Every throughput figure, as `gloam bench throughput --json` prints it.
#[derive(Serialize)]
pub struct Throughput {
    pub render: RenderFigures,
    pub sensor: gloam_sensor::bench::Throughput,
    pub codec: CodecFigures,
}

/// Measures the ray, sensor-chain and codec figures (`quick`: fewer frames
/// and shorter timings, for tests).
pub fn run(
    scene_path: &Path,
    quick: bool,
    threads: Option<usize>,
) -> Result<Throughput, BenchError> {
    let scene = gloam_scene::load(scene_path, &crate::unlisted())?;
    let settings = RenderSettings {
        spp: if quick { 1 } else { 4 },
        threads,
        ..Default::default()
    };
    let tracer = Tracer::new(&scene, &settings)?;
    let out = tracer.render(&|_, _| {})?;
    let s = &out.stats;
    let t = s.trace_seconds.max(1e-9);
    let render = RenderFigures {
        scene: scene_path.display().to_string(),
        width: s.width,
        height: s.height,
        spp: settings.spp,
        threads: s.threads,
        trace_s: s.trace_seconds,
        primary_rays: s.rays.primary,
        shadow_rays: s.rays.shadow,
        secondary_rays: s.rays.secondary,
        primary_rays_per_s: s.rays.primary as f64 / t,
        shadow_rays_per_s: s.rays.shadow as f64 / t,
        rays_per_s: s.rays_per_second,
    };

    let frames = if quick { 2 } else { 20 };
    let run_sensor = || gloam_sensor::throughput("gen3-gaas-iccd", 1024, 768, frames);
    let sensor = match threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()?
            .install(run_sensor)?,
        None => run_sensor()?,
    };

    let codec = codec_throughput(if quick { 0.05 } else { 0.5 })?;

    Ok(Throughput {
        render,
        sensor,
        codec,
    })
}

impl Throughput {
    /// The lines `gloam bench throughput` prints.
    pub fn text(&self) -> String {
        let (render, sensor, codec) = (&self.render, &self.sensor, &self.codec);
        let mut m = String::new();

        m.push_str(&format!(
            "rays ({}, {}×{}, spp {}, {} threads): {:.3e} primary/s, {:.3e} shadow/s, {:.3e} total/s",
            render.scene,
            render.width,
            render.height,
            render.spp,
            render.threads,
            render.primary_rays_per_s,
            render.shadow_rays_per_s,
            render.rays_per_s
        ));
        m.push('\n');
        m.push_str(&format!(
            "sensor chain ({}, {}×{}, noise on): {:.1} frames/s, median frame {:.1} ms \
             ({:.1} frames/s; target ≥ 60) ({} threads{})",
            sensor.preset,
            sensor.width,
            sensor.height,
            sensor.frames_per_s,
            sensor.median_frame_ms,
            sensor.median_frames_per_s,
            sensor.threads,
            sensor
                .frames_per_cpu_s
                .map(|f| format!(", {f:.1} frames per CPU-second"))
                .unwrap_or_default()
        ));
        m.push('\n');
        m.push_str(&format!(
            "protocol codec ({}, {} B chunks): encode {:.2} GB/s, decode {:.2} GB/s",
            codec.payload, codec.chunk_bytes, codec.encode_gb_per_s, codec.decode_gb_per_s
        ));
        m.push('\n');

        m
    }
}

/// COBS + CRC-32C of full-size frame chunks of low-light 12-bit pixels in
/// u16 containers (many zero high bytes: short COBS blocks, the realistic
/// worst case), as `firmware-protocol/benches/codec.rs`. GB = 1e9 bytes of
/// pixel data.
fn codec_throughput(seconds_each: f64) -> Result<CodecFigures, BenchError> {
    use firmware_protocol::{
        CobsAccumulator, Feed, FrameChunk, MAX_CHUNK_DATA_LEN, MAX_COBS_FRAME_LEN, MAX_MESSAGE_LEN,
        Message, Packet, decode_message,
    };
    use std::hint::black_box;
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let data: Vec<u8> = (0..MAX_CHUNK_DATA_LEN / 2)
        .flat_map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s % 600) as u16 + 40).to_le_bytes()
        })
        .collect();
    let packet = Packet::new(
        0,
        Message::FrameChunk(FrameChunk {
            seq: 1,
            offset_bytes: 0,
            data: &data,
        }),
    );
    let mut wire = vec![0u8; MAX_COBS_FRAME_LEN];
    let n = packet
        .encode_cobs(&mut wire)
        .map_err(|e| BenchError::Encode(format!("{e:?}")))?;
    let time = |f: &mut dyn FnMut() -> usize| -> f64 {
        let t0 = Instant::now();
        let mut bytes = 0usize;
        let mut iters = 0u64;
        while iters < 16 || t0.elapsed().as_secs_f64() < seconds_each {
            bytes += f();
            iters += 1;
        }
        bytes as f64 / t0.elapsed().as_secs_f64() / 1e9
    };
    let mut out = vec![0u8; MAX_COBS_FRAME_LEN];
    let encode = time(&mut || {
        black_box(black_box(&packet).encode_cobs(&mut out).unwrap_or(0));
        data.len()
    });
    let mut rx_buf = vec![0u8; MAX_MESSAGE_LEN];
    let mut rx = CobsAccumulator::new(&mut rx_buf[..]);
    let mut ok = true;
    let decode = time(&mut || {
        let (_, feed) = rx.feed(black_box(&wire[..n]));
        match feed {
            Feed::Frame(f) => match decode_message(f) {
                Ok(Packet {
                    message: Message::FrameChunk(c),
                    ..
                }) => black_box(c.data.len()),
                _ => {
                    ok = false;
                    0
                }
            },
            _ => {
                ok = false;
                0
            }
        }
    });
    if !ok {
        return Err(BenchError::Check(
            "the codec benchmark failed to decode its own chunk",
        ));
    }
    Ok(CodecFigures {
        payload: "mono12 low-light pixels in u16",
        chunk_bytes: data.len(),
        encode_gb_per_s: encode,
        decode_gb_per_s: decode,
    })
}

// ---------------------------------------------------------------------------
