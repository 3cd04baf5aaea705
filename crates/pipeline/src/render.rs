//! What every front end of a render shares (the CLI's `gloam render`, the
//! Python package): the render settings from `KEY=VALUE` pairs and flags,
//! and the `report.json` document, so a render reports the same figures
//! whichever way it was started.

use std::path::Path;

use gloam_trace::{RenderOutput, RenderSettings};

/// Settings from `--set` pairs, then the dedicated flags.
pub fn settings_from(
    set: &[String],
    spp: Option<u32>,
    seed: Option<u64>,
    estimator: Option<&str>,
    threads: Option<usize>,
) -> anyhow::Result<RenderSettings> {
    for (key, flag, given) in [
        ("spp", "--spp", spp.is_some()),
        ("seed", "--seed", seed.is_some()),
        ("estimator", "--estimator", estimator.is_some()),
    ] {
        if given {
            refuse_both(set, key, flag)?;
        }
    }
    let mut s = RenderSettings::default();
    for pair in set {
        s.set_pair(pair)?;
    }
    if let Some(v) = spp {
        s.set("spp", &v.to_string())?;
    }
    if let Some(v) = seed {
        s.seed = v;
    }
    if let Some(e) = estimator {
        s.estimator = e.parse()?;
    }
    if let Some(t) = threads {
        anyhow::ensure!(t >= 1, "--threads must be at least 1");
        s.threads = Some(t);
    }
    Ok(s)
}

/// Refuses a setting given twice, as `--set KEY=…` and as its own flag:
/// which one wins would be a guess.
pub fn refuse_both(set: &[String], key: &str, flag: &str) -> anyhow::Result<()> {
    if let Some(pair) = set.iter().find(|p| {
        p.split_once('=')
            .is_some_and(|(k, _)| k.trim().eq_ignore_ascii_case(key))
    }) {
        anyhow::bail!("`--set {pair}` and `{flag}` both set {key}: give one");
    }
    Ok(())
}

/// The `report.json` of a render (without `provenance`, which the caller
/// adds): settings, effect plan, timings, rays, per-band means.
pub fn report_json(
    scene_path: &Path,
    scene: &gloam_scene::Scene,
    plan: &gloam_scene::plan::EffectPlan,
    out: &RenderOutput,
    load_s: f64,
    write_s: f64,
) -> serde_json::Value {
    let band_means: serde_json::Map<String, serde_json::Value> = out
        .band_names
        .iter()
        .enumerate()
        .map(|(b, name)| {
            let img = out.radiance.index_axis(ndarray::Axis(0), b);
            let mean = img.mean().unwrap_or(0.0);
            let max = img.iter().copied().fold(0.0, f64::max);
            (
                name.clone(),
                serde_json::json!({"mean_radiance_w_m2_sr": mean, "max_radiance_w_m2_sr": max}),
            )
        })
        .collect();
    serde_json::json!({
        "scene": scene_path.display().to_string(),
        "units": scene.units.as_str(),
        "meters_per_unit": scene.meters_per_unit,
        "image": {"width": out.stats.width, "height": out.stats.height, "bands": out.band_names},
        "outputs": {
            "radiance.tiff": "float32, one page per band, W m^-2 sr^-1",
            "radiance.npy": "float64, band x row x column, W m^-2 sr^-1",
            "preview.png": "first band, scaled to its 99.5th percentile, gamma 2.2",
            "stderr.npy": "float64, band x row x column, W m^-2 sr^-1: estimated standard error of each pixel",
            "stderr.tiff": "float32, one page per band: the same standard error",
            "spp.npy": "uint32, row x column: camera samples per pixel",
        },
        "error": out.error,
        "settings": out.settings,
        "effect_plan": plan,
        "timings_s": {
            "load": load_s,
            "prepare": out.stats.prepare_seconds,
            "trace": out.stats.trace_seconds,
            "write": write_s,
        },
        "rays": out.stats.rays,
        "rays_total": out.stats.rays.total(),
        "rays_per_second": out.stats.rays_per_second,
        "threads": out.stats.threads,
        "wavelengths": out.stats.wavelengths,
        "emission_lines": out.stats.emission_lines,
        "triangles": out.stats.triangles,
        "area_sources": out.stats.area_sources,
        "point_sources": out.stats.point_sources,
        "sky": out.stats.sky,
        "interreflection": out.stats.interreflection,
        "preparation": out.stats.preparation,
        "bands": band_means,
    })
}
