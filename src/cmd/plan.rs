//! `gloam plan SCENE [--json]`: which effects a render of the scene simulates
//! and why (see `gloam_scene::plan`).

pub use gloam_pipeline::cli::PlanArgs;

use super::output::print_json;

pub fn run(args: PlanArgs) -> anyhow::Result<()> {
    // The scene error already reads `file:line: field: message`.
    let scene = gloam_scene::load(&args.scene)?;
    let settings = args.settings().settings()?;
    let (plan, prep) = gloam_trace::plan::effect_plan_observed(
        &scene,
        &settings,
        super::progress::prep_spinner(),
    )?;
    if args.json {
        let mut v = serde_json::to_value(&plan)?;
        v["preparation"] = serde_json::to_value(&prep)?;
        print_json(&v)?;
    } else {
        let n = |k: usize, what: &str| format!("{k} {what}{}", if k == 1 { "" } else { "s" });
        let shared = scene.counts().shared_facets;
        outln!(
            "{}: {}{}, {}, {}, units {}",
            args.scene.display(),
            n(scene.facets.len(), "facet"),
            if shared > 0 {
                format!(" (+ {shared} placed by shared instances)")
            } else {
                String::new()
            },
            n(scene.point_sources.len(), "point source"),
            n(scene.bands.len(), "band"),
            scene.units.as_str()
        );
        outln!();
        out!("{plan}");
        outln!();
        outln!("{}", preparation_line(&prep));
    }
    Ok(())
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
