//! An in-memory link for tests: serial (COBS byte stream) or USB semantics
//! (bulk transfers split into max-size packets, ended by a short packet or a
//! zero-length packet), with fault injection in both directions and
//! scripted disconnects ("the port closes and comes back").

use std::collections::VecDeque;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use firmware_protocol::usb::{TransferAssembler, packets};

use crate::faults::{FaultConfig, FaultInjector, FaultStats, Verdict};
use crate::transport::{DeviceLink, Framing, LinkError, Transport};

/// USB 2.0 high-speed bulk max packet size.
pub const USB_MAX_PACKET_LEN: usize = firmware_protocol::usb::USB_HS_MAX_PACKET_LEN;

/// Options of [`memory_link`].
#[derive(Clone, Debug)]
pub struct MemoryOptions {
    pub framing: Framing,
    /// USB only: bulk max packet size.
    pub max_packet_len: usize,
    /// Faults on device→host units.
    pub to_host: FaultConfig,
    /// Faults on host→device units.
    pub to_device: FaultConfig,
    /// Disconnect after every this many device→host units (`None`: never).
    pub disconnect_every: Option<u64>,
    /// How long a disconnect lasts.
    pub disconnect_for: Duration,
    /// Bytes queued towards the host before the device's `send` waits
    /// (back-pressure, like a full USB FIFO or UART buffer).
    pub capacity_bytes: usize,
}

impl MemoryOptions {
    /// A clean link with the given framing.
    pub fn new(framing: Framing) -> Self {
        Self {
            framing,
            max_packet_len: USB_MAX_PACKET_LEN,
            to_host: FaultConfig::none(),
            to_device: FaultConfig::none(),
            disconnect_every: None,
            disconnect_for: Duration::from_millis(50),
            capacity_bytes: 256 * 1024,
        }
    }
}

struct Unit {
    at: Instant,
    bytes: Vec<u8>,
}

struct Shared {
    to_host: VecDeque<Unit>,
    to_host_bytes: usize,
    /// Bytes of the front `to_host` unit already read (serial).
    host_offset: usize,
    to_device: VecDeque<Unit>,
    /// Bumped on every disconnect; the host must `reconnect` to catch up.
    generation: u64,
    host_generation: u64,
    down_until: Option<Instant>,
    units_to_host: u64,
}

struct Link {
    shared: Mutex<Shared>,
    cond: Condvar,
    opts: MemoryOptions,
    disconnect_stats: Arc<FaultStats>,
}

impl Link {
    fn lock(&self) -> MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn disconnect_locked(&self, s: &mut Shared, for_: Duration) {
        s.generation += 1;
        s.down_until = Some(Instant::now() + for_);
        s.to_host.clear();
        s.to_host_bytes = 0;
        s.host_offset = 0;
        s.to_device.clear();
        self.disconnect_stats
            .disconnects
            .fetch_add(1, Ordering::Relaxed);
        self.cond.notify_all();
    }

    fn device_down(s: &Shared) -> bool {
        s.down_until.is_some_and(|t| Instant::now() < t)
    }
}

/// Push a unit (serial) or its packets (USB), applying `faults`.
fn enqueue(
    q: &mut VecDeque<Unit>,
    framing: Framing,
    max_packet_len: usize,
    faults: &mut FaultInjector,
    unit: &[u8],
) -> usize {
    let mut bytes = unit.to_vec();
    let verdict = faults.apply(&mut bytes);
    let now = Instant::now();
    let delay = match verdict {
        Verdict::Drop if framing == Framing::Cobs => return 0,
        Verdict::Drop => None,
        Verdict::Deliver(d) => d,
    };
    let last = q.back().map_or(now, |u| u.at);
    let at = (now + delay.unwrap_or_default()).max(last);
    match framing {
        Framing::Cobs => {
            let n = bytes.len();
            q.push_back(Unit { at, bytes });
            n
        }
        Framing::UsbTransfers => {
            let mut ps: Vec<Vec<u8>> = packets(&bytes, max_packet_len)
                .map(<[u8]>::to_vec)
                .collect();
            if verdict == Verdict::Drop {
                // USB loses packets, not messages: dropping a full packet
                // shortens the transfer, dropping the terminating short
                // packet (or ZLP) merges it with the next transfer.
                let i = (unit.len() * 7919 + ps.len()) % ps.len();
                ps.remove(i);
            }
            let n = ps.iter().map(Vec::len).sum();
            q.extend(ps.into_iter().map(|bytes| Unit { at, bytes }));
            n
        }
    }
}

/// The host end: a [`Transport`].
pub struct MemoryHost {
    link: Arc<Link>,
    faults: FaultInjector,
    usb_rx: TransferAssembler<Vec<u8>>,
}

/// The device end: a [`DeviceLink`] for the emulator.
pub struct MemoryDevice {
    link: Arc<Link>,
    faults: FaultInjector,
    usb_rx: TransferAssembler<Vec<u8>>,
}

/// Handle to script link events and read fault counts.
#[derive(Clone)]
pub struct LinkControl {
    link: Arc<Link>,
    to_host_stats: Arc<FaultStats>,
    to_device_stats: Arc<FaultStats>,
}

impl LinkControl {
    /// Unplug the link for `for_`: everything in flight is lost, the host's
    /// port is closed and must be re-opened with [`Transport::reconnect`].
    pub fn disconnect(&self, for_: Duration) {
        let mut s = self.link.lock();
        self.link.disconnect_locked(&mut s, for_);
    }
    /// Faults injected on device→host units (plus disconnects).
    pub fn to_host_stats(&self) -> crate::faults::FaultCounts {
        let mut c = self.to_host_stats.snapshot();
        c.disconnects = self.link.disconnect_stats.snapshot().disconnects;
        c
    }
    /// Faults injected on host→device units.
    pub fn to_device_stats(&self) -> crate::faults::FaultCounts {
        self.to_device_stats.snapshot()
    }
}

/// A connected pair of in-memory link ends.
pub fn memory_link(opts: MemoryOptions) -> (MemoryHost, MemoryDevice, LinkControl) {
    let to_host = FaultInjector::new(opts.to_host.clone());
    let to_device = FaultInjector::new(opts.to_device.clone());
    let control_stats = (to_host.stats(), to_device.stats());
    let buf_len = firmware_protocol::MAX_MESSAGE_LEN + 2 * opts.max_packet_len;
    let link = Arc::new(Link {
        shared: Mutex::new(Shared {
            to_host: VecDeque::new(),
            to_host_bytes: 0,
            host_offset: 0,
            to_device: VecDeque::new(),
            generation: 0,
            host_generation: 0,
            down_until: None,
            units_to_host: 0,
        }),
        cond: Condvar::new(),
        opts: opts.clone(),
        disconnect_stats: Arc::new(FaultStats::default()),
    });
    let host = MemoryHost {
        link: link.clone(),
        faults: to_device,
        usb_rx: TransferAssembler::new(vec![0; buf_len], opts.max_packet_len),
    };
    let device = MemoryDevice {
        link: link.clone(),
        faults: to_host,
        usb_rx: TransferAssembler::new(vec![0; buf_len], opts.max_packet_len),
    };
    let control = LinkControl {
        link,
        to_host_stats: control_stats.0,
        to_device_stats: control_stats.1,
    };
    (host, device, control)
}

/// Pop deliverable packets until one USB transfer is complete.
fn pop_transfer(
    q: &mut VecDeque<Unit>,
    asm: &mut TransferAssembler<Vec<u8>>,
    out: &mut [u8],
    queued_bytes: Option<&mut usize>,
) -> Option<usize> {
    let now = Instant::now();
    let mut taken = 0usize;
    let mut result = None;
    while let Some(u) = q.front() {
        if u.at > now {
            break;
        }
        let u = q.pop_front().expect("front exists");
        taken += u.bytes.len();
        match asm.push_packet(&u.bytes) {
            Ok(Some(t)) => {
                let n = t.len().min(out.len());
                out[..n].copy_from_slice(&t[..n]);
                result = Some(n);
                break;
            }
            Ok(None) => {}
            // An overlong transfer: the bytes are gone, like a babble error.
            Err(_) => {}
        }
    }
    if let Some(b) = queued_bytes {
        *b = b.saturating_sub(taken);
    }
    result
}

impl Transport for MemoryHost {
    fn describe(&self) -> String {
        match self.link.opts.framing {
            Framing::Cobs => "in-memory serial link".into(),
            Framing::UsbTransfers => format!(
                "in-memory USB link ({}-byte packets)",
                self.link.opts.max_packet_len
            ),
        }
    }

    fn framing(&self) -> Framing {
        self.link.opts.framing
    }

    fn send(&mut self, wire: &[u8], _timeout: Duration) -> Result<(), LinkError> {
        let link = self.link.clone();
        let mut s = link.lock();
        if s.host_generation != s.generation {
            return Err(LinkError::disconnected("port closed (device went away)"));
        }
        let o = &link.opts;
        enqueue(
            &mut s.to_device,
            o.framing,
            o.max_packet_len,
            &mut self.faults,
            wire,
        );
        link.cond.notify_all();
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        let deadline = Instant::now() + timeout;
        let link = self.link.clone();
        let mut s = link.lock();
        loop {
            if s.host_generation != s.generation {
                return Err(LinkError::disconnected("port closed (device went away)"));
            }
            let now = Instant::now();
            match link.opts.framing {
                Framing::Cobs => {
                    let mut n = 0;
                    while n < buf.len() {
                        let off = s.host_offset;
                        let Some(u) = s.to_host.front() else { break };
                        if u.at > now {
                            break;
                        }
                        let avail = &u.bytes[off..];
                        let k = avail.len().min(buf.len() - n);
                        buf[n..n + k].copy_from_slice(&avail[..k]);
                        n += k;
                        if off + k == u.bytes.len() {
                            let len = u.bytes.len();
                            s.to_host.pop_front();
                            s.host_offset = 0;
                            s.to_host_bytes = s.to_host_bytes.saturating_sub(len);
                        } else {
                            s.host_offset = off + k;
                        }
                    }
                    if n > 0 {
                        link.cond.notify_all();
                        return Ok(n);
                    }
                }
                Framing::UsbTransfers => {
                    let sh = &mut *s;
                    let got = pop_transfer(
                        &mut sh.to_host,
                        &mut self.usb_rx,
                        buf,
                        Some(&mut sh.to_host_bytes),
                    );
                    link.cond.notify_all();
                    if let Some(n) = got {
                        return Ok(n);
                    }
                }
            }
            if now >= deadline {
                return Ok(0);
            }
            // Wake for new data, or when a delayed unit becomes due.
            let due = s.to_host.front().map(|u| u.at).unwrap_or(deadline);
            let wait = due
                .min(deadline)
                .saturating_duration_since(now)
                .max(Duration::from_micros(50));
            s = link
                .cond
                .wait_timeout(s, wait)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
    }

    fn clear_input(&mut self) {
        let mut s = self.link.lock();
        s.to_host.clear();
        s.to_host_bytes = 0;
        s.host_offset = 0;
        self.usb_rx.reset();
        self.link.cond.notify_all();
    }

    fn reconnect(&mut self) -> Result<(), LinkError> {
        let mut s = self.link.lock();
        if Link::device_down(&s) {
            return Err(LinkError::disconnected("device not present"));
        }
        s.host_generation = s.generation;
        s.to_host.clear();
        s.to_host_bytes = 0;
        s.host_offset = 0;
        self.usb_rx.reset();
        Ok(())
    }
}

impl DeviceLink for MemoryDevice {
    fn framing(&self) -> Framing {
        self.link.opts.framing
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        let deadline = Instant::now() + timeout;
        let link = self.link.clone();
        let mut s = link.lock();
        loop {
            if Link::device_down(&s) {
                return Err(LinkError::disconnected("unplugged"));
            }
            let now = Instant::now();
            match link.opts.framing {
                Framing::Cobs => {
                    let mut n = 0;
                    while let Some(u) = s.to_device.front() {
                        if u.at > now || n + u.bytes.len() > buf.len() {
                            break;
                        }
                        let u = s.to_device.pop_front().expect("front exists");
                        buf[n..n + u.bytes.len()].copy_from_slice(&u.bytes);
                        n += u.bytes.len();
                    }
                    if n > 0 {
                        return Ok(n);
                    }
                }
                Framing::UsbTransfers => {
                    if let Some(n) = pop_transfer(&mut s.to_device, &mut self.usb_rx, buf, None) {
                        return Ok(n);
                    }
                }
            }
            if now >= deadline {
                return Ok(0);
            }
            let wait = deadline.saturating_duration_since(now);
            s = link
                .cond
                .wait_timeout(s, wait)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
    }

    fn send(&mut self, wire: &[u8]) -> Result<(), LinkError> {
        let link = self.link.clone();
        let mut s = link.lock();
        if Link::device_down(&s) {
            return Err(LinkError::disconnected("unplugged"));
        }
        // Back-pressure: wait (bounded) while the host is behind.
        let deadline = Instant::now() + Duration::from_secs(1);
        while s.to_host_bytes > link.opts.capacity_bytes {
            let now = Instant::now();
            if now >= deadline || s.host_generation != s.generation {
                // Host not reading (or gone): the unit is lost, as on a wire.
                return Ok(());
            }
            s = link
                .cond
                .wait_timeout(s, deadline - now)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
        s.units_to_host += 1;
        if let Some(every) = link.opts.disconnect_every
            && every > 0
            && s.units_to_host % every == 0
        {
            link.disconnect_locked(&mut s, link.opts.disconnect_for);
            return Err(LinkError::disconnected("unplugged"));
        }
        let o = &link.opts;
        let n = enqueue(
            &mut s.to_host,
            o.framing,
            o.max_packet_len,
            &mut self.faults,
            wire,
        );
        s.to_host_bytes += n;
        link.cond.notify_all();
        Ok(())
    }
}
