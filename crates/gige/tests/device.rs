//! The sans-IO device against the GigE Vision specification's answers:
//! command/acknowledge layout, status codes for bad input, control-channel
//! privilege and heartbeat, the XML behind the `Local:` URL, and GVSP
//! packets. No sockets.

use std::net::{Ipv4Addr, SocketAddrV4};

use gloam_gige::bootstrap as bs;
use gloam_gige::features::{self, pixel_format, reg};
use gloam_gige::fuzzing::test_device;
use gloam_gige::gvcp::{self, FLAG_ACK_REQUIRED, command, parse_ack};
use gloam_gige::gvsp;
use gloam_gige::{Device, Event};

const A: SocketAddrV4 = SocketAddrV4::new(Ipv4Addr::LOCALHOST, 50000);
const B: SocketAddrV4 = SocketAddrV4::new(Ipv4Addr::LOCALHOST, 50001);

// Status codes as the specification numbers them.
const SUCCESS: u16 = 0x0000;
const NOT_IMPLEMENTED: u16 = 0x8001;
const INVALID_PARAMETER: u16 = 0x8002;
const INVALID_ADDRESS: u16 = 0x8003;
const WRITE_PROTECT: u16 = 0x8004;
const BAD_ALIGNMENT: u16 = 0x8005;
const ACCESS_DENIED: u16 = 0x8006;
const BUSY: u16 = 0x8007;
const INVALID_HEADER: u16 = 0x800E;

struct Client {
    addr: SocketAddrV4,
    id: u16,
}

impl Client {
    fn new(addr: SocketAddrV4) -> Self {
        Self { addr, id: 0 }
    }

    fn send(
        &mut self,
        d: &mut Device,
        now_us: u64,
        cmd: u16,
        payload: &[u8],
    ) -> (u16, u16, Vec<u8>) {
        self.id = self.id.wrapping_add(1).max(1);
        let reply = d
            .handle(
                now_us,
                self.addr,
                &gvcp::encode_command(FLAG_ACK_REQUIRED, cmd, self.id, payload),
            )
            .expect("an acknowledge");
        let ack = parse_ack(&reply).expect("well-formed acknowledge");
        assert_eq!(ack.ack_id, self.id, "ack id echoes the request id");
        (ack.status, ack.answer, ack.payload.to_vec())
    }

    fn read(&mut self, d: &mut Device, addr: u32) -> Result<u32, u16> {
        let (s, answer, p) = self.send(d, 0, command::READREG, &addr.to_be_bytes());
        assert_eq!(answer, command::READREG + 1);
        if s == SUCCESS {
            Ok(u32::from_be_bytes(p[..4].try_into().unwrap()))
        } else {
            Err(s)
        }
    }

    fn write(&mut self, d: &mut Device, addr: u32, v: u32) -> u16 {
        let mut p = addr.to_be_bytes().to_vec();
        p.extend_from_slice(&v.to_be_bytes());
        self.send(d, 0, command::WRITEREG, &p).0
    }

    /// An 8-byte double register, as Aravis writes it: one WRITEMEM.
    fn write_double(&mut self, d: &mut Device, addr: u32, x: f64) -> u16 {
        let mut p = addr.to_be_bytes().to_vec();
        p.extend_from_slice(&x.to_be_bytes());
        self.send(d, 0, command::WRITEMEM, &p).0
    }

    fn read_double(&mut self, d: &mut Device, addr: u32) -> f64 {
        let b = self.read_mem(d, addr, 8).expect("READMEM of a double");
        f64::from_be_bytes(b[..8].try_into().unwrap())
    }

    fn take_control(&mut self, d: &mut Device) -> u16 {
        self.write(d, bs::CONTROL_CHANNEL_PRIVILEGE, bs::CCP_CONTROL)
    }

    fn read_mem(&mut self, d: &mut Device, addr: u32, n: u16) -> Result<Vec<u8>, u16> {
        let mut p = addr.to_be_bytes().to_vec();
        p.extend_from_slice(&[0, 0]);
        p.extend_from_slice(&n.to_be_bytes());
        let (s, _, body) = self.send(d, 0, command::READMEM, &p);
        if s == SUCCESS {
            assert_eq!(
                &body[..4],
                &addr.to_be_bytes(),
                "READMEM_ACK echoes the address"
            );
            Ok(body[4..].to_vec())
        } else {
            Err(s)
        }
    }
}

#[test]
fn discovery_ack_mirrors_the_bootstrap_block() {
    let mut d = test_device();
    let reply = d
        .handle(0, A, &[0x42, 0x11, 0x00, 0x02, 0x00, 0x00, 0xFF, 0xFF])
        .expect("discovery is always answered");
    let ack = parse_ack(&reply).unwrap();
    assert_eq!((ack.status, ack.answer, ack.ack_id), (0, 0x0003, 0xFFFF));
    // 248 bytes: version 2.0, big-endian device mode, MAC, IP, names.
    assert_eq!(ack.payload.len(), 0xF8);
    assert_eq!(&ack.payload[0..4], &[0, 2, 0, 0]);
    assert_eq!(ack.payload[4] & 0x80, 0x80);
    assert_eq!(&ack.payload[10..16], &[2, 0, 0, 0, 0, 1]);
    assert_eq!(&ack.payload[0x24..0x28], &[127, 0, 0, 1]);
    assert_eq!(&ack.payload[0x48..0x4D], b"gloam");
    assert_eq!(&ack.payload[0x68..0x6C], b"fuzz");
}

#[test]
fn the_xml_behind_the_local_url_is_the_genicam_description() {
    let mut d = test_device();
    let mut c = Client::new(A);
    let url = c.read_mem(&mut d, bs::FIRST_URL, 512).unwrap();
    let url = String::from_utf8(url.split(|b| *b == 0).next().unwrap().to_vec()).unwrap();
    // "Local:NAME;ADDRESS;LENGTH", address and length in hex.
    let parts: Vec<&str> = url
        .strip_prefix("Local:")
        .expect("Local: URL")
        .split(';')
        .collect();
    assert_eq!(parts[0], features::XML_FILE_NAME);
    let addr = u32::from_str_radix(parts[1], 16).unwrap();
    let len = usize::from_str_radix(parts[2], 16).unwrap();
    assert_eq!(addr, features::XML_ADDRESS);
    let mut xml = Vec::new();
    while xml.len() < len {
        let n = (len - xml.len()).min(512).div_ceil(4) * 4;
        xml.extend(
            c.read_mem(&mut d, addr + xml.len() as u32, n as u16)
                .unwrap(),
        );
    }
    xml.truncate(len);
    let xml = String::from_utf8(xml).unwrap();
    assert_eq!(xml.as_bytes(), d.xml());
    for f in [
        "Name=\"Width\"",
        "Name=\"PixelFormat\"",
        "Name=\"AcquisitionStart\"",
        "Name=\"AcquisitionFrameRate\"",
        "Name=\"ExposureTime\"",
        "Name=\"GainAuto\"",
        "Name=\"TriggerSoftware\"",
        "Name=\"IntensifierMcpVoltage\"",
    ] {
        assert!(xml.contains(f), "{f} missing");
    }
    // Past the end of the XML: nothing there.
    let end = (addr + len as u32).div_ceil(4) * 4;
    assert_eq!(c.read_mem(&mut d, end, 4), Err(INVALID_ADDRESS));
}

#[test]
fn bad_datagrams_get_status_codes_or_silence_never_a_panic() {
    let mut d = test_device();
    // Not GVCP at all (no 0x42 key, shorter than a header): silence.
    assert!(d.handle(0, A, &[]).is_none());
    assert!(d.handle(0, A, &[0x42, 1, 0, 0x80]).is_none());
    assert!(
        d.handle(0, A, &[0x41, 1, 0, 0x80, 0, 4, 0, 1, 0, 0, 0, 0])
            .is_none()
    );
    // Announced length disagrees with the datagram: INVALID_HEADER.
    let mut c = Client::new(A);
    let r = d
        .handle(0, A, &[0x42, 1, 0, 0x80, 0, 8, 0, 1, 0, 0, 0, 0])
        .unwrap();
    assert_eq!(parse_ack(&r).unwrap().status, INVALID_HEADER);
    // Oversized datagram.
    let big = gvcp::encode_command(FLAG_ACK_REQUIRED, command::READREG, 9, &[0u8; 1000]);
    assert_eq!(
        parse_ack(&d.handle(0, A, &big).unwrap()).unwrap().status,
        INVALID_HEADER
    );
    // Request id 0 is reserved.
    let z = gvcp::encode_command(FLAG_ACK_REQUIRED, command::READREG, 0, &[0, 0, 0, 0]);
    assert_eq!(
        parse_ack(&d.handle(0, A, &z).unwrap()).unwrap().status,
        INVALID_HEADER
    );
    // Unknown command.
    assert_eq!(c.send(&mut d, 0, 0x7770, &[]).0, NOT_IMPLEMENTED);
    assert_eq!(
        c.send(&mut d, 0, command::FORCEIP, &[0; 56]).0,
        NOT_IMPLEMENTED
    );
    // READREG: unaligned, unknown; no ack when not asked for.
    assert_eq!(c.read(&mut d, 0x0002), Err(BAD_ALIGNMENT));
    assert_eq!(c.read(&mut d, 0x00F0_0000), Err(INVALID_ADDRESS));
    assert!(
        d.handle(
            0,
            A,
            &gvcp::encode_command(0, command::READREG, 5, &[0, 0, 0, 0])
        )
        .is_none()
    );
    // READMEM: zero, odd and oversized counts; unaligned address.
    assert_eq!(c.read_mem(&mut d, 0, 0), Err(INVALID_PARAMETER));
    assert_eq!(c.read_mem(&mut d, 0, 6), Err(INVALID_PARAMETER));
    assert_eq!(c.read_mem(&mut d, 0, 540), Err(INVALID_PARAMETER));
    assert_eq!(c.read_mem(&mut d, 2, 4), Err(BAD_ALIGNMENT));
    assert_eq!(c.read_mem(&mut d, u32::MAX - 3, 8), Err(INVALID_ADDRESS));
    // The device still serves.
    assert_eq!(c.read(&mut d, bs::NUMBER_OF_STREAM_CHANNELS), Ok(1));
}

#[test]
fn writes_need_control_and_respect_read_only_and_ranges() {
    let mut d = test_device();
    let mut a = Client::new(A);
    // No control yet: ACCESS_DENIED.
    assert_eq!(a.write(&mut d, reg::WIDTH, 32), ACCESS_DENIED);
    assert_eq!(a.take_control(&mut d), SUCCESS);
    assert_eq!(
        a.read(&mut d, bs::CONTROL_CHANNEL_PRIVILEGE),
        Ok(bs::CCP_CONTROL)
    );
    assert_eq!(a.write(&mut d, reg::WIDTH, 32), SUCCESS);
    assert_eq!(a.read(&mut d, reg::WIDTH), Ok(32));
    assert_eq!(a.read(&mut d, reg::PAYLOAD_SIZE), Ok(32 * 48 * 2));
    // Read-only and unknown registers.
    assert_eq!(a.write(&mut d, reg::SENSOR_WIDTH, 1), WRITE_PROTECT);
    assert_eq!(a.write(&mut d, reg::PAYLOAD_SIZE, 1), WRITE_PROTECT);
    assert_eq!(a.write(&mut d, bs::VERSION, 1), WRITE_PROTECT);
    assert_eq!(a.write(&mut d, 0x00F0_0000, 1), INVALID_ADDRESS);
    assert_eq!(a.write(&mut d, reg::WIDTH + 1, 1), BAD_ALIGNMENT);
    // Out of range: refused, value unchanged.
    assert_eq!(a.write(&mut d, reg::WIDTH, 65), INVALID_PARAMETER);
    assert_eq!(
        a.write(&mut d, reg::PIXEL_FORMAT, 0x0108_0003),
        INVALID_PARAMETER
    );
    assert_eq!(
        a.write(&mut d, reg::EXPOSURE_TIME, f32::NAN.to_bits()),
        INVALID_PARAMETER
    );
    assert_eq!(a.write(&mut d, reg::GAIN_AUTO, 0), SUCCESS);
    assert_eq!(a.write_double(&mut d, reg::GAIN_DB, 1e9), INVALID_PARAMETER);
    assert_eq!(a.read(&mut d, reg::WIDTH), Ok(32));
    // Concatenated WRITEREG stops at the first failure and says where.
    let mut p = Vec::new();
    for (r, v) in [
        (reg::HEIGHT, 24u32),
        (reg::SENSOR_HEIGHT, 1),
        (reg::WIDTH, 16),
    ] {
        p.extend_from_slice(&r.to_be_bytes());
        p.extend_from_slice(&v.to_be_bytes());
    }
    let (s, _, body) = a.send(&mut d, 0, command::WRITEREG, &p);
    assert_eq!(
        (s, u16::from_be_bytes([body[2], body[3]])),
        (WRITE_PROTECT, 1)
    );
    assert_eq!(a.read(&mut d, reg::HEIGHT), Ok(24));
    assert_eq!(a.read(&mut d, reg::WIDTH), Ok(32));
    // GainLinear as a double-precision float; Mono8/12/16 as PFNC codes.
    assert_eq!(a.write_double(&mut d, reg::GAIN_LINEAR, 2.5), SUCCESS);
    assert_eq!(d.settings().gain_milli, 2500);
    assert_eq!(
        a.write(&mut d, reg::PIXEL_FORMAT, pixel_format::MONO8),
        SUCCESS
    );
    assert_eq!(d.settings().bits, 8);
    assert_eq!(a.read(&mut d, reg::PAYLOAD_SIZE), Ok(32 * 24));
}

#[test]
fn a_second_controller_is_refused_until_the_heartbeat_expires() {
    let mut d = test_device();
    let (mut a, mut b) = (Client::new(A), Client::new(B));
    assert_eq!(a.take_control(&mut d), SUCCESS);
    assert_eq!(b.take_control(&mut d), ACCESS_DENIED);
    assert_eq!(b.write(&mut d, reg::WIDTH, 8), ACCESS_DENIED);
    // Reads stay open to others (control is not exclusive).
    assert_eq!(b.read(&mut d, reg::WIDTH), Ok(64));
    // A's heartbeat: any command within the timeout keeps control.
    let t = u64::from(bs::DEFAULT_HEARTBEAT_MS) * 1000;
    a.send(
        &mut d,
        t - 1000,
        command::READREG,
        &bs::CONTROL_CHANNEL_PRIVILEGE.to_be_bytes(),
    );
    let mut p = bs::CONTROL_CHANNEL_PRIVILEGE.to_be_bytes().to_vec();
    p.extend_from_slice(&bs::CCP_CONTROL.to_be_bytes());
    assert_eq!(
        b.send(&mut d, t + 500_000, command::WRITEREG, &p).0,
        ACCESS_DENIED
    );
    // Silent for longer than the timeout: control lapses, B may take it.
    assert_eq!(
        b.send(&mut d, 2 * t + 1000, command::WRITEREG, &p).0,
        SUCCESS
    );
    assert_eq!(d.controller(), Some(B));
    assert!(d.take_events().contains(&Event::ControlReleased));
    // Exclusive control also shuts out reads.
    p[7] = (bs::CCP_CONTROL | bs::CCP_EXCLUSIVE) as u8;
    assert_eq!(
        b.send(&mut d, 2 * t + 2000, command::WRITEREG, &p).0,
        SUCCESS
    );
    assert_eq!(a.read(&mut d, reg::WIDTH), Err(ACCESS_DENIED));
    // Releasing (write 0) lets A in again.
    assert_eq!(b.write(&mut d, bs::CONTROL_CHANNEL_PRIVILEGE, 0), SUCCESS);
    assert_eq!(a.take_control(&mut d), SUCCESS);
}

#[test]
fn acquisition_locks_the_format_and_packetresend_is_an_event() {
    let mut d = test_device();
    let mut a = Client::new(A);
    a.take_control(&mut d);
    assert_eq!(
        a.write(&mut d, reg::ACQUISITION_START, 1),
        0x8FFF,
        "no stream destination yet"
    );
    a.write(
        &mut d,
        bs::STREAM_CHANNEL_DESTINATION,
        u32::from(Ipv4Addr::LOCALHOST),
    );
    a.write(&mut d, bs::STREAM_CHANNEL_PORT, 40000);
    assert_eq!(a.write(&mut d, reg::ACQUISITION_START, 1), SUCCESS);
    assert!(d.acquiring());
    assert_eq!(a.write(&mut d, reg::WIDTH, 8), BUSY);
    // Standard ids: channel 0 | block id, first and last packet ids.
    let mut p = Vec::new();
    for w in [7u32, 3, 5] {
        p.extend_from_slice(&w.to_be_bytes());
    }
    assert!(
        d.handle(0, A, &gvcp::encode_command(0, command::PACKETRESEND, 9, &p))
            .is_none()
    );
    assert_eq!(a.write(&mut d, reg::ACQUISITION_STOP, 1), SUCCESS);
    let ev = d.take_events();
    assert_eq!(
        ev,
        vec![
            Event::AcquisitionStart,
            Event::Resend {
                block_id: 7,
                first_packet: 3,
                last_packet: 5
            },
            Event::AcquisitionStop
        ]
    );
    // A packet size outside 576..=9000 bytes is refused.
    assert_eq!(
        a.write(&mut d, bs::STREAM_CHANNEL_PACKET_SIZE, 100),
        INVALID_PARAMETER
    );
    assert_eq!(
        a.write(&mut d, bs::STREAM_CHANNEL_PACKET_SIZE, 9001),
        INVALID_PARAMETER
    );
}

#[test]
fn gvsp_frames_are_leader_payload_trailer() {
    let info = gvsp::ImageInfo {
        payload_type: gvsp::PAYLOAD_TYPE_IMAGE,
        timestamp_ticks: 0x1_0000_0002,
        pixel_format: pixel_format::MONO12,
        width: 3,
        height: 2,
    };
    let data: Vec<u8> = (0..12).collect();
    // 36 bytes of overhead: 8 data bytes per payload packet at 44.
    let p = gvsp::packetize(0x1234, &info, &data, 44);
    assert_eq!(p.len(), 1 + 2 + 1);
    // Leader: status 0, block id, content type 1, packet id 0.
    assert_eq!(&p[0][..8], &[0, 0, 0x12, 0x34, 1, 0, 0, 0]);
    assert_eq!(&p[0][10..12], &[0, 1], "payload type image");
    assert_eq!(&p[0][12..20], &[0, 0, 0, 1, 0, 0, 0, 2], "timestamp");
    assert_eq!(&p[0][20..24], &0x0110_0005u32.to_be_bytes());
    assert_eq!(&p[0][24..32], &[0, 0, 0, 3, 0, 0, 0, 2]);
    assert_eq!(p[0].len(), 8 + 36);
    assert_eq!(&p[1][..8], &[0, 0, 0x12, 0x34, 3, 0, 0, 1]);
    assert_eq!(&p[1][8..], &data[..8]);
    assert_eq!(&p[2][8..], &data[8..]);
    assert_eq!(&p[3][..8], &[0, 0, 0x12, 0x34, 2, 0, 0, 3]);
    assert_eq!(
        &p[3][8..],
        &[0, 0, 0, 1, 0, 0, 0, 2],
        "trailer: image, size y"
    );
    // Resend store: packets served again; unknown ones flagged unavailable.
    let mut store = gvsp::ResendStore::new(1 << 20);
    store.insert(0x1234, p.clone());
    assert_eq!(
        store.resend(0x1234, 1, 2, 100),
        vec![p[1].clone(), p[2].clone()]
    );
    let missing = store.resend(0x1235, 1, 1, 100);
    assert_eq!(&missing[0][..2], &[0x80, 0x0C]);
    assert_eq!(gvsp::next_block_id(u16::MAX), 1);
}

#[test]
fn fuzz_entry_point_survives_hostile_sequences() {
    // A few structured sequences through the fuzz entry point.
    let mut seq = Vec::new();
    for cmd in [0x0080u16, 0x0082, 0x0084, 0x0086, 0x0040, 0x0002, 0xFFFF] {
        for len in [0usize, 4, 8, 12, 20, 520] {
            let payload: Vec<u8> = (0..len)
                .map(|i| (i * 37 + usize::from(cmd as u8)) as u8)
                .collect();
            let d = gvcp::encode_command(1, cmd, 7, &payload);
            seq.push(((d.len() / 5).min(127) as u8) << 1);
            seq.extend(d);
        }
    }
    gloam_gige::fuzzing::device_datagrams(&seq);
}

#[test]
fn gloam_stimulus_takes_a_renderable_stimulus_or_changes_nothing() {
    let mut d = test_device();
    let mut a = Client::new(A);
    let mut b = Client::new(B);
    let writemem = |c: &mut Client, d: &mut Device, text: &str| {
        let mut p = reg::STIMULUS.to_be_bytes().to_vec();
        let mut body = text.as_bytes().to_vec();
        body.resize(reg::STIMULUS_BYTES as usize, 0);
        p.extend_from_slice(&body);
        c.send(d, 0, command::WRITEMEM, &p)
    };
    let json = r#"{"kind":"uniform","radiance_w_m2_sr":1e-5,"spectrum":"cie-a"}"#;
    // Only the controller may change what the camera sees.
    assert_eq!(writemem(&mut a, &mut d, json).0, ACCESS_DENIED);
    assert_eq!(a.take_control(&mut d), SUCCESS);
    assert_eq!(writemem(&mut b, &mut d, json).0, ACCESS_DENIED);
    let (s, _, ack) = writemem(&mut a, &mut d, json);
    assert_eq!(s, SUCCESS);
    // The ack's index counts the bytes written.
    assert_eq!(u16::from_be_bytes([ack[2], ack[3]]), 512);
    let want: gloam_grabber::Stimulus = serde_json::from_str(json).unwrap();
    assert_eq!(d.take_events(), vec![Event::Stimulus(want)]);
    let back = a.read_mem(&mut d, reg::STIMULUS, 512).unwrap();
    assert_eq!(&back[..json.len()], json.as_bytes());
    // Not JSON, an unknown lamp, a negative radiance, no NUL: refused,
    // and the register keeps the last good stimulus.
    for bad in [
        "{not json",
        r#"{"kind":"uniform","radiance_w_m2_sr":1e-5,"spectrum":"no-such-lamp"}"#,
        r#"{"kind":"uniform","radiance_w_m2_sr":-1,"spectrum":"cie-a"}"#,
    ] {
        assert_eq!(writemem(&mut a, &mut d, bad).0, INVALID_PARAMETER, "{bad}");
        assert!(d.take_events().is_empty(), "{bad}");
    }
    let mut p = reg::STIMULUS.to_be_bytes().to_vec();
    p.extend_from_slice(&[b'x'; 512]);
    assert_eq!(
        a.send(&mut d, 0, command::WRITEMEM, &p).0,
        INVALID_PARAMETER
    );
    let back = a.read_mem(&mut d, reg::STIMULUS, 512).unwrap();
    assert_eq!(&back[..json.len()], json.as_bytes());
    // Past the end of the register: no such address.
    let mut p = (reg::STIMULUS + 508).to_be_bytes().to_vec();
    p.extend_from_slice(&[0; 8]);
    assert_eq!(a.send(&mut d, 0, command::WRITEMEM, &p).0, INVALID_ADDRESS);
    // The XML describes it where it is.
    let xml = String::from_utf8(d.xml().to_vec()).unwrap();
    let node = &xml[xml.find("<StringReg Name=\"GloamStimulus\"").unwrap()..];
    assert!(node.contains(&format!("<Address>0x{:x}</Address>", reg::STIMULUS)));
    assert!(node.contains("<Length>512</Length>"));
}

#[test]
fn bright_source_protection_is_a_read_only_state() {
    let mut d = test_device();
    let mut a = Client::new(A);
    assert_eq!(a.take_control(&mut d), SUCCESS);
    assert_eq!(a.read(&mut d, reg::BRIGHT_SOURCE_PROTECTION), Ok(0));
    d.set_bright_source_protection(true);
    assert_eq!(a.read(&mut d, reg::BRIGHT_SOURCE_PROTECTION), Ok(1));
    assert_eq!(
        a.write(&mut d, reg::BRIGHT_SOURCE_PROTECTION, 0),
        WRITE_PROTECT
    );
    let xml = String::from_utf8(d.xml().to_vec()).unwrap();
    assert!(xml.contains("<Enumeration Name=\"IntensifierBrightSourceProtection\""));
    assert!(xml.contains(&format!(
        "<Address>0x{:x}</Address>",
        reg::BRIGHT_SOURCE_PROTECTION
    )));
}

#[test]
fn gain_is_in_db_as_sfnc_defines_it_and_the_linear_factor_sits_beside_it() {
    let mut d = test_device();
    let mut a = Client::new(A);
    a.take_control(&mut d);
    assert_eq!(a.write(&mut d, reg::GAIN_AUTO, 0), SUCCESS);
    // 40 dB is a factor of 100 (20·log10 100 = 40), and reads back exactly.
    assert_eq!(a.write_double(&mut d, reg::GAIN_DB, 40.0), SUCCESS);
    assert_eq!(d.settings().gain_milli, 100_000);
    assert_eq!(a.read_double(&mut d, reg::GAIN_DB), 40.0);
    assert_eq!(a.read_double(&mut d, reg::GAIN_LINEAR), 100.0);
    // The linear factor 2.5 is 7.9588 dB (20·log10 2.5 = 7.958800173…).
    assert_eq!(a.write_double(&mut d, reg::GAIN_LINEAR, 2.5), SUCCESS);
    let db = a.read_double(&mut d, reg::GAIN_DB);
    assert!((db - 7.958_800_173_440_752).abs() < 1e-12, "{db}");
    // Two WRITEREGs, high word first, write one double too: 0 dB = 1×.
    let bits = 0.0f64.to_bits();
    assert_eq!(a.write(&mut d, reg::GAIN_DB, (bits >> 32) as u32), SUCCESS);
    assert_eq!(a.write(&mut d, reg::GAIN_DB + 4, bits as u32), SUCCESS);
    assert_eq!(d.settings().gain_milli, 1000);
    // The range is the linear one in dB: 0.1…100 × is −20…40 dB.
    assert_eq!(
        a.write_double(&mut d, reg::GAIN_DB, 40.01),
        INVALID_PARAMETER
    );
    assert_eq!(a.write_double(&mut d, reg::GAIN_DB, -20.0), SUCCESS);
    assert_eq!(d.settings().gain_milli, 100);
    assert_eq!(
        a.write_double(&mut d, reg::GAIN_DB, f64::NAN),
        INVALID_PARAMETER
    );
    // Under GainAuto the gain is the AGC's: writes are WRITE_PROTECT (the
    // register is locked), not ACCESS_DENIED (another application has
    // control), and change nothing.
    assert_eq!(a.write(&mut d, reg::GAIN_AUTO, 2), SUCCESS);
    assert_eq!(a.write_double(&mut d, reg::GAIN_DB, 6.0), WRITE_PROTECT);
    assert_eq!(a.write_double(&mut d, reg::GAIN_LINEAR, 2.0), WRITE_PROTECT);
    assert_eq!(d.settings().gain_milli, 100);
    // The XML says so before a client writes: dB, double precision, locked
    // by GainAuto, range −20…40 dB.
    let xml = String::from_utf8(d.xml().to_vec()).unwrap();
    let node = |open: &str, close: &str| {
        let i = xml.find(open).unwrap();
        xml[i..i + xml[i..].find(close).unwrap()].to_string()
    };
    let gain = node("<Float Name=\"Gain\"", "</Float>");
    for want in [
        "<pIsLocked>GainLocked</pIsLocked>",
        "<Min>-20</Min>",
        "<Max>40</Max>",
        "<Unit>dB</Unit>",
    ] {
        assert!(gain.contains(want), "Gain lacks {want}: {gain}");
    }
    assert!(xml.contains("<Float Name=\"GainLinear\" NameSpace=\"Custom\">"));
    assert!(node("<FloatReg Name=\"GainReg\"", "</FloatReg>").contains("<Length>8</Length>"));
    assert!(xml.contains("<pVariable Name=\"AUTO\">GainAutoReg</pVariable>"));
}

/// SFNC: registers persist until power-up or DeviceReset, which load the
/// set UserSetDefault names; a new control session changes nothing.
#[test]
fn registers_persist_across_sessions_and_device_reset_loads_user_set_default() {
    let mut d = test_device();
    let (mut a, mut b) = (Client::new(A), Client::new(B));
    let rate = |c: &mut Client, d: &mut Device| {
        f32::from_bits(c.read(d, reg::ACQUISITION_FRAME_RATE).unwrap())
    };
    a.take_control(&mut d);
    // The preset's power-up values (test_device: 25 Hz, 64 pixels wide).
    assert_eq!(rate(&mut a, &mut d), 25.0);
    assert_eq!(a.read(&mut d, reg::WIDTH), Ok(64));
    assert_eq!(
        a.write(&mut d, reg::ACQUISITION_FRAME_RATE, 5f32.to_bits()),
        SUCCESS
    );
    assert_eq!(a.write(&mut d, reg::WIDTH, 16), SUCCESS);
    assert_eq!(a.write(&mut d, reg::GAIN_AUTO, 0), SUCCESS);
    assert_eq!(a.write_double(&mut d, reg::GAIN_DB, 40.0), SUCCESS);
    // A half-written double (high word only) dies with its session.
    assert_eq!(a.write(&mut d, reg::GAIN_DB, 0x4050_0000), SUCCESS);
    assert_eq!(a.write(&mut d, bs::CONTROL_CHANNEL_PRIVILEGE, 0), SUCCESS);
    // What A left is what B gets.
    assert_eq!(b.take_control(&mut d), SUCCESS);
    assert_eq!(rate(&mut b, &mut d), 5.0);
    assert_eq!(b.read(&mut d, reg::WIDTH), Ok(16));
    assert_eq!(b.read(&mut d, reg::GAIN_AUTO), Ok(0));
    let db = b.read_double(&mut d, reg::GAIN_DB);
    assert!((db - 40.0).abs() < 1e-3, "{db} dB");
    // A low word alone keeps the stored high word: 40 dB is still 40 dB.
    let low = 40f64.to_bits() as u32;
    assert_eq!(b.write(&mut d, reg::GAIN_DB + 4, low), SUCCESS);
    let db = b.read_double(&mut d, reg::GAIN_DB);
    assert!((db - 40.0).abs() < 1e-3, "{db} dB");
    // Default is read-only; UserSet1 keeps what is saved into it.
    assert_eq!(b.write(&mut d, reg::USER_SET_SAVE, 1), WRITE_PROTECT);
    assert_eq!(b.write(&mut d, reg::USER_SET_SELECTOR, 1), SUCCESS);
    assert_eq!(b.write(&mut d, reg::USER_SET_SAVE, 1), SUCCESS);
    assert_eq!(b.write(&mut d, reg::USER_SET_SELECTOR, 0), SUCCESS);
    assert_eq!(b.write(&mut d, reg::USER_SET_LOAD, 1), SUCCESS);
    assert_eq!(rate(&mut b, &mut d), 25.0);
    assert_eq!(b.read(&mut d, reg::WIDTH), Ok(64));
    assert_eq!(b.write(&mut d, reg::USER_SET_SELECTOR, 1), SUCCESS);
    assert_eq!(b.write(&mut d, reg::USER_SET_LOAD, 1), SUCCESS);
    assert_eq!(rate(&mut b, &mut d), 5.0);
    assert_eq!(b.read(&mut d, reg::WIDTH), Ok(16));
    assert_eq!(
        b.write(&mut d, reg::USER_SET_SELECTOR, 2),
        INVALID_PARAMETER
    );
    assert_eq!(b.write(&mut d, reg::USER_SET_DEFAULT, 2), INVALID_PARAMETER);
    // DeviceReset: control released, the Default set (UserSetDefault) back.
    assert_eq!(b.write(&mut d, reg::DEVICE_RESET, 1), SUCCESS);
    assert_eq!(d.controller(), None);
    assert!(d.take_events().contains(&Event::ControlReleased));
    assert_eq!(rate(&mut a, &mut d), 25.0);
    assert_eq!(a.read(&mut d, reg::WIDTH), Ok(64));
    // With UserSetDefault = UserSet1, DeviceReset loads UserSet1; the
    // choice itself survives the reset (it is the user sets' setting).
    a.take_control(&mut d);
    assert_eq!(a.write(&mut d, reg::USER_SET_DEFAULT, 1), SUCCESS);
    assert_eq!(rate(&mut a, &mut d), 25.0, "choosing does not load");
    assert_eq!(a.write(&mut d, reg::DEVICE_RESET, 1), SUCCESS);
    b.take_control(&mut d);
    assert_eq!(b.read(&mut d, reg::USER_SET_DEFAULT), Ok(1));
    assert_eq!(rate(&mut b, &mut d), 5.0);
    assert_eq!(b.read(&mut d, reg::WIDTH), Ok(16));
}

/// The chunks of a payload as a client finds them: walking the trailers
/// `[id u32 BE][length u32 BE]` back from the end, as Aravis's
/// `arv_buffer_get_chunk_data` does. `(id, data)` from last to first.
fn walk_chunks(payload: &[u8]) -> Vec<(u32, Vec<u8>)> {
    let mut out = Vec::new();
    let mut end = payload.len();
    while end >= 8 {
        let t = &payload[end - 8..end];
        let id = u32::from_be_bytes(t[..4].try_into().unwrap());
        let len = u32::from_be_bytes(t[4..].try_into().unwrap()) as usize;
        assert!(len > 0 && len + 8 <= end, "chunk {id:#x}: length {len}");
        out.push((id, payload[end - 8 - len..end - 8].to_vec()));
        end -= 8 + len;
    }
    assert_eq!(end, 0, "the chunks tile the payload");
    out
}

/// `<ChunkID>` of the port `Chunk{name}` reads through, from the XML text.
fn chunk_id_in_xml(xml: &str, name: &str) -> u32 {
    let port = format!("<Port Name=\"Chunk{name}Port\">");
    let at = xml.find(&port).unwrap_or_else(|| panic!("no {port}")) + port.len();
    let rest = &xml[at..];
    let id = rest
        .split("<ChunkID>")
        .nth(1)
        .and_then(|s| s.split("</ChunkID>").next())
        .unwrap();
    u32::from_str_radix(id, 16).unwrap()
}

#[test]
fn chunk_payload_walked_from_its_end_gives_back_every_value_under_the_xmls_ids() {
    use features::chunk;
    let values = chunk::Values {
        frame_id: 7,
        timestamp_ticks: 0x0102_0304_0506_0708,
        gain_linear: 100.0,
        exposure_us: 2500.0,
        gate_duty: 0.5,
        agc_active: true,
        bright_source_protection: false,
    };
    // Five image bytes: the image chunk is padded to eight.
    let mut payload = vec![1u8, 2, 3, 4, 5];
    gvsp::chunked_payload(
        &mut payload,
        chunk::IMAGE_ID,
        &values.chunks(chunk::ALL_ENABLED),
    );
    // 8 image + 8 trailer; 2×4 offsets, 6×8 ids/floats, 2×4 flags = 64 data
    // bytes in 10 chunks with 10 trailers.
    assert_eq!(payload.len(), 8 + 8 + 64 + 10 * 8);
    assert_eq!(payload.len(), chunk::payload_bytes(5, chunk::ALL_ENABLED));
    let mut found = walk_chunks(&payload);
    found.reverse();
    assert_eq!(found.len(), 11);
    assert_eq!(found[0], (chunk::IMAGE_ID, vec![1, 2, 3, 4, 5, 0, 0, 0]));
    let xml = String::from_utf8(test_device().xml().to_vec()).unwrap();
    let get = |name: &str| -> Vec<u8> {
        let id = chunk_id_in_xml(&xml, name);
        found
            .iter()
            .find(|c| c.0 == id)
            .unwrap_or_else(|| panic!("no chunk {id:#x} ({name})"))
            .1
            .clone()
    };
    let f64_of = |b: Vec<u8>| f64::from_be_bytes(b[..8].try_into().unwrap());
    let u_of = |b: Vec<u8>| b.iter().fold(0u64, |a, &x| a << 8 | u64::from(x));
    assert_eq!(u_of(get("FrameID")), 7);
    assert_eq!(u_of(get("Timestamp")), 0x0102_0304_0506_0708);
    assert_eq!(f64_of(get("Gain")), 40.0, "20·log10(100) dB");
    assert_eq!(f64_of(get("GainLinear")), 100.0);
    assert_eq!(f64_of(get("ExposureTime")), 2500.0);
    assert_eq!(f64_of(get("GateDuty")), 0.5);
    assert_eq!(get("AgcActive"), vec![0, 0, 0, 1]);
    assert_eq!(get("BrightSourceProtection"), vec![0, 0, 0, 0]);
    assert_eq!(get("OffsetX"), vec![0, 0, 0, 0]);
    // Only the enabled chunks are sent: Gain alone (selector entry 4).
    let mut only_gain = vec![0u8; 8];
    gvsp::chunked_payload(&mut only_gain, chunk::IMAGE_ID, &values.chunks(1 << 4));
    let walked = walk_chunks(&only_gain);
    assert_eq!(walked.len(), 2);
    assert_eq!(walked[0].0, chunk_id_in_xml(&xml, "Gain"));
}

#[test]
fn chunk_mode_grows_payload_size_and_device_reset_turns_it_off() {
    let mut d = test_device();
    let (mut a, mut b) = (Client::new(A), Client::new(B));
    a.take_control(&mut d);
    let image = a.read(&mut d, reg::PAYLOAD_SIZE).unwrap();
    let w = a.read(&mut d, reg::WIDTH).unwrap();
    let h = a.read(&mut d, reg::HEIGHT).unwrap();
    let bpp = pixel_format::bytes_per_pixel(a.read(&mut d, reg::PIXEL_FORMAT).unwrap()) as u32;
    assert_eq!(image, w * h * bpp, "chunk mode is off at power-up");
    assert_eq!(d.chunks(), None);
    assert_eq!(a.write(&mut d, reg::CHUNK_MODE_ACTIVE, 1), SUCCESS);
    // Image trailer, then 10 chunks of 64 data bytes with their trailers.
    assert_eq!(
        a.read(&mut d, reg::PAYLOAD_SIZE),
        Ok((w * h * bpp).next_multiple_of(4) + 8 + 64 + 80)
    );
    // ChunkEnable is per selector entry: disable Gain (4), the rest stay.
    assert_eq!(a.write(&mut d, reg::CHUNK_SELECTOR, 4), SUCCESS);
    assert_eq!(a.read(&mut d, reg::CHUNK_ENABLE), Ok(1));
    assert_eq!(a.write(&mut d, reg::CHUNK_ENABLE, 0), SUCCESS);
    assert_eq!(a.read(&mut d, reg::CHUNK_ENABLE), Ok(0));
    assert_eq!(a.write(&mut d, reg::CHUNK_SELECTOR, 5), SUCCESS);
    assert_eq!(a.read(&mut d, reg::CHUNK_ENABLE), Ok(1));
    assert_eq!(d.chunks(), Some(features::chunk::ALL_ENABLED & !(1 << 4)));
    assert_eq!(
        a.read(&mut d, reg::PAYLOAD_SIZE),
        Ok((w * h * bpp).next_multiple_of(4) + 8 + 64 + 80 - 16)
    );
    assert_eq!(a.write(&mut d, reg::CHUNK_SELECTOR, 10), INVALID_PARAMETER);
    assert_eq!(a.write(&mut d, reg::CHUNK_ENABLE, 2), INVALID_PARAMETER);
    // Locked while the host streams: PayloadSize may not change under it.
    assert_eq!(a.write(&mut d, reg::TL_PARAMS_LOCKED, 1), SUCCESS);
    assert_eq!(a.write(&mut d, reg::CHUNK_MODE_ACTIVE, 0), BUSY);
    assert_eq!(a.write(&mut d, reg::TL_PARAMS_LOCKED, 0), SUCCESS);
    // The next controller finds chunks on (registers persist); DeviceReset
    // loads the Default set: no chunks.
    assert_eq!(a.write(&mut d, bs::CONTROL_CHANNEL_PRIVILEGE, 0), SUCCESS);
    b.take_control(&mut d);
    assert_eq!(b.read(&mut d, reg::CHUNK_MODE_ACTIVE), Ok(1));
    assert_eq!(b.write(&mut d, reg::DEVICE_RESET, 1), SUCCESS);
    b.take_control(&mut d);
    assert_eq!(b.read(&mut d, reg::CHUNK_MODE_ACTIVE), Ok(0));
    assert_eq!(b.read(&mut d, reg::PAYLOAD_SIZE), Ok(image));
}

/// ExposureAuto and GainSelector have one entry each; AcquisitionFrameRate
/// paces the stream only while AcquisitionFrameRateEnable is on (off: the
/// sensor's own 25 Hz), and the switch is part of a user set.
#[test]
fn sfnc_exposure_auto_gain_selector_and_frame_rate_enable() {
    let mut d = test_device();
    let mut a = Client::new(A);
    a.take_control(&mut d);
    assert_eq!(a.read(&mut d, reg::EXPOSURE_AUTO), Ok(0));
    assert_eq!(a.write(&mut d, reg::EXPOSURE_AUTO, 2), INVALID_PARAMETER);
    assert_eq!(a.write(&mut d, reg::EXPOSURE_AUTO, 0), SUCCESS);
    assert_eq!(a.read(&mut d, reg::GAIN_SELECTOR), Ok(0));
    assert_eq!(a.write(&mut d, reg::GAIN_SELECTOR, 1), INVALID_PARAMETER);
    assert_eq!(a.read(&mut d, reg::ACQUISITION_FRAME_RATE_ENABLE), Ok(1));
    assert_eq!(
        a.write(&mut d, reg::ACQUISITION_FRAME_RATE, 5f32.to_bits()),
        SUCCESS
    );
    assert_eq!(d.frame_period_us(), 200_000);
    assert_eq!(a.write(&mut d, reg::USER_SET_SELECTOR, 1), SUCCESS);
    assert_eq!(
        a.write(&mut d, reg::ACQUISITION_FRAME_RATE_ENABLE, 0),
        SUCCESS
    );
    assert_eq!(a.write(&mut d, reg::USER_SET_SAVE, 1), SUCCESS);
    assert_eq!(d.frame_period_us(), 40_000, "the sensor's 25 Hz");
    assert_eq!(
        f32::from_bits(a.read(&mut d, reg::ACQUISITION_FRAME_RATE).unwrap()),
        5.0,
        "kept, not honoured"
    );
    assert_eq!(
        a.write(&mut d, reg::ACQUISITION_FRAME_RATE_ENABLE, 2),
        INVALID_PARAMETER
    );
    assert_eq!(
        a.write(&mut d, reg::ACQUISITION_FRAME_RATE_ENABLE, 1),
        SUCCESS
    );
    assert_eq!(d.frame_period_us(), 200_000);
    assert_eq!(a.write(&mut d, reg::USER_SET_LOAD, 1), SUCCESS);
    assert_eq!(a.read(&mut d, reg::ACQUISITION_FRAME_RATE_ENABLE), Ok(0));
    // The XML names them where SFNC clients look.
    let xml = String::from_utf8(d.xml().to_vec()).unwrap();
    for name in ["ExposureAuto", "GainSelector", "AcquisitionFrameRateEnable"] {
        assert!(
            xml.contains(&format!("Name=\"{name}\" NameSpace=\"Standard\"")),
            "{name}"
        );
    }
    assert!(!xml.contains("DeviceTemperature"), "not modelled");
}

/// `GloamStimulus` reads the stimulus shown from the start (a rig's), and
/// a JSON too long for the register leaves it as it was.
#[test]
fn gloam_stimulus_reads_the_stimulus_in_effect_from_the_start() {
    let mut d = test_device();
    let mut a = Client::new(A);
    let stim = gloam_grabber::Stimulus::Uniform {
        radiance_w_m2_sr: 1.5e-5,
        spectrum: "cie-a".into(),
    };
    d.show_stimulus(&stim);
    let bytes = a.read_mem(&mut d, reg::STIMULUS, 128).unwrap();
    let end = bytes.iter().position(|&b| b == 0).unwrap();
    let back: gloam_grabber::Stimulus = serde_json::from_slice(&bytes[..end]).unwrap();
    assert_eq!(back, stim);
    assert!(d.take_events().is_empty(), "shown already: no event");
    let long = gloam_grabber::Stimulus::Uniform {
        radiance_w_m2_sr: 1.0,
        spectrum: "x".repeat(600),
    };
    d.show_stimulus(&long);
    let again = a.read_mem(&mut d, reg::STIMULUS, 128).unwrap();
    assert_eq!(again, bytes);
}
