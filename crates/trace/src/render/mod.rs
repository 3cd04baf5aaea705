//! The render: a pixel's camera samples (here), the image sampled with
//! adaptive stopping (`adaptive.rs`), the estimates and the errors they
//! state (`estimate.rs`), the film they are developed on (`film.rs`),
//! point sources seen directly (here) and probes (`probe.rs`).

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::DVec3;
use gloam_scene::Scene;
use ndarray::Array3;
use rayon::prelude::*;
use serde::Serialize;

use crate::direct_view::ViewTerm;
use crate::light::Light;
use crate::sampler::PixelSampler;
use crate::settings::{LightStrataMode, PixelStrata, RenderSettings};
use crate::tracer::{PathState, RayCounts, TraceError, Tracer, stream};

mod adaptive;
mod estimate;
pub(crate) use estimate::render_bytes_per_pixel;
mod film;
pub(crate) mod probe;
#[cfg(test)]
mod tests;

pub use adaptive::PixelGoal;
use adaptive::{Halt, Region};
pub use estimate::*;
use film::Image;

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

/// A render worker's stack (rayon's, set so it is known: std's default).
const WORKER_STACK_BYTES: usize = 2 << 20;
/// What a worker takes besides: its guard page and the signal stack std
/// maps for each thread (a failure to map that one aborts the process, so
/// the pool is checked before it starts).
const WORKER_EXTRA_BYTES: u64 = 128 << 10;

/// Whether `n` workers' stacks fit the address space left under
/// `ulimit -v` (with an eighth kept for the allocator); why not.
fn pool_fits(n: usize) -> Result<(), String> {
    let Some(left) = gloam_scene::address_space_unreserved() else {
        return Ok(());
    };
    let need = (n as u64).saturating_mul(WORKER_STACK_BYTES as u64 + WORKER_EXTRA_BYTES);
    if need <= left / 8 * 7 {
        return Ok(());
    }
    Err(format!(
        "their stacks need {} MB of address space and {} MB is left under RLIMIT_AS",
        need >> 20,
        left >> 20
    ))
}

/// Runs `f` on a pool of `threads` workers (the global pool when `None`).
/// A pool that cannot start is an error: the render used to run on the
/// global pool instead while its report said `threads: N`.
fn with_pool<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> T + Send,
) -> Result<T, TraceError> {
    match threads {
        Some(n) => match pool_fits(n.max(1)).and_then(|()| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n.max(1))
                .stack_size(WORKER_STACK_BYTES)
                .build()
                .map_err(|e| e.to_string())
        }) {
            Ok(pool) => Ok(pool.install(f)),
            Err(e) => Err(TraceError::BadInput(format!(
                "threads = {n}: the worker threads could not start ({e}); each needs its own stack, which an address-space or process limit (ulimit -v, -u) can refuse — ask for fewer"
            ))),
        },
        None => Ok(f()),
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
        let sobol = (
            self.settings.pixel_strata == PixelStrata::Sobol,
            self.settings.light_strata == LightStrataMode::Sobol,
        );
        let first = replicate.map_or(est.n, |r| est.rep_n[r]);
        let sampler = PixelSampler::new(self.settings.seed, idx, replicate, first, sobol);
        let mut sub = Vec::with_capacity(n);
        sampler.film_positions(n, &mut rng, &mut sub);
        let mut acc = Light::dark(self.wl.len(), est.groups);
        // Final-gather directions only when there is a cache to gather from.
        let k = if self.cache.is_some() {
            self.settings.gather_rays as usize
        } else {
            0
        };
        let mut pts: Vec<[f64; 2]> = Vec::with_capacity(k);
        for (j, [sx, sy]) in (0u32..).zip(sub) {
            acc.clear();
            sampler.gather(j, k, &mut pts);
            let d = cam.pixel_direction(col as f64 + sx, row as f64 + sy);
            c.primary += 1;
            est.sees_emitter |= self.trace(
                cam.position,
                d,
                u32::MAX,
                &self.ones,
                PathState::camera(self.settings.diffuse_bounces, true),
                (k > 0).then_some(pts.as_slice()),
                sampler.light(j),
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
        Ok(self.render_split(rows, progress, stop, 0, None)?.0)
    }

    /// The whole image sampled until every pixel's standard error in the
    /// goal's band is within the bound the goal sets for it from the first
    /// round (`spp` samples each): a camera's own noise for `--target-error
    /// camera`. The settings' `target_error` is not used. Stoppable as
    /// [`Tracer::render_rows_until`].
    pub fn render_to_goal(
        &self,
        goal: &dyn PixelGoal,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<RenderOutput, TraceError> {
        let rows = 0..self.camera.height;
        Ok(self.render_split(rows, progress, stop, 0, Some(goal))?.0)
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
        goal: Option<&dyn PixelGoal>,
    ) -> Result<(RenderOutput, Vec<RenderOutput>), TraceError> {
        let halt = Halt::new(stop);
        let region = self.region(rows, goal.is_some())?;
        let t0 = Instant::now();
        let (samples, threads) = with_pool(self.settings.threads, || {
            let s = self.sample_image(&region, groups, goal, progress, &halt);
            (s, rayon::current_num_threads())
        })?;
        let mut samples = samples?;
        if halt.stopped() {
            return Err(TraceError::Interrupted);
        }
        let mut film = self.develop(&samples, &region);
        if !region.partial && !halt.now() {
            self.state_cache_bias(&mut film, &samples)?;
        }
        let deposits = if self.settings.drop.direct_view {
            Vec::new()
        } else {
            self.point_deposits(&mut samples.rays)
        };
        film.image.deposit(&deposits, &region, None);
        let layers: Vec<Image> = (0..groups)
            .map(|g| {
                let mut layer = self.develop_layer(&samples, &region, &film, g);
                layer.deposit(&deposits, &region, Some(g));
                layer
            })
            .collect();
        let stats = self.render_stats(&region, threads, samples.rays, t0.elapsed().as_secs_f64());
        let whole = RenderOutput {
            radiance: film.image.radiance,
            std_error: film.image.std_error,
            spp: film.spp,
            error: film.error,
            band_names: self.wl.band_names.clone(),
            settings: self.settings.clone(),
            stats,
        };
        let layers = layers
            .into_iter()
            .map(|layer| RenderOutput {
                radiance: layer.radiance,
                std_error: layer.std_error,
                spp: whole.spp.clone(),
                error: whole.error.clone(),
                band_names: whole.band_names.clone(),
                settings: whole.settings.clone(),
                stats: whole.stats.clone(),
            })
            .collect();
        Ok((whole, layers))
    }

    /// A render's statistics: its size, the scene's, rays and timings.
    fn render_stats(
        &self,
        region: &Region,
        threads: usize,
        rays: RayCounts,
        trace_seconds: f64,
    ) -> RenderStats {
        RenderStats {
            width: region.w,
            height: region.h,
            bands: self.wl.band_names.len(),
            wavelengths: self.wl.len(),
            emission_lines: self.wl.len() - self.wl.n_continuum,
            triangles: self.geom.triangle_count(),
            area_sources: self.area.len(),
            point_sources: self.points.len(),
            threads,
            prepare_seconds: self.build_seconds,
            preparation: self.preparation.clone(),
            trace_seconds,
            rays,
            rays_per_second: rays.total() as f64 / trace_seconds.max(1e-9),
            sky: self.sky_summary().cloned(),
            interreflection: self.interreflection.clone(),
        }
    }
}
