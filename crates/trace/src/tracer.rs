//! The prepared scene and everything that happens along a ray: direct
//! lighting over the scene's lights (`lights/`: one `LightSource`
//! interface over the families and a `LightSampler`; here, which terms a
//! shading point computes, keeps apart or drops), directly viewed
//! emitters, specular recursion, diffuse path tracing.

use glam::DVec3;
use gloam_scene::Scene;
use rand::Rng;
use rand_pcg::Pcg64Mcg;

use crate::geometry::{Geometry, Visibility};
use crate::light::Light;
use crate::lights::{
    Route, Term, area_footprints, area_sources, build_light_tree, build_sky, point_lights,
};
// Their old paths, which `render.rs` and the crate root use.
pub(crate) use crate::integrator::PathState;
pub(crate) use crate::lights::LightStrata;
pub use crate::lights::SkyProbeResult;
use crate::prep::{PrepObserver, Preparation};
use crate::settings::RenderSettings;
use crate::spectral::Wavelengths;
pub(crate) use crate::world::MatSpec;
pub use crate::world::World;
use crate::world::centre_of;

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

/// A radiosity cache's bytes per texel and wavelength slot (its direct,
/// smooth, radiance and indirect arrays and the solve's work arrays:
/// 64 measured, a 524 288-texel cache of 61 slots peaking at 2.0 GB).
const CACHE_BYTES_PER_TEXEL_SLOT: f64 = 64.0;
/// An emitter's bytes per wavelength slot (its spectrum and the light
/// tree's copy: 20 000 point sources at 3 001 slots took 0.53 GB).
const EMITTER_BYTES_PER_SLOT: f64 = 16.0;
/// Most gather rays a cache traces for its operator (`cache_texels` ×
/// `cache_rays`): 2³⁰, the most texels at the default rays (about a
/// quarter of an hour on two cores), 256 times the default's.
pub const MAX_CACHE_RAYS: f64 = (1u64 << 30) as f64;

/// Refuses a render too large to hold, before anything is allocated: the
/// image (after `resolution_scale`) against [`MAX_PIXELS`] and the memory
/// available, and the wavelength grid against
/// [`crate::spectral::MAX_WAVELENGTHS`].
/// The scene's shared objects as the geometry takes them: prototype
/// facets in their own frame, placements into the centred frame.
fn shared_inputs(
    scene: &Scene,
    mats: &[MatSpec],
    origin: DVec3,
) -> Vec<crate::geometry::SharedInput> {
    let to_centred = glam::DAffine3::from_translation(-origin);
    scene
        .shared
        .iter()
        .map(|sh| {
            let material = scene.objects[sh.object].material;
            crate::geometry::SharedInput {
                facets: sh.prototype.iter().map(|f| f.vertices.clone()).collect(),
                normals: sh.prototype.iter().map(|f| f.normal()).collect(),
                placements: sh.placements.iter().map(|a| to_centred * *a).collect(),
                transmissive: mats[material].trans.is_some(),
                material: material as u32,
            }
        })
        .collect()
}

fn check_size(scene: &Scene, settings: &RenderSettings, groups: usize) -> Result<(), TraceError> {
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
    check_spectral_memory(scene, settings, n_wl)?;
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
    // Every per-pixel buffer of the render, measured (32 bytes per band
    // were counted, and a legal 8192² render aborted at 10.6 GB).
    let nb = scene.bands.len();
    let per_pixel = crate::render::render_bytes_per_pixel(n_wl as usize, nb, groups);
    let bytes = pixels as u64 * per_pixel;
    if let Some((avail, what)) = gloam_scene::available_memory() {
        if bytes > avail / 10 * 8 {
            let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
            return Err(TraceError::BadInput(format!(
                "a {w}×{h} render of {nb} band{} at {n_wl} wavelength samples{} needs about {:.1} GiB ({per_pixel} bytes a pixel), more than 80 % of the {:.1} GiB available (set by {what}): lower the resolution (camera size or resolution_scale), or coarsen spectral_step_nm",
                if nb == 1 { "" } else { "s" },
                if groups > 0 {
                    format!(" and {groups} light groups")
                } else {
                    String::new()
                },
                gib(bytes),
                gib(avail)
            )));
        }
    }
    Ok(())
}

/// Refuses a radiosity cache whose gather (`cache_texels` × `cache_rays`
/// rays) could not finish, and spectra that could not fit: the cache's
/// texels and every emitter hold one value per wavelength slot. Each
/// count had its own bound, their product none (4 194 304 texels ×
/// 65 536 rays ran for hours; a 0.001 nm step made the pilot's 1 024
/// texels ask for 19 GB and abort, and 20 000 lamps at 0.1 nm took
/// 0.5 GB). Counted for the caches known before the pilot: its own, and
/// the render's when `indirect = cache` asks for it; under `auto` the
/// render's cache is counted once the pilot chooses it
/// ([`check_render_cache_memory`]) — counted up front, a 0.01 nm step on
/// a scene the pilot sends to path tracing (1.9 GB) was refused as
/// needing 29 GiB.
fn check_spectral_memory(
    scene: &Scene,
    settings: &RenderSettings,
    n_wl: f64,
) -> Result<(), TraceError> {
    use crate::settings::Indirect;
    let requested = settings.requested_indirect();
    let pilot = requested != Indirect::Off
        && (requested == Indirect::Auto || settings.diffuse_bounces == 0);
    let render = matches!(requested, Indirect::Auto | Indirect::Cache);
    let (mut texels, mut rays) = (0.0f64, 0.0f64);
    if pilot {
        texels = f64::from(crate::plan::PILOT_TEXELS);
        rays = texels * f64::from(crate::plan::PILOT_RAYS);
    }
    if render {
        rays = rays.max(f64::from(settings.cache_texels) * f64::from(settings.cache_rays));
    }
    if requested == Indirect::Cache {
        texels = texels.max(f64::from(settings.cache_texels));
    }
    if rays > MAX_CACHE_RAYS {
        return Err(TraceError::BadInput(format!(
            "cache_texels = {} × cache_rays = {} is {rays:.3e} gather rays for the radiosity cache (limit {MAX_CACHE_RAYS:.3e}): lower one, or set indirect = path or off",
            settings.cache_texels, settings.cache_rays
        )));
    }
    // Advise only what lowers the count (the pilot's 1 024 texels are
    // there whatever cache_texels says; `indirect = path` was advised to
    // runs that had set it).
    let mut help = vec!["coarsen the step", "narrow the bands"];
    if requested == Indirect::Cache && f64::from(settings.cache_texels) >= texels && texels > 0.0 {
        help.push("lower cache_texels");
    }
    if pilot && settings.diffuse_bounces > 0 {
        help.push("set indirect = path (no pilot cache)");
    }
    if texels > 0.0 {
        help.push("set indirect = off");
    }
    let cache = if pilot && texels <= f64::from(crate::plan::PILOT_TEXELS) {
        "the pilot's radiosity cache"
    } else {
        "a radiosity cache"
    };
    refuse_spectral_bytes(scene, settings, n_wl, texels, cache, &help)
}

/// The memory check of [`check_spectral_memory`] for the render's cache
/// once the pilot has chosen it (`indirect = auto`), before it is built.
fn check_render_cache_memory(tracer: &Tracer, scene: &Scene) -> Result<(), TraceError> {
    let n_wl = tracer.wl.nm.len() as f64;
    let texels = f64::from(tracer.settings.cache_texels);
    let help = [
        "coarsen the step",
        "narrow the bands",
        "lower cache_texels",
        "set indirect = path or off",
    ];
    refuse_spectral_bytes(
        scene,
        &tracer.settings,
        n_wl,
        texels,
        "the render's radiosity cache",
        &help,
    )
}

/// Refuses `n_wl` wavelength slots for a cache of `texels` texels and the
/// scene's emitters past 80 % of the memory available.
fn refuse_spectral_bytes(
    scene: &Scene,
    settings: &RenderSettings,
    n_wl: f64,
    texels: f64,
    cache: &str,
    help: &[&str],
) -> Result<(), TraceError> {
    let emissive = |m: usize| scene.materials.get(m).is_some_and(|m| m.emission.is_some());
    let emitters =
        scene.point_sources.len() + scene.facets.iter().filter(|f| emissive(f.material)).count();
    let bytes =
        n_wl * (texels * CACHE_BYTES_PER_TEXEL_SLOT + emitters as f64 * EMITTER_BYTES_PER_SLOT);
    if let Some(avail) = gloam_scene::available_memory_bytes() {
        if bytes > avail as f64 * 0.8 {
            let gib = |b: f64| b / (1u64 << 30) as f64;
            return Err(TraceError::BadInput(format!(
                "{n_wl} wavelength samples (spectral_step_nm = {}) for {emitters} emitter{}{} need about {:.1} GiB, more than 80 % of the {:.1} GiB available: {}",
                gloam_spectra::num(settings.spectral_step_nm),
                if emitters == 1 { "" } else { "s" },
                if texels > 0.0 {
                    format!(" and {cache} of {texels} texels")
                } else {
                    String::new()
                },
                gib(bytes),
                gib(avail as f64),
                help.join(", or ")
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
    /// Camera rays aimed at the emitters' faces a pixel sees
    /// (`direct_view.rs`), and the straight-through passes they make.
    pub direct_view: u64,
}

impl RayCounts {
    pub fn add(&mut self, o: &RayCounts) {
        self.primary += o.primary;
        self.secondary += o.secondary;
        self.shadow += o.shadow;
        self.direct_view += o.direct_view;
    }
    pub fn total(&self) -> u64 {
        self.primary + self.secondary + self.shadow + self.direct_view
    }
}

/// A scene prepared for tracing with given settings: its [`World`] (the
/// tracer dereferences to it), the settings, and what the pilot's plan
/// chose — the method and bounces of interreflection, the effects left
/// out, the solved cache.
pub struct Tracer {
    pub(crate) world: std::sync::Arc<World>,
    pub(crate) settings: RenderSettings,
    /// The solved radiosity cache (`indirect = cache`).
    pub(crate) cache: Option<crate::indirect::Cache>,
    /// How interreflection was decided (method, pilot estimate, bounces).
    pub(crate) interreflection: crate::plan::InterreflectionDecision,
    /// Effects the plan leaves out because the pilot found them worth no
    /// more than the tolerance (skipped outright, unlike `settings.drop`,
    /// which computes and discards to keep the random numbers).
    pub(crate) skip: crate::settings::Dropped,
    /// Seconds spent building the BVH and spectral tables.
    pub(crate) build_seconds: f64,
    /// The scene's size and each preparation step's time and peak memory.
    pub(crate) preparation: Preparation,
    /// Told as preparation steps begin and end (`prepare_observed`).
    pub(crate) observer: Option<PrepObserver>,
    /// Path tracing's bounce guide toward hot facets (`guide.rs`; None
    /// unless `indirect = path` with `path_guide` and such facets exist).
    pub(crate) guide: Option<crate::guide::HotFacets>,
}

impl std::ops::Deref for Tracer {
    type Target = World;
    fn deref(&self) -> &World {
        &self.world
    }
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
            shared_facets: counts.shared_facets,
            point_sources: scene.point_sources.len(),
            ..Default::default()
        };
        let t0 = std::time::Instant::now();
        if scene.bands.is_empty() {
            return Err(TraceError::NoBands);
        }
        check_size(scene, settings, layers.map_or(0, |m| m.groups))?;
        let wl = Wavelengths::for_scene(scene, settings.spectral_step_nm);
        let mut world = build_world(scene, settings, wl, &mut prep, observer.as_ref())?;
        if let Some(map) = layers {
            world.assign_groups(map);
        }
        let mut tracer = Self {
            world: std::sync::Arc::new(world),
            settings: settings.clone(),
            cache: None,
            interreflection: Default::default(),
            skip: Default::default(),
            build_seconds: 0.0,
            preparation: prep,
            observer,
            guide: None,
        };
        let pilot_step = Preparation::begin("pilot", tracer.observer.as_ref());
        let plan = tracer.plan();
        if plan.piloted {
            tracer
                .preparation
                .end(pilot_step, tracer.observer.clone().as_ref());
        }
        if solve && plan.decision.method == "cache" {
            check_render_cache_memory(&tracer, scene)?;
        }
        tracer.adopt(plan, solve);
        if tracer.settings.path_guide && tracer.interreflection.method == "path" {
            tracer.guide = crate::guide::HotFacets::find(&tracer);
            tracer.interreflection.guided_facets = tracer.guide.as_ref().map(|g| g.len());
        }
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

    /// Diffuse albedo of facet `f` at every slot.
    pub(crate) fn kd(&self, f: u32) -> &[f64] {
        &self.mat_of(f).kd
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
                    if let Some(tr) = &self.mat_of(f).trans {
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
        self.irradiance_with(p, n, ignore, 1, usize::MAX, None, rng, c, out);
    }

    /// [`Tracer::irradiance`] with the light tree's part averaged over
    /// `tree_repeats` independent selections of at most `picks` emitters
    /// each (the radiosity cache's texels: the sky and Moon are sampled
    /// once, the many-light part, the noisy one, `tree_repeats` times, each
    /// of at most [`Tracer::cache_picks`]).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn irradiance_with(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        tree_repeats: u32,
        picks: usize,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let smooth = Smooth::Included;
        self.irradiance_split(
            p,
            n,
            ignore,
            tree_repeats,
            picks,
            strata,
            smooth,
            rng,
            c,
            out,
        );
    }

    /// The light tree's cap on emitters per selection in the radiosity
    /// cache's direct light (which averages several selections per texel
    /// anyway): `light_tree_branches`. Adaptive splitting's larger cap
    /// (`light_tree_max_picks`) is for the camera's vertices; in the cache
    /// it quadrupled night-town's preparation (19.7 → 72 s at quarter size)
    /// for no gain in the image's error.
    pub(crate) fn cache_picks(&self) -> usize {
        self.settings.light_tree_branches.max(1) as usize
    }

    /// [`Tracer::irradiance_with`], its smooth terms ([`Smooth`]) added to
    /// `out`, kept apart or left out: the radiosity cache reads the smooth
    /// light from its texels and recomputes the rest — the part that can
    /// change within a texel — where a gather ray lands. At most `picks`
    /// emitters per selection of the light tree.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn irradiance_split(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        tree_repeats: u32,
        picks: usize,
        strata: Option<LightStrata>,
        smooth: Smooth<'_>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let sharp_only = matches!(smooth, Smooth::Omitted);
        let routes = Term::ALL.map(|t| self.route(t, &smooth));
        // The sharp terms alone take a single pick (a gather ray's
        // reading, averaged over many).
        let branches = if sharp_only { 1 } else { picks };
        let mut bufs: Vec<&mut Light> = vec![out];
        if let Smooth::Apart(apart) = smooth {
            bufs.push(apart);
        }
        self.direct_light(
            p,
            n,
            ignore,
            tree_repeats,
            branches,
            strata,
            routes,
            rng,
            c,
            &mut bufs,
        );
    }

    /// The one table of what happens to a light term at a render's shading
    /// point ([`Route`]): a term the plan skips (`self.skip`), or a smooth
    /// term under [`Smooth::Omitted`], is not computed; a dropped one
    /// (`settings.drop`) is not computed if it draws no random numbers, and
    /// otherwise computed into a scratch buffer, so the render shares every
    /// other random number with the full one; the rest go to `out`
    /// (buffer 0), or the smooth ones to [`Smooth::Apart`]'s (buffer 1).
    fn route(&self, term: Term, smooth: &Smooth<'_>) -> Route {
        let (dropped, skipped) = (self.settings.drop.light(term), self.skip.light(term));
        let smooth_term = term.is_smooth();
        if skipped
            || (dropped && !term.draws_random())
            || (smooth_term && matches!(smooth, Smooth::Omitted))
        {
            Route::Skip
        } else if dropped {
            Route::Scratch
        } else if smooth_term && matches!(smooth, Smooth::Apart(_)) {
            Route::To(1)
        } else {
            Route::To(0)
        }
    }

    /// [`Tracer::irradiance`] split by what it comes from, for the effect
    /// plan's pilot: `[area sources, isotropic point sources, shaped point
    /// sources, Moon, sky dome]` (by [`Term`]), every term computed
    /// whatever `drop` and the plan say. The pilot stays cheap with many
    /// lamps: the tree's picks, each into its own term (unbiased per term,
    /// as each pick's weight is its own 1/pmf).
    pub(crate) fn irradiance_parts(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
    ) -> [Vec<f64>; Term::COUNT] {
        let mut parts: [Light; Term::COUNT] =
            std::array::from_fn(|_| Light::dark(self.wl.len(), 0));
        let routes = Term::ALL.map(|t| Route::To(t as usize));
        let mut bufs: Vec<&mut Light> = parts.iter_mut().collect();
        self.direct_light(p, n, ignore, 1, usize::MAX, None, routes, rng, c, &mut bufs);
        parts.map(Light::into_whole)
    }
}

/// The scene in the tracer's frame (scene-centred origin): materials on
/// the wavelength grid, the geometry and its BVH, the lights and their
/// tree, the camera and the sky — each step timed in `prep`.
fn build_world(
    scene: &Scene,
    settings: &RenderSettings,
    wl: Wavelengths,
    prep: &mut Preparation,
    observer: Option<&PrepObserver>,
) -> Result<World, TraceError> {
    // Scene-centred origin: centre of the box around facets, camera, lamps.
    let (origin, extent) = centre_of(scene);

    let mats: Vec<MatSpec> = scene
        .materials
        .iter()
        .map(|m| MatSpec::of(m, &wl))
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
    let step = Preparation::begin("bvh", observer);
    let geom = Geometry::new(origin, extent, &facet_verts, transmissive)
        .with_shared(shared_inputs(scene, &mats, origin));
    prep.end(step, observer);
    prep.triangles = geom.triangle_count();

    let step = Preparation::begin("light_structure", observer);

    let (area, facet_source) =
        area_sources(scene, settings, &wl, origin, &facet_verts, &facet_normal);

    let points = point_lights(scene, &wl, origin);
    let distant = crate::lights::distant_lights(scene, &wl);
    let light_tree = build_light_tree(&area, &points, &wl, settings, scene.meters_per_unit, extent);

    let camera = scaled_camera(scene, settings, origin);
    prep.area_emitters = area.len();
    prep.end(step, observer);
    let ones = vec![1.0; wl.len()];
    let step = Preparation::begin("sky", observer);
    let sky = build_sky(scene, settings, &wl)?;
    prep.end(step, observer);
    let view = if settings.drop.direct_view {
        Default::default()
    } else {
        area_footprints(&camera, &area)
    };
    Ok(World {
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
        distant,
        camera,
        ones,
        sky,
        light_tree,
        layers: None,
        view,
    })
}

/// The scene's camera moved into the tracer's frame and scaled to the
/// render's resolution.
fn scaled_camera(scene: &Scene, settings: &RenderSettings, origin: DVec3) -> gloam_scene::Camera {
    let mut camera = scene.camera.clone();
    camera.position -= origin;
    camera.look_at -= origin;
    if settings.resolution_scale != 1.0 {
        let scale = |n: u32| ((n as f64 * settings.resolution_scale).round() as u32).max(1);
        camera.width = scale(camera.width);
        camera.height = scale(camera.height);
    }
    camera
}
