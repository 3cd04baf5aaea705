//! The GigE Vision device as a sans-IO state machine: fed GVCP datagrams
//! (with their source address and the time), it returns the acknowledge to
//! send, and records what the stream side must do (start, stop, trigger,
//! resend, test packet) as [`Event`]s. No sockets, no clocks, no threads:
//! the UDP server and the tests drive it.

use std::net::{Ipv4Addr, SocketAddrV4};

use gloam_grabber::{CaptureSettings, Stimulus};

use crate::bootstrap as bs;
use crate::features::{self, XmlFacts, chunk, pixel_format, reg, value};
use crate::gvcp::{self, Status, be32, command};

/// Who the device says it is.
#[derive(Clone, Debug)]
pub struct Identity {
    pub vendor: String,
    pub model: String,
    pub version: String,
    pub manufacturer_info: String,
    pub serial: String,
    pub user_name: String,
    pub mac: [u8; 6],
    pub ip: Ipv4Addr,
    pub subnet_mask: Ipv4Addr,
    pub gateway: Ipv4Addr,
}

/// Fixed facts about the simulated camera behind the device.
#[derive(Clone, Debug)]
pub struct CameraFacts {
    pub max_width: u32,
    pub max_height: u32,
    pub resizable: bool,
    pub min_gain_milli: u32,
    pub max_gain_milli: u32,
    pub max_exposure_us: u32,
    pub has_agc: bool,
    pub mcp_range_v: Option<(f64, f64)>,
    /// The sensor's own frame rate: the default pace of the stream, Hz.
    pub sensor_frame_rate_hz: f64,
    /// Highest AcquisitionFrameRate accepted, Hz.
    pub max_frame_rate_hz: f64,
    /// Power-up settings (the sensor preset's).
    pub defaults: CaptureSettings,
}

/// What the stream side has to do, in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// A new acquisition: restart the source, block ids from 1.
    AcquisitionStart,
    AcquisitionStop,
    SoftwareTrigger,
    /// Send one test packet of the configured size (SCPS bit 31).
    FireTestPacket,
    /// Send packets `first..=last` of block `block_id` again.
    Resend {
        block_id: u64,
        first_packet: u32,
        last_packet: u32,
    },
    /// The controller went away (heartbeat expired or released control).
    ControlReleased,
    /// `GloamStimulus` was written: show this from the next frame on.
    Stimulus(Stimulus),
}

/// Stream channel 0 as configured by the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamConfig {
    pub destination: Option<SocketAddrV4>,
    /// Whole-packet size as GigE Vision counts it (IP + UDP headers included).
    pub packet_bytes: u32,
    /// Delay between packets, ns.
    pub packet_delay_ns: u32,
}

#[derive(Clone, Copy, Debug)]
struct Controller {
    addr: SocketAddrV4,
    exclusive: bool,
    last_seen_us: u64,
}

/// Counters the server feeds back into readable registers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StreamCounters {
    pub frames_sent: u32,
    pub packets_dropped: u32,
    pub packets_resent: u32,
    pub resend_requests: u32,
}

/// The settings a user set holds: what a client configures, not the
/// transport (stream channel, heartbeat) nor the world (`GloamStimulus`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct UserSet {
    settings: CaptureSettings,
    pixel_format: u32,
    frame_rate_hz: f32,
    frame_rate_enable: bool,
    mcp_voltage_v: f32,
    acquisition_mode: u32,
    frame_count: u32,
    trigger_mode: u32,
    chunk_mode: bool,
    /// `ChunkEnable` bit mask over [`chunk::DEFS`].
    chunk_enable: u32,
}

/// The device.
pub struct Device {
    identity: Identity,
    facts: CameraFacts,
    xml: Vec<u8>,
    url: String,
    controller: Option<Controller>,
    heartbeat_ms: u32,
    gvcp_config: u32,
    scp: u32,
    scps: u32,
    scpd: u32,
    scda: u32,
    stream_source_port: u16,
    settings: CaptureSettings,
    pixel_format: u32,
    frame_rate_hz: f32,
    /// `AcquisitionFrameRateEnable`: off, the sensor's own rate paces.
    frame_rate_enable: bool,
    gain_in_effect_milli: Option<u32>,
    bright_source_protection: bool,
    mcp_voltage_v: f32,
    acquisition_mode: u32,
    frame_count: u32,
    trigger_mode: u32,
    tl_locked: u32,
    acquiring: bool,
    latched_ticks: u64,
    now_us: u64,
    user_name: [u8; 16],
    /// `GloamStimulus` as last written (NUL-padded JSON).
    stimulus: Vec<u8>,
    counters: StreamCounters,
    events: Vec<Event>,
    /// Default (the preset's, read-only) and UserSet1.
    user_sets: [UserSet; 2],
    user_set_selector: u32,
    /// The set power-up and DeviceReset load (not a new control session:
    /// registers persist across sessions).
    user_set_default: u32,
    /// High word of an 8-byte double register written, waiting for its low
    /// word: (address, value).
    pending_high: Option<(u32, u32)>,
    chunk_mode: bool,
    chunk_selector: u32,
    chunk_enable: u32,
}

/// Who sent a write command, and when: what the privilege and access
/// checks of each write need.
#[derive(Clone, Copy)]
struct Caller {
    from: SocketAddrV4,
    is_controller: bool,
    now_us: u64,
}

/// An acknowledge body of a write command: the index (how much was
/// written) in its low 16 bits.
fn index_body(n: u16) -> Vec<u8> {
    let mut b = vec![0u8; 4];
    b[2..].copy_from_slice(&n.to_be_bytes());
    b
}

/// Byte offset of `addr` in the `GloamStimulus` string register.
fn stimulus_offset(addr: u32) -> Option<usize> {
    (reg::STIMULUS..reg::STIMULUS + reg::STIMULUS_BYTES)
        .contains(&addr)
        .then(|| (addr - reg::STIMULUS) as usize)
}

fn put_str(buf: &mut [u8], s: &str) {
    let n = s.len().min(buf.len().saturating_sub(1));
    buf[..n].copy_from_slice(&s.as_bytes()[..n]);
}

impl Device {
    pub fn new(identity: Identity, mut facts: CameraFacts) -> Self {
        let mcp = facts.mcp_range_v;
        let xml = features::genicam_xml(&XmlFacts {
            vendor: identity.vendor.clone(),
            model: identity.model.clone(),
            max_width: facts.max_width,
            max_height: facts.max_height,
            resizable: facts.resizable,
            max_exposure_us: f64::from(facts.max_exposure_us),
            max_frame_rate_hz: facts.max_frame_rate_hz,
            has_agc: facts.has_agc,
            mcp_range_v: mcp,
            gain_range: (
                f64::from(facts.min_gain_milli) / 1000.0,
                f64::from(facts.max_gain_milli) / 1000.0,
            ),
        })
        .into_bytes();
        let url = format!(
            "Local:{};{:x};{:x}",
            features::XML_FILE_NAME,
            features::XML_ADDRESS,
            xml.len()
        );
        let mut settings = facts.defaults;
        // The stream carries one of the three Mono formats: the digitizer
        // runs at that format's depth.
        let pf = pixel_format::for_bits(settings.bits);
        settings.bits = pixel_format::bits(pf).unwrap_or(16);
        settings.width = settings.width.min(facts.max_width);
        settings.height = settings.height.min(facts.max_height);
        settings.agc = settings.agc && facts.has_agc;
        facts.defaults = settings;
        let mut user_name = [0u8; 16];
        put_str(&mut user_name, &identity.user_name);
        let power_up = UserSet {
            settings,
            pixel_format: pf,
            frame_rate_hz: facts.sensor_frame_rate_hz as f32,
            // On, at the sensor's rate: the same pace either way until a
            // client sets a rate.
            frame_rate_enable: true,
            mcp_voltage_v: settings.mcp_voltage_mv as f32 / 1000.0,
            acquisition_mode: value::ACQUISITION_MODE_CONTINUOUS,
            frame_count: 1,
            trigger_mode: value::OFF,
            chunk_mode: false,
            chunk_enable: chunk::ALL_ENABLED,
        };
        Self {
            frame_rate_hz: facts.sensor_frame_rate_hz as f32,
            frame_rate_enable: true,
            mcp_voltage_v: settings.mcp_voltage_mv as f32 / 1000.0,
            identity,
            facts,
            xml,
            url,
            controller: None,
            heartbeat_ms: bs::DEFAULT_HEARTBEAT_MS,
            gvcp_config: 0,
            scp: 0,
            scps: bs::DEFAULT_PACKET_BYTES,
            scpd: 0,
            scda: 0,
            stream_source_port: 0,
            settings,
            pixel_format: pf,
            gain_in_effect_milli: None,
            bright_source_protection: false,
            acquisition_mode: value::ACQUISITION_MODE_CONTINUOUS,
            frame_count: 1,
            trigger_mode: value::OFF,
            tl_locked: 0,
            acquiring: false,
            latched_ticks: 0,
            now_us: 0,
            user_name,
            stimulus: vec![0; reg::STIMULUS_BYTES as usize],
            counters: StreamCounters::default(),
            events: Vec::new(),
            user_sets: [power_up; 2],
            user_set_selector: value::USER_SET_DEFAULT,
            user_set_default: value::USER_SET_DEFAULT,
            pending_high: None,
            chunk_mode: false,
            chunk_selector: 0,
            chunk_enable: chunk::ALL_ENABLED,
        }
    }

    fn current_set(&self) -> UserSet {
        UserSet {
            settings: self.settings,
            pixel_format: self.pixel_format,
            frame_rate_hz: self.frame_rate_hz,
            frame_rate_enable: self.frame_rate_enable,
            mcp_voltage_v: self.mcp_voltage_v,
            acquisition_mode: self.acquisition_mode,
            frame_count: self.frame_count,
            trigger_mode: self.trigger_mode,
            chunk_mode: self.chunk_mode,
            chunk_enable: self.chunk_enable,
        }
    }

    fn load_set(&mut self, set: u32) {
        let u = self.user_sets[(set as usize).min(1)];
        self.settings = u.settings;
        self.pixel_format = u.pixel_format;
        self.frame_rate_hz = u.frame_rate_hz;
        self.frame_rate_enable = u.frame_rate_enable;
        self.mcp_voltage_v = u.mcp_voltage_v;
        self.acquisition_mode = u.acquisition_mode;
        self.frame_count = u.frame_count;
        self.trigger_mode = u.trigger_mode;
        self.chunk_mode = u.chunk_mode;
        self.chunk_enable = u.chunk_enable;
    }

    /// DeviceReset: what a power cycle does — the UserSetDefault set is
    /// loaded (SFNC) — short of forgetting the user sets (non-volatile) and
    /// the stimulus (the world, not the device). A new control session
    /// does none of this: registers persist until power-up or DeviceReset,
    /// as on a real camera.
    fn reset(&mut self) {
        if self.controller.is_some() {
            self.release_control();
        }
        self.load_set(self.user_set_default);
        self.gain_in_effect_milli = None;
        self.pending_high = None;
        self.heartbeat_ms = bs::DEFAULT_HEARTBEAT_MS;
        self.gvcp_config = 0;
        self.scps = bs::DEFAULT_PACKET_BYTES;
        self.scpd = 0;
        self.user_set_selector = value::USER_SET_DEFAULT;
        self.chunk_selector = 0;
    }

    /// The GenICam XML served at [`features::XML_ADDRESS`].
    pub fn xml(&self) -> &[u8] {
        &self.xml
    }

    /// The capture settings the next frame is rendered with.
    pub fn settings(&self) -> CaptureSettings {
        self.settings
    }

    pub fn pixel_format(&self) -> u32 {
        self.pixel_format
    }

    /// The chunks each frame carries (`ChunkEnable` bit mask over
    /// [`chunk::DEFS`]), or `None` with `ChunkModeActive` off.
    pub fn chunks(&self) -> Option<u32> {
        self.chunk_mode.then_some(self.chunk_enable)
    }

    /// Frame period the stream is paced to, µs: the AcquisitionFrameRate
    /// period (with AcquisitionFrameRateEnable off, the sensor's own),
    /// never shorter than the exposure.
    pub fn frame_period_us(&self) -> u64 {
        let hz = if self.frame_rate_enable {
            f64::from(self.frame_rate_hz)
        } else {
            self.facts.sensor_frame_rate_hz
        };
        let p = 1e6 / hz.max(0.1);
        (p.round() as u64).max(u64::from(self.settings.exposure_us))
    }

    pub fn acquiring(&self) -> bool {
        self.acquiring
    }

    pub fn triggered(&self) -> bool {
        self.trigger_mode == value::ON
    }

    /// Frames an acquisition of the current mode takes (`None`: until stopped).
    pub fn frames_per_acquisition(&self) -> Option<u32> {
        match self.acquisition_mode {
            value::ACQUISITION_MODE_SINGLE_FRAME => Some(1),
            value::ACQUISITION_MODE_MULTI_FRAME => Some(self.frame_count.max(1)),
            _ => None,
        }
    }

    pub fn stream(&self) -> StreamConfig {
        let port = (self.scp & 0xFFFF) as u16;
        let destination = (self.scda != 0 && port != 0)
            .then(|| SocketAddrV4::new(Ipv4Addr::from(self.scda), port));
        StreamConfig {
            destination,
            packet_bytes: (self.scps & 0xFFFF).clamp(bs::MIN_PACKET_BYTES, bs::MAX_PACKET_BYTES),
            packet_delay_ns: self.scpd,
        }
    }

    /// Who holds control, if anyone.
    pub fn controller(&self) -> Option<SocketAddrV4> {
        self.controller.map(|c| c.addr)
    }

    /// The stream socket's port (reported in SCSP).
    pub fn set_stream_source_port(&mut self, port: u16) {
        self.stream_source_port = port;
    }

    /// The gain the last frame was taken at (the AGC's), thousandths.
    pub fn set_gain_in_effect(&mut self, milli: u32) {
        self.gain_in_effect_milli = Some(milli);
    }

    /// Whether bright-source protection was cutting the gain at the last frame.
    pub fn set_bright_source_protection(&mut self, active: bool) {
        self.bright_source_protection = active;
    }

    pub fn set_counters(&mut self, c: StreamCounters) {
        self.counters = c;
    }

    /// The stream side finished a SingleFrame/MultiFrame acquisition.
    pub fn acquisition_completed(&mut self) {
        self.acquiring = false;
    }

    /// Events since the last call.
    pub fn take_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    /// Expires a silent controller (heartbeat). Call periodically.
    pub fn poll(&mut self, now_us: u64) {
        if let Some(c) = self.controller {
            let disabled = self.gvcp_config & 1 != 0;
            if !disabled
                && now_us.saturating_sub(c.last_seen_us) > u64::from(self.heartbeat_ms) * 1000
            {
                self.release_control();
            }
        }
    }

    fn release_control(&mut self) {
        self.controller = None;
        if self.acquiring {
            self.acquiring = false;
            self.events.push(Event::AcquisitionStop);
        }
        self.scp = 0;
        self.scda = 0;
        self.tl_locked = 0;
        self.events.push(Event::ControlReleased);
    }

    /// Handles one datagram from `from` at `now_us` (µs on any monotonic
    /// clock; timestamps use the same clock). Returns the acknowledge to send
    /// back, if any.
    pub fn handle(&mut self, now_us: u64, from: SocketAddrV4, datagram: &[u8]) -> Option<Vec<u8>> {
        self.poll(now_us);
        self.now_us = now_us;
        let (h, payload) = gvcp::parse_command(datagram).ok()?;
        let answer = h.command.wrapping_add(1);
        let ack = |status: Status, body: &[u8]| -> Option<Vec<u8>> {
            h.ack_required()
                .then(|| gvcp::encode_ack(status, answer, h.req_id, body))
        };
        if datagram.len() > gvcp::MAX_DATAGRAM_BYTES
            || usize::from(h.length) != payload.len()
            || h.length % 4 != 0
        {
            return ack(Status::InvalidHeader, &[]);
        }
        if h.req_id == 0 && h.command != command::DISCOVERY {
            return ack(Status::InvalidHeader, &[]);
        }
        if let Some(c) = self.controller.as_mut()
            && c.addr == from
        {
            c.last_seen_us = now_us;
        }
        let is_controller = self.controller.is_some_and(|c| c.addr == from);
        let locked_out = self.controller.is_some_and(|c| c.exclusive) && !is_controller;
        let caller = Caller {
            from,
            is_controller,
            now_us,
        };
        let (status, body) = match h.command {
            command::DISCOVERY => {
                // Always unicast back to the asker.
                let body = self.discovery_data();
                return Some(gvcp::encode_ack(Status::Success, answer, h.req_id, &body));
            }
            command::READREG => self.readreg(payload, locked_out),
            command::WRITEREG => self.writereg(caller, payload),
            command::READMEM => self.readmem(payload, locked_out),
            command::WRITEMEM => self.writemem(caller, payload),
            command::PACKETRESEND => self.packetresend(h.flags, payload),
            _ => (Status::NotImplemented, Vec::new()),
        };
        ack(status, &body)
    }

    /// READREG: each 4-byte address in turn; the first failure ends the
    /// acknowledge with the values read so far.
    fn readreg(&self, payload: &[u8], locked_out: bool) -> (Status, Vec<u8>) {
        if payload.is_empty() {
            return (Status::InvalidParameter, Vec::new());
        }
        if locked_out {
            return (Status::AccessDenied, Vec::new());
        }
        let mut body = Vec::with_capacity(payload.len());
        for a in payload.chunks_exact(4) {
            match self.read_register(be32(a)) {
                Ok(v) => body.extend_from_slice(&v.to_be_bytes()),
                Err(s) => return (s, body),
            }
        }
        (Status::Success, body)
    }

    /// WRITEREG: address/value pairs in turn; the acknowledge's index
    /// counts the writes that took.
    fn writereg(&mut self, caller: Caller, payload: &[u8]) -> (Status, Vec<u8>) {
        if payload.is_empty() || payload.len() % 8 != 0 {
            return (Status::InvalidParameter, index_body(0));
        }
        let mut done: u16 = 0;
        for pair in payload.chunks_exact(8) {
            let (a, v) = (be32(&pair[..4]), be32(&pair[4..]));
            let r = if a == bs::CONTROL_CHANNEL_PRIVILEGE {
                self.write_ccp(caller.from, v, caller.now_us)
            } else if !caller.is_controller {
                Err(Status::AccessDenied)
            } else {
                self.write_register(a, v)
            };
            if let Err(s) = r {
                return (s, index_body(done));
            }
            done += 1;
        }
        (Status::Success, index_body(done))
    }

    /// READMEM: one aligned block of device memory (the XML, the strings).
    fn readmem(&self, payload: &[u8], locked_out: bool) -> (Status, Vec<u8>) {
        if payload.len() != 8 {
            return (Status::InvalidParameter, Vec::new());
        }
        if locked_out {
            return (Status::AccessDenied, Vec::new());
        }
        let addr = be32(&payload[..4]);
        let count = u32::from(gvcp::be16(&payload[6..8]));
        if count == 0 || count as usize > gvcp::MAX_MEMORY_BYTES || count % 4 != 0 {
            return (Status::InvalidParameter, payload[..4].to_vec());
        }
        if addr % 4 != 0 {
            return (Status::BadAlignment, payload[..4].to_vec());
        }
        match self.read_memory(addr, count) {
            Ok(data) => {
                let mut body = payload[..4].to_vec();
                body.extend_from_slice(&data);
                (Status::Success, body)
            }
            Err(s) => (s, payload[..4].to_vec()),
        }
    }

    /// WRITEMEM: the stimulus string as a whole, or word by word into
    /// registers; the acknowledge's index counts the bytes written.
    fn writemem(&mut self, caller: Caller, payload: &[u8]) -> (Status, Vec<u8>) {
        if payload.len() < 8 {
            return (Status::InvalidParameter, index_body(0));
        }
        let addr = be32(&payload[..4]);
        let data = &payload[4..];
        if addr % 4 != 0 {
            return (Status::BadAlignment, index_body(0));
        }
        if !caller.is_controller {
            return (Status::AccessDenied, index_body(0));
        }
        if let Some(o) = stimulus_offset(addr) {
            return match self.write_stimulus(o, data) {
                Ok(()) => (Status::Success, index_body(data.len() as u16)),
                Err(s) => (s, index_body(0)),
            };
        }
        let mut written: u16 = 0;
        for (i, w) in data.chunks_exact(4).enumerate() {
            let a = addr.wrapping_add(4 * i as u32);
            if let Err(s) = self.write_memory_word(&caller, a, w) {
                return (s, index_body(written));
            }
            written += 4;
        }
        (Status::Success, index_body(written))
    }

    /// One word of a WRITEMEM: the user-defined name, the control channel
    /// privilege, or a register.
    fn write_memory_word(&mut self, caller: &Caller, a: u32, w: &[u8]) -> Result<(), Status> {
        if bs::string_field(a).is_some_and(|(b, _)| b == bs::USER_DEFINED_NAME) {
            let o = (a - bs::USER_DEFINED_NAME) as usize;
            self.user_name[o..o + 4].copy_from_slice(w);
            self.user_name[15] = 0;
            Ok(())
        } else if a == bs::CONTROL_CHANNEL_PRIVILEGE {
            self.write_ccp(caller.from, be32(w), caller.now_us)
        } else {
            self.write_register(a, be32(w))
        }
    }

    /// PACKETRESEND: queues the resend of a packet range of one block.
    fn packetresend(&mut self, flags: u8, payload: &[u8]) -> (Status, Vec<u8>) {
        let ext = flags & gvcp::FLAG_EXTENDED_IDS != 0;
        if payload.len() != if ext { 20 } else { 12 } {
            return (Status::InvalidParameter, Vec::new());
        }
        let w0 = be32(&payload[..4]);
        if (w0 >> 16) != 0 {
            return (Status::InvalidParameter, Vec::new());
        }
        let block_id = if ext {
            u64::from(be32(&payload[12..16])) << 32 | u64::from(be32(&payload[16..20]))
        } else {
            u64::from(w0 & 0xFFFF)
        };
        let first = be32(&payload[4..8]) & 0x00FF_FFFF;
        let last = be32(&payload[8..12]) & 0x00FF_FFFF;
        if first > last && last != 0x00FF_FFFF {
            return (Status::InvalidParameter, Vec::new());
        }
        self.events.push(Event::Resend {
            block_id,
            first_packet: first,
            last_packet: last,
        });
        // No acknowledge is defined for PACKETRESEND; send one only
        // if asked.
        (Status::Success, Vec::new())
    }

    fn write_ccp(&mut self, from: SocketAddrV4, v: u32, now_us: u64) -> Result<(), Status> {
        let wants = v & (bs::CCP_CONTROL | bs::CCP_EXCLUSIVE) != 0;
        match self.controller {
            Some(c) if c.addr != from => Err(Status::AccessDenied),
            Some(_) if !wants => {
                self.release_control();
                Ok(())
            }
            _ if wants => {
                if self.controller.is_none() {
                    // A half-written double belongs to the last client;
                    // every register it wrote stays (SFNC).
                    self.pending_high = None;
                }
                self.controller = Some(Controller {
                    addr: from,
                    exclusive: v & bs::CCP_EXCLUSIVE != 0,
                    last_seen_us: now_us,
                });
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// DISCOVERY_ACK body: a copy of bootstrap memory 0x0000..0x00F8.
    fn discovery_data(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(bs::DISCOVERY_DATA_END as usize);
        for a in (0..bs::DISCOVERY_DATA_END).step_by(4) {
            // Reserved words in the block read as zero.
            out.extend_from_slice(&self.read_register(a).unwrap_or(0).to_be_bytes());
        }
        out
    }

    fn string_bytes(&self, field: u32) -> [u8; 512] {
        let mut b = [0u8; 512];
        let id = &self.identity;
        match field {
            bs::MANUFACTURER_NAME => put_str(&mut b[..32], &id.vendor),
            bs::MODEL_NAME => put_str(&mut b[..32], &id.model),
            bs::DEVICE_VERSION => put_str(&mut b[..32], &id.version),
            bs::MANUFACTURER_INFO => put_str(&mut b[..48], &id.manufacturer_info),
            bs::SERIAL_NUMBER => put_str(&mut b[..16], &id.serial),
            bs::USER_DEFINED_NAME => b[..16].copy_from_slice(&self.user_name),
            bs::FIRST_URL => put_str(&mut b, &self.url),
            _ => {}
        }
        b
    }

    /// What `GloamStimulus` reads while the camera shows `s` without a
    /// client having written it (a rig's stimulus at start). A stimulus
    /// whose JSON does not fit the register leaves it empty.
    pub fn show_stimulus(&mut self, s: &Stimulus) {
        let Ok(json) = serde_json::to_vec(s) else {
            return;
        };
        if json.len() < self.stimulus.len() {
            self.stimulus.fill(0);
            self.stimulus[..json.len()].copy_from_slice(&json);
        }
    }

    /// A WRITEMEM into `GloamStimulus` at byte `offset`: the whole string
    /// must parse as a stimulus the camera can render, else nothing changes
    /// (INVALID_PARAMETER).
    fn write_stimulus(&mut self, offset: usize, data: &[u8]) -> Result<(), Status> {
        let end = offset
            .checked_add(data.len())
            .filter(|e| *e <= self.stimulus.len())
            .ok_or(Status::InvalidAddress)?;
        let mut next = self.stimulus.clone();
        next[offset..end].copy_from_slice(data);
        let text_len = next.iter().position(|&b| b == 0).unwrap_or(next.len());
        if text_len == next.len() {
            // No terminating NUL: not a string.
            return Err(Status::InvalidParameter);
        }
        if text_len > 0 {
            let s: Stimulus =
                serde_json::from_slice(&next[..text_len]).map_err(|_| Status::InvalidParameter)?;
            gloam_simcam::render_stimulus(&s, 2, 2).map_err(|_| Status::InvalidParameter)?;
            self.events.push(Event::Stimulus(s));
        }
        self.stimulus = next;
        Ok(())
    }

    /// Device memory `addr..addr + count` (both multiples of 4).
    pub fn read_memory(&self, addr: u32, count: u32) -> Result<Vec<u8>, Status> {
        let end = addr.checked_add(count).ok_or(Status::InvalidAddress)?;
        if let Some(o) = stimulus_offset(addr) {
            let e = o + count as usize;
            return self
                .stimulus
                .get(o..e)
                .map(<[u8]>::to_vec)
                .ok_or(Status::InvalidAddress);
        }
        let xml_end = features::XML_ADDRESS + self.xml.len().div_ceil(4) as u32 * 4;
        if addr >= features::XML_ADDRESS {
            if end > xml_end {
                return Err(Status::InvalidAddress);
            }
            let mut out = vec![0u8; count as usize];
            let o = (addr - features::XML_ADDRESS) as usize;
            let avail = self.xml.len().saturating_sub(o).min(out.len());
            out[..avail].copy_from_slice(&self.xml[o..o + avail]);
            return Ok(out);
        }
        let mut out = Vec::with_capacity(count as usize);
        let mut a = addr;
        while a < end {
            if let Some((base, _)) = bs::string_field(a) {
                let s = self.string_bytes(base);
                let o = (a - base) as usize;
                out.extend_from_slice(&s[o..o + 4]);
            } else {
                out.extend_from_slice(&self.read_register(a)?.to_be_bytes());
            }
            a += 4;
        }
        Ok(out)
    }

    /// The gain in effect, linear: the AGC's under GainAuto, else the set one.
    fn gain_read(&self) -> f64 {
        let milli = match (self.settings.agc, self.gain_in_effect_milli) {
            (true, Some(m)) => m,
            _ => self.settings.gain_milli,
        };
        f64::from(milli) / 1000.0
    }

    /// The value of the 8-byte double register at `base`.
    fn double_value(&self, base: u32) -> f64 {
        match base {
            reg::GAIN_DB => features::gain_db(self.gain_read()),
            _ => self.gain_read(),
        }
    }

    /// One 4-byte register.
    pub fn read_register(&self, a: u32) -> Result<u32, Status> {
        if a % 4 != 0 {
            return Err(Status::BadAlignment);
        }
        if let Some((base, _)) = bs::string_field(a) {
            let s = self.string_bytes(base);
            return Ok(be32(&s[(a - base) as usize..]));
        }
        if let Some(o) = stimulus_offset(a) {
            return Ok(be32(&self.stimulus[o..]));
        }
        if let Some(&base) = reg::DOUBLES.iter().find(|&&b| a == b || a == b + 4) {
            let bits = self.double_value(base).to_bits();
            return Ok(if a == base {
                (bits >> 32) as u32
            } else {
                bits as u32
            });
        }
        let id = &self.identity;
        let s = &self.settings;
        let f = &self.facts;
        let mac = id.mac;
        Ok(match a {
            bs::VERSION => bs::VERSION_VALUE,
            bs::DEVICE_MODE => bs::DEVICE_MODE_VALUE,
            bs::MAC_HIGH => u32::from(u16::from_be_bytes([mac[0], mac[1]])),
            bs::MAC_LOW => u32::from_be_bytes([mac[2], mac[3], mac[4], mac[5]]),
            bs::SUPPORTED_IP_CONFIGURATION => 0b111,
            bs::CURRENT_IP_CONFIGURATION => 0b100,
            bs::CURRENT_IP => u32::from(id.ip),
            bs::CURRENT_SUBNET_MASK => u32::from(id.subnet_mask),
            bs::CURRENT_GATEWAY => u32::from(id.gateway),
            bs::NUMBER_OF_INTERFACES => 1,
            bs::PERSISTENT_IP | bs::PERSISTENT_SUBNET_MASK | bs::PERSISTENT_GATEWAY => 0,
            bs::NUMBER_OF_MESSAGE_CHANNELS => 0,
            bs::NUMBER_OF_STREAM_CHANNELS => 1,
            bs::GVCP_CAPABILITY => bs::GVCP_CAPABILITY_VALUE,
            bs::HEARTBEAT_TIMEOUT => self.heartbeat_ms,
            bs::TIMESTAMP_TICK_FREQUENCY_HIGH => (bs::TICK_FREQUENCY_HZ >> 32) as u32,
            bs::TIMESTAMP_TICK_FREQUENCY_LOW => bs::TICK_FREQUENCY_HZ as u32,
            bs::TIMESTAMP_CONTROL => 0,
            bs::TIMESTAMP_VALUE_HIGH => (self.latched_ticks >> 32) as u32,
            bs::TIMESTAMP_VALUE_LOW => self.latched_ticks as u32,
            bs::GVCP_CONFIGURATION => self.gvcp_config,
            bs::CONTROL_CHANNEL_PRIVILEGE => match self.controller {
                Some(c) => bs::CCP_CONTROL | if c.exclusive { bs::CCP_EXCLUSIVE } else { 0 },
                None => 0,
            },
            bs::STREAM_CHANNEL_PORT => self.scp,
            bs::STREAM_CHANNEL_PACKET_SIZE => self.scps & !bs::SCPS_FIRE_TEST,
            bs::STREAM_CHANNEL_PACKET_DELAY => self.scpd,
            bs::STREAM_CHANNEL_DESTINATION => self.scda,
            bs::STREAM_CHANNEL_SOURCE_PORT => u32::from(self.stream_source_port),
            bs::STREAM_CHANNEL_CAPABILITY => 0,
            bs::STREAM_CHANNEL_CONFIGURATION => 0,
            reg::WIDTH => s.width,
            reg::HEIGHT => s.height,
            reg::SENSOR_WIDTH => f.max_width,
            reg::SENSOR_HEIGHT => f.max_height,
            reg::OFFSET_X | reg::OFFSET_Y => 0,
            reg::PIXEL_FORMAT => self.pixel_format,
            reg::PAYLOAD_SIZE => self.payload_bytes(),
            reg::ACQUISITION_MODE => self.acquisition_mode,
            reg::ACQUISITION_START | reg::ACQUISITION_STOP | reg::TRIGGER_SOFTWARE => 0,
            reg::ACQUISITION_FRAME_COUNT => self.frame_count,
            reg::ACQUISITION_FRAME_RATE => self.frame_rate_hz.to_bits(),
            reg::EXPOSURE_TIME => (s.exposure_us as f32).to_bits(),
            reg::EXPOSURE_AUTO => value::EXPOSURE_AUTO_OFF,
            reg::ACQUISITION_FRAME_RATE_ENABLE => u32::from(self.frame_rate_enable),
            reg::GAIN_SELECTOR => value::GAIN_SELECTOR_ALL,
            reg::USER_SET_SELECTOR => self.user_set_selector,
            reg::USER_SET_DEFAULT => self.user_set_default,
            reg::USER_SET_LOAD | reg::USER_SET_SAVE | reg::DEVICE_RESET => 0,
            reg::GAIN_AUTO => {
                if s.agc {
                    value::GAIN_AUTO_CONTINUOUS
                } else {
                    value::GAIN_AUTO_OFF
                }
            }
            reg::GAIN_AUTO_SETPOINT if f.has_agc => (s.agc_setpoint_ppm as f32 / 1e6).to_bits(),
            reg::BRIGHT_SOURCE_PROTECTION if f.has_agc => u32::from(self.bright_source_protection),
            reg::INTENSIFIER_MCP_VOLTAGE if f.mcp_range_v.is_some() => self.mcp_voltage_v.to_bits(),
            reg::TRIGGER_SELECTOR => value::TRIGGER_SELECTOR_FRAME_START,
            reg::TRIGGER_MODE => self.trigger_mode,
            reg::TRIGGER_SOURCE => value::TRIGGER_SOURCE_SOFTWARE,
            reg::TL_PARAMS_LOCKED => self.tl_locked,
            reg::CHUNK_MODE_ACTIVE => u32::from(self.chunk_mode),
            reg::CHUNK_SELECTOR => self.chunk_selector,
            reg::CHUNK_ENABLE => (self.chunk_enable >> self.chunk_selector) & 1,
            reg::FRAMES_SENT => self.counters.frames_sent,
            reg::PACKETS_DROPPED => self.counters.packets_dropped,
            reg::PACKETS_RESENT => self.counters.packets_resent,
            reg::RESEND_REQUESTS => self.counters.resend_requests,
            _ => return Err(Status::InvalidAddress),
        })
    }

    /// Bytes of one frame's payload: the image, and in chunk mode the
    /// enabled chunks after it.
    pub fn payload_bytes(&self) -> u32 {
        let image = self.settings.width
            * self.settings.height
            * pixel_format::bytes_per_pixel(self.pixel_format) as u32;
        match self.chunks() {
            Some(enabled) => chunk::payload_bytes(image as usize, enabled) as u32,
            None => image,
        }
    }

    fn float_in(v: u32, lo: f64, hi: f64) -> Result<f64, Status> {
        let x = f64::from(f32::from_bits(v));
        // Single precision: accept the range's ends as rounded to f32.
        let (lo32, hi32) = (f64::from(lo as f32), f64::from(hi as f32));
        if x.is_finite() && x >= lo.min(lo32) && x <= hi.max(hi32) {
            Ok(x.clamp(lo, hi))
        } else {
            Err(Status::InvalidParameter)
        }
    }

    /// Sets the gain from `Gain` (dB, `base` = [`reg::GAIN_DB`]) or
    /// `GainLinear`; out of range: INVALID_PARAMETER, nothing changes.
    fn write_gain(&mut self, base: u32, x: f64) -> Result<(), Status> {
        let f = &self.facts;
        let (lo, hi) = (
            f64::from(f.min_gain_milli) / 1000.0,
            f64::from(f.max_gain_milli) / 1000.0,
        );
        let (lo, hi, linear) = if base == reg::GAIN_DB {
            (
                features::gain_db(lo),
                features::gain_db(hi),
                features::gain_linear(x),
            )
        } else {
            (lo, hi, x)
        };
        // The XML's decimal range ends, parsed back, may differ in the last
        // bit from the values computed here.
        let tol = 1e-9 * hi.abs().max(1.0);
        if !(x.is_finite() && x >= lo - tol && x <= hi + tol) {
            return Err(Status::InvalidParameter);
        }
        self.settings.gain_milli =
            ((linear * 1000.0).round() as u32).clamp(f.min_gain_milli, f.max_gain_milli);
        Ok(())
    }

    /// One 4-byte register write by the controller.
    pub fn write_register(&mut self, a: u32, v: u32) -> Result<(), Status> {
        if a % 4 != 0 {
            return Err(Status::BadAlignment);
        }
        let frozen = self.acquiring || self.tl_locked != 0;
        // What sets PayloadSize cannot change while a host streams.
        if frozen
            && matches!(
                a,
                reg::WIDTH
                    | reg::HEIGHT
                    | reg::PIXEL_FORMAT
                    | reg::CHUNK_MODE_ACTIVE
                    | reg::CHUNK_ENABLE
            )
        {
            return Err(Status::Busy);
        }
        match a {
            bs::HEARTBEAT_TIMEOUT
            | bs::GVCP_CONFIGURATION
            | bs::TIMESTAMP_CONTROL
            | bs::STREAM_CHANNEL_PORT
            | bs::STREAM_CHANNEL_PACKET_SIZE
            | bs::STREAM_CHANNEL_PACKET_DELAY
            | bs::STREAM_CHANNEL_DESTINATION
            | bs::STREAM_CHANNEL_CONFIGURATION => self.write_bootstrap(a, v),
            reg::WIDTH
            | reg::HEIGHT
            | reg::OFFSET_X
            | reg::OFFSET_Y
            | reg::PIXEL_FORMAT
            | reg::CHUNK_MODE_ACTIVE
            | reg::CHUNK_ENABLE
            | reg::CHUNK_SELECTOR
            | reg::TL_PARAMS_LOCKED => self.write_format(a, v),
            reg::ACQUISITION_MODE
            | reg::ACQUISITION_START
            | reg::ACQUISITION_STOP
            | reg::ACQUISITION_FRAME_COUNT
            | reg::ACQUISITION_FRAME_RATE
            | reg::ACQUISITION_FRAME_RATE_ENABLE
            | reg::EXPOSURE_TIME
            | reg::EXPOSURE_AUTO => self.write_acquisition(a, v),
            reg::TRIGGER_SELECTOR
            | reg::TRIGGER_SOURCE
            | reg::TRIGGER_MODE
            | reg::TRIGGER_SOFTWARE => self.write_trigger(a, v),
            _ if reg::DOUBLES.iter().any(|&b| a == b || a == b + 4) => self.write_double_word(a, v),
            reg::GAIN_SELECTOR
            | reg::GAIN_AUTO
            | reg::GAIN_AUTO_SETPOINT
            | reg::INTENSIFIER_MCP_VOLTAGE => self.write_gain_control(a, v),
            reg::USER_SET_SELECTOR
            | reg::USER_SET_DEFAULT
            | reg::USER_SET_LOAD
            | reg::USER_SET_SAVE
            | reg::DEVICE_RESET => self.write_user_set(a, v, frozen),
            _ => Err(self.not_writable(a)),
        }
    }

    /// Why a write to `a` is refused when no writable register is there:
    /// known but read-only, or nothing there at all.
    fn not_writable(&self, a: u32) -> Status {
        if self.read_register(a).is_ok() {
            Status::WriteProtect
        } else {
            Status::InvalidAddress
        }
    }

    /// The bootstrap block's writable registers: heartbeat, GVCP and
    /// timestamp control, and stream channel 0.
    fn write_bootstrap(&mut self, a: u32, v: u32) -> Result<(), Status> {
        match a {
            bs::HEARTBEAT_TIMEOUT => self.heartbeat_ms = v.max(bs::MIN_HEARTBEAT_MS),
            bs::GVCP_CONFIGURATION => self.gvcp_config = v & 1,
            bs::TIMESTAMP_CONTROL => {
                // Latch (bit 1); reset (bit 0) is accepted and ignored: the
                // clock is the server's monotonic one.
                if v & 2 != 0 {
                    self.latched_ticks = self.now_us.saturating_mul(1000);
                }
            }
            bs::STREAM_CHANNEL_PORT => self.scp = v & 0xFFFF,
            bs::STREAM_CHANNEL_PACKET_SIZE => {
                let size = v & 0xFFFF;
                if !(bs::MIN_PACKET_BYTES..=bs::MAX_PACKET_BYTES).contains(&size) {
                    return Err(Status::InvalidParameter);
                }
                self.scps = (v & !bs::SCPS_FIRE_TEST) & (bs::SCPS_DO_NOT_FRAGMENT | 0xFFFF);
                if v & bs::SCPS_FIRE_TEST != 0 {
                    self.events.push(Event::FireTestPacket);
                }
            }
            bs::STREAM_CHANNEL_PACKET_DELAY => self.scpd = v.min(1_000_000),
            bs::STREAM_CHANNEL_DESTINATION => self.scda = v,
            bs::STREAM_CHANNEL_CONFIGURATION => {
                if v != 0 {
                    return Err(Status::InvalidParameter);
                }
            }
            _ => return Err(self.not_writable(a)),
        }
        Ok(())
    }

    /// What shapes the payload: image size, offsets, pixel format, chunks,
    /// and the transport-layer lock that freezes them.
    fn write_format(&mut self, a: u32, v: u32) -> Result<(), Status> {
        let f = &self.facts;
        match a {
            reg::WIDTH => {
                let lo = if f.resizable { 1 } else { f.max_width };
                if !(lo..=f.max_width).contains(&v) {
                    return Err(Status::InvalidParameter);
                }
                self.settings.width = v;
            }
            reg::HEIGHT => {
                let lo = if f.resizable { 1 } else { f.max_height };
                if !(lo..=f.max_height).contains(&v) {
                    return Err(Status::InvalidParameter);
                }
                self.settings.height = v;
            }
            reg::OFFSET_X | reg::OFFSET_Y => {
                if v != 0 {
                    return Err(Status::InvalidParameter);
                }
            }
            reg::PIXEL_FORMAT => {
                let bits = pixel_format::bits(v).ok_or(Status::InvalidParameter)?;
                self.pixel_format = v;
                self.settings.bits = bits;
            }
            reg::CHUNK_MODE_ACTIVE | reg::CHUNK_ENABLE => {
                if v > 1 {
                    return Err(Status::InvalidParameter);
                }
                if a == reg::CHUNK_MODE_ACTIVE {
                    self.chunk_mode = v == 1;
                } else {
                    let bit = 1 << self.chunk_selector;
                    self.chunk_enable = if v == 1 {
                        self.chunk_enable | bit
                    } else {
                        self.chunk_enable & !bit
                    };
                }
            }
            reg::CHUNK_SELECTOR => {
                if v as usize >= chunk::DEFS.len() {
                    return Err(Status::InvalidParameter);
                }
                self.chunk_selector = v;
            }
            reg::TL_PARAMS_LOCKED => {
                if v > 1 {
                    return Err(Status::InvalidParameter);
                }
                self.tl_locked = v;
            }
            _ => return Err(self.not_writable(a)),
        }
        Ok(())
    }

    /// Acquisition mode, start and stop, frame count, pacing and exposure.
    fn write_acquisition(&mut self, a: u32, v: u32) -> Result<(), Status> {
        let f = &self.facts;
        match a {
            reg::ACQUISITION_MODE => {
                if v > value::ACQUISITION_MODE_MULTI_FRAME {
                    return Err(Status::InvalidParameter);
                }
                self.acquisition_mode = v;
            }
            reg::ACQUISITION_START => {
                if v != 0 {
                    if self.stream().destination.is_none() {
                        return Err(Status::Error);
                    }
                    self.acquiring = true;
                    self.events.push(Event::AcquisitionStart);
                }
            }
            reg::ACQUISITION_STOP => {
                if v != 0 && self.acquiring {
                    self.acquiring = false;
                    self.events.push(Event::AcquisitionStop);
                }
            }
            reg::ACQUISITION_FRAME_COUNT => {
                if !(1..=65535).contains(&v) {
                    return Err(Status::InvalidParameter);
                }
                self.frame_count = v;
            }
            reg::ACQUISITION_FRAME_RATE => {
                let hz = Self::float_in(v, 0.1, f.max_frame_rate_hz)?;
                self.frame_rate_hz = hz as f32;
            }
            reg::EXPOSURE_TIME => {
                let us = Self::float_in(v, 1.0, f64::from(f.max_exposure_us))?;
                self.settings.exposure_us = us.round() as u32;
            }
            // One entry: anything else is not a value it has.
            reg::EXPOSURE_AUTO => {
                if v != 0 {
                    return Err(Status::InvalidParameter);
                }
            }
            reg::ACQUISITION_FRAME_RATE_ENABLE => {
                if v > 1 {
                    return Err(Status::InvalidParameter);
                }
                self.frame_rate_enable = v == 1;
            }
            _ => return Err(self.not_writable(a)),
        }
        Ok(())
    }

    /// Trigger configuration and the software trigger.
    fn write_trigger(&mut self, a: u32, v: u32) -> Result<(), Status> {
        match a {
            reg::TRIGGER_SELECTOR | reg::TRIGGER_SOURCE => {
                if v != 0 {
                    return Err(Status::InvalidParameter);
                }
            }
            reg::TRIGGER_MODE => {
                if v > 1 {
                    return Err(Status::InvalidParameter);
                }
                self.trigger_mode = v;
            }
            reg::TRIGGER_SOFTWARE => {
                if v != 0 && self.acquiring && self.triggered() {
                    self.events.push(Event::SoftwareTrigger);
                }
            }
            _ => return Err(self.not_writable(a)),
        }
        Ok(())
    }

    /// One word of a double-precision gain register: the high word waits
    /// for the low one, which completes the value.
    fn write_double_word(&mut self, a: u32, v: u32) -> Result<(), Status> {
        if self.settings.agc {
            // Locked by GainAuto (the XML's pIsLocked): the
            // register is not writable now.
            self.pending_high = None;
            return Err(Status::WriteProtect);
        }
        if reg::DOUBLES.contains(&a) {
            // High word: wait for the low one.
            self.pending_high = Some((a, v));
            return Ok(());
        }
        let base = a - 4;
        let high = match self.pending_high.take() {
            Some((b, h)) if b == base => h,
            _ => (self.double_value(base).to_bits() >> 32) as u32,
        };
        let x = f64::from_bits((u64::from(high) << 32) | u64::from(v));
        self.write_gain(base, x)
    }

    /// Gain selector, GainAuto (the AGC), its setpoint and the MCP voltage;
    /// the AGC's registers exist only on a tube with one, the MCP's only
    /// on a tube with an MCP.
    fn write_gain_control(&mut self, a: u32, v: u32) -> Result<(), Status> {
        let f = &self.facts;
        match a {
            // One entry: anything else is not a value it has.
            reg::GAIN_SELECTOR => {
                if v != 0 {
                    return Err(Status::InvalidParameter);
                }
            }
            reg::GAIN_AUTO => match v {
                value::GAIN_AUTO_OFF => {
                    // The override: hold the gain the AGC had reached.
                    if self.settings.agc
                        && let Some(m) = self.gain_in_effect_milli
                    {
                        self.settings.gain_milli = m.clamp(f.min_gain_milli, f.max_gain_milli);
                    }
                    self.settings.agc = false;
                }
                value::GAIN_AUTO_CONTINUOUS if f.has_agc => self.settings.agc = true,
                _ => return Err(Status::InvalidParameter),
            },
            reg::GAIN_AUTO_SETPOINT if f.has_agc => {
                let x = Self::float_in(v, 0.0, 1.0)?;
                self.settings.agc_setpoint_ppm = (x * 1e6).round() as u32;
            }
            reg::INTENSIFIER_MCP_VOLTAGE if f.mcp_range_v.is_some() => {
                let (lo, hi) = f.mcp_range_v.unwrap_or((0.0, 0.0));
                let volts = Self::float_in(v, lo, hi)?;
                self.mcp_voltage_v = volts as f32;
                self.settings.mcp_voltage_mv = (volts * 1000.0).round() as u32;
            }
            _ => return Err(self.not_writable(a)),
        }
        Ok(())
    }

    /// User sets (select, load, save, the power-up default) and DeviceReset.
    fn write_user_set(&mut self, a: u32, v: u32, frozen: bool) -> Result<(), Status> {
        match a {
            reg::USER_SET_SELECTOR | reg::USER_SET_DEFAULT => {
                if v > value::USER_SET_1 {
                    return Err(Status::InvalidParameter);
                }
                if a == reg::USER_SET_SELECTOR {
                    self.user_set_selector = v;
                } else {
                    self.user_set_default = v;
                }
            }
            reg::USER_SET_LOAD if v != 0 => {
                if frozen {
                    return Err(Status::Busy);
                }
                self.load_set(self.user_set_selector);
            }
            reg::USER_SET_SAVE if v != 0 => {
                if self.user_set_selector == value::USER_SET_DEFAULT {
                    // The preset's settings cannot be overwritten.
                    return Err(Status::WriteProtect);
                }
                self.user_sets[value::USER_SET_1 as usize] = self.current_set();
            }
            reg::USER_SET_LOAD | reg::USER_SET_SAVE => {}
            reg::DEVICE_RESET => {
                if v != 0 {
                    self.reset();
                }
            }
            _ => return Err(self.not_writable(a)),
        }
        Ok(())
    }
}
