//! `gloam device --pty`: the device emulator on a pseudo-terminal;
//! `gloam device --gige ADDR[:PORT]`: the simulated camera as a GigE Vision
//! device (crate `gloam-gige`). The arguments are `gloam_simcam::cli`'s;
//! what is served (a rig, `--scene`, `--sequence`'s layers mixed per
//! frame) is `gloam_pipeline::cli::device`'s.

use std::io::Write;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, bail};

use gloam_gige::{Device, GigeServer, ServerConfig, StreamFaults};
use gloam_grabber::FrameSource;
use gloam_grabber::emulator::{EmulatorStats, run_emulator};
use gloam_grabber::serial::PtyDevice;
use gloam_pipeline::cli::device::{DeviceSource, device_source};
pub use gloam_simcam::cli::DeviceArgs;

/// Prints the address a client connects to as stdout's first line.
fn announce(what: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(out, "{what}")
        .and_then(|()| out.flush())
        .context("writing to stdout (the device's address, its first line)")
}

fn source(args: &DeviceArgs) -> anyhow::Result<DeviceSource> {
    Ok(device_source(args, &|line| eprintln!("{line}"))?)
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
    let DeviceSource {
        mut source,
        sensor,
        view,
        ..
    } = source(&args)?;
    let info = source.info();
    let pty = PtyDevice::open().context("opening a pseudo-terminal")?;
    let path = pty.slave_path().to_string();
    announce(&path)?;
    eprintln!(
        "gloam device: emulating {} ({view}, seed {}, {}×{}) at {} baud on {path}; connect with --grabber serial:{path} — Ctrl-C to stop",
        sensor, args.seed, info.max_width, info.max_height, args.baud
    );
    let (stats, stop) = (EmulatorStats::default(), AtomicBool::new(false));
    let config = args.emulator_config();
    Ok(run_emulator(pty, &mut source, &config, &stats, &stop)?)
}

/// `--gige ADDR[:PORT]`: the same camera as a GigE Vision device.
fn gige(args: &DeviceArgs, addr: &str) -> anyhow::Result<()> {
    let bind = gloam_gige::parse_bind_addr(addr)
        .with_context(|| format!("--gige '{addr}': expected an IPv4 ADDR or ADDR:PORT"))?;
    let DeviceSource {
        source,
        sensor,
        view,
        from_scene,
    } = source(args)?;
    let info = source.info();
    if info.max_width > 65_535 || info.max_height > 65_535 {
        bail!("frame too large for GigE Vision");
    }
    let mcp_range_v = source
        .config()
        .mcp
        .as_ref()
        .map(|m| (m.min_voltage_v, m.max_voltage_v));
    // A sequence's frame rate is the camera's default (its clock's).
    let rate_hz = source.frame_rate_hz();
    let facts = gloam_gige::camera_facts(&info, !from_scene, rate_hz, mcp_range_v);
    let (name, seed) = (&info.name, args.seed);
    let identity =
        gloam_gige::simulated_identity(name, &sensor, &view, seed, args.serial_number, *bind.ip());
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
