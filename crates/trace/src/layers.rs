//! Light layers (`gloam render --layers`): one radiance image per light
//! group, whose sum is the ordinary render.
//!
//! How: radiance is linear in each emitter's emission. Each group's layer
//! is rendered by the same tracer with every other group's emission set to
//! zero — the light tree, the effect plan and the sample counts stay those
//! of the whole scene, so every layer draws exactly the random numbers of
//! the ordinary render, and each term a path adds (a light sample, an
//! emitter or the sky seen along a ray, a cached interreflection) lands,
//! unchanged, in exactly one layer (`x · 0 = 0` adds nothing in the
//! others). The interreflection cache is solved once per group with the
//! whole scene's number of bounces and tail ratio, so the solve is one
//! linear map for every group. The layers therefore sum to the ordinary
//! image up to floating-point summation order (relative ~1e-15; the test
//! `layers_sum_to_the_ordinary_render` holds it to 1e-9).
//!
//! Cost: one render per group (plus one cache solve per group when the
//! plan caches interreflection) — not yet the single pass that carries a
//! radiance vector per group through `trace`. Adaptive sampling is
//! refused: its sample counts depend on the values, so the layers would
//! sample differently from the whole.

use gloam_scene::Scene;

use crate::indirect::CacheSize;
use crate::{RenderOutput, TraceError, Tracer};

/// Which light group each of a tracer's emitters belongs to.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerMap {
    /// Number of groups.
    pub groups: usize,
    /// Per emissive facet, by facet index in the scene.
    area_by_facet: Vec<(u32, usize)>,
    /// Per point source (placements expanded).
    point: Vec<usize>,
    moon: Option<usize>,
    sky: Option<usize>,
}

#[derive(Debug, thiserror::Error)]
pub enum LayerError {
    #[error(
        "--layers with adaptive sampling (target_error): the sample counts would follow each layer's values, not the whole render's; give a fixed --spp"
    )]
    Adaptive,
    #[error(
        "the scene has no light groups (no emissive object, point source or [sky]): nothing to split into layers"
    )]
    NoGroups,
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
            moon: lg.moon,
            sky: lg.sky,
        }
    }

    fn area_group(&self, facet: u32) -> Option<usize> {
        self.area_by_facet
            .binary_search_by_key(&facet, |&(f, _)| f)
            .ok()
            .map(|i| self.area_by_facet[i].1)
    }
}

/// The tracer's emission as prepared, to restore after the layers.
struct Emission {
    area: Vec<Vec<f64>>,
    points: Vec<Vec<f64>>,
    sky: Option<(Vec<f64>, crate::sky_light::RadianceTable)>,
}

impl Tracer {
    /// One [`RenderOutput`] per group of `map` (in its order), for image
    /// rows `rows`; see the module docs. The tracer is left as it was.
    pub fn render_layers(
        &mut self,
        map: &LayerMap,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Vec<RenderOutput>, LayerError> {
        if self.settings.target_error.is_some() {
            return Err(LayerError::Adaptive);
        }
        if map.groups == 0 {
            return Err(LayerError::NoGroups);
        }
        let saved = Emission {
            area: self.area.iter().map(|s| s.radiance.clone()).collect(),
            points: self.points.iter().map(|p| p.intensity.clone()).collect(),
            sky: self
                .sky
                .as_ref()
                .map(|s| (s.moon_en.clone(), s.table.clone())),
        };
        let cache = self.cache.take();
        let result = self.layers_with(map, &saved, cache.as_ref(), rows, progress, stop);
        self.restore(&saved);
        self.cache = cache;
        result
    }

    fn layers_with(
        &mut self,
        map: &LayerMap,
        saved: &Emission,
        cache: Option<&crate::indirect::Cache>,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Vec<RenderOutput>, LayerError> {
        let mut out = Vec::with_capacity(map.groups);
        for g in 0..map.groups {
            self.restore(saved);
            self.keep_only(map, g);
            if let Some(c) = cache {
                let size = CacheSize {
                    texels: self.settings.cache_texels,
                    rays: self.settings.cache_rays,
                    tolerance: self.settings.cache_tolerance,
                    max_iterations: 200,
                    direct_cell_mean: false,
                };
                let fixed = (c.summary.iterations, c.summary.bounce_ratio);
                self.cache = Some(self.build_cache_series(size, Some(fixed)));
            }
            out.push(self.render_rows_until(rows.clone(), progress, stop)?);
        }
        Ok(out)
    }

    fn restore(&mut self, saved: &Emission) {
        for (s, r) in self.area.iter_mut().zip(&saved.area) {
            s.radiance.clone_from(r);
        }
        for (p, i) in self.points.iter_mut().zip(&saved.points) {
            p.intensity.clone_from(i);
        }
        if let (Some(sky), Some((moon, table))) = (self.sky.as_mut(), &saved.sky) {
            sky.moon_en.clone_from(moon);
            sky.table = table.clone();
        }
    }

    /// Zero the emission of every emitter outside group `g`.
    fn keep_only(&mut self, map: &LayerMap, g: usize) {
        for s in self.area.iter_mut() {
            if map.area_group(s.facet) != Some(g) {
                s.radiance.fill(0.0);
            }
        }
        for (i, p) in self.points.iter_mut().enumerate() {
            if map.point.get(i) != Some(&g) {
                p.intensity.fill(0.0);
            }
        }
        if let Some(sky) = self.sky.as_mut() {
            if map.moon != Some(g) {
                sky.moon_en.fill(0.0);
            }
            if map.sky != Some(g) {
                sky.table.zero();
            }
        }
    }
}
