//! Light layers (`gloam render --layers`): one radiance image per light
//! group, whose sum is the ordinary render, from one pass.
//!
//! How: radiance is linear in each emitter's emission, and every term a
//! path adds comes from one emitter. So each path is traced once, exactly
//! as in the ordinary render (same light tree, effect plan, samples and
//! random numbers), and beside its spectral light it carries one part per
//! light group (`light.rs`): a light sample of a point source, an area
//! source, the Moon or the sky dome, and an emitter or the sky seen along
//! a ray, are added to the whole and to their emitter's group; throughput
//! and reflectance apply to every part alike. The rest:
//!
//! - *The analytic estimator's clamp* of a negative penumbra sum at a
//!   shading point is taken on the whole, as always; each group's part
//!   follows it (scaled so the parts stay non-negative and sum to the
//!   clamped whole; `Light::add_clamped`), so the layers sum to the whole
//!   there too.
//! - *The interreflection cache* is gathered once: its texels' direct
//!   irradiance split by group, its rays traced once, and only the bounce
//!   series solved again per group, with the whole scene's number of
//!   bounces and tail ratio (the same linear map for every group), so the
//!   groups' caches sum to the whole's. The groups' series are solved
//!   beside the whole's in one pass over the operator per bounce (no
//!   rays; its cost grows with the groups, memory-bound on the office).
//!   A tracer not prepared for the groups solves its cache again.
//! - *Point sources seen directly* are deposited in their group's layer.
//!
//! The whole is bit-identical to the ordinary render (the same arithmetic
//! on the same numbers); the layers sum to it up to floating-point
//! summation order (the test `layers_sum_to_the_ordinary_render` holds it
//! to 1e-12 of the peak). Adaptive sampling (`target_error`) works: the
//! sample counts follow the whole's errors and every layer gets the same
//! samples.
//!
//! Cost: one pass with more additions per term (each group a term
//! reaches) and per cache reading (every lit group), plus the groups'
//! bounce series — not one render per group. Measured, CPU time over a
//! plain render: office (2 groups, cache-heavy) 1.8–1.9×, night lamps (5
//! groups) 1.3–1.4×, street-switch-on at 640 × 480 (3 groups) 1.2–1.3× (one
//! render per group before: 3.1× office, 5.4× night lamps). At most
//! [`MAX_LAYER_GROUPS`] groups, and their images and cache must fit in
//! memory.

use gloam_scene::Scene;

use crate::prep::PrepObserver;
use crate::{RenderOutput, RenderSettings, TraceError, Tracer};

/// Most light groups a layered render takes: each group costs per pixel
/// and band 32 bytes (its sums while sampling, its radiance and error
/// after), and its share of the cache; beyond this, merge sources with
/// `group = "…"`.
pub const MAX_LAYER_GROUPS: usize = 64;

/// Which light group each of a tracer's emitters belongs to.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerMap {
    /// Number of groups.
    pub groups: usize,
    /// Per emissive facet, by facet index in the scene.
    area_by_facet: Vec<(u32, usize)>,
    /// Per point source (placements expanded).
    point: Vec<usize>,
    /// Per distant source.
    distant: Vec<usize>,
    moon: Option<usize>,
    sky: Option<usize>,
    sun: Option<usize>,
    twilight: Option<usize>,
}

#[derive(Debug, thiserror::Error)]
pub enum LayerError {
    #[error(
        "the scene has no light groups (no emissive object, point source or [sky]): nothing to split into layers"
    )]
    NoGroups,
    #[error(
        "the scene has {0} light groups; --layers takes at most {MAX_LAYER_GROUPS}: merge sources into groups with group = \"NAME\" on point sources, objects or materials"
    )]
    TooManyGroups(usize),
    #[error(
        "--layers with {groups} light groups over a {width}×{height} image of {bands} bands needs about {need_gib:.1} GiB, more than 80 % of the {avail_gib:.1} GiB available: merge groups (group = \"NAME\") or lower resolution_scale"
    )]
    Memory {
        groups: usize,
        width: u32,
        height: u32,
        bands: usize,
        need_gib: f64,
        avail_gib: f64,
    },
    #[error(transparent)]
    Trace(#[from] TraceError),
}

impl LayerMap {
    /// The groups of `scene` ([`Scene::light_groups`]) for its emitters.
    pub fn of(scene: &Scene) -> Self {
        let lg = &scene.light_groups;
        let mut area_by_facet = Vec::new();
        for (o, g) in scene.objects.iter().zip(&lg.object) {
            if let Some(g) = g {
                area_by_facet.extend(o.facets().map(|f| (f as u32, *g)));
            }
        }
        area_by_facet.sort_unstable();
        let mut point = Vec::with_capacity(scene.point_sources.len());
        for (t, g) in scene.point_source_groups.iter().zip(&lg.point_table) {
            point.extend(std::iter::repeat_n(*g, t.instances));
        }
        Self {
            groups: lg.groups.len(),
            area_by_facet,
            point,
            distant: lg.distant.clone(),
            moon: lg.moon,
            sky: lg.sky,
            sun: lg.sun,
            twilight: lg.twilight,
        }
    }

    fn area_group(&self, facet: u32) -> Option<usize> {
        self.area_by_facet
            .binary_search_by_key(&facet, |&(f, _)| f)
            .ok()
            .map(|i| self.area_by_facet[i].1)
    }

    /// Refuses a map with no group or more than [`MAX_LAYER_GROUPS`].
    fn check(&self) -> Result<(), LayerError> {
        match self.groups {
            0 => Err(LayerError::NoGroups),
            g if g > MAX_LAYER_GROUPS => Err(LayerError::TooManyGroups(g)),
            _ => Ok(()),
        }
    }
}

impl Tracer {
    /// As [`Tracer::prepare_observed`] (solving the cache), for layered
    /// renders split by `map`: the emitters carry their groups and the
    /// interreflection cache is solved per group from its one gather, so
    /// [`Tracer::render_layered`] need not solve it again.
    pub fn prepare_layered(
        scene: &Scene,
        settings: &RenderSettings,
        observer: Option<PrepObserver>,
        map: &LayerMap,
    ) -> Result<Self, LayerError> {
        map.check()?;
        Ok(Self::prepare_inner(
            scene,
            settings,
            true,
            observer,
            Some(map),
        )?)
    }

    /// One [`RenderOutput`] per group of `map` (in its order), for image
    /// rows `rows` (see [`Tracer::render_layered`], of which these are
    /// the layers).
    pub fn render_layers(
        &mut self,
        map: &LayerMap,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Vec<RenderOutput>, LayerError> {
        Ok(self.render_layered(map, rows, progress, stop)?.1)
    }

    /// The ordinary render of image rows `rows` — bit-identical to
    /// [`Tracer::render_rows_until`] — and one [`RenderOutput`] per group of
    /// `map` (in its order), from the same single pass; see the module
    /// docs. A tracer not prepared for `map` ([`Tracer::prepare_layered`])
    /// is switched to it here, solving its cache again (the same whole,
    /// now split by group); an ordinary render afterwards is unchanged.
    pub fn render_layered(
        &mut self,
        map: &LayerMap,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<(RenderOutput, Vec<RenderOutput>), LayerError> {
        self.render_layered_goal(map, rows, progress, stop, None)
    }

    /// [`Tracer::render_layered`] of the whole image sampled to a
    /// per-pixel `goal` (as [`Tracer::render_to_goal`]), which is given
    /// each group's image too ([`crate::PixelGoal::bounds_layered`]): a
    /// sequence's `--target-error camera`.
    pub fn render_layered_to_goal(
        &mut self,
        map: &LayerMap,
        goal: &dyn crate::PixelGoal,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<(RenderOutput, Vec<RenderOutput>), LayerError> {
        let rows = 0..self.image_size().1;
        self.render_layered_goal(map, rows, progress, stop, Some(goal))
    }

    fn render_layered_goal(
        &mut self,
        map: &LayerMap,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
        goal: Option<&dyn crate::PixelGoal>,
    ) -> Result<(RenderOutput, Vec<RenderOutput>), LayerError> {
        map.check()?;
        self.check_layer_memory(map.groups, rows.len())?;
        if self.layers.as_ref() != Some(map) {
            // The world is this tracer's alone here (a copy only if a
            // pilot's probe still shared it).
            std::sync::Arc::make_mut(&mut self.world).assign_groups(map);
            if self.cache.is_some() {
                let size = self.render_cache_size();
                self.cache = Some(self.build_cache_split(size, map.groups));
            }
        }
        Ok(self.render_split(rows, progress, stop, map.groups, goal)?)
    }

    /// Refuses layers whose images and cache would not fit: per pixel and
    /// band and group 32 bytes, plus per group the cache's radiance.
    fn check_layer_memory(&self, groups: usize, rows: usize) -> Result<(), LayerError> {
        let (width, height) = self.image_size();
        let bands = self.wl.band_names.len();
        let pixels = width as f64 * rows.min(height as usize) as f64;
        let texels = self.cache.as_ref().map_or(0, |c| c.summary.texels) as f64;
        let bytes =
            groups as f64 * (pixels * bands as f64 * 32.0 + texels * self.wl.len() as f64 * 16.0);
        let gib = |b: f64| b / (1u64 << 30) as f64;
        match gloam_scene::available_memory_bytes() {
            Some(avail) if bytes > avail as f64 * 0.8 => Err(LayerError::Memory {
                groups,
                width,
                height,
                bands,
                need_gib: gib(bytes),
                avail_gib: gib(avail as f64),
            }),
            _ => Ok(()),
        }
    }

    /// The number of light groups the emitters carry (0: none assigned).
    pub(crate) fn layer_groups(&self) -> usize {
        self.layers.as_ref().map_or(0, |m| m.groups)
    }
}

impl crate::tracer::World {
    /// Gives every emitter its group of `map` (None where it has none).
    pub(crate) fn assign_groups(&mut self, map: &LayerMap) {
        for s in self.area.iter_mut() {
            s.group = map.area_group(s.facet);
        }
        for (i, p) in self.points.iter_mut().enumerate() {
            p.group = map.point.get(i).copied();
        }
        for (i, d) in self.distant.iter_mut().enumerate() {
            d.group = map.distant.get(i).copied();
        }
        if let Some(sky) = self.sky.as_mut() {
            sky.moon_group = map.moon;
            sky.sky_group = map.sky;
            if let Some(sun) = sky.sun.as_mut() {
                sun.group = map.sun;
            }
            sky.twilight_group = map.twilight;
        }
        self.layers = Some(map.clone());
    }
}
