//! USB transport: one protocol message per bulk transfer (ended by a short
//! packet, or a zero-length packet when the length is a multiple of the
//! max packet size). Default backend: `nusb`; with the `rusb-backend`
//! feature, `rusb` (libusb, with its own `rusb::Context`) is also available.

use std::time::Duration;

use nusb::MaybeFuture;
use nusb::descriptors::TransferType;
use nusb::transfer::{Buffer, Bulk, Direction, In, Out};

use crate::transport::{Framing, LinkError, Transport};

/// A USB device as `gloam grabbers` shows it.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct UsbDeviceInfo {
    pub uri: String,
    pub vendor_id: u16,
    pub product_id: u16,
    pub serial_number: Option<String>,
    pub manufacturer: Option<String>,
    pub product: Option<String>,
    pub bus: String,
    pub address: u8,
}

/// Why USB devices could not be listed or opened (the USB stack's error
/// follows as the source).
const NO_USB_BUS: &str = "no USB bus available on this machine";

/// There is no USB bus to list (containers, VMs without USB pass-through,
/// no usbfs): nusb's error, said plainly.
#[derive(Debug, thiserror::Error)]
#[error("no USB bus available on this machine ({0})")]
pub struct NoUsbBus(pub nusb::Error);

/// USB devices on the bus, or [`NoUsbBus`].
pub fn list_usb() -> Result<Vec<UsbDeviceInfo>, NoUsbBus> {
    let devices = nusb::list_devices().wait().map_err(NoUsbBus)?;
    Ok(devices
        .map(|d| {
            let serial = d.serial_number().map(str::to_string);
            UsbDeviceInfo {
                uri: match &serial {
                    Some(s) => format!("usb:{:04x}:{:04x}:{s}", d.vendor_id(), d.product_id()),
                    None => format!("usb:{:04x}:{:04x}", d.vendor_id(), d.product_id()),
                },
                vendor_id: d.vendor_id(),
                product_id: d.product_id(),
                serial_number: serial,
                manufacturer: d.manufacturer_string().map(str::to_string),
                product: d.product_string().map(str::to_string),
                bus: d.bus_id().to_string(),
                address: d.device_address(),
            }
        })
        .collect())
}

/// Which device a `usb:` URI means.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UsbSelector {
    pub vendor_id: u16,
    pub product_id: u16,
    pub serial_number: Option<String>,
}

impl std::fmt::Display for UsbSelector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:04x}:{:04x}", self.vendor_id, self.product_id)?;
        if let Some(s) = &self.serial_number {
            write!(f, ":{s}")?;
        }
        Ok(())
    }
}

struct Open {
    ep_in: nusb::Endpoint<Bulk, In>,
    ep_out: nusb::Endpoint<Bulk, Out>,
    in_len: usize,
}

/// A USB bulk-pipe transport over nusb (interface 0, its first bulk IN and
/// OUT endpoints).
pub struct UsbTransport {
    selector: UsbSelector,
    open: Option<Open>,
    max_packet_len: usize,
}

fn usb_err(e: nusb::Error, what: &str) -> LinkError {
    match e.kind() {
        nusb::ErrorKind::Disconnected | nusb::ErrorKind::NotFound => {
            LinkError::disconnected_by(what, e)
        }
        _ => LinkError::io_by(what, e),
    }
}

impl UsbTransport {
    /// Find and open the device.
    pub fn open(selector: UsbSelector) -> Result<Self, LinkError> {
        let mut t = Self {
            selector,
            open: None,
            max_packet_len: 512,
        };
        t.reconnect()?;
        Ok(t)
    }

    fn open_device(&self) -> Result<(Open, usize), LinkError> {
        let sel = &self.selector;
        let devices = nusb::list_devices()
            .wait()
            .map_err(|e| LinkError::io_by(NO_USB_BUS, e))?;
        let info = devices
            .into_iter()
            .find(|d| {
                d.vendor_id() == sel.vendor_id
                    && d.product_id() == sel.product_id
                    && sel
                        .serial_number
                        .as_deref()
                        .is_none_or(|s| d.serial_number() == Some(s))
            })
            .ok_or_else(|| LinkError::disconnected(format!("USB device {sel} not found")))?;
        let device = info
            .open()
            .wait()
            .map_err(|e| usb_err(e, "opening USB device"))?;
        let iface = device
            .detach_and_claim_interface(0)
            .wait()
            .map_err(|e| usb_err(e, "claiming interface 0"))?;
        let (mut addr_in, mut addr_out, mut mps) = (None, None, 512usize);
        if let Some(d) = iface.descriptor() {
            for ep in d.endpoints() {
                if ep.transfer_type() != TransferType::Bulk {
                    continue;
                }
                match ep.direction() {
                    Direction::In if addr_in.is_none() => {
                        addr_in = Some(ep.address());
                        mps = ep.max_packet_size().max(8);
                    }
                    Direction::Out if addr_out.is_none() => addr_out = Some(ep.address()),
                    _ => {}
                }
            }
        }
        let (Some(a_in), Some(a_out)) = (addr_in, addr_out) else {
            return Err(LinkError::io(format!(
                "USB device {sel}: interface 0 has no bulk IN/OUT pair"
            )));
        };
        let ep_in = iface
            .endpoint::<Bulk, In>(a_in)
            .map_err(|e| usb_err(e, "opening bulk IN"))?;
        let ep_out = iface
            .endpoint::<Bulk, Out>(a_out)
            .map_err(|e| usb_err(e, "opening bulk OUT"))?;
        // Room for the largest message, rounded up to whole packets.
        let in_len = firmware_protocol::MAX_MESSAGE_LEN.div_ceil(mps) * mps;
        Ok((
            Open {
                ep_in,
                ep_out,
                in_len,
            },
            mps,
        ))
    }
}

impl Transport for UsbTransport {
    fn describe(&self) -> String {
        format!(
            "usb {} ({}-byte packets)",
            self.selector, self.max_packet_len
        )
    }

    fn framing(&self) -> Framing {
        Framing::UsbTransfers
    }

    fn send(&mut self, wire: &[u8], timeout: Duration) -> Result<(), LinkError> {
        let mps = self.max_packet_len;
        let o = self
            .open
            .as_mut()
            .ok_or_else(|| LinkError::disconnected("USB device closed"))?;
        let mut buf = Buffer::new(wire.len());
        buf.extend_from_slice(wire);
        o.ep_out.submit(buf);
        let needs_zlp = !wire.is_empty() && wire.len() % mps == 0;
        if needs_zlp {
            o.ep_out.submit(Buffer::new(0));
        }
        for _ in 0..(1 + usize::from(needs_zlp)) {
            match o.ep_out.wait_next_complete(timeout) {
                Some(c) => c
                    .status
                    .map_err(|e| LinkError::disconnected_by("bulk OUT", e))?,
                None => {
                    o.ep_out.cancel_all();
                    return Err(LinkError::io("bulk OUT timed out"));
                }
            }
        }
        Ok(())
    }

    fn recv(&mut self, out: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        let o = self
            .open
            .as_mut()
            .ok_or_else(|| LinkError::disconnected("USB device closed"))?;
        if o.ep_in.pending() == 0 {
            let b = o.ep_in.allocate(o.in_len);
            o.ep_in.submit(b);
        }
        let Some(c) = o.ep_in.wait_next_complete(timeout) else {
            return Ok(0); // the transfer stays queued for the next call
        };
        if let Err(e) = c.status {
            self.open = None;
            return Err(LinkError::disconnected_by("bulk IN", e));
        }
        let n = c.actual_len.min(out.len()).min(c.buffer.len());
        out[..n].copy_from_slice(&c.buffer[..n]);
        Ok(n)
    }

    fn clear_input(&mut self) {}

    fn reconnect(&mut self) -> Result<(), LinkError> {
        self.open = None;
        let (o, mps) = self.open_device()?;
        self.open = Some(o);
        self.max_packet_len = mps;
        Ok(())
    }
}

/// The libusb backend (feature `rusb-backend`): same semantics, using a
/// private `rusb::Context` (never libusb's global context).
#[cfg(feature = "rusb-backend")]
pub mod rusb_backend {
    use std::time::Duration;

    use rusb::UsbContext;

    use super::UsbSelector;
    use crate::transport::{Framing, LinkError, Transport};

    /// A USB bulk-pipe transport over libusb.
    pub struct RusbTransport {
        selector: UsbSelector,
        ctx: rusb::Context,
        handle: Option<rusb::DeviceHandle<rusb::Context>>,
        ep_in: u8,
        ep_out: u8,
        max_packet_len: usize,
    }

    fn err(e: rusb::Error, what: &str) -> LinkError {
        match e {
            rusb::Error::NoDevice | rusb::Error::NotFound | rusb::Error::Io | rusb::Error::Pipe => {
                LinkError::disconnected_by(what, e)
            }
            _ => LinkError::io_by(what, e),
        }
    }

    impl RusbTransport {
        pub fn open(selector: UsbSelector) -> Result<Self, LinkError> {
            let ctx = rusb::Context::new().map_err(|e| LinkError::io_by(super::NO_USB_BUS, e))?;
            let mut t = Self {
                selector,
                ctx,
                handle: None,
                ep_in: 0x81,
                ep_out: 0x01,
                max_packet_len: 512,
            };
            t.reconnect()?;
            Ok(t)
        }
    }

    impl Transport for RusbTransport {
        fn describe(&self) -> String {
            format!("usb (libusb) {}", self.selector)
        }
        fn framing(&self) -> Framing {
            Framing::UsbTransfers
        }
        fn send(&mut self, wire: &[u8], timeout: Duration) -> Result<(), LinkError> {
            let h = self
                .handle
                .as_ref()
                .ok_or_else(|| LinkError::disconnected("USB device closed"))?;
            h.write_bulk(self.ep_out, wire, timeout)
                .map_err(|e| err(e, "bulk OUT"))?;
            if !wire.is_empty() && wire.len() % self.max_packet_len == 0 {
                h.write_bulk(self.ep_out, &[], timeout)
                    .map_err(|e| err(e, "bulk OUT ZLP"))?;
            }
            Ok(())
        }
        fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
            let h = self
                .handle
                .as_ref()
                .ok_or_else(|| LinkError::disconnected("USB device closed"))?;
            match h.read_bulk(self.ep_in, buf, timeout) {
                Ok(n) => Ok(n),
                Err(rusb::Error::Timeout) => Ok(0),
                Err(e) => Err(err(e, "bulk IN")),
            }
        }
        fn reconnect(&mut self) -> Result<(), LinkError> {
            self.handle = None;
            let sel = &self.selector;
            let devices = self
                .ctx
                .devices()
                .map_err(|e| LinkError::io_by(super::NO_USB_BUS, e))?;
            for d in devices.iter() {
                let Ok(desc) = d.device_descriptor() else {
                    continue;
                };
                if desc.vendor_id() != sel.vendor_id || desc.product_id() != sel.product_id {
                    continue;
                }
                let h = d.open().map_err(|e| err(e, "opening USB device"))?;
                if let Some(want) = &sel.serial_number {
                    let got = h.read_serial_number_string_ascii(&desc).ok();
                    if got.as_deref() != Some(want.as_str()) {
                        continue;
                    }
                }
                let _ = h.set_auto_detach_kernel_driver(true);
                h.claim_interface(0)
                    .map_err(|e| err(e, "claiming interface 0"))?;
                let config = d
                    .active_config_descriptor()
                    .map_err(|e| err(e, "config descriptor"))?;
                for iface in config.interfaces().filter(|i| i.number() == 0) {
                    for alt in iface.descriptors() {
                        for ep in alt.endpoint_descriptors() {
                            if ep.transfer_type() != rusb::TransferType::Bulk {
                                continue;
                            }
                            match ep.direction() {
                                rusb::Direction::In => {
                                    self.ep_in = ep.address();
                                    self.max_packet_len = usize::from(ep.max_packet_size()).max(8);
                                }
                                rusb::Direction::Out => self.ep_out = ep.address(),
                            }
                        }
                    }
                }
                self.handle = Some(h);
                return Ok(());
            }
            Err(LinkError::disconnected(format!(
                "USB device {sel} not found"
            )))
        }
    }
}
