//! The scene file as written: serde structs mirroring the TOML, with every
//! table closed to unknown keys. Semantic checks live in `build.rs`.

use std::collections::BTreeMap;
use std::fmt;

use serde::Deserialize;
use serde::de::{self, MapAccess, Visitor};

/// Three numbers, exactly: serde's own `[f64; 3]` stops reading after the
/// third and would silently drop a fourth.
#[derive(Clone, Copy, Debug)]
pub(crate) struct V3(pub [f64; 3]);

impl<'de> Deserialize<'de> for V3 {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        match <[f64; 3]>::try_from(v.as_slice()) {
            Ok(a) => Ok(V3(a)),
            Err(_) => Err(de::Error::invalid_length(v.len(), &"3 numbers [x, y, z]")),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawScene {
    pub units: String,
    pub camera: RawCamera,
    #[serde(default)]
    pub bands: BTreeMap<String, RawBand>,
    #[serde(default)]
    pub materials: BTreeMap<String, RawMaterial>,
    #[serde(default)]
    pub objects: BTreeMap<String, RawObject>,
    #[serde(default)]
    pub point_sources: BTreeMap<String, RawPointSource>,
    #[serde(default)]
    pub distant_sources: BTreeMap<String, RawDistantSource>,
    pub sky: Option<RawSky>,
    pub sensor: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawCamera {
    pub position: V3,
    pub look_at: V3,
    pub up: Option<V3>,
    pub fov_deg: f64,
    pub width: u32,
    pub height: u32,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBand {
    pub lo_nm: Option<f64>,
    pub hi_nm: Option<f64>,
    pub response: Option<RawSpectrum>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawNormalize {
    pub lo_nm: f64,
    pub hi_nm: f64,
    pub value: f64,
}

/// Emission lines as written: `[[wavelength_nm, value], …]`. Each entry is
/// read as a list and its length checked in `build.rs` (a fixed-size array
/// would let toml drop a third number silently).
pub(crate) type RawLines = Vec<Vec<f64>>;

/// `{ spectrum = "name-or-csv" | value = 0.5, lines = [[nm, value], …],
/// scale = 2, normalize = {…} }`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSpectrumTable {
    pub spectrum: Option<String>,
    pub value: Option<f64>,
    pub lines: Option<RawLines>,
    pub scale: Option<f64>,
    pub normalize: Option<RawNormalize>,
}

/// A spectrum: a number (flat), a string (library name or CSV path), or a
/// [`RawSpectrumTable`].
#[derive(Debug)]
pub(crate) enum RawSpectrum {
    Flat(f64),
    Name(String),
    Table(RawSpectrumTable),
}

impl<'de> Deserialize<'de> for RawSpectrum {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawSpectrum;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a number (flat spectrum), a spectrum name or CSV path, or a table \
                     { spectrum = \"…\" | value = …, lines = [[nm, value], …], scale = …, normalize = { lo_nm, hi_nm, value } }",
                )
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<RawSpectrum, E> {
                Ok(RawSpectrum::Flat(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RawSpectrum, E> {
                Ok(RawSpectrum::Flat(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RawSpectrum, E> {
                Ok(RawSpectrum::Flat(v as f64))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawSpectrum, E> {
                Ok(RawSpectrum::Name(v.to_string()))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<RawSpectrum, A::Error> {
                RawSpectrumTable::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(RawSpectrum::Table)
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawMaterial {
    pub reflectance: Option<RawSpectrum>,
    pub specular_fraction: Option<f64>,
    pub transmission: Option<RawSpectrum>,
    pub emission: Option<RawEmission>,
    /// Light group of the objects made of it (see `groups.rs`).
    pub group: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawEmission {
    pub spectrum: Option<String>,
    pub value: Option<f64>,
    pub lines: Option<RawLines>,
    pub scale: Option<f64>,
    pub normalize: Option<RawNormalize>,
    pub shape_exponent: Option<f64>,
    /// An IES or EULUMDAT file, relative to the scene (a measured area
    /// luminaire: see `AreaLuminaire`).
    pub photometry: Option<String>,
    /// The luminaire's C0 axis (projected perpendicular to each facet's
    /// normal).
    pub c0_direction: Option<V3>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawPointSource {
    pub position: V3,
    pub direction: Option<V3>,
    pub shape_exponent: Option<f64>,
    pub spectrum: Option<String>,
    pub value: Option<f64>,
    pub lines: Option<RawLines>,
    pub scale: Option<f64>,
    pub normalize: Option<RawNormalize>,
    pub instances: Option<Vec<RawPlacement>>,
    pub instances_csv: Option<String>,
    /// An IES or EULUMDAT file, relative to the scene.
    pub photometry: Option<String>,
    /// The luminaire's C0 axis (projected perpendicular to `direction`).
    pub c0_direction: Option<V3>,
    /// Light group (see `groups.rs`).
    pub group: Option<String>,
}

/// A distant (directional) source: parallel light along `direction`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawDistantSource {
    /// The way the light travels.
    pub direction: V3,
    pub spectrum: Option<String>,
    pub value: Option<f64>,
    pub lines: Option<RawLines>,
    pub scale: Option<f64>,
    pub normalize: Option<RawNormalize>,
    /// Light group (see `groups.rs`).
    pub group: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawObject {
    pub material: String,
    pub vertices: Option<Vec<V3>>,
    pub faces: Option<Vec<Vec<usize>>>,
    #[serde(rename = "box")]
    pub box_: Option<RawBox>,
    pub quad: Option<RawQuad>,
    pub obj: Option<String>,
    pub translate: Option<V3>,
    pub rotate_z_deg: Option<f64>,
    pub scale: Option<RawScale>,
    pub instances: Option<Vec<RawPlacement>>,
    pub instances_csv: Option<String>,
    /// `"auto"`, `"expand"` or `"shared"` (see `instance::Instancing`).
    pub instancing: Option<String>,
    /// Light group of an emissive object (see `groups.rs`).
    pub group: Option<String>,
}

/// One placement of an instanced object or point source:
/// `{ translate = [x, y, z], rotate_z_deg = θ, scale = s | [sx, sy, sz] }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawPlacement {
    pub translate: Option<V3>,
    pub rotate_z_deg: Option<f64>,
    pub scale: Option<RawScale>,
}

/// `scale = 2.0` or `scale = [sx, sy, sz]`.
#[derive(Debug)]
pub(crate) enum RawScale {
    Uniform(f64),
    PerAxis(V3),
}

impl<'de> Deserialize<'de> for RawScale {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawScale;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number (uniform scale) or [sx, sy, sz]")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<RawScale, E> {
                Ok(RawScale::Uniform(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RawScale, E> {
                Ok(RawScale::Uniform(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RawScale, E> {
                Ok(RawScale::Uniform(v as f64))
            }
            fn visit_seq<A: de::SeqAccess<'de>>(self, seq: A) -> Result<RawScale, A::Error> {
                V3::deserialize(de::value::SeqAccessDeserializer::new(seq)).map(RawScale::PerAxis)
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBox {
    pub min: V3,
    pub max: V3,
    #[serde(default)]
    pub inward: bool,
    #[serde(default)]
    pub omit: Vec<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawQuad {
    pub center: V3,
    pub size: [f64; 2],
    pub normal: V3,
    pub width_axis: Option<V3>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSky {
    pub utc: toml::Value,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub height_m: Option<f64>,
    pub visibility_km: Option<f64>,
    pub moon: Option<bool>,
    pub night_sky: Option<bool>,
    pub overcast: Option<bool>,
}
