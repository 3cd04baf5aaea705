//! `sim:` URIs: the simulated camera's vocabulary, parsed on the grabber's
//! generic [`UriParts`] (scheme, opaque body, each key once).
//!
//! ```text
//! sim:PRESET_OR_RIG[?rig=RIG&seed=S&size=WxH]   in-process sensor chain + rig
//! sim:PRESET?scene=PATH[&seed=S&size=WxH]        … looking at a traced scene
//! ```
//!
//! `PRESET` is a sensor preset or a sensor TOML path (`sim:my/cam.toml`);
//! `sensor=`/`preset=` name it as a parameter instead. Nothing is
//! percent-decoded: a name or path is used as written.

use gloam_grabber::GrabError;
use gloam_grabber::uri::{UriParts, parse_size, uri_error};

/// The scheme.
pub const SCHEME: &str = "sim";

/// Built-in rigs a `sim:` URI can name: what the simulated camera looks at
/// by default ([`crate::rig_stimulus`] renders them).
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

/// The forms a `sim:` URI takes, for its errors.
pub const SIM_FORMS: &str =
    "sim:PRESET_OR_RIG[?rig=R&seed=S&size=WxH] or sim:PRESET?scene=PATH[&seed=S&size=WxH]";

/// A parsed `sim:` URI.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SimUri {
    /// Sensor preset name or sensor file path.
    pub preset: String,
    pub rig: String,
    pub seed: u64,
    /// `size=`; without it a rig is [`crate::DEFAULT_RIG_SIZE`] and a scene
    /// its camera's resolution.
    pub size: Option<(u32, u32)>,
    /// `scene=PATH`: look at this scene (rendered once by the tracer)
    /// instead of a rig.
    pub scene: Option<String>,
}

fn bad(uri: &str, why: impl std::fmt::Display) -> GrabError {
    uri_error(uri, why, SIM_FORMS)
}

/// The seed a `sim:` camera runs with: `flag` (`--seed`) when the URI
/// gives no `seed=`, the URI's `seed` otherwise — and a flag that
/// contradicts the URI's is refused: `--seed 5` on `…&seed=4` ran with 5
/// while the capture's report recorded the URI.
pub fn agreed_seed(uri: &str, parsed: u64, flag: Option<u64>) -> Result<u64, GrabError> {
    let given = uri.split_once('?').is_some_and(|(_, q)| {
        q.split('&')
            .any(|p| p.split_once('=').map_or(p, |(k, _)| k) == "seed")
    });
    match flag {
        Some(f) if given && f != parsed => Err(GrabError::InvalidSetting(format!(
            "grabber URI '{uri}': --seed {f} contradicts its seed={parsed}; give the seed once"
        ))),
        Some(f) => Ok(f),
        None => Ok(parsed),
    }
}

/// Whether `uri` is of the `sim:` scheme (well formed or not).
pub fn is_sim(uri: &str) -> bool {
    uri.split_once(':').is_some_and(|(s, _)| s == SCHEME)
}

/// A `%XX` in `text`: names and paths are taken as written, so a
/// percent-encoded character would name another file than meant.
fn percent_escape(text: &str) -> Option<&str> {
    let b = text.as_bytes();
    (0..b.len().saturating_sub(2))
        .find(|&i| b[i] == b'%' && b[i + 1].is_ascii_hexdigit() && b[i + 2].is_ascii_hexdigit())
        .map(|i| &text[i..i + 3])
}

impl SimUri {
    /// Parses a `sim:` URI; any other scheme is refused as not one.
    pub fn parse(uri: &str) -> Result<Self, GrabError> {
        let UriParts {
            scheme,
            body,
            params,
        } = UriParts::parse(uri).map_err(|e| bad(uri, e))?;
        if scheme != SCHEME {
            return Err(GrabError::Unsupported(format!("'{uri}': not a sim: URI")));
        }
        let literal = |what: &str, text: &str| match percent_escape(text) {
            Some(esc) => Err(bad(
                uri,
                format!(
                    "{what} '{text}' holds '{esc}': sim: URIs are not percent-decoded{}",
                    if matches!(
                        esc.to_ascii_uppercase().as_str(),
                        "%26" | "%3F" | "%23" | "%3D"
                    ) {
                        " and cannot hold '&', '?', '#' or '=' (they separate the URI's parts): give the file a name or a link without them"
                    } else {
                        ", write the character itself"
                    }
                ),
            )),
            None => Ok(()),
        };
        literal("preset or rig", body)?;
        let is_rig = RIGS.iter().any(|r| r.0 == body);
        let (mut preset, mut rig) = if body.is_empty() {
            (DEFAULT_SIM_PRESET.to_string(), DEFAULT_RIG.to_string())
        } else if is_rig {
            (DEFAULT_SIM_PRESET.to_string(), body.to_string())
        } else {
            (body.to_string(), DEFAULT_RIG.to_string())
        };
        // Who named the preset and the rig: two namings, one would win.
        let mut preset_by = (!body.is_empty() && !is_rig).then(|| format!("'sim:{body}'"));
        let mut rig_by = is_rig.then(|| format!("'sim:{body}'"));
        let (mut seed, mut size, mut scene) = (0u64, None, None);
        for (k, v) in params {
            match k {
                "rig" => {
                    literal("rig", v)?;
                    if let Some(by) = rig_by.replace(format!("'{k}={v}'")) {
                        return Err(bad(
                            uri,
                            format!("the rig is named twice, by {by} and '{k}={v}'"),
                        ));
                    }
                    rig = v.to_string();
                }
                "scene" => {
                    if v.is_empty() {
                        return Err(bad(uri, "scene needs a path"));
                    }
                    literal("scene", v)?;
                    scene = Some(v.to_string());
                }
                "sensor" | "preset" => {
                    if v.is_empty() {
                        return Err(bad(uri, format!("{k} needs a preset name or sensor file")));
                    }
                    literal(k, v)?;
                    if let Some(by) = preset_by.replace(format!("'{k}={v}'")) {
                        return Err(bad(
                            uri,
                            format!("the sensor is named twice, by {by} and '{k}={v}'"),
                        ));
                    }
                    preset = v.to_string();
                }
                "seed" => {
                    seed = v
                        .parse()
                        .map_err(|_| bad(uri, format!("seed '{v}' is not an integer")))?
                }
                "size" => {
                    size = Some(
                        parse_size(v)
                            .ok_or_else(|| bad(uri, format!("size '{v}' is not WxH (1..4096)")))?,
                    )
                }
                _ => {
                    return Err(bad(
                        uri,
                        format!(
                            "unknown parameter '{k}' (sim: takes rig, scene, seed, size, sensor or preset)"
                        ),
                    ));
                }
            }
        }
        if !RIGS.iter().any(|r| r.0 == rig) {
            return Err(bad(uri, format!("unknown rig '{rig}'")));
        }
        if scene.is_some() && rig_by.is_some() {
            return Err(bad(uri, "give a rig or a scene, not both"));
        }
        Ok(SimUri {
            preset,
            rig,
            seed,
            size,
            scene,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_sim_forms() {
        assert_eq!(
            SimUri::parse("sim:gen3-gaas-iccd?seed=7&rig=edge&size=64x48").unwrap(),
            SimUri {
                preset: "gen3-gaas-iccd".into(),
                rig: "edge".into(),
                seed: 7,
                size: Some((64, 48)),
                scene: None,
            }
        );
        assert_eq!(
            SimUri::parse("sim:sine").unwrap(),
            SimUri {
                preset: DEFAULT_SIM_PRESET.into(),
                rig: "sine".into(),
                seed: 0,
                size: None,
                scene: None,
            }
        );
        assert_eq!(
            SimUri::parse("sim:").unwrap(),
            SimUri {
                preset: DEFAULT_SIM_PRESET.into(),
                rig: DEFAULT_RIG.into(),
                seed: 0,
                size: None,
                scene: None,
            }
        );
        assert_eq!(
            SimUri::parse("sim:gen3-gaas-iccd?scene=sims/a b/scene.toml&seed=2").unwrap(),
            SimUri {
                preset: "gen3-gaas-iccd".into(),
                rig: DEFAULT_RIG.into(),
                seed: 2,
                size: None,
                scene: Some("sims/a b/scene.toml".into()),
            }
        );
        // A sensor file by path, and the sensor as a parameter beside a rig.
        assert_eq!(
            SimUri::parse("sim:my/cams/cam.toml?size=16x8")
                .unwrap()
                .preset,
            "my/cams/cam.toml"
        );
        let u = SimUri::parse("sim:edge?sensor=scientific-ccd&seed=18446744073709551615").unwrap();
        assert_eq!(
            (u.preset.as_str(), u.rig.as_str(), u.seed),
            ("scientific-ccd", "edge", u64::MAX)
        );
        assert_eq!(
            SimUri::parse("sim:?preset=s25-ebccd&rig=dark").unwrap(),
            SimUri {
                preset: "s25-ebccd".into(),
                rig: "dark".into(),
                seed: 0,
                size: None,
                scene: None,
            }
        );
        assert!(is_sim("sim:x") && is_sim("sim:") && !is_sim("simx:a") && !is_sim("sim"));
    }

    /// Each refusal names the URI, the offending part, and the sim: forms.
    #[test]
    fn refuses_malformed_sim_uris_naming_the_part() {
        for (uri, part) in [
            ("sim:gen3-gaas-iccd?scene=", "scene needs a path"),
            ("sim:edge?scene=x.toml", "give a rig or a scene, not both"),
            (
                "sim:gen3-gaas-iccd?rig=sine&scene=x.toml",
                "give a rig or a scene, not both",
            ),
            ("sim:x?seed=-1", "seed '-1' is not an integer"),
            ("sim:x?seed=1e3", "seed '1e3' is not an integer"),
            ("sim:x?rig=moon", "unknown rig 'moon'"),
            ("sim:x?size=0x3", "size '0x3' is not WxH (1..4096)"),
            ("sim:x?size=4097x1", "size '4097x1'"),
            (
                "sim:scientific-ccd?size=16x16&size=32x32",
                "parameter 'size' is given twice",
            ),
            ("sim:x?colour=red", "unknown parameter 'colour'"),
            ("sim:x?Seed=1", "unknown parameter 'Seed'"),
            // issue 46: lenient URIs
            ("sim:x?=3", "parameter '=3' has no name"),
            ("sim:x?seed", "parameter 'seed' needs a value"),
            ("sim:x?seed=1&", "empty parameter in 'seed=1&'"),
            ("sim:x?&seed=1", "empty parameter in '&seed=1'"),
            (
                "sim:x?seed=1&&size=2x2",
                "empty parameter in 'seed=1&&size=2x2'",
            ),
            ("sim:x?", "nothing after '?'"),
            ("sim:x?s%65ed=1", "parameter name 's%65ed'"),
            (
                "sim:gen3-gaas-iccd?scene=my%20scene.toml",
                "scene 'my%20scene.toml' holds '%20'",
            ),
            (
                "sim:gen3%2Dgaas-iccd",
                "preset or rig 'gen3%2Dgaas-iccd' holds '%2D'",
            ),
            ("sim:x?rig=%65dge", "rig '%65dge' holds '%65'"),
            ("sim:x?sensor=", "sensor needs a preset name or sensor file"),
            (
                "sim:gen3-gaas-iccd?preset=scientific-ccd",
                "the sensor is named twice, by 'sim:gen3-gaas-iccd' and 'preset=scientific-ccd'",
            ),
            (
                "sim:?sensor=a&preset=b",
                "the sensor is named twice, by 'sensor=a' and 'preset=b'",
            ),
            (
                "sim:sine?rig=edge",
                "the rig is named twice, by 'sim:sine' and 'rig=edge'",
            ),
        ] {
            let e = SimUri::parse(uri).unwrap_err();
            let msg = e.to_string();
            assert!(matches!(e, GrabError::InvalidSetting(_)), "{uri}: {msg}");
            assert!(
                msg.starts_with(&format!("invalid setting: grabber URI '{uri}': {part}"))
                    && msg.ends_with(&format!("(expected {SIM_FORMS})")),
                "{uri}: {msg}"
            );
        }
        // A '%' that escapes nothing is a character like any other.
        assert_eq!(
            SimUri::parse("sim:x?scene=100%.toml")
                .unwrap()
                .scene
                .as_deref(),
            Some("100%.toml")
        );
        // Other schemes are not sim: URIs.
        let e = SimUri::parse("serial:/dev/ttyUSB0").unwrap_err();
        assert!(matches!(e, GrabError::Unsupported(_)), "{e}");
    }
}
