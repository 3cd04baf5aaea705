#![doc = include_str!("../README.md")]

use std::path::{Path, PathBuf};

use glam::DVec3;
pub use gloam_spectra::Spectrum;

mod build;
mod coincide;
mod error;
mod geometry;
mod groups;
mod instance;
pub mod photometry;
pub mod plan;
mod raw;
pub mod sequence;

pub use build::{MAX_BANDS, MAX_COORDINATE, MAX_DISTANT_SOURCES};
pub use error::SceneError;
pub use geometry::{FacetError, MIN_FACET_SIZE, PLANARITY_TOLERANCE, check_facet};
pub use groups::{LightGroup, LightGroups, MOON_GROUP, SKY_GROUP, SUN_GROUP, TWILIGHT_GROUP};
pub use instance::{
    Instancing, MAX_FACETS, MAX_INSTANCES, MAX_POINT_SOURCES, MAX_ROTATION_DEG, MAX_SHARED_FACETS,
    PLACEMENTS_CSV_HEADER, SHARE_ABOVE_FACETS, SharedInstances, address_space_unreserved,
    available_memory, available_memory_bytes, box_corners, heap_chunk,
};

/// Reads and validates a scene file. Relative paths inside it (CSV spectra,
/// OBJ files, sensor files) are resolved against the scene file's directory.
/// `reads` notes the scene file and every file it leads to.
pub fn load(path: &Path, reads: &gloam_io::ReadLog) -> Result<Scene, SceneError> {
    let text =
        gloam_io::read_text(path, gloam_io::MAX_TEXT_FILE_BYTES, reads).map_err(|source| {
            SceneError::Io {
                path: path.to_path_buf(),
                what: "scene",
                source,
            }
        })?;
    parse_str_noting(&text, path, reads)
}

/// Parses and validates scene text; `path` names the file in errors and is
/// the base for relative paths (it need not exist).
pub fn parse_str(text: &str, path: &Path) -> Result<Scene, SceneError> {
    parse_str_noting(text, path, &gloam_io::ReadLog::off())
}

/// [`parse_str`], noting the files the scene names (spectra, OBJ,
/// placements, photometry) in `reads`.
pub fn parse_str_noting(
    text: &str,
    path: &Path,
    reads: &gloam_io::ReadLog,
) -> Result<Scene, SceneError> {
    build::build(text, path, reads)
}

/// Length unit of a scene's geometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Units {
    Meters,
    Feet,
}

impl Units {
    /// Metres per scene unit (exactly 0.3048 for feet).
    pub fn meters_per_unit(self) -> f64 {
        match self {
            Units::Meters => 1.0,
            Units::Feet => 0.3048,
        }
    }

    /// The spelling used in scene files: `m` or `ft`.
    pub fn as_str(self) -> &'static str {
        match self {
            Units::Meters => "m",
            Units::Feet => "ft",
        }
    }
}

/// A validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene file (as given to [`load`]/[`parse_str`]).
    pub path: PathBuf,
    pub units: Units,
    /// Metres per scene unit: multiply lengths by this, areas by its square.
    pub meters_per_unit: f64,
    /// Materials in file order; [`Facet::material`] indexes this.
    pub materials: Vec<Material>,
    /// Every facet of every object, in file order; an instanced object's
    /// facets are its prototype's, once per placement, in placement order
    /// (see [`Scene::objects`] and [`Scene::facet_origin`]).
    pub facets: Vec<Facet>,
    /// The `[objects.NAME]` tables in file order, each with the range of
    /// [`Scene::facets`] it produced.
    pub objects: Vec<ObjectInfo>,
    /// The instanced objects kept as one prototype and its placements
    /// (`instancing = "shared"`, or `"auto"` above [`SHARE_ABOVE_FACETS`]
    /// placed facets): their facets are not in [`Scene::facets`], so a
    /// placement costs a transform, not a copy.
    pub shared: Vec<SharedInstances>,
    /// Every point source, placements expanded, in file order.
    pub point_sources: Vec<PointSource>,
    /// The `[point_sources.NAME]` tables in file order, each with the range
    /// of [`Scene::point_sources`] it produced.
    pub point_source_groups: Vec<PointSourceGroup>,
    /// The `[distant_sources.NAME]` tables in file order.
    pub distant_sources: Vec<DistantSource>,
    /// Light groups (`--layers`) and each source table's group.
    pub light_groups: LightGroups,
    pub camera: Camera,
    /// Bands in file order (at least one).
    pub bands: Vec<Band>,
    pub sky: Option<SkyConfig>,
    /// A sensor preset name, or a path (resolved against the scene's
    /// directory when it names an existing file).
    pub sensor: Option<String>,
}

impl Scene {
    /// The material of a facet.
    pub fn material_of(&self, facet: &Facet) -> &Material {
        &self.materials[facet.material]
    }

    /// The material called `name`, with its index.
    pub fn material_by_name(&self, name: &str) -> Option<(usize, &Material)> {
        self.materials
            .iter()
            .enumerate()
            .find(|(_, m)| m.name == name)
    }

    /// Indices of the facets whose material emits (the area sources).
    pub fn emitting_facets(&self) -> Vec<usize> {
        self.facets
            .iter()
            .enumerate()
            .filter(|(_, f)| self.materials[f.material].emission.is_some())
            .map(|(i, _)| i)
            .collect()
    }

    /// The band called `name`.
    pub fn band(&self, name: &str) -> Option<&Band> {
        self.bands.iter().find(|b| b.name == name)
    }

    /// The directory relative paths in the scene are resolved against.
    pub fn base_dir(&self) -> &Path {
        base_dir(&self.path)
    }

    /// Which object, placement and prototype facet facet `i` came from
    /// (`None` when `i` is out of range). O(log objects), no per-facet
    /// storage.
    pub fn facet_origin(&self, i: usize) -> Option<FacetOrigin> {
        // A shared object holds no facets of the list: the one whose range
        // holds `i` is the last unshared one starting at or before it.
        let last = self.objects.partition_point(|o| o.first_facet <= i);
        let k = self.objects[..last].iter().rposition(|o| !o.shared)?;
        let o = &self.objects[k];
        let local = i - o.first_facet;
        if local >= o.prototype_facets * o.instances || o.prototype_facets == 0 {
            return None;
        }
        Some(FacetOrigin {
            object: k,
            instance: local / o.prototype_facets,
            prototype_facet: local % o.prototype_facets,
        })
    }

    /// The C0 axis (unit, in the facet's plane) of facet `i` when its
    /// material is a measured luminaire, `None` otherwise. The material's
    /// `c0_direction` is in the scene's frame (an object's own
    /// `rotate_z_deg` does not turn it); each placement turns it with the
    /// geometry, as a point source's: projected into the prototype facet's
    /// plane ([`AreaLuminaire::c0_for`]), carried by the placement's
    /// scale and rotation, projected into the placed facet's plane.
    pub fn luminaire_c0(&self, i: usize) -> Option<DVec3> {
        let f = self.facets.get(i)?;
        let lum = self.materials[f.material]
            .emission
            .as_ref()?
            .luminaire
            .as_ref()?;
        let n = f.normal();
        let placed = self.facet_origin(i).and_then(|o| {
            let x = self.objects[o.object]
                .luminaire_placements
                .get(o.instance)?;
            let n_proto = x.normal_back(n).try_normalize()?;
            build::perpendicular(x.direction(lum.c0_for(n_proto)), n)
        });
        Some(placed.unwrap_or_else(|| lum.c0_for(n)))
    }

    /// Which `[point_sources.NAME]` table (index into
    /// [`Scene::point_source_groups`]) and which of its placements point
    /// source `i` came from.
    pub fn point_source_origin(&self, i: usize) -> Option<(usize, usize)> {
        let k = self.point_source_groups.partition_point(|g| g.first <= i);
        let g = self.point_source_groups.get(k.checked_sub(1)?)?;
        (i - g.first < g.instances).then_some((k - 1, i - g.first))
    }

    /// How much the file describes and how much instancing made of it.
    pub fn counts(&self) -> SceneCounts {
        SceneCounts {
            objects: self.objects.len(),
            instanced_objects: self.objects.iter().filter(|o| o.instanced).count(),
            instances: self.objects.iter().map(|o| o.instances).sum(),
            prototype_facets: self.objects.iter().map(|o| o.prototype_facets).sum(),
            facets: self.facets.len(),
            shared_facets: self.shared.iter().map(SharedInstances::placed_facets).sum(),
            point_source_prototypes: self.point_source_groups.len(),
            point_sources: self.point_sources.len(),
        }
    }
}

/// One `[objects.NAME]` table and the facets it produced: its prototype
/// (the geometry as written, with the object's own transform) once per
/// placement, `prototype_facets × instances` facets from `first_facet` on.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectInfo {
    pub name: String,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// Facets of one copy.
    pub prototype_facets: usize,
    /// Placements: 1 for an object without `instances`/`instances_csv`.
    pub instances: usize,
    /// True when the object has `instances` or `instances_csv` (even with
    /// a single placement).
    pub instanced: bool,
    /// True when its placements share one prototype ([`Scene::shared`])
    /// instead of being copied into [`Scene::facets`]: it then owns no
    /// facets of that list ([`ObjectInfo::facets`] is empty).
    pub shared: bool,
    /// Index of its first facet in [`Scene::facets`].
    pub first_facet: usize,
    /// Each placement's transform, kept only for an instanced object of a
    /// measured-luminaire material (its C0 axis turns with the placement,
    /// see [`Scene::luminaire_c0`]); empty otherwise.
    pub(crate) luminaire_placements: Vec<instance::Xform>,
}

impl ObjectInfo {
    /// Its facets' indices in [`Scene::facets`].
    pub fn facets(&self) -> std::ops::Range<usize> {
        if self.shared {
            return self.first_facet..self.first_facet;
        }
        self.first_facet..self.first_facet + self.prototype_facets * self.instances
    }

    /// The facets of placement `k` (in the order of the list or CSV rows).
    pub fn instance_facets(&self, k: usize) -> std::ops::Range<usize> {
        if self.shared {
            return self.first_facet..self.first_facet;
        }
        let a = self.first_facet + k * self.prototype_facets;
        a..a + self.prototype_facets
    }
}

/// Where a facet came from: [`Scene::objects`]`[object]`, its placement
/// `instance` (0 for an object placed once), and the facet's index in the
/// object's prototype.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FacetOrigin {
    pub object: usize,
    pub instance: usize,
    pub prototype_facet: usize,
}

/// One `[point_sources.NAME]` table: `instances` point sources from
/// `first` on in [`Scene::point_sources`] (1 without placements), all with
/// its name.
#[derive(Clone, Debug, PartialEq)]
pub struct PointSourceGroup {
    pub name: String,
    pub instances: usize,
    pub first: usize,
}

/// Sizes of a scene before and after instancing (see [`Scene::counts`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneCounts {
    /// `[objects.NAME]` tables.
    pub objects: usize,
    /// Of those, the ones with `instances`/`instances_csv`.
    pub instanced_objects: usize,
    /// Placements over all objects (an object placed once counts 1).
    pub instances: usize,
    /// Facets as described: one copy of each object.
    pub prototype_facets: usize,
    /// Facets after expansion (`Scene::facets.len()`).
    pub facets: usize,
    /// Placed facets of the shared objects ([`Scene::shared`]): traced
    /// through their prototype, never stored.
    pub shared_facets: u64,
    /// `[point_sources.NAME]` tables.
    pub point_source_prototypes: usize,
    /// Point sources after expansion.
    pub point_sources: usize,
}

impl std::fmt::Display for SceneCounts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} objects ({} instanced, {} placements), {} prototype facets → {} facets{}; {} point source tables → {} point sources",
            self.objects,
            self.instanced_objects,
            self.instances,
            self.prototype_facets,
            self.facets,
            if self.shared_facets > 0 {
                format!(" + {} placed by shared instances", self.shared_facets)
            } else {
                String::new()
            },
            self.point_source_prototypes,
            self.point_sources
        )
    }
}

pub(crate) fn base_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// A surface material.
///
/// Reflection: `reflectance` is the total (directional-hemispherical)
/// reflectance ρ(λ) in 0..1; the fraction `specular_fraction` of it is
/// mirror-like and the rest, `(1 − specular_fraction)·ρ(λ)`, is Lambertian.
/// Transmission τ(λ) lets light straight through (a leaf, a screen): rays
/// crossing the surface keep their direction and are weighted by τ.
/// Energy conservation `ρ(λ) + τ(λ) ≤ 1` is checked at load time.
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    /// Total reflectance, 0..1 (see the type docs for the diffuse/specular split).
    pub reflectance: Spectrum,
    /// Fraction of the reflectance that is specular, 0..1.
    pub specular_fraction: f64,
    /// Straight-through transmission, 0..1; `None` for opaque materials.
    pub transmission: Option<Spectrum>,
    /// Set when facets of this material are area sources.
    pub emission: Option<Emission>,
}

impl Material {
    /// Lambertian part of the reflectance at `wavelength_nm`.
    pub fn diffuse_reflectance(&self, wavelength_nm: f64) -> f64 {
        (1.0 - self.specular_fraction) * self.reflectance.eval(wavelength_nm)
    }

    /// Specular part of the reflectance at `wavelength_nm`.
    pub fn specular_reflectance(&self, wavelength_nm: f64) -> f64 {
        self.specular_fraction * self.reflectance.eval(wavelength_nm)
    }

    /// True when the material lets any light through.
    pub fn is_transmissive(&self) -> bool {
        self.transmission
            .as_ref()
            .is_some_and(|t| t.integral() > 0.0)
    }

    /// True when the material has a specular lobe that reflects anything.
    pub fn is_specular(&self) -> bool {
        self.specular_fraction > 0.0 && self.reflectance.integral() > 0.0
    }
}

/// Emission of an area source: radiance `L(λ) cos^m(alpha)` about the facet
/// normal, emitted from the front side only — or, with a measured
/// [`AreaLuminaire`], `L(λ) · I(γ, C) / (I_max cos γ)` per square metre of
/// the emitting object's area (see there).
#[derive(Clone, Debug)]
pub struct Emission {
    /// Radiance along the normal, W m⁻² sr⁻¹ nm⁻¹ (lines in W m⁻² sr⁻¹).
    /// With a luminaire: the radiance a luminous area of 1 m² has where
    /// `I / cos γ` is `I_max` (numerically the spectral intensity of the
    /// file's largest candela value × scale, W sr⁻¹ nm⁻¹); the tracer
    /// divides it by each emitting object's area in m² (each placement's:
    /// an instanced object is one luminaire per placement).
    pub radiance_w_m2_sr_nm: Spectrum,
    /// m in `cos^m(alpha)`; 0 is Lambertian (and with a luminaire).
    pub shape_exponent: f64,
    /// The measured distribution, when `photometry = "file"` gives one.
    pub luminaire: Option<AreaLuminaire>,
}

/// A measured luminaire spread over an emitting object: the far-field
/// equivalence `L(ω) = I(γ, C) / (A cos γ)` — the intensity divided by the
/// object's area A projected toward ω, γ from each facet's normal (the
/// nadir), C from the C0 axis projected into the facet's plane. Exact for a
/// planar object; the object's flux is the file's flux below γ = 90° ×
/// scale (a facet emits from its front only, so light the file gives
/// above its plane is dropped).
#[derive(Clone, Debug)]
pub struct AreaLuminaire {
    pub table: std::sync::Arc<photometry::Photometry>,
    /// The C0 axis as given, in the scene's frame (unit; projected per
    /// facet by [`AreaLuminaire::c0_for`], and turned by each placement of
    /// an instanced object: [`Scene::luminaire_c0`]).
    pub c0_direction: DVec3,
    /// Whether the file gave `c0_direction` (the default +x may fall back
    /// to +y on a facet facing ±x; a given axis along a normal is refused).
    pub c0_given: bool,
    /// The file it was read from (as resolved against the scene).
    pub file: std::path::PathBuf,
}

impl AreaLuminaire {
    /// `cos γ` below which the radiance is held at its value at this
    /// cosine (γ > 89.94°): `1 / cos γ` stays bounded (≤ 1000 × I/A) where
    /// a file gives light at the horizon, at a flux cost of at most the
    /// file's intensity there times a 1.1e-3 sr band.
    pub const MIN_COS_GAMMA: f64 = 1e-3;

    /// The C0 axis in the plane of a facet with unit `normal`: the given
    /// axis projected, else x, else y.
    pub fn c0_for(&self, normal: DVec3) -> DVec3 {
        [self.c0_direction, DVec3::X, DVec3::Y]
            .into_iter()
            .find_map(|v| build::perpendicular(v, normal))
            .unwrap_or(DVec3::X)
    }

    /// The TILT=INCLUDE factor for a facet with unit `normal` (its tilt
    /// from straight down, −z); 1 without a tilt table.
    pub fn tilt_factor(&self, normal: DVec3) -> f64 {
        (self.table.tilt.as_ref()).map_or(1.0, |t| t.factor_for_nadir(normal))
    }

    /// `I(γ, C) / (I_max cos γ)` toward unit `w` leaving a facet with unit
    /// `normal` and C0 axis `c0` (from [`Self::c0_for`]): the radiance
    /// relative to `I_max / A`; 0 behind the facet, `cos γ` held at
    /// [`Self::MIN_COS_GAMMA`] below it.
    pub fn relative_radiance(&self, normal: DVec3, c0: DVec3, w: DVec3) -> f64 {
        let cos_g = normal.dot(w);
        if cos_g.is_nan() || cos_g <= 0.0 {
            return 0.0;
        }
        let gamma = cos_g.min(1.0).acos().to_degrees();
        let c90 = -normal.cross(c0);
        let (x, y) = (w.dot(c0), w.dot(c90));
        let c = if x == 0.0 && y == 0.0 {
            0.0
        } else {
            y.atan2(x).to_degrees()
        };
        self.table.candela_at(gamma, c) / self.table.max_candela / cos_g.max(Self::MIN_COS_GAMMA)
    }
}

/// A planar, convex triangle or quad.
#[derive(Clone, Debug, PartialEq)]
pub struct Facet {
    /// 3 or 4 vertices in scene units, counter-clockwise seen from the front.
    pub vertices: Vec<DVec3>,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// The name of the scene object the facet belongs to.
    pub object: String,
}

impl Facet {
    /// Newell's vector: twice the vector area (normal × area).
    fn newell(&self) -> DVec3 {
        geometry::newell(&self.vertices)
    }

    /// Unit normal of the front side (right-hand rule on the vertex order);
    /// zero for a degenerate facet (which loading rejects).
    pub fn normal(&self) -> DVec3 {
        self.newell().normalize_or_zero()
    }

    /// Area in scene units² (exact for planar polygons).
    pub fn area(&self) -> f64 {
        0.5 * self.newell().length()
    }

    /// Area centroid (for a quad, the area-weighted mean of its two triangles).
    pub fn centroid(&self) -> DVec3 {
        geometry::centroid(&self.vertices)
    }
}

/// A point source: intensity `I_s(λ) cos^m(alpha)` about `direction`
/// (zero behind it for m > 0; m = 0 is isotropic), or, with a measured
/// [`Luminaire`], `I_s(λ) · I(γ, C) / I_max` with γ measured from
/// `direction` (the nadir) and C from the luminaire's C0 plane.
#[derive(Clone, Debug)]
pub struct PointSource {
    pub name: String,
    /// Scene units.
    pub position: DVec3,
    /// Unit vector.
    pub direction: DVec3,
    pub shape_exponent: f64,
    /// I_s, W sr⁻¹ nm⁻¹ (lines in W sr⁻¹): with a luminaire, the intensity
    /// toward its brightest direction (its luminous intensity is the
    /// file's largest candela value × scale × tilt factor).
    pub intensity_w_sr_nm: Spectrum,
    /// The measured distribution, when `photometry = "file"` gives one.
    pub luminaire: Option<Luminaire>,
}

impl PointSource {
    /// True for shaped sources (m > 0, or a measured distribution).
    pub fn is_shaped(&self) -> bool {
        self.shape_exponent > 0.0 || self.luminaire.is_some()
    }
}

/// A distant (directional) source: parallel light from infinitely far
/// away, as a collimator or a sun gives it — `E(λ)` on a surface facing
/// the beam, `E(λ) cos θ` on one turned by θ, wherever it stands.
#[derive(Clone, Debug)]
pub struct DistantSource {
    pub name: String,
    /// Unit vector: the way the light travels (the source lies along
    /// `−direction`).
    pub direction: DVec3,
    /// Irradiance normal to the beam, W m⁻² nm⁻¹ (lines in W m⁻²).
    pub irradiance_w_m2_nm: Spectrum,
}

/// A point source's measured intensity distribution in the scene: the
/// table (shared by every placement) and the luminaire's C0 axis.
#[derive(Clone, Debug)]
pub struct Luminaire {
    pub table: std::sync::Arc<photometry::Photometry>,
    /// Unit vector of the C0 half-plane, perpendicular to the source's
    /// `direction`; C90 is `−direction × c0` (counter-clockwise seen from
    /// above the luminaire).
    pub c0: DVec3,
    /// The file it was read from (as resolved against the scene).
    pub file: std::path::PathBuf,
}

impl Luminaire {
    /// `I(γ, C) / I_max` toward unit `w` (from the lamp) for nadir `dir`:
    /// bilinear in (γ, C) over the table (see [`photometry::Photometry::candela_at`]).
    pub fn relative_toward(&self, dir: DVec3, w: DVec3) -> f64 {
        let cos_g = dir.dot(w).clamp(-1.0, 1.0);
        let gamma = cos_g.acos().to_degrees();
        let c90 = -dir.cross(self.c0);
        let (x, y) = (w.dot(self.c0), w.dot(c90));
        let c = if x == 0.0 && y == 0.0 {
            0.0
        } else {
            y.atan2(x).to_degrees()
        };
        self.table.candela_at(gamma, c) / self.table.max_candela
    }
}

/// A pinhole camera.
///
/// Image convention: pixel (column, row) with row 0 at the top; continuous
/// coordinates `(px, py)` run over `0..width`, `0..height` and pixel `(i, j)`
/// has its centre at `(i + 0.5, j + 0.5)`. Pixels are square, so the vertical
/// field is `2·atan(tan(fov/2)·height/width)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub position: DVec3,
    pub look_at: DVec3,
    pub up: DVec3,
    /// Horizontal field of view, degrees (0 < fov < 180).
    pub fov_deg: f64,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// Orthonormal (right, true up, forward) basis.
    pub fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let f = (self.look_at - self.position).normalize();
        let r = f.cross(self.up).normalize();
        let u = r.cross(f);
        (r, u, f)
    }

    /// tan of the half fields of view (horizontal, vertical).
    pub fn tan_half_fov(&self) -> (f64, f64) {
        let th = (self.fov_deg.to_radians() * 0.5).tan();
        (th, th * self.height as f64 / self.width as f64)
    }

    /// Unit direction of the ray through continuous pixel coordinates
    /// `(px, py)` (see the type docs).
    pub fn pixel_direction(&self, px: f64, py: f64) -> DVec3 {
        let (r, u, f) = self.basis();
        let (th, tv) = self.tan_half_fov();
        let x = (2.0 * px / self.width as f64 - 1.0) * th;
        let y = (1.0 - 2.0 * py / self.height as f64) * tv;
        (f + x * r + y * u).normalize()
    }

    /// Continuous pixel coordinates of a scene point, or `None` when it is
    /// behind the camera. Points outside the image give coordinates outside
    /// `0..width`, `0..height`.
    pub fn project(&self, p: DVec3) -> Option<(f64, f64)> {
        let (r, u, f) = self.basis();
        let d = p - self.position;
        let z = d.dot(f);
        if z <= 0.0 {
            return None;
        }
        let (th, tv) = self.tan_half_fov();
        let x = d.dot(r) / (z * th);
        let y = d.dot(u) / (z * tv);
        Some((
            (x + 1.0) * 0.5 * self.width as f64,
            (1.0 - y) * 0.5 * self.height as f64,
        ))
    }

    /// True when the point projects inside the image (in front of the camera).
    pub fn sees_point(&self, p: DVec3) -> bool {
        self.project(p).is_some_and(|(x, y)| {
            (0.0..=self.width as f64).contains(&x) && (0.0..=self.height as f64).contains(&y)
        })
    }

    /// True when any part of the polygon lies inside the viewing frustum
    /// (occlusion is not considered).
    pub fn frustum_overlaps(&self, polygon: &[DVec3]) -> bool {
        geometry::frustum_overlaps(self, polygon)
    }
}

/// A spectral band of the render.
#[derive(Clone, Debug)]
pub struct Band {
    pub name: String,
    /// Response curve: a 0/1 rectangle over `lo_nm..hi_nm` for rectangular
    /// bands, otherwise the given response clipped to `lo_nm..hi_nm`.
    pub response: Spectrum,
    /// Support of the response, nm.
    pub lo_nm: f64,
    pub hi_nm: f64,
}

/// The optional `[sky]` block (outdoor scenes); parsed now, simulated by the
/// sky crate.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyConfig {
    /// ISO-8601 date and time, UTC (e.g. `2024-03-14T22:30:00Z`), as
    /// written (reports quote it).
    pub utc: String,
    /// The same instant, parsed once here (the tracer and the frames'
    /// dates read this, never the text again).
    pub instant: gloam_sky::UtcInstant,
    pub latitude_deg: f64,
    /// East positive.
    pub longitude_deg: f64,
    /// Observer height above sea level, m.
    pub height_m: f64,
    /// Horizontal meteorological visibility, km.
    pub visibility_km: f64,
    pub moon: bool,
    pub night_sky: bool,
    pub overcast: bool,
}

impl SkyConfig {
    /// The Sun's geometric elevation at the site and instant, degrees.
    pub fn sun_elevation_deg(&self) -> f64 {
        self.sun_elevation_deg_at(self.instant)
    }

    /// The Sun's geometric elevation at the site at instant `t`, degrees
    /// (a sequence's sky clock moves the instant).
    pub fn sun_elevation_deg_at(&self, t: gloam_sky::UtcInstant) -> f64 {
        gloam_sky::Site::new(self.latitude_deg, self.longitude_deg, self.height_m)
            .map(|site| {
                gloam_sky::ephemeris(t, &site, gloam_sky::Refraction::None)
                    .sun
                    .elevation_geometric_deg
            })
            .unwrap_or(f64::NEG_INFINITY)
    }

    /// Whether the Sun lights the sky: at or above −18° (twilight or day).
    pub fn twilight(&self) -> bool {
        self.sun_elevation_deg() >= gloam_sky::twilight::TWILIGHT_MIN_SUN_ELEVATION_DEG
    }

    /// Whether the Sun's direct beam reaches the ground: above the
    /// horizon under a clear sky.
    pub fn sun_beam(&self) -> bool {
        !self.overcast && self.sun_elevation_deg() > 0.0
    }
}

#[cfg(test)]
mod tests;
