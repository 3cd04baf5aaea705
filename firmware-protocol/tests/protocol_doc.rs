//! The worked hex examples in `PROTOCOL.md` are generated here from the real
//! encoder, so they cannot drift from the code. The test fails if the
//! document's generated section differs; regenerate it with
//! `GLOAM_BLESS=1 cargo test -p firmware-protocol --test protocol_doc`.

use std::fmt::Write as _;
use std::path::PathBuf;

use firmware_protocol::*;

const BEGIN: &str = "<!-- BEGIN GENERATED EXAMPLES (tests/protocol_doc.rs) -->";
const END: &str = "<!-- END GENERATED EXAMPLES -->";

fn hex(bytes: &[u8]) -> String {
    let mut s = String::new();
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            s.push(if i % 24 == 0 { '\n' } else { ' ' });
            if i % 24 == 0 {
                s.push_str("         ");
            }
        }
        write!(s, "{b:02x}").unwrap();
    }
    s
}

fn example(out: &mut String, title: &str, note: &str, p: &Packet<'_>) {
    let mut raw = vec![0u8; MAX_MESSAGE_LEN];
    let n = p.encode(&mut raw).unwrap();
    let mut wire = vec![0u8; MAX_COBS_FRAME_LEN];
    let w = p.encode_cobs(&mut wire).unwrap();
    // The examples double as decode tests.
    assert_eq!(decode_message(&raw[..n]).unwrap(), *p);
    writeln!(out, "#### {title}\n").unwrap();
    if !note.is_empty() {
        writeln!(out, "{note}\n").unwrap();
    }
    writeln!(out, "```text").unwrap();
    writeln!(out, "message: {}", hex(&raw[..n])).unwrap();
    writeln!(
        out,
        "         (kind {:02x}, tag {}, CRC-32C {:08x})",
        raw[0],
        p.tag,
        u32::from_le_bytes(raw[n - 4..n].try_into().unwrap())
    )
    .unwrap();
    writeln!(out, "serial:  {}", hex(&wire[..w])).unwrap();
    writeln!(out, "```\n").unwrap();
}

fn generate() -> String {
    let mut o = String::new();
    writeln!(
        o,
        "CRC-32C check value: `crc32c(\"123456789\") = {:08x}`.\n",
        crc32c(b"123456789")
    )
    .unwrap();
    writeln!(
        o,
        "Each example shows the un-framed message (what one USB bulk transfer \
         carries) and the serial form (COBS-stuffed, ending in the `00` delimiter).\n"
    )
    .unwrap();
    let hello = Packet::new(
        1,
        Message::Hello(Hello {
            version_major: 1,
            version_minor: 0,
            host_max_message_len: MAX_MESSAGE_LEN as u16,
        }),
    );
    example(
        &mut o,
        "Hello (host → device)",
        &format!("Protocol 1.0, host accepts messages up to {MAX_MESSAGE_LEN} bytes."),
        &hello,
    );
    let caps = Packet::new(
        1,
        Message::Capabilities(Capabilities {
            version_major: 1,
            version_minor: 0,
            chunk_data_len: 16384,
            max_width_px: 1280,
            max_height_px: 1024,
            bit_depths: bit_depths::MONO8 | bit_depths::MONO12 | bit_depths::MONO16,
            features: features::MCP
                | features::AGC
                | features::GATE
                | features::TEST_PATTERN
                | features::TEMPERATURE,
            firmware_version: 0x0001_0200,
            serial_number: 0x00C0_FFEE,
            frame_buffer_len_bytes: 1280 * 1024 * 2,
        }),
    );
    example(
        &mut o,
        "Capabilities (device → host, reply to tag 1)",
        "16 KiB chunks, 1280×1024 max, 8/12/16-bit, MCP+AGC+gate+test pattern+temperature, \
         firmware 1.2.0, serial 0x00C0FFEE, 2.5 MiB frame buffer.",
        &caps,
    );
    example(
        &mut o,
        "SetControl GainMilli = 2500 (×2.5), tag 2",
        "",
        &Packet::new(
            2,
            Message::SetControl {
                control: Control::GainMilli,
                value: 2500,
            },
        ),
    );
    example(
        &mut o,
        "Ack of tag 2",
        "",
        &Packet::new(
            2,
            Message::Ack {
                request_kind: Kind::SetControl as u8,
            },
        ),
    );
    example(
        &mut o,
        "SetControl McpVoltageMv = 800000 (800 V), tag 3",
        "",
        &Packet::new(
            3,
            Message::SetControl {
                control: Control::McpVoltageMv,
                value: 800_000,
            },
        ),
    );
    example(
        &mut o,
        "Pending for tag 3 (ramp takes ~1.5 s)",
        "Followed later by `Ack`/`Nak` with tag 3.",
        &Packet::new(
            3,
            Message::Pending {
                request_kind: Kind::SetControl as u8,
                eta_ms: 1500,
            },
        ),
    );
    example(
        &mut o,
        "Nak: value out of range (tag 4, detail = rejected value 900000)",
        "",
        &Packet::new(
            4,
            Message::Nak {
                request_kind: Kind::SetControl as u8,
                code: ErrorCode::OUT_OF_RANGE,
                detail: 900_000,
            },
        ),
    );
    example(
        &mut o,
        "GetControl FrameSize, tag 5",
        "",
        &Packet::new(
            5,
            Message::GetControl {
                control: Control::FrameSize,
            },
        ),
    );
    example(
        &mut o,
        "ControlValue FrameSize = 4 × 2 (value 0x00020004), tag 5",
        "",
        &Packet::new(
            5,
            Message::ControlValue {
                control: Control::FrameSize,
                value: 4 | (2 << 16),
            },
        ),
    );
    example(
        &mut o,
        "GetStatus, tag 6",
        "",
        &Packet::new(6, Message::GetStatus),
    );
    example(
        &mut o,
        "Status, tag 6",
        "Ready, −12.5 °C, 42 frames sent, 1 receive error, device clock 9 876 543 210 µs.",
        &Packet::new(
            6,
            Message::Status(Status {
                state: DeviceState::Ready,
                temperature_milli_c: -12_500,
                frames_sent: 42,
                rx_errors: 1,
                device_time_us: 9_876_543_210,
            }),
        ),
    );
    example(
        &mut o,
        "StartStream, 1 frame, tag 7",
        "",
        &Packet::new(7, Message::StartStream { frame_count: 1 }),
    );
    // A 4×2 Mono8 frame sent in two chunks of 4 bytes.
    let pixels: [u8; 8] = [0x00, 0x10, 0x20, 0x30, 0x40, 0x50, 0x60, 0x70];
    let leader = FrameLeader {
        seq: 0,
        timestamp_us: 1_000_000,
        width_px: 4,
        height_px: 2,
        pixel_format: PixelFormat::Mono8,
        agc_enabled: true,
        test_pattern: TestPattern::Off as u8,
        gain_milli: 2500,
        mcp_voltage_mv: 800_000,
        agc_setpoint_ppm: 500_000,
        exposure_us: 20_000,
        gate_ns: 1_000,
        payload_len_bytes: 8,
    };
    example(
        &mut o,
        "FrameLeader (seq 0, 4×2 Mono8, AGC on)",
        "Timestamp 1 000 000 µs, gain ×2.5 in effect, 800 V MCP, AGC set-point 50 %, \
         20 ms exposure, 1 µs gate, 8 payload bytes.",
        &Packet::new(UNSOLICITED_TAG, Message::FrameLeader(leader)),
    );
    for k in 0..2 {
        example(
            &mut o,
            &format!("FrameChunk (seq 0, offset {})", 4 * k),
            "",
            &Packet::new(
                UNSOLICITED_TAG,
                Message::FrameChunk(FrameChunk {
                    seq: 0,
                    offset_bytes: 4 * k as u32,
                    data: &pixels[4 * k..4 * k + 4],
                }),
            ),
        );
    }
    example(
        &mut o,
        "FrameTrailer (seq 0, OK)",
        &format!(
            "`crc32c` = CRC-32C of the 8 pixel bytes `{}` = `{:08x}`.",
            hex(&pixels),
            crc32c(&pixels)
        ),
        &Packet::new(
            UNSOLICITED_TAG,
            Message::FrameTrailer(FrameTrailer {
                seq: 0,
                status: ErrorCode::OK,
                valid_len_bytes: 8,
                crc32c: crc32c(&pixels),
            }),
        ),
    );
    example(
        &mut o,
        "StopStream, tag 8",
        "",
        &Packet::new(8, Message::StopStream),
    );
    example(
        &mut o,
        "Nak: corrupt request (unsolicited, tag 0)",
        "Sent when a received frame fails COBS or CRC checks.",
        &Packet::new(
            UNSOLICITED_TAG,
            Message::Nak {
                request_kind: 0,
                code: ErrorCode::CORRUPT_REQUEST,
                detail: 0,
            },
        ),
    );
    o
}

#[test]
fn protocol_md_examples_match_the_code() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("PROTOCOL.md");
    let doc = std::fs::read_to_string(&path).expect("PROTOCOL.md exists");
    let start = doc.find(BEGIN).expect("begin marker") + BEGIN.len();
    let end = doc.find(END).expect("end marker");
    let generated = format!("\n\n{}", generate());
    if std::env::var_os("GLOAM_BLESS").is_some() {
        let new = format!("{}{}{}", &doc[..start], generated, &doc[end..]);
        std::fs::write(&path, new).unwrap();
        return;
    }
    assert!(
        doc[start..end] == generated,
        "PROTOCOL.md examples are stale; run GLOAM_BLESS=1 cargo test -p firmware-protocol --test protocol_doc"
    );
}
