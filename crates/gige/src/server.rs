//! The UDP server around [`Device`]: a control thread answering GVCP on
//! the device port, and a stream thread rendering frames from a
//! [`FrameSource`] and sending them as GVSP, paced to the frame period.

use std::io;
use std::net::{SocketAddr, SocketAddrV4, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use gloam_grabber::FrameSource;

use crate::device::{Device, Event, StreamCounters};
use crate::features::{chunk, pixel_format};
use crate::gvsp::{self, FaultInjector, ImageInfo, ResendStore, StreamFaults};

/// Longest time one frame's packets are spread over (a video-rate
/// readout); shorter frame periods spread them over half the period.
const MAX_READOUT: Duration = Duration::from_millis(40);

/// How the server runs.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// GVCP address (port 3956 for real clients).
    pub bind: SocketAddrV4,
    pub faults: StreamFaults,
    /// Bytes of recent frames kept for PACKETRESEND.
    pub resend_store_bytes: usize,
    /// Print a status line on stderr this often while streaming.
    pub report_every: Option<Duration>,
    /// Link rate the stream is paced to, bit/s (1e9: GigE). Unpaced
    /// bursts overflow the receiver's socket buffer (208 KiB by default
    /// on Linux) long before loopback runs out of bandwidth.
    pub link_bits_per_s: f64,
}

/// What the server did (also readable as Gloam* features).
#[derive(Default, Debug)]
pub struct ServerStats {
    pub frames_sent: AtomicU64,
    pub packets_sent: AtomicU64,
    pub packets_dropped: AtomicU64,
    pub packets_reordered: AtomicU64,
    pub packets_resent: AtomicU64,
    pub resend_requests: AtomicU64,
    pub render_errors: AtomicU64,
}

impl ServerStats {
    fn counters(&self) -> StreamCounters {
        let c = |a: &AtomicU64| a.load(Ordering::Relaxed).min(u64::from(u32::MAX)) as u32;
        StreamCounters {
            frames_sent: c(&self.frames_sent),
            packets_dropped: c(&self.packets_dropped),
            packets_resent: c(&self.packets_resent),
            resend_requests: c(&self.resend_requests),
        }
    }
}

/// One frame's packets on their way to the sender thread.
struct Outgoing {
    dest: SocketAddrV4,
    packets: Vec<Vec<u8>>,
    /// Wire time per byte, ns.
    ns_per_byte: f64,
    /// Extra delay after each packet (GevSCPD).
    delay: Duration,
}

struct Shared {
    device: Device,
    store: ResendStore,
    /// Incremented on every AcquisitionStart / Stop: a frame rendered for an
    /// older generation is not sent.
    generation: u64,
    restart: bool,
    triggers: u32,
    /// Written to `GloamStimulus`, not yet shown to the source.
    stimulus: Option<gloam_grabber::Stimulus>,
}

/// A bound server; [`GigeServer::run`] serves until `stop`.
pub struct GigeServer {
    control: UdpSocket,
    /// Bound to the limited broadcast address, port 3956: where discovery
    /// broadcasts arrive (a socket bound to one address does not see them).
    discovery: Option<UdpSocket>,
    stream: UdpSocket,
    shared: Arc<(Mutex<Shared>, Condvar)>,
    config: ServerConfig,
    stats: Arc<ServerStats>,
}

fn lock(m: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl GigeServer {
    /// Binds the GVCP socket at `config.bind` and a stream socket next to it.
    pub fn bind(config: ServerConfig, mut device: Device) -> io::Result<Self> {
        let control = UdpSocket::bind(config.bind)?;
        let discovery = if config.bind.ip().is_unspecified() {
            None
        } else {
            UdpSocket::bind(SocketAddrV4::new(
                std::net::Ipv4Addr::BROADCAST,
                config.bind.port(),
            ))
            .ok()
        };
        let stream = UdpSocket::bind(SocketAddrV4::new(*config.bind.ip(), 0))?;
        device.set_stream_source_port(stream.local_addr()?.port());
        Ok(Self {
            control,
            discovery,
            stream,
            shared: Arc::new((
                Mutex::new(Shared {
                    device,
                    store: ResendStore::new(config.resend_store_bytes),
                    generation: 0,
                    restart: false,
                    triggers: 0,
                    stimulus: None,
                }),
                Condvar::new(),
            )),
            config,
            stats: Arc::new(ServerStats::default()),
        })
    }

    /// The GVCP address actually bound.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.control.local_addr()
    }

    pub fn stats(&self) -> Arc<ServerStats> {
        self.stats.clone()
    }

    /// Serves until `stop` is set: GVCP on this thread, GVSP on another
    /// that owns `source`.
    pub fn run(self, source: Box<dyn FrameSource>, stop: &AtomicBool) -> io::Result<()> {
        let epoch = Instant::now();
        self.control
            .set_read_timeout(Some(Duration::from_millis(20)))?;
        let this = &self;
        std::thread::scope(|scope| -> io::Result<()> {
            let streamer = scope.spawn(move || this.stream_loop(source, stop, epoch));
            if let Some(d) = &this.discovery {
                scope.spawn(move || this.discovery_loop(d, stop, epoch));
            }
            let r = self.control_loop(stop, epoch);
            stop.store(true, Ordering::SeqCst);
            self.shared.1.notify_all();
            let _ = streamer.join();
            r
        })
    }

    fn control_loop(&self, stop: &AtomicBool, epoch: Instant) -> io::Result<()> {
        let mut buf = vec![0u8; 2048];
        let mut resend_faults = FaultInjector::new(StreamFaults {
            seed: self.config.faults.seed ^ 0x005E_ED0F_2E5E_4D00,
            ..self.config.faults
        });
        let mut last_report = Instant::now();
        let mut reported_frames = u64::MAX;
        while !stop.load(Ordering::SeqCst) {
            let got = self.control.recv_from(&mut buf);
            let now_us = epoch.elapsed().as_micros() as u64;
            let (reply, events, stream) = {
                let mut sh = lock(&self.shared.0);
                sh.device.set_counters(self.stats.counters());
                let reply = match got {
                    Ok((n, SocketAddr::V4(from))) => {
                        sh.device.handle(now_us, from, &buf[..n]).map(|r| (r, from))
                    }
                    Ok(_) => None,
                    Err(e)
                        if matches!(
                            e.kind(),
                            io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                        ) =>
                    {
                        sh.device.poll(now_us);
                        None
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => None,
                    // ICMP "port unreachable" from an earlier send shows up
                    // here on Linux; the device keeps serving.
                    Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => None,
                    Err(e) => return Err(e),
                };
                let events = sh.device.take_events();
                let stream = sh.device.stream();
                (reply, events, stream)
            };
            if let Some((r, from)) = reply {
                let _ = self.control.send_to(&r, from);
            }
            let mut wake = false;
            for ev in events {
                match ev {
                    Event::AcquisitionStart => {
                        let mut sh = lock(&self.shared.0);
                        sh.generation += 1;
                        sh.restart = true;
                        sh.triggers = 0;
                        wake = true;
                    }
                    Event::AcquisitionStop | Event::ControlReleased => {
                        let mut sh = lock(&self.shared.0);
                        sh.generation += 1;
                        sh.triggers = 0;
                        wake = true;
                    }
                    Event::SoftwareTrigger => {
                        lock(&self.shared.0).triggers += 1;
                        wake = true;
                    }
                    Event::Stimulus(s) => {
                        // Before any trigger that follows it: events keep
                        // their order and the render loop takes both under
                        // one lock.
                        lock(&self.shared.0).stimulus = Some(s);
                        wake = true;
                    }
                    Event::FireTestPacket => {
                        if let Some(dest) = stream.destination {
                            let n = (stream.packet_bytes as usize).saturating_sub(28);
                            let mut p = gvsp::header(0, 0, gvsp::CONTENT_PAYLOAD, 0).to_vec();
                            p.resize(n.max(gvsp::HEADER_BYTES), 0);
                            let _ = self.stream.send_to(&p, dest);
                        }
                    }
                    Event::Resend {
                        block_id,
                        first_packet,
                        last_packet,
                    } => {
                        self.stats.resend_requests.fetch_add(1, Ordering::Relaxed);
                        let Some(dest) = stream.destination else {
                            continue;
                        };
                        let packets = lock(&self.shared.0).store.resend(
                            block_id,
                            first_packet,
                            last_packet,
                            4096,
                        );
                        let mut out = Vec::with_capacity(packets.len() + 1);
                        let before = resend_faults.dropped;
                        for p in packets {
                            resend_faults.apply(p, &mut out);
                        }
                        resend_faults.flush(&mut out);
                        self.stats
                            .packets_dropped
                            .fetch_add(resend_faults.dropped - before, Ordering::Relaxed);
                        for p in &out {
                            let _ = self.stream.send_to(p, dest);
                        }
                        self.stats
                            .packets_resent
                            .fetch_add(out.len() as u64, Ordering::Relaxed);
                    }
                }
            }
            if wake {
                self.shared.1.notify_all();
            }
            if let Some(every) = self.config.report_every
                && last_report.elapsed() >= every
            {
                last_report = Instant::now();
                let f = self.stats.frames_sent.load(Ordering::Relaxed);
                if f != reported_frames {
                    reported_frames = f;
                    eprintln!(
                        "gloam device: {f} frames sent, {} packets dropped by the fault injector, {} resend requests, {} packets resent",
                        self.stats.packets_dropped.load(Ordering::Relaxed),
                        self.stats.resend_requests.load(Ordering::Relaxed),
                        self.stats.packets_resent.load(Ordering::Relaxed)
                    );
                }
            }
        }
        Ok(())
    }

    /// Answers broadcast discovery (only DISCOVERY: anything else arriving
    /// on the broadcast address is ignored) from the GVCP socket.
    fn discovery_loop(&self, socket: &UdpSocket, stop: &AtomicBool, epoch: Instant) {
        let _ = socket.set_read_timeout(Some(Duration::from_millis(50)));
        let mut buf = vec![0u8; 2048];
        while !stop.load(Ordering::SeqCst) {
            let Ok((n, SocketAddr::V4(from))) = socket.recv_from(&mut buf) else {
                continue;
            };
            let is_discovery = crate::gvcp::parse_command(&buf[..n])
                .is_ok_and(|(h, _)| h.command == crate::gvcp::command::DISCOVERY);
            if !is_discovery {
                continue;
            }
            let now_us = epoch.elapsed().as_micros() as u64;
            let reply = lock(&self.shared.0).device.handle(now_us, from, &buf[..n]);
            if let Some(r) = reply {
                let _ = self.control.send_to(&r, from);
            }
        }
    }

    fn stream_loop(&self, source: Box<dyn FrameSource>, stop: &AtomicBool, epoch: Instant) {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Outgoing>(2);
        std::thread::scope(|scope| {
            scope.spawn(move || self.send_loop(rx));
            self.render_loop(source, stop, epoch, tx);
        });
    }

    /// Sends frames handed over by the render loop, paced, through the
    /// fault injector.
    fn send_loop(&self, rx: std::sync::mpsc::Receiver<Outgoing>) {
        let mut faults = FaultInjector::new(self.config.faults);
        let mut out: Vec<Vec<u8>> = Vec::new();
        while let Ok(Outgoing {
            dest,
            packets,
            ns_per_byte,
            delay,
        }) = rx.recv()
        {
            let before = faults.dropped;
            let before_reordered = faults.reordered;
            let mut sent = 0u64;
            let mut link_free_at = Instant::now();
            let pace = |bytes: usize, link_free_at: &mut Instant| {
                // Wire time of this packet (IP/UDP headers included), then
                // sleep off any lead over the link of more than 200 µs.
                *link_free_at +=
                    Duration::from_nanos(((bytes + 28) as f64 * ns_per_byte) as u64) + delay;
                let now = Instant::now();
                if *link_free_at > now + Duration::from_micros(200) {
                    std::thread::sleep(*link_free_at - now);
                } else if *link_free_at < now {
                    *link_free_at = now;
                }
            };
            for p in packets {
                out.clear();
                faults.apply(p, &mut out);
                for q in &out {
                    let _ = self.stream.send_to(q, dest);
                    pace(q.len(), &mut link_free_at);
                    sent += 1;
                }
            }
            out.clear();
            faults.flush(&mut out);
            for q in &out {
                let _ = self.stream.send_to(q, dest);
                sent += 1;
            }
            self.stats.packets_sent.fetch_add(sent, Ordering::Relaxed);
            self.stats
                .packets_dropped
                .fetch_add(faults.dropped - before, Ordering::Relaxed);
            self.stats
                .packets_reordered
                .fetch_add(faults.reordered - before_reordered, Ordering::Relaxed);
            self.stats.frames_sent.fetch_add(1, Ordering::Relaxed);
        }
    }

    fn render_loop(
        &self,
        mut source: Box<dyn FrameSource>,
        stop: &AtomicBool,
        epoch: Instant,
        tx: std::sync::mpsc::SyncSender<Outgoing>,
    ) {
        let (m, cv) = &*self.shared;
        let mut block_id: u16 = 1;
        let mut next_due = Instant::now();
        let mut frames_in_acquisition: u32 = 0;
        let mut pixels: Vec<u16> = Vec::new();
        let mut bytes: Vec<u8> = Vec::new();
        while !stop.load(Ordering::SeqCst) {
            let mut sh = lock(m);
            if sh.restart {
                sh.restart = false;
                sh.store.clear();
                source.restart();
                block_id = 1;
                frames_in_acquisition = 0;
                // Like a sensor, the first frame is read out one frame period
                // after the acquisition starts (its exposure comes first); a
                // frame sent at once can reach a client whose receive thread
                // is not draining yet and overflow its socket buffer.
                next_due = Instant::now() + Duration::from_micros(sh.device.frame_period_us());
            }
            if !sh.device.acquiring() {
                let _ = cv.wait_timeout(sh, Duration::from_millis(50));
                continue;
            }
            let now = Instant::now();
            if sh.device.triggered() {
                if sh.triggers == 0 {
                    let _ = cv.wait_timeout(sh, Duration::from_millis(50));
                    continue;
                }
                sh.triggers -= 1;
            } else if now < next_due {
                let wait = (next_due - now).min(Duration::from_millis(50));
                let _ = cv.wait_timeout(sh, wait);
                continue;
            }
            if let Some(stim) = sh.stimulus.take()
                && let Err(e) = source.present(&stim)
            {
                eprintln!("gloam device: stimulus not shown ({})", with_causes(&e));
            }
            let generation = sh.generation;
            let triggered = sh.device.triggered();
            let settings = sh.device.settings();
            let pf = sh.device.pixel_format();
            let chunks = sh.device.chunks();
            let stream = sh.device.stream();
            let period = Duration::from_micros(sh.device.frame_period_us());
            let limit = sh.device.frames_per_acquisition();
            drop(sh);

            let Some(dest) = stream.destination else {
                continue;
            };
            // The frame's exposure started on the schedule (the sensor's
            // clock), however long the simulation takes to render it.
            let exposure_start = if triggered {
                Instant::now()
            } else {
                next_due.min(Instant::now())
            };
            let timestamp_ticks = exposure_start.saturating_duration_since(epoch).as_nanos() as u64;
            pixels.resize(settings.width as usize * settings.height as usize, 0);
            let rendered = source.render(&settings, &mut pixels);
            let rendered = match rendered {
                Ok(r) => r,
                Err(e) => {
                    self.stats.render_errors.fetch_add(1, Ordering::Relaxed);
                    eprintln!(
                        "gloam device: frame not rendered ({}); acquisition stopped",
                        with_causes(&e)
                    );
                    let mut sh = lock(m);
                    sh.device.acquisition_completed();
                    continue;
                }
            };
            gvsp::pixel_bytes(&pixels, pixel_format::bytes_per_pixel(pf), &mut bytes);
            // The values this frame was rendered with, as chunks after the image.
            let payload_type = match chunks {
                Some(enabled) => {
                    let values = chunk::Values {
                        frame_id: u64::from(frames_in_acquisition) + 1,
                        timestamp_ticks,
                        gain_linear: f64::from(rendered.gain_milli) / 1000.0,
                        exposure_us: f64::from(settings.exposure_us),
                        gate_duty: rendered.gate_duty.unwrap_or(1.0),
                        agc_active: settings.agc,
                        bright_source_protection: rendered.bright_source_protection,
                    };
                    gvsp::chunked_payload(&mut bytes, chunk::IMAGE_ID, &values.chunks(enabled));
                    gvsp::PAYLOAD_TYPE_IMAGE_EXTENDED_CHUNK
                }
                None => gvsp::PAYLOAD_TYPE_IMAGE,
            };
            let info = ImageInfo {
                payload_type,
                timestamp_ticks,
                pixel_format: pf,
                width: settings.width,
                height: settings.height,
            };
            let packets = gvsp::packetize(block_id, &info, &bytes, stream.packet_bytes as usize);
            {
                let mut sh = lock(m);
                if sh.generation != generation || !sh.device.acquiring() {
                    continue;
                }
                sh.store.insert(block_id, packets.clone());
                sh.device.set_gain_in_effect(rendered.gain_milli);
                sh.device
                    .set_bright_source_protection(rendered.bright_source_protection);
            }
            // Packets leave as the sensor reads out: spread over half the
            // frame period (never faster than the link). A frame sent as one
            // burst overflows the client's socket buffer whenever its receive
            // thread is descheduled for a millisecond or two. The sender
            // thread does this while the next frame renders.
            // At most MAX_READOUT, as a sensor's readout: a slow sensor
            // (1 Hz) spreading 4 packets over half a second would leave
            // gaps a client takes for a lost frame (Aravis gives up on a
            // frame after 100 ms without a packet).
            let total_bytes: usize = packets.iter().map(|p| p.len() + 28).sum();
            let spread_ns = (period.as_nanos() as f64 * 0.5).min(MAX_READOUT.as_nanos() as f64);
            let ns_per_byte = (8e9 / self.config.link_bits_per_s.max(1e6))
                .max(spread_ns / total_bytes.max(1) as f64);
            let outgoing = Outgoing {
                dest,
                packets,
                ns_per_byte,
                delay: Duration::from_nanos(u64::from(stream.packet_delay_ns)),
            };
            if tx.send(outgoing).is_err() {
                break;
            }
            block_id = gvsp::next_block_id(block_id);
            frames_in_acquisition += 1;
            // Paced to the frame period from the previous frame's due time;
            // a frame that took longer than a period restarts the schedule
            // rather than bursting to catch up.
            next_due += period;
            let now = Instant::now();
            if next_due + period < now {
                next_due = now;
            }
            if limit.is_some_and(|n| frames_in_acquisition >= n) {
                let mut sh = lock(m);
                if sh.generation == generation {
                    sh.device.acquisition_completed();
                }
            }
        }
    }
}

/// An error and its sources, `a: b: c`, as the CLI prints them.
fn with_causes(e: &dyn std::error::Error) -> String {
    let mut out = e.to_string();
    let mut next = e.source();
    while let Some(c) = next {
        out.push_str(": ");
        out.push_str(&c.to_string());
        next = c.source();
    }
    out
}
