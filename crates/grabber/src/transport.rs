//! The byte links the protocol client talks over.
//!
//! A [`Transport`] moves *wire units* between host and device: COBS-framed
//! byte streams on serial links ([`Framing::Cobs`]: UART, CDC-ACM, PTY) or
//! whole bulk transfers on USB ([`Framing::UsbTransfers`]: one message per
//! transfer, ended by a short or zero-length packet). Every call takes a
//! timeout; nothing here blocks forever.

use std::time::Duration;

/// How messages are delimited on a link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Framing {
    /// A byte stream of COBS frames, each ended by `0x00`.
    Cobs,
    /// One message per USB bulk transfer (short packet / ZLP terminated).
    UsbTransfers,
}

/// A link failure: whether the device went away (the client reconnects)
/// or the link failed otherwise, what was being done, and the error of the
/// layer below when there is one.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// The device (or its port) went away; [`Transport::reconnect`] may bring it back.
    #[error("link disconnected: {what}")]
    Disconnected {
        what: String,
        #[source]
        cause: Option<LinkCause>,
    },
    /// Any other I/O failure.
    #[error("link I/O error: {what}")]
    Io {
        what: String,
        #[source]
        cause: Option<LinkCause>,
    },
}

/// The error of the layer under a link (the OS, the serial port library,
/// the USB stack), kept typed so callers can inspect it.
#[derive(Debug, thiserror::Error)]
pub enum LinkCause {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Serial(#[from] serialport::Error),
    #[error(transparent)]
    Usb(#[from] nusb::Error),
    #[error(transparent)]
    UsbTransfer(#[from] nusb::transfer::TransferError),
    #[cfg(feature = "rusb-backend")]
    #[error(transparent)]
    Rusb(#[from] rusb::Error),
}

impl LinkError {
    /// The device went away, for a reason with no lower-level error.
    pub fn disconnected(what: impl Into<String>) -> Self {
        Self::Disconnected {
            what: what.into(),
            cause: None,
        }
    }

    /// The device went away while doing `what`, because of `cause`.
    pub fn disconnected_by(what: impl Into<String>, cause: impl Into<LinkCause>) -> Self {
        Self::Disconnected {
            what: what.into(),
            cause: Some(cause.into()),
        }
    }

    /// Another failure, with no lower-level error.
    pub fn io(what: impl Into<String>) -> Self {
        Self::Io {
            what: what.into(),
            cause: None,
        }
    }

    /// Another failure while doing `what`, because of `cause`.
    pub fn io_by(what: impl Into<String>, cause: impl Into<LinkCause>) -> Self {
        Self::Io {
            what: what.into(),
            cause: Some(cause.into()),
        }
    }

    /// True when the device went away (reconnecting may help).
    pub fn is_disconnect(&self) -> bool {
        matches!(self, Self::Disconnected { .. })
    }

    /// What failed and why, without the kind: `what: cause`. The client
    /// reports an interrupted stream with it.
    pub fn reason(&self) -> String {
        let (Self::Disconnected { what, cause } | Self::Io { what, cause }) = self;
        match cause {
            Some(c) => format!("{what}: {c}"),
            None => what.clone(),
        }
    }

    /// The whole message on one line: kind, what and cause.
    pub fn full_text(&self) -> String {
        match self {
            Self::Disconnected { .. } => format!("link disconnected: {}", self.reason()),
            Self::Io { .. } => format!("link I/O error: {}", self.reason()),
        }
    }
}

/// The host end of a link to a device.
pub trait Transport: Send {
    /// One line: kind and address (e.g. `serial /dev/ttyUSB0 @ 3000000 baud`).
    fn describe(&self) -> String;
    /// How messages are delimited.
    fn framing(&self) -> Framing;
    /// Line rate in payload bytes per second, where known (serial: baud/10
    /// for 8N1). Used to size timeouts and chunk lengths.
    fn line_rate_bytes_per_s(&self) -> Option<f64> {
        None
    }
    /// Send one wire unit: COBS frame(s) with delimiters, or one USB
    /// transfer. Waits at most `timeout`.
    fn send(&mut self, wire: &[u8], timeout: Duration) -> Result<(), LinkError>;
    /// Serial: the bytes available, waiting at most `timeout` for the first.
    /// USB: one whole transfer (a longer transfer is cut to `buf.len()`, which
    /// the message CRC then rejects). `Ok(0)`: nothing arrived in time.
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError>;
    /// Discard whatever is buffered on the receive side.
    fn clear_input(&mut self) {}
    /// Close and re-open the link after [`LinkError::Disconnected`]. Fails
    /// (quickly) while the device is still away.
    fn reconnect(&mut self) -> Result<(), LinkError>;
}

impl<T: Transport + ?Sized> Transport for Box<T> {
    fn describe(&self) -> String {
        (**self).describe()
    }
    fn framing(&self) -> Framing {
        (**self).framing()
    }
    fn line_rate_bytes_per_s(&self) -> Option<f64> {
        (**self).line_rate_bytes_per_s()
    }
    fn send(&mut self, wire: &[u8], timeout: Duration) -> Result<(), LinkError> {
        (**self).send(wire, timeout)
    }
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        (**self).recv(buf, timeout)
    }
    fn clear_input(&mut self) {
        (**self).clear_input()
    }
    fn reconnect(&mut self) -> Result<(), LinkError> {
        (**self).reconnect()
    }
}

/// The device end of a link, as the emulator sees it.
pub trait DeviceLink: Send {
    /// How messages are delimited.
    fn framing(&self) -> Framing;
    /// Request bytes (serial: any run of bytes; USB: one transfer); `Ok(0)`
    /// when nothing arrived within `timeout`. `Disconnected` while no host
    /// is attached.
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError>;
    /// Send one wire unit.
    fn send(&mut self, wire: &[u8]) -> Result<(), LinkError>;
}
