//! Grabber URIs: the generic syntax every scheme shares, and the
//! transports' schemes.
//!
//! ```text
//! SCHEME:BODY[?KEY=VALUE&KEY=VALUE…]             every scheme (UriParts)
//! serial:PATH[?baud=N]                           protocol over a serial port
//! usb:VID:PID[:SERIAL][?backend=nusb|rusb]     protocol over USB bulk (hex ids)
//! genicam:DEVICE_ID|ADDR[?trigger=auto|software|off&resend=always|never&timeout_ms=N&size=WxH]
//!                                                a GenICam camera through Aravis (feature `genicam`)
//! ```
//!
//! The crates that own other cameras parse their schemes' bodies and keys
//! on [`UriParts`] (`gloam-simcam` the `sim:` vocabulary), so this crate
//! knows no sensor, preset or rig.

use crate::interface::GrabError;
use crate::usb::UsbSelector;

/// What is wrong with a URI's generic syntax ([`UriParts::parse`]); the
/// scheme's owner adds the URI and its forms ([`uri_error`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum UriSyntaxError {
    /// No `SCHEME:`.
    NoScheme,
    /// A `?` with nothing after it.
    EmptyQuery,
    /// An empty parameter: `&&`, or `&` at the start or end of the query.
    EmptyParameter { query: String },
    /// `KEY` without `=VALUE`.
    NoValue { param: String },
    /// `=VALUE` without a key.
    EmptyKey { param: String },
    /// A key of other characters than ASCII letters, digits and `_`
    /// (percent-encoded, spaced, …): never one a scheme knows.
    BadKey { key: String },
    /// The same key twice: one would silently win.
    Twice { key: String },
}

impl std::fmt::Display for UriSyntaxError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NoScheme => write!(f, "no scheme"),
            Self::EmptyQuery => write!(
                f,
                "nothing after '?' (give KEY=VALUE parameters or drop the '?')"
            ),
            Self::EmptyParameter { query } => write!(
                f,
                "empty parameter in '{query}' (a stray '&' at its start or end, or '&&')"
            ),
            Self::NoValue { param } => write!(
                f,
                "parameter '{param}' needs a value{}",
                // `scene=a&b.toml` split at its '&'.
                if param.contains(['.', '/']) {
                    " ('&' separates a URI's parameters: a path holding '&' cannot be named here; give the file a name or a link without it)"
                } else {
                    ""
                }
            ),
            Self::EmptyKey { param } => write!(f, "parameter '{param}' has no name before '='"),
            Self::BadKey { key } => write!(
                f,
                "parameter name '{key}' is not ASCII letters, digits and '_' (URIs here are not percent-decoded)"
            ),
            Self::Twice { key } => write!(f, "parameter '{key}' is given twice"),
        }
    }
}

/// A URI split generically: `SCHEME:BODY[?KEY=VALUE&…]`, the body opaque
/// (only the first `?` ends it), each key once. Nothing is decoded: what is
/// written is what the scheme's owner gets.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UriParts<'a> {
    pub scheme: &'a str,
    pub body: &'a str,
    /// The query's parameters in order, each key once.
    pub params: Vec<(&'a str, &'a str)>,
}

impl<'a> UriParts<'a> {
    /// Splits `uri`, refusing a missing scheme, empty parameters, a key
    /// without a value, an empty or odd key and a key given twice.
    pub fn parse(uri: &'a str) -> Result<Self, UriSyntaxError> {
        let (scheme, rest) = uri.split_once(':').ok_or(UriSyntaxError::NoScheme)?;
        let (body, query) = match rest.split_once('?') {
            Some((b, q)) => (b, Some(q)),
            None => (rest, None),
        };
        let mut params: Vec<(&str, &str)> = Vec::new();
        if let Some(q) = query {
            if q.is_empty() {
                return Err(UriSyntaxError::EmptyQuery);
            }
            for p in q.split('&') {
                if p.is_empty() {
                    return Err(UriSyntaxError::EmptyParameter {
                        query: q.to_string(),
                    });
                }
                let (k, v) = p.split_once('=').ok_or_else(|| UriSyntaxError::NoValue {
                    param: p.to_string(),
                })?;
                if k.is_empty() {
                    return Err(UriSyntaxError::EmptyKey {
                        param: p.to_string(),
                    });
                }
                if !k.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_') {
                    return Err(UriSyntaxError::BadKey { key: k.to_string() });
                }
                if params.iter().any(|(k0, _)| *k0 == k) {
                    return Err(UriSyntaxError::Twice { key: k.to_string() });
                }
                params.push((k, v));
            }
        }
        Ok(Self {
            scheme,
            body,
            params,
        })
    }
}

/// The one form of a URI error: `grabber URI 'URI': WHY (expected FORMS)`,
/// `forms` the scheme owner's summary of what it accepts.
pub fn uri_error(uri: &str, why: impl std::fmt::Display, forms: &str) -> GrabError {
    GrabError::InvalidSetting(format!("grabber URI '{uri}': {why} (expected {forms})"))
}

/// The transports' forms, for their errors.
pub const TRANSPORT_FORMS: &str =
    "serial:PATH[?baud=N], usb:VID:PID[:SERIAL] or genicam:DEVICE_ID|ADDR";

/// The schemes [`GrabberUri`] parses.
pub const TRANSPORT_SCHEMES: &[&str] = &["serial", "usb", "genicam"];

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

/// A parsed transport URI.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GrabberUri {
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
    uri_error(uri, why, TRANSPORT_FORMS)
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
        let UriParts {
            scheme,
            body,
            params,
        } = UriParts::parse(uri).map_err(|e| bad(uri, e))?;
        match scheme {
            "serial" => {
                if body.is_empty() {
                    return Err(bad(uri, "missing port path"));
                }
                let mut baud = crate::serial::DEFAULT_BAUD;
                for (k, v) in params {
                    match k {
                        "baud" => {
                            // A whole number past 32 bits is too large, not
                            // "not a positive integer".
                            baud = match v.parse::<u128>() {
                                Ok(b) if b > 0 && b <= u128::from(u32::MAX) => b as u32,
                                Ok(b) if b > 0 => {
                                    return Err(bad(
                                        uri,
                                        format!("baud {b} is too large: at most {}", u32::MAX),
                                    ));
                                }
                                _ => {
                                    return Err(bad(
                                        uri,
                                        format!("baud '{v}' is not a positive integer"),
                                    ));
                                }
                            }
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
    fn splits_any_scheme_generically() {
        // The body is opaque up to the first '?': spaces, colons, slashes.
        assert_eq!(
            UriParts::parse("sim:a b/c:d.toml?scene=sims/a b/scene.toml&seed=2").unwrap(),
            UriParts {
                scheme: "sim",
                body: "a b/c:d.toml",
                params: vec![("scene", "sims/a b/scene.toml"), ("seed", "2")],
            }
        );
        // A value may hold '=' and is never decoded.
        assert_eq!(
            UriParts::parse("x:?k=a=b%20c").unwrap().params,
            vec![("k", "a=b%20c")]
        );
        assert_eq!(
            UriParts::parse("x:").unwrap(),
            UriParts {
                scheme: "x",
                body: "",
                params: vec![],
            }
        );
        for (uri, why) in [
            ("nothing", UriSyntaxError::NoScheme),
            ("x:a?", UriSyntaxError::EmptyQuery),
            (
                "x:a?k=1&",
                UriSyntaxError::EmptyParameter {
                    query: "k=1&".into(),
                },
            ),
            (
                "x:a?&k=1",
                UriSyntaxError::EmptyParameter {
                    query: "&k=1".into(),
                },
            ),
            (
                "x:a?k=1&&j=2",
                UriSyntaxError::EmptyParameter {
                    query: "k=1&&j=2".into(),
                },
            ),
            ("x:a?k", UriSyntaxError::NoValue { param: "k".into() }),
            ("x:a?=1", UriSyntaxError::EmptyKey { param: "=1".into() }),
            (
                "x:a?s%65ed=1",
                UriSyntaxError::BadKey {
                    key: "s%65ed".into(),
                },
            ),
            (
                "x:a?se ed=1",
                UriSyntaxError::BadKey {
                    key: "se ed".into(),
                },
            ),
            ("x:a?k=1&k=1", UriSyntaxError::Twice { key: "k".into() }),
        ] {
            assert_eq!(UriParts::parse(uri), Err(why.clone()), "{uri}");
        }
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
        let e = GrabberUri::parse("serial:/dev/x?baud=9600&baud=115200").unwrap_err();
        assert!(e.to_string().contains("'baud' is given twice"), "{e}");
        for (bad, part) in [
            ("", "no scheme"),
            ("sim", "no scheme"),
            ("tcp:host", "unknown scheme 'tcp'"),
            ("sim:gen3-gaas-iccd", "unknown scheme 'sim'"),
            ("serial:", "missing port path"),
            ("serial:/dev/x?baud=fast", "baud 'fast'"),
            (
                "serial:/dev/x?baud=9600&",
                "empty parameter in 'baud=9600&'",
            ),
            ("serial:/dev/x?", "nothing after '?'"),
            ("serial:/dev/x?=9600", "parameter '=9600' has no name"),
            ("serial:/dev/x?baud", "parameter 'baud' needs a value"),
            ("serial:/dev/x?b%61ud=9600", "parameter name 'b%61ud'"),
            ("usb:zz:00", "vendor id 'zz'"),
            ("usb:1d50:6018?speed=high", "unknown parameter 'speed'"),
        ] {
            let e = GrabberUri::parse(bad).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("invalid setting: grabber URI '{bad}': {part}"))
                    && e.contains("(expected serial:PATH"),
                "{bad}: {e}"
            );
        }
    }
}
