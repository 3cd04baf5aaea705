//! `gloam bench scale`: how preparation time, peak memory, ray throughput
//! and the time to a 1 % image grow with the number of triangles and of
//! lamps.
//!
//! Two families of scenes are generated here, in Rust, into a scratch
//! directory (a `scene.toml` and OBJ files) and read back with the scene
//! crate's own loader, so the count checks cover the real path:
//!
//! - **triangles** `N`: a 20 × 20 × 5 m room (an inward box, 6 quads) lit
//!   by 4 ceiling panels (emitting quads), with `k = ⌈N / 4096⌉` UV spheres
//!   on the floor, each of `n` latitude bands and `2n` longitude segments
//!   (`4 n (n − 1)` triangles; `n` the nearest to `N / k`, at least 3).
//!   Triangles in the BVH: `12 + 8 + k · 4 n (n − 1)`
//!   ([`expected_counts`]).
//! - **lamps** `N`: a ground quad under a `⌈√N⌉`-wide grid of `N` shaped
//!   point sources (`cos²` about straight down, 6 m up, 10 m apart, a flat
//!   spectrum of 20 W sr⁻¹ over 400–700 nm) and beside each an emitting
//!   quad (0.6 × 0.3 m, facing down, 6.05 m up, 20 W m⁻² sr⁻¹): `N + 1`
//!   facets, `2 (N + 1)` triangles, `N` emitting facets. The camera looks
//!   straight down from 3 m at the middle of the grid, so every pixel sees
//!   the unoccluded ground and its band radiance has a closed form,
//!   `ρ/π (Σ I cos^m α cos θ / d² + Σ L F)` ([`lamp_grid_radiance`]).
//! - **instances** `N`: `N` shared placements of one 49 728-triangle model
//!   over a ground quad under nine lamps (`scale_instances.rs`): the
//!   two-level BVH's placement count costs bytes, not triangles.
//!
//! **Per case** a fresh child process of the gloam binary (`gloam bench
//! scale --case KIND:N`, hidden) generates, loads, prepares (`Tracer::new`:
//! BVH, effect-plan pilot, radiosity cache) and renders at a fixed spp, and
//! prints one JSON object. The parent kills a case that outlives
//! `--timeout-s` and records it as `timeout`. Figures:
//!
//! - `prepare_s`: the tracer's `prepare_seconds` (BVH, pilot, cache);
//!   `generate_s` and `load_s` are reported apart;
//! - `peak_rss_bytes`: the child's `VmHWM` (peak resident set) from
//!   `/proc/self/status`, read after the render; `prepare_peak_rss_bytes`
//!   the same read right after preparation (Linux; `null` elsewhere);
//! - `rays_per_s`: all rays traced (primary, shadow, secondary) per second
//!   of trace time;
//! - `time_to_1pct_s`: the render reports each pixel's standard error; with
//!   `e` the RMS over pixels of the relative standard error
//!   (`ErrorSummary::rel_std_error_rms`) at the fixed spp, and the error
//!   falling as 1/√samples, the time to bring it to 1 % is
//!   `prepare_s + trace_s · max(1, spp (e / 0.01)²) / spp` (at least one
//!   sample per pixel: the lamp grid is exact at any spp).
//!
//! **Mitsuba 3** (optional): where `python3 -c 'import mitsuba'` works,
//! `scale_mitsuba.py` renders each case's generated scene too (load,
//! render, peak RSS), under the same timeout, also when gloam's side timed
//! out; never required.
//!
//! **Size checks**: sizes must lie within 1 … 10⁷ triangles and 1 … 10⁵
//! lamps; a case whose estimated peak memory exceeds the machine's
//! `MemAvailable` is skipped (`too_large`); and the child fails unless the
//! loaded scene's triangle, facet, point-source and emitter counts equal the
//! generator's closed form.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use gloam_trace::prep::peak_rss_bytes;

use super::BenchError;
use super::child::{mitsuba_importable, run_mitsuba_script, stderr_tail, wait_with_timeout};
use gloam_trace::{DVec3, RenderSettings, Tracer};
use serde::{Deserialize, Serialize};

/// Largest accepted triangle count (the size check).
pub const MAX_TRIANGLES: u64 = 10_000_000;
/// Largest accepted lamp count (the size check).
pub const MAX_LAMPS: u64 = 100_000;
/// The default sizes.
pub const DEFAULT_TRIANGLES: [u64; 4] = [1_000, 10_000, 100_000, 1_000_000];
pub const DEFAULT_LAMPS: [u64; 5] = [1, 10, 100, 1_000, 10_000];
/// `--quick` sizes: small enough to run in seconds (and below the 2 048
/// facets the radiosity cache handles today).
pub const QUICK_TRIANGLES: [u64; 1] = [1_000];
pub const QUICK_LAMPS: [u64; 3] = [1, 10, 100];
/// Placements of the instances family (2 012 × 49 728 ≈ 10⁸ triangles);
/// `--quick` runs none.
pub const DEFAULT_INSTANCES: [u64; 3] = [10, 1_000, 2_012];
pub use super::scale_instances::{MAX_PLACEMENTS, TREE_TRIANGLES};

/// Lamp-grid constants (see the module docs).
const LAMP_HEIGHT: f64 = 6.0;
const LAMP_PITCH: f64 = 10.0;
const LAMP_M: f64 = 2.0;
const LAMP_W_SR: f64 = 20.0;
const PANEL_HEIGHT: f64 = 6.05;
const PANEL_SIZE: [f64; 2] = [0.6, 0.3];
const PANEL_OFFSET: f64 = 1.0;
const PANEL_L: f64 = 20.0;
const GROUND_RHO: f64 = 0.5;
const CAMERA_HEIGHT: f64 = 3.0;
const CAMERA_FOV_DEG: f64 = 60.0;

/// Which family a case belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    Triangles,
    Lamps,
    Instances,
}

impl Kind {
    pub fn as_str(self) -> &'static str {
        match self {
            Kind::Triangles => "triangles",
            Kind::Lamps => "lamps",
            Kind::Instances => "instances",
        }
    }
}

/// One case: a family and its size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Case {
    pub kind: Kind,
    pub size: u64,
}

impl Case {
    /// `triangles:N` or `lamps:N` (N may be written `1e4`).
    pub fn parse(s: &str) -> Result<Case, BenchError> {
        let (k, n) = s.split_once(':').ok_or_else(|| {
            BenchError::Invalid(format!(
                "--case {s:?}: expected KIND:N, e.g. triangles:1000"
            ))
        })?;
        let kind = match k {
            "triangles" => Kind::Triangles,
            "lamps" => Kind::Lamps,
            "instances" => Kind::Instances,
            _ => {
                return Err(BenchError::Invalid(format!(
                    "--case {s:?}: the kind must be `triangles`, `lamps` or `instances`"
                )));
            }
        };
        let case = Case {
            kind,
            size: parse_count(n).map_err(|e| BenchError::Invalid(format!("--case {s:?}: {e}")))?,
        };
        case.check()?;
        Ok(case)
    }

    /// The size check: within 1 … the family's maximum.
    pub fn check(&self) -> Result<(), BenchError> {
        let max = match self.kind {
            Kind::Triangles => MAX_TRIANGLES,
            Kind::Lamps => MAX_LAMPS,
            Kind::Instances => MAX_PLACEMENTS,
        };
        ensure_valid!(
            (1..=max).contains(&self.size),
            "{} {}: must be within 1 … {max}",
            self.kind.as_str(),
            self.size
        );
        Ok(())
    }

    pub fn label(&self) -> String {
        format!("{}:{}", self.kind.as_str(), self.size)
    }
}

/// A count such as `1000`, `1e4` or `2.5e3` (a whole number ≥ 1).
pub fn parse_count(s: &str) -> Result<u64, BenchError> {
    let t = s.trim();
    let v: f64 = t.parse().map_err(|_| {
        BenchError::Invalid(format!("{t:?} is not a number (write e.g. 1000 or 1e4)"))
    })?;
    ensure_valid!(
        v >= 1.0 && v.is_finite() && v.fract() == 0.0,
        "{t:?}: a count must be a whole number ≥ 1"
    );
    // Past 1e12 it is no count a case can have (and past 2^64 not a u64):
    // named as too large, not as a fraction.
    ensure_valid!(
        (..=1e12).contains(&v),
        "{t:?}: too large a count (at most 1e12)"
    );
    Ok(v as u64)
}

/// A comma-separated list of counts (`1e3,1e4`), each checked against `max`.
pub fn parse_counts(s: &str, what: &str, max: u64) -> Result<Vec<u64>, BenchError> {
    let mut v: Vec<u64> = Vec::new();
    ensure_valid!(!s.trim().is_empty(), "--{what}: no sizes given");
    for (k, part) in s.split(',').enumerate().take(1000) {
        // An empty item (`1e3,,1e4`, a trailing comma) was dropped unseen.
        ensure_valid!(
            !part.trim().is_empty(),
            "--{what} {s:?}: item {} is empty",
            k + 1
        );
        let n = parse_count(part).map_err(|e| BenchError::Invalid(format!("--{what}: {e}")))?;
        ensure_valid!(n <= max, "--{what}: {n} exceeds the largest size, {max}");
        // The same size twice ran the same case twice, as two rows.
        ensure_valid!(
            !v.contains(&n),
            "--{what} {s:?}: {n} is given twice (each size is one case)"
        );
        v.push(n);
    }
    ensure_valid!(v.len() <= 32, "--{what}: at most 32 sizes");
    Ok(v)
}

/// What a case's generator makes, in closed form.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counts {
    /// Triangles in the BVH (a quad is two).
    pub triangles: u64,
    pub facets: u64,
    pub point_sources: u64,
    pub emitting_facets: u64,
    /// Triangles placed through shared instances (not in the BVH's own
    /// count: one prototype serves them all).
    #[serde(default)]
    pub placed_triangles: u64,
}

/// Sphere layout for a triangle target: (spheres, latitude bands).
fn sphere_plan(n: u64) -> (u64, u64) {
    let k = n.div_ceil(4096).max(1);
    let per = n as f64 / k as f64;
    // 4 b (b − 1) = per  →  b = (1 + √(1 + per)) / 2.
    let b = ((1.0 + (1.0 + per).sqrt()) / 2.0).round().max(3.0) as u64;
    (k, b)
}

/// The generator's counts for `case`, in closed form.
pub fn expected_counts(case: Case) -> Counts {
    match case.kind {
        Kind::Triangles => {
            let (k, b) = sphere_plan(case.size);
            let sphere = k * 4 * b * (b - 1);
            Counts {
                triangles: 12 + 8 + sphere,
                facets: 6 + 4 + sphere,
                point_sources: 0,
                emitting_facets: 4,
                placed_triangles: 0,
            }
        }
        Kind::Lamps => Counts {
            triangles: 2 * (case.size + 1),
            facets: case.size + 1,
            point_sources: case.size,
            emitting_facets: case.size,
            placed_triangles: 0,
        },
        Kind::Instances => Counts {
            triangles: 2,
            facets: 1,
            point_sources: 9,
            emitting_facets: 0,
            placed_triangles: case.size * TREE_TRIANGLES,
        },
    }
}

/// Rough peak memory of a case, bytes (for the `MemAvailable` check):
/// measured ~1 kB per triangle through loading and BVH, plus a base.
pub fn estimated_peak_bytes(case: Case) -> u64 {
    let c = expected_counts(case);
    let shared = if c.placed_triangles > 0 {
        1_500 * TREE_TRIANGLES + 1_000 * case.size
    } else {
        0
    };
    200_000_000 + 1_500 * c.triangles + 4_000 * c.point_sources + shared
}

/// Lamp grid: lamp positions (the panels sit `PANEL_OFFSET` east of each).
fn lamp_positions(n: u64) -> Vec<DVec3> {
    let side = (n as f64).sqrt().ceil() as u64;
    let half = (side as f64 - 1.0) / 2.0;
    (0..n)
        .map(|i| {
            let (r, c) = (i / side, i % side);
            DVec3::new(
                (c as f64 - half) * LAMP_PITCH,
                (r as f64 - half) * LAMP_PITCH,
                LAMP_HEIGHT,
            )
        })
        .collect()
}

fn panel_vertices(lamp: DVec3) -> [DVec3; 4] {
    let c = DVec3::new(lamp.x + PANEL_OFFSET, lamp.y, PANEL_HEIGHT);
    let (a, b) = (PANEL_SIZE[0] / 2.0, PANEL_SIZE[1] / 2.0);
    // Counter-clockwise seen from below (normal −z).
    [
        c + DVec3::new(-a, -b, 0.0),
        c + DVec3::new(-a, b, 0.0),
        c + DVec3::new(a, b, 0.0),
        c + DVec3::new(a, -b, 0.0),
    ]
}

/// Refuses, before any case runs, an `--out` whose `scale.json` or
/// `scale.png` the bench did not write: it replaces only a previous
/// bench's report (a `scale.json` holding its `method` and `cases`, and the
/// `scale.png` beside such a report), never a user's file of that name.
fn refuse_foreign_outputs(out: &Path) -> Result<(), BenchError> {
    let json = out.join("scale.json");
    let png = out.join("scale.png");
    let ours = |p: &Path| -> bool {
        std::fs::symlink_metadata(p).is_ok_and(|m| m.is_file())
            && gloam_io::read_text(p, gloam_io::MAX_TEXT_FILE_BYTES, &crate::unlisted())
                .ok()
                .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
                .is_some_and(|v| v.get("method").is_some() && v.get("cases").is_some())
    };
    let json_exists = std::fs::symlink_metadata(&json).is_ok();
    let png_exists = std::fs::symlink_metadata(&png).is_ok();
    if (json_exists || png_exists) && !ours(&json) {
        let what = if json_exists {
            format!(
                "{} exists and is not a report `gloam bench scale` wrote",
                json.display()
            )
        } else {
            format!(
                "{} exists without a report of `gloam bench scale` (scale.json) beside it",
                png.display()
            )
        };
        return Err(BenchError::Invalid(format!(
            "--out {}: {what}; the bench replaces only its own scale.json and scale.png — remove it or choose another --out",
            out.display()
        )));
    }
    if png_exists && !std::fs::symlink_metadata(&png).is_ok_and(|m| m.is_file()) {
        return Err(BenchError::Invalid(format!(
            "--out {}: {} is not a regular file; the bench replaces only its own scale.png",
            out.display(),
            png.display()
        )));
    }
    Ok(())
}

/// Writes the case's scene into `dir` and returns the `scene.toml` path.
pub fn generate(case: Case, dir: &Path, width: u32, height: u32) -> Result<PathBuf, BenchError> {
    case.check()?;
    // A new directory only: the case writes scene.toml and OBJ files into
    // it, and nothing the bench did not create is replaced.
    std::fs::create_dir(dir).map_err(|e| {
        if e.kind() == std::io::ErrorKind::AlreadyExists {
            BenchError::Invalid(format!(
                "{}: already exists; a bench case writes its generated scene into a new directory only",
                dir.display()
            ))
        } else {
            BenchError::io("creating", dir)(e)
        }
    })?;
    let mut toml = String::new();
    let _ = writeln!(
        toml,
        "# gloam bench scale: {} (generated; see crates/bench/src/scale.rs)\nunits = \"m\"\n",
        case.label()
    );
    match case.kind {
        Kind::Triangles => {
            let (k, b) = sphere_plan(case.size);
            let _ = writeln!(
                toml,
                "[camera]\nposition = [1.0, 1.0, 3.5]\nlook_at = [10.0, 10.0, 0.5]\nfov_deg = 70.0\nwidth = {width}\nheight = {height}\n\n\
                 [bands.visible]\nlo_nm = 400\nhi_nm = 700\n\n\
                 [materials.wall]\nreflectance = 0.6\n[materials.grey]\nreflectance = 0.5\n\
                 [materials.panel]\nemission = {{ value = 1.0, normalize = {{ lo_nm = 400, hi_nm = 700, value = 15.0 }} }}\n\n\
                 [objects.room]\nmaterial = \"wall\"\nbox = {{ min = [0.0, 0.0, 0.0], max = [20.0, 20.0, 5.0], inward = true }}\n"
            );
            for (i, (x, y)) in [(6.0, 6.0), (14.0, 6.0), (6.0, 14.0), (14.0, 14.0)]
                .iter()
                .enumerate()
            {
                let _ = writeln!(
                    toml,
                    "[objects.panel-{i}]\nmaterial = \"panel\"\nquad = {{ center = [{x}, {y}, 4.99], size = [1.2, 0.6], normal = [0.0, 0.0, -1.0] }}"
                );
            }
            let _ = writeln!(
                toml,
                "\n[objects.spheres]   # {k} spheres of {b} bands\nmaterial = \"grey\"\nobj = \"spheres.obj\""
            );
            let spheres = dir.join("spheres.obj");
            write_spheres(&spheres, k, b).map_err(BenchError::io("writing", &spheres))?;
        }
        Kind::Instances => {
            super::scale_instances::generate(case.size, dir, width, height, &mut toml)?;
        }
        Kind::Lamps => {
            let lamps = lamp_positions(case.size);
            let side = (case.size as f64).sqrt().ceil();
            let ground = side * LAMP_PITCH + 40.0;
            let _ = writeln!(
                toml,
                "[camera]   # straight down over the middle of the grid\nposition = [0.0, 0.0, {CAMERA_HEIGHT}]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\nfov_deg = {CAMERA_FOV_DEG}\nwidth = {width}\nheight = {height}\n\n\
                 [bands.visible]\nlo_nm = 400\nhi_nm = 700\n\n\
                 [materials.ground]\nreflectance = {GROUND_RHO}\n\
                 [materials.panel]\nemission = {{ value = 1.0, normalize = {{ lo_nm = 400, hi_nm = 700, value = {PANEL_L} }} }}\n\n\
                 [objects.ground]\nmaterial = \"ground\"\nquad = {{ center = [0.0, 0.0, 0.0], size = [{ground}, {ground}], normal = [0.0, 0.0, 1.0] }}\n\
                 [objects.panels]\nmaterial = \"panel\"\nobj = \"panels.obj\"\n"
            );
            let panels = dir.join("panels.obj");
            let write_panels = || -> std::io::Result<()> {
                let mut obj = std::io::BufWriter::new(std::fs::File::create(&panels)?);
                for l in &lamps {
                    for v in panel_vertices(*l) {
                        writeln!(obj, "v {} {} {}", v.x, v.y, v.z)?;
                    }
                }
                for i in 0..lamps.len() {
                    let k = 4 * i + 1;
                    writeln!(obj, "f {} {} {} {}", k, k + 1, k + 2, k + 3)?;
                }
                obj.flush()
            };
            write_panels().map_err(BenchError::io("writing", &panels))?;
            for (i, l) in lamps.iter().enumerate() {
                let _ = writeln!(
                    toml,
                    "[point_sources.lamp-{i}]\nposition = [{}, {}, {}]\nshape_exponent = {LAMP_M}\nvalue = 1.0\nnormalize = {{ lo_nm = 400, hi_nm = 700, value = {LAMP_W_SR} }}",
                    l.x, l.y, l.z
                );
            }
        }
    }
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).map_err(BenchError::io("writing", &path))?;
    Ok(path)
}

/// `k` UV spheres of `b` latitude bands and `2b` segments, as triangles,
/// on a square grid over the room's floor.
fn write_spheres(path: &Path, k: u64, b: u64) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    let side = (k as f64).sqrt().ceil() as u64;
    let spacing = 16.0 / side as f64;
    let r = 0.35 * spacing;
    let per_sphere_vertices = 2 + (b - 1) * 2 * b;
    for s in 0..k {
        let cx = 2.0 + spacing * ((s % side) as f64 + 0.5);
        let cy = 2.0 + spacing * ((s / side) as f64 + 0.5);
        write_uv_sphere(
            &mut w,
            DVec3::new(cx, cy, r),
            r,
            b,
            1 + s * per_sphere_vertices,
        )?;
    }
    w.flush()
}

/// One UV sphere (centre `c`, radius `r`, `b` latitude bands and `2b`
/// segments: `2 + (b − 1)·2b` vertices, `4 b (b − 1)` outward triangles)
/// as OBJ lines, its first vertex numbered `base` (OBJ counts from 1).
pub(super) fn write_uv_sphere(
    w: &mut impl std::io::Write,
    c: DVec3,
    r: f64,
    b: u64,
    base: u64,
) -> std::io::Result<()> {
    let segs = 2 * b;
    let per_sphere_vertices = 2 + (b - 1) * segs;
    // Vertices: south pole, rings 1..b−1, north pole.
    let mut vert = |p: DVec3| writeln!(w, "v {:.6} {:.6} {:.6}", p.x, p.y, p.z);
    vert(c - DVec3::Z * r)?;
    for i in 1..b {
        let th = std::f64::consts::PI * i as f64 / b as f64;
        for j in 0..segs {
            let ph = std::f64::consts::TAU * j as f64 / segs as f64;
            vert(c + r * DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), -th.cos()))?;
        }
    }
    vert(c + DVec3::Z * r)?;
    let ring = |i: u64, j: u64| base + 1 + (i - 1) * segs + (j % segs);
    let (south, north) = (base, base + per_sphere_vertices - 1);
    for j in 0..segs {
        // Outward, counter-clockwise seen from outside.
        writeln!(w, "f {} {} {}", south, ring(1, j + 1), ring(1, j))?;
        writeln!(w, "f {} {} {}", north, ring(b - 1, j), ring(b - 1, j + 1))?;
    }
    for i in 1..b - 1 {
        for j in 0..segs {
            let (a0, a1) = (ring(i, j), ring(i, j + 1));
            let (b0, b1) = (ring(i + 1, j), ring(i + 1, j + 1));
            writeln!(w, "f {a0} {a1} {b1}")?;
            writeln!(w, "f {a0} {b1} {b0}")?;
        }
    }
    Ok(())
}

/// The closed-form band radiance (W m⁻² sr⁻¹) of the ground at `p` in the
/// lamp-grid scene: `ρ/π` times the irradiance from every lamp
/// (`I cos^m α cos θ / d²`) and every panel (Lambert's polygon formula,
/// `L · ½ Σ Θ_i (n · Γ_i)`, the panels lying wholly above the ground's
/// horizon and facing it).
pub fn lamp_grid_radiance(n_lamps: u64, p: DVec3) -> f64 {
    let up = DVec3::Z;
    let mut e = 0.0;
    for l in lamp_positions(n_lamps) {
        let d = l - p;
        let r2 = d.length_squared();
        let r = r2.sqrt();
        let cos_a = d.z / r; // the lamp points straight down: cos α = (l − p)·ẑ / r
        let cos_t = d.dot(up) / r;
        e += LAMP_W_SR * cos_a.powf(LAMP_M) * cos_t / r2;
        let v = panel_vertices(l);
        let mut sum = 0.0;
        for i in 0..4 {
            let a = v[i] - p;
            let b = v[(i + 1) % 4] - p;
            let g = a.cross(b);
            let theta = g.length().atan2(a.dot(b));
            sum += theta * g.normalize().dot(up);
        }
        e += PANEL_L * 0.5 * sum.abs();
    }
    GROUND_RHO / std::f64::consts::PI * e
}

/// One case's figures, as the child prints them.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CaseResult {
    pub kind: Kind,
    pub size: u64,
    pub expected: Counts,
    pub triangles: u64,
    pub facets: u64,
    pub point_sources: u64,
    pub emitting_facets: u64,
    /// Triangles placed through shared instances.
    #[serde(default)]
    pub placed_triangles: u64,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub threads: usize,
    pub generate_s: f64,
    pub load_s: f64,
    pub prepare_s: f64,
    pub trace_s: f64,
    pub rays: u64,
    pub rays_per_s: f64,
    pub rel_std_error_rms: f64,
    pub time_to_1pct_s: f64,
    pub prepare_peak_rss_bytes: Option<u64>,
    pub peak_rss_bytes: Option<u64>,
    /// Lamp cases: the rendered mean band radiance over the image and the
    /// closed form's mean over the pixel centres (W m⁻² sr⁻¹).
    pub mean_radiance: f64,
    pub closed_form_mean_radiance: Option<f64>,
}

/// Generates, loads, prepares and renders one case in this process (the
/// child's job; tests call it directly).
pub fn run_case(
    case: Case,
    dir: &Path,
    width: u32,
    height: u32,
    spp: u32,
    threads: Option<usize>,
    set: &[String],
) -> Result<CaseResult, BenchError> {
    case.check()?;
    ensure_valid!(
        (1..=4096).contains(&width) && (1..=4096).contains(&height),
        "image {width}×{height}: each side must be within 1 … 4096"
    );
    ensure_valid!(
        (2..=4096).contains(&spp),
        "spp {spp}: must be within 2 … 4096 (a pixel's standard error needs two samples)"
    );
    let t0 = Instant::now();
    let path = generate(case, dir, width, height)?;
    let generate_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let scene = gloam_scene::load(&path, &crate::unlisted())?;
    let load_s = t1.elapsed().as_secs_f64();
    let expected = expected_counts(case);
    let got = scene_counts(&scene);
    let triangles = got.triangles;
    ensure_valid!(
        got == expected,
        "size check: {} generated {got:?}, the closed form says {expected:?}",
        case.label()
    );
    let mut settings = RenderSettings {
        spp,
        threads,
        ..Default::default()
    };
    for pair in set {
        settings.set_pair(pair)?;
    }
    // Preparation resets the kernel's peak mark at each step (to time each
    // step's peak), so the process peak is the largest of the peak after
    // loading, the steps' peaks and the peak since the last step.
    let load_peak = peak_rss_bytes();
    let tracer = Tracer::new(&scene, &settings)?;
    let prepare_peak_rss_bytes = [
        load_peak,
        tracer.preparation().peak_rss_bytes,
        peak_rss_bytes(),
    ]
    .into_iter()
    .flatten()
    .max();
    let out = tracer.render(&|_, _| {})?;
    let s = &out.stats;
    ensure_valid!(
        s.triangles as u64 == expected.triangles,
        "size check: the tracer holds {} triangles, the generator made {}",
        s.triangles,
        expected.triangles
    );
    let e = out.error.rel_std_error_rms;
    let mean_radiance = out
        .radiance
        .index_axis(ndarray::Axis(0), 0)
        .mean()
        .unwrap_or(0.0);
    let closed_form_mean_radiance = (case.kind == Kind::Lamps)
        .then(|| lamp_grid_mean_radiance(case.size, &scene.camera, (s.width, s.height)));
    Ok(CaseResult {
        kind: case.kind,
        size: case.size,
        expected,
        triangles,
        facets: got.facets,
        point_sources: got.point_sources,
        emitting_facets: got.emitting_facets,
        placed_triangles: got.placed_triangles,
        width: s.width,
        height: s.height,
        spp,
        threads: s.threads,
        generate_s,
        load_s,
        prepare_s: s.prepare_seconds,
        trace_s: s.trace_seconds,
        rays: s.rays.total(),
        rays_per_s: s.rays_per_second,
        rel_std_error_rms: e,
        time_to_1pct_s: time_to_1pct(s.prepare_seconds, s.trace_seconds, spp, e),
        prepare_peak_rss_bytes,
        peak_rss_bytes: prepare_peak_rss_bytes.max(peak_rss_bytes()),
        mean_radiance,
        closed_form_mean_radiance,
    })
}

/// What the loaded scene holds, to compare with the generator's closed
/// form: triangles (flat and placed through shared instances), facets,
/// point sources and emitting facets.
fn scene_counts(scene: &gloam_scene::Scene) -> Counts {
    let triangles: u64 = scene
        .facets
        .iter()
        .map(|f| f.vertices.len() as u64 - 2)
        .sum();
    Counts {
        triangles,
        facets: scene.facets.len() as u64,
        point_sources: scene.point_sources.len() as u64,
        emitting_facets: scene.emitting_facets().len() as u64,
        placed_triangles: scene
            .shared
            .iter()
            .map(|s| {
                let per: u64 = s
                    .prototype
                    .iter()
                    .map(|f| f.vertices.len() as u64 - 2)
                    .sum();
                per * s.placements.len() as u64
            })
            .sum(),
    }
}

/// The lamp grid's closed-form radiance averaged over the render's own
/// pixel grid (resolution_scale 1) of `width` × `height` pixels.
fn lamp_grid_mean_radiance(
    size: u64,
    cam: &gloam_scene::Camera,
    (width, height): (u32, u32),
) -> f64 {
    let mut sum = 0.0;
    for row in 0..height {
        for col in 0..width {
            // The render's own pixel grid (resolution_scale 1).
            let d = cam.pixel_direction(col as f64 + 0.5, row as f64 + 0.5);
            let t = -cam.position.z / d.z;
            sum += lamp_grid_radiance(size, cam.position + t * d);
        }
    }
    sum / (width as f64 * height as f64)
}

/// Time to a 1 % per-pixel error from a render at a fixed `spp` whose
/// RMS relative standard error is `e`: the error falls as 1/√samples, so
/// `spp · (e / 0.01)²` samples per pixel are needed, and never fewer than
/// one; preparation is paid once.
pub fn time_to_1pct(prepare_s: f64, trace_s: f64, spp: u32, e: f64) -> f64 {
    let spp = f64::from(spp.max(1));
    let needed = (spp * (e / 0.01).powi(2)).max(1.0);
    prepare_s + trace_s / spp * needed
}

/// What `gloam bench scale` was asked to do.
#[derive(Clone, Debug)]
pub struct ScaleOptions {
    pub triangles: Vec<u64>,
    pub lamps: Vec<u64>,
    /// Placements of the instances family.
    pub instances: Vec<u64>,
    pub out: PathBuf,
    pub threads: Option<usize>,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub timeout_s: f64,
    /// The gloam binary each case runs in (`gloam bench scale --case …`).
    pub exe: PathBuf,
    /// Skip the Mitsuba 3 comparison even when `import mitsuba` works.
    pub no_mitsuba: bool,
    /// Render settings for every case (`--set KEY=VALUE`).
    pub set: Vec<String>,
}

impl ScaleOptions {
    /// The default sizes and settings, or `--quick`'s.
    pub fn new(quick: bool, out: PathBuf, exe: PathBuf) -> Self {
        Self {
            triangles: if quick {
                QUICK_TRIANGLES.to_vec()
            } else {
                DEFAULT_TRIANGLES.to_vec()
            },
            lamps: if quick {
                QUICK_LAMPS.to_vec()
            } else {
                DEFAULT_LAMPS.to_vec()
            },
            instances: if quick {
                Vec::new()
            } else {
                DEFAULT_INSTANCES.to_vec()
            },
            out,
            threads: None,
            width: if quick { 64 } else { 160 },
            height: if quick { 48 } else { 120 },
            spp: if quick { 2 } else { 4 },
            timeout_s: if quick { 60.0 } else { 900.0 },
            exe,
            no_mitsuba: quick,
            set: Vec::new(),
        }
    }
}

/// One row of the report: a case and how it ended.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub case: String,
    pub kind: Kind,
    pub size: u64,
    /// `ok`, `timeout`, `failed` or `too_large`.
    pub status: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub message: Option<String>,
    pub wall_s: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub result: Option<CaseResult>,
    /// The same scene in Mitsuba 3 (`scale_mitsuba.py`), when `import
    /// mitsuba` works: `load_s`, `render_s`, `peak_rss_bytes`, … or `error`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mitsuba: Option<serde_json::Value>,
}

/// `scale.json`.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleReport {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub threads: Option<usize>,
    pub timeout_s: f64,
    /// The `--set KEY=VALUE` settings every case ran with.
    pub set: Vec<String>,
    pub method: &'static str,
    pub cases: Vec<Row>,
    pub mitsuba: String,
    pub json: String,
    /// `null` when no case finished (nothing to plot).
    pub png: Option<String>,
}

const METHOD: &str = "each case in a fresh child process (gloam bench scale --case KIND:N); \
prepare_s = the tracer's prepare_seconds (BVH, effect-plan pilot, radiosity cache); \
peak_rss_bytes = VmHWM from the child's /proc/self/status after the render (prepare_peak_rss_bytes: right after preparation); \
rays_per_s = all rays per second of trace time; time_to_1pct_s = prepare_s + trace_s * max(1, spp * (e / 0.01)^2) / spp with e the RMS over pixels of the render's relative standard error at the fixed spp (at least one sample per pixel)";

/// The Mitsuba 3 side of the comparison (Python, run by `python3`).
const MITSUBA_SCRIPT: &str = include_str!("scale_mitsuba.py");

/// Renders the generated scene in `dir` with Mitsuba 3 (`scale_mitsuba.py`)
/// within `timeout_s`; its JSON, or `{"error": …}`.
fn run_mitsuba(
    dir: &Path,
    spp: u32,
    timeout_s: f64,
    guard: &gloam_io::RunGuard,
) -> serde_json::Value {
    let go = || -> Result<serde_json::Value, BenchError> {
        let script = dir.join("scale_mitsuba.py");
        std::fs::write(&script, MITSUBA_SCRIPT).map_err(BenchError::io("writing", &script))?;
        let (out, err) = (dir.join("mitsuba.json"), dir.join("mitsuba.err"));
        let (scene, spp) = (dir.join("scene"), spp.to_string());
        let args = [scene.as_os_str(), spp.as_ref()];
        run_mitsuba_script(
            &script,
            &args,
            &out,
            &err,
            Duration::from_secs_f64(timeout_s),
            guard,
        )?;
        Ok(serde_json::from_str(
            &gloam_io::read_text(&out, gloam_io::MAX_TEXT_FILE_BYTES, &crate::unlisted())
                .map_err(BenchError::io("reading", &out))?,
        )?)
    };
    go().unwrap_or_else(|e| serde_json::json!({ "error": gloam_io::output_set::chain(&e) }))
}

/// A case's scratch directory in `$TMPDIR` (its generated scene, up to
/// tens of MB, and the child's output), removed when dropped and — being
/// staged with the run's guard — on SIGINT, SIGTERM or SIGHUP too: a
/// `tempfile::TempDir` is not dropped when the signal handler ends the
/// process, and each interrupted run left one behind. Never published.
struct Scratch(gloam_io::output_set::OutputSet);

impl Scratch {
    fn new(guard: &gloam_io::RunGuard) -> Result<Self, BenchError> {
        let tmp = std::env::temp_dir();
        let name = tmp.join(format!("gloam-bench-scale-{}", std::process::id()));
        gloam_io::output_set::OutputSet::begin(&name, false, false, guard)
            .map(Self)
            .map_err(|e| {
                // The system's reason, not the output set's "--out …" wording.
                let mut cause: &dyn std::error::Error = &e;
                while let Some(c) = cause.source() {
                    cause = c;
                }
                BenchError::Invalid(format!(
                    "creating a scratch directory in {} (TMPDIR, else /tmp): {cause}; set TMPDIR to a writable directory",
                    tmp.display()
                ))
            })
    }

    fn path(&self) -> &Path {
        self.0.dir()
    }
}

/// Runs one case in a child process with a timeout (and then in Mitsuba 3
/// when `mitsuba`).
fn run_child(
    opts: &ScaleOptions,
    case: Case,
    mitsuba: bool,
    guard: &gloam_io::RunGuard,
) -> Result<Row, BenchError> {
    let t0 = Instant::now();
    let mut row = Row {
        case: case.label(),
        kind: case.kind,
        size: case.size,
        status: "ok".into(),
        message: None,
        wall_s: 0.0,
        result: None,
        mitsuba: None,
    };
    let need = estimated_peak_bytes(case);
    if let Some(avail) = gloam_scene::available_memory_bytes()
        && need > avail
    {
        row.status = "too_large".into();
        row.message = Some(format!(
            "estimated peak {:.1} GB exceeds MemAvailable {:.1} GB",
            need as f64 / 1e9,
            avail as f64 / 1e9
        ));
        return Ok(row);
    }
    let work = Scratch::new(guard)?;
    let stdout_path = work.path().join("stdout.json");
    let stderr_path = work.path().join("stderr.txt");
    let mut cmd = case_command(opts, case, work.path(), (&stdout_path, &stderr_path))?;
    let mut child = cmd.spawn().map_err(BenchError::io("starting", &opts.exe))?;
    let _reaper = super::child::Reaper::new(&child, guard);
    let status = wait_with_timeout(
        &mut child,
        t0,
        Duration::from_secs_f64(opts.timeout_s.max(0.1)),
    )?;
    row.wall_s = t0.elapsed().as_secs_f64();
    match status {
        None => {
            row.status = "timeout".into();
            row.message = Some(format!("killed after {:.0} s", opts.timeout_s));
        }
        Some(st) if !st.success() => {
            row.status = "failed".into();
            row.message = Some(format!("{st}: {}", stderr_tail(&stderr_path, 5)));
        }
        Some(_) => {
            let text = gloam_io::read_text(
                &stdout_path,
                gloam_io::MAX_TEXT_FILE_BYTES,
                &crate::unlisted(),
            )
            .map_err(BenchError::io("reading", &stdout_path))?;
            match serde_json::from_str::<CaseResult>(&text) {
                Ok(r) => row.result = Some(r),
                Err(e) => {
                    row.status = "failed".into();
                    row.message = Some(format!("the case printed no result ({e})"));
                }
            }
        }
    }
    // Mitsuba gets the scene whenever it was generated (scene.toml is
    // written last), also when gloam timed out preparing it.
    // The Mitsuba script reads flat OBJ scenes; shared instances it does
    // not translate.
    if mitsuba
        && case.kind != Kind::Instances
        && work.path().join("scene").join("scene.toml").exists()
    {
        row.mitsuba = Some(run_mitsuba(work.path(), opts.spp, opts.timeout_s, guard));
    }
    Ok(row)
}

/// The command that runs one case in a child `gloam bench scale --case`,
/// its output to `stdout`/`stderr` files: in its own process group, so a
/// timeout kills the case and anything it started, and killed with the
/// parent on Ctrl-C or SIGTERM (`child::Reaper`).
fn case_command(
    opts: &ScaleOptions,
    case: Case,
    work: &Path,
    (stdout_path, stderr_path): (&Path, &Path),
) -> Result<Command, BenchError> {
    let mut cmd = Command::new(&opts.exe);
    cmd.args(["bench", "scale", "--case", &case.label(), "--case-dir"])
        .arg(work.join("scene"))
        .args([
            "--width",
            &opts.width.to_string(),
            "--height",
            &opts.height.to_string(),
            "--spp",
            &opts.spp.to_string(),
        ])
        .stdin(Stdio::null())
        .stdout(
            std::fs::File::create(stdout_path).map_err(BenchError::io("creating", stdout_path))?,
        )
        .stderr(
            std::fs::File::create(stderr_path).map_err(BenchError::io("creating", stderr_path))?,
        );
    if let Some(n) = opts.threads {
        cmd.args(["--threads", &n.to_string()]);
    }
    for pair in &opts.set {
        cmd.args(["--set", pair]);
    }
    #[cfg(unix)]
    std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
    super::child::die_with_parent(&mut cmd);
    Ok(cmd)
}

/// Whether `import mitsuba` works (and so the side-by-side runs), and a
/// note saying so.
fn mitsuba_check(skip: bool) -> (bool, String) {
    if skip {
        return (false, "skipped (--quick or --no-mitsuba)".into());
    }
    if mitsuba_importable() {
        (
            true,
            "Mitsuba 3 (scalar_rgb, path max_depth 3, isotropic point lights) on the same generated \
             scene, same image size and spp: load_s (mi.load_dict), render_s, peak_rss_bytes \
             (getrusage ru_maxrss of its python3 process)"
                .into(),
        )
    } else {
        (
            false,
            "Mitsuba 3 not available (`python3 -c 'import mitsuba'` failed): side-by-side skipped"
                .into(),
        )
    }
}

/// Runs every case (triangles first, then lamps), writes `scale.json` and
/// `scale.png` into `opts.out`, and returns the report.
pub fn run(opts: &ScaleOptions, guard: &gloam_io::RunGuard) -> Result<ScaleReport, BenchError> {
    check_options(opts)?;
    let cases = cases(opts);
    for c in &cases {
        c.check()?;
    }
    refuse_foreign_outputs(&opts.out)?;
    let (mitsuba, mitsuba_note) = mitsuba_check(opts.no_mitsuba);
    let mut rows = Vec::new();
    for c in cases {
        eprintln!("bench scale: {} …", c.label());
        let row = run_child(opts, c, mitsuba, guard)?;
        eprintln!(
            "bench scale: {} {} ({:.1} s)",
            c.label(),
            row.status,
            row.wall_s
        );
        rows.push(row);
    }
    // Created only now, with something to write: an interrupted or
    // failed run left an empty --out behind.
    std::fs::create_dir_all(&opts.out).map_err(BenchError::io("creating", &opts.out))?;
    let json_path = opts.out.join("scale.json");
    let png_path = opts.out.join("scale.png");
    let mut report = ScaleReport {
        width: opts.width,
        height: opts.height,
        spp: opts.spp,
        threads: opts.threads,
        timeout_s: opts.timeout_s,
        set: opts.set.clone(),
        method: METHOD,
        cases: rows,
        mitsuba: mitsuba_note,
        json: json_path.display().to_string(),
        png: None,
    };

    if report.cases.iter().any(|r| r.result.is_some()) {
        plot(&png_path, &report.cases)?;
        report.png = Some(png_path.display().to_string());
    }
    gloam_pipeline::output::write_atomic(
        &json_path,
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    // A bench none of whose cases finished measured nothing — every case
    // failed, timed out or was too large (all timeouts exited 0): say so
    // by the exit status too (the report, written above, says why).
    let ok = report.cases.iter().filter(|r| r.status == "ok").count();
    let count = |st: &str| report.cases.iter().filter(|r| r.status == st).count();
    ensure_valid!(
        ok > 0 || report.cases.is_empty(),
        "no case finished ({} failed, {} timed out, {} too large, of {}); first: {} (the report is in {})",
        count("failed"),
        count("timeout"),
        count("too_large"),
        report.cases.len(),
        report
            .cases
            .first()
            .and_then(|r| r.message.as_deref())
            .unwrap_or("no message"),
        json_path.display()
    );
    Ok(report)
}

/// Size, samples, timeout and threads within the bench's limits.
fn check_options(opts: &ScaleOptions) -> Result<(), BenchError> {
    ensure_valid!(
        (1..=4096).contains(&opts.width) && (1..=4096).contains(&opts.height),
        "--width/--height {}×{}: each must be within 1 … 4096",
        opts.width,
        opts.height
    );
    ensure_valid!(
        (2..=4096).contains(&opts.spp),
        "--spp {}: must be within 2 … 4096 (a pixel's standard error needs two samples)",
        opts.spp
    );
    ensure_valid!(
        opts.timeout_s.is_finite()
            && opts.timeout_s >= MIN_TIMEOUT_S
            && opts.timeout_s <= MAX_TIMEOUT_S,
        "--timeout-s {}: must be a number of seconds in [{MIN_TIMEOUT_S}, {MAX_TIMEOUT_S:e}]",
        opts.timeout_s
    );
    ensure_valid!(
        opts.threads
            .is_none_or(|n| (1..=gloam_trace::tracer::MAX_THREADS).contains(&n)),
        "--threads {}: must be within 1 … {}",
        opts.threads.unwrap_or(0),
        gloam_trace::tracer::MAX_THREADS
    );
    Ok(())
}

/// The cases asked for: triangles, then lamps, then instances, each in the
/// order given.
fn cases(opts: &ScaleOptions) -> Vec<Case> {
    let mut cases = Vec::new();
    for &n in &opts.triangles {
        cases.push(Case {
            kind: Kind::Triangles,
            size: n,
        });
    }
    for &n in &opts.lamps {
        cases.push(Case {
            kind: Kind::Lamps,
            size: n,
        });
    }
    for &n in &opts.instances {
        cases.push(Case {
            kind: Kind::Instances,
            size: n,
        });
    }
    cases
}

/// Shortest `--timeout-s`: no case starts in less (1e-300 s killed every
/// case at once, and the report said "killed after 0 s").
pub const MIN_TIMEOUT_S: f64 = 1.0;

/// Longest `--timeout-s` (about 11.6 days): a wall-time limit, not
/// "forever" (1e20 s overflowed the clock's duration).
pub const MAX_TIMEOUT_S: f64 = 1e6;

fn plot(path: &Path, rows: &[Row]) -> Result<(), BenchError> {
    use gloam_calib::plot::{Mark, Scale, Series, xy_plot_scaled};
    let mut series = Vec::new();
    for kind in [Kind::Triangles, Kind::Lamps, Kind::Instances] {
        let ok: Vec<&CaseResult> = rows
            .iter()
            .filter(|r| r.kind == kind)
            .filter_map(|r| r.result.as_ref())
            .collect();
        let pts = |f: fn(&CaseResult) -> f64| -> Vec<(f64, f64)> {
            ok.iter().map(|r| (r.size as f64, f(r).max(1e-6))).collect()
        };
        if !ok.is_empty() {
            let k = kind.as_str();
            series.push(Series::new(
                &format!("prepare (vs {k})"),
                pts(|r| r.prepare_s),
                Mark::LinePoints,
            ));
            series.push(Series::new(
                &format!("time to 1 % (vs {k})"),
                pts(|r| r.time_to_1pct_s),
                Mark::LinePoints,
            ));
        }
    }
    xy_plot_scaled(
        path,
        "gloam bench scale",
        ("triangles, lamps or placements", Scale::Log10),
        ("seconds", Scale::Log10),
        &series,
    )
    .map_err(|e| BenchError::Plot {
        path: path.to_path_buf(),
        why: e.to_string(),
    })
}

impl ScaleReport {
    /// The table `gloam bench scale` prints.
    pub fn text(&self) -> String {
        let mut m = String::new();
        let _ = writeln!(
            m,
            "gloam bench scale: {}×{} px, spp {}, timeout {:.0} s per case{}",
            self.width,
            self.height,
            self.spp,
            self.timeout_s,
            if self.set.is_empty() {
                String::new()
            } else {
                format!(", --set {}", self.set.join(" --set "))
            }
        );
        let _ = writeln!(
            m,
            "{:<18} {:>9} {:>9} {:>6} {:>6} {:>9} {:>9} {:>10} {:>10} {:>8} {:>11}  status",
            "case",
            "triangles",
            "facets",
            "lamps",
            "emit",
            "prepare_s",
            "trace_s",
            "peak_MB",
            "rays/s",
            "rel_err",
            "to_1pct_s"
        );
        for r in &self.cases {
            case_line(&mut m, r);
        }
        for r in &self.cases {
            let Some(v) = &r.mitsuba else { continue };
            let f = |k: &str| v[k].as_f64();
            match (f("load_s"), f("render_s"), f("peak_rss_bytes")) {
                (Some(l), Some(t), Some(b)) => {
                    let _ = writeln!(
                        m,
                        "  mitsuba {:<18} load {l:.3} s, render {t:.3} s, peak {:.1} MB, {} triangles",
                        r.case,
                        b / 1e6,
                        v["triangles"]
                    );
                }
                _ => {
                    let _ = writeln!(m, "  mitsuba {:<18} {}", r.case, v["error"]);
                }
            }
        }
        let _ = writeln!(m, "method: {}", self.method);
        let _ = writeln!(m, "mitsuba: {}", self.mitsuba);
        let _ = writeln!(
            m,
            "files: {}{}",
            self.json,
            self.png
                .as_deref()
                .map(|p| format!(", {p}"))
                .unwrap_or_else(|| " (no scale.png: no case finished)".into())
        );
        m
    }
}

/// One case's row of the table: its figures, or its status and why.
fn case_line(m: &mut String, r: &Row) {
    match &r.result {
        Some(c) => {
            let _ = writeln!(
                m,
                "{:<18} {:>9} {:>9} {:>6} {:>6} {:>9.3} {:>9.3} {:>10} {:>10.3e} {:>8.4} {:>11.3}  ok",
                r.case,
                // Placed through shared instances, counted too.
                c.triangles + c.placed_triangles,
                c.facets,
                c.point_sources,
                c.emitting_facets,
                c.prepare_s,
                c.trace_s,
                c.peak_rss_bytes
                    .map(|b| format!("{:.1}", b as f64 / 1e6))
                    .unwrap_or_else(|| "-".into()),
                c.rays_per_s,
                c.rel_std_error_rms,
                c.time_to_1pct_s
            );
        }
        None => {
            let _ = writeln!(
                m,
                "{:<18} {:>9} {:>9} {:>6} {:>6} {:>9} {:>9} {:>10} {:>10} {:>8} {:>11}  {}: {}",
                r.case,
                "-",
                "-",
                "-",
                "-",
                "-",
                "-",
                "-",
                "-",
                "-",
                "-",
                r.status,
                r.message.as_deref().unwrap_or("")
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_parse_and_are_checked() {
        assert_eq!(parse_count("1e4").unwrap(), 10_000);
        assert_eq!(
            parse_counts("1e3, 2000", "triangles", MAX_TRIANGLES).unwrap(),
            [1000, 2000]
        );
        for bad in ["0", "-3", "1.5", "x", "inf", "1e30"] {
            assert!(parse_count(bad).is_err(), "{bad}");
        }
        assert!(parse_counts("1e8", "triangles", MAX_TRIANGLES).is_err());
        assert!(parse_counts("", "lamps", MAX_LAMPS).is_err());
        // Sizes given twice or an empty item: refused, naming them.
        let e = parse_counts("1,1e0", "triangles", MAX_TRIANGLES).unwrap_err();
        assert!(e.to_string().contains("1 is given twice"), "{e}");
        for bad in ["1e3,,1e4", "1e3,", ",1e3"] {
            let e = parse_counts(bad, "triangles", MAX_TRIANGLES).unwrap_err();
            assert!(e.to_string().contains("is empty"), "{bad}: {e}");
        }
        // Too large is named as such, not as a fraction.
        let e = parse_counts("1e13", "triangles", MAX_TRIANGLES).unwrap_err();
        assert!(e.to_string().contains("too large"), "{e}");
        assert!(Case::parse("lamps:1e6").is_err());
        assert!(Case::parse("spheres:10").is_err());
        assert_eq!(
            Case::parse("triangles:1e3").unwrap(),
            Case {
                kind: Kind::Triangles,
                size: 1000
            }
        );
    }

    #[test]
    fn time_to_1pct_scales_by_the_variance_and_needs_one_sample() {
        // 5 % at spp 4 in 2 s of tracing: 4 · 25 = 100 spp, 25× the time.
        assert!((time_to_1pct(1.0, 2.0, 4, 0.05) - 51.0).abs() < 1e-9);
        // Already below 1 % at spp 4: one sample per pixel still costs a quarter.
        assert!((time_to_1pct(1.0, 2.0, 4, 0.001) - 1.5).abs() < 1e-9);
    }

    #[test]
    fn sphere_plan_tracks_the_request() {
        for n in [1_000u64, 10_000, 100_000, 1_000_000, 10_000_000] {
            let c = expected_counts(Case {
                kind: Kind::Triangles,
                size: n,
            });
            let r = c.triangles as f64 / n as f64;
            assert!((0.9..1.1).contains(&r), "{n}: {c:?}");
        }
    }

    /// The generated scenes hold exactly the closed-form counts, and the
    /// lamp grid's rendered mean radiance matches the closed-form sum of
    /// inverse-square cosine terms (plus Lambert's formula for the panels).
    #[test]
    fn quick_cases_match_their_closed_forms() {
        for case in [
            Case {
                kind: Kind::Triangles,
                size: 1000,
            },
            Case {
                kind: Kind::Lamps,
                size: 1,
            },
            Case {
                kind: Kind::Lamps,
                size: 10,
            },
            Case {
                kind: Kind::Instances,
                size: 3,
            },
        ] {
            let dir = tempfile::tempdir().unwrap();
            let r = run_case(case, &dir.path().join("scene"), 48, 36, 2, Some(2), &[])
                .unwrap_or_else(|e| panic!("{}: {e:#}", case.label()));
            assert_eq!(r.expected, expected_counts(case));
            assert_eq!(
                (r.triangles, r.facets, r.point_sources, r.emitting_facets),
                (
                    r.expected.triangles,
                    r.expected.facets,
                    r.expected.point_sources,
                    r.expected.emitting_facets
                ),
                "{}",
                case.label()
            );
            assert_eq!(r.placed_triangles, r.expected.placed_triangles);
            assert!(r.prepare_s > 0.0 && r.trace_s > 0.0 && r.rays > 0);
            assert!(r.rel_std_error_rms.is_finite() && r.time_to_1pct_s >= r.prepare_s);
            if let Some(cf) = r.closed_form_mean_radiance {
                // Point sources and unoccluded panels are exact; only the
                // sub-pixel jitter of the primary hits separates the two.
                let rel = (r.mean_radiance - cf).abs() / cf;
                assert!(
                    rel < 0.002,
                    "{}: rendered mean {} vs closed form {cf} ({:.3} %)",
                    case.label(),
                    r.mean_radiance,
                    100.0 * rel
                );
            }
        }
    }
}
