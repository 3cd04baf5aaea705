//! `gloam bench accuracy SCENE --out DIR …` and `gloam bench throughput`:
//! what accuracy costs in time, and every performance figure the README
//! quotes.
//!
//! **accuracy** sweeps the settings that trade accuracy for time and, for
//! each run, records wall time and the error against the truth:
//!
//! - *closed form* when the scene has one: no point sources, no sky, area
//!   sources with integer shape exponents, no specular or transmissive
//!   material, and all non-emitting facets in one plane (nothing can occlude
//!   an emitter from them: `sims/panel-validation`). The truth of a pixel is
//!   `(1/π) Σ_s F_s(p) ∫ R_b ρ L_s dλ`, with `F_s` Lambert's/Arvo's factor
//!   (`gloam_trace::closed_form`) averaged over an 8 × 8 grid of sub-pixel
//!   primary hits, and the band integral exact (lines included).
//! - otherwise a *reference* render (analytic, high spp, 1 nm grid, as two
//!   independent halves), cached in `DIR/reference.npy` with its key (scene
//!   hash + settings) in `DIR/reference.json`. The halves give the
//!   reference's own noise, which is subtracted from each run's mean squared
//!   error, so the error reported is that of the run alone.
//!
//! Only pixels whose primary hits (4 × 4 sub-pixel rays) all land on
//! non-emitting facets count: the floor/room irradiance map, not the
//! directly viewed lamps (exact by construction). Errors:
//! `rel_rms_error = sqrt(Σ(x − t)² / Σ t²)` over those pixels and all bands,
//! `max_rel_error = max |x − t| / t` over pixels with `t` above 1 % of the
//! band's mean.
//!
//! The reference, like the default, has `diffuse_bounces = 0`: on the
//! office room the `diffuse_bounces` rows therefore measure the
//! inter-reflected light the default leaves out, not an error. The
//! `spectral_step_nm` rows use a clear-mercury copy of a scene whose own
//! sources have no emission lines (the panel), where the truth stays exact.
//!
//! **plan** renders each sim with the effect plan and with `all_effects`
//! (every estimator path forced on), and checks that the two images differ
//! by less than 1.5 × the seed-to-seed difference of the planned render.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clap::{Args, Subcommand};
use gloam_scene::Scene;
use gloam_trace::closed_form::shaped_polygon_irradiance_factor;
use gloam_trace::{DVec3, Estimator, RenderSettings, Tracer};
use ndarray::{Array2, Array3, Axis};
use rayon::prelude::*;
use serde::Serialize;

use super::output::{print_json, write_atomic, write_atomic_with};

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Error against the truth and wall time across the accuracy settings.
    Accuracy(AccuracyArgs),
    /// Rays/s, sensor-chain frames/s and protocol codec GB/s.
    Throughput(ThroughputArgs),
    /// Time the effect plan saves: each sim rendered with the plan and with
    /// every effect forced on (`all_effects`), images checked to agree.
    Plan(PlanBenchArgs),
}

#[derive(Args)]
pub struct PlanBenchArgs {
    /// Scene files (default: every `sims/*/scene.toml`).
    pub scenes: Vec<PathBuf>,
    /// Camera samples per pixel (default 1: the plan's saving per sample).
    #[arg(long, default_value_t = 1)]
    pub spp: u32,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct AccuracyArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Output directory: accuracy.csv, accuracy.png, summary.md, the
    /// cached reference.
    #[arg(long)]
    pub out: PathBuf,
    /// Total wall-time budget, seconds (the sweep stops cleanly when spent).
    #[arg(long, default_value_t = 120.0)]
    pub budget_s: f64,
    /// Also render with every effect forced on and report the time the
    /// effect plan saves (the tracer's `all_effects` setting).
    #[arg(long)]
    pub all_effects: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print the summary as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct ThroughputArgs {
    /// Scene for the ray figures (default: the office room).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Fewer frames and shorter timings (for tests).
    #[arg(long)]
    pub quick: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(c: BenchCommand) -> anyhow::Result<()> {
    match c {
        BenchCommand::Accuracy(a) => accuracy(a),
        BenchCommand::Throughput(a) => throughput(a),
        BenchCommand::Plan(a) => plan_bench(a),
    }
}

/// A path as given, or relative to the source tree (so `gloam bench` finds
/// the sims from any directory of a checkout).
fn find_path(p: &Path) -> PathBuf {
    if p.exists() || p.is_absolute() {
        return p.to_path_buf();
    }
    let alt = Path::new(env!("CARGO_MANIFEST_DIR")).join(p);
    if alt.exists() { alt } else { p.to_path_buf() }
}

// ---------------------------------------------------------------------------
// plan

/// `sqrt(Σ(a − b)² / Σ b²)` over every pixel and band.
fn rel_rms_diff(a: &Array3<f64>, b: &Array3<f64>) -> f64 {
    let (mut se, mut st) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b.iter()) {
        se += (x - y) * (x - y);
        st += y * y;
    }
    if st > 0.0 {
        (se / st).sqrt()
    } else {
        se.sqrt()
    }
}

fn plan_bench(args: PlanBenchArgs) -> anyhow::Result<()> {
    let scenes: Vec<PathBuf> = if args.scenes.is_empty() {
        let dir = find_path(Path::new("sims"));
        let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
            .with_context(|| format!("listing {}", dir.display()))?
            .filter_map(|e| e.ok().map(|e| e.path().join("scene.toml")))
            .filter(|p| p.exists())
            .collect();
        v.sort();
        v
    } else {
        args.scenes.iter().map(|p| find_path(p)).collect()
    };
    let mut out = Vec::new();
    let (mut t_plan, mut t_all) = (0.0, 0.0);
    for path in &scenes {
        let scene = gloam_scene::load(path)?;
        let base = RenderSettings {
            spp: args.spp,
            threads: args.threads,
            ..Default::default()
        };
        let mut forced = base.clone();
        forced.set("all_effects", "true").map_err(|e| {
            anyhow::anyhow!("gloam-trace has no setting to force every effect on ({e})")
        })?;
        let render = |s: &RenderSettings| -> anyhow::Result<(Array3<f64>, f64)> {
            let t0 = Instant::now();
            let o = Tracer::new(&scene, s)?.render(&|_, _| {})?;
            Ok((o.radiance, t0.elapsed().as_secs_f64()))
        };
        let (a, ta) = render(&base)?;
        let (b, tb) = render(&forced)?;
        // The plan's own noise: the same render with another seed.
        let (a2, _) = render(&RenderSettings {
            seed: base.seed + 1,
            ..base.clone()
        })?;
        let noise = rel_rms_diff(&a2, &a);
        let diff = rel_rms_diff(&b, &a);
        // Interreflection, both directions: flip the plan's decision and
        // measure the change of the signal over the pixels that do not see
        // an emitter (the pilot's own pixel set), against the tolerance.
        let tracer = Tracer::prepare(&scene, &base, false)?;
        let decision = tracer.interreflection.clone();
        let kept = decision.method != "off";
        let mut flipped = base.clone();
        flipped.set("indirect", if kept { "off" } else { "cache" })?;
        let (c, _) = render(&flipped)?;
        let mask = receiver_mask(&scene, &tracer, 2);
        let masked_mean = |img: &Array3<f64>| -> Vec<f64> {
            img.axis_iter(Axis(0))
                .map(|band| {
                    let (s, n) = mask
                        .indexed_iter()
                        .filter(|(_, m)| **m)
                        .fold((0.0, 0usize), |(s, n), ((r, cc), _)| {
                            (s + band[[r, cc]], n + 1)
                        });
                    s / n.max(1) as f64
                })
                .collect()
        };
        let (ma, mc, ma2) = (masked_mean(&a), masked_mean(&c), masked_mean(&a2));
        let with_ir = if kept { &ma } else { &mc };
        let change = (0..ma.len())
            .map(|b| {
                let d = with_ir[b].abs().max(1e-300);
                (ma[b] - mc[b]).abs() / d
            })
            .fold(0.0, f64::max);
        let mean_noise = (0..ma.len())
            .map(|b| (ma[b] - ma2[b]).abs() / ma[b].abs().max(1e-300))
            .fold(0.0, f64::max);
        let tol = base.tolerance;
        let ir_ok = if kept {
            change > tol
        } else {
            change <= tol + 3.0 * mean_noise
        };
        // Two independent renders differ by √2 σ; forced vs plan shares
        // the seed, so agreement within noise is diff ≤ 1.5 × that + 1e-9.
        let agree = diff <= 1.5 * noise + 1e-9;
        t_plan += ta;
        t_all += tb;
        out.push(serde_json::json!({
            "scene": path.display().to_string(),
            "plan_s": ta,
            "all_effects_s": tb,
            "saved_s": tb - ta,
            "saved_fraction": 1.0 - ta / tb.max(1e-12),
            "rel_rms_difference": diff,
            "rel_rms_noise_between_seeds": noise,
            "agree_within_noise": agree,
            "interreflection": {
                "decision": decision.method,
                "estimated_share": decision.estimated_share,
                "measured_share": change,
                "tolerance": tol,
                "mean_noise_between_seeds": mean_noise,
                "consistent": ir_ok,
            },
        }));
    }
    let all_agree = out.iter().all(|v| v["agree_within_noise"] == true);
    let ir_consistent = out
        .iter()
        .all(|v| v["interreflection"]["consistent"] == true);
    let total = serde_json::json!({
        "plan_s": t_plan,
        "all_effects_s": t_all,
        "saved_s": t_all - t_plan,
        "saved_fraction": 1.0 - t_plan / f64::max(t_all, 1e-12),
        "all_agree_within_noise": all_agree,
        "interreflection_decisions_consistent": ir_consistent,
    });
    if args.json {
        print_json(&serde_json::json!({"spp": args.spp, "scenes": out, "total": total}))?;
    } else {
        println!(
            "| scene | plan (s) | all effects (s) | saved | rel RMS diff | noise (seed to seed) | agree |"
        );
        println!("|---|---|---|---|---|---|---|");
        for v in &out {
            println!(
                "| {} | {:.3} | {:.3} | {:.0} % | {:.2e} | {:.2e} | {} |",
                v["scene"].as_str().unwrap_or_default(),
                v["plan_s"].as_f64().unwrap_or(f64::NAN),
                v["all_effects_s"].as_f64().unwrap_or(f64::NAN),
                100.0 * v["saved_fraction"].as_f64().unwrap_or(f64::NAN),
                v["rel_rms_difference"].as_f64().unwrap_or(f64::NAN),
                v["rel_rms_noise_between_seeds"]
                    .as_f64()
                    .unwrap_or(f64::NAN),
                v["agree_within_noise"]
            );
        }
        println!(
            "| **total** | {t_plan:.3} | {t_all:.3} | {:.0} % | | | {all_agree} |",
            100.0 * (1.0 - t_plan / t_all.max(1e-12))
        );
        println!(
            "\n| scene | interreflection | estimated share | measured share (flipped) | tolerance | consistent |"
        );
        println!("|---|---|---|---|---|---|");
        for v in &out {
            let ir = &v["interreflection"];
            println!(
                "| {} | {} | {:.3e} | {:.3e} | {} | {} |",
                v["scene"].as_str().unwrap_or_default(),
                ir["decision"].as_str().unwrap_or_default(),
                ir["estimated_share"].as_f64().unwrap_or(f64::NAN),
                ir["measured_share"].as_f64().unwrap_or(f64::NAN),
                ir["tolerance"],
                ir["consistent"]
            );
        }
    }
    anyhow::ensure!(
        all_agree,
        "rendering with every effect forced on changed an image beyond its noise"
    );
    anyhow::ensure!(
        ir_consistent,
        "an interreflection decision disagrees with its measured share (see the table)"
    );
    Ok(())
}

// ---------------------------------------------------------------------------
// throughput

#[derive(Serialize)]
struct RenderFigures {
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
struct CodecFigures {
    payload: &'static str,
    chunk_bytes: usize,
    encode_gb_per_s: f64,
    decode_gb_per_s: f64,
}

fn throughput(args: ThroughputArgs) -> anyhow::Result<()> {
    let scene_path = find_path(
        args.scene
            .as_deref()
            .unwrap_or(Path::new("sims/office-room/scene.toml")),
    );
    let scene = gloam_scene::load(&scene_path)?;
    let settings = RenderSettings {
        spp: if args.quick { 1 } else { 4 },
        threads: args.threads,
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

    let frames = if args.quick { 2 } else { 20 };
    let run_sensor = || gloam_sensor::throughput("gen3-gaas-iccd", 1024, 768, frames);
    let sensor = match args.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()?
            .install(run_sensor)?,
        None => run_sensor()?,
    };

    let codec = codec_throughput(if args.quick { 0.05 } else { 0.5 })?;

    if args.json {
        print_json(&serde_json::json!({
            "render": render,
            "sensor": sensor,
            "codec": codec,
        }))?;
    } else {
        println!(
            "rays ({}, {}×{}, spp {}, {} threads): {:.3e} primary/s, {:.3e} shadow/s, {:.3e} total/s",
            render.scene,
            render.width,
            render.height,
            render.spp,
            render.threads,
            render.primary_rays_per_s,
            render.shadow_rays_per_s,
            render.rays_per_s
        );
        println!(
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
        );
        println!(
            "protocol codec ({}, {} B chunks): encode {:.2} GB/s, decode {:.2} GB/s",
            codec.payload, codec.chunk_bytes, codec.encode_gb_per_s, codec.decode_gb_per_s
        );
    }
    Ok(())
}

/// COBS + CRC-32C of full-size frame chunks of low-light 12-bit pixels in
/// u16 containers (many zero high bytes: short COBS blocks, the realistic
/// worst case), as `firmware-protocol/benches/codec.rs`. GB = 1e9 bytes of
/// pixel data.
fn codec_throughput(seconds_each: f64) -> anyhow::Result<CodecFigures> {
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
        .map_err(|e| anyhow::anyhow!("encoding a chunk: {e:?}"))?;
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
    anyhow::ensure!(ok, "the codec benchmark failed to decode its own chunk");
    Ok(CodecFigures {
        payload: "mono12 low-light pixels in u16",
        chunk_bytes: data.len(),
        encode_gb_per_s: encode,
        decode_gb_per_s: decode,
    })
}

// ---------------------------------------------------------------------------
// accuracy: the truth

/// What each run is compared against.
struct Truth {
    /// "closed-form" or "reference".
    kind: &'static str,
    /// Band × row × column.
    image: Array3<f64>,
    /// Pixels that count.
    mask: Array2<bool>,
    /// Variance of the reference per pixel and band (None for the closed
    /// form), subtracted from each run's squared errors.
    noise_var: Option<Array3<f64>>,
    /// Wall time spent making it (0 when cached).
    seconds: f64,
    note: String,
}

/// Primary hit of the ray through `(px, py)`: (facet, world point, ray dir).
fn primary_hit(scene: &Scene, tracer: &Tracer, px: f64, py: f64) -> Option<(u32, DVec3, DVec3)> {
    let cam = &scene.camera;
    let d = cam.pixel_direction(px, py);
    let o = cam.position - tracer.geom.origin;
    let hit = tracer.geom.intersect(o, d, 0.0, f64::INFINITY, u32::MAX)?;
    Some((hit.facet, cam.position + d * hit.t, d))
}

fn is_emitter(scene: &Scene, facet: usize) -> bool {
    scene.materials[scene.facets[facet].material]
        .emission
        .is_some()
}

/// Pixels whose four corners and `k × k` interior sub-pixel primary rays
/// all hit the same non-emitting facet (a convex facet then holds the
/// pixel's whole footprint), and none of whose eight neighbours shows an
/// emitter at any of its test points (an emitter's corner can poke into a
/// pixel between the test points; it then shows in a neighbour).
fn receiver_mask(scene: &Scene, tracer: &Tracer, k: usize) -> Array2<bool> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    // (all on one non-emitting facet, any emitter seen)
    let v: Vec<(bool, bool)> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (col, row) = (i % w, i / w);
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
            let inner = (0..k * k).map(|j| {
                (
                    ((j % k) as f64 + 0.5) / k as f64,
                    ((j / k) as f64 + 0.5) / k as f64,
                )
            });
            let mut facet = None;
            let mut same = true;
            let mut emitter = false;
            for (dx, dy) in corners.into_iter().chain(inner) {
                match primary_hit(scene, tracer, col as f64 + dx, row as f64 + dy) {
                    Some((f, _, _)) if is_emitter(scene, f as usize) => {
                        emitter = true;
                        same = false;
                    }
                    Some((f, _, _)) => same &= *facet.get_or_insert(f) == f,
                    None => same = false,
                }
            }
            (same, emitter)
        })
        .collect();
    Array2::from_shape_fn((h, w), |(r, c)| {
        v[r * w + c].0
            && (r.saturating_sub(1)..(r + 2).min(h))
                .all(|rr| (c.saturating_sub(1)..(c + 2).min(w)).all(|cc| !v[rr * w + cc].1))
    })
}

/// Why the scene has no closed form (None: it has one).
fn closed_form_obstacle(scene: &Scene) -> Option<String> {
    if !scene.point_sources.is_empty() {
        return Some("it has point sources".into());
    }
    if scene.sky.is_some() {
        return Some("it has a sky".into());
    }
    let mut plane: Option<(DVec3, f64)> = None;
    let mut emitters = 0;
    for f in &scene.facets {
        let m = &scene.materials[f.material];
        if let Some(e) = &m.emission {
            emitters += 1;
            if e.shape_exponent.fract() != 0.0 || e.shape_exponent < 0.0 {
                return Some("a shape exponent is not an integer".into());
            }
            continue;
        }
        if m.specular_fraction > 0.0 || m.transmission.is_some() {
            return Some(format!("material `{}` is specular or transmissive", m.name));
        }
        let n = f.normal();
        let d = n.dot(f.vertices[0]);
        match plane {
            None => plane = Some((n, d)),
            Some((n0, d0)) => {
                let tol = 1e-9 * (1.0 + d0.abs());
                if n.dot(n0).abs() < 1.0 - 1e-12
                    || f.vertices.iter().any(|v| (n0.dot(*v) - d0).abs() > tol)
                {
                    return Some(
                        "its non-emitting facets are not coplanar (occlusion possible)".into(),
                    );
                }
            }
        }
    }
    if emitters == 0 {
        return Some("it has no area source".into());
    }
    None
}

/// The closed-form truth (see the module docs).
fn closed_form_truth(scene: &Scene, tracer: &Tracer) -> Truth {
    let t0 = Instant::now();
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let nb = scene.bands.len();
    // Sources: vertices, normal, m, and per receiver material and band the
    // exact ∫ R_b ρ L dλ / π.
    struct Src {
        verts: Vec<DVec3>,
        normal: DVec3,
        m: u32,
        coef: BTreeMap<usize, Vec<f64>>,
    }
    let receivers: Vec<usize> = scene
        .facets
        .iter()
        .map(|f| f.material)
        .filter(|&m| scene.materials[m].emission.is_none())
        .collect();
    let srcs: Vec<Src> = scene
        .facets
        .iter()
        .filter_map(|f| {
            let e = scene.materials[f.material].emission.as_ref()?;
            let coef = receivers
                .iter()
                .map(|&rm| {
                    let rho = &scene.materials[rm].reflectance;
                    let prod = e.radiance_w_m2_sr_nm.product(rho);
                    let v = scene
                        .bands
                        .iter()
                        .map(|b| {
                            // The last product integrated exactly (quadratic
                            // pieces); `prod` is exact when ρ is flat, as on
                            // the closed-form scenes.
                            prod.integrate_weighted_band(&b.response, b.lo_nm, b.hi_nm)
                                * std::f64::consts::FRAC_1_PI
                        })
                        .collect();
                    (rm, v)
                })
                .collect();
            Some(Src {
                verts: f.vertices.clone(),
                normal: f.normal(),
                m: e.shape_exponent as u32,
                coef,
            })
        })
        .collect();
    let k = 8usize;
    let mask = receiver_mask(scene, tracer, 4);
    let vals: Vec<Vec<f64>> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (col, row) = (i % w, i / w);
            let mut acc = vec![0.0; nb];
            for j in 0..k * k {
                let px = col as f64 + ((j % k) as f64 + 0.5) / k as f64;
                let py = row as f64 + ((j / k) as f64 + 0.5) / k as f64;
                let Some((f, p, d)) = primary_hit(scene, tracer, px, py) else {
                    continue;
                };
                let facet = &scene.facets[f as usize];
                if is_emitter(scene, f as usize) {
                    continue;
                }
                let mut n = facet.normal();
                if n.dot(d) > 0.0 {
                    n = -n;
                }
                for s in &srcs {
                    let fac = shaped_polygon_irradiance_factor(p, n, &s.verts, s.normal, s.m);
                    if let Some(c) = s.coef.get(&facet.material) {
                        acc.iter_mut().zip(c).for_each(|(a, c)| *a += fac * c);
                    }
                }
            }
            acc.iter_mut().for_each(|a| *a /= (k * k) as f64);
            acc
        })
        .collect();
    let mut image = Array3::<f64>::zeros((nb, h, w));
    for (i, v) in vals.iter().enumerate() {
        for (b, x) in v.iter().enumerate() {
            image[[b, i / w, i % w]] = *x;
        }
    }
    Truth {
        kind: "closed-form",
        image,
        mask,
        noise_var: None,
        seconds: t0.elapsed().as_secs_f64(),
        note: format!(
            "closed form (Lambert/Arvo per source, {k}×{k} sub-pixel hits per pixel, exact band integrals)"
        ),
    }
}

/// 64-bit FNV-1a.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The reference: the scene's whole light by brute-force path tracing
/// (`indirect = path`, 64 diffuse bounces, Russian roulette after 3 —
/// unbiased; the truncated remainder of a ρ ≤ 0.9 room after 64 bounces is
/// < 0.1 %), independent of the radiosity cache the default uses.
fn reference_settings(threads: Option<usize>, spp: u32) -> RenderSettings {
    let mut s = RenderSettings {
        spp,
        area_samples: 4,
        source_roulette_fraction: 0.0,
        threads,
        ..Default::default()
    };
    s.set("indirect", "path").expect("valid");
    s.diffuse_bounces = 64;
    s.rr_start = 3;
    s
}

/// Pixels of the reference subset: at most `REFERENCE_PIXELS` of the mask,
/// evenly strided (the per-pixel RMS over a uniform subset estimates the
/// RMS over all of them without bias).
const REFERENCE_PIXELS: usize = 1200;

/// The high-sample reference, cached in `dir` (see the module docs).
fn reference_truth(
    scene_path: &Path,
    scene: &Scene,
    tracer: &Tracer,
    dir: &Path,
    threads: Option<usize>,
    spp: u32,
) -> anyhow::Result<Truth> {
    use ndarray_npy::{ReadNpyExt, WriteNpyExt};
    let t0 = Instant::now();
    let text =
        std::fs::read(scene_path).with_context(|| format!("reading {}", scene_path.display()))?;
    let base = reference_settings(None, spp);
    let key = format!(
        "{:016x}-{:016x}",
        fnv1a(&text),
        fnv1a(serde_json::to_string(&base)?.as_bytes())
    );
    let npy = dir.join("reference.npy");
    let meta = dir.join("reference.json");
    let full_mask = receiver_mask(scene, tracer, 4);
    let (nb, h, w) = (
        scene.bands.len(),
        scene.camera.height as usize,
        scene.camera.width as usize,
    );
    let from_stack = |stack: &ndarray::Array4<f64>| -> (Array3<f64>, Array3<f64>, Array2<bool>) {
        let image = stack.index_axis(Axis(0), 0).to_owned();
        let var = stack.index_axis(Axis(0), 1).to_owned();
        let mask = Array2::from_shape_fn((h, w), |(r, c)| {
            full_mask[[r, c]] && image[[0, r, c]].is_finite()
        });
        (image, var, mask)
    };
    if let (Ok(m), Ok(f)) = (std::fs::read_to_string(&meta), std::fs::File::open(&npy)) {
        let m: serde_json::Value = serde_json::from_str(&m).unwrap_or_default();
        if m["key"] == key {
            if let Ok(stack) = ndarray::Array4::<f64>::read_npy(std::io::BufReader::new(f)) {
                if stack.dim() == (2, nb, h, w) {
                    let (image, var, mask) = from_stack(&stack);
                    return Ok(Truth {
                        kind: "reference",
                        image,
                        mask,
                        noise_var: Some(var),
                        seconds: 0.0,
                        note: format!("cached reference ({npy}, key {key})", npy = npy.display()),
                    });
                }
            }
        }
    }
    // A strided subset of the counted pixels, each rendered in two
    // independent halves (seeds differ): their mean is the reference,
    // their difference measures its noise per pixel.
    let pixels: Vec<(usize, usize)> = full_mask
        .indexed_iter()
        .filter(|(_, m)| **m)
        .map(|(rc, _)| rc)
        .collect();
    let stride = pixels.len().div_ceil(REFERENCE_PIXELS).max(1);
    let subset: Vec<(usize, usize)> = pixels.into_iter().step_by(stride).collect();
    let half = |seed: u64| -> anyhow::Result<Vec<Vec<f64>>> {
        let s = RenderSettings {
            seed,
            spp: spp.div_ceil(2),
            ..reference_settings(threads, spp)
        };
        let t = Tracer::new(scene, &s)?;
        let v: Result<Vec<Vec<f64>>, _> = subset
            .par_iter()
            .map(|&(r, c)| t.probe_pixel(c as u32, r as u32))
            .collect();
        Ok(v?)
    };
    let a = half(1_000_001)?;
    let b = half(1_000_002)?;
    let mut stack = ndarray::Array4::<f64>::from_elem((2, nb, h, w), f64::NAN);
    for (k, &(r, c)) in subset.iter().enumerate() {
        for bi in 0..nb {
            stack[[0, bi, r, c]] = 0.5 * (a[k][bi] + b[k][bi]);
            // Var(mean of two) = E[(a − b)²] / 4.
            stack[[1, bi, r, c]] = (a[k][bi] - b[k][bi]).powi(2) / 4.0;
        }
    }
    std::fs::create_dir_all(dir)?;
    write_atomic_with(&npy, |f| {
        let mut w = std::io::BufWriter::new(f);
        stack.write_npy(&mut w)?;
        // Flush here: a BufWriter dropped with unwritten data loses the error.
        std::io::Write::flush(&mut w)?;
        Ok(())
    })?;
    let seconds = t0.elapsed().as_secs_f64();
    write_atomic(
        &meta,
        serde_json::to_string_pretty(&serde_json::json!({
            "key": key,
            "scene": scene_path.display().to_string(),
            "settings": base,
            "pixels": subset.len(),
            "seconds": seconds,
        }))?
        .as_bytes(),
    )?;
    let (image, var, mask) = from_stack(&stack);
    Ok(Truth {
        kind: "reference",
        image,
        mask,
        noise_var: Some(var),
        seconds,
        note: format!(
            "reference: the whole light by brute-force path tracing (64 diffuse bounces, spp {spp} in two halves) on {} of the counted pixels, cached in {}",
            subset.len(),
            npy.display()
        ),
    })
}

/// Errors of a render against the truth, over the counted pixels, with the
/// reference's own noise subtracted (per pixel and band).
#[derive(Clone, Copy, Debug, Default)]
struct Errors {
    /// Energy-weighted: `sqrt(Σ(x−t)²/Σt²)` (bright pixels dominate).
    energy: f64,
    /// Per pixel: `sqrt(mean(((x−t)/t)²))` (penumbrae and dark walls count
    /// as much as bright ones).
    pixel: f64,
    /// `max |x−t|/t` over pixels above 1 % of the band mean.
    max_rel: f64,
}

fn errors(img: &Array3<f64>, truth: &Truth) -> Errors {
    let mut se = 0.0;
    let mut st = 0.0;
    let mut sv = 0.0;
    let mut rel2 = 0.0;
    let mut n = 0usize;
    let mut nrel = 0usize;
    let mut max_rel: f64 = 0.0;
    for (b, (pi, pt)) in img
        .axis_iter(Axis(0))
        .zip(truth.image.axis_iter(Axis(0)))
        .enumerate()
    {
        let (mut sum_t, mut cnt) = (0.0, 0usize);
        for ((r, c), &m) in truth.mask.indexed_iter() {
            if m {
                sum_t += pt[[r, c]];
                cnt += 1;
            }
        }
        let floor = 0.01 * sum_t / cnt.max(1) as f64;
        for ((r, c), &m) in truth.mask.indexed_iter() {
            if !m {
                continue;
            }
            let (x, t) = (pi[[r, c]], pt[[r, c]]);
            let var = truth.noise_var.as_ref().map_or(0.0, |v| v[[b, r, c]]);
            se += (x - t).powi(2);
            st += t * t;
            sv += var;
            n += 1;
            if t > 0.0 {
                rel2 += ((x - t).powi(2) - var) / (t * t);
                nrel += 1;
            }
            if t > floor && t > 0.0 {
                max_rel = max_rel.max((x - t).abs() / t);
            }
        }
    }
    if n == 0 || st <= 0.0 {
        return Errors {
            energy: f64::NAN,
            pixel: f64::NAN,
            max_rel: f64::NAN,
        };
    }
    Errors {
        energy: ((se - sv).max(0.0) / st).sqrt(),
        pixel: (rel2 / nrel.max(1) as f64).max(0.0).sqrt(),
        max_rel,
    }
}

/// For a target-error render: the fraction of counted pixels (first band)
/// whose actual error `|x−t|` is within 2× the target (relative to
/// `max(t, dark floor)`) and within 2× the render's own standard-error
/// estimate (combined with the reference's noise).
fn error_coverage(img: &Array3<f64>, se: &Array3<f64>, truth: &Truth, target: f64) -> (f64, f64) {
    let (pi, ps, pt) = (
        img.index_axis(Axis(0), 0),
        se.index_axis(Axis(0), 0),
        truth.image.index_axis(Axis(0), 0),
    );
    let mean_t = {
        let v: Vec<f64> = pi.iter().copied().collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let floor = gloam_trace::render::DARK_FLOOR * mean_t;
    let (mut n, mut a, mut b) = (0usize, 0usize, 0usize);
    for ((r, c), &m) in truth.mask.indexed_iter() {
        if !m {
            continue;
        }
        let (x, t, s) = (pi[[r, c]], pt[[r, c]], ps[[r, c]]);
        let var_ref = truth.noise_var.as_ref().map_or(0.0, |v| v[[0, r, c]]);
        let err = (x - t).abs();
        n += 1;
        if err <= 2.0 * (target * t.max(floor)).hypot(var_ref.sqrt()) {
            a += 1;
        }
        if err <= 2.0 * (s * s + var_ref).sqrt() {
            b += 1;
        }
    }
    let n = n.max(1) as f64;
    (a as f64 / n, b as f64 / n)
}

// ---------------------------------------------------------------------------
// accuracy: the sweep

#[derive(Clone, Debug, Serialize)]
struct Row {
    estimator: String,
    setting: String,
    value: String,
    spp: u32,
    time_s: f64,
    rel_rms_error: f64,
    max_rel_error: f64,
    /// Per-pixel RMS relative error (see [`Errors`]).
    pixel_rms_error: f64,
    /// Target-error rows: fraction of counted pixels whose actual error is
    /// within 2× the stated target, and within 2× the render's own
    /// per-pixel standard-error estimate.
    within_2x_target: Option<f64>,
    within_2x_estimate: Option<f64>,
    /// Of `time_s`, the part spent preparing (BVH, pilot, radiosity cache).
    prepare_s: f64,
}

/// One planned run.
struct Plan {
    estimator: Estimator,
    setting: &'static str,
    value: String,
    settings: RenderSettings,
    /// Scene variant (line-spectrum source) for the spectral sweep.
    scene: Option<usize>,
}

const LADDER: [u32; 9] = [1, 2, 4, 8, 16, 32, 64, 128, 256];
const ESTIMATORS: [Estimator; 3] = [
    Estimator::Analytic,
    Estimator::SolidAngle,
    Estimator::Dirsig2001,
];

fn with(
    est: Estimator,
    threads: Option<usize>,
    f: impl FnOnce(&mut RenderSettings),
) -> RenderSettings {
    let mut s = RenderSettings {
        estimator: est,
        threads,
        ..Default::default()
    };
    f(&mut s);
    s
}

/// Settings other than spp, around their defaults.
fn other_plans(threads: Option<usize>, line_variant: Option<usize>) -> Vec<Plan> {
    let mut v = Vec::new();
    let mut push = |est: Estimator, setting: &'static str, value: &str, scene: Option<usize>| {
        let mut s = with(est, threads, |_| {});
        s.set(setting, value)
            .expect("benchmark settings are valid keys and values");
        v.push(Plan {
            estimator: est,
            setting,
            value: value.to_string(),
            settings: s,
            scene,
        });
    };
    // First what this sweep is for: the whole light and renders to a
    // stated error; then the finer settings.
    // Interreflection: off (the first wave's default: direct light only),
    // brute-force path tracing truncated at k bounces (the truncation bias
    // against the whole-light reference), the cache read without and with
    // more final-gather rays.
    push(Estimator::Analytic, "indirect", "off", None);
    for x in ["1", "2", "4"] {
        push(Estimator::Analytic, "diffuse_bounces", x, None);
    }
    for x in ["0", "4", "64"] {
        push(Estimator::Analytic, "gather_rays", x, None);
    }
    // Renders to a stated error.
    for x in ["0.1", "0.05", "0.02", "0.01"] {
        push(Estimator::Analytic, "target_error", x, None);
    }
    for x in ["1", "2", "5", "10", "20", "40"] {
        push(Estimator::Analytic, "spectral_step_nm", x, line_variant);
    }
    for x in ["4", "64"] {
        push(Estimator::Analytic, "area_samples", x, None);
        push(Estimator::SolidAngle, "area_samples", x, None);
    }
    push(Estimator::Analytic, "occlusion", "ratio", None);
    for x in ["1", "2", "6"] {
        push(Estimator::Analytic, "recursion", x, None);
    }
    for (key, vals) in [
        ("SAMPLE_AREA_DENSITY", &["4", "16", "64"][..]),
        ("MAX_SAMPLE_POINTS", &["4", "2000"][..]),
        ("MAX_SOURCE_SAMPLES", &["25", "400"][..]),
        ("SOLID_ANGLE_DENSITY", &["250", "4000"][..]),
        ("SOLID_ANGLE_THRESHOLD", &["1e-8", "1e-3"][..]),
        ("IRRADIANCE_THRESHOLD", &["1e-12", "1e-2"][..]),
    ] {
        for x in vals {
            push(Estimator::Dirsig2001, key, x, None);
        }
    }
    v
}

/// A copy of `scene` whose emitters radiate clear mercury (lines on a
/// weak continuum) scaled to the same first-band radiance: the spectral
/// sweep's worst case when the scene's own sources are spectrally smooth.
fn mercury_variant(scene: &Scene) -> Option<Scene> {
    let hg = gloam_spectra::library::get("mercury-clear")?;
    let band = scene.bands.first()?;
    let mut s = scene.clone();
    for m in &mut s.materials {
        if let Some(e) = &mut m.emission {
            let want = e.radiance_w_m2_sr_nm.integrate_band(band.lo_nm, band.hi_nm);
            let have = hg.integrate_band(band.lo_nm, band.hi_nm);
            if have > 0.0 {
                e.radiance_w_m2_sr_nm = hg.scaled(want / have).ok()?;
            }
        }
    }
    Some(s)
}

fn has_lines(scene: &Scene) -> bool {
    scene.materials.iter().any(|m| {
        m.emission
            .as_ref()
            .is_some_and(|e| !e.radiance_w_m2_sr_nm.lines().is_empty())
    })
}

#[derive(Serialize)]
struct Summary {
    /// Energy-weighted metric (`rel_rms_error`).
    time_to_1pct_s: BTreeMap<String, Option<f64>>,
    time_to_0_1pct_s: BTreeMap<String, Option<f64>>,
    /// Per-pixel metric (`pixel_rms_error`).
    time_to_1pct_pixel_s: BTreeMap<String, Option<f64>>,
    time_to_0_1pct_pixel_s: BTreeMap<String, Option<f64>>,
    /// The `--target-error` rows: time, achieved per-pixel error, where the
    /// time went, and how well the error estimate held.
    target_error: Vec<serde_json::Value>,
    scene: String,
    truth: String,
    truth_seconds: f64,
    runs: usize,
    skipped_for_budget: usize,
    budget_s: f64,
    elapsed_s: f64,
    /// Lowest error each estimator's spp ladder reached, and at what time.
    best: BTreeMap<String, Option<(f64, f64)>>,
    effect_plan: Option<serde_json::Value>,
    /// What the `spectral_step_nm` rows were rendered on.
    spectral_sweep: String,
    csv: String,
    png: String,
    summary_md: String,
}

/// Time at which the estimator's spp ladder first reaches `target`,
/// interpolated log–log between the rungs that bracket it; the first rung's
/// time when it is already below (an upper bound); None if never.
fn time_to(rows: &[&Row], target: f64, metric: fn(&Row) -> f64) -> Option<f64> {
    let mut prev: Option<&Row> = None;
    for r in rows {
        if metric(r).is_finite() && metric(r) <= target {
            return Some(match prev {
                Some(p) if metric(p) > 0.0 && metric(r) > 0.0 && p.time_s > 0.0 => {
                    let (lt0, lt1) = (p.time_s.ln(), r.time_s.max(1e-12).ln());
                    let (le0, le1) = (metric(p).ln(), metric(r).ln());
                    if (le1 - le0).abs() < 1e-300 {
                        r.time_s
                    } else {
                        (lt0 + (target.ln() - le0) * (lt1 - lt0) / (le1 - le0)).exp()
                    }
                }
                _ => r.time_s,
            });
        }
        if metric(r).is_finite() {
            prev = Some(r);
        }
    }
    None
}

fn pareto(rows: &[Row]) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.rel_rms_error.is_finite() && r.time_s > 0.0 && r.estimator != "sensor")
        .map(|r| (r.time_s, r.rel_rms_error))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for p in pts {
        if p.1 < best {
            best = p.1;
            front.push(p);
        }
    }
    front
}

fn accuracy(args: AccuracyArgs) -> anyhow::Result<()> {
    let t_start = Instant::now();
    anyhow::ensure!(
        args.budget_s.is_finite() && args.budget_s > 0.0,
        "--budget-s must be a positive number of seconds"
    );
    let scene_path = find_path(&args.scene);
    let scene = gloam_scene::load(&scene_path)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let budget = args.budget_s;
    let elapsed = || t_start.elapsed().as_secs_f64();
    let base_tracer = Tracer::new(&scene, &with(Estimator::Analytic, args.threads, |_| {}))?;

    // Scenes: [0] the scene, [1] a line-spectrum variant for the spectral
    // sweep when the scene's own sources are smooth and the truth is exact.
    let obstacle = closed_form_obstacle(&scene);
    let mut scenes = vec![scene.clone()];
    let line_variant = if has_lines(&scene) {
        None
    } else if obstacle.is_none() {
        mercury_variant(&scene).map(|v| {
            scenes.push(v);
            1
        })
    } else {
        None
    };
    let mut truths = Vec::new();
    match &obstacle {
        None => {
            for s in &scenes {
                let t = Tracer::new(s, &with(Estimator::Analytic, args.threads, |_| {}))?;
                truths.push(closed_form_truth(s, &t));
            }
        }
        Some(_) => {
            // Reference spp: about a third of the budget, from a timed
            // pilot of the reference settings on 64 pixels (256 … 16384).
            let t0 = Instant::now();
            let probe = reference_settings(args.threads, 16);
            let t = Tracer::new(&scene, &probe)?;
            let (w, h) = (scene.camera.width, scene.camera.height);
            (0..64u32)
                .into_par_iter()
                .map(|k| t.probe_pixel((k * 37 + 5) % w, (k * 53 + 3) % h))
                .collect::<Result<Vec<_>, _>>()?;
            let per_sample_px = t0.elapsed().as_secs_f64().max(1e-3) / (64.0 * 16.0);
            let spp = ((0.35 * budget / (per_sample_px * REFERENCE_PIXELS as f64)) as u32)
                .clamp(256, 16384)
                / 2
                * 2;
            truths.push(reference_truth(
                &scene_path,
                &scene,
                &base_tracer,
                &args.out,
                args.threads,
                spp,
            )?);
        }
    }
    let truth_seconds: f64 = truths.iter().map(|t| t.seconds).sum();
    let mask_px = truths[0].mask.iter().filter(|&&m| m).count();
    anyhow::ensure!(
        mask_px > 0,
        "no pixel of {} sees a non-emitting surface: nothing to measure",
        scene_path.display()
    );

    let mut rows: Vec<Row> = Vec::new();
    // Time per spp unit, per estimator (predicts the next run's cost).
    let mut cost: BTreeMap<String, f64> = BTreeMap::new();
    // Runs only when `limit` (s since the start) is not predicted to pass.
    let mut exec = |plan: &Plan, rows: &mut Vec<Row>, limit: f64| -> anyhow::Result<bool> {
        let key = plan.estimator.to_string();
        let predicted = cost.get(&key).map_or(0.0, |c| c * plan.settings.spp as f64);
        if elapsed() + predicted > limit {
            return Ok(false);
        }
        let si = plan.scene.unwrap_or(0);
        let (s, truth) = (&scenes[si], &truths[si.min(truths.len() - 1)]);
        let t0 = Instant::now();
        let tracer = Tracer::new(s, &plan.settings)?;
        let prepare_s = t0.elapsed().as_secs_f64();
        let out = tracer.render(&|_, _| {})?;
        let dt = t0.elapsed().as_secs_f64();
        if plan.setting == "spp" {
            cost.insert(key.clone(), dt / plan.settings.spp as f64);
        }
        let e = errors(&out.radiance, truth);
        let (within_2x_target, within_2x_estimate) = match plan.settings.target_error {
            Some(target) => {
                let (a, b) = error_coverage(&out.radiance, &out.std_error, truth, target);
                (Some(a), Some(b))
            }
            None => (None, None),
        };
        rows.push(Row {
            estimator: key,
            setting: plan.setting.to_string(),
            value: plan.value.clone(),
            spp: out.spp.iter().map(|&n| n as u64).sum::<u64>() as u32
                / out.spp.len().max(1) as u32,
            time_s: dt,
            rel_rms_error: e.energy,
            max_rel_error: e.max_rel,
            pixel_rms_error: e.pixel,
            within_2x_target,
            within_2x_estimate,
            prepare_s,
        });
        Ok(true)
    };
    let ladder_plan = |est: Estimator, spp: u32| Plan {
        estimator: est,
        setting: "spp",
        value: spp.to_string(),
        settings: with(est, args.threads, |s| s.spp = spp),
        scene: None,
    };
    let others = other_plans(args.threads, line_variant);
    let planned = LADDER.len() * ESTIMATORS.len() + others.len() + 2;

    // 1. Each estimator's spp ladder, rung by rung across estimators, within
    //    60 % of the budget; an estimator whose next rung does not fit stops
    //    climbing.
    let mut next_rung = [0usize; 3];
    for (k, spp) in LADDER.iter().enumerate() {
        for (i, est) in ESTIMATORS.iter().enumerate() {
            if next_rung[i] == k && exec(&ladder_plan(*est, *spp), &mut rows, 0.6 * budget)? {
                next_rung[i] = k + 1;
            }
        }
    }
    // 2. The other settings at the default spp.
    for plan in &others {
        exec(plan, &mut rows, budget)?;
    }
    // 3. Sensor noise on/off (the camera chain on the default render).
    if elapsed() < budget {
        rows.extend(sensor_noise_rows(&scene, args.threads, &truths[0])?);
    }
    // 4. The rest of the ladders with what is left.
    for (k, spp) in LADDER.iter().enumerate() {
        for (i, est) in ESTIMATORS.iter().enumerate() {
            if next_rung[i] == k && exec(&ladder_plan(*est, *spp), &mut rows, budget)? {
                next_rung[i] = k + 1;
            }
        }
    }
    let skipped = planned.saturating_sub(rows.len());
    // 5. The effect plan against every effect forced on.
    let effect_plan = if args.all_effects {
        Some(effect_plan_saving(&scenes[0], args.threads, &truths[0])?)
    } else {
        None
    };

    // Outputs.
    let csv_path = args.out.join("accuracy.csv");
    let mut csv = String::from(
        "estimator,setting,value,spp,time_s,rel_rms_error,max_rel_error,pixel_rms_error,prepare_s\n",
    );
    for r in &rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{:.6},{:.6e},{:.6e},{:.6e},{:.6}",
            r.estimator,
            r.setting,
            r.value,
            r.spp,
            r.time_s,
            r.rel_rms_error,
            r.max_rel_error,
            r.pixel_rms_error,
            r.prepare_s
        );
    }
    write_atomic(&csv_path, csv.as_bytes())?;

    let ladder = |est: &str| -> Vec<&Row> {
        rows.iter()
            .filter(|r| r.estimator == est && r.setting == "spp")
            .collect()
    };
    let mut t1 = BTreeMap::new();
    let mut t01 = BTreeMap::new();
    let mut p1 = BTreeMap::new();
    let mut p01 = BTreeMap::new();
    let mut best = BTreeMap::new();
    for est in ESTIMATORS {
        let name = est.to_string();
        let l = ladder(&name);
        t1.insert(name.clone(), time_to(&l, 0.01, |r| r.rel_rms_error));
        t01.insert(name.clone(), time_to(&l, 0.001, |r| r.rel_rms_error));
        p1.insert(name.clone(), time_to(&l, 0.01, |r| r.pixel_rms_error));
        p01.insert(name.clone(), time_to(&l, 0.001, |r| r.pixel_rms_error));
        best.insert(
            name,
            l.iter()
                .filter(|r| r.rel_rms_error.is_finite())
                .min_by(|a, b| a.rel_rms_error.total_cmp(&b.rel_rms_error))
                .map(|r| (r.rel_rms_error, r.time_s)),
        );
    }

    let png_path = args.out.join("accuracy.png");
    plot(&png_path, &scene_path, &rows)?;

    let md_path = args.out.join("summary.md");
    let summary = Summary {
        time_to_1pct_s: t1,
        time_to_0_1pct_s: t01,
        time_to_1pct_pixel_s: p1,
        time_to_0_1pct_pixel_s: p01,
        target_error: rows
            .iter()
            .filter(|r| r.setting == "target_error")
            .map(|r| {
                serde_json::json!({
                    "target": r.value.parse::<f64>().ok(),
                    "time_s": r.time_s,
                    "prepare_s": r.prepare_s,
                    "sampling_s": r.time_s - r.prepare_s,
                    "mean_spp": r.spp,
                    "pixel_rms_error": r.pixel_rms_error,
                    "rel_rms_error": r.rel_rms_error,
                    "within_2x_target": r.within_2x_target,
                    "within_2x_estimate": r.within_2x_estimate,
                    "goal_s_at_0_01": 18.0,
                    "mitsuba3_multijitter_s_at_0_01": 91.0,
                })
            })
            .collect(),
        scene: scene_path.display().to_string(),
        truth: truths[0].note.clone(),
        truth_seconds,
        runs: rows.len(),
        skipped_for_budget: skipped,
        budget_s: budget,
        elapsed_s: elapsed(),
        best,
        effect_plan,
        spectral_sweep: if line_variant.is_some() {
            "a copy of the scene with its emitters radiating clear mercury (lines), same first-band radiance".into()
        } else {
            "the scene itself".into()
        },
        csv: csv_path.display().to_string(),
        png: png_path.display().to_string(),
        summary_md: md_path.display().to_string(),
    };
    write_atomic(
        &md_path,
        summary_markdown(&summary, &rows, truths[0].kind, mask_px).as_bytes(),
    )?;
    if args.json {
        print_json(&summary)?;
    } else {
        print!(
            "{}",
            summary_markdown(&summary, &rows, truths[0].kind, mask_px)
        );
    }
    Ok(())
}

/// Sensor noise on/off: the Gen III ICCD chain on the default render scaled
/// to starlight (5 pe/pixel/frame at the brightest counted pixel). The
/// error is that of the frame against the noise-free frame, relative to
/// the mean signal above black.
fn sensor_noise_rows(
    scene: &Scene,
    threads: Option<usize>,
    truth: &Truth,
) -> anyhow::Result<Vec<Row>> {
    let out =
        Tracer::new(scene, &with(Estimator::Analytic, threads, |_| {}))?.render(&|_, _| {})?;
    let img = out.radiance.index_axis(Axis(0), 0);
    let max = img
        .indexed_iter()
        .filter(|(ix, _)| truth.mask[*ix])
        .map(|(_, &v)| v)
        .fold(0.0, f64::max)
        .max(1e-300);
    // (The analytic estimator's control variate can leave a pixel slightly
    // negative in penumbra; the sensor takes no negative input.)
    let pe = img.mapv(|v| (v / max * 5.0).clamp(0.0, 50.0));
    let mut frames = Vec::new();
    let mut times = Vec::new();
    for noise in [false, true] {
        let mut cam = gloam_sensor::Camera::from_preset_or_file("gen3-gaas-iccd")?;
        cam.set_override_gain(Some(30.0))?;
        cam.set_noise(noise);
        let t0 = Instant::now();
        let f = cam.capture_photoelectrons(pe.view())?;
        times.push(t0.elapsed().as_secs_f64());
        let black = cam.chain().black_dn(30.0);
        frames.push((f, black));
    }
    let (clean, black) = &frames[0];
    let (noisy, _) = &frames[1];
    let mut se = 0.0;
    let mut sig = 0.0;
    let mut max_rel: f64 = 0.0;
    let mut n = 0usize;
    for ((ix, &m), (&a, &b)) in truth
        .mask
        .indexed_iter()
        .zip(clean.pixels.iter().zip(noisy.pixels.iter()))
    {
        let _ = ix;
        if !m {
            continue;
        }
        let s = a as f64 - black;
        se += (b as f64 - a as f64).powi(2);
        sig += s;
        n += 1;
        if s > 1.0 {
            max_rel = max_rel.max((b as f64 - a as f64).abs() / s);
        }
    }
    let mean_sig = (sig / n.max(1) as f64).max(1e-300);
    let rms = (se / n.max(1) as f64).sqrt() / mean_sig;
    Ok(vec![
        Row {
            estimator: "sensor".into(),
            setting: "noise".into(),
            value: "off".into(),
            spp: out.settings.spp,
            time_s: times[0],
            rel_rms_error: 0.0,
            max_rel_error: 0.0,
            pixel_rms_error: 0.0,
            within_2x_target: None,
            within_2x_estimate: None,
            prepare_s: 0.0,
        },
        Row {
            estimator: "sensor".into(),
            setting: "noise".into(),
            value: "on".into(),
            spp: out.settings.spp,
            time_s: times[1],
            rel_rms_error: rms,
            max_rel_error: max_rel,
            pixel_rms_error: rms,
            within_2x_target: None,
            within_2x_estimate: None,
            prepare_s: 0.0,
        },
    ])
}

/// Renders with the effect plan and with every effect forced on (the
/// tracer's `all_effects` setting), checks that the images agree
/// within noise and reports the time the plan saves.
fn effect_plan_saving(
    scene: &Scene,
    threads: Option<usize>,
    truth: &Truth,
) -> anyhow::Result<serde_json::Value> {
    let plan = with(Estimator::Analytic, threads, |_| {});
    let mut forced = plan.clone();
    if let Err(e) = forced.set("all_effects", "true") {
        return Ok(serde_json::json!({
            "available": false,
            "reason": format!("gloam-trace has no setting to force every effect on ({e})"),
        }));
    }
    let t0 = Instant::now();
    let a = Tracer::new(scene, &plan)?.render(&|_, _| {})?;
    let ta = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let b = Tracer::new(scene, &forced)?.render(&|_, _| {})?;
    let tb = t0.elapsed().as_secs_f64();
    let ea = errors(&a.radiance, truth).energy;
    let eb = errors(&b.radiance, truth).energy;
    // Agreement: the two renders differ by no more than their own errors
    // (3× the larger, plus 1e-9 for exact renders).
    let diff = {
        let t = Truth {
            kind: "plan",
            image: a.radiance.clone(),
            mask: truth.mask.clone(),
            noise_var: None,
            seconds: 0.0,
            note: String::new(),
        };
        errors(&b.radiance, &t).energy
    };
    let agree = diff <= 3.0 * ea.max(eb) * std::f64::consts::SQRT_2 + 1e-9;
    Ok(serde_json::json!({
        "available": true,
        "plan_s": ta,
        "all_effects_s": tb,
        "saved_s": tb - ta,
        "saved_fraction": 1.0 - ta / tb.max(1e-12),
        "rel_rms_difference": diff,
        "rel_rms_error_plan": ea,
        "rel_rms_error_all_effects": eb,
        "agree_within_noise": agree,
    }))
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or("not reached".into(), |t| format!("{t:.3} s"))
}

fn summary_markdown(s: &Summary, rows: &[Row], truth_kind: &str, mask_px: usize) -> String {
    let mut m = String::new();
    let _ = writeln!(m, "# Accuracy against time: `{}`\n", s.scene);
    let _ = writeln!(
        m,
        "Truth: {} ({truth_kind}; {:.1} s). Error over {mask_px} pixels that see non-emitting surfaces: \
         `rel_rms = sqrt(Σ(x−t)²/Σt²)`, `max_rel` over pixels above 1 % of the band mean. \
         {} runs in {:.1} s of a {:.0} s budget ({} skipped for the budget).\n",
        s.truth, s.truth_seconds, s.runs, s.elapsed_s, s.budget_s, s.skipped_for_budget
    );
    let _ = writeln!(
        m,
        "## Time to reach an RMS error (spp ladder, log–log interpolation)\n"
    );
    let _ = writeln!(
        m,
        "| estimator | 1 % energy | 0.1 % energy | 1 % per pixel | 0.1 % per pixel | lowest rel RMS error (at time) |"
    );
    let _ = writeln!(m, "|---|---|---|---|---|---|");
    for est in ESTIMATORS {
        let e = est.to_string();
        let best = s.best.get(&e).copied().flatten();
        let _ = writeln!(
            m,
            "| {e} | {} | {} | {} | {} | {} |",
            fmt_opt(s.time_to_1pct_s.get(&e).copied().flatten()),
            fmt_opt(s.time_to_0_1pct_s.get(&e).copied().flatten()),
            fmt_opt(s.time_to_1pct_pixel_s.get(&e).copied().flatten()),
            fmt_opt(s.time_to_0_1pct_pixel_s.get(&e).copied().flatten()),
            best.map_or("–".into(), |(err, t)| format!("{err:.3e} ({t:.3} s)"))
        );
    }
    if !s.target_error.is_empty() {
        let _ = writeln!(
            m,
            "\n## Renders to a stated error (`--target-error`)\n\n\
             | target | time (s) | of which prepare (s) | mean spp | per-pixel RMS error | energy RMS error | within 2× target | within 2× own estimate |\n|---|---|---|---|---|---|---|---|"
        );
        for t in &s.target_error {
            let f = |k: &str| t[k].as_f64().unwrap_or(f64::NAN);
            let _ = writeln!(
                m,
                "| {} | {:.2} | {:.2} | {} | {:.3e} | {:.3e} | {:.1} % | {:.1} % |",
                f("target"),
                f("time_s"),
                f("prepare_s"),
                t["mean_spp"],
                f("pixel_rms_error"),
                f("rel_rms_error"),
                100.0 * f("within_2x_target"),
                100.0 * f("within_2x_estimate")
            );
        }
        let _ = writeln!(
            m,
            "\nGoal at 0.01 on the office room, 2 threads: ≤ 18 s (Mitsuba 3 multijitter: ~91 s)."
        );
    }
    let a = s.time_to_1pct_s.get("analytic").copied().flatten();
    let d = s.time_to_1pct_s.get("dirsig2001").copied().flatten();
    let _ = writeln!(
        m,
        "\n1 % RMS: analytic (default) vs dirsig2001 at its defaults: {}\n",
        match (a, d) {
            (Some(a), Some(d)) => format!("{:.1}× faster", d / a),
            (Some(_), None) => "dirsig2001 never reached 1 % within its spp ladder/budget".into(),
            _ => "analytic did not reach 1 %".into(),
        }
    );
    if let Some(p) = &s.effect_plan {
        let _ = writeln!(
            m,
            "## Effect plan\n\n```json\n{}\n```\n",
            serde_json::to_string_pretty(p).unwrap_or_default()
        );
    }
    let _ = writeln!(m, "## All runs\n");
    let _ = writeln!(
        m,
        "| estimator | setting | value | spp | time (s) | rel RMS error | per-pixel RMS error | max rel error |"
    );
    let _ = writeln!(m, "|---|---|---|---|---|---|---|---|");
    for r in rows {
        let _ = writeln!(
            m,
            "| {} | {} | {} | {} | {:.3} | {:.3e} | {:.3e} | {:.3e} |",
            r.estimator,
            r.setting,
            r.value,
            r.spp,
            r.time_s,
            r.rel_rms_error,
            r.pixel_rms_error,
            r.max_rel_error
        );
    }
    let _ = writeln!(m, "\nFiles: `{}`, `{}`.", s.csv, s.png);
    m
}

/// Error against time, log–log, one curve per estimator's spp ladder, the
/// other settings as points, the Pareto front marked.
fn plot(path: &Path, scene: &Path, rows: &[Row]) -> anyhow::Result<()> {
    use gloam_calib::plot::{Mark, Scale, Series, xy_plot_scaled};
    // An exact result (error 0) is drawn at 1e-9 rather than dropped.
    let lg = |r: &Row| (r.time_s.max(1e-6), r.rel_rms_error.max(1e-9));
    let mut series = Vec::new();
    for est in ESTIMATORS {
        let e = est.to_string();
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.estimator == e && r.setting == "spp" && r.rel_rms_error.is_finite())
            .map(lg)
            .collect();
        if !pts.is_empty() {
            series.push(Series::new(
                &format!("{e} (spp ladder)"),
                pts,
                Mark::LinePoints,
            ));
        }
    }
    let others: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.setting != "spp" && r.estimator != "sensor" && r.rel_rms_error.is_finite())
        .map(lg)
        .collect();
    if !others.is_empty() {
        series.push(Series::new("other settings", others, Mark::Points));
    }
    let front: Vec<(f64, f64)> = pareto(rows)
        .into_iter()
        .map(|(t, e)| (t.max(1e-6), e.max(1e-9)))
        .collect();
    if !front.is_empty() {
        series.push(Series::new("Pareto front", front, Mark::Line));
    }
    let name = scene
        .parent()
        .and_then(|p| p.file_name())
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| scene.display().to_string());
    xy_plot_scaled(
        path,
        &format!("accuracy vs time: {name}"),
        ("wall time (s)", Scale::Log10),
        ("relative RMS error", Scale::Log10),
        &series,
    )
    .map_err(|e| anyhow::anyhow!("{e}"))
    .with_context(|| format!("writing {}", path.display()))
}
