//! `gloam plan SCENE [--json]`: which effects a render of the scene simulates
//! and why (see `gloam_scene::plan`).

pub use gloam_pipeline::cli::PlanArgs;
use gloam_pipeline::cli::print::{estimate_line, preparation_line, scene_line};

use super::print_json;

pub fn run(args: PlanArgs) -> anyhow::Result<()> {
    // The scene error already reads `file:line: field: message`.
    let scene = gloam_scene::load(&args.scene, &gloam_io::ReadLog::off())?;
    let settings = args.settings().settings()?;
    // Checked before the plan's preparation: a bad camera is refused now,
    // the scene's own `sensor` at its line (render would refuse it).
    let off = gloam_io::ReadLog::off();
    gloam_pipeline::resolve_scene_sensor(args.sensor.as_deref(), &scene, &args.scene, &off)?;
    let camera_target = args.camera_target(&scene, &off)?;
    let (plan, prep) = gloam_trace::plan::effect_plan_observed(
        &scene,
        &settings,
        super::progress::prep_spinner(),
    )?;
    // `--target-error camera[:K]`: what a camera run would cost, before it.
    let estimate = match &camera_target {
        Some((k, sensor)) => {
            let spp_fixed = args.settings().names_spp();
            let capture = args.capture(sensor);
            Some(gloam_pipeline::camera_goal::estimate(
                &scene, &settings, spp_fixed, &capture, *k,
            )?)
        }
        None => None,
    };
    if args.json {
        let mut v = serde_json::to_value(&plan)?;
        v["preparation"] = serde_json::to_value(&prep)?;
        if let Some(e) = &estimate {
            v["camera_target_estimate"] = serde_json::to_value(e)?;
        }
        return print_json(&v);
    }
    outln!("{}", scene_line(&args.scene, &scene));
    outln!();
    out!("{plan}");
    outln!();
    outln!("{}", preparation_line(&prep));
    if let (Some(e), Some((_, sensor))) = (&estimate, &camera_target) {
        outln!("{}", estimate_line(e, sensor.name()));
    }
    Ok(())
}
