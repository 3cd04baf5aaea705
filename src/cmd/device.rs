//! `gloam device --pty`: the device emulator on a pseudo-terminal;
//! `gloam device --gige ADDR[:PORT]`: the simulated camera as a GigE Vision
//! device (crate `gloam-gige`).

use std::io::Write;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anyhow::{Context, bail};
use clap::Args;

use gloam_grabber::emulator::{DEFAULT_BAUD, EmulatorConfig, EmulatorStats, run_emulator};
use gloam_grabber::faults::FaultConfig;
use gloam_grabber::serial::PtyDevice;
use gloam_grabber::uri::parse_size;
use gloam_simcam::{DEFAULT_RIG_SIZE, SensorSource};

#[derive(Args)]
pub struct DeviceArgs {
    /// Expose the emulated device on a pseudo-terminal; its path (the side a
    /// client opens) is the first line of stdout.
    #[arg(long, conflicts_with = "gige")]
    pub pty: bool,
    /// Serve the simulated camera as a GigE Vision device: GVCP on
    /// ADDR[:PORT] (port 3956 by default), GVSP from the same address.
    #[arg(long, value_name = "ADDR[:PORT]")]
    pub gige: Option<String>,
    /// GigE fault injection: probability of dropping each GVSP packet.
    #[arg(long, default_value_t = 0.0, value_parser = probability)]
    pub gvsp_loss: f64,
    /// GigE fault injection: probability of sending each GVSP packet after
    /// the next one.
    #[arg(long, default_value_t = 0.0, value_parser = probability)]
    pub gvsp_reorder: f64,
    /// Sensor preset (or sensor TOML file) behind the HAL.
    #[arg(long, default_value = "gen2-s20-iccd")]
    pub sensor: String,
    /// Scene file the camera looks at: rendered once by the tracer (default
    /// settings) at the scene camera's resolution, or at --size.
    #[arg(long, conflicts_with = "rig")]
    pub scene: Option<String>,
    /// Calibration rig the camera looks at: uniform, sine, edge, dark.
    #[arg(long)]
    pub rig: Option<String>,
    /// Line rate to emulate (PTYs ignore baud, so the emulator paces itself,
    /// 8N1 = 10 bits per byte).
    #[arg(long, default_value_t = DEFAULT_BAUD)]
    pub baud: u32,
    /// Noise seed of the simulated sensor.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Image size WxH (default 320×240 for a rig, the scene camera's for a
    /// scene).
    #[arg(long, value_parser = parse_size_arg)]
    pub size: Option<(u32, u32)>,
    /// Serial number reported in the handshake.
    #[arg(long, default_value_t = 1)]
    pub serial_number: u32,
    /// Fault injection: probability of dropping each outgoing message.
    #[arg(long, default_value_t = 0.0, value_parser = probability)]
    pub fault_drop: f64,
    /// Fault injection: probability of flipping a bit in each outgoing message.
    #[arg(long, default_value_t = 0.0, value_parser = probability)]
    pub fault_corrupt: f64,
    /// Fault injection: probability of truncating each outgoing message.
    #[arg(long, default_value_t = 0.0, value_parser = probability)]
    pub fault_truncate: f64,
    /// Fault injection: stall the link this long before a message…
    #[arg(long, default_value_t = 0)]
    pub fault_delay_ms: u64,
    /// …with this probability per message.
    #[arg(long, default_value_t = 0.01, value_parser = probability)]
    pub fault_delay_p: f64,
    /// Fault injection: power-cycle the device in the middle of every N-th frame.
    #[arg(long)]
    pub fault_reset_every: Option<u64>,
    /// Seed of the fault generator.
    #[arg(long, default_value_t = 1)]
    pub fault_seed: u64,
}

fn parse_size_arg(s: &str) -> Result<(u32, u32), String> {
    parse_size(s).ok_or_else(|| format!("'{s}' is not WxH with 1..4096 each"))
}

/// What a device serves, from `--scene` or `--rig`: the source, a label
/// for messages, its frame size, and whether it came from a scene (a
/// rendered scene has a fixed size; a rig can be resized).
pub(super) struct DeviceSource {
    pub source: SensorSource,
    pub view: String,
    pub size: (u32, u32),
    pub from_scene: bool,
}

/// The source both `--pty` and `--gige` serve.
pub(super) fn device_source(args: &DeviceArgs) -> anyhow::Result<DeviceSource> {
    Ok(match &args.scene {
        Some(path) => {
            eprintln!("gloam device: rendering {path} …");
            let scene = gloam_pipeline::render_scene_view(path, &args.sensor, args.size)
                .with_context(|| format!("rendering scene '{path}'"))?;
            let size = scene.size();
            let source = SensorSource::with_scene(&args.sensor, scene, args.seed)
                .with_context(|| format!("sensor '{}'", args.sensor))?;
            DeviceSource {
                source,
                view: format!("scene '{path}'"),
                size,
                from_scene: true,
            }
        }
        None => {
            let rig = args
                .rig
                .as_deref()
                .unwrap_or(gloam_grabber::uri::DEFAULT_RIG);
            let size = args.size.unwrap_or(DEFAULT_RIG_SIZE);
            let source = SensorSource::new(&args.sensor, rig, args.seed, size)
                .with_context(|| format!("sensor '{}'", args.sensor))?;
            DeviceSource {
                source,
                view: format!("rig '{rig}'"),
                size,
                from_scene: false,
            }
        }
    })
}

fn probability(s: &str) -> Result<f64, String> {
    let p: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if (0.0..=1.0).contains(&p) {
        Ok(p)
    } else {
        Err(format!("{p} is not a probability in 0..=1"))
    }
}

pub fn run(args: DeviceArgs) -> anyhow::Result<()> {
    if let Some(addr) = args.gige.clone() {
        return super::device_gige::run(&args, &addr);
    }
    if !args.pty {
        bail!("say --pty (pseudo-terminal) or --gige ADDR[:PORT] (GigE Vision)");
    }
    if args.baud == 0 {
        bail!("--baud must be positive");
    }
    let DeviceSource {
        mut source,
        view,
        size,
        ..
    } = device_source(&args)?;
    let pty = PtyDevice::open().context("opening a pseudo-terminal")?;
    let path = pty.slave_path().to_string();
    {
        let mut out = std::io::stdout().lock();
        writeln!(out, "{path}")?;
        out.flush()?;
    }
    eprintln!(
        "gloam device: emulating {} ({view}, seed {}, {}×{}) at {} baud on {path}; connect with --grabber serial:{path} — Ctrl-C to stop",
        args.sensor, args.seed, size.0, size.1, args.baud
    );
    let config = EmulatorConfig {
        baud: Some(args.baud),
        faults: FaultConfig {
            drop: args.fault_drop,
            corrupt: args.fault_corrupt,
            truncate: args.fault_truncate,
            delay_p: if args.fault_delay_ms > 0 {
                args.fault_delay_p
            } else {
                0.0
            },
            delay: Duration::from_millis(args.fault_delay_ms),
            seed: args.fault_seed,
        },
        reset_every: args.fault_reset_every.filter(|n| *n > 0),
        serial_number: args.serial_number,
    };
    let stats = EmulatorStats::default();
    let stop = AtomicBool::new(false);
    Ok(run_emulator(pty, &mut source, &config, &stats, &stop)?)
}
