#![doc = include_str!("../README.md")]

mod interface;

pub mod client;
pub mod emulator;
pub mod faults;
#[cfg(feature = "genicam")]
pub mod genicam;
pub mod memory;
pub mod serial;
pub mod source;
mod stream_ids;
pub mod transport;
pub mod uri;
pub mod usb;

pub use client::{ClientOptions, ClientStats, ProtocolGrabber};
/// The wire protocol (message types, controls) the client speaks.
pub use firmware_protocol;
pub use interface::*;
pub use source::{CaptureSettings, FrameSource, SyntheticSource};
pub use transport::{DeviceLink, Framing, LinkError, Transport};
pub use uri::{GrabberUri, UriParts, UriSyntaxError};

/// CRC-32C of pixels as little-endian `u16` bytes (the one
/// implementation, on the lowest floor with the frame).
pub use gloam_io::frame::pixels_crc32c;

/// Options for [`Registry::open`].
#[derive(Clone, Debug, Default)]
pub struct OpenOptions {
    /// Noise seed for `sim:` grabbers (a URI's own `seed=` must agree);
    /// refused by hardware (the emulator takes its seed on its own
    /// command line).
    pub seed: Option<u64>,
    /// Protocol client tuning for `serial:` and `usb:`.
    pub client: ClientOptions,
    /// Where a grabber that reads files (a `sim:` camera's sensor TOML)
    /// notes them: the log of the run that opens it.
    pub reads: gloam_io::ReadLog,
}

/// Builds a grabber from a whole URI (its scheme already matched).
pub type Constructor = std::sync::Arc<
    dyn Fn(&str, &OpenOptions) -> Result<Box<dyn FrameGrabber>, GrabError> + Send + Sync,
>;

/// URI scheme → constructor. This crate registers the transports
/// (`serial:`, `usb:`, `genicam:`); the layer that owns a kind of camera
/// registers its scheme (`gloam-simcam` the `sim:` rigs, `gloam-pipeline`
/// `sim:` with scenes, which it renders itself), so nothing here calls back
/// up into the crates that depend on it.
#[derive(Clone)]
pub struct Registry {
    constructors: std::collections::BTreeMap<String, Constructor>,
}

impl std::fmt::Debug for Registry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registry")
            .field("schemes", &self.constructors.keys().collect::<Vec<_>>())
            .finish()
    }
}

impl Default for Registry {
    fn default() -> Self {
        Self::transports()
    }
}

impl Registry {
    /// No schemes at all.
    pub fn empty() -> Self {
        Self {
            constructors: Default::default(),
        }
    }

    /// The transports this crate speaks: `serial:`, `usb:` and `genicam:`.
    pub fn transports() -> Self {
        let mut r = Self::empty();
        let transport: Constructor = std::sync::Arc::new(open_transport);
        for scheme in ["serial", "usb", "genicam"] {
            r.register(scheme, transport.clone());
        }
        r
    }

    /// Registers (or replaces) the constructor of `scheme` (no colon).
    pub fn register(&mut self, scheme: &str, constructor: Constructor) -> &mut Self {
        self.constructors.insert(scheme.to_string(), constructor);
        self
    }

    /// The registered schemes, sorted.
    pub fn schemes(&self) -> impl Iterator<Item = &str> {
        self.constructors.keys().map(String::as_str)
    }

    /// Opens a grabber by URI (see the crate docs and `docs/hardware.md`)
    /// with the constructor registered for its scheme.
    pub fn open(&self, uri: &str, opts: &OpenOptions) -> Result<Box<dyn FrameGrabber>, GrabError> {
        let scheme = uri.split_once(':').map(|(s, _)| s);
        match scheme.and_then(|s| self.constructors.get(s)) {
            Some(c) => c(uri, opts),
            // Known syntax with no constructor here: say who provides one.
            None if scheme == Some("sim") => Err(GrabError::Unsupported(format!(
                "'{uri}': simulated cameras are opened through gloam-simcam's registry"
            ))),
            // A transport this registry lacks: its syntax still checked.
            None if scheme.is_some_and(|s| uri::TRANSPORT_SCHEMES.contains(&s)) => {
                GrabberUri::parse(uri)?;
                Err(GrabError::Unsupported(format!(
                    "'{uri}': no grabber registered for this scheme"
                )))
            }
            // Unknown or malformed: name the schemes this registry opens.
            None => {
                let known: Vec<String> = self.schemes().map(|s| format!("{s}:…")).collect();
                let forms = if known.is_empty() {
                    "a scheme registered here, and none is".to_string()
                } else {
                    format!("one of {}", known.join(", "))
                };
                let parts =
                    uri::UriParts::parse(uri).map_err(|e| uri::uri_error(uri, e, &forms))?;
                Err(uri::uri_error(
                    uri,
                    format!("unknown scheme '{}'", parts.scheme),
                    &forms,
                ))
            }
        }
    }
}

/// Opens a hardware grabber by URI ([`Registry::transports`], default
/// options). Simulated cameras: `gloam_simcam::open`.
pub fn open(uri: &str) -> Result<Box<dyn FrameGrabber>, GrabError> {
    Registry::transports().open(uri, &OpenOptions::default())
}

/// The constructor of the transports' schemes.
fn open_transport(uri: &str, opts: &OpenOptions) -> Result<Box<dyn FrameGrabber>, GrabError> {
    // A seed given for a real camera was neither applied nor refused.
    if let Some(seed) = opts.seed {
        return Err(GrabError::Unsupported(format!(
            "--seed {seed}: '{uri}' is a real device, whose noise no seed sets (a seed is for simulated cameras, sim:…); drop --seed"
        )));
    }
    match GrabberUri::parse(uri)? {
        GrabberUri::Serial { path, baud } => {
            let t = serial::SerialTransport::open(&path, baud)?;
            Ok(Box::new(ProtocolGrabber::connect(t, opts.client.clone())?))
        }
        GrabberUri::Usb(sel) => {
            let t = usb::UsbTransport::open(sel)?;
            Ok(Box::new(ProtocolGrabber::connect(t, opts.client.clone())?))
        }
        #[cfg(feature = "rusb-backend")]
        GrabberUri::UsbRusb(sel) => {
            let t = usb::rusb_backend::RusbTransport::open(sel)?;
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
const GENICAM_FEATURE_OFF: &str = "GenICam cameras need gloam built with the `genicam` feature (cargo build --features genicam; Debian: libaravis-dev and libusb-1.0-0-dev)";

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
    /// Simulated cameras (filled by `gloam_simcam::list_grabbers`).
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

/// Serial ports, USB devices and GenICam cameras (or why there are none);
/// `sim` is left empty for `gloam_simcam::list_grabbers` to fill. With the
/// `genicam` feature this sends GigE Vision discovery broadcasts on every
/// network interface.
pub fn list_grabbers() -> GrabberList {
    let (serial, serial_error) = match serial::list_ports() {
        Ok(p) => (p, None),
        Err(e) => (Vec::new(), Some(e.to_string())),
    };
    let (usb, usb_error) = match usb::list_usb() {
        Ok(d) => (d, None),
        Err(e) => (Vec::new(), Some(e.to_string())),
    };
    let (genicam, genicam_error) = list_genicam();
    GrabberList {
        serial,
        serial_error,
        usb,
        usb_error,
        sim: Vec::new(),
        genicam,
        genicam_error,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Round 12 of issue 46: an exposure past 32 bits of microseconds was
    /// clamped without a word, and a seed for a real device ignored.
    #[test]
    fn exposures_are_whole_microseconds_in_32_bits_and_devices_take_no_seed() {
        assert_eq!(interface::exposure_us(4294.967295).unwrap(), u32::MAX);
        let e = interface::exposure_us(4294.968).unwrap_err().to_string();
        assert!(e.contains("above the 4294.967295 s"), "{e}");
        assert!(interface::exposure_us(1e-7).is_err());
        let opts = OpenOptions {
            seed: Some(3),
            ..OpenOptions::default()
        };
        let e = Registry::transports()
            .open("serial:/dev/null", &opts)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("--seed 3") && e.contains("real device"), "{e}");
    }

    /// A scheme nobody registered is named with the ones that are; the
    /// generic syntax is checked first.
    #[test]
    fn unknown_schemes_name_the_registered_ones() {
        let mut r = Registry::transports();
        let err = |r: &Registry, uri: &str| r.open(uri, &OpenOptions::default()).err().unwrap();
        let e = err(&r, "tcp:host").to_string();
        assert_eq!(
            e,
            "invalid setting: grabber URI 'tcp:host': unknown scheme 'tcp' (expected one of genicam:…, serial:…, usb:…)"
        );
        r.register("cam", std::sync::Arc::new(|_, _| unreachable!()));
        let e = err(&r, "tcp:host?a=1&").to_string();
        assert_eq!(
            e,
            "invalid setting: grabber URI 'tcp:host?a=1&': empty parameter in 'a=1&' (a stray '&' at its start or end, or '&&') (expected one of cam:…, genicam:…, serial:…, usb:…)"
        );
        let e = err(&Registry::empty(), "nothing").to_string();
        assert!(e.contains("'nothing': no scheme"), "{e}");
        // A transport's URI in a registry without it: checked, then refused.
        let e = err(&Registry::empty(), "serial:/dev/x?baud=0");
        assert!(e.to_string().contains("baud '0'"), "{e}");
        let e = err(&Registry::empty(), "serial:/dev/x");
        assert!(matches!(e, GrabError::Unsupported(_)), "{e}");
        // sim: lives in gloam-simcam.
        let e = err(&r, "sim:gen3-gaas-iccd").to_string();
        assert!(e.contains("gloam-simcam"), "{e}");
    }
}
