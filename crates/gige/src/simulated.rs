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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bind_addr_defaults_to_the_gvcp_port() {
        assert_eq!(
            parse_bind_addr("127.0.0.1"),
            Ok(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 3956))
        );
        assert_eq!(
            parse_bind_addr("10.1.2.3:5000"),
            Ok(SocketAddrV4::new(Ipv4Addr::new(10, 1, 2, 3), 5000))
        );
        assert!(parse_bind_addr("camera.local").is_err());
    }

    #[test]
    fn identity_fits_the_bootstrap_registers_and_carries_the_serial() {
        let long = "x".repeat(100);
        let id = simulated_identity(
            &long,
            &long,
            "rig 'sine'",
            7,
            0x0102_0304,
            Ipv4Addr::LOCALHOST,
        );
        assert_eq!(id.model.chars().count(), 31);
        assert_eq!(id.manufacturer_info.chars().count(), 47);
        assert_eq!(id.mac, [0x02, 0x67, 1, 2, 3, 4]);
        assert_eq!(id.serial, "16909060");
    }
}
