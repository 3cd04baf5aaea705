#![doc = include_str!("../README.md")]

mod interface;

pub mod client;
pub mod emulator;
pub mod faults;
#[cfg(feature = "genicam")]
pub mod genicam;
pub mod memory;
pub mod serial;
pub mod sim;
pub mod source;
pub mod transport;
pub mod uri;
pub mod usb;

pub use client::{ClientOptions, ClientStats, ProtocolGrabber};
/// The wire protocol (message types, controls) the client speaks.
pub use firmware_protocol;
pub use interface::*;
pub use sim::{SceneImage, SceneView, SensorSource, SimGrabber};
pub use source::{CaptureSettings, FrameSource, SyntheticSource};
pub use transport::{DeviceLink, Framing, LinkError, Transport};
pub use uri::GrabberUri;

/// CRC-32C of pixels as little-endian `u16` bytes:
/// [`FrameMeta::pixels_crc32c`]. The protocol's own engine, so the host and
/// the device checksum frames with one implementation.
pub fn pixels_crc32c(pixels: &[u16]) -> u32 {
    let mut d = firmware_protocol::Crc32c::new();
    let mut buf = [0u8; 4096];
    for block in pixels.chunks(buf.len() / 2) {
        for (o, p) in buf.chunks_exact_mut(2).zip(block) {
            o.copy_from_slice(&p.to_le_bytes());
        }
        d.update(&buf[..block.len() * 2]);
    }
    d.value()
}

/// Renders a scene file for `sim:PRESET?scene=PATH`: `(path, preset,
/// size)`, the size (width, height) defaulting to the scene camera's; the
/// preset lets the renderer weight by that camera's detector response.
/// Supplied by the caller (the `gloam` CLI uses the tracer), so this crate
/// stays free of tracing.
pub type SceneRenderer = std::sync::Arc<
    dyn Fn(&str, &str, Option<(u32, u32)>) -> Result<SceneView, String> + Send + Sync,
>;

/// Options for [`open_with`].
#[derive(Clone, Default)]
pub struct OpenOptions {
    /// Noise seed for `sim:` grabbers (overrides `?seed=`); ignored by
    /// hardware (the emulator takes its seed on its own command line).
    pub seed: Option<u64>,
    /// Protocol client tuning for `serial:` and `usb:`.
    pub client: ClientOptions,
    /// Renders `sim:…?scene=PATH` scenes; without one such URIs are an error.
    pub scene_renderer: Option<SceneRenderer>,
}

impl std::fmt::Debug for OpenOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OpenOptions")
            .field("seed", &self.seed)
            .field("client", &self.client)
            .field("scene_renderer", &self.scene_renderer.is_some())
            .finish()
    }
}

/// Open a grabber by URI (see the crate docs and `docs/hardware.md`).
pub fn open(uri: &str) -> Result<Box<dyn FrameGrabber>, GrabError> {
    open_with(uri, &OpenOptions::default())
}

/// [`open`] with options.
pub fn open_with(uri: &str, opts: &OpenOptions) -> Result<Box<dyn FrameGrabber>, GrabError> {
    match GrabberUri::parse(uri)? {
        GrabberUri::Sim {
            preset,
            rig,
            seed,
            size,
            scene,
        } => {
            let seed = opts.seed.unwrap_or(seed);
            match scene {
                Some(path) => {
                    let render = opts.scene_renderer.as_ref().ok_or_else(|| {
                        GrabError::Unsupported(format!(
                            "'{uri}': scenes need a renderer (the gloam CLI provides one)"
                        ))
                    })?;
                    let view = render(&path, &preset, size)
                        .map_err(|e| GrabError::InvalidSetting(format!("scene '{path}': {e}")))?;
                    Ok(Box::new(SimGrabber::from_scene(&preset, view, seed)?))
                }
                None => Ok(Box::new(SimGrabber::from_preset(
                    &preset,
                    &rig,
                    seed,
                    size.unwrap_or(sim::DEFAULT_RIG_SIZE),
                )?)),
            }
        }
        GrabberUri::Serial { path, baud } => {
            let t = serial::SerialTransport::open(&path, baud).map_err(|e| match e {
                LinkError::Disconnected(m) | LinkError::Io(m) => GrabError::Disconnected(m),
            })?;
            Ok(Box::new(ProtocolGrabber::connect(t, opts.client.clone())?))
        }
        GrabberUri::Usb(sel) => {
            let t = usb::UsbTransport::open(sel).map_err(|e| match e {
                LinkError::Disconnected(m) | LinkError::Io(m) => GrabError::Disconnected(m),
            })?;
            Ok(Box::new(ProtocolGrabber::connect(t, opts.client.clone())?))
        }
        #[cfg(feature = "rusb-backend")]
        GrabberUri::UsbRusb(sel) => {
            let t = usb::rusb_backend::RusbTransport::open(sel).map_err(|e| match e {
                LinkError::Disconnected(m) | LinkError::Io(m) => GrabError::Disconnected(m),
            })?;
            Ok(Box::new(ProtocolGrabber::connect(t, opts.client.clone())?))
        }
        #[cfg(not(feature = "rusb-backend"))]
        GrabberUri::UsbRusb(_) => Err(GrabError::Unsupported(
            "usb:…?backend=rusb needs gloam built with the `gloam-grabber/rusb-backend` feature"
                .into(),
        )),
        #[cfg(feature = "genicam")]
        GrabberUri::Genicam(o) => Ok(Box::new(genicam::GenicamGrabber::open(&o)?)),
        #[cfg(not(feature = "genicam"))]
        GrabberUri::Genicam(_) => Err(GrabError::Unsupported(format!(
            "'{uri}': {GENICAM_FEATURE_OFF}"
        ))),
    }
}

/// Why there are no `genicam:` grabbers in this build.
#[cfg(not(feature = "genicam"))]
const GENICAM_FEATURE_OFF: &str = "GenICam cameras need gloam built with the `genicam` feature (cargo build --features genicam; Debian: libaravis-dev)";

/// One simulated camera in [`GrabberList`].
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct SimInfo {
    pub uri: String,
    pub description: String,
}

/// Everything [`list_grabbers`] found.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct GrabberList {
    pub serial: Vec<serial::SerialPortInfo>,
    /// Why serial ports could not be listed, if they could not.
    pub serial_error: Option<String>,
    pub usb: Vec<usb::UsbDeviceInfo>,
    /// Why USB devices could not be listed (e.g. "no USB bus available").
    pub usb_error: Option<String>,
    pub sim: Vec<SimInfo>,
    /// GenICam cameras Aravis found (feature `genicam`).
    pub genicam: Vec<GenicamInfo>,
    /// Why GenICam cameras could not be listed (e.g. the feature is off).
    pub genicam_error: Option<String>,
}

/// One GenICam camera in [`GrabberList`].
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct GenicamInfo {
    pub uri: String,
    pub device_id: String,
    pub vendor: String,
    pub model: String,
    /// GigEVision or USB3Vision.
    pub protocol: String,
    pub address: String,
}

fn list_genicam() -> (Vec<GenicamInfo>, Option<String>) {
    #[cfg(feature = "genicam")]
    {
        (genicam::list_devices(), None)
    }
    #[cfg(not(feature = "genicam"))]
    {
        (Vec::new(), Some(GENICAM_FEATURE_OFF.to_string()))
    }
}

/// Serial ports, USB devices, GenICam cameras (or why there are none) and
/// the simulated cameras. With the `genicam` feature this sends GigE Vision
/// discovery broadcasts on every network interface.
pub fn list_grabbers() -> GrabberList {
    let (serial, serial_error) = match serial::list_ports() {
        Ok(p) => (p, None),
        Err(e) => (Vec::new(), Some(e)),
    };
    let (usb, usb_error) = match usb::list_usb() {
        Ok(d) => (d, None),
        Err(e) => (Vec::new(), Some(e)),
    };
    let mut sim: Vec<SimInfo> = gloam_sensor::presets()
        .into_iter()
        .map(|(name, description)| SimInfo {
            uri: format!("sim:{name}"),
            description,
        })
        .collect();
    sim.extend(sim::RIGS.iter().map(|(name, d)| SimInfo {
        uri: format!("sim:{name}"),
        description: format!("rig: {d} (sensor {})", uri::DEFAULT_SIM_PRESET),
    }));
    let (genicam, genicam_error) = list_genicam();
    GrabberList {
        serial,
        serial_error,
        usb,
        usb_error,
        sim,
        genicam,
        genicam_error,
    }
}
