//! `gloam device --pty`: the device emulator on a pseudo-terminal;
//! `gloam device --gige ADDR[:PORT]`: the simulated camera as a GigE Vision
//! device (crate `gloam-gige`). The arguments are `gloam_simcam::cli`'s.
//! With `--sequence` either serves a night that changes: the sequence's
//! light-group layers mixed per frame (`SceneImage::Layers`).

use std::io::Write;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, bail};

use gloam_gige::{Device, GigeServer, ServerConfig, StreamFaults};
use gloam_grabber::FrameSource;
use gloam_grabber::emulator::{EmulatorStats, run_emulator};
use gloam_grabber::serial::PtyDevice;
pub use gloam_simcam::cli::DeviceArgs;
use gloam_simcam::{DEFAULT_RIG_SIZE, LayerWeights, SceneImage, SceneView, SensorSource};

/// `--sequence`: its scene's light-group layers, rendered once for the
/// camera, and the sequence's weights for any exposure window (looped over
/// its frames with `--loop`, else its last intensities held).
fn sequence_view(args: &DeviceArgs, path: &str) -> anyhow::Result<SceneView> {
    let seq = gloam_scene::sequence::load_sequence(Path::new(path))
        .with_context(|| format!("sequence '{path}'"))?;
    seq.check_static("gloam device --sequence")?;
    let scene = seq.scene.to_string_lossy().into_owned();
    eprintln!("gloam device: rendering the light groups of {scene} …");
    let (groups, layers) =
        gloam_pipeline::scene_view::render_scene_layers(&scene, &args.sensor, args.size)
            .with_context(|| format!("rendering the layers of scene '{scene}'"))?;
    seq.check_groups(groups.iter().map(String::as_str))?;
    let duration_s = f64::from(seq.frames) / seq.frame_rate_hz;
    let looped = args.loop_sequence;
    let frame_rate_hz = seq.frame_rate_hz;
    let weights = move |t0: f64, t1: f64| {
        let (start, width) = (
            if looped {
                t0.rem_euclid(duration_s)
            } else {
                t0
            },
            t1 - t0,
        );
        seq.weights(groups.iter().map(String::as_str), start, start + width)
    };
    Ok(SceneView {
        label: path.to_string(),
        image: SceneImage::Layers {
            e_s_m2_sr: layers,
            frame_rate_hz,
            weights: LayerWeights(Arc::new(weights)),
        },
    })
}

/// The source both `--pty` and `--gige` serve, from `--scene`,
/// `--sequence` or `--rig`, a label for messages, and whether it is a
/// (fixed-size) rendered scene.
fn device_source(args: &DeviceArgs) -> anyhow::Result<(SensorSource, String, bool)> {
    let sensor = || format!("sensor '{}'", args.sensor);
    if let Some(path) = &args.sequence {
        let view = sequence_view(args, path)?;
        let source =
            SensorSource::with_scene(&args.sensor, view, args.seed).with_context(sensor)?;
        return Ok((source, format!("sequence '{path}'"), true));
    }
    Ok(match &args.scene {
        Some(path) => {
            eprintln!("gloam device: rendering {path} …");
            let scene = gloam_pipeline::render_scene_view(path, &args.sensor, args.size)
                .with_context(|| format!("rendering scene '{path}'"))?;
            if let Some(note) = gloam_pipeline::scene_view_fit_note(&scene, &args.sensor) {
                eprintln!("warning: {note}");
            }
            let source =
                SensorSource::with_scene(&args.sensor, scene, args.seed).with_context(sensor)?;
            (source, format!("scene '{path}'"), true)
        }
        None => {
            let rig = (args.rig.as_deref()).unwrap_or(gloam_simcam::DEFAULT_RIG);
            let size = args.size.unwrap_or(DEFAULT_RIG_SIZE);
            let source =
                SensorSource::new(&args.sensor, rig, args.seed, size).with_context(sensor)?;
            (source, format!("rig '{rig}'"), false)
        }
    })
}

/// Prints the address a client connects to as stdout's first line.
fn announce(what: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(out, "{what}")?;
    Ok(out.flush()?)
}

pub fn run(args: DeviceArgs) -> anyhow::Result<()> {
    if let Some(addr) = &args.gige {
        return gige(&args, addr);
    }
    if !args.pty {
        bail!("say --pty (pseudo-terminal) or --gige ADDR[:PORT] (GigE Vision)");
    }
    if args.baud == 0 {
        bail!("--baud must be positive");
    }
    let (mut source, view, _) = device_source(&args)?;
    let info = source.info();
    let pty = PtyDevice::open().context("opening a pseudo-terminal")?;
    let path = pty.slave_path().to_string();
    announce(&path)?;
    eprintln!(
        "gloam device: emulating {} ({view}, seed {}, {}×{}) at {} baud on {path}; connect with --grabber serial:{path} — Ctrl-C to stop",
        args.sensor, args.seed, info.max_width, info.max_height, args.baud
    );
    let (stats, stop) = (EmulatorStats::default(), AtomicBool::new(false));
    let config = args.emulator_config();
    Ok(run_emulator(pty, &mut source, &config, &stats, &stop)?)
}

/// `--gige ADDR[:PORT]`: the same camera as a GigE Vision device.
fn gige(args: &DeviceArgs, addr: &str) -> anyhow::Result<()> {
    let bind = gloam_gige::parse_bind_addr(addr)
        .with_context(|| format!("--gige '{addr}': expected an IPv4 ADDR or ADDR:PORT"))?;
    let cfg = gloam_sensor::SensorConfig::load_preset_or_file(&args.sensor)
        .with_context(|| format!("sensor '{}'", args.sensor))?;
    let (source, view, from_scene) = device_source(args)?;
    let info = source.info();
    if info.max_width > 65_535 || info.max_height > 65_535 {
        bail!("frame too large for GigE Vision");
    }
    let mcp_range_v = cfg.mcp.as_ref().map(|m| (m.min_voltage_v, m.max_voltage_v));
    // A sequence's frame rate is the camera's default (its clock's).
    let rate_hz = source.frame_rate_hz();
    let facts = gloam_gige::camera_facts(&info, !from_scene, rate_hz, mcp_range_v);
    let (name, seed) = (&info.name, args.seed);
    let identity = gloam_gige::simulated_identity(
        name,
        &args.sensor,
        &view,
        seed,
        args.serial_number,
        *bind.ip(),
    );
    let faults = StreamFaults {
        loss: args.gvsp_loss,
        reorder: args.gvsp_reorder,
        seed: args.fault_seed,
    };
    let mut device = Device::new(identity, facts);
    // `GloamStimulus` reads what the camera shows from the start (a rig's).
    if let Some(s) = source.stimulus() {
        device.show_stimulus(s);
    }
    let server = GigeServer::bind(ServerConfig::simulated(bind, faults), device)
        .with_context(|| format!("binding GVCP on {bind}"))?;
    let local = server.local_addr()?;
    announce(&local.to_string())?;
    eprintln!(
        "gloam device: GigE Vision camera '{name}' ({view}, seed {seed}, {}×{}, {rate_hz} Hz) on {local}; view it with arv-viewer-0.8 — Ctrl-C to stop",
        info.max_width, info.max_height
    );
    let stop = AtomicBool::new(false);
    let source = Box::new(source) as Box<dyn FrameSource>;
    server.run(source, &stop).context("serving GigE Vision")
}
