//! The prepared scene and everything that happens along a ray: direct
//! lighting from point and area sources (three estimators), directly viewed
//! emitters, specular recursion, diffuse path tracing.

use glam::DVec3;
use gloam_scene::Scene;
use rand::Rng;
use rand_pcg::Pcg64Mcg;

use crate::closed_form;
use crate::geometry::{Geometry, Visibility};
use crate::light::Light;
use crate::prep::{PrepObserver, Preparation};
use crate::sampling::{SphericalRectangle, SphericalTriangle, sample_triangle_area};
use crate::settings::{Estimator, Occlusion, RenderSettings};
use crate::sky_light::{
    RadianceTable, SkyLight, SkySummary, SkyTerms, cosine_hemisphere, orthonormal_basis,
};
use crate::spectral::Wavelengths;

/// Why a scene cannot be traced.
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    #[error("the scene defines no band to render into")]
    NoBands,
    #[error("band `{0}` is not defined by the scene (bands: {1})")]
    UnknownBand(String, String),
    #[error("pixel ({0}, {1}) is outside the {2}×{3} image")]
    PixelOutside(u32, u32, u32, u32),
    #[error("{0}")]
    BadInput(String),
    /// The caller's stop flag ended a render early (nothing is returned).
    #[error("interrupted")]
    Interrupted,
}

/// Most worker threads a render starts.
pub const MAX_THREADS: usize = 1024;

/// Most pixels a render takes (8192 × 8192).
pub const MAX_PIXELS: u64 = 1 << 26;

/// Longest side of a render, pixels (per-row and per-column buffers are
/// sized by it; a 67 108 864 × 1 camera passes [`MAX_PIXELS`]).
pub const MAX_SIDE: u32 = 16384;

/// Bytes a render holds per pixel and band (radiance, standard error and
/// two accumulators, f64).
const BYTES_PER_PIXEL_BAND: u64 = 32;

/// Refuses a render too large to hold, before anything is allocated: the
/// image (after `resolution_scale`) against [`MAX_PIXELS`] and the memory
/// available, and the wavelength grid against
/// [`crate::spectral::MAX_WAVELENGTHS`].
fn check_size(scene: &Scene, settings: &RenderSettings) -> Result<(), TraceError> {
    if let Some(t) = settings.threads.filter(|&t| t > MAX_THREADS) {
        return Err(TraceError::BadInput(format!(
            "threads = {t}: at most {MAX_THREADS} worker threads (this machine has {})",
            std::thread::available_parallelism().map_or(1, |n| n.get())
        )));
    }
    let n_wl = crate::spectral::wavelength_count(scene, settings.spectral_step_nm);
    if n_wl > crate::spectral::MAX_WAVELENGTHS {
        return Err(TraceError::BadInput(format!(
            "the bands span {n_wl:.3e} wavelength samples at spectral_step_nm = {} (limit {:.0e}): narrow the bands or coarsen the step",
            settings.spectral_step_nm,
            crate::spectral::MAX_WAVELENGTHS
        )));
    }
    let scaled = |n: u32| (n as f64 * settings.resolution_scale).round();
    let (w, h) = (scaled(scene.camera.width), scaled(scene.camera.height));
    if !(w >= 1.0 && h >= 1.0) {
        return Err(TraceError::BadInput(format!(
            "resolution_scale {:e} shrinks the {}×{} camera below one pixel: use a scale of at least {:.3e}",
            settings.resolution_scale,
            scene.camera.width,
            scene.camera.height,
            0.5 / scene.camera.width.min(scene.camera.height).max(1) as f64
        )));
    }
    if w > MAX_SIDE as f64 || h > MAX_SIDE as f64 {
        return Err(TraceError::BadInput(format!(
            "the image would be {w}×{h} pixels (camera {}×{} at resolution_scale {}): each side is limited to {MAX_SIDE} pixels",
            scene.camera.width, scene.camera.height, settings.resolution_scale
        )));
    }
    let pixels = w * h;
    if pixels.is_nan() || pixels > MAX_PIXELS as f64 {
        return Err(TraceError::BadInput(format!(
            "the image would be {w}×{h} pixels (camera {}×{} at resolution_scale {}), more than the {MAX_PIXELS}-pixel limit (8192×8192)",
            scene.camera.width, scene.camera.height, settings.resolution_scale
        )));
    }
    let bytes = pixels as u64 * (scene.bands.len() as u64 * BYTES_PER_PIXEL_BAND + 4);
    if let Some(avail) = gloam_scene::available_memory_bytes() {
        if bytes > avail / 10 * 8 {
            return Err(TraceError::BadInput(format!(
                "a {w}×{h} render of {} bands needs about {:.1} GiB, more than 80 % of the {:.1} GiB available",
                scene.bands.len(),
                bytes as f64 / (1u64 << 30) as f64,
                avail as f64 / (1u64 << 30) as f64
            )));
        }
    }
    Ok(())
}

/// Where [`Tracer::irradiance_split`] puts the smooth terms of the
/// irradiance: the sky dome's and the area sources' (extended emitters:
/// no pools or shadow edges sharper than a texel, as the office's cache
/// shows). Point sources and the Moon are the sharp terms.
pub(crate) enum Smooth<'a> {
    /// With the rest, in `out`.
    Included,
    /// In this buffer of their own.
    Apart(&'a mut Light),
    /// Not computed (no random numbers drawn for them), and a light tree
    /// picks a single emitter: the sharp terms alone, as a final-gather
    /// ray reads them where it lands (its many rays average the picks).
    Omitted,
}

/// Ray counters (summed over threads; integers, so deterministic).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RayCounts {
    /// Camera rays.
    pub primary: u64,
    /// Closest-hit rays after the camera ray (specular, diffuse, through
    /// transmissive facets).
    pub secondary: u64,
    /// Occlusion (shadow) rays.
    pub shadow: u64,
}

impl RayCounts {
    pub fn add(&mut self, o: &RayCounts) {
        self.primary += o.primary;
        self.secondary += o.secondary;
        self.shadow += o.shadow;
    }
    pub fn total(&self) -> u64 {
        self.primary + self.secondary + self.shadow
    }
}

/// Per-material spectral factors at the carried wavelengths.
#[derive(Clone, Debug)]
pub(crate) struct MatSpec {
    /// Lambertian albedo (1 − s)ρ.
    pub(crate) kd: Vec<f64>,
    /// Specular reflectance sρ (empty when none).
    pub(crate) ks: Vec<f64>,
    /// Straight-through transmission.
    pub(crate) trans: Option<Vec<f64>>,
    pub(crate) has_diffuse: bool,
}

/// How an area source is sampled in solid angle.
#[derive(Clone, Debug)]
enum Shape {
    /// corner + [0,1]ex + [0,1]ey (a true rectangle).
    Rect { corner: DVec3, ex: DVec3, ey: DVec3 },
    /// One or two triangles.
    Tris(Vec<[DVec3; 3]>),
}

/// An emitting facet.
#[derive(Clone, Debug)]
pub(crate) struct AreaSource {
    pub(crate) facet: u32,
    verts: Vec<DVec3>,
    normal: DVec3,
    centroid: DVec3,
    /// Scene units².
    area: f64,
    /// How the radiance varies with the direction it leaves in.
    profile: Profile,
    /// `Some` when the profile is `cos^m` with an integer m the closed
    /// form handles (None: sampled).
    m_int: Option<u32>,
    /// Spectral radiance along the normal (emission slots); for a
    /// tabulated profile, `I_max / A` with the tilt factor (the profile
    /// supplies `I(γ, C) / (I_max cos γ)`).
    pub(crate) radiance: Vec<f64>,
    /// Σ over bands of the band radiance: a scalar size for choosing.
    size: f64,
    shape: Shape,
    /// Triangles for area sampling, with cumulative area fractions.
    tris: Vec<[DVec3; 3]>,
    tri_cdf: Vec<f64>,
    /// The 2001 method's pre-drawn sample points.
    dirsig_points: Vec<DVec3>,
    /// Its light group under `--layers` (`layers.rs`; None otherwise).
    pub(crate) group: Option<usize>,
}

/// An area source's directional profile: the one place its radiance's
/// dependence on the leaving direction is evaluated (direct view, light
/// samples, the 2001 method, the light tree's bound).
#[derive(Clone, Debug)]
enum Profile {
    /// `cos^m` about the facet normal (m = 0: Lambertian).
    CosPower(f64),
    /// A measured luminaire, `I(γ, C) / (I_max cos γ)` (see
    /// [`gloam_scene::AreaLuminaire::relative_radiance`]), with the C0 axis
    /// projected into this facet's plane.
    Table {
        lum: gloam_scene::AreaLuminaire,
        c0: DVec3,
    },
}

/// A point source: `intensity · shape(ω)`, the shape `cos^m` about `dir`
/// or a measured luminaire's `I(γ, C) / I_max` (see
/// [`PointLight::shape_toward`]).
#[derive(Clone, Debug)]
pub(crate) struct PointLight {
    pub(crate) pos: DVec3,
    dir: DVec3,
    pub(crate) m: f64,
    /// A measured distribution (IES / EULUMDAT); `m` is then 0.
    luminaire: Option<gloam_scene::Luminaire>,
    pub(crate) intensity: Vec<f64>,
    /// Its light group under `--layers` (`layers.rs`; None otherwise).
    pub(crate) group: Option<usize>,
}

/// One light sample toward an area source: unit direction, distance (scene
/// units), and weight `f(ω)/(pdf·N)` with `f = cos^m θ_e cos θ_r`.
#[derive(Clone, Copy)]
struct LightSample {
    dir: DVec3,
    dist: f64,
    w: f64,
}

/// What of a set of shadow rays' weight reaches a source: `Σ_j w_j` (the
/// unoccluded estimate), the weight of the clear rays, and the weight
/// times τ(λ) of those through transmissive facets.
struct Visible {
    sum_w: f64,
    vis_scalar: f64,
    vis_spec: Option<Vec<f64>>,
}

impl Visible {
    /// Adds `scale · L(λ) Σ_j w_j V_j τ_j(λ)` to `out`.
    fn add_to(&self, out: &mut [f64], scale: f64, radiance: &[f64]) {
        match &self.vis_spec {
            None => {
                let g = scale * self.vis_scalar;
                if g != 0.0 {
                    add_emission(out, g, radiance, None);
                }
            }
            Some(v) => out
                .iter_mut()
                .zip(radiance)
                .zip(v)
                .for_each(|((o, l), v)| *o += scale * l * (self.vis_scalar + v)),
        }
    }
}

/// Adds `g · spectrum(λ) · τ(λ)` slot by slot to `out` (τ = 1 for `None`:
/// a clear line of sight), over `spectrum`'s slots (the sky's: the
/// continuum only).
fn add_emission(out: &mut [f64], g: f64, spectrum: &[f64], tau: Option<&[f64]>) {
    match tau {
        None => out.iter_mut().zip(spectrum).for_each(|(o, s)| *o += g * s),
        Some(t) => out
            .iter_mut()
            .zip(spectrum)
            .zip(t)
            .for_each(|((o, s), t)| *o += g * s * t),
    }
}

/// A scene prepared for tracing with given settings.
pub struct Tracer {
    pub(crate) settings: RenderSettings,
    pub(crate) wl: Wavelengths,
    pub(crate) geom: Geometry,
    pub(crate) mpu: f64,
    pub(crate) facet_mat: Vec<u32>,
    pub(crate) facet_normal: Vec<DVec3>,
    pub(crate) facet_verts: Vec<Vec<DVec3>>,
    pub(crate) facet_source: Vec<u32>,
    pub(crate) mats: Vec<MatSpec>,
    pub(crate) area: Vec<AreaSource>,
    pub(crate) points: Vec<PointLight>,
    /// Camera in centred coordinates.
    pub(crate) camera: gloam_scene::Camera,
    pub(crate) ones: Vec<f64>,
    /// The Moon and the sky dome, when the effect plan (or `all_effects`)
    /// calls for them.
    pub(crate) sky: Option<SkyState>,
    /// The solved radiosity cache (`indirect = cache`).
    pub(crate) cache: Option<crate::indirect::Cache>,
    /// How interreflection was decided (method, pilot estimate, bounces).
    pub(crate) interreflection: crate::plan::InterreflectionDecision,
    /// Effects the plan leaves out because the pilot found them worth no
    /// more than the tolerance (skipped outright, unlike `settings.drop`,
    /// which computes and discards to keep the random numbers).
    pub(crate) skip: crate::settings::Dropped,
    /// The light tree over the emitters, when there are more than
    /// `light_tree_min_lights` (else every emitter is evaluated, as always).
    pub(crate) light_tree: Option<crate::light_tree::LightTree>,
    /// Seconds spent building the BVH and spectral tables.
    pub(crate) build_seconds: f64,
    /// The scene's size and each preparation step's time and peak memory.
    pub(crate) preparation: Preparation,
    /// Told as preparation steps begin and end (`prepare_observed`).
    pub(crate) observer: Option<PrepObserver>,
    /// The light groups its emitters and its cache are split by
    /// (`--layers`, `layers.rs`), when a layered render asked for them.
    pub(crate) layers: Option<crate::layers::LayerMap>,
    /// Which pixels each emitter's face covers: the faces seen directly
    /// are computed apart from the camera samples (`direct_view.rs`).
    pub(crate) view: crate::direct_view::Footprints,
}

/// The sky as the tracer uses it: on the continuum slots only (the sky has
/// no emission lines), scene frame +x east, +y north, +z up.
pub(crate) struct SkyState {
    /// Continuum slots (the first `nc` of every spectral vector).
    nc: usize,
    /// Unit vector to the Moon when its direct beam lights the scene.
    pub(crate) moon_dir: Option<DVec3>,
    /// Where moon shadow rays go under `all_effects` when the Moon is dark
    /// (carrying zero irradiance).
    forced_moon_dir: DVec3,
    /// Direct lunar irradiance normal to the beam, W m⁻² nm⁻¹ per slot.
    pub(crate) moon_en: Vec<f64>,
    /// Whether the dome is sampled (a sky term is on, or `all_effects`).
    pub(crate) dome: bool,
    pub(crate) table: RadianceTable,
    pub(crate) summary: SkySummary,
    /// The light groups of the direct beam and of the dome under
    /// `--layers` (`layers.rs`; None otherwise).
    pub(crate) moon_group: Option<usize>,
    pub(crate) sky_group: Option<usize>,
}

/// What [`Tracer::sky_probe`] reports: the two sky terms separately, in one
/// band, W m⁻².
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SkyProbeResult {
    pub band: String,
    /// Direct moonlight, `E_n cos θ · τ` (one shadow ray; exact).
    pub moon_direct_w_m2: f64,
    /// The sky dome, mean of the repetitions (each `sky_samples` rays).
    pub sky_diffuse_w_m2: f64,
    pub sky_std_error_w_m2: f64,
}

/// Builds the sky from the scene's `[sky]` block, gated by the effect plan.
fn build_sky(
    scene: &Scene,
    settings: &RenderSettings,
    wl: &Wavelengths,
) -> Result<Option<SkyState>, TraceError> {
    use gloam_scene::plan::names;
    let plan = gloam_scene::plan::plan(scene);
    let moon = plan.is_enabled(names::MOON);
    let night = plan.is_enabled(names::NIGHT_SKY);
    let atmosphere = plan.is_enabled(names::ATMOSPHERE);
    if !(moon || night || atmosphere || settings.all_effects) {
        return Ok(None);
    }
    let bad =
        |what: &str, e: gloam_sky::SkyError| TraceError::BadInput(format!("[sky] {what}: {e}"));
    let (instant, site, conditions, cfg) = match &scene.sky {
        Some(s) => {
            let instant =
                gloam_sky::UtcInstant::parse_iso8601(&s.utc).map_err(|e| bad("utc", e))?;
            let site = gloam_sky::Site::new(s.latitude_deg, s.longitude_deg, s.height_m)
                .map_err(|e| bad("site", e))?;
            let cloud = if s.overcast {
                gloam_sky::Cloud::Overcast
            } else {
                gloam_sky::Cloud::Clear
            };
            let c = gloam_sky::SkyConditions::new(s.visibility_km, cloud)
                .map_err(|e| bad("visibility_km", e))?;
            (instant, site, c, Some(s))
        }
        None => {
            // all_effects on an indoor scene: a dark sky, paths exercised.
            let instant = gloam_sky::UtcInstant::parse_iso8601("2000-01-01T00:00:00Z")
                .map_err(|e| bad("utc", e))?;
            let site = gloam_sky::Site::new(0.0, 0.0, 0.0).map_err(|e| bad("site", e))?;
            let c = gloam_sky::SkyConditions::new(23.0, gloam_sky::Cloud::Clear)
                .map_err(|e| bad("visibility_km", e))?;
            (instant, site, c, None)
        }
    };
    let model =
        gloam_sky::SkyModel::new(instant, &site, &conditions).map_err(|e| bad("model", e))?;
    let terms = SkyTerms {
        moon,
        night_sky: night,
    };
    let nc = wl.n_continuum;
    let light = SkyLight::new(&model, &wl.nm[..nc], terms);
    let table = RadianceTable::new(&light);
    let moon_dir = light.moon_direction();
    let eph = model.ephemeris();
    let geometric = DVec3::from_array(model.moon_direction_enu()).normalize_or_zero();
    let forced_moon_dir = if geometric.z > 0.0 {
        geometric
    } else {
        DVec3::Z
    };
    let summary = SkySummary {
        utc: cfg.map(|s| s.utc.clone()),
        latitude_deg: site.latitude_deg,
        longitude_deg: site.longitude_east_deg,
        height_m: site.height_m,
        visibility_km: conditions.visibility_km,
        overcast: conditions.cloud == gloam_sky::Cloud::Overcast,
        moon_term: moon,
        night_sky_term: night,
        moon_elevation_deg: eph.moon.elevation_deg,
        moon_azimuth_deg: eph.moon.azimuth_deg,
        moon_illuminated_fraction: eph.illuminated_fraction,
        moon_direct: moon_dir.is_some(),
        moon_direction: geometric.to_array(),
        sky_samples: settings.sky_samples,
        uniform_dome: table.is_uniform(),
    };
    Ok(Some(SkyState {
        nc,
        moon_dir,
        forced_moon_dir,
        moon_en: light.moon_normal_irradiance_w_m2_nm().to_vec(),
        dome: moon || night || settings.all_effects,
        table,
        summary,
        moon_group: None,
        sky_group: None,
    }))
}

/// SplitMix64 finaliser: decorrelates (seed, index) into a stream seed.
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream of item `index` (a pixel, a probe repetition) under `seed`.
pub(crate) fn stream(seed: u64, domain: u64, index: u64) -> Pcg64Mcg {
    let a = mix64(seed ^ mix64(domain));
    let b = mix64(a ^ index);
    Pcg64Mcg::new(((a as u128) << 64) | b as u128 | 1)
}

/// `n` stratified points in [0,1)² (Latin hypercube: each row and column
/// stratum holds exactly one point).
pub(crate) fn latin_hypercube(n: usize, rng: &mut Pcg64Mcg, out: &mut Vec<[f64; 2]>) {
    out.clear();
    let mut perm: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        let j = rng.random_range(0..=i);
        perm.swap(i, j);
    }
    let inv = 1.0 / n as f64;
    for (i, &p) in perm.iter().enumerate() {
        let a: f64 = rng.random();
        let b: f64 = rng.random();
        out.push([
            ((i as f64 + a) * inv).min(1.0 - f64::EPSILON),
            ((p as f64 + b) * inv).min(1.0 - f64::EPSILON),
        ]);
    }
}

/// The luminous area A in `L = I / (A cos γ)` of each measured luminaire,
/// scene units²: the area of its facets of one measured-luminaire material
/// by (material, object, placement) — each placement of an instanced
/// object is a luminaire of its own (summing over placements made N
/// placements each emit 1/N of the file's flux). Keyed by the facet's
/// index when it has no object. One pass over the facets.
fn luminous_areas(scene: &gloam_scene::Scene) -> std::collections::HashMap<LuminaireKey, f64> {
    let mut out = std::collections::HashMap::new();
    for (i, f) in scene.facets.iter().enumerate() {
        if scene.materials[f.material]
            .emission
            .as_ref()
            .is_some_and(|e| e.luminaire.is_some())
        {
            *out.entry(luminaire_key(scene, i)).or_insert(0.0) += f.area();
        }
    }
    out
}

/// (material, object, placement) of a measured-luminaire facet: which
/// luminaire it belongs to (see [`luminous_areas`]).
type LuminaireKey = (usize, usize, usize);

fn luminaire_key(scene: &gloam_scene::Scene, i: usize) -> LuminaireKey {
    let m = scene.facets[i].material;
    scene
        .facet_origin(i)
        .map_or((m, usize::MAX, i), |o| (m, o.object, o.instance))
}

fn shaping(cos: f64, m: f64) -> f64 {
    if m == 0.0 {
        1.0
    } else if cos <= 0.0 {
        0.0
    } else {
        cos.powf(m)
    }
}

fn orthonormal(n: DVec3) -> (DVec3, DVec3) {
    let a = if n.x.abs() > 0.9 { DVec3::Y } else { DVec3::X };
    let t = n.cross(a).normalize();
    (t, n.cross(t))
}

impl Tracer {
    /// Prepares `scene` (BVH, spectral tables, sources, and — when the
    /// effect plan calls for interreflection — the radiosity cache) for
    /// `settings`.
    pub fn new(scene: &Scene, settings: &RenderSettings) -> Result<Self, TraceError> {
        Self::prepare(scene, settings, true)
    }

    /// As [`Tracer::prepare`], telling `observer` as each preparation step
    /// begins and ends (a progress display).
    pub fn prepare_observed(
        scene: &Scene,
        settings: &RenderSettings,
        solve: bool,
        observer: Option<PrepObserver>,
    ) -> Result<Self, TraceError> {
        Self::prepare_inner(scene, settings, solve, observer, None)
    }

    /// As [`Tracer::new`]; `solve` = false stops after the interreflection
    /// decision (the pilot), without building the full cache (`gloam plan`).
    pub fn prepare(
        scene: &Scene,
        settings: &RenderSettings,
        solve: bool,
    ) -> Result<Self, TraceError> {
        Self::prepare_inner(scene, settings, solve, None, None)
    }

    pub(crate) fn prepare_inner(
        scene: &Scene,
        settings: &RenderSettings,
        solve: bool,
        observer: Option<PrepObserver>,
        layers: Option<&crate::layers::LayerMap>,
    ) -> Result<Self, TraceError> {
        let counts = scene.counts();
        let mut prep = Preparation {
            facets: scene.facets.len(),
            prototype_facets: counts.prototype_facets,
            instances: counts.instances,
            point_sources: scene.point_sources.len(),
            ..Default::default()
        };
        let t0 = std::time::Instant::now();
        if scene.bands.is_empty() {
            return Err(TraceError::NoBands);
        }
        check_size(scene, settings)?;
        let wl = Wavelengths::for_scene(scene, settings.spectral_step_nm);

        // Scene-centred origin: centre of the box around facets, camera, lamps.
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        let mut grow = |p: DVec3| {
            lo = lo.min(p);
            hi = hi.max(p);
        };
        for f in &scene.facets {
            f.vertices.iter().for_each(|&v| grow(v));
        }
        grow(scene.camera.position);
        scene.point_sources.iter().for_each(|p| grow(p.position));
        let origin = 0.5 * (lo + hi);
        let extent = 0.5 * (hi - lo).length();

        let mats: Vec<MatSpec> = scene
            .materials
            .iter()
            .map(|m| {
                let rho = wl.factor(&m.reflectance);
                let s = m.specular_fraction.clamp(0.0, 1.0);
                let kd: Vec<f64> = rho.iter().map(|r| (1.0 - s) * r).collect();
                let ks: Vec<f64> = if s > 0.0 {
                    rho.iter().map(|r| s * r).collect()
                } else {
                    Vec::new()
                };
                MatSpec {
                    has_diffuse: kd.iter().any(|&k| k > 0.0),
                    kd,
                    ks: if ks.iter().any(|&k| k > 0.0) {
                        ks
                    } else {
                        Vec::new()
                    },
                    trans: m
                        .transmission
                        .as_ref()
                        .filter(|_| m.is_transmissive())
                        .map(|t| wl.factor(t)),
                }
            })
            .collect();

        let facet_verts: Vec<Vec<DVec3>> = scene
            .facets
            .iter()
            .map(|f| f.vertices.iter().map(|&v| v - origin).collect())
            .collect();
        let facet_mat: Vec<u32> = scene.facets.iter().map(|f| f.material as u32).collect();
        let facet_normal: Vec<DVec3> = scene.facets.iter().map(|f| f.normal()).collect();
        let transmissive: Vec<bool> = facet_mat
            .iter()
            .map(|&m| mats[m as usize].trans.is_some())
            .collect();
        let step = Preparation::begin("bvh", observer.as_ref());
        let geom = Geometry::new(origin, extent, &facet_verts, transmissive);
        prep.end(step, observer.as_ref());
        prep.triangles = geom.triangle_count();

        let step = Preparation::begin("light_structure", observer.as_ref());

        let mut facet_source = vec![u32::MAX; scene.facets.len()];
        let mut area = Vec::new();
        let mut rng = stream(settings.seed, 0x00D1_2516_2001, 0);
        let lum_areas = luminous_areas(scene);
        for (i, f) in scene.facets.iter().enumerate() {
            let Some(e) = &scene.materials[f.material].emission else {
                continue;
            };
            let verts = facet_verts[i].clone();
            let normal = facet_normal[i];
            let (profile, m_int, radiance) = match &e.luminaire {
                None => {
                    let m = e.shape_exponent.max(0.0);
                    let m_int = (m.fract() == 0.0 && m <= u32::MAX as f64).then_some(m as u32);
                    (
                        Profile::CosPower(m),
                        m_int,
                        wl.emission(&e.radiance_w_m2_sr_nm),
                    )
                }
                Some(lum) => {
                    // I_max (× tilt) over the luminous area of the
                    // object's placement, m².
                    let a_su2 = lum_areas
                        .get(&luminaire_key(scene, i))
                        .copied()
                        .unwrap_or(0.0);
                    let a_m2 = a_su2 * scene.meters_per_unit.powi(2);
                    let k = lum.tilt_factor(normal) / a_m2.max(f64::MIN_POSITIVE);
                    let radiance = wl
                        .emission(&e.radiance_w_m2_sr_nm)
                        .into_iter()
                        .map(|v| v * k)
                        .collect();
                    // Turned by the facet's placement, as a point source's.
                    let c0 = scene.luminaire_c0(i).unwrap_or_else(|| lum.c0_for(normal));
                    let lum = lum.clone();
                    (Profile::Table { lum, c0 }, None, radiance)
                }
            };
            let size = wl.total(&radiance);
            let tris: Vec<[DVec3; 3]> = (1..verts.len() - 1)
                .map(|k| [verts[0], verts[k], verts[k + 1]])
                .collect();
            let tri_areas: Vec<f64> = tris
                .iter()
                .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length())
                .collect();
            let total: f64 = tri_areas.iter().sum::<f64>().max(f64::MIN_POSITIVE);
            let mut acc = 0.0;
            let tri_cdf = tri_areas
                .iter()
                .map(|a| {
                    acc += a / total;
                    acc
                })
                .collect();
            let shape = rect_of(&verts).unwrap_or_else(|| Shape::Tris(tris.clone()));
            let area_su = f.area();
            let mut src = AreaSource {
                facet: i as u32,
                centroid: f.centroid() - origin,
                verts,
                normal,
                area: area_su,
                profile,
                m_int,
                radiance,
                size,
                shape,
                tris,
                tri_cdf,
                dirsig_points: Vec::new(),
                group: None,
            };
            if settings.estimator == Estimator::Dirsig2001 {
                let d = &settings.dirsig2001;
                let n = ((area_su * d.SAMPLE_AREA_DENSITY).round() as u64)
                    .clamp(1, d.MAX_SAMPLE_POINTS as u64);
                src.dirsig_points = (0..n)
                    .map(|_| src.area_point([rng.random(), rng.random()]))
                    .collect();
            }
            facet_source[i] = area.len() as u32;
            area.push(src);
        }

        let points: Vec<PointLight> = scene
            .point_sources
            .iter()
            .map(|p| PointLight {
                pos: p.position - origin,
                dir: p.direction.normalize_or_zero(),
                m: p.shape_exponent.max(0.0),
                luminaire: p.luminaire.clone(),
                intensity: wl.emission(&p.intensity_w_sr_nm),
                group: None,
            })
            .collect();
        let light_tree =
            build_light_tree(&area, &points, &wl, settings, scene.meters_per_unit, extent);

        let mut camera = scene.camera.clone();
        camera.position -= origin;
        camera.look_at -= origin;
        if settings.resolution_scale != 1.0 {
            let scale = |n: u32| ((n as f64 * settings.resolution_scale).round() as u32).max(1);
            camera.width = scale(camera.width);
            camera.height = scale(camera.height);
        }
        prep.area_emitters = area.len();
        prep.end(step, observer.as_ref());
        let ones = vec![1.0; wl.len()];
        let step = Preparation::begin("sky", observer.as_ref());
        let sky = build_sky(scene, settings, &wl)?;
        prep.end(step, observer.as_ref());
        let view = if settings.drop.direct_view {
            Default::default()
        } else {
            let sources: Vec<(Vec<[DVec3; 3]>, bool)> = area
                .iter()
                .map(|s| {
                    let faces = (camera.position - s.centroid).dot(s.normal) > 0.0;
                    (s.tris.clone(), faces)
                })
                .collect();
            crate::direct_view::Footprints::build(&camera, &sources)
        };
        let mut tracer = Self {
            settings: settings.clone(),
            wl,
            geom,
            mpu: scene.meters_per_unit,
            facet_mat,
            facet_normal,
            facet_verts,
            facet_source,
            mats,
            area,
            points,
            camera,
            ones,
            sky,
            cache: None,
            interreflection: Default::default(),
            skip: Default::default(),
            light_tree,
            build_seconds: 0.0,
            preparation: prep,
            observer,
            layers: None,
            view,
        };
        if let Some(map) = layers {
            tracer.assign_groups(map);
        }
        tracer.decide_interreflection(solve);
        tracer.build_seconds = t0.elapsed().as_secs_f64();
        Ok(tracer)
    }

    /// The settings this tracer was prepared with.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The wavelength grid and the bands it integrates into.
    pub fn wavelengths(&self) -> &Wavelengths {
        &self.wl
    }

    /// The scene's geometry (BVH) in the tracer's centred coordinates.
    pub fn geometry(&self) -> &Geometry {
        &self.geom
    }

    /// How interreflection was decided (method, pilot estimate, bounces).
    pub fn interreflection(&self) -> &crate::plan::InterreflectionDecision {
        &self.interreflection
    }

    /// Seconds spent building the BVH and spectral tables.
    pub fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    /// The scene's size and each preparation step's time and peak memory.
    pub fn preparation(&self) -> &Preparation {
        &self.preparation
    }

    /// Index of the band called `name` (or the first band for `None`).
    pub fn band_index(&self, name: Option<&str>) -> Result<usize, TraceError> {
        match name {
            None => Ok(0),
            Some(n) => self
                .wl
                .band_names
                .iter()
                .position(|b| b == n)
                .ok_or_else(|| TraceError::UnknownBand(n.into(), self.wl.band_names.join(", "))),
        }
    }

    /// The facet whose polygon contains `p` (centred coordinates), if any:
    /// the nearest plane within a tolerance set by f64 rounding of the
    /// coordinates involved (~4500 ulps), not by the scene's size — a point
    /// 0.1 mm under an emitter 1e5 m from the origin lies on the floor, not
    /// on the emitter.
    pub(crate) fn facet_at(&self, p: DVec3) -> Option<u32> {
        let mut best: Option<(f64, u32)> = None;
        for (i, v) in self.facet_verts.iter().enumerate() {
            let n = self.facet_normal[i];
            let tol = 1e-12 * (p.abs().max_element() + v[0].abs().max_element())
                + 1e-12 * (v[1] - v[0]).length();
            let d = (p - v[0]).dot(n).abs();
            if d > tol {
                continue;
            }
            let k = v.len();
            let inside = (0..k).all(|j| {
                let a = v[j];
                let b = v[(j + 1) % k];
                (b - a).cross(p - a).dot(n) >= -tol * (b - a).length()
            });
            if inside && best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, i as u32));
            }
        }
        best.map(|(_, i)| i)
    }

    pub(crate) fn area_centroids(&self) -> Vec<DVec3> {
        self.area.iter().map(|s| s.centroid).collect()
    }

    /// Diffuse albedo of facet `f` at every slot.
    pub(crate) fn kd(&self, f: u32) -> &[f64] {
        &self.mats[self.facet_mat[f as usize] as usize].kd
    }

    /// Transmission from `p` along unit `dir` over `dist`: `None` when
    /// blocked, `Some(None)` when clear, `Some(Some(τ))` through
    /// transmissive facets.
    pub(crate) fn shadow(
        &self,
        p: DVec3,
        dir: DVec3,
        dist: f64,
        ignore: [u32; 2],
        c: &mut RayCounts,
    ) -> Option<Option<Vec<f64>>> {
        c.shadow += 1;
        let eps = self.geom.epsilon(p);
        let tmax = dist * (1.0 - 1e-9) - eps;
        if tmax <= eps {
            return Some(None);
        }
        match self.geom.visibility(p, dir, eps, tmax, ignore) {
            Visibility::Blocked => None,
            // Transmissive occluders dropped: they stop light like any facet.
            Visibility::Clear(list)
                if !list.is_empty()
                    && (self.settings.drop.transmissive_occluders
                        || self.skip.transmissive_occluders) =>
            {
                None
            }
            Visibility::Clear(list) if list.is_empty() && !self.settings.all_effects => Some(None),
            Visibility::Clear(list) => {
                let mut t = self.ones.clone();
                for f in list {
                    if let Some(tr) = &self.mats[self.facet_mat[f as usize] as usize].trans {
                        t.iter_mut().zip(tr).for_each(|(a, b)| *a *= b);
                    }
                }
                Some(Some(t))
            }
        }
    }

    /// Spectral irradiance (W m⁻² nm⁻¹ at continuum slots, W m⁻² at line
    /// slots) at `p` (centred) with unit normal `n`, added to `out`.
    /// `ignore` is the facet `p` lies on (or `u32::MAX`).
    pub(crate) fn irradiance(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        self.irradiance_with(p, n, ignore, 1, None, rng, c, out);
    }

    /// [`Tracer::irradiance`] with the light tree's part averaged over
    /// `tree_repeats` independent selections (the radiosity cache's texels:
    /// the sky and Moon are sampled once, the many-light part, the noisy
    /// one, `tree_repeats` times).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn irradiance_with(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        tree_repeats: u32,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let smooth = Smooth::Included;
        self.irradiance_split(p, n, ignore, tree_repeats, strata, smooth, rng, c, out);
    }

    /// [`Tracer::irradiance_with`], its smooth terms ([`Smooth`]) added to
    /// `out`, kept apart or left out: the radiosity cache reads the smooth
    /// light from its texels and recomputes the rest — the part that can
    /// change within a texel — where a gather ray lands.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn irradiance_split(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        tree_repeats: u32,
        strata: Option<LightStrata>,
        mut smooth: Smooth<'_>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        // A dropped term that draws random numbers (dome, area sources) is
        // still computed, into a scratch buffer, so the render shares every
        // other random number with the full one: the difference is the
        // term, not noise (`gloam bench plan`).
        let (drop, skip) = (&self.settings.drop, &self.skip);
        // With a light tree the point sources are among the emitters it
        // picks (below).
        let points: &[PointLight] = if self.light_tree.is_some() {
            &[]
        } else {
            &self.points
        };
        for l in points {
            let shaped = l.is_shaped();
            if (shaped && (drop.shaped_point_sources || skip.shaped_point_sources))
                || (!shaped && (drop.point_sources || skip.point_sources))
            {
                continue;
            }
            self.point_irradiance(l, p, n, ignore, 1.0, c, out);
        }
        // Dropped terms are discarded whole: no groups.
        let nwl = out.len();
        let scratch = || Light::dark(nwl, 0);
        if let Some(sky) = &self.sky {
            if !(drop.moon || skip.moon) {
                self.moon_irradiance(sky, p, n, ignore, c, out);
            }
            match &mut smooth {
                _ if skip.night_sky => {}
                Smooth::Omitted => {}
                _ if drop.night_sky => {
                    self.dome_irradiance(sky, p, n, ignore, rng, c, &mut scratch())
                }
                Smooth::Included => self.dome_irradiance(sky, p, n, ignore, rng, c, out),
                Smooth::Apart(apart) => self.dome_irradiance(sky, p, n, ignore, rng, c, apart),
            }
        }
        match &mut smooth {
            _ if skip.area_sources => {}
            Smooth::Omitted => {}
            _ if drop.area_sources => {
                self.area_irradiance(p, n, ignore, strata, rng, c, &mut scratch())
            }
            Smooth::Included => self.area_irradiance(p, n, ignore, strata, rng, c, out),
            Smooth::Apart(apart) => self.area_irradiance(p, n, ignore, strata, rng, c, apart),
        }
        if let Some(tree) = &self.light_tree {
            // Point sources draw no random numbers: a dropped one need not
            // be traced at all. Dropped area picks are traced and discarded.
            // The sharp terms alone take a single pick (a gather ray's
            // reading, averaged over many).
            let sharp_only = matches!(smooth, Smooth::Omitted);
            let skipped = [
                skip.area_sources || sharp_only,
                skip.point_sources || drop.point_sources,
                skip.shaped_point_sources || drop.shaped_point_sources,
            ];
            let dropped = [
                drop.area_sources,
                drop.point_sources,
                drop.shaped_point_sources,
            ];
            let branches = if sharp_only { 1 } else { usize::MAX };
            let repeats = tree_repeats.max(1);
            let w = 1.0 / repeats as f64;
            for _ in 0..repeats {
                let parts = self
                    .tree_irradiance(tree, p, n, ignore, skipped, branches, strata, rng, c, out);
                // w = 1 for one selection: x · 1 is x exactly. Area picks
                // are smooth terms.
                for (k, (part, _)) in parts
                    .iter()
                    .zip(dropped)
                    .enumerate()
                    .filter(|(_, (_, d))| !d)
                {
                    let to = match &mut smooth {
                        Smooth::Apart(apart) if k == 0 => &mut **apart,
                        _ => &mut *out,
                    };
                    to.add_each(part, |o, x| {
                        o.iter_mut().zip(x).for_each(|(o, x)| *o += w * x)
                    });
                }
            }
        }
    }

    /// The area sources' part of [`Tracer::irradiance`], by the chosen
    /// estimator.
    #[allow(clippy::too_many_arguments)]
    fn area_irradiance(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        if self.area.is_empty() && !self.settings.all_effects {
            return;
        }
        match self.settings.estimator {
            // The light tree picks the area sources (`tree_irradiance`).
            Estimator::Analytic if self.light_tree.as_ref().is_some_and(|t| t.has_area) => {}
            Estimator::Analytic => self.analytic(p, n, ignore, strata, rng, c, out),
            Estimator::SolidAngle => {
                for s in &self.area {
                    if s.facet != ignore {
                        self.solid_angle(s, p, n, ignore, 1.0, strata, rng, c, out);
                    }
                }
            }
            Estimator::Dirsig2001 => {
                for s in &self.area {
                    if s.facet != ignore {
                        self.dirsig2001(s, p, n, ignore, rng, c, out);
                    }
                }
            }
        }
    }

    /// [`Tracer::irradiance`] split by what it comes from, for the effect
    /// plan's pilot: `[area sources, isotropic point sources, shaped point
    /// sources, Moon, sky dome]`.
    pub(crate) fn irradiance_parts(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
    ) -> [Vec<f64>; 5] {
        let z = || Light::dark(self.wl.len(), 0);
        let mut parts = [z(), z(), z(), z(), z()];
        let points: &[PointLight] = if self.light_tree.is_some() {
            &[]
        } else {
            &self.points
        };
        for l in points {
            let k = if l.is_shaped() { 2 } else { 1 };
            self.point_irradiance(l, p, n, ignore, 1.0, c, &mut parts[k]);
        }
        if let Some(sky) = &self.sky {
            self.moon_irradiance(sky, p, n, ignore, c, &mut parts[3]);
            self.dome_irradiance(sky, p, n, ignore, rng, c, &mut parts[4]);
        }
        self.area_irradiance(p, n, ignore, None, rng, c, &mut parts[0]);
        // The pilot stays cheap with many lamps: the tree's picks, each
        // into its own term (unbiased per term, as each pick's weight is
        // its own 1/pmf).
        if let Some(tree) = &self.light_tree {
            let like = &parts[0];
            let tree_parts = self.tree_irradiance(
                tree,
                p,
                n,
                ignore,
                [false; 3],
                usize::MAX,
                None,
                rng,
                c,
                like,
            );
            for (k, part) in tree_parts.iter().enumerate() {
                (parts[k].whole.iter_mut())
                    .zip(&part.whole)
                    .for_each(|(o, x)| *o += x);
            }
        }
        parts.map(Light::into_whole)
    }

    /// Direct moonlight at `p` (normal `n`): `E_n(λ) cos θ τ(λ)` with one
    /// shadow ray to infinity. A directional source: no distance, so no
    /// `meters_per_unit` (W m⁻² whatever the scene units).
    fn moon_irradiance(
        &self,
        sky: &SkyState,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let d = match sky.moon_dir {
            Some(d) => d,
            None if self.settings.all_effects => sky.forced_moon_dir,
            None => return,
        };
        let cos = n.dot(d);
        if cos.is_nan() || cos <= 0.0 {
            return;
        }
        let moon = (sky.moon_group, cos, &sky.moon_en[..]);
        self.add_if_visible(p, d, f64::INFINITY, ignore, moon, c, out);
    }

    /// One shadow ray from `p` along unit `dir` over `dist`; unless it is
    /// blocked, adds `g · spectrum · τ` (`light = (group, g, spectrum)`)
    /// to `out` and to that light group.
    #[allow(clippy::too_many_arguments)]
    fn add_if_visible(
        &self,
        p: DVec3,
        dir: DVec3,
        dist: f64,
        ignore: u32,
        (group, g, spectrum): (Option<usize>, f64, &[f64]),
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        if let Some(tau) = self.shadow(p, dir, dist, [ignore, u32::MAX], c) {
            out.add_from(group, |o| add_emission(o, g, spectrum, tau.as_deref()));
        }
    }

    /// The sky dome at `p` (normal `n`): `sky_samples` cosine-weighted
    /// directions (Latin-hypercube stratified), each adding `π L(ω) τ(ω) / N`
    /// when its shadow ray escapes; directions below the horizon carry no
    /// sky and cast no ray.
    #[allow(clippy::too_many_arguments)]
    fn dome_irradiance(
        &self,
        sky: &SkyState,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        if !sky.dome {
            return;
        }
        let nsamp = self.settings.sky_samples.max(1) as usize;
        let mut u = Vec::with_capacity(nsamp);
        latin_hypercube(nsamp, rng, &mut u);
        let (t, b) = orthonormal_basis(n);
        let w = std::f64::consts::PI / nsamp as f64;
        let mut l = vec![0.0; sky.nc];
        for uv in u {
            let local = cosine_hemisphere(uv);
            let dir = (t * local.x + b * local.y + n * local.z).normalize_or_zero();
            if dir.z.is_nan() || dir.z <= 0.0 {
                continue;
            }
            let Some(tau) = self.shadow(p, dir, f64::INFINITY, [ignore, u32::MAX], c) else {
                continue;
            };
            sky.table.radiance_into(dir, &mut l);
            out.add_from(sky.sky_group, |o| add_emission(o, w, &l, tau.as_deref()));
        }
    }

    /// The two sky terms at world-space `point` (normal `normal`) in `band`,
    /// separately: direct moonlight (exact, one shadow ray) and the dome
    /// (mean of `samples` repetitions of `sky_samples` rays, with its
    /// standard error). `None` when the render has no sky.
    pub fn sky_probe(
        &self,
        point: DVec3,
        normal: DVec3,
        band: Option<&str>,
        samples: u32,
    ) -> Result<Option<SkyProbeResult>, TraceError> {
        let b = self.band_index(band)?;
        let n = normal
            .try_normalize()
            .ok_or_else(|| TraceError::BadInput("the normal must be a non-zero vector".into()))?;
        let Some(sky) = &self.sky else {
            return Ok(None);
        };
        let p = point - self.geom.origin;
        let ignore = self.facet_at(p).unwrap_or(u32::MAX);
        let mut c = RayCounts::default();
        let mut e = Light::dark(self.wl.len(), 0);
        self.moon_irradiance(sky, p, n, ignore, &mut c, &mut e);
        let moon = self.wl.integrate(&e.whole)[b];
        let k = samples.max(1);
        let mut es = Vec::with_capacity(k as usize);
        for i in 0..k {
            let mut rng = stream(self.settings.seed, 0x5C1E_D0E5, i as u64);
            e.clear();
            self.dome_irradiance(sky, p, n, ignore, &mut rng, &mut c, &mut e);
            es.push(self.wl.integrate(&e.whole)[b]);
        }
        let mean = es.iter().sum::<f64>() / k as f64;
        let se = if k > 1 {
            let var = es.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
            (var / k as f64).sqrt()
        } else {
            0.0
        };
        Ok(Some(SkyProbeResult {
            band: self.wl.band_names[b].clone(),
            moon_direct_w_m2: moon,
            sky_diffuse_w_m2: mean,
            sky_std_error_w_m2: se,
        }))
    }

    /// What the render took from the `[sky]` block (None: no sky).
    pub fn sky_summary(&self) -> Option<&SkySummary> {
        self.sky.as_ref().map(|s| &s.summary)
    }

    /// A point source's irradiance at `p` times `scale` (1, or the light
    /// tree's 1/pmf), one shadow ray.
    #[allow(clippy::too_many_arguments)]
    fn point_irradiance(
        &self,
        l: &PointLight,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        scale: f64,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let v = l.pos - p;
        let r = v.length();
        if r <= 0.0 {
            return;
        }
        let w = v / r;
        let cos_r = w.dot(n);
        if cos_r <= 0.0 {
            return;
        }
        let shape = l.shape_toward(-w);
        if shape == 0.0 {
            return;
        }
        let r_m = r * self.mpu;
        // scale·shape is exactly shape for scale = 1 (no light tree).
        let g = scale * shape * cos_r / (r_m * r_m);
        self.add_if_visible(p, w, r, ignore, (l.group, g, &l.intensity), c, out);
    }

    /// Draws `nsamp` light samples (Latin-hypercube stratified) of `s` seen from `p` (normal `n`),
    /// uniform in solid angle where possible, else uniform in area. Samples
    /// below either horizon get weight 0 but still count. Returns false
    /// when the point is behind or in the emitter's plane (no light).
    #[allow(clippy::too_many_arguments)]
    fn light_samples(
        &self,
        s: &AreaSource,
        p: DVec3,
        n: DVec3,
        nsamp: u32,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        out: &mut Vec<LightSample>,
    ) -> bool {
        out.clear();
        let h = (p - s.centroid).dot(s.normal);
        if h <= 1e-14 * (self.geom.extent + p.abs().max_element()) {
            return false;
        }
        let nsamp = nsamp.max(1) as usize;
        let mut u = Vec::with_capacity(nsamp);
        match strata {
            Some(st) => st.points(s.facet, nsamp, self.settings.area_samples, &mut u),
            None => latin_hypercube(nsamp, rng, &mut u),
        }
        let inv_n = 1.0 / nsamp as f64;
        let weight = |x: DVec3, per_sr: Option<f64>| -> LightSample {
            let v = x - p;
            let d2 = v.length_squared();
            let dist = d2.sqrt();
            if dist.is_nan() || dist <= 0.0 {
                return LightSample {
                    dir: s.normal,
                    dist: 0.0,
                    w: 0.0,
                };
            }
            let dir = v / dist;
            let cos_e = -dir.dot(s.normal);
            let cos_r = dir.dot(n);
            let f = if cos_e > 0.0 && cos_r > 0.0 {
                cos_r * s.shape(cos_e, -dir)
            } else {
                0.0
            };
            let w = match per_sr {
                Some(omega) => f * omega * inv_n,
                None => f * s.area * cos_e / d2 * inv_n,
            };
            LightSample { dir, dist, w }
        };
        // Practically in the emitter's plane: area sampling (the solid-angle
        // samplers also decline there, and below 1e-6 sr).
        let grazing = h < 1e-10 * s.area.sqrt();
        if !grazing {
            match &s.shape {
                Shape::Rect { corner, ex, ey } => {
                    if let Some(sr) = SphericalRectangle::new(p, *corner, *ex, *ey) {
                        let omega = sr.solid_angle();
                        out.extend(u.iter().map(|&uv| weight(sr.sample(uv), Some(omega))));
                        return true;
                    }
                }
                Shape::Tris(tris) => {
                    let st: Option<Vec<SphericalTriangle>> = tris
                        .iter()
                        .map(|t| SphericalTriangle::new(p, t[0], t[1], t[2]))
                        .collect();
                    if let Some(st) = st {
                        let omegas: Vec<f64> = st.iter().map(|t| t.solid_angle()).collect();
                        let total: f64 = omegas.iter().sum();
                        for &[u0, u1] in &u {
                            // Pick a triangle by solid angle, reuse u0.
                            let mut x = u0 * total;
                            let mut k = 0;
                            while k + 1 < st.len() && x >= omegas[k] {
                                x -= omegas[k];
                                k += 1;
                            }
                            let u0k = (x / omegas[k]).clamp(0.0, 1.0 - f64::EPSILON);
                            let dir = st[k].sample([u0k, u1]);
                            // Point on the emitter plane along `dir`.
                            let denom = dir.dot(s.normal);
                            let t = if denom < 0.0 { h / -denom } else { 0.0 };
                            out.push(weight(p + dir * t, Some(total)));
                        }
                        return true;
                    }
                }
            }
        }
        out.extend(u.iter().map(|&uv| weight(s.area_point(uv), None)));
        true
    }

    /// The shadow rays of `samples` toward `s` from `p`: what of their
    /// weight arrives ([`Visible::add_to`] turns it into light).
    fn occlusion(
        &self,
        s: &AreaSource,
        p: DVec3,
        ignore: u32,
        samples: &[LightSample],
        c: &mut RayCounts,
    ) -> Visible {
        let mut sum_w = 0.0;
        let mut vis_scalar = 0.0;
        let mut vis_spec: Option<Vec<f64>> = None;
        for ls in samples {
            if ls.w <= 0.0 {
                continue;
            }
            sum_w += ls.w;
            match self.shadow(p, ls.dir, ls.dist, [ignore, s.facet], c) {
                None => {}
                Some(None) => vis_scalar += ls.w,
                Some(Some(t)) => {
                    let v = vis_spec.get_or_insert_with(|| vec![0.0; t.len()]);
                    v.iter_mut().zip(&t).for_each(|(a, b)| *a += ls.w * b);
                }
            }
        }
        Visible {
            sum_w,
            vis_scalar,
            vis_spec,
        }
    }

    /// Occluded MC sum over `samples` times L: adds
    /// `scale · L(λ) Σ_j w_j V_j τ_j(λ)` to `out` (to `s`'s group);
    /// returns `Σ_j w_j` (unoccluded MC).
    #[allow(clippy::too_many_arguments)]
    fn occluded_sum(
        &self,
        s: &AreaSource,
        p: DVec3,
        ignore: u32,
        samples: &[LightSample],
        scale: f64,
        c: &mut RayCounts,
        out: &mut Light,
    ) -> f64 {
        let v = self.occlusion(s, p, ignore, samples, c);
        out.add_from(s.group, |o| v.add_to(o, scale, &s.radiance));
        v.sum_w
    }

    #[allow(clippy::too_many_arguments)]
    fn solid_angle(
        &self,
        s: &AreaSource,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        scale: f64,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let mut samples = Vec::new();
        if self.light_samples(
            s,
            p,
            n,
            self.settings.area_samples,
            strata,
            rng,
            &mut samples,
        ) {
            self.occluded_sum(s, p, ignore, &samples, scale, c, out);
        }
    }

    /// The `analytic` estimator (see the crate docs, "Occlusion rule"):
    /// per source, the closed form corrected by `n_s` shadow rays; a source
    /// whose every sample is blocked at a wavelength contributes exactly 0
    /// there, and the summed area-source irradiance at the hit point is
    /// clamped at 0 per wavelength.
    #[allow(clippy::too_many_arguments)]
    fn analytic(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        // Closed-form unoccluded factor of each source (None: non-integer m).
        let factors: Vec<Option<f64>> = self
            .area
            .iter()
            .map(|s| {
                if s.facet == ignore {
                    return Some(0.0);
                }
                s.m_int.map(|m| {
                    closed_form::shaped_polygon_irradiance_factor(p, n, &s.verts, s.normal, m)
                })
            })
            .collect();
        let total: f64 = self
            .area
            .iter()
            .zip(&factors)
            .map(|(s, f)| f.unwrap_or(0.0) * s.size)
            .sum();
        let mut samples = Vec::new();
        let mut occ = vec![0.0; out.len()];
        // The area sources' sum at this point, clamped at 0 at the end.
        let mut area = out.dark_like();
        for (s, f) in self.area.iter().zip(&factors) {
            self.analytic_source(
                s,
                *f,
                total,
                1.0,
                p,
                n,
                ignore,
                strata,
                rng,
                c,
                &mut samples,
                &mut occ,
                &mut area,
            );
        }
        // No negative irradiance (see the crate docs): the control variate
        // can undershoot in deep penumbra.
        out.add_clamped(&area);
    }

    /// One area source's `analytic` estimate times `scale` (1, or the light
    /// tree's 1/pmf) into `area`: the closed form `factor` (None: non-integer
    /// m, sampled instead) corrected by shadow rays, their number set by the
    /// source's share of `total` (the scaled closed-form sum at `p`).
    /// `samples` and `occ` are scratch.
    #[allow(clippy::too_many_arguments)]
    fn analytic_source(
        &self,
        s: &AreaSource,
        factor: Option<f64>,
        total: f64,
        scale: f64,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        samples: &mut Vec<LightSample>,
        occ: &mut [f64],
        area: &mut Light,
    ) {
        let frac = self.settings.source_roulette_fraction;
        let n_full = self.settings.area_samples.max(1);
        let Some(factor) = factor else {
            // Non-integer shape exponent: no closed form; sample it.
            if s.facet != ignore {
                self.solid_angle(s, p, n, ignore, scale, strata, rng, c, area);
            }
            return;
        };
        if factor <= 0.0 && !self.settings.all_effects {
            return;
        }
        // Shadow rays allocated by the source's share of the closed-form
        // irradiance here: dim sources get fewer (at least one). Each
        // count gives an unbiased correction, so this never biases.
        // (scale = 1 without a light tree: every product below is then
        // exactly the unscaled one.)
        let share = factor * s.size * scale;
        let n_s = if frac > 0.0 && total > 0.0 && share < frac * total {
            ((n_full as f64 * share / (frac * total)).ceil() as u32).clamp(1, n_full)
        } else {
            n_full
        };
        let sampled = factor > 0.0 && self.light_samples(s, p, n, n_s, strata, rng, samples);
        occ.iter_mut().for_each(|x| *x = 0.0);
        let sum_w = if sampled {
            let v = self.occlusion(s, p, ignore, samples, c);
            v.add_to(occ, 1.0, &s.radiance);
            v.sum_w
        } else {
            0.0
        };
        if sum_w <= 0.0 {
            // No sample carries weight: no visibility information, the
            // closed form stands.
            area.add_from(s.group, |o| {
                o.iter_mut()
                    .zip(&s.radiance)
                    .for_each(|(o, l)| *o += scale * (factor * l))
            });
            return;
        }
        match self.settings.occlusion {
            Occlusion::Cv => {
                // E = E_closed + (MC_occ − MC_unocc), same samples;
                // exactly 0 where every sample is blocked (MC_occ = 0).
                area.add_from(s.group, |o| {
                    o.iter_mut()
                        .zip(occ.iter())
                        .zip(&s.radiance)
                        .for_each(|((o, mo), l)| {
                            if *mo != 0.0 {
                                *o += scale * (factor * l + (mo - sum_w * l));
                            }
                        })
                });
            }
            Occlusion::Ratio => {
                let k = factor / sum_w;
                area.add_from(s.group, |o| {
                    o.iter_mut()
                        .zip(occ.iter())
                        .for_each(|(o, mo)| *o += scale * (k * mo))
                });
            }
        }
    }

    /// Direct light from the emitters the light tree picks at `p`, split as
    /// `[area sources, isotropic point sources, shaped point sources]`: each
    /// pick's usual estimate (area: `analytic_source`; point: one shadow
    /// ray) times its 1/pmf, so each part is unbiased. Categories in
    /// `skipped` are neither traced nor counted. The area part is clamped at
    /// 0 per wavelength like `analytic`'s sum.
    #[allow(clippy::too_many_arguments)]
    fn tree_irradiance(
        &self,
        tree: &crate::light_tree::LightTree,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        skipped: [bool; 3],
        branches: usize,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        like: &Light,
    ) -> [Light; 3] {
        use crate::light_tree::LightRef;
        let nwl = self.wl.len();
        let mut parts = [like.dark_like(), like.dark_like(), like.dark_like()];
        let mut picks = Vec::new();
        tree.select_in(p, n, branches, rng, &mut picks);
        // Area picks: closed forms first, for the shadow-ray shares.
        let mut area_picks: Vec<(&AreaSource, Option<f64>, f64)> = Vec::new();
        for &(l, w) in &picks {
            match l {
                LightRef::Area(i) if !skipped[0] => {
                    let s = &self.area[i as usize];
                    let f = if s.facet == ignore {
                        Some(0.0)
                    } else {
                        s.m_int.map(|m| {
                            closed_form::shaped_polygon_irradiance_factor(
                                p, n, &s.verts, s.normal, m,
                            )
                        })
                    };
                    area_picks.push((s, f, w));
                }
                LightRef::Area(_) => {}
                LightRef::Point(i) => {
                    let l = &self.points[i as usize];
                    let k = if l.is_shaped() { 2 } else { 1 };
                    if !skipped[k] {
                        self.point_irradiance(l, p, n, ignore, w, c, &mut parts[k]);
                    }
                }
            }
        }
        if !area_picks.is_empty() {
            let total: f64 = area_picks
                .iter()
                .map(|(s, f, w)| f.unwrap_or(0.0) * s.size * w)
                .sum();
            let mut samples = Vec::new();
            let mut occ = vec![0.0; nwl];
            let mut area = like.dark_like();
            for &(s, f, w) in &area_picks {
                self.analytic_source(
                    s,
                    f,
                    total,
                    w,
                    p,
                    n,
                    ignore,
                    strata,
                    rng,
                    c,
                    &mut samples,
                    &mut occ,
                    &mut area,
                );
            }
            parts[0].add_clamped(&area);
        }
        parts
    }

    /// The published 2001 method (see the crate docs).
    #[allow(clippy::too_many_arguments)]
    fn dirsig2001(
        &self,
        s: &AreaSource,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let d = &self.settings.dirsig2001;
        let to_p = p - s.centroid;
        let h = to_p.dot(s.normal);
        if h <= 0.0 || s.dirsig_points.is_empty() {
            return;
        }
        // Solid angle from the angles the sides subtend at p.
        let k = s.verts.len();
        let phi: Vec<f64> = (0..k)
            .map(|i| {
                let a = s.verts[i] - p;
                let b = s.verts[(i + 1) % k] - p;
                a.cross(b).length().atan2(a.dot(b))
            })
            .collect();
        let omega = if k == 4 {
            0.5 * (phi[0] + phi[2]) * 0.5 * (phi[1] + phi[3])
        } else {
            let mn = phi.iter().copied().fold(f64::INFINITY, f64::min);
            let mx = phi.iter().copied().fold(0.0, f64::max);
            mn * mx / 2.0
        };
        if omega < d.SOLID_ANGLE_THRESHOLD {
            return;
        }
        // cos^m(alpha) once, alpha at the source centre.
        let shape = s.shape(h / to_p.length(), to_p.normalize());
        let cos_r_c = (-to_p.normalize()).dot(n).max(0.0);
        if s.size * omega * cos_r_c * shape < d.IRRADIANCE_THRESHOLD {
            return;
        }
        let nrays =
            ((omega * d.SOLID_ANGLE_DENSITY).ceil() as u64).clamp(1, d.MAX_SOURCE_SAMPLES as u64);
        let inv_n = 1.0 / nrays as f64;
        let mut samples = Vec::with_capacity(nrays as usize);
        for _ in 0..nrays {
            let x = s.dirsig_points[rng.random_range(0..s.dirsig_points.len())];
            let v = x - p;
            let r2 = v.length_squared();
            let dist = r2.sqrt();
            let dir = v / dist;
            let cos_t = dir.dot(n);
            let w = if cos_t > 0.0 && -dir.dot(s.normal) > 0.0 && r2 > 0.0 {
                cos_t * cos_t * s.area / r2 * inv_n
            } else {
                0.0
            };
            samples.push(LightSample { dir, dist, w });
        }
        self.occluded_sum(s, p, ignore, &samples, shape, c, out);
    }

    /// Spectral radiance arriving along the unit ray `(o, d)` (centred), times
    /// `thr`, added to `acc`. `spec_depth` is 1 for camera rays; `diffuse`
    /// counts diffuse bounces taken; `after_diffuse` suppresses emitter
    /// hits (already counted by next-event estimation). With `view_apart`
    /// (a camera ray of a render), the faces [`crate::direct_view`]
    /// computes apart are not added where the camera ray meets them.
    /// Returns whether the ray (a camera ray, through transmissive facets)
    /// met the front of an emitter it added: such a pixel's error is the
    /// emitter edge's, not the scene's.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn trace(
        &self,
        mut o: DVec3,
        d: DVec3,
        mut ignore: u32,
        thr: &[f64],
        spec_depth: u32,
        diffuse: u32,
        after_diffuse: bool,
        view_apart: bool,
        gather: Option<&[[f64; 2]]>,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        acc: &mut Light,
    ) -> bool {
        let mut met_emitter = false;
        let mut thr = thr.to_vec();
        // The pixel's stratified light-sample points, for the first
        // directly lit vertex only.
        let mut strata = strata;
        // The pixel's stratified final-gather points, for the first
        // diffuse vertex only.
        let mut gather = gather;
        // Straight-through passes across transmissive facets.
        for pass in 0..64 {
            if pass > 0 || spec_depth > 1 || after_diffuse {
                c.secondary += 1;
            }
            let eps = if ignore == u32::MAX {
                0.0
            } else {
                self.geom.epsilon(o)
            };
            let Some(hit) = self.geom.intersect(o, d, eps, f64::INFINITY, ignore) else {
                // Escaped: the sky dome's radiance in that direction (not
                // after a diffuse bounce, whose vertex sampled the dome).
                if let Some(sky) = &self.sky
                    && !after_diffuse
                {
                    let mut l = vec![0.0; sky.nc];
                    sky.table.radiance_into(d, &mut l);
                    acc.add_from(sky.sky_group, |a| {
                        a[..sky.nc]
                            .iter_mut()
                            .zip(&thr)
                            .zip(&l)
                            .for_each(|((a, t), l)| *a += t * l)
                    });
                }
                return met_emitter;
            };
            let f = hit.facet;
            let p = o + d * hit.t;
            let ng = self.facet_normal[f as usize];
            let front = d.dot(ng) < 0.0;
            let ns = if front { ng } else { -ng };
            let mat = &self.mats[self.facet_mat[f as usize] as usize];

            // Emitter seen along the ray: L cos^m(alpha) from the front.
            let src = self.facet_source[f as usize];
            let seen_directly = spec_depth == 1 && !after_diffuse;
            let apart = seen_directly && view_apart && self.view.apart(src);
            met_emitter |= seen_directly && src != u32::MAX && front && !apart;
            if src != u32::MAX
                && front
                && !after_diffuse
                && !apart
                && !(seen_directly && self.settings.drop.direct_view)
            {
                let s = &self.area[src as usize];
                let g = s.shape(-d.dot(ng), -d);
                acc.add_from(s.group, |a| {
                    a.iter_mut()
                        .zip(&thr)
                        .zip(&s.radiance)
                        .for_each(|((a, t), l)| *a += g * t * l)
                });
            }

            // Direct lighting of the Lambertian part: L = kd E / π.
            let all = self.settings.all_effects;
            if mat.has_diffuse || all {
                let mut e = acc.dark_like();
                self.irradiance_with(p, ns, f, 1, strata.take(), rng, c, &mut e);
                let inv_pi = std::f64::consts::FRAC_1_PI;
                acc.add_each(&e, |acc, e| {
                    for (((a, t), k), e) in acc.iter_mut().zip(&thr).zip(&mat.kd).zip(e) {
                        *a += t * k * e * inv_pi;
                    }
                });
            }

            // Diffuse interreflection from the radiosity cache (not after a
            // path-traced diffuse bounce: the two methods are exclusive).
            if let Some(cache) = &self.cache
                && mat.has_diffuse
                && !after_diffuse
            {
                let inv_pi = std::f64::consts::FRAC_1_PI;
                let scale: Vec<f64> = thr
                    .iter()
                    .zip(&mat.kd)
                    .map(|(t, k)| t * k * inv_pi)
                    .collect();
                self.cached_indirect(cache, p, ns, f, front, &scale, gather.take(), rng, c, acc);
            }

            // Specular recursion.
            if (!mat.ks.is_empty() || all)
                && spec_depth < self.settings.recursion
                && !self.skip.specular_recursion
            {
                let r = d - 2.0 * d.dot(ns) * ns;
                let t2: Vec<f64> = if mat.ks.is_empty() {
                    vec![0.0; thr.len()]
                } else {
                    thr.iter().zip(&mat.ks).map(|(a, b)| a * b).collect()
                };
                // Dropped: traced into a scratch buffer, so the other
                // random numbers stay those of the full render.
                let mut scratch;
                let target = if self.settings.drop.specular_recursion {
                    scratch = Light::dark(acc.len(), 0);
                    &mut scratch
                } else {
                    &mut *acc
                };
                self.trace(
                    p,
                    r,
                    f,
                    &t2,
                    spec_depth + 1,
                    diffuse,
                    false,
                    false,
                    None,
                    None,
                    rng,
                    c,
                    target,
                );
            }

            // Diffuse bounce with Russian roulette.
            if mat.has_diffuse && diffuse < self.settings.diffuse_bounces {
                let mut t2: Vec<f64> = thr.iter().zip(&mat.kd).map(|(a, b)| a * b).collect();
                let mut alive = true;
                if diffuse >= self.settings.rr_start {
                    let q = mat.kd.iter().copied().fold(0.0, f64::max).clamp(0.05, 0.95);
                    if rng.random::<f64>() < q {
                        t2.iter_mut().for_each(|x| *x /= q);
                    } else {
                        alive = false;
                    }
                }
                if alive {
                    let (tx, ty) = orthonormal(ns);
                    let u1: f64 = rng.random();
                    let u2: f64 = rng.random();
                    let r = u1.sqrt();
                    let phi = 2.0 * std::f64::consts::PI * u2;
                    let dir = (tx * (r * phi.cos())
                        + ty * (r * phi.sin())
                        + ns * (1.0 - u1).max(0.0).sqrt())
                    .normalize();
                    self.trace(
                        p,
                        dir,
                        f,
                        &t2,
                        spec_depth,
                        diffuse + 1,
                        true,
                        false,
                        None,
                        None,
                        rng,
                        c,
                        acc,
                    );
                }
            }

            // Straight through a transmissive facet.
            match &mat.trans {
                Some(tr)
                    if !(self.settings.drop.transmissive_occluders
                        || self.skip.transmissive_occluders) =>
                {
                    thr.iter_mut().zip(tr).for_each(|(a, b)| *a *= b);
                    if thr.iter().all(|&x| x == 0.0) {
                        return met_emitter;
                    }
                    o = p;
                    ignore = f;
                }
                _ => return met_emitter,
            }
        }
        met_emitter
    }
}

/// The light tree over `area` (with the `analytic` estimator; the other
/// estimators keep their loop over every area source) and `points`, when the
/// scene has more than `light_tree_min_lights` emitters; `None` keeps
/// today's exhaustive path, bit for bit.
fn build_light_tree(
    area: &[AreaSource],
    points: &[PointLight],
    wl: &Wavelengths,
    settings: &RenderSettings,
    mpu: f64,
    extent: f64,
) -> Option<crate::light_tree::LightTree> {
    use crate::light_tree::{Cone, LightInfo, LightRef, LightTree};
    if (area.len() + points.len()) as u64 <= settings.light_tree_min_lights as u64 {
        return None;
    }
    // A scalar size for the tree: the band total, or (emitting only outside
    // every band) the spectral sum, so an emitter never gets weight 0 while
    // it emits at some slot.
    let size = |v: &[f64], total: f64| {
        if total > 0.0 {
            total
        } else {
            v.iter().map(|x| x.max(0.0)).sum()
        }
    };
    let mut infos = Vec::with_capacity(area.len() + points.len());
    if settings.estimator == Estimator::Analytic {
        for (i, s) in area.iter().enumerate() {
            let (lo, hi) = s.verts.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), v| (lo.min(*v), hi.max(*v)),
            );
            infos.push(LightInfo {
                light: LightRef::Area(i as u32),
                lo,
                hi,
                // L·A: the on-axis intensity (scene units).
                phi: size(&s.radiance, s.size) * s.area,
                cone: Cone {
                    axis: s.normal,
                    theta_o: 0.0,
                    theta_e: std::f64::consts::FRAC_PI_2,
                    // Projected area × cos^m shaping; a table is
                    // bounded by its I_max (phi) with no falloff assumed.
                    exponent: match s.profile {
                        Profile::CosPower(m) => m + 1.0,
                        Profile::Table { .. } => 0.0,
                    },
                },
            });
        }
    }
    let mpu2 = (mpu * mpu).max(f64::MIN_POSITIVE);
    for (i, l) in points.iter().enumerate() {
        // Shaped: cos^m about `dir`, nothing behind; isotropic (or no
        // direction): every way.
        let cone = if let Some(lum) = &l.luminaire {
            // Intensity ≤ I_max everywhere (phi below) and zero beyond the
            // table's support angle from the nadir: a cone of that
            // half-angle, no falloff assumed inside it.
            let support = lum.table.support_deg().to_radians() + 1e-9;
            if support >= std::f64::consts::PI || l.dir == DVec3::ZERO {
                Cone::ALL
            } else {
                Cone {
                    axis: l.dir,
                    theta_o: 0.0,
                    theta_e: support,
                    exponent: 0.0,
                }
            }
        } else if l.m > 0.0 && l.dir != DVec3::ZERO {
            Cone {
                axis: l.dir,
                theta_o: 0.0,
                theta_e: std::f64::consts::FRAC_PI_2,
                exponent: l.m,
            }
        } else {
            Cone::ALL
        };
        infos.push(LightInfo {
            light: LightRef::Point(i as u32),
            lo: l.pos,
            hi: l.pos,
            phi: size(&l.intensity, wl.total(&l.intensity)) / mpu2,
            cone,
        });
    }
    LightTree::build(infos, extent, settings.light_tree_branches)
}

impl PointLight {
    /// The intensity's shape toward unit direction `w` (from the lamp), in
    /// [0, 1]: `cos^m(alpha)` about `dir`, or for a measured luminaire the
    /// file's candela bilinearly interpolated in (γ, C) over its table,
    /// divided by its largest value. Every point-light evaluation (direct
    /// light, the camera's view of the lamp, the radiosity cache) goes
    /// through here, so a tabulated lamp is evaluated exactly — no
    /// sampling — wherever a `cos^m` one is.
    pub(crate) fn shape_toward(&self, w: DVec3) -> f64 {
        match &self.luminaire {
            None => shaping(self.dir.dot(w), self.m),
            Some(l) => l.relative_toward(self.dir, w),
        }
    }

    /// Shaped (counted under `shaped-point-sources`): `cos^m` with m > 0,
    /// or a measured distribution.
    pub(crate) fn is_shaped(&self) -> bool {
        self.m > 0.0 || self.luminaire.is_some()
    }
}

impl AreaSource {
    /// Radiance at slot `slot` leaving toward unit `w` (from the facet):
    /// the profile read exactly, tabulated (γ, C) or `cos^m`.
    pub(crate) fn radiance_toward(&self, slot: usize, w: DVec3) -> f64 {
        self.shape(w.dot(self.normal), w) * self.radiance[slot]
    }

    /// The profile toward unit `w` leaving the facet, whose cosine with
    /// the normal is `cos_e` (the caller's, so `cos^m` sources evaluate
    /// exactly as before): `cos^m`, or a table's `I / (I_max cos γ)`.
    pub(crate) fn shape(&self, cos_e: f64, w: DVec3) -> f64 {
        match &self.profile {
            Profile::CosPower(m) => shaping(cos_e, *m),
            Profile::Table { lum, c0 } => lum.relative_radiance(self.normal, *c0, w),
        }
    }

    /// A point uniform in area, `u ∈ [0,1)²`.
    fn area_point(&self, u: [f64; 2]) -> DVec3 {
        let mut k = 0;
        while k + 1 < self.tris.len() && u[0] >= self.tri_cdf[k] {
            k += 1;
        }
        let lo = if k == 0 { 0.0 } else { self.tri_cdf[k - 1] };
        let width = (self.tri_cdf[k] - lo).max(f64::MIN_POSITIVE);
        let u0 = ((u[0] - lo) / width).clamp(0.0, 1.0);
        let t = &self.tris[k];
        sample_triangle_area(t[0], t[1], t[2], [u0, u[1]])
    }
}

/// A quad that is a true rectangle, as corner + two perpendicular edges.
fn rect_of(v: &[DVec3]) -> Option<Shape> {
    if v.len() != 4 {
        return None;
    }
    let ex = v[1] - v[0];
    let ey = v[3] - v[0];
    let tol = 1e-9 * (ex.length() + ey.length());
    if ex.normalize_or_zero().dot(ey.normalize_or_zero()).abs() > 1e-9
        || (v[0] + ex + ey - v[2]).length() > tol
    {
        return None;
    }
    Some(Shape::Rect {
        corner: v[0],
        ex,
        ey,
    })
}

/// Where a camera vertex's light samples come from: one Owen-scrambled
/// Sobol sequence per pixel and source, continued across the pixel's
/// camera samples (sample `j` takes points `j·stride …`), so the shadow
/// rays of all of a pixel's samples stratify each source jointly and a
/// penumbra converges as a stratified estimate, not as independent draws.
/// Each point is uniform on its own, so the estimate stays unbiased.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightStrata {
    /// The pixel's (and replicate's) scramble.
    pub scramble: u64,
    /// The camera sample's index within its sequence.
    pub sample: u32,
}

impl LightStrata {
    /// `n` points for source `facet`, from block `sample·stride` (stride ≥
    /// n: the full shadow-ray count, so blocks never overlap).
    fn points(&self, facet: u32, n: usize, stride: u32, out: &mut Vec<[f64; 2]>) {
        let seed = mix64(self.scramble ^ mix64(facet as u64 ^ 0x11_6A75));
        let first = self.sample.wrapping_mul(stride.max(n as u32));
        out.extend(
            (0..n as u32).map(|k| crate::sampling::sobol_owen_2d(first.wrapping_add(k), seed)),
        );
    }
}

#[cfg(test)]
mod light_strata_tests {
    use super::LightStrata;

    /// Samples 0…15 with 4 shadow rays each take the first 64 points of a
    /// scrambled Sobol (0,2)-sequence: a (0,6,2)-net, so every 8 × 8 cell
    /// (and every 4 × 16, 16 × 4 … box of area 1/64) holds exactly one —
    /// the joint stratification across a pixel's samples.
    #[test]
    fn a_pixels_light_samples_form_a_net() {
        for scramble in [1u64, 0xDEAD_BEEF, 42 << 40] {
            let mut pts = Vec::new();
            for sample in 0..16 {
                LightStrata { scramble, sample }.points(7, 4, 4, &mut pts);
            }
            assert_eq!(pts.len(), 64);
            for (nx, ny) in [(8usize, 8usize), (4, 16), (16, 4), (2, 32), (64, 1)] {
                let mut seen = vec![0u32; 64];
                for [x, y] in &pts {
                    let cell = (x * nx as f64) as usize * ny + (y * ny as f64) as usize;
                    seen[cell] += 1;
                }
                assert!(
                    seen.iter().all(|&k| k == 1),
                    "{nx}x{ny}, scramble {scramble}"
                );
            }
        }
    }
}
