//! Serial transport (UART, USB CDC-ACM, pseudo-terminals) over `serialport`,
//! and the pseudo-terminal device end used by the emulator.

use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

use serialport::{ClearBuffer, SerialPort};

use crate::transport::{DeviceLink, Framing, LinkError, Transport};

/// Default baud rate for `serial:` URIs without `?baud=`.
pub const DEFAULT_BAUD: u32 = crate::emulator::DEFAULT_BAUD;

fn classify(e: std::io::Error, what: &str) -> LinkError {
    match e.kind() {
        // Hang-up, unplugged USB adapter, closed PTY peer, vanished node.
        ErrorKind::BrokenPipe
        | ErrorKind::NotFound
        | ErrorKind::ConnectionReset
        | ErrorKind::ConnectionAborted
        | ErrorKind::UnexpectedEof
        | ErrorKind::PermissionDenied
        | ErrorKind::Other => LinkError::disconnected_by(what, e),
        _ => LinkError::io_by(what, e),
    }
}

fn open_port(path: &str, baud: u32) -> Result<Box<dyn SerialPort>, LinkError> {
    let port = serialport::new(path, baud)
        .timeout(Duration::from_millis(50))
        .open()
        .map_err(|e| {
            let what = format!("opening {path}");
            match e.kind {
                serialport::ErrorKind::NoDevice | serialport::ErrorKind::Io(_) => {
                    LinkError::disconnected_by(what, e)
                }
                _ => LinkError::io_by(what, e),
            }
        })?;
    // Stale bytes from before we opened are not ours.
    let _ = port.clear(ClearBuffer::All);
    Ok(port)
}

/// A serial port speaking COBS framing.
pub struct SerialTransport {
    path: String,
    baud: u32,
    port: Option<Box<dyn SerialPort>>,
}

impl SerialTransport {
    /// Open `path` at `baud` (8N1, no flow control).
    pub fn open(path: &str, baud: u32) -> Result<Self, LinkError> {
        let port = open_port(path, baud)?;
        Ok(Self {
            path: path.to_string(),
            baud,
            port: Some(port),
        })
    }

    fn port(&mut self) -> Result<&mut Box<dyn SerialPort>, LinkError> {
        self.port
            .as_mut()
            .ok_or_else(|| LinkError::disconnected(format!("{} is closed", self.path)))
    }
}

impl Transport for SerialTransport {
    fn describe(&self) -> String {
        format!("serial {} @ {} baud", self.path, self.baud)
    }

    fn framing(&self) -> Framing {
        Framing::Cobs
    }

    fn line_rate_bytes_per_s(&self) -> Option<f64> {
        Some(f64::from(self.baud) / 10.0)
    }

    fn send(&mut self, wire: &[u8], timeout: Duration) -> Result<(), LinkError> {
        let path = self.path.clone();
        let deadline = Instant::now() + timeout;
        let port = self.port()?;
        let mut rest = wire;
        while !rest.is_empty() {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(LinkError::io(format!("{path}: write timed out")));
            }
            let _ = port.set_timeout(left);
            match port.write(rest) {
                Ok(0) => return Err(LinkError::disconnected(format!("{path}: write returned 0"))),
                Ok(n) => rest = &rest[n..],
                Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::Interrupted => {
                }
                Err(e) => {
                    self.port = None;
                    return Err(classify(e, &path));
                }
            }
        }
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        let path = self.path.clone();
        let port = self.port()?;
        let _ = port.set_timeout(timeout.max(Duration::from_millis(1)));
        match port.read(buf) {
            // poll() said readable and there is nothing: the peer hung up.
            Ok(0) => {
                self.port = None;
                Err(LinkError::disconnected(format!("{path}: hung up")))
            }
            Ok(n) => Ok(n),
            Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::Interrupted => {
                Ok(0)
            }
            Err(e) => {
                self.port = None;
                Err(classify(e, &path))
            }
        }
    }

    fn clear_input(&mut self) {
        if let Some(p) = &self.port {
            let _ = p.clear(ClearBuffer::Input);
        }
    }

    fn reconnect(&mut self) -> Result<(), LinkError> {
        self.port = None;
        self.port = Some(open_port(&self.path, self.baud)?);
        Ok(())
    }
}

/// The master side of a pseudo-terminal: the emulator's device end. The
/// slave side (its path is [`PtyDevice::slave_path`]) is what a client opens.
#[cfg(unix)]
pub struct PtyDevice {
    master: serialport::TTYPort,
    slave_path: String,
}

#[cfg(unix)]
impl PtyDevice {
    /// Allocate a pseudo-terminal pair. The slave is closed again at once so
    /// that each client open/close is seen as a connect/disconnect.
    pub fn open() -> Result<Self, LinkError> {
        let (master, slave) = serialport::TTYPort::pair()
            .map_err(|e| LinkError::io_by("allocating a pseudo-terminal", e))?;
        let slave_path = slave
            .name()
            .ok_or_else(|| LinkError::io("pseudo-terminal has no slave path"))?;
        drop(slave);
        Ok(Self { master, slave_path })
    }

    /// Path a client opens (e.g. `/dev/pts/7`).
    pub fn slave_path(&self) -> &str {
        &self.slave_path
    }
}

#[cfg(unix)]
impl DeviceLink for PtyDevice {
    fn framing(&self) -> Framing {
        Framing::Cobs
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        let _ = self
            .master
            .set_timeout(timeout.max(Duration::from_millis(1)));
        match self.master.read(buf) {
            Ok(0) => Err(LinkError::disconnected("no client on the pty")),
            Ok(n) => Ok(n),
            Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::Interrupted => {
                Ok(0)
            }
            Err(e) => Err(LinkError::disconnected_by("no client on the pty", e)),
        }
    }

    fn send(&mut self, wire: &[u8]) -> Result<(), LinkError> {
        let _ = self.master.set_timeout(Duration::from_millis(500));
        let mut rest = wire;
        while !rest.is_empty() {
            match self.master.write(rest) {
                Ok(0) => return Err(LinkError::disconnected("pty write returned 0")),
                Ok(n) => rest = &rest[n..],
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                // Client not reading: the unit is lost, as on a real wire.
                Err(e) if e.kind() == ErrorKind::TimedOut => return Ok(()),
                Err(e) => return Err(LinkError::disconnected_by("pty", e)),
            }
        }
        Ok(())
    }
}

/// Serial ports the OS knows about.
pub fn list_ports() -> Result<Vec<SerialPortInfo>, serialport::Error> {
    let ports = serialport::available_ports()?;
    Ok(ports
        .into_iter()
        .map(|p| {
            let (kind, vid_pid, serial, product) = match p.port_type {
                serialport::SerialPortType::UsbPort(u) => (
                    "usb-serial",
                    Some(format!("{:04x}:{:04x}", u.vid, u.pid)),
                    u.serial_number,
                    u.product,
                ),
                serialport::SerialPortType::PciPort => ("pci", None, None, None),
                serialport::SerialPortType::BluetoothPort => ("bluetooth", None, None, None),
                serialport::SerialPortType::Unknown => ("unknown", None, None, None),
            };
            SerialPortInfo {
                uri: format!("serial:{}", p.port_name),
                path: p.port_name,
                kind: kind.into(),
                vid_pid,
                serial_number: serial,
                product,
            }
        })
        .collect())
}

/// One serial port in [`crate::list_grabbers`].
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct SerialPortInfo {
    pub uri: String,
    pub path: String,
    pub kind: String,
    pub vid_pid: Option<String>,
    pub serial_number: Option<String>,
    pub product: Option<String>,
}
