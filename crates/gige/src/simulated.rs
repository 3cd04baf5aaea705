//! What `gloam device --gige` serves beyond the frames: the simulated
//! camera's bootstrap identity, the address to bind and the server's
//! defaults for a simulated camera on a GigE link.

use std::net::{AddrParseError, Ipv4Addr, SocketAddrV4};
use std::time::Duration;

use crate::device::Identity;
use crate::gvcp::GVCP_PORT;
use crate::gvsp::StreamFaults;
use crate::server::ServerConfig;

/// `ADDR` or `ADDR:PORT` (IPv4); the GVCP port 3956 when none is given.
pub fn parse_bind_addr(s: &str) -> Result<SocketAddrV4, AddrParseError> {
    if let Ok(a) = s.parse::<SocketAddrV4>() {
        return Ok(a);
    }
    Ok(SocketAddrV4::new(s.parse::<Ipv4Addr>()?, GVCP_PORT))
}

/// The bootstrap identity of simulated camera `name` (sensor `sensor`
/// looking at `view` with noise seed `seed`), within the bootstrap
/// registers' string lengths (model 31, manufacturer info 47 bytes).
pub fn simulated_identity(
    name: &str,
    sensor: &str,
    view: &str,
    seed: u64,
    serial: u32,
    ip: Ipv4Addr,
) -> Identity {
    let s = serial.to_be_bytes();
    Identity {
        vendor: "gloam".into(),
        model: format!("simulated {name}").chars().take(31).collect(),
        version: env!("CARGO_PKG_VERSION").into(),
        manufacturer_info: format!("{sensor} looking at {view}, seed {seed}")
            .chars()
            .take(47)
            .collect(),
        serial: format!("{serial}"),
        user_name: String::new(),
        // Locally administered unicast MAC carrying the serial number.
        mac: [0x02, 0x67, s[0], s[1], s[2], s[3]],
        ip,
        subnet_mask: Ipv4Addr::new(255, 0, 0, 0),
        gateway: Ipv4Addr::UNSPECIFIED,
    }
}

impl ServerConfig {
    /// A simulated camera on a 1 Gb/s link: 64 MiB of frames kept for
    /// resends, a status line every 5 s.
    pub fn simulated(bind: SocketAddrV4, faults: StreamFaults) -> Self {
        Self {
            bind,
            faults,
            resend_store_bytes: 64 << 20,
            report_every: Some(Duration::from_secs(5)),
            link_bits_per_s: 1e9,
        }
    }
}
