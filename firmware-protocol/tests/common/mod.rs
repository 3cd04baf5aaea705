//! Shared test helpers: a mock HAL, a recording sink and a sample of every
//! message kind.
#![allow(dead_code)]

use firmware_protocol::device::MIN_TX_LEN;
use firmware_protocol::*;

/// One of every message kind, with distinctive field values.
pub fn sample_packets(chunk_data: &[u8]) -> Vec<Packet<'_>> {
    let leader = FrameLeader {
        seq: 7,
        timestamp_us: 1_234_567,
        width_px: 4,
        height_px: 2,
        pixel_format: PixelFormat::Mono16,
        agc_enabled: true,
        test_pattern: 1,
        gain_milli: 2500,
        mcp_voltage_mv: 750_000,
        agc_setpoint_ppm: 400_000,
        exposure_us: 20_000,
        gate_ns: 1_000,
        payload_len_bytes: 16,
    };
    vec![
        Packet::new(
            1,
            Message::Hello(Hello {
                version_major: 1,
                version_minor: 0,
                host_max_message_len: 16399,
            }),
        ),
        Packet::new(
            2,
            Message::GetControl {
                control: Control::GainMilli,
            },
        ),
        Packet::new(
            3,
            Message::SetControl {
                control: Control::McpVoltageMv,
                value: 800_000,
            },
        ),
        Packet::new(4, Message::StartStream { frame_count: 10 }),
        Packet::new(5, Message::StopStream),
        Packet::new(6, Message::GetStatus),
        Packet::new(
            1,
            Message::Capabilities(Capabilities {
                version_major: 1,
                version_minor: 0,
                chunk_data_len: 16384,
                max_width_px: 1280,
                max_height_px: 1024,
                bit_depths: bit_depths::MONO8 | bit_depths::MONO12 | bit_depths::MONO16,
                features: features::MCP | features::AGC | features::GATE | features::TEST_PATTERN,
                firmware_version: 0x0001_0200,
                serial_number: 0xC0FFEE,
                frame_buffer_len_bytes: 1280 * 1024 * 2,
            }),
        ),
        Packet::new(
            4,
            Message::Ack {
                request_kind: Kind::StartStream as u8,
            },
        ),
        Packet::new(
            3,
            Message::Nak {
                request_kind: Kind::SetControl as u8,
                code: ErrorCode::OUT_OF_RANGE,
                detail: 900_000,
            },
        ),
        Packet::new(
            2,
            Message::ControlValue {
                control: Control::GainMilli,
                value: 1000,
            },
        ),
        Packet::new(
            3,
            Message::Pending {
                request_kind: Kind::SetControl as u8,
                eta_ms: 1500,
            },
        ),
        Packet::new(
            6,
            Message::Status(Status {
                state: DeviceState::Streaming,
                temperature_milli_c: -12_500,
                frames_sent: 42,
                rx_errors: 1,
                device_time_us: 9_876_543_210,
            }),
        ),
        Packet::new(UNSOLICITED_TAG, Message::FrameLeader(leader)),
        Packet::new(
            UNSOLICITED_TAG,
            Message::FrameChunk(FrameChunk {
                seq: 7,
                offset_bytes: 0,
                data: chunk_data,
            }),
        ),
        Packet::new(
            UNSOLICITED_TAG,
            Message::FrameTrailer(FrameTrailer {
                seq: 7,
                status: ErrorCode::OK,
                valid_len_bytes: chunk_data.len() as u32,
                crc32c: crc32c(chunk_data),
            }),
        ),
    ]
}

/// Records every wire unit the device sends.
#[derive(Default)]
pub struct VecSink {
    pub units: Vec<Vec<u8>>,
    pub fail: bool,
}

impl Sink for VecSink {
    fn send(&mut self, wire_bytes: &[u8]) -> Result<(), SinkError> {
        if self.fail {
            return Err(SinkError);
        }
        self.units.push(wire_bytes.to_vec());
        Ok(())
    }
}

impl VecSink {
    /// Un-frame every recorded unit (COBS for serial) into message bytes.
    pub fn messages(&mut self, transport: Transport) -> Vec<Vec<u8>> {
        let units = std::mem::take(&mut self.units);
        units
            .into_iter()
            .map(|u| match transport {
                Transport::Usb => u,
                Transport::Serial => {
                    assert_eq!(u.last(), Some(&0), "COBS unit ends with its delimiter");
                    assert!(!u[..u.len() - 1].contains(&0));
                    let mut out = vec![0u8; u.len()];
                    let n = cobs::decode_frame(&u[..u.len() - 1], &mut out).unwrap();
                    out.truncate(n);
                    out
                }
            })
            .collect()
    }
}

/// Mock hardware: a ramp image, a clock advanced by the test, a slow MCP.
pub struct MockHal {
    pub now_us: u64,
    pub gain_milli: u32,
    pub mcp_eta_ms: Option<u32>,
    /// Polls before a pending MCP change completes.
    pub pending_polls_left: u32,
    pub pending_result: Result<(), ErrorCode>,
    pub frame_ready: bool,
    pub fail_capture: Option<ErrorCode>,
    pub truncate_to: Option<usize>,
    pub captures: u32,
}

impl Default for MockHal {
    fn default() -> Self {
        Self {
            now_us: 1_000,
            gain_milli: 1000,
            mcp_eta_ms: None,
            pending_polls_left: 0,
            pending_result: Ok(()),
            frame_ready: true,
            fail_capture: None,
            truncate_to: None,
            captures: 0,
        }
    }
}

impl Hal for MockHal {
    fn now_us(&mut self) -> u64 {
        self.now_us
    }
    fn read_temperature_milli_c(&mut self) -> Option<i32> {
        Some(21_500)
    }
    fn set_gain(&mut self, gain_milli: u32) -> Result<(), ErrorCode> {
        self.gain_milli = gain_milli;
        Ok(())
    }
    fn apply_control(
        &mut self,
        control: Control,
        _value: u32,
        _settings: &Settings,
    ) -> Result<Applied, ErrorCode> {
        match (control, self.mcp_eta_ms) {
            (Control::McpVoltageMv, Some(eta_ms)) => Ok(Applied::InProgress { eta_ms }),
            _ => Ok(Applied::Done),
        }
    }
    fn poll_pending(&mut self) -> Option<Result<(), ErrorCode>> {
        if self.pending_polls_left == 0 {
            Some(self.pending_result)
        } else {
            self.pending_polls_left -= 1;
            None
        }
    }
    fn capture_frame(
        &mut self,
        settings: &Settings,
        frame: &mut [u8],
    ) -> Result<Option<CaptureInfo>, ErrorCode> {
        if !self.frame_ready {
            return Ok(None);
        }
        if let Some(code) = self.fail_capture {
            return Err(code);
        }
        for (i, b) in frame.iter_mut().enumerate() {
            *b = (i as u32).wrapping_mul(31).wrapping_add(self.captures) as u8;
        }
        self.captures += 1;
        let ts = self.now_us;
        self.now_us += u64::from(settings.exposure_us);
        Ok(Some(CaptureInfo {
            timestamp_us: ts,
            gain_milli: self.gain_milli,
            mcp_voltage_mv: settings.mcp_voltage_mv,
            valid_len_bytes: self.truncate_to.unwrap_or(frame.len()).min(frame.len()),
        }))
    }
}

pub fn config() -> DeviceConfig {
    DeviceConfig {
        max_width_px: 64,
        max_height_px: 48,
        bit_depths: bit_depths::MONO8 | bit_depths::MONO12 | bit_depths::MONO16,
        features: features::MCP | features::AGC | features::GATE | features::TEST_PATTERN,
        firmware_version: 0x0001_0000,
        serial_number: 1234,
        max_gain_milli: 100_000,
        max_mcp_voltage_mv: 900_000,
        max_exposure_us: 10_000_000,
        initial_settings: Settings {
            width_px: 16,
            height_px: 8,
            ..Settings::default()
        },
    }
}

pub const FRAME_BUF_LEN: usize = 64 * 48 * 2;

pub fn tx_len_min() -> usize {
    MIN_TX_LEN
}
