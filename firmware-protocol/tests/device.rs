//! The device state machine over a mock HAL: handshake, get/set, slow
//! operations, streaming, and error replies — over both transports.

mod common;

use common::*;
use firmware_protocol::*;

struct Rig {
    tx: Vec<u8>,
    frame: Vec<u8>,
}

impl Rig {
    fn new(tx_len: usize) -> Self {
        Self {
            tx: vec![0; tx_len],
            frame: vec![0; FRAME_BUF_LEN],
        }
    }
    fn device(&mut self, transport: Transport, hal: MockHal) -> Device<'_, MockHal> {
        Device::new(
            hal,
            config(),
            transport,
            DeviceBuffers {
                tx: &mut self.tx,
                frame: &mut self.frame,
            },
        )
        .unwrap()
    }
}

/// Send one request over `transport`, return the decoded replies' bytes.
fn request(
    dev: &mut Device<'_, MockHal>,
    transport: Transport,
    tag: u16,
    msg: Message<'_>,
) -> Vec<Vec<u8>> {
    let mut sink = VecSink::default();
    let p = Packet::new(tag, msg);
    let mut buf = [0u8; 64];
    match transport {
        Transport::Serial => {
            let n = p.encode_cobs(&mut buf).unwrap();
            // Deliver one byte at a time to exercise chunking.
            for b in &buf[..n] {
                dev.handle_bytes(std::slice::from_ref(b), &mut sink)
                    .unwrap();
            }
        }
        Transport::Usb => {
            let n = p.encode(&mut buf).unwrap();
            dev.handle_message(&buf[..n], &mut sink).unwrap();
        }
    }
    sink.messages(transport)
}

fn one(replies: &[Vec<u8>]) -> Packet<'_> {
    assert_eq!(replies.len(), 1, "expected exactly one reply");
    decode_message(&replies[0]).unwrap()
}

fn hello() -> Message<'static> {
    Message::Hello(Hello {
        version_major: PROTOCOL_VERSION_MAJOR,
        version_minor: PROTOCOL_VERSION_MINOR,
        host_max_message_len: u16::MAX,
    })
}

fn nak_code(p: &Packet<'_>) -> ErrorCode {
    match p.message {
        Message::Nak { code, .. } => code,
        m => panic!("expected Nak, got {m:?}"),
    }
}

#[test]
fn handshake_required_then_capabilities() {
    for transport in [Transport::Serial, Transport::Usb] {
        let mut rig = Rig::new(MAX_COBS_FRAME_LEN);
        let mut dev = rig.device(transport, MockHal::default());
        assert_eq!(dev.state(), DeviceState::AwaitingHello);
        let r = request(
            &mut dev,
            transport,
            9,
            Message::GetControl {
                control: Control::GainMilli,
            },
        );
        let p = one(&r);
        assert_eq!(p.tag, 9);
        assert_eq!(nak_code(&p), ErrorCode::HANDSHAKE_REQUIRED);

        // GetStatus works before the handshake.
        let r = request(&mut dev, transport, 10, Message::GetStatus);
        let Message::Status(s) = one(&r).message else {
            panic!()
        };
        assert_eq!(s.state, DeviceState::AwaitingHello);
        assert_eq!(s.temperature_milli_c, 21_500);

        let r = request(&mut dev, transport, 11, hello());
        let p = one(&r);
        assert_eq!(p.tag, 11);
        let Message::Capabilities(c) = p.message else {
            panic!("{p:?}")
        };
        assert_eq!(c.version_major, PROTOCOL_VERSION_MAJOR);
        assert_eq!(c.max_width_px, 64);
        assert_eq!(c.frame_buffer_len_bytes as usize, FRAME_BUF_LEN);
        assert_eq!(usize::from(c.chunk_data_len), MAX_CHUNK_DATA_LEN);
        assert_eq!(dev.state(), DeviceState::Ready);
    }
}

#[test]
fn version_mismatch_and_small_host_buffer() {
    let mut rig = Rig::new(MAX_COBS_FRAME_LEN);
    let mut dev = rig.device(Transport::Serial, MockHal::default());
    let r = request(
        &mut dev,
        Transport::Serial,
        1,
        Message::Hello(Hello {
            version_major: 2,
            version_minor: 0,
            host_max_message_len: 1000,
        }),
    );
    let p = one(&r);
    assert_eq!(nak_code(&p), ErrorCode::UNSUPPORTED_VERSION);
    let Message::Nak { detail, .. } = p.message else {
        panic!()
    };
    assert_eq!(detail, u32::from(PROTOCOL_VERSION_MAJOR) << 8);
    assert_eq!(dev.state(), DeviceState::AwaitingHello);

    let r = request(
        &mut dev,
        Transport::Serial,
        2,
        Message::Hello(Hello {
            version_major: 1,
            version_minor: 7,
            host_max_message_len: 1000,
        }),
    );
    let Message::Capabilities(c) = one(&r).message else {
        panic!()
    };
    // 1000 - 15 bytes overhead, rounded down to even.
    assert_eq!(c.chunk_data_len, 984);
}

#[test]
fn small_tx_buffer_limits_chunks() {
    let mut rig = Rig::new(300);
    let mut dev = rig.device(Transport::Serial, MockHal::default());
    let r = request(&mut dev, Transport::Serial, 1, hello());
    let Message::Capabilities(c) = one(&r).message else {
        panic!()
    };
    let chunk = usize::from(c.chunk_data_len);
    assert!(cobs::max_encoded_len(chunk + 15) < 300, "{chunk}");
    assert!(chunk > 250);
    let mut tiny = [0u8; 10];
    let mut frame = [0u8; 10];
    assert!(
        Device::new(
            MockHal::default(),
            config(),
            Transport::Usb,
            DeviceBuffers {
                tx: &mut tiny,
                frame: &mut frame
            }
        )
        .is_err()
    );
}

#[test]
fn set_and_get_every_control() {
    let mut rig = Rig::new(MAX_COBS_FRAME_LEN);
    let mut dev = rig.device(Transport::Serial, MockHal::default());
    request(&mut dev, Transport::Serial, 1, hello());
    let cases = [
        (Control::GainMilli, 3000),
        (Control::McpVoltageMv, 650_000),
        (Control::AgcEnabled, 1),
        (Control::AgcSetpointPpm, 250_000),
        (Control::ExposureUs, 40_000),
        (Control::GateNs, 500),
        (Control::BitDepth, 12),
        (Control::FrameSize, 32 | (24 << 16)),
        (Control::TestPattern, TestPattern::Checkerboard as u32),
    ];
    for (i, (control, value)) in cases.into_iter().enumerate() {
        let tag = 100 + i as u16;
        let r = request(
            &mut dev,
            Transport::Serial,
            tag,
            Message::SetControl { control, value },
        );
        let p = one(&r);
        assert_eq!(p.tag, tag);
        assert_eq!(
            p.message,
            Message::Ack {
                request_kind: Kind::SetControl as u8
            },
            "{control:?}"
        );
        let r = request(
            &mut dev,
            Transport::Serial,
            tag,
            Message::GetControl { control },
        );
        assert_eq!(one(&r).message, Message::ControlValue { control, value });
    }
    assert_eq!(dev.hal_mut().gain_milli, 3000);
    assert_eq!(dev.settings().pixel_format, PixelFormat::Mono12);
}

#[test]
fn out_of_range_and_unsupported() {
    let mut rig = Rig::new(MAX_COBS_FRAME_LEN);
    let mut dev = rig.device(Transport::Usb, MockHal::default());
    request(&mut dev, Transport::Usb, 1, hello());
    let bad = [
        (Control::GainMilli, 0, ErrorCode::OUT_OF_RANGE),
        (Control::GainMilli, 100_001, ErrorCode::OUT_OF_RANGE),
        (Control::McpVoltageMv, 900_001, ErrorCode::OUT_OF_RANGE),
        (Control::AgcEnabled, 2, ErrorCode::OUT_OF_RANGE),
        (Control::AgcSetpointPpm, 1_000_001, ErrorCode::OUT_OF_RANGE),
        (Control::BitDepth, 10, ErrorCode::OUT_OF_RANGE),
        (Control::FrameSize, 65 | (8 << 16), ErrorCode::OUT_OF_RANGE),
        (Control::FrameSize, 0, ErrorCode::OUT_OF_RANGE),
        (Control::TestPattern, 9, ErrorCode::OUT_OF_RANGE),
    ];
    for (control, value, code) in bad {
        let r = request(
            &mut dev,
            Transport::Usb,
            5,
            Message::SetControl { control, value },
        );
        let p = one(&r);
        assert_eq!(nak_code(&p), code, "{control:?}={value}");
    }
    // Settings unchanged.
    assert_eq!(dev.settings().gain_milli, 1000);

    // A device without an MCP says NOT_SUPPORTED.
    let mut tx = vec![0u8; 512];
    let mut frame = vec![0u8; FRAME_BUF_LEN];
    let mut cfg = config();
    cfg.features = 0;
    let mut dev = Device::new(
        MockHal::default(),
        cfg,
        Transport::Usb,
        DeviceBuffers {
            tx: &mut tx,
            frame: &mut frame,
        },
    )
    .unwrap();
    request(&mut dev, Transport::Usb, 1, hello());
    for control in [Control::McpVoltageMv, Control::AgcEnabled, Control::GateNs] {
        let r = request(&mut dev, Transport::Usb, 2, Message::GetControl { control });
        assert_eq!(nak_code(&one(&r)), ErrorCode::NOT_SUPPORTED);
    }
    let r = request(
        &mut dev,
        Transport::Usb,
        2,
        Message::SetControl {
            control: Control::TestPattern,
            value: 1,
        },
    );
    assert_eq!(nak_code(&one(&r)), ErrorCode::NOT_SUPPORTED);
}

#[test]
fn malformed_unknown_and_corrupt_requests() {
    let mut rig = Rig::new(MAX_COBS_FRAME_LEN);
    let mut dev = rig.device(Transport::Usb, MockHal::default());
    request(&mut dev, Transport::Usb, 1, hello());
    let mut sink = VecSink::default();
    // Authentic (good CRC) but unknown kind 0x30, tag 0x0102.
    let mut m = vec![0x30, 0x02, 0x01];
    m.extend_from_slice(&crc32c(&m).to_le_bytes());
    dev.handle_message(&m, &mut sink).unwrap();
    // Unknown control id 0x7F.
    let mut m = vec![Kind::GetControl as u8, 0x03, 0x00, 0x7F];
    m.extend_from_slice(&crc32c(&m).to_le_bytes());
    dev.handle_message(&m, &mut sink).unwrap();
    // Wrong length.
    let mut m = vec![Kind::StartStream as u8, 0x04, 0x00, 0x01];
    m.extend_from_slice(&crc32c(&m).to_le_bytes());
    dev.handle_message(&m, &mut sink).unwrap();
    // Bad CRC.
    dev.handle_message(&[Kind::GetStatus as u8, 5, 0, 1, 2, 3, 4], &mut sink)
        .unwrap();
    // A reply kind sent as a request.
    let p = Packet::new(6, Message::Ack { request_kind: 1 });
    let mut b = [0u8; 16];
    let n = p.encode(&mut b).unwrap();
    dev.handle_message(&b[..n], &mut sink).unwrap();

    let msgs = sink.messages(Transport::Usb);
    let got: Vec<(u16, ErrorCode)> = msgs
        .iter()
        .map(|m| {
            let p = decode_message(m).unwrap();
            (p.tag, nak_code(&p))
        })
        .collect();
    assert_eq!(
        got,
        vec![
            (0x0102, ErrorCode::UNKNOWN_MESSAGE),
            (3, ErrorCode::UNKNOWN_CONTROL),
            (4, ErrorCode::MALFORMED),
            (UNSOLICITED_TAG, ErrorCode::CORRUPT_REQUEST),
            (6, ErrorCode::UNKNOWN_MESSAGE),
        ]
    );
    let r = request(&mut dev, Transport::Usb, 7, Message::GetStatus);
    let Message::Status(s) = one(&r).message else {
        panic!()
    };
    assert_eq!(s.rx_errors, 1);
}

#[test]
fn serial_garbage_is_counted_and_resynchronised() {
    let mut rig = Rig::new(MAX_COBS_FRAME_LEN);
    let mut dev = rig.device(Transport::Serial, MockHal::default());
    let mut sink = VecSink::default();
    // Noise with a delimiter, an overlong frame, then a good Hello.
    let mut bytes = vec![0x05, 0x11, 0x00];
    bytes.extend(std::iter::repeat_n(0x42, 100));
    bytes.push(0);
    let mut h = [0u8; 32];
    let n = Packet::new(3, hello()).encode_cobs(&mut h).unwrap();
    bytes.extend_from_slice(&h[..n]);
    dev.handle_bytes(&bytes, &mut sink).unwrap();
    let msgs = sink.messages(Transport::Serial);
    assert_eq!(msgs.len(), 3);
    assert_eq!(
        nak_code(&decode_message(&msgs[0]).unwrap()),
        ErrorCode::CORRUPT_REQUEST
    );
    assert_eq!(
        nak_code(&decode_message(&msgs[1]).unwrap()),
        ErrorCode::CORRUPT_REQUEST
    );
    assert!(matches!(
        decode_message(&msgs[2]).unwrap().message,
        Message::Capabilities(_)
    ));
}

#[test]
fn slow_mcp_change_replies_pending_then_ack_or_timeout() {
    let mut rig = Rig::new(MAX_COBS_FRAME_LEN);
    let hal = MockHal {
        mcp_eta_ms: Some(100),
        pending_polls_left: 3,
        ..MockHal::default()
    };
    let mut dev = rig.device(Transport::Serial, hal);
    request(&mut dev, Transport::Serial, 1, hello());
    let set = Message::SetControl {
        control: Control::McpVoltageMv,
        value: 700_000,
    };
    let r = request(&mut dev, Transport::Serial, 42, set);
    let p = one(&r);
    assert_eq!(p.tag, 42);
    assert_eq!(
        p.message,
        Message::Pending {
            request_kind: Kind::SetControl as u8,
            eta_ms: 100
        }
    );
    // A second SetControl while pending is BUSY; GetStatus still works.
    let r = request(
        &mut dev,
        Transport::Serial,
        43,
        Message::SetControl {
            control: Control::GainMilli,
            value: 2000,
        },
    );
    assert_eq!(nak_code(&one(&r)), ErrorCode::BUSY);
    let mut sink = VecSink::default();
    for _ in 0..3 {
        assert_eq!(dev.poll(&mut sink).unwrap(), Activity::Idle);
    }
    assert!(sink.units.is_empty());
    assert_eq!(dev.settings().mcp_voltage_mv, 0, "not applied until done");
    dev.poll(&mut sink).unwrap();
    let msgs = sink.messages(Transport::Serial);
    let p = one(&msgs);
    assert_eq!(p.tag, 42);
    assert!(matches!(p.message, Message::Ack { .. }));
    assert_eq!(dev.settings().mcp_voltage_mv, 700_000);

    // Now one that never finishes: TIMEOUT after eta + grace.
    dev.hal_mut().pending_polls_left = u32::MAX;
    let r = request(&mut dev, Transport::Serial, 50, set);
    assert!(matches!(one(&r).message, Message::Pending { .. }));
    dev.hal_mut().now_us += u64::from(100 + PENDING_GRACE_MS) * 1000 - 1;
    dev.poll(&mut sink).unwrap();
    assert!(sink.units.is_empty());
    dev.hal_mut().now_us += 1;
    dev.poll(&mut sink).unwrap();
    let msgs = sink.messages(Transport::Serial);
    let p = one(&msgs);
    assert_eq!((p.tag, nak_code(&p)), (50, ErrorCode::TIMEOUT));
}

/// Poll until idle, collecting everything emitted.
fn drain(dev: &mut Device<'_, MockHal>, transport: Transport) -> Vec<Vec<u8>> {
    let mut sink = VecSink::default();
    for _ in 0..100_000 {
        if dev.poll(&mut sink).unwrap() == Activity::Idle {
            break;
        }
    }
    sink.messages(transport)
}

#[test]
fn streaming_frames_reassemble_bit_exact() {
    for transport in [Transport::Serial, Transport::Usb] {
        let mut rig = Rig::new(200); // small tx => many chunks per frame
        let mut dev = rig.device(transport, MockHal::default());
        request(&mut dev, transport, 1, hello());
        for (control, value) in [
            (Control::FrameSize, 20 | (10 << 16)),
            (Control::GainMilli, 1234),
        ] {
            request(
                &mut dev,
                transport,
                2,
                Message::SetControl { control, value },
            );
        }
        let r = request(
            &mut dev,
            transport,
            3,
            Message::StartStream { frame_count: 3 },
        );
        assert!(matches!(one(&r).message, Message::Ack { .. }));
        assert_eq!(dev.state(), DeviceState::Streaming);
        // BitDepth can't change mid-stream.
        let r = request(
            &mut dev,
            transport,
            4,
            Message::SetControl {
                control: Control::BitDepth,
                value: 8,
            },
        );
        assert_eq!(nak_code(&one(&r)), ErrorCode::BUSY);
        let r = request(
            &mut dev,
            transport,
            4,
            Message::StartStream { frame_count: 0 },
        );
        assert_eq!(nak_code(&one(&r)), ErrorCode::BUSY);

        let msgs = drain(&mut dev, transport);
        assert_eq!(dev.state(), DeviceState::Ready);
        let mut buf = vec![0u8; FRAME_BUF_LEN];
        let mut asm = FrameAssembler::new(&mut buf[..]);
        let mut frames = Vec::new();
        let mut chunks = 0;
        for m in &msgs {
            let p = decode_message(m).unwrap();
            assert_eq!(p.tag, UNSOLICITED_TAG);
            if matches!(p.message, Message::FrameChunk(_)) {
                chunks += 1;
            }
            match asm.push(&p.message) {
                AssemblyEvent::Frame { info, data } => frames.push((info, data.to_vec())),
                AssemblyEvent::InProgress => {}
                e => panic!("{e:?}"),
            }
        }
        assert_eq!(frames.len(), 3);
        assert!(chunks > 3 * 2, "{chunks}");
        for (i, (info, data)) in frames.iter().enumerate() {
            let l = info.leader;
            assert_eq!(l.seq, i as u32);
            assert_eq!(info.frames_missed, 0);
            assert_eq!((l.width_px, l.height_px), (20, 10));
            assert_eq!(l.pixel_format, PixelFormat::Mono16);
            assert_eq!(l.gain_milli, 1234);
            assert_eq!(data.len(), 400);
            let expect: Vec<u8> = (0..400u32)
                .map(|j| j.wrapping_mul(31).wrapping_add(i as u32) as u8)
                .collect();
            assert_eq!(data, &expect);
        }
        assert!(frames[1].0.leader.timestamp_us > frames[0].0.leader.timestamp_us);
    }
}

#[test]
fn stop_stream_aborts_frame_in_flight() {
    let mut rig = Rig::new(128);
    let mut dev = rig.device(Transport::Usb, MockHal::default());
    request(&mut dev, Transport::Usb, 1, hello());
    request(
        &mut dev,
        Transport::Usb,
        2,
        Message::StartStream { frame_count: 0 },
    );
    let mut sink = VecSink::default();
    for _ in 0..3 {
        dev.poll(&mut sink).unwrap(); // leader + 2 chunks
    }
    let r = request(&mut dev, Transport::Usb, 3, Message::StopStream);
    assert_eq!(r.len(), 2, "ABORTED trailer, then Ack");
    let Message::FrameTrailer(t) = decode_message(&r[0]).unwrap().message else {
        panic!()
    };
    assert_eq!(t.status, ErrorCode::ABORTED);
    assert!(t.valid_len_bytes > 0);
    assert!(matches!(
        decode_message(&r[1]).unwrap().message,
        Message::Ack { .. }
    ));
    assert_eq!(dev.state(), DeviceState::Ready);
    assert!(
        drain(&mut dev, Transport::Usb).is_empty(),
        "nothing after the Ack"
    );
    // The assembler drops the aborted frame.
    let mut buf = vec![0u8; FRAME_BUF_LEN];
    let mut asm = FrameAssembler::new(&mut buf[..]);
    let mut events = Vec::new();
    for m in sink.messages(Transport::Usb).iter().chain(r.iter()) {
        let p = decode_message(m).unwrap();
        events.push(format!("{:?}", asm.push(&p.message)));
    }
    assert!(
        events.iter().any(|e| e.contains("DeviceStatus")),
        "{events:?}"
    );
    // Stop when idle is a harmless Ack.
    let r = request(&mut dev, Transport::Usb, 4, Message::StopStream);
    assert!(matches!(one(&r).message, Message::Ack { .. }));
}

#[test]
fn capture_failure_and_truncation_are_reported() {
    let mut rig = Rig::new(MAX_MESSAGE_LEN);
    let hal = MockHal {
        fail_capture: Some(ErrorCode::HARDWARE_FAULT),
        ..MockHal::default()
    };
    let mut dev = rig.device(Transport::Usb, hal);
    request(&mut dev, Transport::Usb, 1, hello());
    request(
        &mut dev,
        Transport::Usb,
        2,
        Message::StartStream { frame_count: 2 },
    );
    dev.hal_mut().frame_ready = false;
    assert!(
        drain(&mut dev, Transport::Usb).is_empty(),
        "no frame ready yet"
    );
    dev.hal_mut().frame_ready = true;
    let mut sink = VecSink::default();
    dev.poll(&mut sink).unwrap();
    dev.poll(&mut sink).unwrap();
    let msgs = sink.messages(Transport::Usb);
    assert_eq!(msgs.len(), 2, "leader + trailer, no chunks");
    let Message::FrameTrailer(t) = decode_message(&msgs[1]).unwrap().message else {
        panic!()
    };
    assert_eq!(
        (t.status, t.valid_len_bytes, t.crc32c),
        (ErrorCode::HARDWARE_FAULT, 0, 0)
    );

    dev.hal_mut().fail_capture = None;
    dev.hal_mut().truncate_to = Some(100);
    let msgs = drain(&mut dev, Transport::Usb);
    let last = decode_message(msgs.last().unwrap()).unwrap();
    let Message::FrameTrailer(t) = last.message else {
        panic!()
    };
    assert_eq!((t.status, t.valid_len_bytes), (ErrorCode::TRUNCATED, 100));
}

#[test]
fn sink_failure_is_reported_not_fatal() {
    let mut rig = Rig::new(MAX_MESSAGE_LEN);
    let mut dev = rig.device(Transport::Usb, MockHal::default());
    let mut sink = VecSink {
        fail: true,
        ..VecSink::default()
    };
    let mut b = [0u8; 32];
    let n = Packet::new(1, hello()).encode(&mut b).unwrap();
    assert_eq!(dev.handle_message(&b[..n], &mut sink), Err(SinkError));
    // The state still advanced; the host will retry Hello, which is idempotent.
    assert_eq!(dev.state(), DeviceState::Ready);
}

#[test]
fn test_patterns_fill_expected_values() {
    let mut buf = [0u8; 32];
    let n = fill_test_pattern(TestPattern::Ramp, PixelFormat::Mono8, 4, 4, &mut buf);
    assert_eq!(n, 16);
    assert_eq!(&buf[..8], &[0, 1, 2, 3, 1, 2, 3, 4]);
    let n = fill_test_pattern(TestPattern::Flat, PixelFormat::Mono12, 2, 2, &mut buf);
    assert_eq!(n, 8);
    assert_eq!(u16::from_le_bytes([buf[0], buf[1]]), 2048);
    let n = fill_test_pattern(
        TestPattern::Checkerboard,
        PixelFormat::Mono16,
        16,
        1,
        &mut buf,
    );
    assert_eq!(n, 32);
    assert_eq!(u16::from_le_bytes([buf[30], buf[31]]), 0xFFFF);
    // Too-small buffer: fills what fits, never panics.
    assert_eq!(
        fill_test_pattern(TestPattern::Ramp, PixelFormat::Mono16, 100, 100, &mut buf),
        32
    );
}
