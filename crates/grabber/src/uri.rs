//! Grabber URIs.
//!
//! ```text
//! sim:PRESET_OR_RIG[?rig=RIG&seed=S&size=WxH]   in-process sensor chain + rig
//! sim:PRESET?scene=PATH[&seed=S&size=WxH]        … looking at a traced scene
//! serial:PATH[?baud=N]                           protocol over a serial port
//! usb:VID:PID[:SERIAL][?backend=nusb|rusb]     protocol over USB bulk (hex ids)
//! genicam:DEVICE_ID|ADDR[?trigger=auto|software|off&resend=always|never&timeout_ms=N&size=WxH]
//!                                                a GenICam camera through Aravis (feature `genicam`)
//! ```

use crate::interface::GrabError;
use crate::usb::UsbSelector;

/// Built-in rigs a `sim:` URI can name: what the simulated camera looks at
/// by default. The vocabulary of the URI lives here with the other schemes'
/// so one parser names every form; `gloam-simcam` renders them.
pub const RIGS: &[(&str, &str)] = &[
    (
        "uniform",
        "integrating-sphere port filling the view (default), CIE A, ~25 % of full scale at the reference gain",
    ),
    (
        "sine",
        "sinusoidal bar target, 0.05 cycles/pixel, modulation 0.8, tilted 5°",
    ),
    ("edge", "ISO 12233 slanted edge, 5°, 10:1 contrast"),
    ("dark", "capped lens"),
];

/// Sensor preset used when a `sim:` URI names only a rig.
pub const DEFAULT_SIM_PRESET: &str = "gen2-s20-iccd";
/// Rig used when a `sim:` URI names only a preset.
pub const DEFAULT_RIG: &str = "uniform";

/// How frames are started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriggerChoice {
    /// Software trigger when the camera has one, else free-running.
    Auto,
    /// One `TriggerSoftware` per grab (refused if the camera lacks it).
    Software,
    /// Free-running (`TriggerMode=Off`).
    Off,
}

/// What a `genicam:` URI asks for.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GenicamOptions {
    /// Aravis device id (`Vendor-Model-Serial`, as `gloam grabbers` lists
    /// it) or the camera's IP address.
    pub name: String,
    pub trigger: TriggerChoice,
    /// Ask for lost GVSP packets again (PACKETRESEND); `?resend=never`
    /// turns it off, to see raw losses.
    pub packet_resend: bool,
    /// How long one grab waits for its frame; `None`: 2 s plus three
    /// frame periods.
    pub timeout_ms: Option<u64>,
    /// Width and height to set at open.
    pub size: Option<(u32, u32)>,
}

/// A parsed grabber URI.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GrabberUri {
    Sim {
        preset: String,
        rig: String,
        seed: u64,
        /// `size=`; without it a rig is `gloam_simcam::DEFAULT_RIG_SIZE` and a scene
        /// its camera's resolution.
        size: Option<(u32, u32)>,
        /// `scene=PATH`: look at this scene (rendered once by the tracer)
        /// instead of a rig.
        scene: Option<String>,
    },
    Serial {
        path: String,
        baud: u32,
    },
    Usb(UsbSelector),
    /// `usb:…?backend=rusb`: the libusb backend (feature `rusb-backend`).
    UsbRusb(UsbSelector),
    /// `genicam:NAME`: through Aravis (feature `genicam`).
    Genicam(GenicamOptions),
}

fn bad(uri: &str, why: impl std::fmt::Display) -> GrabError {
    GrabError::InvalidSetting(format!(
        "grabber URI '{uri}': {why} (expected sim:PRESET_OR_RIG[?rig=R&seed=S&size=WxH], sim:PRESET?scene=PATH, serial:PATH[?baud=N], usb:VID:PID[:SERIAL] or genicam:DEVICE_ID|ADDR)"
    ))
}

/// `WxH`.
pub fn parse_size(s: &str) -> Option<(u32, u32)> {
    let (w, h) = s.split_once(['x', 'X'])?;
    let (w, h) = (w.trim().parse().ok()?, h.trim().parse().ok()?);
    ((1..=4096).contains(&w) && (1..=4096).contains(&h)).then_some((w, h))
}

impl GrabberUri {
    /// Parse a URI.
    pub fn parse(uri: &str) -> Result<Self, GrabError> {
        let (scheme, rest) = uri.split_once(':').ok_or_else(|| bad(uri, "no scheme"))?;
        let (body, query) = match rest.split_once('?') {
            Some((b, q)) => (b, Some(q)),
            None => (rest, None),
        };
        let params: Vec<(&str, &str)> = match query {
            Some(q) => q
                .split('&')
                .filter(|p| !p.is_empty())
                .map(|p| {
                    p.split_once('=')
                        .ok_or_else(|| bad(uri, format!("parameter '{p}' needs a value")))
                })
                .collect::<Result<_, _>>()?,
            None => Vec::new(),
        };
        // Each parameter once: with two, one would silently win.
        for (i, (k, _)) in params.iter().enumerate() {
            if params[..i].iter().any(|(k0, _)| k0 == k) {
                return Err(bad(uri, format!("parameter '{k}' is given twice")));
            }
        }
        match scheme {
            "sim" => {
                let is_rig = RIGS.iter().any(|r| r.0 == body);
                let (mut preset, mut rig) = if body.is_empty() {
                    (DEFAULT_SIM_PRESET.to_string(), DEFAULT_RIG.to_string())
                } else if is_rig {
                    (DEFAULT_SIM_PRESET.to_string(), body.to_string())
                } else {
                    (body.to_string(), DEFAULT_RIG.to_string())
                };
                let (mut seed, mut size, mut scene) = (0u64, None, None);
                let mut rig_named = is_rig;
                for (k, v) in params {
                    match k {
                        "rig" => {
                            rig = v.to_string();
                            rig_named = true;
                        }
                        "scene" => {
                            if v.is_empty() {
                                return Err(bad(uri, "scene needs a path"));
                            }
                            scene = Some(v.to_string());
                        }
                        "sensor" | "preset" => preset = v.to_string(),
                        "seed" => {
                            seed = v
                                .parse()
                                .map_err(|_| bad(uri, format!("seed '{v}' is not an integer")))?
                        }
                        "size" => {
                            size = Some(parse_size(v).ok_or_else(|| {
                                bad(uri, format!("size '{v}' is not WxH (1..4096)"))
                            })?)
                        }
                        _ => return Err(bad(uri, format!("unknown parameter '{k}'"))),
                    }
                }
                if !RIGS.iter().any(|r| r.0 == rig) {
                    return Err(bad(uri, format!("unknown rig '{rig}'")));
                }
                if scene.is_some() && rig_named {
                    return Err(bad(uri, "give a rig or a scene, not both"));
                }
                Ok(GrabberUri::Sim {
                    preset,
                    rig,
                    seed,
                    size,
                    scene,
                })
            }
            "serial" => {
                if body.is_empty() {
                    return Err(bad(uri, "missing port path"));
                }
                let mut baud = crate::serial::DEFAULT_BAUD;
                for (k, v) in params {
                    match k {
                        "baud" => {
                            baud = v.parse().ok().filter(|b| *b > 0).ok_or_else(|| {
                                bad(uri, format!("baud '{v}' is not a positive integer"))
                            })?
                        }
                        _ => return Err(bad(uri, format!("unknown parameter '{k}'"))),
                    }
                }
                Ok(GrabberUri::Serial {
                    path: body.to_string(),
                    baud,
                })
            }
            "usb" => {
                let mut rusb = false;
                for (k, v) in params {
                    match (k, v) {
                        ("backend", "nusb") => rusb = false,
                        ("backend", "rusb") => rusb = true,
                        ("backend", other) => {
                            return Err(bad(
                                uri,
                                format!("unknown USB backend '{other}' (nusb or rusb)"),
                            ));
                        }
                        _ => return Err(bad(uri, format!("unknown parameter '{k}'"))),
                    }
                }
                let mut parts = body.splitn(3, ':');
                let hex = |s: Option<&str>, what: &str| -> Result<u16, GrabError> {
                    let s = s
                        .filter(|s| !s.is_empty())
                        .ok_or_else(|| bad(uri, format!("missing {what}")))?;
                    u16::from_str_radix(s.trim_start_matches("0x"), 16)
                        .map_err(|_| bad(uri, format!("{what} '{s}' is not 4 hex digits")))
                };
                let vendor_id = hex(parts.next(), "vendor id")?;
                let product_id = hex(parts.next(), "product id")?;
                let serial_number = parts.next().filter(|s| !s.is_empty()).map(str::to_string);
                let sel = UsbSelector {
                    vendor_id,
                    product_id,
                    serial_number,
                };
                Ok(if rusb {
                    GrabberUri::UsbRusb(sel)
                } else {
                    GrabberUri::Usb(sel)
                })
            }
            "genicam" => {
                if body.is_empty() {
                    return Err(bad(uri, "missing device id or address"));
                }
                let mut o = GenicamOptions {
                    name: body.to_string(),
                    trigger: TriggerChoice::Auto,
                    packet_resend: true,
                    timeout_ms: None,
                    size: None,
                };
                for (k, v) in params {
                    match (k, v) {
                        ("trigger", "auto") => o.trigger = TriggerChoice::Auto,
                        ("trigger", "software") => o.trigger = TriggerChoice::Software,
                        ("trigger", "off") => o.trigger = TriggerChoice::Off,
                        ("trigger", other) => {
                            return Err(bad(
                                uri,
                                format!("trigger '{other}' is not auto, software or off"),
                            ));
                        }
                        ("resend", "always") => o.packet_resend = true,
                        ("resend", "never") => o.packet_resend = false,
                        ("resend", other) => {
                            return Err(bad(
                                uri,
                                format!("resend '{other}' is not always or never"),
                            ));
                        }
                        ("timeout_ms", v) => {
                            o.timeout_ms = Some(
                                v.parse()
                                    .ok()
                                    .filter(|t| (1..=3_600_000).contains(t))
                                    .ok_or_else(|| {
                                        bad(uri, format!("timeout_ms '{v}' is not 1…3600000"))
                                    })?,
                            )
                        }
                        ("size", v) => {
                            o.size = Some(parse_size(v).ok_or_else(|| {
                                bad(uri, format!("size '{v}' is not WxH (1..4096)"))
                            })?)
                        }
                        _ => return Err(bad(uri, format!("unknown parameter '{k}'"))),
                    }
                }
                Ok(GrabberUri::Genicam(o))
            }
            other => Err(bad(uri, format!("unknown scheme '{other}'"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_all_schemes() {
        assert_eq!(
            GrabberUri::parse("sim:gen3-gaas-iccd?seed=7&rig=edge&size=64x48").unwrap(),
            GrabberUri::Sim {
                preset: "gen3-gaas-iccd".into(),
                rig: "edge".into(),
                seed: 7,
                size: Some((64, 48)),
                scene: None,
            }
        );
        assert_eq!(
            GrabberUri::parse("sim:sine").unwrap(),
            GrabberUri::Sim {
                preset: DEFAULT_SIM_PRESET.into(),
                rig: "sine".into(),
                seed: 0,
                size: None,
                scene: None,
            }
        );
        assert_eq!(
            GrabberUri::parse("sim:gen3-gaas-iccd?scene=sims/a b/scene.toml&seed=2").unwrap(),
            GrabberUri::Sim {
                preset: "gen3-gaas-iccd".into(),
                rig: DEFAULT_RIG.into(),
                seed: 2,
                size: None,
                scene: Some("sims/a b/scene.toml".into()),
            }
        );
        for bad_uri in [
            "sim:gen3-gaas-iccd?scene=",
            "sim:edge?scene=x.toml",
            "sim:gen3-gaas-iccd?rig=sine&scene=x.toml",
        ] {
            let e = GrabberUri::parse(bad_uri).unwrap_err().to_string();
            assert!(e.contains(bad_uri), "{e}");
        }
        assert_eq!(
            GrabberUri::parse("serial:/dev/ttyUSB0?baud=115200").unwrap(),
            GrabberUri::Serial {
                path: "/dev/ttyUSB0".into(),
                baud: 115_200
            }
        );
        assert_eq!(
            GrabberUri::parse("usb:1d50:6018:ABC123").unwrap(),
            GrabberUri::Usb(UsbSelector {
                vendor_id: 0x1d50,
                product_id: 0x6018,
                serial_number: Some("ABC123".into())
            })
        );
        assert!(matches!(
            GrabberUri::parse("usb:1d50").unwrap_err(),
            GrabError::InvalidSetting(_)
        ));
    }

    #[test]
    fn parses_genicam() {
        assert_eq!(
            GrabberUri::parse("genicam:127.0.0.1").unwrap(),
            GrabberUri::Genicam(GenicamOptions {
                name: "127.0.0.1".into(),
                trigger: TriggerChoice::Auto,
                packet_resend: true,
                timeout_ms: None,
                size: None,
            })
        );
        // Aravis device ids hold dashes and spaces; only '?' ends them.
        assert_eq!(
            GrabberUri::parse(
                "genicam:gloam-simulated gen2-s20-iccd-GL0001?trigger=off&resend=never&timeout_ms=500&size=64x48"
            )
            .unwrap(),
            GrabberUri::Genicam(GenicamOptions {
                name: "gloam-simulated gen2-s20-iccd-GL0001".into(),
                trigger: TriggerChoice::Off,
                packet_resend: false,
                timeout_ms: Some(500),
                size: Some((64, 48)),
            })
        );
        for bad_uri in [
            "genicam:",
            "genicam:x?trigger=line1",
            "genicam:x?resend=sometimes",
            "genicam:x?timeout_ms=0",
            "genicam:x?size=0x0",
            "genicam:x?gain=3",
        ] {
            let e = GrabberUri::parse(bad_uri).unwrap_err().to_string();
            assert!(e.contains(bad_uri) && e.contains("genicam:"), "{e}");
        }
    }

    #[test]
    fn rejects_garbage_with_clear_errors() {
        let e = GrabberUri::parse("sim:scientific-ccd?size=16x16&size=32x32").unwrap_err();
        assert!(e.to_string().contains("'size' is given twice"), "{e}");
        for bad in [
            "",
            "sim",
            "tcp:host",
            "serial:",
            "serial:/dev/x?baud=fast",
            "sim:x?seed=-1",
            "sim:x?rig=moon",
            "usb:zz:00",
            "sim:x?size=0x3",
        ] {
            let e = GrabberUri::parse(bad).unwrap_err().to_string();
            assert!(e.contains("grabber URI"), "{bad}: {e}");
        }
    }
}
