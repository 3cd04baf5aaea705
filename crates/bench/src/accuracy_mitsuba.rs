//! `gloam bench accuracy`'s side-by-side with Mitsuba 3 (when `python3`
//! can import it; never needed by tests): the same loaded scene rendered
//! by Mitsuba's path tracer along an spp ladder, each image measured
//! against the same truth with the same metric as gloam's rows, so the two
//! ladders and their times to 1 % and 0.1 % per-pixel error stand side by
//! side in one run on one machine.
//!
//! The scene goes over as what gloam loaded: every facet (boxes, quads,
//! inline geometry and OBJ alike) triangulated into one OBJ per material,
//! each band's diffuse reflectance and emitted band radiance as one RGB
//! channel (Mitsuba `llvm_ad_rgb`, or `scalar_rgb` where LLVM cannot
//! start: with spectrally flat reflectances each
//! band is an independent grey transport, so this is exact; a spectrally
//! varying reflectance is band-averaged and the report says so). Scenes
//! with what that cannot carry (point sources, sky or moon, specular or
//! transmissive materials, shaped emitters, more than 3 bands) are
//! skipped with the reason.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;
use std::time::Duration;

use gloam_scene::Scene;
use ndarray::Array3;

use super::BenchError;
use super::child::run_mitsuba_script;
use super::metrics::{Errors, errors};
use super::truth::Truth;

/// The Mitsuba 3 side (Python, run by `python3`).
const SCRIPT: &str = include_str!("accuracy_mitsuba.py");

/// Whole light: Mitsuba's `path` with unbounded depth (Russian roulette).
pub const WHOLE_LIGHT_DEPTH: i32 = -1;
/// Direct light only: camera → surface → emitter.
pub const DIRECT_ONLY_DEPTH: i32 = 2;
const WHOLE_LIGHT_LADDER: [u32; 5] = [4, 16, 64, 256, 1024];
const DIRECT_ONLY_LADDER: [u32; 5] = [4, 16, 64, 256, 1024];
/// Largest image the side-by-side reads back (pixels).
const MAX_PIXELS: usize = 16_777_216;

/// One rung of a Mitsuba ladder, measured.
#[derive(Clone, Debug)]
pub struct Rung {
    pub max_depth: i32,
    pub spp: u32,
    /// `mi.render` wall time (the scene loaded once before, `load_s`).
    pub render_s: f64,
    pub errors: Errors,
}

/// What the side-by-side produced.
pub struct SideBySide {
    pub rungs: Vec<Rung>,
    /// What ran and how (version, variant, threads, load time, exactness).
    pub note: String,
}

/// Why `scene` cannot go to Mitsuba as this module writes it, if it cannot.
pub fn obstacle(scene: &Scene) -> Option<String> {
    if !scene.point_sources.is_empty() {
        return Some("point sources (Mitsuba has no cos^m point emitter)".into());
    }
    if let Some(d) = scene.distant_sources.first() {
        return Some(format!(
            "distant sources (distant_sources.{}: this export writes area emitters only)",
            d.name
        ));
    }
    if scene.sky.is_some() {
        return Some("a [sky] (moon and night-sky models are gloam's own)".into());
    }
    if let Some(sh) = scene.shared.first() {
        return Some(format!(
            "shared instances (objects.{}: this export writes flat meshes; instancing = \"expand\" would copy them)",
            scene.objects[sh.object].name
        ));
    }
    if scene.bands.len() > 3 {
        return Some(format!(
            "{} bands (RGB carries at most 3)",
            scene.bands.len()
        ));
    }
    for m in &scene.materials {
        if m.specular_fraction > 0.0 || m.is_transmissive() {
            return Some(format!("material {:?} is specular or transmissive", m.name));
        }
        if let Some(e) = &m.emission
            && e.shape_exponent != 0.0
        {
            return Some(format!(
                "material {:?} emits cos^{} (Mitsuba's area emitter is Lambertian)",
                m.name, e.shape_exponent
            ));
        }
    }
    None
}

/// Each band's mean diffuse reflectance of material `m`, and whether it
/// is flat over every band (then the RGB transport is exact).
fn band_reflectance(scene: &Scene, m: usize) -> ([f64; 3], bool) {
    let mat = &scene.materials[m];
    let mut v = [0.0; 3];
    let mut flat = true;
    for (k, b) in scene.bands.iter().enumerate().take(3) {
        const N: usize = 61;
        let xs: Vec<f64> = (0..N)
            .map(|i| {
                mat.diffuse_reflectance(b.lo_nm + (b.hi_nm - b.lo_nm) * i as f64 / (N - 1) as f64)
            })
            .collect();
        let (lo, hi) = xs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, z), &x| {
                (a.min(x), z.max(x))
            });
        let band_flat = hi - lo <= 1e-12 * hi.abs().max(1.0);
        flat &= band_flat;
        // A flat reflectance goes over exactly; else the band's mean.
        v[k] = if band_flat {
            xs[0]
        } else {
            xs.iter().sum::<f64>() / N as f64
        };
    }
    (v, flat)
}

/// Writes `scene.json` and one OBJ per material into `dir`; false when the
/// reflectances had to be band-averaged (not exact).
fn export(
    scene: &Scene,
    dir: &Path,
    seed: u32,
    time_limit_s: f64,
    direct_ladder: bool,
) -> Result<bool, BenchError> {
    std::fs::create_dir_all(dir).map_err(BenchError::io("creating", dir))?;
    let mut meshes = Vec::new();
    let mut exact = true;
    for (m, mat) in scene.materials.iter().enumerate() {
        let facets: Vec<_> = scene.facets.iter().filter(|f| f.material == m).collect();
        if facets.is_empty() {
            continue;
        }
        let name = format!("material-{m}.obj");
        let path = dir.join(&name);
        let write = || -> std::io::Result<()> {
            let mut w = std::io::BufWriter::new(std::fs::File::create(&path)?);
            writeln!(w, "# {} (gloam material {:?})", name, mat.name)?;
            let mut base = 1usize;
            for f in &facets {
                for v in &f.vertices {
                    writeln!(w, "v {:.9} {:.9} {:.9}", v.x, v.y, v.z)?;
                }
                // A convex facet: a fan from its first vertex keeps the
                // winding (and so the front face) of the facet.
                for k in 1..f.vertices.len() - 1 {
                    writeln!(w, "f {} {} {}", base, base + k, base + k + 1)?;
                }
                base += f.vertices.len();
            }
            w.flush()
        };
        write().map_err(BenchError::io("writing", &path))?;
        let (rho, flat) = band_reflectance(scene, m);
        exact &= flat;
        let emission = mat.emission.as_ref().map(|e| {
            let mut v = [0.0; 3];
            for (k, b) in scene.bands.iter().enumerate().take(3) {
                v[k] = e
                    .radiance_w_m2_sr_nm
                    .integrate_weighted_band(&b.response, b.lo_nm, b.hi_nm);
            }
            v
        });
        meshes.push(serde_json::json!({
            "obj": name,
            "reflectance": rho,
            "emission": emission,
        }));
    }
    let mut ladders = vec![serde_json::json!([WHOLE_LIGHT_DEPTH, WHOLE_LIGHT_LADDER])];
    if direct_ladder {
        ladders.push(serde_json::json!([DIRECT_ONLY_DEPTH, DIRECT_ONLY_LADDER]));
    }
    let c = &scene.camera;
    let json = serde_json::json!({
        "camera": {
            "position": [c.position.x, c.position.y, c.position.z],
            "look_at": [c.look_at.x, c.look_at.y, c.look_at.z],
            "up": [c.up.x, c.up.y, c.up.z],
            "fov_deg": c.fov_deg,
            "width": c.width,
            "height": c.height,
        },
        "sampler": "multijitter",
        "seed": seed,
        "time_limit_s": time_limit_s,
        "meshes": meshes,
        "ladders": ladders,
    });
    let path = dir.join("scene.json");
    std::fs::write(&path, serde_json::to_vec_pretty(&json)?)
        .map_err(BenchError::io("writing", &path))?;
    let script = dir.join("accuracy_mitsuba.py");
    std::fs::write(&script, SCRIPT).map_err(BenchError::io("writing", &script))?;
    Ok(exact)
}

/// Renders `scene` with Mitsuba 3 into `dir` (whole-light and direct-only
/// ladders, each stopping once `time_limit_s` is spent) and measures each
/// image against `whole` and `direct` (the truths of gloam's rows).
pub fn side_by_side(
    scene: &Scene,
    dir: &Path,
    (whole, direct): (&Truth, Option<&Truth>),
    time_limit_s: f64,
    guard: &gloam_io::RunGuard,
) -> Result<SideBySide, BenchError> {
    // Checked before Mitsuba renders (and before an image is read back).
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let nb = scene.bands.len();
    ensure_valid!(
        w * h <= MAX_PIXELS,
        "Mitsuba side-by-side: {w}×{h} exceeds {MAX_PIXELS} pixels"
    );
    // The direct-only ladder only where there is a direct-only truth.
    let exact = export(scene, dir, 0, time_limit_s, direct.is_some())?;
    let (log, err) = (dir.join("mitsuba.log"), dir.join("mitsuba.err"));
    // The script stops climbing at the limit; the timeout only guards a
    // rung that hangs (4× the limit, as a rung is at most ~4× the last).
    run_mitsuba_script(
        &dir.join("accuracy_mitsuba.py"),
        &[dir.as_os_str()],
        &log,
        &err,
        Duration::from_secs_f64(4.0 * time_limit_s + 60.0),
        guard,
    )?;
    let json_path = dir.join("mitsuba.json");
    let text = gloam_io::read_text(
        &json_path,
        gloam_io::MAX_TEXT_FILE_BYTES,
        &crate::unlisted(),
    )
    .map_err(BenchError::io("reading", &json_path))?;
    let report: serde_json::Value = serde_json::from_str(&text)?;
    let mut rungs = Vec::new();
    let runs = report["runs"].as_array().cloned().unwrap_or_default();
    for r in runs.iter().take(64) {
        let (Some(depth), Some(spp), Some(render_s), Some(file)) = (
            r["max_depth"].as_i64(),
            r["spp"].as_u64(),
            r["render_s"].as_f64(),
            r["file"].as_str(),
        ) else {
            return Err(BenchError::Invalid(format!(
                "{}: a run lacks max_depth, spp, render_s or file",
                json_path.display()
            )));
        };
        // A direct-only rung is measured against the direct-only truth
        // (the script renders that ladder only when there is one).
        let truth = match (depth as i32 == DIRECT_ONLY_DEPTH, direct) {
            (false, _) => whole,
            (true, Some(t)) => t,
            (true, None) => continue,
        };
        let path = dir.join(file);
        let bytes = gloam_io::read_bounded(&path, (w * h * 3 * 4) as u64, &crate::unlisted())
            .map_err(BenchError::io("reading", &path))?;
        ensure_valid!(
            bytes.len() == w * h * 3 * 4,
            "{}: {} bytes, expected {h}×{w}×3 float32",
            path.display(),
            bytes.len()
        );
        let mut img = Array3::<f64>::zeros((nb, h, w));
        for (i, px) in bytes.chunks_exact(12).enumerate() {
            let (y, x) = (i / w, i % w);
            for b in 0..nb {
                let c = &px[4 * b..4 * b + 4];
                img[[b, y, x]] = f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64;
            }
        }
        rungs.push(Rung {
            max_depth: depth as i32,
            spp: spp as u32,
            render_s,
            errors: errors(&img, truth),
        });
    }
    let mut note = String::new();
    let _ = write!(
        note,
        "Mitsuba {} ({}, {} threads), path tracer, multijitter sampler, box pixel filter; scene load {:.2} s and one untimed 1-spp render per ladder (JIT compile: {}) not counted in the times; {}",
        report["version"].as_str().unwrap_or("?"),
        report["variant"].as_str().unwrap_or("?"),
        report["threads"].as_u64().unwrap_or(0),
        report["load_s"].as_f64().unwrap_or(f64::NAN),
        report["warmup_s"],
        if exact {
            "reflectances spectrally flat: each band is an exact grey transport in one RGB channel"
        } else {
            "reflectances band-averaged (not exact for spectrally varying materials)"
        }
    );
    Ok(SideBySide { rungs, note })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The office as Mitsuba receives it: the troffers' vis-band radiance
    /// is the `normalize` value the scene file states, each material's
    /// reflectance its stated value, and the OBJ triangles cover exactly
    /// the area of the scene's facets (a fan keeps a convex facet whole).
    #[test]
    fn the_office_goes_over_with_its_stated_radiance_reflectance_and_area() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../sims/office-room/scene.toml");
        let scene = gloam_scene::load(&path, &crate::unlisted()).unwrap();
        assert_eq!(obstacle(&scene), None);
        let dir = tempfile::tempdir().unwrap();
        assert!(
            export(&scene, dir.path(), 0, 10.0, true).unwrap(),
            "flat reflectances: exact"
        );
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("scene.json")).unwrap()).unwrap();
        let meshes = json["meshes"].as_array().unwrap();
        let lit: Vec<_> = meshes.iter().filter(|m| !m["emission"].is_null()).collect();
        assert_eq!(lit.len(), 1);
        let vis = lit[0]["emission"][0].as_f64().unwrap();
        assert!(
            (vis / 15.058 - 1.0).abs() < 1e-9,
            "troffer vis radiance {vis}"
        );
        let mut rho: Vec<f64> = meshes
            .iter()
            .map(|m| m["reflectance"][0].as_f64().unwrap())
            .collect();
        rho.sort_by(f64::total_cmp);
        assert_eq!(rho, [0.0, 0.15, 0.25, 0.3, 0.45, 0.6, 0.8]);
        // Triangle areas from the OBJ files against the facets' own.
        let mut obj_area = 0.0;
        for m in meshes {
            let text =
                std::fs::read_to_string(dir.path().join(m["obj"].as_str().unwrap())).unwrap();
            let mut v = Vec::new();
            for l in text.lines().filter(|l| !l.starts_with('#')) {
                let f: Vec<f64> = l
                    .split_whitespace()
                    .skip(1)
                    .map(|x| x.parse().unwrap())
                    .collect();
                if l.starts_with("v ") {
                    v.push(gloam_trace::DVec3::new(f[0], f[1], f[2]));
                } else if l.starts_with("f ") {
                    let (a, b, c) = (
                        v[f[0] as usize - 1],
                        v[f[1] as usize - 1],
                        v[f[2] as usize - 1],
                    );
                    obj_area += 0.5 * (b - a).cross(c - a).length();
                }
            }
        }
        let area: f64 = scene.facets.iter().map(|f| f.area()).sum();
        assert!((obj_area / area - 1.0).abs() < 1e-9, "{obj_area} vs {area}");
    }
}
