//! `gloam plan SCENE [--json]`: which effects a render of the scene simulates
//! and why (see `gloam_scene::plan`).

pub use gloam_pipeline::cli::PlanArgs;

use super::output::print_json;

pub fn run(args: PlanArgs) -> anyhow::Result<()> {
    // The scene error already reads `file:line: field: message`.
    let scene = gloam_scene::load(&args.scene)?;
    let settings = args.settings().settings()?;
    // Checked before the plan's preparation: a bad camera is refused now.
    let camera_target = args.camera_target(&scene)?;
    let (plan, prep) = gloam_trace::plan::effect_plan_observed(
        &scene,
        &settings,
        super::progress::prep_spinner(),
    )?;
    // `--target-error camera[:K]`: what a camera run would cost, before it.
    let estimate = match &camera_target {
        Some((k, capture)) => {
            let spp_fixed = args.settings().names_spp();
            Some(gloam_pipeline::camera_goal::estimate(
                &scene, &settings, spp_fixed, capture, *k,
            )?)
        }
        None => None,
    };
    if args.json {
        let mut v = serde_json::to_value(&plan)?;
        v["preparation"] = serde_json::to_value(&prep)?;
        if let Some(e) = &estimate {
            v["camera_target_estimate"] = e.clone();
        }
        print_json(&v)?;
    } else {
        let n = |k: usize, what: &str| format!("{k} {what}{}", if k == 1 { "" } else { "s" });
        let shared = scene.counts().shared_facets;
        outln!(
            "{}: {}{}, {}{}, {}, units {}",
            args.scene.display(),
            n(scene.facets.len(), "facet"),
            if shared > 0 {
                format!(" (+ {shared} placed by shared instances)")
            } else {
                String::new()
            },
            n(scene.point_sources.len(), "point source"),
            match scene.distant_sources.len() {
                0 => String::new(),
                k => format!(", {}", n(k, "distant source")),
            },
            n(scene.bands.len(), "band"),
            scene.units.as_str()
        );
        outln!();
        out!("{plan}");
        outln!();
        outln!("{}", preparation_line(&prep));
        if let (Some(e), Some((_, capture))) = (&estimate, &camera_target) {
            outln!("{}", estimate_line(e, capture.sensor));
        }
    }
    Ok(())
}

/// One line: the camera target's estimate against the 2 % default.
fn estimate_line(e: &serde_json::Value, sensor: &str) -> String {
    let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let (c, r) = (&e["camera"], &e["default_2_percent"]);
    format!(
        "--target-error camera:{} through '{sensor}' (estimated from {}×{} trial renders): {:.1} spp vs {:.1} at the 2 % default, {:.1} vs {:.1} M rays (×{:.1}), {:.2} vs {:.2} s of tracing (×{:.1}) at full size",
        f(&e["k"]),
        e["trial_width"],
        e["trial_height"],
        f(&c["mean_spp"]),
        f(&r["mean_spp"]),
        f(&c["rays"]) / 1e6,
        f(&r["rays"]) / 1e6,
        f(&e["rays_saving"]),
        f(&c["trace_seconds"]),
        f(&r["trace_seconds"]),
        f(&e["time_saving"]),
    )
}

/// One line: each preparation step's time (and peak memory), as `gloam
/// plan` ran them.
fn preparation_line(p: &gloam_trace::Preparation) -> String {
    let mib = |b: Option<u64>| {
        b.map_or(String::new(), |b| {
            format!(", {:.0} MiB", b as f64 / 1048576.0)
        })
    };
    let steps: Vec<String> = p
        .steps
        .iter()
        .map(|s| format!("{} {:.2} s{}", s.name, s.seconds, mib(s.peak_rss_bytes)))
        .collect();
    format!(
        "preparation {:.2} s ({}); {} object placements, {} triangles, {} emitting facets, peak {}",
        p.seconds,
        steps.join("; "),
        p.instances,
        p.triangles,
        p.area_emitters,
        p.peak_rss_bytes.map_or("unknown".into(), |b| format!(
            "{:.0} MiB",
            b as f64 / 1048576.0
        ))
    )
}
