//! The parallel render loop, point sources seen directly, and probes.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::DVec3;
use gloam_scene::Scene;
use ndarray::Array3;
use rayon::prelude::*;
use serde::Serialize;

use crate::settings::RenderSettings;
use crate::tracer::{RayCounts, TraceError, Tracer, latin_hypercube, stream};

/// Side of the square image tiles handed to rayon.
pub const TILE: u32 = 16;

/// Random-stream domains (so pixels and probes never share a stream).
const DOMAIN_PIXEL: u64 = 1;
const DOMAIN_PROBE: u64 = 2;

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
    /// What the render took from the `[sky]` block (None: no sky light).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky: Option<crate::sky_light::SkySummary>,
}

/// A rendered radiance image.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Band radiance at the entrance pupil, W m⁻² sr⁻¹, band × row × column.
    pub radiance: Array3<f64>,
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
    /// direct light), when the point lies on a facet.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radiance_w_m2_sr: Option<f64>,
}

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
    /// samples (without point sources seen directly).
    fn pixel_spectral(&self, col: u32, row: u32, c: &mut RayCounts) -> Vec<f64> {
        let cam = &self.camera;
        let idx = row as u64 * cam.width as u64 + col as u64;
        let mut rng = stream(self.settings.seed, DOMAIN_PIXEL, idx);
        let spp = self.settings.spp.max(1) as usize;
        let mut sub = Vec::with_capacity(spp);
        latin_hypercube(spp, &mut rng, &mut sub);
        let mut acc = vec![0.0; self.wl.len()];
        for [sx, sy] in sub {
            let d = cam.pixel_direction(col as f64 + sx, row as f64 + sy);
            c.primary += 1;
            self.trace(
                cam.position,
                d,
                u32::MAX,
                &self.ones,
                1,
                0,
                false,
                &mut rng,
                c,
                &mut acc,
            );
        }
        let inv = 1.0 / spp as f64;
        acc.iter_mut().for_each(|a| *a *= inv);
        acc
    }

    /// Point sources seen directly: `(col, row, band radiances)` for each
    /// unoccluded source in the field of view (see the crate docs).
    fn point_deposits(&self, c: &mut RayCounts) -> Vec<(u32, u32, Vec<f64>)> {
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
            out.push((px as u32, py as u32, self.wl.integrate(&spec)));
        }
        out
    }

    /// Renders the whole image. `progress(done, total)` is called as tiles
    /// finish (from worker threads).
    pub fn render(&self, progress: &(dyn Fn(u64, u64) + Sync)) -> Result<RenderOutput, TraceError> {
        let cam = &self.camera;
        let (w, h) = (cam.width, cam.height);
        let nb = self.wl.band_names.len();
        let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE))
            .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
            .collect();
        let total = tiles.len() as u64;
        let done = AtomicU64::new(0);
        let t0 = Instant::now();
        let threads = self.settings.threads;
        let (results, threads_used) = with_pool(threads, || {
            let res: Vec<(u32, u32, u32, u32, Vec<f64>, RayCounts)> = tiles
                .par_iter()
                .map(|&(x0, y0)| {
                    let x1 = (x0 + TILE).min(w);
                    let y1 = (y0 + TILE).min(h);
                    let mut c = RayCounts::default();
                    let mut buf = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize * nb);
                    for row in y0..y1 {
                        for col in x0..x1 {
                            let s = self.pixel_spectral(col, row, &mut c);
                            buf.extend(self.wl.integrate(&s));
                        }
                    }
                    let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                    progress(n, total);
                    (x0, y0, x1, y1, buf, c)
                })
                .collect();
            (res, rayon::current_num_threads())
        });
        let mut radiance = Array3::<f64>::zeros((nb, h as usize, w as usize));
        let mut rays = RayCounts::default();
        for (x0, y0, x1, y1, buf, c) in results {
            rays.add(&c);
            let mut k = 0;
            for row in y0..y1 {
                for col in x0..x1 {
                    for b in 0..nb {
                        radiance[[b, row as usize, col as usize]] = buf[k + b];
                    }
                    k += nb;
                }
            }
        }
        let mut c = RayCounts::default();
        for (col, row, vals) in self.point_deposits(&mut c) {
            for (b, v) in vals.iter().enumerate() {
                radiance[[b, row as usize, col as usize]] += v;
            }
        }
        rays.add(&c);
        let trace_seconds = t0.elapsed().as_secs_f64();
        let lines = self.wl.len() - self.wl.n_continuum;
        Ok(RenderOutput {
            radiance,
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
                trace_seconds,
                rays,
                rays_per_second: rays.total() as f64 / trace_seconds.max(1e-9),
                sky: self.sky_summary().cloned(),
            },
        })
    }

    /// Band radiances of one pixel, bit-identical to the same pixel of
    /// [`Tracer::render`] (same random stream, point sources included).
    pub fn probe_pixel(&self, col: u32, row: u32) -> Result<Vec<f64>, TraceError> {
        let cam = &self.camera;
        if col >= cam.width || row >= cam.height {
            return Err(TraceError::PixelOutside(col, row, cam.width, cam.height));
        }
        let mut c = RayCounts::default();
        let mut v = self.wl.integrate(&self.pixel_spectral(col, row, &mut c));
        for (x, y, vals) in self.point_deposits(&mut c) {
            if (x, y) == (col, row) {
                v.iter_mut().zip(&vals).for_each(|(a, b)| *a += b);
            }
        }
        Ok(v)
    }

    /// Irradiance at world-space `point` on a receiver with `normal`, in
    /// `band` (the first band for `None`): the mean of `samples`
    /// independent estimates (each with `area_samples` shadow rays per area
    /// source) and its standard error. When the point lies on a facet, also
    /// the radiance that facet's Lambertian part reflects, `ρ_d E / π`.
    pub fn probe_point(
        &self,
        point: DVec3,
        normal: DVec3,
        band: Option<&str>,
        samples: u32,
    ) -> Result<ProbeResult, TraceError> {
        let b = self.band_index(band)?;
        let n = normal
            .try_normalize()
            .ok_or_else(|| TraceError::BadInput("the normal must be a non-zero vector".into()))?;
        if !point.is_finite() {
            return Err(TraceError::BadInput("the point must be finite".into()));
        }
        let p = point - self.geom.origin;
        let facet = self.facet_at(p);
        let ignore = facet.unwrap_or(u32::MAX);
        let k = samples.max(1);
        let mut es = Vec::with_capacity(k as usize);
        let mut ls = Vec::with_capacity(k as usize);
        let mut c = RayCounts::default();
        for i in 0..k {
            let mut rng = stream(self.settings.seed, DOMAIN_PROBE, i as u64);
            let mut e = vec![0.0; self.wl.len()];
            self.irradiance(p, n, ignore, &mut rng, &mut c, &mut e);
            es.push(self.wl.integrate(&e)[b]);
            if let Some(f) = facet {
                let l: Vec<f64> = e
                    .iter()
                    .zip(self.kd(f))
                    .map(|(e, k)| e * k * std::f64::consts::FRAC_1_PI)
                    .collect();
                ls.push(self.wl.integrate(&l)[b]);
            }
        }
        let mean = es.iter().sum::<f64>() / k as f64;
        let se = if k > 1 {
            let var = es.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
            (var / k as f64).sqrt()
        } else {
            0.0
        };
        Ok(ProbeResult {
            band: self.wl.band_names[b].clone(),
            irradiance_w_m2: mean,
            std_error_w_m2: se,
            radiance_w_m2_sr: facet.map(|_| ls.iter().sum::<f64>() / k as f64),
        })
    }

    /// The camera ray through continuous pixel coordinates `(px, py)`:
    /// origin and unit direction in the tracer's centred frame (see
    /// [`crate::geometry`]), ready for `self.geom`.
    pub fn camera_ray(&self, px: f64, py: f64) -> (DVec3, DVec3) {
        (self.camera.position, self.camera.pixel_direction(px, py))
    }

    /// Centroids of the emitting facets, in the centred frame.
    pub fn emitter_centroids(&self) -> Vec<DVec3> {
        self.area_centroids()
    }

    /// Continuous pixel coordinates of a world-space point (None behind the camera).
    pub fn project(&self, point: DVec3) -> Option<(f64, f64)> {
        self.camera.project(point - self.geom.origin)
    }
}
