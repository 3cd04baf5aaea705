//! The command-line arguments of `gloam device` (feature `cli`): which
//! simulated camera a device serves, over which link, with which faults.

use std::time::Duration;

use clap::Args;
use gloam_grabber::emulator::{DEFAULT_BAUD, EmulatorConfig};
use gloam_grabber::faults::FaultConfig;
use gloam_grabber::uri::parse_size;

#[derive(Args)]
pub struct DeviceArgs {
    /// Expose the emulated device on a pseudo-terminal; its path (the side a
    /// client opens) is the first line of stdout. The GigE faults are not
    /// its (a flag that would be ignored is refused).
    #[arg(long, conflicts_with_all = ["gige", "gvsp_loss", "gvsp_reorder"])]
    pub pty: bool,
    /// Serve the simulated camera as a GigE Vision device: GVCP on
    /// ADDR[:PORT] (port 3956 by default), GVSP from the same address, with
    /// GenICam SFNC features and per-frame chunk data; any GenICam client
    /// (Aravis, gloam's own genicam: grabber) streams from it.
    /// The serial link's line rate and faults are not its (a flag that
    /// would be ignored is refused).
    #[arg(
        long,
        value_name = "ADDR[:PORT]",
        conflicts_with_all = [
            "baud",
            "fault_drop",
            "fault_corrupt",
            "fault_truncate",
            "fault_delay_ms",
            "fault_delay_p",
            "fault_reset_every",
        ]
    )]
    pub gige: Option<String>,
    /// GigE fault injection: probability of dropping each GVSP packet.
    #[arg(long, default_value_t = 0.0, value_parser = probability)]
    pub gvsp_loss: f64,
    /// GigE fault injection: probability of sending each GVSP packet after
    /// the next one.
    #[arg(long, default_value_t = 0.0, value_parser = probability)]
    pub gvsp_reorder: f64,
    /// Sensor preset (or sensor TOML file) behind the HAL. Default: the
    /// scene's (or the sequence scene's) own `sensor` entry, as `render`
    /// and `sequence` take it, else gen2-s20-iccd.
    #[arg(long, value_parser = gloam_sensor::cli::preset_or_file())]
    pub sensor: Option<String>,
    /// Scene file the camera looks at: rendered once by the tracer (default
    /// settings) at the scene camera's resolution, or at --size.
    #[arg(long, conflicts_with = "rig")]
    pub scene: Option<String>,
    /// Calibration rig the camera looks at: uniform, sine, edge, dark.
    #[arg(long)]
    pub rig: Option<String>,
    /// Sequence file (TOML) the camera looks at live: its scene's light
    /// groups are rendered once, one layer each, and every frame mixes them
    /// with the sequence's intensities over that frame's exposure (frame k
    /// at k / the sequence's frame rate, which becomes the camera's default
    /// rate; the clock restarts with each acquisition). After the
    /// sequence's last frame its last intensities hold (flicker runs on),
    /// unless --loop.
    #[arg(long, value_name = "SEQ", conflicts_with_all = ["scene", "rig"])]
    pub sequence: Option<String>,
    /// With --sequence: start the sequence over after its last frame.
    #[arg(long = "loop", requires = "sequence")]
    pub loop_sequence: bool,
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
    /// Fault injection: stall the link this long before a message (at most
    /// 600 000 ms, ten minutes)…
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u64).range(0..=600_000))]
    pub fault_delay_ms: u64,
    /// …with this probability per message.
    #[arg(long, default_value_t = 0.01, value_parser = probability)]
    pub fault_delay_p: f64,
    /// Fault injection: power-cycle the device in the middle of every N-th
    /// frame (N ≥ 1; 0 used to mean "never" without a word).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub fault_reset_every: Option<u64>,
    /// Seed of the fault generator.
    #[arg(long, default_value_t = 1)]
    pub fault_seed: u64,
}

/// A flag value clap refuses, said as the value.
#[derive(Debug)]
struct BadValue(String);

impl std::fmt::Display for BadValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadValue {}

fn parse_size_arg(s: &str) -> Result<(u32, u32), BadValue> {
    parse_size(s).ok_or_else(|| BadValue(format!("'{s}' is not WxH with 1..4096 each")))
}

fn probability(s: &str) -> Result<f64, BadValue> {
    let p: f64 = s
        .parse()
        .map_err(|_| BadValue(format!("'{s}' is not a number")))?;
    if (0.0..=1.0).contains(&p) {
        Ok(p)
    } else {
        Err(BadValue(format!("{p} is not a probability in 0..=1")))
    }
}

/// The camera of a device given no `--sensor` and no scene naming one.
pub const DEFAULT_DEVICE_SENSOR: &str = "gen2-s20-iccd";

impl DeviceArgs {
    /// The emulator's link and faults (`--pty`): a delay probability
    /// counts only with a delay, and `--fault-reset-every 0` means never.
    pub fn emulator_config(&self) -> EmulatorConfig {
        EmulatorConfig {
            baud: Some(self.baud),
            faults: FaultConfig {
                drop: self.fault_drop,
                corrupt: self.fault_corrupt,
                truncate: self.fault_truncate,
                delay_p: if self.fault_delay_ms > 0 {
                    self.fault_delay_p
                } else {
                    0.0
                },
                delay: Duration::from_millis(self.fault_delay_ms),
                seed: self.fault_seed,
            },
            reset_every: self.fault_reset_every.filter(|n| *n > 0),
            serial_number: self.serial_number,
        }
    }
}
