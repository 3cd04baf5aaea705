//! From the raw TOML structs to a validated [`Scene`]: units, spectra,
//! materials, geometry, sources, camera, bands and sky, each check naming the
//! field it rejects.

use std::collections::BTreeMap;
use std::path::Path;

use glam::DVec3;
use gloam_spectra::{Spectrum, library};

use crate::error::{FieldPath, Locator, Seg};
use crate::geometry::{MIN_FACET_SIZE, box_faces, check_facet, longest_edge, quad_vertices};
use crate::instance::{
    Instancing, MAX_FACETS, MAX_INSTANCES, MAX_POINT_SOURCES, MAX_SHARED_FACETS, Placement,
    SHARE_ABOVE_FACETS, SharedInstances, Xform, available_memory_bytes, bounds, box_corners,
    check_budget, count_obj_faces, facet_bytes, read_placements_csv,
};
use crate::raw::*;
use crate::{
    Band, Camera, DistantSource, Emission, Facet, Luminaire, Material, ObjectInfo, PointSource,
    PointSourceGroup, Scene, SceneError, SkyConfig, Units, base_dir,
};

/// Support of a flat spectrum given as a plain number or `value`, nm.
pub const FLAT_LO_NM: f64 = 200.0;
/// See [`FLAT_LO_NM`].
pub const FLAT_HI_NM: f64 = 2500.0;

type R<T> = Result<T, SceneError>;

struct Ctx<'a> {
    loc: Locator<'a>,
    path: &'a Path,
    /// Where the files the scene names are noted.
    reads: &'a gloam_io::ReadLog,
    /// Read once, when a size is first checked.
    memory: std::cell::OnceCell<Option<u64>>,
}

impl Ctx<'_> {
    fn available_memory(&self) -> Option<u64> {
        *self.memory.get_or_init(available_memory_bytes)
    }

    fn err(&self, field: &FieldPath, msg: impl Into<String>) -> SceneError {
        self.loc.error(field, msg)
    }

    /// Entries of a keyed table (`[materials.NAME]` …) in file order.
    fn ordered<'m, T>(
        &self,
        field: &FieldPath,
        map: &'m BTreeMap<String, T>,
    ) -> Vec<(&'m str, &'m T)> {
        let mut out: Vec<(&str, &T)> = Vec::with_capacity(map.len());
        for k in self.loc.keys_in_file_order(field) {
            if let Some((k, v)) = map.get_key_value(&k) {
                out.push((k.as_str(), v));
            }
        }
        if out.len() != map.len() {
            out = map.iter().map(|(k, v)| (k.as_str(), v)).collect();
        }
        out
    }

    fn resolve(&self, rel: &str) -> std::path::PathBuf {
        let p = Path::new(rel);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            base_dir(self.path).join(p)
        }
    }

    fn finite(&self, field: &FieldPath, v: f64) -> R<f64> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(field, format!("{v} is not a finite number")))
        }
    }

    fn vec3(&self, field: &FieldPath, v: V3) -> R<DVec3> {
        for (i, c) in v.0.iter().enumerate() {
            if !c.is_finite() {
                return Err(self.err(
                    &field.index(i),
                    format!("coordinate {c} is not a finite number"),
                ));
            }
            if c.abs() > MAX_COORDINATE {
                return Err(self.err(
                    &field.index(i),
                    format!(
                        "coordinate {c:e} is out of range (|x| ≤ {MAX_COORDINATE:e} scene units)"
                    ),
                ));
            }
        }
        Ok(DVec3::from_array(v.0))
    }
}

/// Largest coordinate magnitude, scene units: beyond it, f64 geometry
/// (cross products, squared lengths) loses the precision ray tracing needs
/// long before it overflows.
pub const MAX_COORDINATE: f64 = 1e12;

/// A number for a message: plain when short, `1e308` rather than 309
/// digits when not (and `5e-324` rather than `0.000…`).
pub(crate) fn num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e7).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Largest emitter shape exponent (`cos^m`): a cos^10000 lobe is 0.7° wide
/// at half maximum (the documented hard case, exact to 3e-13), and the
/// closed forms loop over the exponent, so 10⁶ would take minutes a vertex.
pub const MAX_SHAPE_EXPONENT: f64 = 10_000.0;

/// Longest wavelength a spectrum or emission line may name, nm (1 mm).
pub const MAX_WAVELENGTH_NM: f64 = 1e6;

/// Narrowest horizontal field of view, degrees.
pub const MIN_FOV_DEG: f64 = 1e-3;

pub(crate) fn build(text: &str, path: &Path, reads: &gloam_io::ReadLog) -> R<Scene> {
    let cx = Ctx {
        loc: Locator::new(text, path),
        path,
        reads,
        memory: std::cell::OnceCell::new(),
    };
    let raw: RawScene = toml::from_str(text).map_err(|e| cx.loc.error_at(e.span(), e.message()))?;
    let root = FieldPath::root();

    let units = units(&cx, &root, &raw.units)?;

    // Materials.
    let mut materials = Vec::new();
    let mf = root.key("materials");
    for (name, m) in cx.ordered(&mf, &raw.materials) {
        materials.push(material(&cx, &mf.key(name), name, m)?);
    }

    // Objects → facets: each object's geometry read once, then placed.
    let mut facets = Vec::new();
    let mut objects = Vec::new();
    let mut shared = Vec::new();
    let of = root.key("objects");
    for (name, o) in cx.ordered(&of, &raw.objects) {
        let out = Built {
            facets: &mut facets,
            shared: &mut shared,
            index: objects.len(),
        };
        objects.push(object(&cx, &of.key(name), name, o, &materials, out)?);
    }

    refuse_coincident_facets(&cx, &of, &facets, &objects)?;
    check_luminaire_radiance(&cx, &of, &facets, &objects, &materials, units)?;
    refuse_coincident_shared(&cx, &of, &facets, &shared, &objects)?;

    let (point_sources, point_source_groups) = point_sources(&cx, &root, &raw)?;

    let mut distant_sources = Vec::new();
    let df = root.key("distant_sources");
    if raw.distant_sources.len() > MAX_DISTANT_SOURCES {
        return Err(cx.err(
            &df,
            format!(
                "{} distant sources: at most {MAX_DISTANT_SOURCES} (each is evaluated at every shading point; a sky is one [sky] table)",
                raw.distant_sources.len()
            ),
        ));
    }
    for (name, d) in cx.ordered(&df, &raw.distant_sources) {
        distant_sources.push(distant_source(&cx, &df.key(name), name, d)?);
    }

    let sky = match &raw.sky {
        Some(s) => Some(sky(&cx, &root.key("sky"), s)?),
        None => None,
    };

    let light_groups = crate::groups::light_groups(
        &raw,
        &materials,
        &objects,
        &point_source_groups,
        &distant_sources,
        sky.as_ref(),
        &|f, m| cx.err(f, m),
    )?;

    let camera = camera(&cx, &root.key("camera"), &raw.camera)?;

    let bands = bands(&cx, &root, &raw)?;
    let sensor = match &raw.sensor {
        None => None,
        Some(s) => Some(sensor_reference(&cx, &root, s)?),
    };

    Ok(Scene {
        path: path.to_path_buf(),
        units,
        meters_per_unit: units.meters_per_unit(),
        materials,
        facets,
        objects,
        shared,
        point_sources,
        point_source_groups,
        distant_sources,
        light_groups,
        camera,
        bands,
        sky,
        sensor,
    })
}

/// The scene's length unit.
fn units(cx: &Ctx, root: &FieldPath, units: &str) -> R<Units> {
    match units {
        "m" => Ok(Units::Meters),
        "ft" => Ok(Units::Feet),
        other => Err(cx.err(
            &root.key("units"),
            format!("unknown units '{other}': use \"m\" or \"ft\""),
        )),
    }
}

/// Point sources, each placed once or at each of its placements, and the
/// group (name, first, count) each became.
fn point_sources(
    cx: &Ctx,
    root: &FieldPath,
    raw: &RawScene,
) -> R<(Vec<PointSource>, Vec<PointSourceGroup>)> {
    let mut point_sources = Vec::new();
    let mut point_source_groups = Vec::new();
    let pf = root.key("point_sources");
    for (name, p) in cx.ordered(&pf, &raw.point_sources) {
        let first = point_sources.len();
        point_source(cx, &pf.key(name), name, p, &mut point_sources)?;
        point_source_groups.push(PointSourceGroup {
            name: name.to_string(),
            instances: point_sources.len() - first,
            first,
        });
    }
    Ok((point_sources, point_source_groups))
}

/// The scene's bands: at least one.
fn bands(cx: &Ctx, root: &FieldPath, raw: &RawScene) -> R<Vec<Band>> {
    let mut bands = Vec::new();
    let bf = root.key("bands");
    if raw.bands.len() > MAX_BANDS {
        return Err(cx.err(
            &bf,
            format!(
                "{} bands: at most {MAX_BANDS} (each band is a plane of every image and a sum of every pixel)",
                raw.bands.len()
            ),
        ));
    }
    for (name, b) in cx.ordered(&bf, &raw.bands) {
        bands.push(band(cx, &bf.key(name), name, b)?);
    }
    if bands.is_empty() {
        return Err(cx.err(
            &bf,
            "a scene needs at least one band, e.g. [bands.vis] lo_nm = 400, hi_nm = 700",
        ));
    }
    Ok(bands)
}

/// The sensor the scene names: a file next to the scene (by its resolved
/// path) or a preset name, kept as given.
fn sensor_reference(cx: &Ctx, root: &FieldPath, s: &str) -> R<String> {
    if s.trim().is_empty() {
        return Err(cx.err(&root.key("sensor"), "empty sensor reference"));
    }
    let p = cx.resolve(s);
    Ok(if p.is_file() {
        p.to_string_lossy().into_owned()
    } else {
        s.to_string()
    })
}

/// Facet `i`'s object index, placement and prototype facet.
fn origin_of(objects: &[ObjectInfo], i: usize) -> (usize, usize, usize) {
    let k = objects.partition_point(|o| o.first_facet <= i).max(1) - 1;
    let o = &objects[k];
    let local = i - o.first_facet;
    let per = o.prototype_facets.max(1);
    (k, local / per, local % per)
}

/// Refuses two facets on exactly the same vertices (in any order, either
/// side out): a ray cannot tell which of them it hits (the image takes
/// one, light sampling counts both), and every ray that reaches such a
/// stack tests all of it — 10 000 coincident triangles made the cache and
/// the render quadratic (82 s in issue 46). One sort of the facets' vertex
/// sets, O(n log n); the pair reported is the one whose later facet comes
/// first in the file.
/// The two facets on exactly the same vertices whose second index is
/// least (`a < b`), if any: one sort of their vertex bit patterns.
pub(crate) fn first_coincident_pair(facets: &[Facet]) -> Result<Option<(usize, usize)>, String> {
    // Each facet's vertices as bit patterns (-0.0 as 0.0), sorted.
    type Key = ([[u64; 3]; 4], u8);
    let key = |f: &Facet| -> Key {
        let mut k = [[u64::MAX; 3]; 4];
        for (slot, v) in k.iter_mut().zip(&f.vertices) {
            *slot = [v.x, v.y, v.z].map(|c| (c + 0.0).to_bits());
        }
        let n = f.vertices.len().min(4);
        k[..n].sort_unstable();
        (k, n as u8)
    };
    let mut order: Vec<(Key, usize)> = Vec::new();
    order
        .try_reserve_exact(facets.len())
        .map_err(|_| format!("{} facets", facets.len()))?;
    order.extend(facets.iter().enumerate().map(|(i, f)| (key(f), i)));
    order.sort_unstable();
    // Within a run of equal keys the indices ascend: the pair (first,
    // second) of the run whose second index is least.
    let mut worst: Option<(usize, usize)> = None;
    for w in order.windows(2) {
        if w[0].0 == w[1].0 {
            let (a, b) = (w[0].1, w[1].1);
            if worst.is_none_or(|(_, wb)| b < wb) {
                worst = Some((a, b));
            }
        }
    }
    Ok(worst)
}

fn refuse_coincident_facets(
    cx: &Ctx,
    of: &FieldPath,
    facets: &[Facet],
    objects: &[ObjectInfo],
) -> R<()> {
    let Some((a, b)) =
        first_coincident_pair(facets).map_err(|m| cx.err(of, format!("{m}: out of memory")))?
    else {
        return Ok(());
    };
    let describe = |i: usize| {
        let (k, inst, pf) = origin_of(objects, i);
        let o = &objects[k];
        if o.instanced {
            format!("objects.{} facet {pf} of placement {inst}", o.name)
        } else {
            format!("objects.{} facet {pf}", o.name)
        }
    };
    let (kb, _, _) = origin_of(objects, b);
    Err(cx.err(
        &of.key(&objects[kb].name),
        format!(
            "{} lies exactly on {} (the same {} vertices): a ray cannot tell which it hits \
             and light sampling would count both; remove one, or move it apart",
            describe(b),
            describe(a),
            facets[b].vertices.len()
        ),
    ))
}

/// Names one side of a coincident pair: `objects.NAME facet F of placement
/// P` (or without the placement for an object placed once).
pub(crate) fn describe_who(
    objects: &[ObjectInfo],
    shared: &[SharedInstances],
    w: crate::coincide::Who,
) -> (usize, String) {
    match w {
        crate::coincide::Who::Facet(i) => {
            let (k, inst, pf) = origin_of(objects, i);
            let o = &objects[k];
            if o.instanced {
                (
                    k,
                    format!("objects.{} facet {pf} of placement {inst}", o.name),
                )
            } else {
                (k, format!("objects.{} facet {pf}", o.name))
            }
        }
        crate::coincide::Who::Placed {
            shared: s,
            placement,
            facet,
        } => {
            let k = shared[s].object;
            (
                k,
                format!(
                    "objects.{} facet {facet} of placement {placement}",
                    objects[k].name
                ),
            )
        }
    }
}

/// Refuses a shared placement's facet on exactly the vertices of another
/// placement's facet or of an expanded facet, as [`refuse_coincident_facets`]
/// refuses copies ([`crate::coincide`]).
fn refuse_coincident_shared(
    cx: &Ctx,
    of: &FieldPath,
    facets: &[Facet],
    shared: &[SharedInstances],
    objects: &[ObjectInfo],
) -> R<()> {
    let Some((a, b)) = crate::coincide::first_coincident_shared(facets, shared).map_err(|m| {
        let k = shared.first().map_or(0, |s| s.object);
        cx.err(&of.key(&objects[k].name), m)
    })?
    else {
        return Ok(());
    };
    let (_, da) = describe_who(objects, shared, a);
    let (kb, db) = describe_who(objects, shared, b);
    Err(cx.err(
        &of.key(&objects[kb].name),
        format!(
            "{db} lies exactly on {da} (the same vertices): a ray cannot tell which it hits \
             and light sampling would count both; remove one, or move it apart"
        ),
    ))
}

/// What a spectrum is, for messages and range checks.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Reflectance,
    Transmission,
    Radiance,
    Intensity,
    Irradiance,
    Response,
}

impl Kind {
    /// The unit of an emission line's value for emitters, `None` for the
    /// kinds that cannot have lines.
    fn line_unit(self) -> Option<&'static str> {
        match self {
            Kind::Radiance => Some("W m⁻² sr⁻¹"),
            Kind::Intensity => Some("W sr⁻¹"),
            Kind::Irradiance => Some("W m⁻²"),
            Kind::Reflectance | Kind::Transmission | Kind::Response => None,
        }
    }

    fn word(self) -> &'static str {
        match self {
            Kind::Reflectance => "reflectance",
            Kind::Transmission => "transmission",
            Kind::Radiance => "radiance",
            Kind::Intensity => "intensity",
            Kind::Irradiance => "irradiance",
            Kind::Response => "response",
        }
    }
}

/// A built-in name or a CSV path relative to the scene.
fn named_spectrum(cx: &Ctx, field: &FieldPath, name: &str) -> R<Spectrum> {
    if let Some(s) = library::get(name) {
        return Ok(s);
    }
    let p = cx.resolve(name);
    // Anything on disk by that name is read (and a directory or device
    // refused by name), not reported as missing.
    if p.exists() {
        return gloam_spectra::read_csv(&p, cx.reads)
            .map_err(|e| cx.err(field, format!("spectrum file: {e}")));
    }
    Err(cx.err(
        field,
        format!(
            "unknown spectrum '{name}': not a built-in name (see `gloam spectra list`) and no file {}",
            p.display()
        ),
    ))
}

fn flat(cx: &Ctx, field: &FieldPath, v: f64, kind: Kind) -> R<Spectrum> {
    if !v.is_finite() {
        return Err(cx.err(field, format!("{} {v} is not a finite number", kind.word())));
    }
    if v < 0.0 {
        return Err(cx.err(field, format!("negative {} {v} (must be ≥ 0)", kind.word())));
    }
    Spectrum::constant(FLAT_LO_NM, FLAT_HI_NM, v).map_err(|e| cx.err(field, e.to_string()))
}

/// The keys of a spectrum given by parts (a table, an emission, a point
/// source).
struct Parts<'a> {
    spectrum: Option<&'a str>,
    value: Option<f64>,
    lines: Option<&'a [Vec<f64>]>,
    scale: Option<f64>,
    normalize: Option<&'a RawNormalize>,
}

/// Builds a spectrum from its parts: `spectrum` (name/CSV) or `value` (flat)
/// or neither (lines only), plus `lines`, then `scale`, then `normalize`.
fn spectrum_parts(cx: &Ctx, field: &FieldPath, p: Parts, kind: Kind) -> R<Spectrum> {
    let lf = field.key("lines");
    if p.lines.is_some() && kind.line_unit().is_none() {
        return Err(cx.err(
            &lf,
            format!(
                "a {} has no emission lines: `lines` belong to emitters (`emission`, point sources)",
                kind.word()
            ),
        ));
    }
    let has_lines = p.lines.is_some_and(|l| !l.is_empty());
    let mut s = match (p.spectrum, p.value) {
        (Some(name), None) => named_spectrum(cx, &field.key("spectrum"), name)?,
        (None, Some(v)) => flat(cx, &field.key("value"), v, kind)?,
        (Some(_), Some(_)) => {
            return Err(cx.err(
                &field.key("value"),
                "give either `spectrum` (a name or CSV file) or `value` (flat), not both",
            ));
        }
        // Lines alone: a line spectrum with no continuum.
        (None, None) if has_lines => Spectrum::default(),
        (None, None) => {
            let or_lines = if kind.line_unit().is_some() {
                " or `lines` (emission lines only)"
            } else {
                ""
            };
            return Err(cx.err(
                field,
                format!(
                    "missing `spectrum` (a built-in name or CSV file) or `value` (a flat spectrum){or_lines}"
                ),
            ));
        }
    };
    if let (Some(lines), Some(unit)) = (p.lines, kind.line_unit()) {
        s = add_lines(cx, &lf, s, lines, p.spectrum, unit)?;
    }
    let (scale, normalize) = (p.scale, p.normalize);
    if let Some(k) = scale {
        let f = field.key("scale");
        if !(k.is_finite() && k >= 0.0) {
            return Err(cx.err(&f, format!("scale {k} must be a finite number ≥ 0")));
        }
        s = s.scaled(k).map_err(|e| cx.err(&f, e.to_string()))?;
    }
    if let Some(n) = normalize {
        let f = field.key("normalize");
        if !(n.lo_nm.is_finite() && n.hi_nm.is_finite() && n.lo_nm >= 0.0 && n.hi_nm > n.lo_nm) {
            return Err(cx.err(
                &f,
                format!(
                    "band {}–{} nm must have 0 ≤ lo_nm < hi_nm",
                    n.lo_nm, n.hi_nm
                ),
            ));
        }
        if !(n.value.is_finite() && n.value >= 0.0) {
            return Err(cx.err(
                &f.key("value"),
                format!(
                    "normalisation value {} must be a finite number ≥ 0",
                    n.value
                ),
            ));
        }
        s = s
            .normalized_to_band(n.lo_nm, n.hi_nm, n.value)
            .map_err(|e| cx.err(&f, e.to_string()))?;
    }
    if matches!(kind, Kind::Radiance | Kind::Intensity | Kind::Irradiance) {
        // A source so bright that its band integrals (and the radiance they
        // feed) overflow to inf would give a silently wrong image.
        let peak = spectrum_peak(&s);
        if peak.is_nan() || peak > MAX_EMISSION {
            return Err(cx.err(
                field,
                format!(
                    "{} {peak:e} is out of range (at most {MAX_EMISSION:e} per nm; the Sun's surface is ~2e7 W m⁻² sr⁻¹ nm⁻¹)",
                    kind.word()
                ),
            ));
        }
    }
    Ok(s)
}

/// The largest value of a spectrum, continuum or line (NaN when one is).
pub(crate) fn spectrum_peak(s: &Spectrum) -> f64 {
    s.values()
        .iter()
        .chain(s.lines().iter().map(|l| &l.value))
        .fold(
            0.0f64,
            |m, &v| if v.is_nan() { f64::NAN } else { m.max(v.abs()) },
        )
}

/// The largest `I(γ, C) / (I_max cos γ)` a facet of this luminaire can
/// emit (the tracer's [`crate::AreaLuminaire::relative_radiance`], `cos γ`
/// held at its minimum): per interval of the vertical angles that reaches
/// the front hemisphere, the interval's larger candela over the cosine at
/// its far end — an upper bound of the bilinear table over `cos γ`.
fn luminaire_radiance_factor(t: &crate::photometry::Photometry) -> f64 {
    let nv = t.vertical_deg.len();
    if nv == 0 || t.max_candela <= 0.0 {
        return 0.0;
    }
    let planes = t.candela.len() / nv;
    let mut worst = 0.0f64;
    for v in 0..nv {
        if t.vertical_deg[v] > 90.0 {
            break;
        }
        let far = t.vertical_deg[(v + 1).min(nv - 1)].min(90.0);
        let cos = far
            .to_radians()
            .cos()
            .max(crate::AreaLuminaire::MIN_COS_GAMMA);
        for h in 0..planes {
            let row = &t.candela[h * nv..(h + 1) * nv];
            let c = row[v].max(row[(v + 1).min(nv - 1)]);
            worst = worst.max(c / cos);
        }
    }
    worst / t.max_candela
}

/// Holds each measured area luminaire's radiance `I / (A cos γ)` — what
/// the tracer emits — to [`MAX_EMISSION`]: the intensity alone is checked
/// where the file is read, but a small luminous area (written so, or made
/// so by the object's or a placement's scale) multiplies it without bound
/// (1.7e39, infinite f32 pixels, in issue 46). Per object and placement,
/// after units: the peak intensity × the largest TILT factor over its
/// facets × [`luminaire_radiance_factor`] / area in m².
fn check_luminaire_radiance(
    cx: &Ctx,
    of: &FieldPath,
    facets: &[Facet],
    objects: &[ObjectInfo],
    materials: &[Material],
    units: Units,
) -> R<()> {
    let m2 = units.meters_per_unit().powi(2);
    for o in objects {
        let m = &materials[o.material];
        let Some((e, lum)) = m
            .emission
            .as_ref()
            .and_then(|e| Some((e, e.luminaire.as_ref()?)))
        else {
            continue;
        };
        if o.shared || o.prototype_facets == 0 {
            continue;
        }
        let intensity = spectrum_peak(&e.radiance_w_m2_sr_nm);
        let rel = luminaire_radiance_factor(&lum.table);
        for k in 0..o.instances {
            let start = o.first_facet + k * o.prototype_facets;
            let fs = &facets[start..start + o.prototype_facets];
            let area_su: f64 = fs.iter().map(Facet::area).sum();
            let area = area_su * m2;
            let tilt = fs
                .iter()
                .map(|f| lum.tilt_factor(f.normal()))
                .fold(0.0f64, f64::max);
            let radiance = intensity * tilt * rel / area;
            if radiance.is_nan() || radiance > MAX_EMISSION {
                let at = if o.instanced {
                    format!(", placement {k}")
                } else {
                    String::new()
                };
                return Err(cx.err(
                    &of.key(&o.name),
                    format!(
                        "measured luminaire '{}' (material '{}'{at}): radiance up to {radiance:e} W m⁻² sr⁻¹ nm⁻¹ is out of range (at most {MAX_EMISSION:e}): peak intensity {intensity:e} W sr⁻¹ nm⁻¹ × tilt factor {} × {} (largest I/(I_max cos γ), cos γ held ≥ {}) over a luminous area of {area:e} m²; enlarge the object or lower the material's scale",
                        o.name,
                        m.name,
                        num(tilt),
                        num(rel),
                        crate::AreaLuminaire::MIN_COS_GAMMA,
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Most `[bands.NAME]` tables: a camera has a few, a hyperspectral cube
/// a few hundred; the pilot's work grows with their square (2 000 took
/// 28 s to plan a 32 × 24 render in issue 46).
pub const MAX_BANDS: usize = 512;

/// Most `[distant_sources.NAME]` tables: each is evaluated at every
/// shading point, outside the light tree (80 000 took 35 s at 32 × 24 in
/// issue 46; a scene has the Sun, the Moon and a few beams).
pub const MAX_DISTANT_SOURCES: usize = 1000;

/// Largest spectral radiance (W m⁻² sr⁻¹ nm⁻¹) or intensity (W sr⁻¹ nm⁻¹)
/// a source may have, continuum or line.
pub const MAX_EMISSION: f64 = 1e20;

/// Adds the emission lines written as `lines = [[wavelength_nm, value], …]`
/// to `s`, checking each: wavelength finite and > 0, value finite and ≥ 0
/// (in `unit`), and each wavelength given once — in the list and against the
/// lines `s` already has from its `spectrum` (`named`).
fn add_lines(
    cx: &Ctx,
    field: &FieldPath,
    s: Spectrum,
    lines: &[Vec<f64>],
    named: Option<&str>,
    unit: &str,
) -> R<Spectrum> {
    let limit = gloam_spectra::MAX_LINES;
    if lines.len() + s.lines().len() > limit {
        return Err(cx.err(
            field,
            format!(
                "{} emission lines{}: at most {limit} in one spectrum",
                lines.len(),
                match s.lines().len() {
                    0 => String::new(),
                    n => format!(" (and {n} from its spectrum)"),
                }
            ),
        ));
    }
    let mut out: Vec<gloam_spectra::EmissionLine> = Vec::with_capacity(lines.len());
    for (i, entry) in lines.iter().enumerate() {
        let at = field.index(i);
        let &[w, v] = entry.as_slice() else {
            return Err(cx.err(
                &at,
                format!(
                    "an emission line is [wavelength_nm, value], found {} number{}",
                    entry.len(),
                    if entry.len() == 1 { "" } else { "s" }
                ),
            ));
        };
        if !(w.is_finite() && w > 0.0 && w <= MAX_WAVELENGTH_NM) {
            return Err(cx.err(
                &at.index(0),
                format!("emission line wavelength {} nm must be a finite number in (0, {MAX_WAVELENGTH_NM:e}]", num(w)),
            ));
        }
        if !(v.is_finite() && v >= 0.0) {
            return Err(cx.err(
                &at.index(1),
                format!(
                    "emission line value {} {unit} at {w} nm must be a finite number ≥ 0",
                    num(v)
                ),
            ));
        }
        if let Some(k) = out.iter().position(|l| l.wavelength_nm == w) {
            return Err(cx.err(
                &at,
                format!(
                    "a second emission line at {w} nm (the first is {field}[{k}]); give each line once, with the summed value"
                ),
            ));
        }
        if s.lines().iter().any(|l| l.wavelength_nm == w) {
            return Err(cx.err(
                &at,
                format!(
                    "spectrum '{}' already has an emission line at {w} nm; give each line once (change that spectrum's line instead)",
                    named.unwrap_or("(given)")
                ),
            ));
        }
        out.push(gloam_spectra::EmissionLine {
            wavelength_nm: w,
            value: v,
        });
    }
    // Checked above; any remaining refusal is still an error, not a panic.
    s.with_lines(out).map_err(|e| cx.err(field, e.to_string()))
}

fn spectrum(cx: &Ctx, field: &FieldPath, raw: &RawSpectrum, kind: Kind) -> R<Spectrum> {
    match raw {
        RawSpectrum::Flat(v) => flat(cx, field, *v, kind),
        RawSpectrum::Name(n) => named_spectrum(cx, field, n),
        RawSpectrum::Table(t) => spectrum_parts(
            cx,
            field,
            Parts {
                spectrum: t.spectrum.as_deref(),
                value: t.value,
                lines: t.lines.as_deref(),
                scale: t.scale,
                normalize: t.normalize.as_ref(),
            },
            kind,
        ),
    }
}

/// Reflectance and transmission: continuum only, every value within 0..1.
fn check_fraction(cx: &Ctx, field: &FieldPath, s: &Spectrum, kind: Kind) -> R<()> {
    if !s.lines().is_empty() {
        return Err(cx.err(
            field,
            format!(
                "a {} has no emission lines (this spectrum has {}); use a continuum",
                kind.word(),
                s.lines().len()
            ),
        ));
    }
    for (&w, &v) in s.wavelengths_nm().iter().zip(s.values()) {
        if v > 1.0 + 1e-12 {
            return Err(cx.err(field, format!("{} {v} at {w} nm exceeds 1", kind.word())));
        }
    }
    Ok(())
}

fn material(cx: &Ctx, field: &FieldPath, name: &str, m: &RawMaterial) -> R<Material> {
    let ef = field.key("emission");
    let emission = match &m.emission {
        None => None,
        Some(e) if e.photometry.is_some() => Some(measured_emission(cx, &ef, e)?),
        Some(e) => Some(plain_emission(cx, &ef, e)?),
    };
    let rf = field.key("reflectance");
    let reflectance = match &m.reflectance {
        Some(r) => spectrum(cx, &rf, r, Kind::Reflectance)?,
        None if emission.is_some() => Spectrum::constant(FLAT_LO_NM, FLAT_HI_NM, 0.0)
            .map_err(|e| cx.err(&rf, e.to_string()))?,
        None => {
            return Err(cx.err(
                field,
                "missing `reflectance` (a number 0..1, a spectrum name/CSV, or a table)",
            ));
        }
    };
    check_fraction(cx, &rf, &reflectance, Kind::Reflectance)?;
    let sf = field.key("specular_fraction");
    let specular_fraction = m.specular_fraction.unwrap_or(0.0);
    if !(0.0..=1.0).contains(&specular_fraction) {
        return Err(cx.err(
            &sf,
            format!("specular fraction {specular_fraction} must be within 0..1"),
        ));
    }
    let tf = field.key("transmission");
    let transmission = match &m.transmission {
        Some(t) => Some(transmission(cx, &tf, t, &reflectance)?),
        None => None,
    };
    Ok(Material {
        name: name.to_string(),
        reflectance,
        specular_fraction,
        transmission,
        emission,
    })
}

/// A measured luminaire's emission: its photometry file's table and the
/// direction its C0 half-plane faces.
fn measured_emission(cx: &Ctx, f: &FieldPath, e: &RawEmission) -> R<Emission> {
    let (table, intensity, path) = measured(
        cx,
        f,
        Measured {
            photometry: e.photometry.as_deref(),
            shape_exponent: e.shape_exponent.is_some(),
            value: e.value.is_some(),
            normalize: e.normalize.is_some(),
            spectrum: e.spectrum.as_deref(),
            lines: e.lines.as_deref(),
            scale: e.scale,
        },
    )?;
    let cf = f.key("c0_direction");
    let c0_direction = match e.c0_direction {
        Some(v) => cx
            .vec3(&cf, v)?
            .try_normalize()
            .ok_or_else(|| cx.err(&cf, "c0_direction is a zero vector"))?,
        None => DVec3::X,
    };
    Ok(Emission {
        // W sr⁻¹ nm⁻¹ over 1 m²: the tracer divides by the area.
        radiance_w_m2_sr_nm: intensity,
        shape_exponent: 0.0,
        luminaire: Some(crate::AreaLuminaire {
            table: std::sync::Arc::new(table),
            c0_direction,
            c0_given: e.c0_direction.is_some(),
            file: path,
        }),
    })
}

/// An emission given as a radiance spectrum and a shape exponent.
fn plain_emission(cx: &Ctx, f: &FieldPath, e: &RawEmission) -> R<Emission> {
    if e.c0_direction.is_some() {
        return Err(cx.err(
            &f.key("c0_direction"),
            "`c0_direction` orients a measured luminaire: it needs `photometry = \"file.ies\"`",
        ));
    }
    let radiance = spectrum_parts(
        cx,
        f,
        Parts {
            spectrum: e.spectrum.as_deref(),
            value: e.value,
            lines: e.lines.as_deref(),
            scale: e.scale,
            normalize: e.normalize.as_ref(),
        },
        Kind::Radiance,
    )?;
    let m_exp = e.shape_exponent.unwrap_or(0.0);
    if !(m_exp.is_finite() && (0.0..=MAX_SHAPE_EXPONENT).contains(&m_exp)) {
        return Err(cx.err(
            &f.key("shape_exponent"),
            format!(
                "shape exponent {} must be a finite number in [0, {MAX_SHAPE_EXPONENT}]",
                num(m_exp)
            ),
        ));
    }
    Ok(Emission {
        radiance_w_m2_sr_nm: radiance,
        shape_exponent: m_exp,
        luminaire: None,
    })
}

/// A transmission spectrum, a fraction that with the reflectance returns
/// no more light than the surface receives.
fn transmission(cx: &Ctx, tf: &FieldPath, t: &RawSpectrum, reflectance: &Spectrum) -> R<Spectrum> {
    let t = spectrum(cx, tf, t, Kind::Transmission)?;
    check_fraction(cx, tf, &t, Kind::Transmission)?;
    // ρ + τ ≤ 1: both are piecewise linear, so checking at the nodes
    // of both grids is exact.
    let mut grid: Vec<f64> = reflectance
        .wavelengths_nm()
        .iter()
        .chain(t.wavelengths_nm())
        .copied()
        .collect();
    grid.sort_by(f64::total_cmp);
    for w in grid {
        let sum = reflectance.eval(w) + t.eval(w);
        if sum > 1.0 + 1e-9 {
            return Err(cx.err(
                tf,
                format!(
                    "reflectance {} + transmission {} = {sum} at {w} nm exceeds 1 \
                     (a surface cannot return more light than it receives)",
                    reflectance.eval(w),
                    t.eval(w)
                ),
            ));
        }
    }
    Ok(t)
}

/// The object's own `scale`, `rotate_z_deg` and `translate`, or one
/// placement's (the same keys, the same checks).
fn xform(
    cx: &Ctx,
    field: &FieldPath,
    translate: Option<V3>,
    rotate_z_deg: Option<f64>,
    scale: Option<&RawScale>,
) -> R<Xform> {
    let translate = match translate {
        Some(t) => cx.vec3(&field.key("translate"), t)?,
        None => DVec3::ZERO,
    };
    let rot = match rotate_z_deg {
        Some(r) => {
            let f = field.key("rotate_z_deg");
            let r = cx.finite(&f, r)?;
            if !crate::instance::rotation_ok(r) {
                return Err(cx.err(
                    &f,
                    format!(
                        "{} degrees is past the limit of ±{:e} (a turn is 360; reduce the angle)",
                        num(r),
                        crate::instance::MAX_ROTATION_DEG
                    ),
                ));
            }
            r
        }
        None => 0.0,
    };
    let scale = match scale {
        None => DVec3::ONE,
        Some(RawScale::Uniform(s)) => DVec3::splat(*s),
        Some(RawScale::PerAxis(v)) => DVec3::from_array(v.0),
    };
    if !(scale.is_finite() && scale.min_element() > 0.0) {
        return Err(cx.err(
            &field.key("scale"),
            format!("scale {scale} must be finite and > 0 on every axis"),
        ));
    }
    Ok(Xform::new(scale, rot, translate))
}

/// The placements of an object or point source (`instances = […]` or
/// `instances_csv = "…"`), `None` when it is placed once, and the field to
/// blame for their number.
fn placements(
    cx: &Ctx,
    field: &FieldPath,
    inline: Option<&[RawPlacement]>,
    csv: Option<&str>,
) -> R<(Option<Vec<Placement>>, FieldPath)> {
    let inf = field.key("instances");
    let csvf = field.key("instances_csv");
    match (inline, csv) {
        (None, None) => Ok((None, field.clone())),
        (Some(_), Some(_)) => Err(cx.err(
            &csvf,
            "give either `instances` (a list) or `instances_csv` (a file), not both",
        )),
        (Some(list), None) => {
            if list.is_empty() {
                return Err(cx.err(
                    &inf,
                    "no placements: give at least one { translate = [x, y, z], … }, or remove `instances`",
                ));
            }
            if list.len() > MAX_INSTANCES {
                return Err(cx.err(
                    &inf,
                    format!(
                        "{} placements, more than the limit of {MAX_INSTANCES} per object or point source",
                        list.len()
                    ),
                ));
            }
            let mut out = Vec::with_capacity(list.len());
            for (k, p) in list.iter().enumerate() {
                out.push(Placement {
                    xform: xform(
                        cx,
                        &inf.index(k),
                        p.translate,
                        p.rotate_z_deg,
                        p.scale.as_ref(),
                    )?,
                    at: k,
                });
            }
            Ok((Some(out), inf))
        }
        (None, Some(file)) => {
            let p = cx.resolve(file);
            let list = read_placements_csv(&p, MAX_COORDINATE, cx.reads)
                .map_err(|m| cx.err(&csvf, format!("placements file {m}")))?;
            Ok((Some(list), csvf))
        }
    }
}

/// An error about one placement: its entry in `instances = […]`, or the
/// `instances_csv` line naming the file's line.
fn placement_err(cx: &Ctx, pfield: &FieldPath, p: &Placement, msg: String) -> SceneError {
    match pfield.0.last() {
        Some(Seg::Key(k)) if k == "instances_csv" => cx.err(
            pfield,
            format!("placement on line {} of the placements file: {msg}", p.at),
        ),
        _ => cx.err(&pfield.index(p.at), msg),
    }
}

/// Where an object's geometry goes: the scene's facets, or (shared
/// placements) the scene's shared prototypes; `index` is the object's.
struct Built<'a> {
    facets: &'a mut Vec<Facet>,
    shared: &'a mut Vec<SharedInstances>,
    index: usize,
}

/// Appends an object's facets to the scene's: its geometry, read once (the
/// prototype), as it is, once per placement, or (shared) once with its
/// placements' transforms; every size is checked before it is allocated.
fn object(
    cx: &Ctx,
    field: &FieldPath,
    name: &str,
    o: &RawObject,
    materials: &[Material],
    out: Built,
) -> R<ObjectInfo> {
    let Built {
        facets: scene_facets,
        shared: scene_shared,
        index,
    } = out;
    let before = scene_facets.len();
    let material = object_material(cx, field, o, materials)?;
    let own = xform(cx, field, o.translate, o.rotate_z_deg, o.scale.as_ref())?;
    one_kind_of_geometry(cx, field, o)?;

    let (placements, placements_field) = placements(
        cx,
        field,
        o.instances.as_deref(),
        o.instances_csv.as_deref(),
    )?;
    let emits = materials[material].emission.is_some();
    let budget = FacetBudget {
        before,
        shared_before: scene_shared
            .iter()
            .map(SharedInstances::placed_facets)
            .sum(),
        instances: placements.as_ref().map_or(1, Vec::len) as u128,
        placed: placements.is_some(),
        emits,
        instancing: instancing(cx, field, o, placements.is_some(), emits)?,
        bytes_each: facet_bytes(name),
    };

    // An object placed once is built straight into the scene's list; an
    // instanced one into its prototype, then copied per placement.
    let mut prototype: Vec<Facet> = Vec::new();
    let facets = if placements.is_some() {
        &mut prototype
    } else {
        &mut *scene_facets
    };
    let reader = GeometryReader {
        cx,
        field,
        own: &own,
        budget: &budget,
        placements_field: placements.is_some().then_some(&placements_field),
    };
    let mut sink = FacetSink {
        facets,
        material,
        name,
    };
    if o.vertices.is_some() || o.faces.is_some() {
        inline_geometry(&reader, o, &mut sink)?;
    } else if let Some(b) = &o.box_ {
        box_geometry(&reader, b, &mut sink)?;
    } else if let Some(q) = &o.quad {
        quad_geometry(&reader, q, &mut sink)?;
    } else if let Some(file) = &o.obj {
        obj_geometry(&reader, file, &mut sink)?;
    }
    let prototype_facets = sink.facets.len() - if placements.is_some() { 0 } else { before };
    let own_facets = &sink.facets[sink.facets.len() - prototype_facets..];
    refuse_c0_along_normal(cx, field, name, &materials[material], own_facets)?;
    let shared = budget.share(prototype_facets);
    if let Some(placements) = &placements {
        budget.check(cx, prototype_facets, &placements_field)?;
        if shared {
            check_shared(cx, &placements_field, placements, &prototype)?;
            scene_shared.push(SharedInstances {
                object: index,
                placements: placements.iter().map(|p| p.xform.affine()).collect(),
                prototype,
            });
        } else {
            expand(cx, &placements_field, placements, &prototype, scene_facets)?;
        }
    }
    Ok(ObjectInfo {
        name: name.to_string(),
        material,
        prototype_facets,
        instances: placements.as_ref().map_or(1, Vec::len),
        instanced: placements.is_some(),
        shared,
        first_facet: before,
        luminaire_placements: luminaire_placements(&materials[material], placements.as_deref()),
    })
}

/// The object's material, by name among the scene's.
fn object_material(cx: &Ctx, field: &FieldPath, o: &RawObject, materials: &[Material]) -> R<usize> {
    materials
        .iter()
        .position(|m| m.name == o.material)
        .ok_or_else(|| {
            let known: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
            cx.err(
                &field.key("material"),
                format!(
                    "unknown material '{}' (defined: {})",
                    o.material,
                    if known.is_empty() {
                        "none".to_string()
                    } else {
                        known.join(", ")
                    }
                ),
            )
        })
}

/// An object has exactly one kind of geometry.
fn one_kind_of_geometry(cx: &Ctx, field: &FieldPath, o: &RawObject) -> R<()> {
    let kinds = [
        o.vertices.is_some() || o.faces.is_some(),
        o.box_.is_some(),
        o.quad.is_some(),
        o.obj.is_some(),
    ];
    match kinds.iter().filter(|&&k| k).count() {
        1 => Ok(()),
        0 => Err(cx.err(
            field,
            "no geometry: give `vertices` + `faces`, `box`, `quad` or `obj`",
        )),
        _ => Err(cx.err(
            field,
            "more than one kind of geometry: give only one of `vertices` + `faces`, `box`, `quad`, `obj` per object",
        )),
    }
}

/// The object's `instancing`; "shared" needs placements and a material
/// that does not emit (each placement of an emitter is a light).
fn instancing(
    cx: &Ctx,
    field: &FieldPath,
    o: &RawObject,
    placed: bool,
    emits: bool,
) -> R<Instancing> {
    let instancing = match &o.instancing {
        None => Instancing::Auto,
        Some(v) => v
            .parse::<Instancing>()
            .map_err(|m| cx.err(&field.key("instancing"), m))?,
    };
    if instancing == Instancing::Shared {
        if !placed {
            return Err(cx.err(
                &field.key("instancing"),
                "instancing = \"shared\" needs placements: give `instances` or `instances_csv`",
            ));
        }
        if emits {
            return Err(cx.err(
                &field.key("instancing"),
                format!(
                    "material '{}' emits: each placement of an emitter is a light of its own and is expanded; remove instancing = \"shared\"",
                    o.material
                ),
            ));
        }
    }
    Ok(instancing)
}

/// The placed facets of shared instances, this object's added to those
/// placed before, within the per-scene limit.
fn check_shared_budget(
    cx: &Ctx,
    at: &FieldPath,
    shared_before: u64,
    prototype: usize,
    instances: u128,
) -> R<()> {
    let placed = shared_before as u128 + prototype as u128 * instances;
    if placed > MAX_SHARED_FACETS as u128 {
        return Err(cx.err(
            at,
            format!(
                "{instances} placements × {prototype} facets{}: more than the {MAX_SHARED_FACETS} placed facets shared instances may hold per scene",
                if shared_before > 0 {
                    format!(" plus {shared_before} placed before")
                } else {
                    String::new()
                }
            ),
        ));
    }
    Ok(())
}

/// Refuses a measured luminaire whose given `c0_direction` is parallel to
/// one of the object's facet normals (after the object's own transform):
/// its C0 axis has no projection in that facet's plane, and the default
/// (+x, else +y) silently took its place. A placement turns axis and facet
/// together (a similarity), so checking the prototype covers every
/// placement.
fn refuse_c0_along_normal(
    cx: &Ctx,
    field: &FieldPath,
    name: &str,
    material: &Material,
    facets: &[Facet],
) -> R<()> {
    let Some(lum) = (material.emission.as_ref()).and_then(|e| e.luminaire.as_ref()) else {
        return Ok(());
    };
    if !lum.c0_given {
        return Ok(());
    }
    for (i, f) in facets.iter().enumerate() {
        let n = f.normal();
        if perpendicular(lum.c0_direction, n).is_none() {
            let c = lum.c0_direction;
            return Err(cx.err(
                &field.key("material"),
                format!(
                    "object '{name}', facet {i} (normal [{}, {}, {}]): material '{}' has c0_direction [{}, {}, {}] parallel to the facet's normal, so its C0 axis has no direction in the facet's plane; give a c0_direction along the facet",
                    num(n.x),
                    num(n.y),
                    num(n.z),
                    material.name,
                    num(c.x),
                    num(c.y),
                    num(c.z)
                ),
            ));
        }
    }
    Ok(())
}

/// A measured luminaire's C0 axis turns with each placement
/// (`Scene::luminaire_c0`): its transforms are kept, and only its.
fn luminaire_placements(material: &Material, placements: Option<&[Placement]>) -> Vec<Xform> {
    match placements {
        Some(pl)
            if material
                .emission
                .as_ref()
                .is_some_and(|e| e.luminaire.is_some()) =>
        {
            pl.iter().map(|p| p.xform).collect()
        }
        _ => Vec::new(),
    }
}

/// What an object's facets are checked against before they are
/// allocated: the scene's facet limit and memory, and for shared
/// placements the per-scene limit on placed facets.
struct FacetBudget {
    /// Facets in the scene before this object.
    before: usize,
    /// Facets placed by shared instances before this object.
    shared_before: u64,
    /// Placements (1 when the object is placed once).
    instances: u128,
    placed: bool,
    emits: bool,
    instancing: Instancing,
    bytes_each: usize,
}

impl FacetBudget {
    /// Whether `prototype` facets are shared across the placements rather
    /// than copied (decided again on the exact count once it is read).
    fn share(&self, prototype: usize) -> bool {
        self.placed
            && !self.emits
            && match self.instancing {
                Instancing::Shared => true,
                Instancing::Expand => false,
                Instancing::Auto => prototype as u128 * self.instances > SHARE_ABOVE_FACETS as u128,
            }
    }

    /// The facets this object adds (prototype × placements, or the
    /// prototype alone when shared) against the scene's limit and memory.
    fn check(&self, cx: &Ctx, prototype: usize, at: &FieldPath) -> R<()> {
        let instances = self.instances;
        if self.share(prototype) {
            check_shared_budget(cx, at, self.shared_before, prototype, instances)?;
        }
        let copies = if self.share(prototype) { 1 } else { instances };
        check_budget(
            self.before,
            prototype as u128 * copies,
            MAX_FACETS,
            self.bytes_each,
            cx.available_memory(),
            "facets",
        )
        .map_err(|m| {
            let per = if instances > 1 {
                format!("{instances} placements × {prototype} facets: ")
            } else {
                String::new()
            };
            cx.err(at, format!("{per}{m}"))
        })
    }
}

/// What each kind of geometry needs while it is read: the object's own
/// transform and the size check made before anything is allocated.
struct GeometryReader<'a> {
    cx: &'a Ctx<'a>,
    field: &'a FieldPath,
    own: &'a Xform,
    budget: &'a FacetBudget,
    /// The placements' field, when the object has placements.
    placements_field: Option<&'a FieldPath>,
}

impl GeometryReader<'_> {
    /// Checks `prototype` facets of `geometry` against the budget; a limit
    /// is reported at the placements when there are, else at the geometry.
    fn budget(&self, prototype: usize, geometry: &str) -> R<()> {
        let at = match self.placements_field {
            Some(p) => p.clone(),
            None => self.field.key(geometry),
        };
        self.budget.check(self.cx, prototype, &at)
    }
}

/// Where an object's facets go (the scene's list or its prototype), and
/// what each carries.
struct FacetSink<'a> {
    facets: &'a mut Vec<Facet>,
    material: usize,
    name: &'a str,
}

impl FacetSink<'_> {
    /// Adds one facet after checking every vertex, not only the centre or
    /// corner given: a quad's size or a transform can carry a corner past
    /// the limit.
    fn push(&mut self, cx: &Ctx, verts: Vec<DVec3>, at: &FieldPath) -> R<()> {
        if let Some(v) = verts
            .iter()
            .find(|v| !v.is_finite() || v.abs().max_element() > MAX_COORDINATE)
        {
            return Err(cx.err(
                at,
                format!(
                    "a vertex at ({:e}, {:e}, {:e}) is out of range (|x| ≤ {MAX_COORDINATE:e} scene units)",
                    v.x, v.y, v.z
                ),
            ));
        }
        check_facet(&verts).map_err(|e| cx.err(at, e.to_string()))?;
        self.facet(verts);
        Ok(())
    }

    fn facet(&mut self, vertices: Vec<DVec3>) {
        self.facets.push(Facet {
            vertices,
            material: self.material,
            object: self.name.to_string(),
        });
    }
}

/// Inline geometry: `vertices` and `faces` (3 or 4 indices each).
fn inline_geometry(rd: &GeometryReader, o: &RawObject, sink: &mut FacetSink) -> R<()> {
    let cx = rd.cx;
    let vf = rd.field.key("vertices");
    let ff = rd.field.key("faces");
    let (Some(vs), Some(fs)) = (&o.vertices, &o.faces) else {
        return Err(cx.err(
            if o.vertices.is_none() { &ff } else { &vf },
            "inline geometry needs both `vertices` and `faces`",
        ));
    };
    rd.budget(fs.len(), "faces")?;
    let mut pts = Vec::with_capacity(vs.len());
    for (i, v) in vs.iter().enumerate() {
        pts.push(rd.own.point(cx.vec3(&vf.index(i), *v)?));
    }
    if fs.is_empty() {
        return Err(cx.err(&ff, "no faces"));
    }
    for (i, face) in fs.iter().enumerate() {
        let at = ff.index(i);
        if !(face.len() == 3 || face.len() == 4) {
            return Err(cx.err(
                &at,
                format!(
                    "a face has 3 or 4 vertex indices, this one has {}",
                    face.len()
                ),
            ));
        }
        let mut verts = Vec::with_capacity(face.len());
        for &k in face {
            let p = pts.get(k).ok_or_else(|| {
                cx.err(
                    &at,
                    format!(
                        "vertex index {k} is out of range (there are {} vertices, indexed from 0)",
                        pts.len()
                    ),
                )
            })?;
            verts.push(*p);
        }
        sink.push(cx, verts, &at)?;
    }
    Ok(())
}

/// A box: its six faces (outward, or inward for a room), less those
/// `omit` names.
fn box_geometry(rd: &GeometryReader, b: &RawBox, sink: &mut FacetSink) -> R<()> {
    let cx = rd.cx;
    let bf = rd.field.key("box");
    rd.budget(6, "box")?;
    let min = cx.vec3(&bf.key("min"), b.min)?;
    let max = cx.vec3(&bf.key("max"), b.max)?;
    if !(max.cmpgt(min).all()) {
        return Err(cx.err(
            &bf.key("max"),
            format!("box max {max} must exceed min {min} on every axis (zero-volume box)"),
        ));
    }
    const NAMES: [&str; 8] = ["-x", "+x", "-y", "+y", "-z", "+z", "bottom", "top"];
    for (i, s) in b.omit.iter().enumerate() {
        if !NAMES.contains(&s.as_str()) {
            return Err(cx.err(
                &bf.key("omit").index(i),
                format!("unknown box face '{s}' (use -x, +x, -y, +y, -z/bottom, +z/top)"),
            ));
        }
    }
    let omitted = |n: &str| {
        b.omit
            .iter()
            .any(|s| s == n || (s == "bottom" && n == "-z") || (s == "top" && n == "+z"))
    };
    if NAMES[..6].iter().all(|n| omitted(n)) {
        return Err(cx.err(
            &bf.key("omit"),
            "every face of the box is omitted: nothing would be left",
        ));
    }
    for (face, q) in box_faces(min, max, b.inward) {
        if !omitted(face) {
            sink.push(cx, q.iter().map(|&p| rd.own.point(p)).collect(), &bf)?;
        }
    }
    Ok(())
}

/// A quad: centre, normal, size and optional width axis.
fn quad_geometry(rd: &GeometryReader, q: &RawQuad, sink: &mut FacetSink) -> R<()> {
    let cx = rd.cx;
    let qf = rd.field.key("quad");
    rd.budget(1, "quad")?;
    let c = cx.vec3(&qf.key("center"), q.center)?;
    let n = cx.vec3(&qf.key("normal"), q.normal)?;
    let wa = match q.width_axis {
        Some(a) => Some(cx.vec3(&qf.key("width_axis"), a)?),
        None => None,
    };
    let [w, h] = q.size;
    for (i, s) in q.size.iter().enumerate() {
        cx.finite(&qf.key("size").index(i), *s)?;
        if *s <= 0.0 {
            return Err(cx.err(
                &qf.key("size").index(i),
                format!("size {s} must be > 0 (zero area)"),
            ));
        }
    }
    let verts = quad_vertices(c, w, h, n, wa).map_err(|e| cx.err(&qf, e.to_string()))?;
    sink.push(cx, verts.iter().map(|&p| rd.own.point(p)).collect(), &qf)
}

/// An OBJ mesh, read (bounded) and parsed once per object however many
/// placements; its faces are counted and budgeted before the parser
/// allocates for them.
fn obj_geometry(rd: &GeometryReader, file: &str, sink: &mut FacetSink) -> R<()> {
    let cx = rd.cx;
    let at = rd.field.key("obj");
    let p = cx.resolve(file);
    // `..Default::default()` keeps this compiling if tobj's optional
    // `merging`/`reordering` features (more fields) get enabled.
    // Points and lines are kept so that they can be reported: a face
    // with fewer than three vertices is an error, not dropped.
    #[allow(clippy::needless_update)]
    let opts = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        ignore_points: false,
        ignore_lines: false,
        ..Default::default()
    };
    let bytes = gloam_io::read_bounded(&p, gloam_io::MAX_MESH_FILE_BYTES, cx.reads)
        .map_err(|e| cx.err(&at, format!("cannot read OBJ file {}: {e}", p.display())))?;
    // The face lines bound the facets: refuse an oversized mesh (or
    // placement count) before the OBJ parser allocates for it.
    rd.budget(count_obj_faces(&bytes), "obj")?;
    if let Some((k, what)) = obj_line_error(&bytes) {
        return Err(cx.err(&at, format!("OBJ file {}:{k}: {what}", p.display())));
    }
    let (models, _mtl) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &opts, |_| {
        // Materials come from the scene file, not from .mtl files.
        Ok(Default::default())
    })
    .map_err(|e| cx.err(&at, format!("cannot load OBJ file {}: {e}", p.display())))?;
    for model in &models {
        let arities = &model.mesh.face_arities;
        if let Some((k, n)) = arities.iter().enumerate().find(|(_, n)| **n < 3) {
            return Err(cx.err(
                &at,
                format!(
                    "OBJ file {}: object '{}' face {} has {n} vertex(es) (a point or line element); faces need at least 3",
                    p.display(),
                    model.name,
                    k + 1
                ),
            ));
        }
    }
    let faces: usize = models.iter().map(|m| mesh_faces(&m.mesh)).sum();
    if faces == 0 {
        return Err(cx.err(&at, format!("OBJ file {} has no faces", p.display())));
    }
    rd.budget(faces, "obj")?;
    sink.facets.reserve(faces);
    for model in &models {
        obj_model_facets(rd, &at, &p, model, sink)?;
    }
    Ok(())
}

/// The first line (from 1) the OBJ parser would take wrongly or report
/// without its line, and why: a line (`l`) or point (`p`) element, which
/// the parser would turn into a facet, not a surface; a vertex (`v`)
/// whose coordinates are not finite numbers; a face (`f`) whose vertex
/// index is not a number, 0, or refers past the vertices defined so far
/// (1-based, negative from the last). Comments (`#`) end a line. One
/// pass, no allocation per line.
fn obj_line_error(bytes: &[u8]) -> Option<(usize, String)> {
    let mut vertices = 0i64;
    for (k, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = line.split(|&b| b == b'#').next().unwrap_or(line);
        let mut words = line
            .split(|b| b.is_ascii_whitespace())
            .filter(|w| !w.is_empty());
        let what = match words.next() {
            Some(b"l") => Some("a line element (`l`) is not a surface; remove it (only faces, `f`, become facets)".to_string()),
            Some(b"p") => Some("a point element (`p`) is not a surface; remove it (only faces, `f`, become facets)".to_string()),
            Some(b"v") => {
                vertices += 1;
                words.take(3).find_map(|w| {
                    let text = String::from_utf8_lossy(w);
                    match text.parse::<f32>() {
                        Ok(x) if x.is_finite() => None,
                        Ok(_) => Some(format!("vertex {vertices} has the coordinate '{text}', not a finite number (|x| ≤ 3.4e38 in an OBJ's 32-bit floats)")),
                        Err(_) => Some(format!("vertex {vertices} has the coordinate '{text}', not a number")),
                    }
                })
            }
            Some(b"f") => words.find_map(|w| {
                let index = w.split(|&b| b == b'/').next().unwrap_or(w);
                let text = String::from_utf8_lossy(index);
                match text.parse::<i64>() {
                    Err(_) => Some(format!("the face's vertex '{}' is not an index", String::from_utf8_lossy(w))),
                    Ok(0) => Some("a face's vertex index is 0; OBJ counts vertices from 1 (or back from -1)".to_string()),
                    Ok(i) if i.unsigned_abs() > vertices.unsigned_abs() => Some(format!(
                        "the face's vertex index {i} refers past the {vertices} vertices defined before it"
                    )),
                    Ok(_) => None,
                }
            }),
            _ => None,
        };
        if let Some(what) = what {
            return Some((k + 1, what));
        }
    }
    None
}

/// Faces of a parsed OBJ mesh (all triangles when it lists no arities).
fn mesh_faces(mesh: &tobj::Mesh) -> usize {
    if mesh.face_arities.is_empty() {
        mesh.indices.len() / 3
    } else {
        mesh.face_arities.len()
    }
}

/// One OBJ model's faces as facets, each checked as an inline face is and
/// named by file, model and face in an error.
fn obj_model_facets(
    rd: &GeometryReader,
    at: &FieldPath,
    p: &Path,
    model: &tobj::Model,
    sink: &mut FacetSink,
) -> R<()> {
    let cx = rd.cx;
    let mesh = &model.mesh;
    let pos = |k: u32| -> Option<DVec3> {
        let k = k as usize * 3;
        let s = mesh.positions.get(k..k + 3)?;
        Some(DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64))
    };
    let mut start = 0usize;
    for fi in 0..mesh_faces(mesh) {
        let n = mesh.face_arities.get(fi).map_or(3, |&a| a as usize);
        let idx = mesh.indices.get(start..start + n).unwrap_or(&[]);
        start += n;
        // Formatted only for an error: building it for every face
        // cost more than the face itself.
        let what = || format!("{} (model '{}', face {fi})", p.display(), model.name);
        if !(n == 3 || n == 4) {
            return Err(cx.err(
                at,
                format!(
                    "{}: a face has 3 or 4 vertices, this one has {n}; split it",
                    what()
                ),
            ));
        }
        let mut verts = Vec::with_capacity(n);
        for &k in idx {
            let v = pos(k).ok_or_else(|| {
                cx.err(at, format!("{}: vertex index {k} is out of range", what()))
            })?;
            verts.push(rd.own.point(v));
        }
        if let Some(v) = verts
            .iter()
            .find(|v| !v.is_finite() || v.abs().max_element() > MAX_COORDINATE)
        {
            return Err(cx.err(
                at,
                format!(
                    "{}: a vertex at ({:e}, {:e}, {:e}) is out of range (|x| ≤ {MAX_COORDINATE:e} scene units)",
                    what(),
                    v.x,
                    v.y,
                    v.z
                ),
            ));
        }
        check_facet(&verts).map_err(|m| cx.err(at, format!("{}: {m}", what())))?;
        sink.facet(verts);
    }
    Ok(())
}

/// Checks shared placements as [`expand`] checks copies, without making
/// them: every placed vertex within the coordinate limit (through the
/// corners of the prototype's box, which bound them), facets valid under a
/// per-axis or extreme scale (quads, for a per-axis one: an affine map
/// keeps a triangle planar and convex), no facet of the prototype on
/// another, and no two placements the same.
fn check_shared(
    cx: &Ctx,
    pfield: &FieldPath,
    placements: &[Placement],
    prototype: &[Facet],
) -> R<()> {
    let corners = box_corners(bounds(prototype));
    let has_quads = prototype.iter().any(|f| f.vertices.len() > 3);
    let smallest = smallest_facet(prototype);
    for pl in placements {
        let x = pl.xform;
        let shrinks = smallest * x.min_scale() < MIN_FACET_SIZE;
        if let Some(v) = corners
            .iter()
            .map(|&c| x.point(c))
            .find(|v| !v.is_finite() || v.abs().max_element() > MAX_COORDINATE)
        {
            return Err(placement_err(
                cx,
                pfield,
                pl,
                format!(
                    "the placed object reaches ({:e}, {:e}, {:e}), out of range (|x| ≤ {MAX_COORDINATE:e} scene units)",
                    v.x, v.y, v.z
                ),
            ));
        }
        if shrinks || x.scale_is_extreme() || (has_quads && !x.is_similarity()) {
            for (j, f) in prototype.iter().enumerate() {
                let mut placed = [DVec3::ZERO; 4];
                let n = f.vertices.len().min(4);
                for (p, v) in placed.iter_mut().zip(&f.vertices) {
                    *p = x.point(*v);
                }
                if let Err(e) = check_facet(&placed[..n]) {
                    return Err(placement_err(
                        cx,
                        pfield,
                        pl,
                        format!("facet {j} of the prototype: {e}"),
                    ));
                }
            }
        }
    }
    if let Some((a, b)) = first_coincident_pair(prototype).map_err(|m| cx.err(pfield, m))? {
        return Err(cx.err(
            pfield,
            format!(
                "facet {b} of the prototype lies exactly on its facet {a}: a ray cannot tell which it hits; remove one"
            ),
        ));
    }
    let mut keys: Vec<([u64; 12], usize)> = placements
        .iter()
        .enumerate()
        .map(|(k, p)| {
            (
                p.xform
                    .affine()
                    .to_cols_array()
                    .map(|c| (c + 0.0).to_bits()),
                k,
            )
        })
        .collect();
    keys.sort_unstable();
    if let Some(w) = keys.windows(2).find(|w| w[0].0 == w[1].0) {
        let (a, b) = (w[0].1.min(w[1].1), w[0].1.max(w[1].1));
        return Err(placement_err(
            cx,
            pfield,
            &placements[b],
            format!(
                "the same placement as placement {a}: every facet would lie on its twin; remove one"
            ),
        ));
    }
    Ok(())
}

/// The longest edge of the prototype's smallest facet (infinite when it
/// has none).
fn smallest_facet(prototype: &[Facet]) -> f64 {
    prototype
        .iter()
        .map(|f| longest_edge(&f.vertices))
        .fold(f64::INFINITY, f64::min)
}

/// Appends one transformed copy of `prototype` per placement (in placement
/// order).
fn expand(
    cx: &Ctx,
    pfield: &FieldPath,
    placements: &[Placement],
    prototype: &[Facet],
    facets: &mut Vec<Facet>,
) -> R<()> {
    facets.reserve(prototype.len() * placements.len());
    let smallest = smallest_facet(prototype);
    for pl in placements {
        let x = pl.xform;
        // A scale that shrinks a facet below the smallest a scene holds
        // is checked too (a 1e-80 quad placed at 1e-6 was taken, the
        // same scale on the object refused).
        let check =
            !x.is_similarity() || x.scale_is_extreme() || smallest * x.min_scale() < MIN_FACET_SIZE;
        for (j, f) in prototype.iter().enumerate() {
            let verts: Vec<DVec3> = f.vertices.iter().map(|&p| x.point(p)).collect();
            // The scene's coordinate limit holds after the transform, as
            // before it. A similarity of moderate scale keeps a valid facet
            // valid (planar, convex, of non-zero area); a per-axis scale,
            // or one so large or small that areas may overflow or vanish,
            // is checked facet by facet.
            let bad = if !verts.iter().all(|v| v.is_finite()) {
                Some("a vertex is not finite after the transform".to_string())
            } else if let Some(v) = verts
                .iter()
                .find(|v| v.abs().max_element() > MAX_COORDINATE)
            {
                Some(format!(
                    "a vertex at ({:e}, {:e}, {:e}) after the transform is out of range (|x| ≤ {MAX_COORDINATE:e} scene units)",
                    v.x, v.y, v.z
                ))
            } else if check {
                check_facet(&verts).err().map(|e| e.to_string())
            } else {
                None
            };
            if let Some(m) = bad {
                return Err(placement_err(
                    cx,
                    pfield,
                    pl,
                    format!("facet {j} of the prototype: {m}"),
                ));
            }
            facets.push(Facet {
                vertices: verts,
                material: f.material,
                object: f.object.clone(),
            });
        }
    }
    Ok(())
}

/// Appends a point source, or one per placement: position and direction
/// transformed like an object's geometry, intensity unchanged.
fn point_source(
    cx: &Ctx,
    field: &FieldPath,
    name: &str,
    p: &RawPointSource,
    out: &mut Vec<PointSource>,
) -> R<()> {
    let proto = point_source_prototype(cx, field, name, p)?;
    let (placements, pfield) = placements(
        cx,
        field,
        p.instances.as_deref(),
        p.instances_csv.as_deref(),
    )?;
    let Some(placements) = placements else {
        check_budget(out.len(), 1, MAX_POINT_SOURCES, 0, None, "point sources")
            .map_err(|e| cx.err(field, e.to_string()))?;
        out.push(tilted(cx, field, proto)?);
        return Ok(());
    };
    let s = &proto.intensity_w_sr_nm;
    let bytes_each = std::mem::size_of::<PointSource>()
        + 16 * s.values().len()
        + std::mem::size_of_val(s.lines())
        + name.len()
        + 64;
    check_budget(
        out.len(),
        placements.len() as u128,
        MAX_POINT_SOURCES,
        bytes_each,
        cx.available_memory(),
        "point sources",
    )
    .map_err(|m| cx.err(&pfield, format!("{} placements: {m}", placements.len())))?;
    out.reserve_exact(placements.len());
    for pl in &placements {
        let position = pl.xform.point(proto.position);
        let direction = pl.xform.direction(proto.direction).normalize_or_zero();
        if !(position.is_finite() && direction.is_finite() && direction != DVec3::ZERO) {
            let msg = format!("point source '{name}' is not finite after the transform");
            return Err(placement_err(cx, &pfield, pl, msg));
        }
        if position.abs().max_element() > MAX_COORDINATE {
            let msg = format!(
                "point source '{name}' at ({:e}, {:e}, {:e}) after the transform is out of range (|x| ≤ {MAX_COORDINATE:e} scene units)",
                position.x, position.y, position.z
            );
            return Err(placement_err(cx, &pfield, pl, msg));
        }
        let luminaire = match &proto.luminaire {
            Some(l) => {
                let c0 = perpendicular(pl.xform.direction(l.c0), direction).ok_or_else(|| {
                    let msg = format!(
                        "point source '{name}': c0_direction is parallel to direction after the transform"
                    );
                    placement_err(cx, &pfield, pl, msg)
                })?;
                Some(Luminaire { c0, ..l.clone() })
            }
            None => None,
        };
        let placed = PointSource {
            position,
            direction,
            luminaire,
            ..proto.clone()
        };
        out.push(tilted(cx, field, placed)?);
    }
    Ok(())
}

/// `v` made perpendicular to unit `d` and normalised (`None` when `v` is
/// parallel to `d` or not finite).
pub(crate) fn perpendicular(v: DVec3, d: DVec3) -> Option<DVec3> {
    (v - v.dot(d) * d)
        .try_normalize()
        .filter(|u| u.is_finite() && u.dot(d).abs() < 1e-9)
}

/// Applies a TILT=INCLUDE table: the whole distribution times the factor
/// at the angle between the luminaire's nadir and straight down (−z).
fn tilted(cx: &Ctx, field: &FieldPath, mut p: PointSource) -> R<PointSource> {
    let Some(tilt) = p.luminaire.as_ref().and_then(|l| l.table.tilt.as_ref()) else {
        return Ok(p);
    };
    let k = tilt.factor_for_nadir(p.direction);
    let pf = field.key("photometry");
    p.intensity_w_sr_nm = p
        .intensity_w_sr_nm
        .scaled(k)
        .map_err(|e| cx.err(&pf, format!("tilt factor {}: {e}", num(k))))?;
    // The file's intensity was held to the limit before this factor (up
    // to ×10): hold the tilted one too.
    let peak = spectrum_peak(&p.intensity_w_sr_nm);
    if peak.is_nan() || peak > MAX_EMISSION {
        return Err(cx.err(
            &pf,
            format!(
                "intensity {peak:e} W sr⁻¹ nm⁻¹ after the file's TILT factor {} (at this placement's direction) is out of range (at most {MAX_EMISSION:e}); lower scale",
                num(k)
            ),
        ));
    }
    Ok(p)
}

/// A `[distant_sources.NAME]` table: its direction of travel, normalised,
/// and its irradiance normal to the beam (parts as a point source's).
fn distant_source(
    cx: &Ctx,
    field: &FieldPath,
    name: &str,
    d: &RawDistantSource,
) -> R<DistantSource> {
    let df = field.key("direction");
    let direction = unit(cx.vec3(&df, d.direction)?)
        .ok_or_else(|| cx.err(&df, "direction is a zero vector"))?;
    let irradiance = spectrum_parts(
        cx,
        field,
        Parts {
            spectrum: d.spectrum.as_deref(),
            value: d.value,
            lines: d.lines.as_deref(),
            scale: d.scale,
            normalize: d.normalize.as_ref(),
        },
        Kind::Irradiance,
    )?;
    Ok(DistantSource {
        name: name.to_string(),
        direction,
        irradiance_w_m2_nm: irradiance,
    })
}

/// `v` as a unit vector, scaled by its largest component first so that
/// components too small to square (1e-320) still give their direction;
/// `None` for the zero vector.
fn unit(v: DVec3) -> Option<DVec3> {
    let m = v.abs().max_element();
    (m > 0.0 && m.is_finite())
        .then(|| (v / m).try_normalize())
        .flatten()
}

fn point_source_prototype(
    cx: &Ctx,
    field: &FieldPath,
    name: &str,
    p: &RawPointSource,
) -> R<PointSource> {
    let position = cx.vec3(&field.key("position"), p.position)?;
    let df = field.key("direction");
    let direction = match p.direction {
        Some(d) => {
            unit(cx.vec3(&df, d)?).ok_or_else(|| cx.err(&df, "direction is a zero vector"))?
        }
        None => DVec3::NEG_Z,
    };
    if p.photometry.is_some() {
        return luminaire_prototype(cx, field, name, p, position, direction);
    }
    if p.c0_direction.is_some() {
        return Err(cx.err(
            &field.key("c0_direction"),
            "`c0_direction` orients a measured luminaire: it needs `photometry = \"file.ies\"`",
        ));
    }
    let m = p.shape_exponent.unwrap_or(0.0);
    if !(m.is_finite() && (0.0..=MAX_SHAPE_EXPONENT).contains(&m)) {
        return Err(cx.err(
            &field.key("shape_exponent"),
            format!(
                "shape exponent {} must be a finite number in [0, {MAX_SHAPE_EXPONENT}]",
                num(m)
            ),
        ));
    }
    let intensity = spectrum_parts(
        cx,
        field,
        Parts {
            spectrum: p.spectrum.as_deref(),
            value: p.value,
            lines: p.lines.as_deref(),
            scale: p.scale,
            normalize: p.normalize.as_ref(),
        },
        Kind::Intensity,
    )?;
    Ok(PointSource {
        name: name.to_string(),
        position,
        direction,
        shape_exponent: m,
        intensity_w_sr_nm: intensity,
        luminaire: None,
    })
}

/// A point source with `photometry = "file"`: the file gives the
/// distribution in candela, `spectrum`/`lines` the spectral shape, scaled
/// so the luminous intensity toward the brightest direction is the file's
/// largest candela value (× `scale`).
fn luminaire_prototype(
    cx: &Ctx,
    field: &FieldPath,
    name: &str,
    p: &RawPointSource,
    position: DVec3,
    direction: DVec3,
) -> R<PointSource> {
    let (table, intensity, path) = measured(
        cx,
        field,
        Measured {
            photometry: p.photometry.as_deref(),
            shape_exponent: p.shape_exponent.is_some(),
            value: p.value.is_some(),
            normalize: p.normalize.is_some(),
            spectrum: p.spectrum.as_deref(),
            lines: p.lines.as_deref(),
            scale: p.scale,
        },
    )?;
    let cf = field.key("c0_direction");
    let c0 = match p.c0_direction {
        Some(v) => perpendicular(cx.vec3(&cf, v)?, direction)
            .ok_or_else(|| cx.err(&cf, "c0_direction is parallel to direction (or zero)"))?,
        None => perpendicular(DVec3::X, direction)
            .or_else(|| perpendicular(DVec3::Y, direction))
            .unwrap_or(DVec3::X),
    };
    Ok(PointSource {
        name: name.to_string(),
        position,
        direction,
        shape_exponent: 0.0,
        intensity_w_sr_nm: intensity,
        luminaire: Some(Luminaire {
            table: std::sync::Arc::new(table),
            c0,
            file: path,
        }),
    })
}

/// The keys of a source given by a photometric file.
struct Measured<'a> {
    photometry: Option<&'a str>,
    shape_exponent: bool,
    value: bool,
    normalize: bool,
    spectrum: Option<&'a str>,
    lines: Option<&'a [Vec<f64>]>,
    scale: Option<f64>,
}

/// Reads a photometric file and scales the spectral shape so its luminous
/// intensity (683·∫V·S dλ) is the file's largest candela value × `scale`:
/// the table, that spectral intensity (W sr⁻¹ nm⁻¹), and the resolved path.
/// Shared by point sources and emitting materials.
fn measured(
    cx: &Ctx,
    field: &FieldPath,
    m: Measured,
) -> R<(crate::photometry::Photometry, Spectrum, std::path::PathBuf)> {
    let pf = field.key("photometry");
    let excluded = [
        (
            m.shape_exponent,
            "shape_exponent",
            "the file gives the distribution",
        ),
        (
            m.value,
            "value",
            "the file gives the magnitude; give the spectral shape with `spectrum` (a name or CSV) and/or `lines`",
        ),
        (
            m.normalize,
            "normalize",
            "the file gives the magnitude (use `scale` to dim it)",
        ),
    ];
    for (given, key, why) in excluded {
        if given {
            return Err(cx.err(
                &field.key(key),
                format!("`{key}` and `photometry` exclude each other: {why}"),
            ));
        }
    }
    if m.spectrum.is_none() && m.lines.is_none_or(|l| l.is_empty()) {
        return Err(cx.err(
            field,
            "a measured luminaire needs its spectral shape: `spectrum` (a built-in name or CSV file) and/or `lines`",
        ));
    }
    let Some(file) = m.photometry else {
        return Err(cx.err(&pf, "missing file name"));
    };
    let path = cx.resolve(file);
    let table = crate::photometry::Photometry::read(&path, cx.reads)
        .map_err(|e| cx.err(&pf, format!("photometry file: {e}")))?;
    let shape = spectrum_parts(
        cx,
        field,
        Parts {
            spectrum: m.spectrum,
            value: None,
            lines: m.lines,
            scale: None,
            normalize: None,
        },
        Kind::Intensity,
    )?;
    let cd_per_unit = gloam_spectra::photopic(&shape);
    if !(cd_per_unit.is_finite() && cd_per_unit > 0.0) {
        return Err(cx.err(
            field,
            format!(
                "the spectrum has no luminous content (683·∫V·S dλ = {}): it cannot carry the file's candela",
                num(cd_per_unit)
            ),
        ));
    }
    let scale = match m.scale {
        Some(k) if !(k.is_finite() && k >= 0.0) => {
            return Err(cx.err(
                &field.key("scale"),
                format!("scale {k} must be a finite number ≥ 0"),
            ));
        }
        Some(k) => k,
        None => 1.0,
    };
    let intensity = shape
        .scaled(table.max_candela * scale / cd_per_unit)
        .map_err(|e| cx.err(&pf, e.to_string()))?;
    let peak = spectrum_peak(&intensity);
    if peak.is_nan() || peak > MAX_EMISSION {
        return Err(cx.err(
            &pf,
            format!("intensity {peak:e} W sr⁻¹ nm⁻¹ is out of range (at most {MAX_EMISSION:e})"),
        ));
    }
    Ok((table, intensity, path))
}

fn camera(cx: &Ctx, field: &FieldPath, c: &RawCamera) -> R<Camera> {
    let position = cx.vec3(&field.key("position"), c.position)?;
    let look_at = cx.vec3(&field.key("look_at"), c.look_at)?;
    let up = match c.up {
        Some(u) => cx.vec3(&field.key("up"), u)?,
        None => DVec3::Z,
    };
    let view = look_at - position;
    if view.length() == 0.0 {
        return Err(cx.err(&field.key("look_at"), "look_at equals the camera position"));
    }
    if view.normalize().cross(up).length() < 1e-9 {
        return Err(cx.err(
            &field.key("up"),
            format!(
                "up [{}, {}, {}] is zero or parallel to the view direction",
                num(up.x),
                num(up.y),
                num(up.z)
            ),
        ));
    }
    let fov = cx.finite(&field.key("fov_deg"), c.fov_deg)?;
    if !(MIN_FOV_DEG..180.0).contains(&fov) {
        return Err(cx.err(
            &field.key("fov_deg"),
            format!(
                "horizontal field of view {}° must be within [{MIN_FOV_DEG}, 180)",
                num(fov)
            ),
        ));
    }
    for (k, v) in [("width", c.width), ("height", c.height)] {
        if v == 0 {
            return Err(cx.err(&field.key(k), format!("{k} must be at least 1 pixel")));
        }
    }
    Ok(Camera {
        position,
        look_at,
        up,
        fov_deg: fov,
        width: c.width,
        height: c.height,
    })
}

fn band(cx: &Ctx, field: &FieldPath, name: &str, b: &RawBand) -> R<Band> {
    let check_edges = |lo: f64, hi: f64| -> R<()> {
        if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo) {
            // Name the edge at fault: lo_nm when it alone is out of range.
            let at = if !(lo.is_finite() && lo >= 0.0) {
                "lo_nm"
            } else {
                "hi_nm"
            };
            return Err(cx.err(
                &field.key(at),
                format!("band {lo}–{hi} nm must have 0 ≤ lo_nm < hi_nm"),
            ));
        }
        Ok(())
    };
    let rect = |lo: f64, hi: f64| {
        Spectrum::constant(lo, hi, 1.0).map_err(|e| cx.err(field, e.to_string()))
    };
    match (&b.response, b.lo_nm, b.hi_nm) {
        (None, Some(lo), Some(hi)) => {
            check_edges(lo, hi)?;
            Ok(Band {
                name: name.to_string(),
                response: rect(lo, hi)?,
                lo_nm: lo,
                hi_nm: hi,
            })
        }
        (None, _, _) => Err(cx.err(
            field,
            "a band needs `lo_nm` and `hi_nm` (rectangular) or a `response` spectrum",
        )),
        (Some(r), lo, hi) => {
            let rf = field.key("response");
            let s = spectrum(cx, &rf, r, Kind::Response)?;
            let (slo, shi) = s
                .support_nm()
                .ok_or_else(|| cx.err(&rf, "the response spectrum is empty"))?;
            let (lo, hi) = (lo.unwrap_or(slo), hi.unwrap_or(shi));
            check_edges(lo, hi)?;
            let s = if lo > slo || hi < shi {
                s.product(&rect(lo, hi)?)
            } else {
                s
            };
            if s.integral() <= 0.0 {
                return Err(cx.err(&rf, format!("the response is zero over {lo}–{hi} nm")));
            }
            Ok(Band {
                name: name.to_string(),
                response: s,
                lo_nm: lo,
                hi_nm: hi,
            })
        }
    }
}

/// Why a `sky.utc` text is not a UTC date-time; each names the text.
#[derive(Debug, thiserror::Error)]
enum UtcError {
    #[error("'{text}' is not an ISO-8601 date-time such as 2024-03-14T22:30:00Z")]
    Shape { text: String },
    #[error("'{text}': seconds must have two digits")]
    Seconds { text: String },
    #[error("'{text}': the time must be UTC (end with Z or nothing), not '{rest}'")]
    NotUtc { text: String, rest: String },
    #[error("'{text}': {source}")]
    Calendar {
        text: String,
        source: gloam_sky::SkyError,
    },
}

/// Accepts `YYYY-MM-DDTHH:MM[:SS[.fff]]` with an optional `Z` or `+00:00`
/// (or a space for `T`).
fn iso8601_utc(s: &str) -> Result<gloam_sky::UtcInstant, UtcError> {
    let b = s.as_bytes();
    let digits = |r: std::ops::Range<usize>| {
        b.get(r.clone())
            .is_some_and(|x| x.iter().all(u8::is_ascii_digit))
    };
    let shape = digits(0..4)
        && b.get(4) == Some(&b'-')
        && digits(5..7)
        && b.get(7) == Some(&b'-')
        && digits(8..10)
        && matches!(b.get(10), Some(b'T' | b't' | b' '))
        && digits(11..13)
        && b.get(13) == Some(&b':')
        && digits(14..16);
    let text = || s.to_string();
    if !shape {
        return Err(UtcError::Shape { text: text() });
    }
    let mut rest = &s[16..];
    if let Some(r) = rest.strip_prefix(':') {
        let sec_len = r
            .bytes()
            .take_while(|c| c.is_ascii_digit() || *c == b'.')
            .count();
        if sec_len < 2 {
            return Err(UtcError::Seconds { text: text() });
        }
        rest = &r[sec_len..];
    }
    if !matches!(rest, "" | "Z" | "z" | "+00:00" | "-00:00") {
        return Err(UtcError::NotUtc {
            text: text(),
            rest: rest.to_string(),
        });
    }
    // The calendar (month lengths, leap years, ranges) is the sky crate's
    // parser's, the one the render uses: an impossible date fails here,
    // with the file and line, rather than at render time.
    gloam_sky::UtcInstant::parse_iso8601(s).map_err(|source| UtcError::Calendar {
        text: text(),
        source,
    })
}

fn sky(cx: &Ctx, field: &FieldPath, s: &RawSky) -> R<SkyConfig> {
    let uf = field.key("utc");
    let utc = match &s.utc {
        toml::Value::String(x) => x.clone(),
        toml::Value::Datetime(d) => d.to_string(),
        other => {
            return Err(cx.err(
                &uf,
                format!(
                    "expected an ISO-8601 UTC date-time, found a {}",
                    other.type_str()
                ),
            ));
        }
    };
    let instant = iso8601_utc(&utc).map_err(|e| cx.err(&uf, e.to_string()))?;
    let lat = cx.finite(&field.key("latitude_deg"), s.latitude_deg)?;
    if !(-90.0..=90.0).contains(&lat) {
        return Err(cx.err(
            &field.key("latitude_deg"),
            format!("latitude {lat}° must be within -90..90"),
        ));
    }
    let lon = cx.finite(&field.key("longitude_deg"), s.longitude_deg)?;
    if !(-180.0..=360.0).contains(&lon) {
        return Err(cx.err(
            &field.key("longitude_deg"),
            format!("longitude {lon}° must be within -180..360 (east positive)"),
        ));
    }
    let height_m = cx.finite(&field.key("height_m"), s.height_m.unwrap_or(0.0))?;
    let vis = cx.finite(&field.key("visibility_km"), s.visibility_km.unwrap_or(23.0))?;
    if vis <= 0.0 {
        return Err(cx.err(
            &field.key("visibility_km"),
            format!("visibility {vis} km must be > 0"),
        ));
    }
    Ok(SkyConfig {
        utc,
        instant,
        latitude_deg: lat,
        longitude_deg: lon,
        height_m,
        visibility_km: vis,
        moon: s.moon.unwrap_or(true),
        night_sky: s.night_sky.unwrap_or(true),
        overcast: s.overcast.unwrap_or(false),
    })
}
