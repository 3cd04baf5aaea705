//! Fuzz entry point: any bytes, as a sequence of GVCP datagrams from two
//! clients, into one device. It must never panic, and every reply must be
//! a well-formed acknowledge no longer than the specification allows.

use std::net::{Ipv4Addr, SocketAddrV4};

use crate::device::{CameraFacts, Device, Identity};
use crate::gvcp;

/// A small device with fixed facts (no sensor chain behind it).
pub fn test_device() -> Device {
    let defaults = gloam_grabber::CaptureSettings {
        width: 64,
        height: 48,
        bits: 12,
        ..Default::default()
    };
    Device::new(
        Identity {
            vendor: "gloam".into(),
            model: "fuzz".into(),
            version: "0".into(),
            manufacturer_info: String::new(),
            serial: "1".into(),
            user_name: String::new(),
            mac: [2, 0, 0, 0, 0, 1],
            ip: Ipv4Addr::LOCALHOST,
            subnet_mask: Ipv4Addr::new(255, 0, 0, 0),
            gateway: Ipv4Addr::UNSPECIFIED,
        },
        CameraFacts {
            max_width: 64,
            max_height: 48,
            resizable: true,
            min_gain_milli: 100,
            max_gain_milli: 100_000,
            max_exposure_us: 1_000_000,
            has_agc: true,
            mcp_range_v: Some((500.0, 1000.0)),
            sensor_frame_rate_hz: 25.0,
            max_frame_rate_hz: 1000.0,
            defaults,
        },
    )
}

/// Feeds `data` to a device: the first byte of each record picks the
/// client (two of them) and the datagram length, the rest is the datagram.
pub fn device_datagrams(data: &[u8]) {
    let mut dev = test_device();
    let clients = [
        SocketAddrV4::new(Ipv4Addr::LOCALHOST, 40000),
        SocketAddrV4::new(Ipv4Addr::LOCALHOST, 40001),
    ];
    let mut rest = data;
    let mut now_us = 0u64;
    while let Some((&sel, tail)) = rest.split_first() {
        let n = (usize::from(sel >> 1) * 5).min(tail.len());
        let (dgram, tail) = tail.split_at(n);
        now_us += u64::from(sel) * 10_000;
        if let Some(reply) = dev.handle(now_us, clients[usize::from(sel & 1)], dgram) {
            let ack = gvcp::parse_ack(&reply).expect("a reply parses as an acknowledge");
            assert!(reply.len() <= gvcp::MAX_DATAGRAM_BYTES, "reply too long");
            assert_eq!(ack.payload.len() + gvcp::HEADER_BYTES, reply.len());
        }
        let _ = dev.take_events();
        rest = tail;
    }
}
