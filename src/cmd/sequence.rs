//! `gloam sequence SEQ --out DIR …`: a night that changes, through a camera.
//!
//! Renders the sequence's scene once into one layer per light group
//! (`layers.npy`, `layers.json`, and the ordinary render's files, as
//! `render --layers` writes them), then captures the sequence's frames from
//! the layers mixed at each frame's weights ([`capture_sequence`]): the
//! frames, `frames.jsonl`, `frames-preview.png`, the animated
//! `frames-preview-animated.png`, `gain-over-time.png` and `report.json`.

use std::time::Instant;

pub use gloam_pipeline::cli::SequenceArgs;
use gloam_pipeline::render::RenderJob;
use gloam_pipeline::sequence::{
    ANIMATION_MAX_FRAMES, ANIMATION_MAX_WIDTH_PX, capture_sequence, check_video_rate,
};
use gloam_pipeline::{FrameContext, OutputSet, Provenance};

use super::output::write_atomic;

pub fn run(args: SequenceArgs) -> anyhow::Result<()> {
    let t_start = Instant::now();
    let mut provenance = Provenance::of_this_run();
    let set = OutputSet::begin(&args.out, args.force, false)?;
    let dir = set.dir().to_path_buf();
    let t_load = Instant::now();
    let sequence = gloam_scene::sequence::load_sequence(&args.sequence)?;
    let scene = gloam_scene::load(&sequence.scene)?;
    let load_s = t_load.elapsed().as_secs_f64();
    let groups: Vec<String> = (scene.light_groups.groups.iter())
        .map(|g| g.name.clone())
        .collect();
    // Refused before the render: a group the scene lacks, a camera whose
    // video standard cannot run at the sequence's rate.
    sequence.check_groups(groups.iter().map(String::as_str))?;
    let settings = args.settings.settings()?;
    let (camera, capture) = args.capture(&sequence, &scene, settings.seed)?;
    let config = gloam_sensor::load_preset_or_file(camera)
        .map_err(|e| anyhow::anyhow!(e).context(format!("camera '{camera}'")))?;
    check_video_rate(&sequence, camera, &config)?;

    let job = RenderJob {
        camera: Some(camera),
        observer: super::progress::prep_spinner(),
        layers: true,
        ..RenderJob::new(&scene, &settings)
    };
    let prepared = job.prepare()?;
    let rendered = super::progress::render_with_bar(prepared, None)?;
    let layers =
        (rendered.layers.as_ref()).ok_or_else(|| anyhow::anyhow!("the render made no layers"))?;
    let detected = (layers.detected.as_ref())
        .ok_or_else(|| anyhow::anyhow!("the layered render carried no detected band"))?;

    let t_write = Instant::now();
    rendered.write_images(&dir)?;
    let write_s = t_write.elapsed().as_secs_f64();
    provenance.add_inputs_read();
    let mut index = layers.json(settings.seed);
    index["provenance"] = serde_json::to_value(&provenance)?;
    write_atomic(
        &dir.join("layers.json"),
        serde_json::to_string_pretty(&index)?.as_bytes(),
    )?;

    let context = FrameContext {
        camera: Some(camera.to_string()),
        seed: Some(settings.seed),
        provenance: Some(provenance.clone()),
    };
    let captured = capture_sequence(&sequence, &groups, detected, &capture, &dir, context)?;
    for line in &captured.notes {
        eprintln!("{line}");
    }

    let still_s = rendered.radiance.stats.trace_seconds;
    let frames = f64::from(captured.frames.max(1));
    let mut report = rendered.report_json(&sequence.scene, &scene, load_s, write_s);
    report["sequence"] = serde_json::json!({
        "file": args.sequence.display().to_string(),
        "frames": captured.frames,
        "frame_rate_hz": captured.frame_rate_hz,
        "groups": captured.groups,
        "camera": camera,
        "outputs": {
            "frames.jsonl": "one line per frame; its `sequence` gives time_s, window_s and each light group's mean intensity over the exposure",
            "gain-over-time.png": "the gain in effect per frame",
            "frames-preview-animated.png": format!(
                "APNG: the frames (at most {ANIMATION_MAX_FRAMES}, at most {ANIMATION_MAX_WIDTH_PX} px wide), each black level to clip"
            ),
        },
        "timings_s": {
            "still_render": still_s,
            "layered_render": layers.seconds,
            "layered_over_still": layers.seconds / still_s.max(1e-9),
            "mix": captured.mix_s,
            "camera": captured.camera_s,
            "mix_per_frame_ms": 1e3 * captured.mix_s / frames,
            "camera_per_frame_ms": 1e3 * captured.camera_s / frames,
        },
        "method": "the scene rendered in one pass that gives the still and one layer per light group (each path's light attributed to its emitter's group; layered_render is that pass, still_render its trace time); frame i mixes the layers' detected radiance with the groups' mean intensities over its exposure window and runs it through one camera, whose AGC, lag and bright-source protection carry over between frames",
    });
    report["sensor_capture"] = captured.sensor_capture.clone();
    report["provenance"] = serde_json::to_value(&provenance)?;
    write_atomic(
        &dir.join("report.json"),
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    set.publish(&provenance, None)?;

    let gains = captured.gain_over_time.iter().map(|g| g.1);
    let (lo, hi) = gains.fold((f64::INFINITY, 0.0f64), |(l, h), g| (l.min(g), h.max(g)));
    eprintln!(
        "sequence: {} frames at {} Hz through '{camera}', {} light groups; still render {:.2} s, layers {:.2} s ({:.1}× the still), mixing {:.2} ms/frame, camera {:.1} ms/frame; gain in effect {:.4}–{:.4}; {:.2} s in all → {}",
        captured.frames,
        captured.frame_rate_hz,
        captured.groups.len(),
        still_s,
        layers.seconds,
        layers.seconds / still_s.max(1e-9),
        1e3 * captured.mix_s / frames,
        1e3 * captured.camera_s / frames,
        lo,
        hi,
        t_start.elapsed().as_secs_f64(),
        args.out.display()
    );
    Ok(())
}
