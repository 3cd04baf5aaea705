//! `gloam sequence SEQ --out DIR …`: a night that changes, through a camera.
//!
//! Renders the sequence's scene into one layer per light group — once, or,
//! with moving bodies (`[[move]]`), once per distinct pose of the bodies —
//! and captures the frames from the layers mixed at each frame's weights
//! ([`capture_scene_sequence`]): the frames, `frames.jsonl`,
//! `frames-preview.png`, the animated `frames-preview-animated.png`,
//! `gain-over-time.png`, frame 0's layers (`layers.npy`, `layers.json`, as
//! `render --layers` writes them) and `report.json`. No ordinary image is
//! rendered: the layers sum to it.

use std::time::Instant;

use gloam_io::OutputSet;
pub use gloam_pipeline::cli::SequenceArgs;
use gloam_pipeline::sequence::{
    ANIMATION_MAX_FRAMES, ANIMATION_MAX_WIDTH_PX, SceneSequence, capture_scene_sequence,
};
use gloam_pipeline::{FrameContext, Provenance};

use super::output::write_atomic;

pub fn run(args: SequenceArgs) -> anyhow::Result<()> {
    let t_start = Instant::now();
    let mut provenance = Provenance::of_this_run();
    let set = OutputSet::begin(&args.out, args.force, false)?;
    let dir = set.dir().to_path_buf();
    let t_load = Instant::now();
    let mut sequence = gloam_scene::sequence::load_sequence(&args.sequence)?;
    let mut scene = gloam_scene::load(&sequence.scene)?;
    sequence.bind_sky(&mut scene)?;
    for w in sequence.sky.iter().flat_map(|c| &c.warnings) {
        eprintln!("{w}");
    }
    let load_s = t_load.elapsed().as_secs_f64();
    // Refused before any render: a group or moving table the scene lacks
    // (the camera's video rate is checked before the first render too).
    let groups = scene.light_groups.groups.iter().map(|g| g.name.as_str());
    sequence.check_groups(groups)?;
    sequence.check_moves(&scene)?;
    // `--target-error camera[:K]`: each pose's layers sampled until the
    // render's error is under K of the camera's noise at the brightest
    // frame each pixel sees (camera_goal.rs); its first round 2 spp.
    let camera_k = args.settings.camera_target();
    let (settings, _) = (args.settings).with_default_error(args.settings.settings()?, false);
    let (camera, capture) = args.capture(&sequence, &scene, settings.seed)?;
    if camera_k.is_some() && !capture.noise {
        anyhow::bail!(
            "--target-error camera with --no-noise: frames without temporal noise hide no render error; give --target-error E (a relative error) or --spp N"
        );
    }

    let bar = super::progress::TileBar::new();
    let job = SceneSequence {
        sequence: &sequence,
        scene: &scene,
        settings: &settings,
        observer: super::progress::prep_spinner(),
        progress: &|d, t| bar.progress(d, t),
        camera_k,
        keep_sky_renders: false,
    };
    let context = FrameContext {
        camera: Some(camera.to_string()),
        seed: Some(settings.seed),
        provenance: Some(provenance.clone()),
        scene_utc: gloam_pipeline::frames::scene_utc(&scene),
        ..FrameContext::default()
    };
    let captured = capture_scene_sequence(&job, &capture, &dir, context)?;
    bar.finish();
    for line in &captured.report.notes {
        eprintln!("{line}");
    }

    let t_write = Instant::now();
    let layers = &captured.first;
    let (radiance, std_error) = layers.stacked();
    gloam_pipeline::output::write_npy(&dir.join("layers.npy"), &radiance)?;
    gloam_pipeline::output::write_npy(&dir.join("layers_stderr.npy"), &std_error)?;
    provenance.add_inputs_read();
    let mut index = layers.json(settings.seed);
    index["pose"] = serde_json::json!({
        "frame": 0,
        "moves": captured.first_poses,
        "note": "the layers of frame 0's pose; with [[move]] each distinct pose was rendered so (report.json sequence.renders)",
    });
    index["provenance"] = serde_json::to_value(&provenance)?;
    write_atomic(
        &dir.join("layers.json"),
        serde_json::to_string_pretty(&index)?.as_bytes(),
    )?;
    let write_s = t_write.elapsed().as_secs_f64();

    let r = &captured.report;
    let renders = r.renders.clone().unwrap_or_default();
    // With a sky clock: how the AGC held the median over the sky's light.
    let agc_over_sky = match sequence.sky.is_some() && !r.medians_above_black_dn.is_empty() {
        true => gloam_sensor::load_preset_or_file(camera)
            .ok()
            .and_then(|c| c.agc)
            .and_then(|agc| gloam_pipeline::sequence::agc_over_sky(r, &agc)),
        false => None,
    };
    let frames = f64::from(r.frames.max(1));
    let first_out = layers.outputs.first();
    let report = serde_json::json!({
        "scene": sequence.scene.display().to_string(),
        "units": scene.units.as_str(),
        "image": {
            "width": scene.camera.width,
            "height": scene.camera.height,
            "bands": first_out.map(|o| o.band_names.clone()),
        },
        "settings": first_out.map(|o| &o.settings),
        "effect_plan": captured.plan,
        "sequence": {
            "file": args.sequence.display().to_string(),
            "frames": r.frames,
            "frame_rate_hz": r.frame_rate_hz,
            "groups": r.groups,
            "camera": camera,
            "moves": sequence.moves.iter().map(|m| serde_json::json!({
                "objects": m.objects,
                "point_sources": m.point_sources,
                "keys": m.keys.len(),
            })).collect::<Vec<_>>(),
            "renders": renders,
            "sky": sequence.sky.as_ref().map(|c| serde_json::json!({
                "utc_at_start": c.start.map(|t| t.to_iso8601()),
                "time_scale": c.time_scale,
                "renders": c.key_times_s.iter().zip(&c.key_sun_deg).zip(&c.key_lux)
                    .map(|((&t, &sun), &lux)| serde_json::json!({
                        "time_s": t,
                        "utc": sequence.sky_instant_at(t).map(|u| u.to_iso8601()),
                        "sun_elevation_deg": sun,
                        "horizontal_lux": lux,
                    })).collect::<Vec<_>>(),
                "photocells": sequence.groups.iter()
                    .filter_map(|(g, t)| t.photocell.map(|p| (g, p, t)))
                    .map(|(g, p, t)| (g.clone(), serde_json::json!({
                        "on_lux": p.on_lux,
                        "run_up_s": p.run_up_s,
                        "keys": t.keys,
                    })))
                    .collect::<serde_json::Map<_, _>>(),
                "agc": agc_over_sky,
                "warnings": c.warnings,
                "method": "the scene rendered at each instant of `renders` (the sky's clock: utc_at_start + time_scale × t), each frame's layers taken pixel by pixel geometrically between the two renders around its mid-exposure (a^(1-f) b^f; linearly where either is 0); photocells switch on the sky model's horizontal illuminance at the site",
            })),
            "outputs": {
                "frames.jsonl": "one line per frame; its `sequence` gives time_s, window_s and each light group's mean intensity over the exposure",
                "gain-over-time.png": "the gain in effect per frame",
                "frames-preview-animated.png": format!(
                    "APNG: the frames (at most {ANIMATION_MAX_FRAMES}, at most {ANIMATION_MAX_WIDTH_PX} px wide), each black level to clip"
                ),
                "layers.npy": "frame 0's pose: group × band × row × column, W m⁻² sr⁻¹ (their sum is the still render of that pose)",
            },
            "timings_s": {
                "load": load_s,
                "layered_render": renders.seconds,
                "layered_render_per_pose": renders.seconds / (renders.renders.max(1) as f64),
                "mix": r.mix_s,
                "camera": r.camera_s,
                "write_layers": write_s,
                "mix_per_frame_ms": 1e3 * r.mix_s / frames,
                "camera_per_frame_ms": 1e3 * r.camera_s / frames,
            },
            "method": "each distinct pose of the moving bodies (at each frame's mid-exposure; one pose without [[move]]) rendered once, in one pass that attributes each path's light to its emitter's light group (one layer per group, the still render's samples and random numbers), the whole scene moved, so each pose's layers sum to the still render of that pose; frame i mixes its pose's layers' detected radiance with the groups' mean intensities over its exposure window and runs it through one camera, whose AGC, lag and bright-source protection carry over between frames",
        },
        "sensor_capture": r.sensor_capture,
        "provenance": provenance,
    });
    let mut report = report;
    // Frame 0's pose's (each pose's own is under sequence.renders.poses).
    let target = renders.poses.first().and_then(|p| p.camera_target.clone());
    if let Some(t) = &target {
        report["camera_target"] = t.clone();
    }
    write_atomic(
        &dir.join("report.json"),
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    set.publish(&provenance, None)?;

    if let (Some(k), Some(t)) = (camera_k, &target) {
        let pct = |key: &str| 100.0 * t[key].as_f64().unwrap_or(f64::NAN);
        eprintln!(
            "--target-error camera:{k}: frame 0's pose rendered until, at each pixel's brightest frame, its variance is under {:.0} % of the camera's frame variance at gain {:.4}: added {:.1} % (median), {:.1} % (99th percentile); mean {:.1} spp",
            100.0 * k * k,
            t["gain"].as_f64().unwrap_or(f64::NAN),
            pct("added_variance_fraction_median"),
            pct("added_variance_fraction_p99"),
            t["mean_spp"].as_f64().unwrap_or(f64::NAN),
        );
    }
    if let Some(c) = &sequence.sky {
        let (n, lux, sun) = (c.key_lux.len(), &c.key_lux, &c.key_sun_deg);
        if n > 0 {
            eprintln!(
                "sky: {} renders from {} ({:.2}°, {:.3e} lx) to {} ({:.2}°, {:.3e} lx), {}× time",
                n,
                sequence
                    .sky_instant_at(0.0)
                    .map_or_else(String::new, |t| t.to_iso8601()),
                sun[0],
                lux[0],
                (sequence.sky_instant_at(sequence.duration_s()))
                    .map_or_else(String::new, |t| t.to_iso8601()),
                sun[n - 1],
                lux[n - 1],
                c.time_scale
            );
        }
    }
    // A loop that never reached its set range has no frame "from" which it
    // held, nor a range of medians or light: said so, not `frame -1 (NaN
    // s)`, `inf–-inf` and `NaN decades`.
    if let Some(a) = agc_over_sky.as_ref() {
        let head = format!(
            "AGC ({:?} metering, set point {} DN): the median",
            a.metering, a.set_point_dn
        );
        let range = gloam_pipeline::sequence::AGC_SET_RANGE_FACTOR;
        match (a.held_from_frame, a.held_from_s) {
            (Some(frame), Some(s)) => eprintln!(
                "{head} within ×/÷{range} of it in {} of {} frames from frame {frame} ({s:.2} s) on, {:.3}–{:.3} of the set point, over {:.3e} → {:.3e} lx ({:.2} decades)",
                a.frames_in_range,
                a.frames_after,
                a.median_over_set_point[0],
                a.median_over_set_point[1],
                a.lux_range[0],
                a.lux_range[1],
                a.decades
            ),
            _ => eprintln!(
                "{head} never came within ×/÷{range} of it in {} frames",
                r.frames
            ),
        }
    }
    let gains = r.gain_over_time.iter().map(|g| g.1);
    let (lo, hi) = gains.fold((f64::INFINITY, 0.0f64), |(l, h), g| (l.min(g), h.max(g)));
    eprintln!(
        "sequence: {} frames at {} Hz through '{camera}', {} light groups; {} layered render{} ({} pose{} of {} moving bod{}, {} frames reused a render) {:.2} s, {:.2} s a render; mixing {:.2} ms/frame, camera {:.1} ms/frame; gain in effect {:.4}–{:.4}; {:.2} s in all → {}",
        r.frames,
        r.frame_rate_hz,
        r.groups.len(),
        renders.renders,
        if renders.renders == 1 { "" } else { "s" },
        renders.poses.len(),
        if renders.poses.len() == 1 { "" } else { "s" },
        sequence.moves.len(),
        if sequence.moves.len() == 1 {
            "y"
        } else {
            "ies"
        },
        renders.frames.saturating_sub(renders.renders as u32),
        renders.seconds,
        renders.seconds / (renders.renders.max(1) as f64),
        1e3 * r.mix_s / frames,
        1e3 * r.camera_s / frames,
        lo,
        hi,
        t_start.elapsed().as_secs_f64(),
        args.out.display()
    );
    Ok(())
}
