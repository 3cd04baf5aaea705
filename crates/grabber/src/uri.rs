//! Grabber URIs.
//!
//! ```text
//! sim:PRESET_OR_RIG[?rig=RIG&seed=S&size=WxH]   in-process sensor chain + rig
//! sim:PRESET?scene=PATH[&seed=S&size=WxH]        … looking at a traced scene
//! serial:PATH[?baud=N]                           protocol over a serial port
//! usb:VID:PID[:SERIAL][?backend=nusb|rusb]     protocol over USB bulk (hex ids)
//! ```

use crate::interface::GrabError;
use crate::sim::RIGS;
use crate::usb::UsbSelector;

/// Sensor preset used when a `sim:` URI names only a rig.
pub const DEFAULT_SIM_PRESET: &str = "gen2-s20-iccd";
/// Rig used when a `sim:` URI names only a preset.
pub const DEFAULT_RIG: &str = "uniform";

/// A parsed grabber URI.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GrabberUri {
    Sim {
        preset: String,
        rig: String,
        seed: u64,
        /// `size=`; without it a rig is [`crate::sim::DEFAULT_RIG_SIZE`] and a scene
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
}

fn bad(uri: &str, why: impl std::fmt::Display) -> GrabError {
    GrabError::InvalidSetting(format!(
        "grabber URI '{uri}': {why} (expected sim:PRESET_OR_RIG[?rig=R&seed=S&size=WxH], sim:PRESET?scene=PATH, serial:PATH[?baud=N] or usb:VID:PID[:SERIAL])"
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
    fn rejects_garbage_with_clear_errors() {
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
