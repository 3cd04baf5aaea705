//! Capturing a render through a simulated camera (`gloam render --sensor`).
//!
//! The tracer gives band radiance (∫ L(λ) R_b(λ) dλ per band); the camera
//! needs each band's spectral shape to integrate its photocathode QE. The
//! spectral distribution inside a band is not kept by the render, so each
//! band's response curve stands in for it (flat within a rectangular band).
//! Narrow bands make this exact; document wide bands accordingly.

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use gloam_sensor::Camera;
use gloam_trace::RenderOutput;
use serde::Serialize;

use super::output::{png16_bytes, write_atomic};

/// What to capture and how.
pub struct FrameCapture<'a> {
    pub sensor: &'a str,
    pub frames: u32,
    pub gain: Option<f64>,
    pub agc: bool,
    pub noise: bool,
    pub seed: u64,
}

/// One line of `frames.jsonl` (the same keys as `gloam capture` writes,
/// plus the sensor's own figures).
#[derive(Serialize)]
struct FrameRecord<'a> {
    index: u32,
    file: String,
    seq: u64,
    /// µs since the stream started.
    timestamp: u64,
    gain: f64,
    agc: bool,
    bits: u8,
    width: usize,
    height: usize,
    pixels_crc32c: u32,
    status: &'static str,
    sensor: &'a gloam_sensor::FrameMeta,
}

impl FrameCapture<'_> {
    pub fn run(
        &self,
        scene: &gloam_scene::Scene,
        render: &RenderOutput,
        out: &Path,
    ) -> anyhow::Result<()> {
        anyhow::ensure!(self.frames >= 1, "--frames must be at least 1");
        let mut config = gloam_sensor::load_preset_or_file(self.sensor)
            .with_context(|| format!("loading sensor '{}'", self.sensor))?;
        config.noise.seed = self.seed;
        let mut camera = Camera::new(config)?;
        camera.set_noise(self.noise);
        if let Some(g) = self.gain {
            camera.set_override_gain(Some(g))?;
        }
        if self.agc {
            camera.set_agc(true);
        }
        let shapes: Vec<_> = render
            .band_names
            .iter()
            .map(|name| {
                scene
                    .band(name)
                    .map(|b| b.response.clone())
                    .with_context(|| format!("band '{name}' missing from the scene"))
            })
            .collect::<anyhow::Result<_>>()?;
        let mut jsonl = Vec::new();
        for i in 0..self.frames {
            let frame = camera
                .capture(render.radiance.view(), &shapes)
                .with_context(|| format!("capturing frame {i}"))?;
            let (h, w) = frame.pixels.dim();
            let pixels: Vec<u16> = frame.pixels.iter().copied().collect();
            let file = format!("frame-{i:06}.png");
            write_atomic(&out.join(&file), &png16_bytes(w as u32, h as u32, &pixels)?)?;
            let m = &frame.meta;
            let rec = FrameRecord {
                index: i,
                file,
                seq: m.seq,
                timestamp: (m.time_s * 1e6).round() as u64,
                gain: m.gain_in_effect,
                agc: m.agc_enabled,
                bits: m.bits,
                width: w,
                height: h,
                pixels_crc32c: gloam_grabber::pixels_crc32c(&pixels),
                status: "ok",
                sensor: m,
            };
            serde_json::to_writer(&mut jsonl, &rec)?;
            jsonl.write_all(b"\n")?;
            // Rewritten after every frame so an interrupted run keeps what it captured.
            write_atomic(&out.join("frames.jsonl"), &jsonl)?;
        }
        eprintln!(
            "captured {} frame(s) through '{}' → {}",
            self.frames,
            self.sensor,
            out.display()
        );
        Ok(())
    }
}
