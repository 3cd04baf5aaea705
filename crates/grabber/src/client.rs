//! The protocol client: a [`FrameGrabber`](crate::FrameGrabber) over any [`Transport`].
//!
//! Guarantees (see `firmware-protocol/PROTOCOL.md` for the wire rules):
//! - a frame is returned as good only when the frame assembler verified it
//!   (leader consistent, every chunk at the next offset, sizes agree, trailer
//!   status OK, CRC-32C of the pixels matches);
//! - every frame lost on the link is reported: damaged frames (leader seen)
//!   as [`GrabError::FrameDamaged`], frames never seen as
//!   [`GrabError::FramesLost`] (sequence gaps), and frames lost while the
//!   device was away as [`GrabError::Interrupted`] (counted from the
//!   device's `frames_sent` when it did not reset);
//! - control requests are retried with fresh tags on timeout or
//!   `CORRUPT_REQUEST`; `Pending` replies extend the wait;
//! - every wait has a deadline;
//! - when the link drops, the port is re-opened and the session (handshake,
//!   controls, stream) restored, within [`ClientOptions::reconnect_timeout`].

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use firmware_protocol::{
    AssemblyEvent, Capabilities, CobsAccumulator, Control, DeviceState, DropReason, ErrorCode,
    Feed, FrameAssembler, Hello, MAX_COBS_FRAME_LEN, MAX_MESSAGE_LEN, Message, Packet, PixelFormat,
    Status, decode_message,
};

use crate::interface::{Frame, FrameMeta, FrameStatus, FrameStream, GrabError, Stimulus};
use crate::transport::{Framing, Transport};

/// Tuning of the client.
#[derive(Clone, Debug)]
pub struct ClientOptions {
    /// Wait for a reply before resending (the protocol's `REPLY_TIMEOUT_MS`).
    pub reply_timeout: Duration,
    /// Attempts per control request.
    pub retries: u32,
    /// How long to keep trying to re-open a link that went away.
    pub reconnect_timeout: Duration,
    /// Stream silence after which a partial frame is dropped and the device probed.
    pub frame_idle_timeout: Duration,
    /// Cap on the message size announced in `Hello` (sets the chunk size);
    /// `None`: chosen from the line rate (≤ 100 ms per chunk), at most a full chunk.
    pub max_message_len: Option<u16>,
}

impl Default for ClientOptions {
    fn default() -> Self {
        Self {
            reply_timeout: Duration::from_millis(u64::from(firmware_protocol::REPLY_TIMEOUT_MS)),
            retries: 5,
            reconnect_timeout: Duration::from_secs(10),
            frame_idle_timeout: Duration::from_millis(u64::from(
                firmware_protocol::FRAME_IDLE_TIMEOUT_MS,
            )),
            max_message_len: None,
        }
    }
}

/// Link statistics kept by the client.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ClientStats {
    pub frames_ok: u64,
    /// Frames whose leader arrived but that failed a check.
    pub frames_damaged: u64,
    /// Frames never seen (sequence gaps and device `frames_sent` accounting).
    pub frames_lost: u64,
    /// Interruptions (link lost or device reset) recovered from.
    pub interruptions: u64,
    /// Interruptions where the number of lost frames could not be known (device reset).
    pub interruptions_uncounted: u64,
    /// Messages that failed COBS or CRC checks.
    pub corrupt_messages: u64,
    /// Control requests resent.
    pub retries: u64,
    /// Pixel payload bytes of good frames.
    pub payload_bytes_ok: u64,
    /// Whole frames captured before the last `present` took effect, dropped.
    pub frames_stale: u64,
}

/// Controls the user asked for; re-applied after a reconnect.
#[derive(Clone, Copy, Debug, Default)]
struct Desired {
    gain_milli: Option<u32>,
    agc: Option<bool>,
    bits: Option<u8>,
    exposure_us: Option<u32>,
}

/// A request to send: a protocol message, or raw kind + body (extensions).
#[derive(Clone, Copy)]
enum Req<'b> {
    Msg(Message<'static>),
    Raw { kind: u8, body: &'b [u8] },
}

/// What one pass of the receive pump produced.
enum Event {
    Reply {
        tag: u16,
        message: Message<'static>,
    },
    /// Stream data was consumed (maybe a frame outcome was queued).
    Stream,
    Timeout,
}

struct Epoch {
    /// Device `frames_sent` when the stream started (None: unknown).
    base_frames_sent: Option<u32>,
    /// Device clock at the stream start, to detect a device reset.
    base_device_time_us: u64,
    /// One past the highest seq accounted for (delivered, damaged or lost).
    accounted: u64,
}

/// The protocol client over a transport `T`.
pub struct ProtocolGrabber<T: Transport> {
    link: T,
    framing: Framing,
    opts: ClientOptions,
    cobs: CobsAccumulator<Vec<u8>>,
    raw: Vec<u8>,
    raw_pos: usize,
    raw_len: usize,
    assembler: FrameAssembler<Vec<u8>>,
    tx: Vec<u8>,
    next_tag: u16,
    caps: Option<Capabilities>,
    streaming: bool,
    epoch: Option<Epoch>,
    desired: Desired,
    outcomes: VecDeque<Result<Frame, GrabError>>,
    last_stream_rx: Instant,
    /// A link loss or device reset that still has to be reported.
    interrupted: Option<String>,
    /// The device lost its state since the last stream start (power cycle,
    /// re-enumeration): frames lost in between cannot be counted.
    device_was_reset: bool,
    /// Latest device clock seen in a `Status` (a jump back means a reset).
    last_device_time_us: u64,
    /// Highest leader seq seen in the current stream.
    last_leader_seq: Option<u32>,
    /// Frames of the current stream below this seq were captured before
    /// the last `present` took effect: dropped as stale, not as losses.
    fresh_from_seq: u64,
    /// Whether the device understands the emulator's stimulus request.
    stimulus_supported: Option<bool>,
    stats: ClientStats,
    frame_size: (u32, u32),
}

fn owned(m: &Message<'_>) -> Option<Message<'static>> {
    Some(match *m {
        Message::Capabilities(c) => Message::Capabilities(c),
        Message::Ack { request_kind } => Message::Ack { request_kind },
        Message::Nak {
            request_kind,
            code,
            detail,
        } => Message::Nak {
            request_kind,
            code,
            detail,
        },
        Message::ControlValue { control, value } => Message::ControlValue { control, value },
        Message::Pending {
            request_kind,
            eta_ms,
        } => Message::Pending {
            request_kind,
            eta_ms,
        },
        Message::Status(s) => Message::Status(s),
        _ => return None,
    })
}

fn reason_text(r: &DropReason) -> String {
    match r {
        DropReason::MissingTrailer => "trailer lost (next leader arrived first)".into(),
        DropReason::SequenceMismatch { got_seq } => {
            format!("sequence mismatch (data of frame {got_seq} inside this frame)")
        }
        DropReason::OffsetGap {
            expected_offset,
            got_offset,
        } => format!("chunk lost (expected offset {expected_offset}, got {got_offset})"),
        DropReason::Oversize => "more data than the leader announced".into(),
        DropReason::TooLargeForBuffer { payload_len_bytes } => {
            format!("payload of {payload_len_bytes} bytes exceeds the receive buffer")
        }
        DropReason::InconsistentLeader => "leader size fields inconsistent".into(),
        DropReason::LengthMismatch { received_len_bytes } => {
            format!("size mismatch ({received_len_bytes} bytes received)")
        }
        DropReason::BadCrc { expected, computed } => {
            format!("pixel CRC-32C mismatch (trailer {expected:#010x}, computed {computed:#010x})")
        }
        DropReason::DeviceStatus(code) => format!("device reported {code}"),
        DropReason::Aborted => "stream went silent mid-frame".into(),
    }
}

impl<T: Transport> ProtocolGrabber<T> {
    /// Connect: handshake now (so a wrong device fails here, not at the first grab).
    pub fn connect(link: T, opts: ClientOptions) -> Result<Self, GrabError> {
        let framing = link.framing();
        let mut g = Self {
            link,
            framing,
            opts,
            cobs: CobsAccumulator::new(vec![0; MAX_MESSAGE_LEN]),
            raw: vec![0; 64 * 1024],
            raw_pos: 0,
            raw_len: 0,
            assembler: FrameAssembler::new(Vec::new()),
            tx: vec![0; MAX_COBS_FRAME_LEN],
            next_tag: 1,
            caps: None,
            streaming: false,
            epoch: None,
            desired: Desired::default(),
            outcomes: VecDeque::new(),
            last_stream_rx: Instant::now(),
            interrupted: None,
            device_was_reset: false,
            last_device_time_us: 0,
            last_leader_seq: None,
            fresh_from_seq: 0,
            stimulus_supported: None,
            stats: ClientStats::default(),
            frame_size: (0, 0),
        };
        g.link.clear_input();
        g.handshake()?;
        Ok(g)
    }

    /// Link statistics so far.
    pub fn stats(&self) -> ClientStats {
        self.stats
    }

    /// The device's capabilities from the last handshake.
    pub fn capabilities(&self) -> Option<Capabilities> {
        self.caps
    }

    /// Stop streaming and account for the frames the device produced that
    /// were never handed out (in flight when the stream stopped): returns
    /// their number when the device could tell. Undelivered outcomes that
    /// were still queued are discarded (and counted).
    pub fn finish(&mut self) -> Result<Option<u64>, GrabError> {
        let mut undelivered = 0u64;
        for o in self.outcomes.drain(..) {
            undelivered += match o {
                Ok(_) | Err(GrabError::FrameDamaged { .. }) => 1,
                Err(GrabError::FramesLost { count, .. }) => count,
                Err(GrabError::Interrupted {
                    frames_lost: Some(n),
                    ..
                }) => n,
                Err(_) => 0,
            };
        }
        if !self.streaming {
            return Ok(Some(undelivered));
        }
        let Some(ep) = self.epoch.take() else {
            return Ok(Some(undelivered));
        };
        self.streaming = false;
        self.assembler.abort();
        let stop = self.with_session(|g| g.request(Message::StopStream));
        stop?;
        let status = self.get_status()?;
        let tail = match ep.base_frames_sent {
            _ if self.device_was_reset => None,
            Some(base)
                if status.device_time_us >= ep.base_device_time_us
                    && status.frames_sent >= base =>
            {
                Some(
                    u64::from(status.frames_sent - base).saturating_sub(ep.accounted) + undelivered,
                )
            }
            _ => None,
        };
        Ok(tail)
    }

    /// Set any protocol control by its wire value (e.g. MCP voltage in mV,
    /// AGC set-point in ppm, test pattern), waiting through `Pending`
    /// replies; remembered only for the controls of [`FrameGrabber`](crate::FrameGrabber).
    pub fn set_control_raw(&mut self, control: Control, value: u32) -> Result<(), GrabError> {
        self.with_session(|g| g.set_control(control, value, &format!("{control:?}")))
    }

    /// Read any protocol control's wire value.
    pub fn get_control_raw(&mut self, control: Control) -> Result<u32, GrabError> {
        self.with_session(|g| g.get_control(control, &format!("{control:?}")))
    }

    /// The transport.
    pub fn transport(&self) -> &T {
        &self.link
    }

    fn tag(&mut self) -> u16 {
        let t = self.next_tag;
        self.next_tag = self.next_tag.checked_add(1).unwrap_or(1);
        t
    }

    /// Largest message we accept: bounded so a chunk takes ≤ ~100 ms on a
    /// slow line (cheap to lose), at most a full chunk.
    fn host_max_message_len(&self) -> u16 {
        let cap = match self.link.line_rate_bytes_per_s() {
            Some(rate) => ((rate * 0.1) as usize).clamp(1024, MAX_MESSAGE_LEN),
            None => MAX_MESSAGE_LEN,
        };
        let cap = cap.min(usize::from(u16::MAX)) as u16;
        self.opts.max_message_len.map_or(cap, |m| m.clamp(64, cap))
    }

    fn send_packet(&mut self, p: &Packet<'_>) -> Result<(), GrabError> {
        let n = match self.framing {
            Framing::Cobs => p.encode_cobs(&mut self.tx),
            Framing::UsbTransfers => p.encode(&mut self.tx),
        }
        .map_err(GrabError::Encode)?;
        let timeout = self.opts.reply_timeout.max(Duration::from_millis(100));
        self.link
            .send(&self.tx[..n], timeout)
            .map_err(GrabError::Link)
    }

    /// Receive and handle messages until a reply arrives, stream data was
    /// consumed, or `deadline` passes.
    fn pump(&mut self, deadline: Instant) -> Result<Event, GrabError> {
        loop {
            // Drain what we already have.
            match self.framing {
                Framing::Cobs => {
                    while self.raw_pos < self.raw_len {
                        let (used, feed) = self.cobs.feed(&self.raw[self.raw_pos..self.raw_len]);
                        self.raw_pos += used;
                        match feed {
                            Feed::NeedMore => {}
                            Feed::Error(_) => self.stats.corrupt_messages += 1,
                            Feed::Frame(f) => {
                                let f = f.to_vec();
                                if let Some(ev) = self.handle_message(&f) {
                                    return Ok(ev);
                                }
                            }
                        }
                    }
                }
                Framing::UsbTransfers => {
                    if self.raw_len > 0 {
                        let n = std::mem::take(&mut self.raw_len);
                        let msg = self.raw[..n].to_vec();
                        if let Some(ev) = self.handle_message(&msg) {
                            return Ok(ev);
                        }
                    }
                }
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(Event::Timeout);
            }
            let wait = (deadline - now).min(Duration::from_millis(50));
            let n = self
                .link
                .recv(&mut self.raw, wait)
                .map_err(GrabError::Link)?;
            self.raw_pos = 0;
            self.raw_len = n;
        }
    }

    /// Handle one un-framed message; `Some` when the caller should look.
    fn handle_message(&mut self, bytes: &[u8]) -> Option<Event> {
        let packet = match decode_message(bytes) {
            Ok(p) => p,
            Err(_) => {
                self.stats.corrupt_messages += 1;
                return None;
            }
        };
        let msg = packet.message;
        if let Some(m) = owned(&msg) {
            return Some(Event::Reply {
                tag: packet.tag,
                message: m,
            });
        }
        if !matches!(
            msg,
            Message::FrameLeader(_) | Message::FrameChunk(_) | Message::FrameTrailer(_)
        ) {
            return None; // a request kind from a device: ignore
        }
        self.last_stream_rx = Instant::now();
        if !self.streaming {
            // Leftovers of a stream we stopped ourselves: not a loss.
            return None;
        }
        if let Message::FrameLeader(l) = &msg {
            self.last_leader_seq = Some(self.last_leader_seq.map_or(l.seq, |s| s.max(l.seq)));
        }
        let (seq, item) = match self.assembler.push(&msg) {
            AssemblyEvent::NotStream | AssemblyEvent::InProgress => return Some(Event::Stream),
            AssemblyEvent::Dropped { seq, reason } => (
                seq,
                Err(GrabError::FrameDamaged {
                    seq: u64::from(seq),
                    reason: reason_text(&reason),
                }),
            ),
            AssemblyEvent::Frame { info, data } => {
                let l = info.leader;
                let pixels: Vec<u16> = match l.pixel_format {
                    PixelFormat::Mono8 => data.iter().map(|&b| u16::from(b)).collect(),
                    PixelFormat::Mono12 | PixelFormat::Mono16 => data
                        .chunks_exact(2)
                        .map(|c| u16::from_le_bytes([c[0], c[1]]))
                        .collect(),
                };
                let bits = l.pixel_format.bit_depth() as u8;
                if bits < 16 && pixels.iter().any(|&p| p >> bits != 0) {
                    // Authentic bytes but out of range: never pass them on.
                    (
                        l.seq,
                        Err(GrabError::FrameDamaged {
                            seq: u64::from(l.seq),
                            reason: format!("pixel values exceed {bits} bits"),
                        }),
                    )
                } else {
                    let meta = FrameMeta {
                        seq: u64::from(l.seq),
                        timestamp_us: l.timestamp_us,
                        gain: f64::from(l.gain_milli) / 1000.0,
                        agc: l.agc_enabled,
                        bits,
                        width: u32::from(l.width_px),
                        height: u32::from(l.height_px),
                        pixels_crc32c: crate::pixels_crc32c(&pixels),
                        status: FrameStatus::Ok,
                        levels: None,
                        // The leader carries the exposure setting, not the
                        // gate duty in effect (autogating is the camera's).
                        exposure_us: Some(f64::from(l.exposure_us)),
                        gate_duty: None,
                        nd_density: None,
                        sensor: None,
                    };
                    (l.seq, Ok(Frame { meta, pixels }))
                }
            }
        };
        self.account(u64::from(seq), item);
        Some(Event::Stream)
    }

    /// Queue one frame outcome, first reporting any frames skipped since
    /// the last one accounted for (the sequence gap).
    fn account(&mut self, seq: u64, item: Result<Frame, GrabError>) {
        if let Some(ep) = &mut self.epoch {
            if seq > ep.accounted {
                let count = seq - ep.accounted;
                self.stats.frames_lost += count;
                self.outcomes.push_back(Err(GrabError::FramesLost {
                    count,
                    next_seq: seq,
                }));
            }
            ep.accounted = ep.accounted.max(seq + 1);
        }
        if matches!(&item, Ok(f) if f.meta.seq < self.fresh_from_seq) {
            self.stats.frames_stale += 1;
            return;
        }
        match &item {
            Ok(f) => {
                self.stats.frames_ok += 1;
                let bpp = if f.meta.bits == 8 { 1 } else { 2 };
                self.stats.payload_bytes_ok += (f.pixels.len() * bpp) as u64;
            }
            Err(_) => self.stats.frames_damaged += 1,
        }
        self.outcomes.push_back(item);
    }

    /// Send `message` and wait for its reply, resending with a fresh tag on
    /// timeout or when the device reports a corrupt request.
    fn request(&mut self, message: Message<'static>) -> Result<Message<'static>, GrabError> {
        self.request_any(Req::Msg(message))
    }

    fn send_raw(&mut self, tag: u16, kind: u8, body: &[u8]) -> Result<(), GrabError> {
        let mut un = Vec::with_capacity(body.len() + 7);
        un.push(kind);
        un.extend_from_slice(&tag.to_le_bytes());
        un.extend_from_slice(body);
        un.extend_from_slice(&firmware_protocol::crc32c(&un).to_le_bytes());
        let wire = match self.framing {
            Framing::Cobs => {
                let mut out = vec![0u8; firmware_protocol::cobs::max_encoded_len(un.len()) + 1];
                let n = firmware_protocol::cobs::encode_frame(&un, &mut out)
                    .map_err(GrabError::Encode)?;
                out.truncate(n);
                out
            }
            Framing::UsbTransfers => un,
        };
        let timeout = self.opts.reply_timeout.max(Duration::from_millis(100));
        self.link.send(&wire, timeout).map_err(GrabError::Link)
    }

    fn request_any(&mut self, req: Req<'_>) -> Result<Message<'static>, GrabError> {
        let kind = match req {
            Req::Msg(m) => format!("{:?}", m.kind()),
            Req::Raw { kind, .. } => format!("request {kind:#04x}"),
        };
        for attempt in 0..self.opts.retries.max(1) {
            if attempt > 0 {
                self.stats.retries += 1;
            }
            let tag = self.tag();
            match req {
                Req::Msg(m) => self.send_packet(&Packet::new(tag, m))?,
                Req::Raw { kind, body } => self.send_raw(tag, kind, body)?,
            }
            let mut deadline = Instant::now() + self.opts.reply_timeout;
            loop {
                match self.pump(deadline)? {
                    Event::Timeout => break,
                    Event::Stream => {}
                    Event::Reply { tag: t, message: m } if t == tag => match m {
                        Message::Pending { eta_ms, .. } => {
                            let grace = u64::from(firmware_protocol::PENDING_GRACE_MS);
                            deadline = Instant::now()
                                + Duration::from_millis(u64::from(eta_ms) + 2 * grace);
                        }
                        m => return Ok(m),
                    },
                    Event::Reply {
                        tag: 0,
                        message:
                            Message::Nak {
                                code: ErrorCode::CORRUPT_REQUEST,
                                ..
                            },
                    } => break,
                    Event::Reply { .. } => {} // stale reply to an earlier attempt
                }
            }
        }
        let after_ms =
            self.opts.reply_timeout.as_millis() as u64 * u64::from(self.opts.retries.max(1));
        Err(GrabError::Timeout {
            what: format!(
                "the reply to {kind:?} ({} attempts)",
                self.opts.retries.max(1)
            ),
            after_ms,
        })
    }

    fn nak_error(what: &str, code: ErrorCode, detail: u32) -> GrabError {
        match code {
            ErrorCode::OUT_OF_RANGE => {
                GrabError::InvalidSetting(format!("{what}: value {detail} out of range"))
            }
            ErrorCode::NOT_SUPPORTED | ErrorCode::UNKNOWN_CONTROL => {
                GrabError::Unsupported(format!("{what}: not supported by this device"))
            }
            ErrorCode::HANDSHAKE_REQUIRED => {
                GrabError::Disconnected(format!("{what}: device was reset (handshake required)"))
            }
            code => GrabError::Nak {
                what: what.to_string(),
                code,
            },
        }
    }

    /// Hello → Capabilities, then restore the requested controls.
    fn handshake(&mut self) -> Result<(), GrabError> {
        self.caps = None;
        self.streaming = false;
        if self.interrupted.is_some() {
            // Before `Hello` resets the session: did the device keep its
            // state (link loss only) or was it reset?
            self.get_status()?;
        }
        let hello = Hello {
            version_major: firmware_protocol::PROTOCOL_VERSION_MAJOR,
            version_minor: firmware_protocol::PROTOCOL_VERSION_MINOR,
            host_max_message_len: self.host_max_message_len(),
        };
        let caps = match self.request(Message::Hello(hello))? {
            Message::Capabilities(c) => c,
            Message::Nak {
                code: ErrorCode::UNSUPPORTED_VERSION,
                detail,
                ..
            } => {
                return Err(GrabError::Device(format!(
                    "device speaks protocol {}.{}, this host {}.{}",
                    detail >> 8,
                    detail & 0xFF,
                    firmware_protocol::PROTOCOL_VERSION_MAJOR,
                    firmware_protocol::PROTOCOL_VERSION_MINOR
                )));
            }
            m => {
                return Err(GrabError::Device(format!(
                    "unexpected reply to Hello: {m:?}"
                )));
            }
        };
        if caps.version_major != firmware_protocol::PROTOCOL_VERSION_MAJOR {
            return Err(GrabError::Device(format!(
                "device protocol major version {} unsupported",
                caps.version_major
            )));
        }
        // Never trust the device with our memory: a frame can be at most
        // max width × max height × 2 bytes, whatever it claims to buffer.
        let max_frame = usize::from(caps.max_width_px) * usize::from(caps.max_height_px) * 2;
        let buf_len = (caps.frame_buffer_len_bytes as usize)
            .min(max_frame)
            .min(256 << 20);
        self.assembler = FrameAssembler::new(vec![0; buf_len]);
        self.caps = Some(caps);
        let d = self.desired;
        if let Some(b) = d.bits {
            self.set_control(Control::BitDepth, u32::from(b), "bit depth")?;
        }
        if let Some(e) = d.exposure_us {
            self.set_control(Control::ExposureUs, e, "exposure")?;
        }
        if let Some(g) = d.gain_milli {
            self.set_control(Control::GainMilli, g, "gain")?;
        }
        if let Some(a) = d.agc {
            self.set_control(Control::AgcEnabled, u32::from(a), "AGC")?;
        }
        let size = self.get_control(Control::FrameSize, "frame size")?;
        self.frame_size = (size & 0xFFFF, size >> 16);
        Ok(())
    }

    fn set_control(&mut self, control: Control, value: u32, what: &str) -> Result<(), GrabError> {
        match self.request(Message::SetControl { control, value })? {
            Message::Ack { .. } => Ok(()),
            Message::Nak { code, detail, .. } => Err(Self::nak_error(what, code, detail)),
            m => Err(GrabError::Device(format!(
                "unexpected reply to set {what}: {m:?}"
            ))),
        }
    }

    fn get_control(&mut self, control: Control, what: &str) -> Result<u32, GrabError> {
        match self.request(Message::GetControl { control })? {
            Message::ControlValue { value, .. } => Ok(value),
            Message::Nak { code, detail, .. } => Err(Self::nak_error(what, code, detail)),
            m => Err(GrabError::Device(format!(
                "unexpected reply to get {what}: {m:?}"
            ))),
        }
    }

    fn get_status(&mut self) -> Result<Status, GrabError> {
        match self.request(Message::GetStatus)? {
            Message::Status(s) => {
                let reset = s.device_time_us < self.last_device_time_us
                    || (self.interrupted.is_some() && s.state == DeviceState::AwaitingHello);
                if reset {
                    self.device_was_reset = true;
                }
                self.last_device_time_us = s.device_time_us;
                Ok(s)
            }
            m => Err(GrabError::Device(format!(
                "unexpected reply to GetStatus: {m:?}"
            ))),
        }
    }

    /// Start a stream, first reporting an interruption of the previous one.
    fn start_stream(&mut self) -> Result<(), GrabError> {
        let status = self.get_status()?;
        if status.state == DeviceState::AwaitingHello {
            return Err(GrabError::Disconnected("device was reset".into()));
        }
        if let Some(reason) = self.interrupted.take() {
            let lost = match &self.epoch {
                _ if self.device_was_reset => None,
                Some(ep) => match ep.base_frames_sent {
                    Some(base)
                        if status.device_time_us >= ep.base_device_time_us
                            && status.frames_sent >= base =>
                    {
                        Some(u64::from(status.frames_sent - base).saturating_sub(ep.accounted))
                    }
                    _ => None,
                },
                None => Some(0),
            };
            self.stats.interruptions += 1;
            match lost {
                Some(0) => {}
                Some(n) => {
                    self.stats.frames_lost += n;
                    self.outcomes.push_back(Err(GrabError::Interrupted {
                        reason,
                        frames_lost: Some(n),
                    }));
                }
                None => {
                    self.stats.interruptions_uncounted += 1;
                    self.outcomes.push_back(Err(GrabError::Interrupted {
                        reason,
                        frames_lost: None,
                    }));
                }
            }
        }
        self.assembler.reset();
        // Open the epoch before asking: if the link drops between the
        // device starting and our seeing its Ack, the frames it streams
        // meanwhile are still counted at the next recovery.
        self.device_was_reset = false;
        self.last_leader_seq = None;
        self.fresh_from_seq = 0;
        self.epoch = Some(Epoch {
            base_frames_sent: Some(status.frames_sent),
            base_device_time_us: status.device_time_us,
            accounted: 0,
        });
        match self.request(Message::StartStream { frame_count: 0 })? {
            Message::Ack { .. } => {}
            // A resent StartStream whose first copy already started the stream.
            Message::Nak {
                code: ErrorCode::BUSY,
                ..
            } => {}
            Message::Nak { code, detail, .. } => {
                self.epoch = None;
                return Err(Self::nak_error("start stream", code, detail));
            }
            m => {
                return Err(GrabError::Device(format!(
                    "unexpected reply to StartStream: {m:?}"
                )));
            }
        }
        self.streaming = true;
        self.last_stream_rx = Instant::now();
        Ok(())
    }

    fn stop_stream(&mut self) -> Result<(), GrabError> {
        if !self.streaming {
            return Ok(());
        }
        self.streaming = false;
        self.epoch = None;
        self.assembler.abort();
        match self.request(Message::StopStream)? {
            Message::Ack { .. } => Ok(()),
            Message::Nak { code, detail, .. } => Err(Self::nak_error("stop stream", code, detail)),
            m => Err(GrabError::Device(format!(
                "unexpected reply to StopStream: {m:?}"
            ))),
        }
    }

    /// The link or device went away: note the interruption, re-open the
    /// port (bounded by `reconnect_timeout`) and force a new handshake.
    fn recover(&mut self, reason: String) -> Result<(), GrabError> {
        if self.streaming || self.epoch.is_some() || self.interrupted.is_some() {
            if let Some(seq) = self.assembler.abort() {
                self.account(
                    u64::from(seq),
                    Err(GrabError::FrameDamaged {
                        seq: u64::from(seq),
                        reason: format!("cut off: {reason}"),
                    }),
                );
            }
            self.interrupted.get_or_insert(reason.clone());
        }
        self.streaming = false;
        self.caps = None;
        self.raw_len = 0;
        self.raw_pos = 0;
        self.cobs.reset();
        let deadline = Instant::now() + self.opts.reconnect_timeout;
        loop {
            match self.link.reconnect() {
                Ok(()) => break,
                Err(e) if Instant::now() >= deadline => {
                    return Err(GrabError::StillAway {
                        reason,
                        after_s: self.opts.reconnect_timeout.as_secs_f64(),
                        source: e,
                    });
                }
                Err(_) => std::thread::sleep(Duration::from_millis(20)),
            }
        }
        self.link.clear_input();
        Ok(())
    }

    /// Run `f` with a session; on a link loss or device reset, recover
    /// and retry (bounded by `reconnect_timeout` per loss).
    fn with_session<R>(
        &mut self,
        mut f: impl FnMut(&mut Self) -> Result<R, GrabError>,
    ) -> Result<R, GrabError> {
        let mut attempts = 0;
        loop {
            let r = if self.caps.is_none() {
                self.handshake().and_then(|()| f(self))
            } else {
                f(self)
            };
            let gone = r.as_ref().err().and_then(GrabError::disconnect_reason);
            match (r, gone) {
                (Err(_), Some(reason)) if attempts < 3 => {
                    attempts += 1;
                    self.recover(reason)?;
                }
                (Err(GrabError::Timeout { what, after_ms }), _)
                    if attempts < 3 && self.caps.is_some() =>
                {
                    // The device stopped answering: treat as gone, re-open.
                    attempts += 1;
                    self.recover(format!(
                        "no reply: timed out after {after_ms} ms waiting for {what}"
                    ))?;
                }
                (r, _) => return r,
            }
        }
    }

    fn line_rate(&self) -> f64 {
        self.link.line_rate_bytes_per_s().unwrap_or(10e6)
    }

    /// Silence on the stream after which the frame in progress is dropped.
    fn idle_timeout(&self) -> Duration {
        let chunk = self
            .caps
            .map_or(MAX_MESSAGE_LEN, |c| usize::from(c.chunk_data_len) + 64);
        let exposure = Duration::from_micros(u64::from(self.desired.exposure_us.unwrap_or(20_000)));
        self.opts.frame_idle_timeout
            + exposure
            + Duration::from_secs_f64(3.0 * chunk as f64 / self.line_rate())
    }

    /// The most a single `grab` may take.
    fn grab_timeout(&self) -> Duration {
        let (w, h) = self.frame_size;
        let frame_bytes = (w as f64) * (h as f64) * 2.0;
        self.idle_timeout() * 2 + Duration::from_secs_f64(3.0 * frame_bytes / self.line_rate())
    }

    /// Stream silence: drop the partial frame and find out what the device is doing.
    fn on_silence(&mut self) -> Result<(), GrabError> {
        if let Some(seq) = self.assembler.abort() {
            self.account(
                u64::from(seq),
                Err(GrabError::FrameDamaged {
                    seq: u64::from(seq),
                    reason: reason_text(&DropReason::Aborted),
                }),
            );
        }
        self.last_stream_rx = Instant::now();
        let status = self.get_status()?;
        match status.state {
            DeviceState::Streaming => Ok(()), // data lost on the way; keep waiting
            DeviceState::Ready => {
                self.interrupted
                    .get_or_insert_with(|| "device stopped streaming".into());
                self.streaming = false;
                Ok(())
            }
            DeviceState::AwaitingHello => {
                self.interrupted
                    .get_or_insert_with(|| "device was reset".into());
                self.streaming = false;
                self.caps = None;
                Ok(())
            }
        }
    }
}

impl<T: Transport> crate::interface::DeviceControl for ProtocolGrabber<T> {
    fn describe(&self) -> String {
        match self.caps {
            Some(c) => format!(
                "gloam protocol {}.{} device #{} (firmware {}.{}.{}, {}×{} max) over {}",
                c.version_major,
                c.version_minor,
                c.serial_number,
                c.firmware_version >> 16,
                (c.firmware_version >> 8) & 0xFF,
                c.firmware_version & 0xFF,
                c.max_width_px,
                c.max_height_px,
                self.link.describe()
            ),
            None => format!(
                "gloam protocol device (not connected) over {}",
                self.link.describe()
            ),
        }
    }

    fn frame_size(&self) -> (u32, u32) {
        self.frame_size
    }

    fn set_gain(&mut self, gain: f64) -> Result<f64, GrabError> {
        if !gain.is_finite() || gain <= 0.0 {
            return Err(GrabError::InvalidSetting(format!(
                "gain {gain} must be positive"
            )));
        }
        // The wire carries thousandths in 32 bits: a gain past that was
        // sent as 4294967295 and refused in those units.
        let wire_max = f64::from(u32::MAX) / 1000.0;
        if gain > wire_max {
            return Err(GrabError::InvalidSetting(format!(
                "gain {gain:e} is above {wire_max}, the largest the protocol carries (thousandths in 32 bits)"
            )));
        }
        let milli = (gain * 1000.0).round().clamp(1.0, f64::from(u32::MAX)) as u32;
        let has_agc = self
            .caps
            .is_none_or(|c| c.features & firmware_protocol::features::AGC != 0);
        self.with_session(|g| {
            if has_agc {
                g.set_control(Control::AgcEnabled, 0, "AGC")?;
            }
            g.set_control(Control::GainMilli, milli, "gain")
        })
        .map_err(|e| match e {
            GrabError::InvalidSetting(m) => GrabError::InvalidSetting(format!(
                "gain {gain} refused by the device ({m}, in thousandths); it is outside the camera's range"
            )),
            e => e,
        })?;
        self.desired.gain_milli = Some(milli);
        if has_agc {
            self.desired.agc = Some(false);
        }
        Ok(f64::from(milli) / 1000.0)
    }

    fn set_agc(&mut self, on: bool) -> Result<bool, GrabError> {
        self.with_session(|g| g.set_control(Control::AgcEnabled, u32::from(on), "AGC"))?;
        self.desired.agc = Some(on);
        Ok(on)
    }

    fn set_bits(&mut self, bits: u8) -> Result<u8, GrabError> {
        if !matches!(bits, 8 | 12 | 16) {
            return Err(GrabError::InvalidSetting(format!(
                "bit depth {bits}: use 8, 12 or 16"
            )));
        }
        self.with_session(|g| {
            g.stop_stream()?;
            g.set_control(Control::BitDepth, u32::from(bits), "bit depth")
        })?;
        self.desired.bits = Some(bits);
        Ok(bits)
    }

    fn set_exposure_s(&mut self, exposure_s: f64) -> Result<f64, GrabError> {
        let us = crate::interface::exposure_us(exposure_s)?;
        self.with_session(|g| g.set_control(Control::ExposureUs, us, "exposure"))
            .map_err(|e| match e {
                GrabError::InvalidSetting(m) => GrabError::InvalidSetting(format!(
                    "exposure {exposure_s} s refused by the device ({m}, in microseconds); it is outside the camera's range"
                )),
                e => e,
            })?;
        self.desired.exposure_us = Some(us);
        Ok(f64::from(us) / 1e6)
    }

    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError> {
        // Protocol 1.0 has no stimulus message: real hardware shows what the
        // operator set up. The emulator understands its own extension
        // request (`emulator::KIND_EMULATOR_STIMULUS`); others NAK it.
        if self.stimulus_supported == Some(false) {
            return Ok(false);
        }
        let body = serde_json::to_vec(stimulus).map_err(GrabError::StimulusJson)?;
        if body.len() > crate::emulator::MAX_STIMULUS_JSON_LEN {
            return Err(GrabError::InvalidSetting(
                "stimulus description too long".into(),
            ));
        }
        let kind = crate::emulator::KIND_EMULATOR_STIMULUS;
        let reply = self.with_session(|g| g.request_any(Req::Raw { kind, body: &body }))?;
        match reply {
            Message::Ack { .. } => {
                self.stimulus_supported = Some(true);
                // Every frame whose leader we have already seen was
                // captured before the stimulus changed: never hand it out
                // as showing the new one.
                self.fresh_from_seq = self.last_leader_seq.map_or(0, |s| u64::from(s) + 1);
                let fresh = self.fresh_from_seq;
                let before = self.outcomes.len();
                self.outcomes
                    .retain(|o| !matches!(o, Ok(f) if f.meta.seq < fresh));
                self.stats.frames_stale += (before - self.outcomes.len()) as u64;
                Ok(true)
            }
            Message::Nak {
                code: ErrorCode::UNKNOWN_MESSAGE,
                ..
            } => {
                self.stimulus_supported = Some(false);
                Ok(false)
            }
            Message::Nak { code, .. } => Err(GrabError::InvalidSetting(format!(
                "stimulus rejected by the device: {code}"
            ))),
            m => Err(GrabError::Device(format!(
                "unexpected reply to the stimulus request: {m:?}"
            ))),
        }
    }
}

impl<T: Transport> FrameStream for ProtocolGrabber<T> {
    fn stop(&mut self) -> Result<(), GrabError> {
        if self.caps.is_none() {
            return Ok(()); // no session, so no stream
        }
        self.stop_stream()
    }

    fn grab(&mut self) -> Result<Frame, GrabError> {
        let mut start = Instant::now();
        let mut recoveries = 0;
        // A device that keeps accepting streams but never delivers must not
        // keep a grab alive for ever.
        let mut restarts = 0;
        loop {
            if let Some(o) = self.outcomes.pop_front() {
                return o;
            }
            let limit = self.grab_timeout();
            if start.elapsed() > limit {
                return Err(GrabError::Timeout {
                    what: "a frame".into(),
                    after_ms: limit.as_millis() as u64,
                });
            }
            // Ok(true): the session or stream was (re)started just now.
            let step = (|| -> Result<bool, GrabError> {
                let mut restarted = false;
                if self.caps.is_none() {
                    self.handshake()?;
                    restarted = true;
                }
                if !self.streaming {
                    self.start_stream()?;
                    restarted = true;
                    if !self.outcomes.is_empty() {
                        return Ok(true);
                    }
                }
                match self.pump(Instant::now() + Duration::from_millis(100))? {
                    Event::Timeout if self.last_stream_rx.elapsed() > self.idle_timeout() => {
                        self.on_silence()?;
                    }
                    _ => {}
                }
                Ok(restarted)
            })();
            let gone = step.as_ref().err().and_then(GrabError::disconnect_reason);
            match (step, gone) {
                // The frame deadline counts from the stream (re)start.
                (Ok(true), _) if restarts < 5 => {
                    restarts += 1;
                    start = Instant::now();
                }
                (Ok(_), _) => {}
                // Recovery is bounded by `reconnect_timeout`; the frame
                // deadline restarts once the link is back.
                (Err(_), Some(reason)) if recoveries < 5 => {
                    recoveries += 1;
                    self.recover(reason)?;
                    start = Instant::now();
                }
                (Err(GrabError::Timeout { what, after_ms }), _) if recoveries < 5 => {
                    recoveries += 1;
                    self.recover(format!("device stopped answering ({what}, {after_ms} ms)"))?;
                    start = Instant::now();
                }
                (Err(e), _) => return Err(e),
            }
        }
    }
}
