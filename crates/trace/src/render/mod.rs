//! The parallel render loop, point sources seen directly, and probes.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::DVec3;
use gloam_scene::Scene;
use ndarray::Array3;
use rayon::prelude::*;
use serde::Serialize;

use crate::direct_view::ViewTerm;
use crate::light::Light;
use crate::settings::{LightStrataMode, RenderSettings};
use crate::tracer::{
    LightStrata, PathState, RayCounts, TraceError, Tracer, latin_hypercube, stream,
};

mod estimate;
mod probe;
#[cfg(test)]
mod tests;

pub use estimate::*;

/// A point source seen directly: pixel column and row, band radiances,
/// and its light group (`--layers`).
pub(crate) type Deposit = (u32, u32, Vec<f64>, Option<usize>);

/// Side of the square image tiles handed to rayon.
pub const TILE: u32 = 16;

/// Random-stream domains (so pixels and probes never share a stream).
const DOMAIN_PIXEL: u64 = 1;
const DOMAIN_PROBE: u64 = 2;
const DOMAIN_BATCH: u64 = 3;
const DOMAIN_REPLICATE: u64 = 4;

/// Timings and ray counts of a render.
#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    pub width: u32,
    pub height: u32,
    pub bands: usize,
    /// Wavelength slots carried (continuum nodes + emission lines).
    pub wavelengths: usize,
    pub emission_lines: usize,
    pub triangles: usize,
    pub area_sources: usize,
    pub point_sources: usize,
    pub threads: usize,
    pub prepare_seconds: f64,
    pub trace_seconds: f64,
    pub rays: RayCounts,
    pub rays_per_second: f64,
    /// How interreflection was decided and computed.
    pub interreflection: crate::plan::InterreflectionDecision,
    /// What the render took from the `[sky]` block (None: no sky light).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky: Option<crate::sky_light::SkySummary>,
    /// The scene's size and each preparation step's time and peak memory.
    pub preparation: crate::prep::Preparation,
}

/// A rendered radiance image.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Band radiance at the entrance pupil, W m⁻² sr⁻¹, band × row × column.
    pub radiance: Array3<f64>,
    /// Estimated standard error of each pixel's radiance, same units and
    /// shape (from the per-sample variance; point sources seen directly
    /// are exact and add none).
    pub std_error: Array3<f64>,
    /// Camera samples each pixel got.
    pub spp: ndarray::Array2<u32>,
    /// What the sampling achieved.
    pub error: ErrorSummary,
    pub band_names: Vec<String>,
    pub settings: RenderSettings,
    pub stats: RenderStats,
}

/// What `gloam probe --point` reports.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ProbeResult {
    pub band: String,
    pub irradiance_w_m2: f64,
    pub std_error_w_m2: f64,
    /// The radiance the surface at the point reflects (Lambertian part,
    /// of the same light as `irradiance_w_m2`), when the point lies on a
    /// facet.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radiance_w_m2_sr: Option<f64>,
    /// The direct part of `irradiance_w_m2`.
    pub direct_irradiance_w_m2: f64,
    /// The interreflected part, when the render would simulate it (the
    /// effect plan's decision).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub indirect_irradiance_w_m2: Option<f64>,
    /// Which light terms the figures include, in words.
    pub terms: String,
}

/// Gather directions per probe repetition for interreflection (at least).
pub const PROBE_GATHER_RAYS: usize = 64;

/// Renders `scene` with `settings` (see [`Tracer::render`]).
pub fn render(scene: &Scene, settings: &RenderSettings) -> Result<RenderOutput, TraceError> {
    Tracer::new(scene, settings)?.render(&|_, _| {})
}

/// Irradiance at a world-space point (see [`Tracer::probe_point`]).
pub fn probe_point(
    scene: &Scene,
    settings: &RenderSettings,
    point: DVec3,
    normal: DVec3,
    band: Option<&str>,
    samples: u32,
) -> Result<ProbeResult, TraceError> {
    Tracer::new(scene, settings)?.probe_point(point, normal, band, samples)
}

fn with_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> T {
    match threads {
        Some(n) => match rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
        {
            Ok(pool) => pool.install(f),
            Err(_) => f(),
        },
        None => f(),
    }
}

impl Tracer {
    /// Spectral radiance of pixel `(col, row)` averaged over `spp` camera
    /// samples (without point sources seen directly): the first batch of
    /// [`Tracer::render`].
    fn pixel_spectral(&self, col: u32, row: u32, c: &mut RayCounts) -> Vec<f64> {
        let mut est = PixelEstimate::new(self.wl.len(), self.wl.band_names.len(), 0);
        self.pixel_batch(
            col,
            row,
            0,
            self.settings.spp.max(1) as usize,
            false,
            &mut est,
            c,
        );
        let inv = 1.0 / est.n.max(1) as f64;
        est.spectral.iter().map(|a| a * inv).collect()
    }

    /// Adds batch `batch` of `n` camera samples (Latin-hypercube stratified
    /// in the pixel) to the pixel's estimate. Each batch has its own random
    /// stream, so a pixel's result depends only on which batches it got.
    /// `replicated` (adaptive renders) splits the batch into two halves of
    /// `⌈n/2⌉` samples, replicates A and B, each with its own streams and
    /// Sobol scramble (see [`stratification`]).
    #[allow(clippy::too_many_arguments)]
    fn pixel_batch(
        &self,
        col: u32,
        row: u32,
        batch: u32,
        n: usize,
        replicated: bool,
        est: &mut PixelEstimate,
        c: &mut RayCounts,
    ) {
        if replicated {
            for r in 0..2 {
                self.pixel_samples(col, row, batch, n.div_ceil(2), Some(r), est, c);
            }
        } else {
            self.pixel_samples(col, row, batch, n, None, est, c);
        }
    }

    /// `n` samples of batch `batch` for one stream: the pixel's own
    /// (`replicate` None) or replicate A/B's.
    #[allow(clippy::too_many_arguments)]
    fn pixel_samples(
        &self,
        col: u32,
        row: u32,
        batch: u32,
        n: usize,
        replicate: Option<usize>,
        est: &mut PixelEstimate,
        c: &mut RayCounts,
    ) {
        let cam = &self.camera;
        let idx = row as u64 * cam.width as u64 + col as u64;
        let domain = match replicate {
            None if batch == 0 => DOMAIN_PIXEL,
            None => DOMAIN_BATCH ^ ((batch as u64) << 32),
            Some(r) => DOMAIN_REPLICATE ^ ((r as u64 + 1) << 8) ^ ((batch as u64) << 32),
        };
        let mut rng = stream(self.settings.seed, domain, idx);
        let mut sub = Vec::with_capacity(n);
        latin_hypercube(n, &mut rng, &mut sub);
        let mut acc = Light::dark(self.wl.len(), est.groups);
        // Final-gather directions: one Owen-scrambled Sobol sequence per
        // pixel (per replicate), continued across batches (the samples it
        // has so far), each sample taking the next block of `gather_rays`
        // points. (Only when there is a cache to gather from.)
        let k = if self.cache.is_some() {
            self.settings.gather_rays as usize
        } else {
            0
        };
        let salt = replicate.map_or(0, |r| (r as u64 + 1) << 40);
        let scramble =
            crate::tracer::mix64(self.settings.seed ^ crate::tracer::mix64(idx ^ 0x6A7E ^ salt));
        let mut pts: Vec<[f64; 2]> = Vec::with_capacity(k);
        // The camera vertex's light samples: their own scramble per pixel
        // (and replicate), the sample index continuing across batches.
        let strata = (self.settings.light_strata == LightStrataMode::Sobol)
            .then(|| crate::tracer::mix64(scramble ^ 0x005E_ED11_6475));
        for [sx, sy] in sub {
            acc.clear();
            pts.clear();
            let so_far = replicate.map_or(est.n, |r| est.rep_n[r]);
            let first = so_far as u64 * k as u64;
            pts.extend(
                (0..k as u64).map(|i| crate::sampling::sobol_owen_2d((first + i) as u32, scramble)),
            );
            let d = cam.pixel_direction(col as f64 + sx, row as f64 + sy);
            c.primary += 1;
            est.sees_emitter |= self.trace(
                cam.position,
                d,
                u32::MAX,
                &self.ones,
                PathState::camera(self.settings.diffuse_bounces, true),
                (k > 0).then_some(pts.as_slice()),
                strata.map(|scramble| LightStrata {
                    scramble,
                    sample: so_far,
                }),
                &mut rng,
                c,
                &mut acc,
            );
            est.add(&acc.whole, &self.wl.integrate(&acc.whole), replicate);
            for g in 0..est.groups {
                if let Some(part) = acc.part(g) {
                    est.add_layer(g, &self.wl.integrate(part));
                }
            }
        }
    }

    /// The pixels that show a point source directly (unoccluded, facing
    /// the camera, in the field of view): emitters for every mask of
    /// pixels "that see no emitter" (the pilot's share, `gloam bench`).
    pub fn point_source_pixels(&self) -> Vec<(u32, u32)> {
        let mut c = RayCounts::default();
        self.point_deposits(&mut c)
            .into_iter()
            .map(|(col, row, _, _)| (col, row))
            .collect()
    }

    /// Point sources seen directly: `(col, row, band radiances, light
    /// group)` for each unoccluded source in the field of view (see the
    /// crate docs).
    pub(crate) fn point_deposits(&self, c: &mut RayCounts) -> Vec<Deposit> {
        let cam = &self.camera;
        let (_, _, fwd) = cam.basis();
        let mut out = Vec::new();
        for l in &self.points {
            let Some((px, py)) = cam.project(l.pos) else {
                continue;
            };
            if !(px >= 0.0 && py >= 0.0 && px < cam.width as f64 && py < cam.height as f64) {
                continue;
            }
            let v = cam.position - l.pos;
            let r = v.length();
            if r <= 0.0 {
                continue;
            }
            let w = v / r;
            let shape = l.shape_toward(w);
            if shape == 0.0 {
                continue;
            }
            // Towards the lamp from the camera.
            let vis = self.shadow(cam.position, -w, r, [u32::MAX, u32::MAX], c);
            let Some(tau) = vis else { continue };
            // The exact solid angle of that pixel: its corners on the
            // unit-distance image plane.
            let (c0, r0) = (px.floor(), py.floor());
            let corner = |x: f64, y: f64| {
                let d = cam.pixel_direction(x, y);
                cam.position + d / d.dot(fwd)
            };
            let quad = [
                corner(c0, r0),
                corner(c0 + 1.0, r0),
                corner(c0 + 1.0, r0 + 1.0),
                corner(c0, r0 + 1.0),
            ];
            let omega = crate::closed_form::polygon_solid_angle(cam.position, &quad);
            if omega.is_nan() || omega <= 0.0 {
                continue;
            }
            let r_m = r * self.mpu;
            let g = shape / (r_m * r_m * omega);
            let spec: Vec<f64> = match tau {
                None => l.intensity.iter().map(|i| g * i).collect(),
                Some(t) => l.intensity.iter().zip(&t).map(|(i, t)| g * i * t).collect(),
            };
            out.push((px as u32, py as u32, self.wl.integrate(&spec), l.group));
        }
        out
    }

    /// Renders the whole image. `progress(done, total)` is called as tiles
    /// finish (from worker threads); with `target_error`, further rounds
    /// report on the pixels still sampling.
    ///
    /// Every pixel first gets one batch of `spp` samples. With
    /// `target_error = E`, pixels whose estimated relative standard error
    /// (see [`ErrorSummary`]) exceeds `E` get further batches, sized from
    /// the error so far (at most 4× their count per round, at least
    /// [`MIN_ADAPTIVE_SPP`] in all, at most `max_spp`), until every pixel
    /// meets `E` or its cap. Batches have their own random streams, so the
    /// image is bit-identical at any thread count.
    pub fn render(&self, progress: &(dyn Fn(u64, u64) + Sync)) -> Result<RenderOutput, TraceError> {
        self.render_rows(0..self.camera.height, progress)
    }

    /// The image size `(width, height)` in pixels (after `resolution_scale`).
    pub fn image_size(&self) -> (u32, u32) {
        (self.camera.width, self.camera.height)
    }

    /// Renders only image rows `rows` (all columns): the output arrays hold
    /// those rows, and every pixel is bit-identical to the same pixel of
    /// [`Tracer::render`], because each pixel's random streams are keyed by
    /// its index in the whole image. So separately rendered row bands
    /// reassemble into the untiled image exactly. Adaptive sampling
    /// (`target_error`) scales its dark-pixel floor by the image mean, which
    /// a band does not know, so it is refused for a partial image.
    pub fn render_rows(
        &self,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<RenderOutput, TraceError> {
        self.render_rows_until(rows, progress, &|| false)
    }

    /// [`Tracer::render_rows`] that a caller can stop: `stop()` is polled
    /// before every tile and every adaptive round (from worker threads);
    /// once it returns true the remaining work is skipped and the render
    /// returns [`TraceError::Interrupted`] (so a host such as the Python
    /// package can honour Ctrl-C within one tile's time). A render that
    /// is not stopped is bit-identical to [`Tracer::render_rows`].
    pub fn render_rows_until(
        &self,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<RenderOutput, TraceError> {
        Ok(self.render_split(rows, progress, stop, 0)?.0)
    }

    /// [`Tracer::render_rows_until`], and with `groups` > 0 (`--layers`,
    /// the emitters' groups assigned) one output per light group from the
    /// same samples: each pixel's samples split by the group of the
    /// emitter each term came from (`light.rs`). The whole is bit-identical
    /// to an unsplit render; the sample counts (adaptive or not) are the
    /// whole's. A layer's standard error is its per-sample one (times the
    /// whole's measured stratification factor, adaptive renders); its spp,
    /// error summary and statistics are the whole's.
    pub(crate) fn render_split(
        &self,
        rows: std::ops::Range<u32>,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
        groups: usize,
    ) -> Result<(RenderOutput, Vec<RenderOutput>), TraceError> {
        let stopped = std::sync::atomic::AtomicBool::new(false);
        let halt = || {
            if stopped.load(Ordering::Relaxed) || stop() {
                stopped.store(true, Ordering::Relaxed);
                return true;
            }
            false
        };
        let cam = &self.camera;
        let (w, full_h) = (cam.width, cam.height);
        if rows.start >= rows.end || rows.end > full_h {
            return Err(TraceError::BadInput(format!(
                "rows {}..{} are not a non-empty part of the image's 0..{full_h}",
                rows.start, rows.end
            )));
        }
        let partial = rows.start != 0 || rows.end != full_h;
        if partial && self.settings.target_error.is_some() {
            return Err(TraceError::BadInput(
                "target_error needs the whole image (its dark-pixel floor is relative to the image mean); render a tile at a fixed spp".into(),
            ));
        }
        let row0 = rows.start;
        let h = rows.end - rows.start;
        let nb = self.wl.band_names.len();
        let nwl = self.wl.len();
        let npix = w as usize * h as usize;
        let t0 = Instant::now();
        let threads = self.settings.threads;
        let spp = self.settings.spp.max(1);
        // Adaptive renders sample in two replicates, so their error
        // estimate is measured rather than assumed (see `stratification`).
        let replicated = self.settings.target_error.is_some();
        let done = AtomicU64::new(0);
        let (ests, views, rays, rounds, threads_used) = with_pool(threads, || {
            // Round 0: every pixel, one batch of spp, tile by tile.
            let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE))
                .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, row0 + ty * TILE)))
                .collect();
            let total = tiles.len() as u64;
            type Pixel = (usize, PixelEstimate, Option<ViewTerm>);
            let res: Vec<(Vec<Pixel>, RayCounts)> = tiles
                .par_iter()
                .map(|&(x0, y0)| {
                    if halt() {
                        return (Vec::new(), RayCounts::default());
                    }
                    let x1 = (x0 + TILE).min(w);
                    let y1 = (y0 + TILE).min(rows.end);
                    let mut c = RayCounts::default();
                    let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
                    for row in y0..y1 {
                        if row > y0 && halt() {
                            break;
                        }
                        for col in x0..x1 {
                            let mut e = PixelEstimate::new(nwl, nb, groups);
                            // Emitters seen directly: computed apart, and
                            // whether the pixel sees one decided by them,
                            // not by its samples (`direct_view.rs`).
                            let view = self.view_term(col, row, &mut c);
                            e.sees_emitter = view
                                .as_ref()
                                .is_some_and(|v| v.bands.iter().any(|&x| x > 0.0));
                            self.pixel_batch(col, row, 0, spp as usize, replicated, &mut e, &mut c);
                            out.push(((row - row0) as usize * w as usize + col as usize, e, view));
                        }
                    }
                    let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                    progress(n, total);
                    (out, c)
                })
                .collect();
            let mut rays = RayCounts::default();
            let mut ests: Vec<Option<PixelEstimate>> = vec![None; npix];
            let mut views: Vec<Option<ViewTerm>> = (0..npix).map(|_| None).collect();
            for (tile, c) in res {
                rays.add(&c);
                for (i, e, v) in tile {
                    ests[i] = Some(e);
                    views[i] = v;
                }
            }
            let mut ests: Vec<PixelEstimate> = ests
                .into_iter()
                .map(|e| e.unwrap_or_else(|| PixelEstimate::new(nwl, nb, groups)))
                .collect();
            let mut rounds = 1u32;
            if let Some(target) = self.settings.target_error {
                let floor = band_floor(&ests, &views, nb);
                let cap = self.settings.max_spp.max(spp);
                loop {
                    if halt() {
                        break;
                    }
                    let (factor, _) = stratification(&ests, &floor);
                    let stated = stated_std_errors(&ests, w as usize, &factor, &floor, true);
                    let rel: Vec<f64> = ests
                        .par_iter()
                        .enumerate()
                        .map(|(i, e)| stated_rel_error(e, &stated[i * nb..(i + 1) * nb], &floor))
                        .collect();
                    let work = allocate(&ests, &rel, target, cap);
                    if work.is_empty() {
                        break;
                    }
                    let total = work.len() as u64;
                    let done = AtomicU64::new(0);
                    let batch = rounds;
                    let updated: Vec<(usize, PixelEstimate, RayCounts)> = work
                        .par_iter()
                        .map(|&(i, add)| {
                            let mut c = RayCounts::default();
                            let mut e = ests[i].clone();
                            let (col, row) =
                                ((i % w as usize) as u32, row0 + (i / w as usize) as u32);
                            self.pixel_batch(col, row, batch, add as usize, true, &mut e, &mut c);
                            let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                            if n % 1024 == 0 || n == total {
                                progress(n, total);
                            }
                            (i, e, c)
                        })
                        .collect();
                    for (i, e, c) in updated {
                        ests[i] = e;
                        rays.add(&c);
                    }
                    rounds += 1;
                    if rounds > 64 {
                        break;
                    }
                }
            }
            (ests, views, rays, rounds, rayon::current_num_threads())
        });
        if stopped.load(Ordering::Relaxed) {
            return Err(TraceError::Interrupted);
        }
        let mut rays = rays;
        let mut radiance = Array3::<f64>::zeros((nb, h as usize, w as usize));
        let mut std_error = Array3::<f64>::zeros((nb, h as usize, w as usize));
        let mut spp_map = ndarray::Array2::<u32>::zeros((h as usize, w as usize));
        let floor = band_floor(&ests, &views, nb);
        let (factor, pooled) = if replicated {
            let (f, g) = stratification(&ests, &floor);
            (f, Some(g))
        } else {
            (vec![1.0; ests.len()], None)
        };
        let stated = stated_std_errors(&ests, w as usize, &factor, &floor, replicated);
        for (i, e) in ests.iter().enumerate() {
            let (row, col) = (i / w as usize, i % w as usize);
            let inv = 1.0 / e.n.max(1) as f64;
            let mean: Vec<f64> = e.spectral.iter().map(|a| a * inv).collect();
            let view = views[i].as_ref();
            for (b, v) in self.wl.integrate(&mean).into_iter().enumerate() {
                let (add, se) = view.map_or((0.0, 0.0), |t| (t.bands[b], t.std_error[b]));
                radiance[[b, row, col]] = v + add;
                std_error[[b, row, col]] = stated[i * nb + b].hypot(se);
            }
            spp_map[[row, col]] = e.n;
        }
        let adaptive = self
            .settings
            .target_error
            .map(|t| (t, self.settings.max_spp.max(spp)));
        let mut error = error_summary(&ests, &floor, &stated, pooled, adaptive, rounds, w as usize);
        if !partial && !halt() {
            let skip: Vec<bool> = ests.iter().map(|e| e.sees_emitter).collect();
            let by_band: Vec<Vec<f64>> = (0..nb)
                .map(|b| {
                    radiance
                        .index_axis(ndarray::Axis(0), b)
                        .iter()
                        .copied()
                        .collect()
                })
                .collect();
            error.bias = with_pool(threads, || self.cache_bias(&by_band, &skip));
            let noise = error
                .rel_std_error_rms_target_pixels
                .unwrap_or(error.rel_std_error_rms);
            error.rel_error_rms_with_bias = error
                .bias
                .as_ref()
                .map(|b| noise.hypot(b.relative_bias_bound));
        }
        let mut c = RayCounts::default();
        let deposits = if self.settings.drop.direct_view {
            Vec::new()
        } else {
            self.point_deposits(&mut c)
        };
        let deposit = |radiance: &mut Array3<f64>, group: Option<Option<usize>>| {
            for (col, row, vals, g) in &deposits {
                if !rows.contains(row) || group.is_some_and(|want| want != *g) {
                    continue;
                }
                for (b, v) in vals.iter().enumerate() {
                    radiance[[b, (row - row0) as usize, *col as usize]] += v;
                }
            }
        };
        deposit(&mut radiance, None);
        let layers: Vec<(Array3<f64>, Array3<f64>)> = (0..groups)
            .map(|g| {
                let mut radiance = Array3::<f64>::zeros((nb, h as usize, w as usize));
                let mut std_error = Array3::<f64>::zeros((nb, h as usize, w as usize));
                for (i, e) in ests.iter().enumerate() {
                    let (row, col) = (i / w as usize, i % w as usize);
                    let view = views[i]
                        .as_ref()
                        .and_then(|t| t.light.part(g))
                        .map(|part| self.wl.integrate(part));
                    for b in 0..nb {
                        let (m, se) = e.layer(g, b);
                        let add = view.as_ref().map_or(0.0, |v| v[b]);
                        radiance[[b, row, col]] = m + add;
                        std_error[[b, row, col]] = se * factor[i];
                    }
                }
                deposit(&mut radiance, Some(Some(g)));
                (radiance, std_error)
            })
            .collect();
        rays.add(&c);
        let trace_seconds = t0.elapsed().as_secs_f64();
        let lines = self.wl.len() - self.wl.n_continuum;
        let whole = RenderOutput {
            radiance,
            std_error,
            spp: spp_map,
            error,
            band_names: self.wl.band_names.clone(),
            settings: self.settings.clone(),
            stats: RenderStats {
                width: w,
                height: h,
                bands: nb,
                wavelengths: self.wl.len(),
                emission_lines: lines,
                triangles: self.geom.triangle_count(),
                area_sources: self.area.len(),
                point_sources: self.points.len(),
                threads: threads_used,
                prepare_seconds: self.build_seconds,
                preparation: self.preparation.clone(),
                trace_seconds,
                rays,
                rays_per_second: rays.total() as f64 / trace_seconds.max(1e-9),
                sky: self.sky_summary().cloned(),
                interreflection: self.interreflection.clone(),
            },
        };
        let layers = layers
            .into_iter()
            .map(|(radiance, std_error)| RenderOutput {
                radiance,
                std_error,
                spp: whole.spp.clone(),
                error: whole.error.clone(),
                band_names: whole.band_names.clone(),
                settings: whole.settings.clone(),
                stats: whole.stats.clone(),
            })
            .collect();
        Ok((whole, layers))
    }
}
