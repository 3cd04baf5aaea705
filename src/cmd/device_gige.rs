//! `gloam device --gige ADDR[:PORT]`: the simulated camera (same sensor,
//! scene/rig, size and seed options as `--pty`) as a GigE Vision device.

use std::io::Write;
use std::net::{Ipv4Addr, SocketAddrV4};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anyhow::{Context, bail};

use gloam_gige::gvcp::GVCP_PORT;
use gloam_gige::{Device, GigeServer, Identity, ServerConfig, StreamFaults};
use gloam_grabber::FrameSource;

use super::device::DeviceArgs;

/// `ADDR` or `ADDR:PORT`, IPv4.
fn parse_addr(s: &str) -> anyhow::Result<SocketAddrV4> {
    if let Ok(a) = s.parse::<SocketAddrV4>() {
        return Ok(a);
    }
    let ip: Ipv4Addr = s
        .parse()
        .with_context(|| format!("--gige '{s}': expected an IPv4 ADDR or ADDR:PORT"))?;
    Ok(SocketAddrV4::new(ip, GVCP_PORT))
}

pub fn run(args: &DeviceArgs, addr: &str) -> anyhow::Result<()> {
    let bind = parse_addr(addr)?;
    let cfg = gloam_sensor::SensorConfig::load_preset_or_file(&args.sensor)
        .with_context(|| format!("sensor '{}'", args.sensor))?;
    let super::device::DeviceSource {
        source,
        view,
        from_scene,
        ..
    } = super::device::device_source(args)?;
    let resizable = !from_scene;
    let info = source.info();
    if info.max_width > 65_535 || info.max_height > 65_535 {
        bail!("frame too large for GigE Vision");
    }
    let facts = gloam_gige::camera_facts(
        &info,
        resizable,
        cfg.timing.frame_rate_hz,
        cfg.mcp.as_ref().map(|m| (m.min_voltage_v, m.max_voltage_v)),
    );
    let serial = args.serial_number;
    let identity = Identity {
        vendor: "gloam".into(),
        model: format!("simulated {}", info.name)
            .chars()
            .take(31)
            .collect(),
        version: env!("CARGO_PKG_VERSION").into(),
        manufacturer_info: format!("{} looking at {view}, seed {}", args.sensor, args.seed)
            .chars()
            .take(47)
            .collect(),
        serial: format!("{serial}"),
        user_name: String::new(),
        // Locally administered unicast MAC carrying the serial number.
        mac: {
            let s = serial.to_be_bytes();
            [0x02, 0x67, s[0], s[1], s[2], s[3]]
        },
        ip: *bind.ip(),
        subnet_mask: Ipv4Addr::new(255, 0, 0, 0),
        gateway: Ipv4Addr::UNSPECIFIED,
    };
    let device = Device::new(identity, facts);
    let server = GigeServer::bind(
        ServerConfig {
            bind,
            faults: StreamFaults {
                loss: args.gvsp_loss,
                reorder: args.gvsp_reorder,
                seed: args.fault_seed,
            },
            resend_store_bytes: 64 << 20,
            report_every: Some(Duration::from_secs(5)),
            link_bits_per_s: 1e9,
        },
        device,
    )
    .with_context(|| format!("binding GVCP on {bind}"))?;
    let local = server.local_addr()?;
    {
        let mut out = std::io::stdout().lock();
        writeln!(out, "{local}")?;
        out.flush()?;
    }
    eprintln!(
        "gloam device: GigE Vision camera '{}' ({view}, seed {}, {}×{}, {} Hz) on {local}; view it with arv-viewer-0.8 — Ctrl-C to stop",
        info.name, args.seed, info.max_width, info.max_height, cfg.timing.frame_rate_hz
    );
    let stop = AtomicBool::new(false);
    server
        .run(Box::new(source) as Box<dyn FrameSource>, &stop)
        .context("serving GigE Vision")
}
