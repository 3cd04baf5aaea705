//! Probes: one pixel as the render computes it, or the irradiance at a
//! point.

use super::*;
use crate::tracer::latin_hypercube;

impl Tracer {
    /// Band radiances of one pixel, bit-identical to the same pixel of
    /// [`Tracer::render`] (same random stream, point sources included).
    pub fn probe_pixel(&self, col: u32, row: u32) -> Result<Vec<f64>, TraceError> {
        let cam = &self.camera;
        if col >= cam.width || row >= cam.height {
            return Err(TraceError::PixelOutside(col, row, cam.width, cam.height));
        }
        let mut c = RayCounts::default();
        let mut v = self.wl.integrate(&self.pixel_spectral(col, row, &mut c));
        if let Some(t) = self.view_term(col, row, &mut c) {
            v.iter_mut().zip(&t.bands).for_each(|(a, b)| *a += b);
        }
        for (x, y, vals, _) in self.point_deposits(&mut c) {
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
        let n = unit_normal(normal)?;
        if !point.is_finite() {
            return Err(TraceError::BadInput("the point must be finite".into()));
        }
        // The scene's own coordinate limit: beyond it the centred offset
        // loses every digit and the answer would be a silent 0 ± 0.
        let lim = gloam_scene::MAX_COORDINATE;
        if point.abs().max_element() > lim {
            return Err(TraceError::BadInput(format!(
                "the point {},{},{} is out of range (|x| ≤ {lim:e} scene units, as scene coordinates)",
                point.x, point.y, point.z
            )));
        }
        let p = point - self.geom.origin;
        let facet = self.facet_at(p);
        let ignore = facet.unwrap_or(u32::MAX);
        let k = samples.max(1);
        let mut es = Vec::with_capacity(k as usize);
        let mut ls = Vec::with_capacity(k as usize);
        let (mut direct_sum, mut indirect_sum) = (0.0, 0.0);
        let mut c = RayCounts::default();
        let indirect = self.probe_indirect_method();
        for i in 0..k {
            let mut rng = stream(self.settings.seed, DOMAIN_PROBE, i as u64);
            let mut e = Light::dark(self.wl.len(), 0);
            self.irradiance(p, n, ignore, &mut rng, &mut c, &mut e);
            let mut e = e.into_whole();
            direct_sum += self.wl.integrate(&e)[b];
            if indirect.is_some() {
                let mut ei = Light::dark(self.wl.len(), 0);
                self.probe_indirect(p, n, ignore, &mut rng, &mut c, &mut ei);
                let ei = ei.into_whole();
                indirect_sum += self.wl.integrate(&ei)[b];
                e.iter_mut().zip(&ei).for_each(|(a, b)| *a += b);
            }
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
            direct_irradiance_w_m2: direct_sum / k as f64,
            indirect_irradiance_w_m2: indirect.map(|_| indirect_sum / k as f64),
            terms: match indirect {
                Some(m) => format!("direct light and interreflection ({m}), as a render"),
                None => format!(
                    "direct light only, as a render ({})",
                    self.interreflection.reason
                ),
            },
        })
    }

    /// How a probe adds interreflection: as the render would (the plan's
    /// decision), or `None` when the render has none.
    pub(super) fn probe_indirect_method(&self) -> Option<&'static str> {
        if self.cache.is_some() {
            Some("radiosity cache, final gather")
        } else if self.settings.diffuse_bounces > 0 {
            Some("path tracing")
        } else {
            None
        }
    }

    /// Interreflected irradiance at `p` (normal `n`), added to `out`: a
    /// final gather from the cache, or cosine-weighted diffuse paths
    /// (`E = π/K Σ L(ω_j)`), with [`PROBE_GATHER_RAYS`] directions.
    pub(super) fn probe_indirect(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        rng: &mut rand_pcg::Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let k = (self.settings.gather_rays as usize).max(PROBE_GATHER_RAYS);
        if let Some(cache) = &self.cache {
            self.final_gather(cache, p, n, ignore, k, None, &self.ones, rng, c, out);
            return;
        }
        let mut u = Vec::with_capacity(k);
        latin_hypercube(k, rng, &mut u);
        let (tx, ty) = crate::sky_light::orthonormal_basis(n);
        let thr = vec![std::f64::consts::PI / k as f64; out.len()];
        for uv in u {
            let l = crate::sky_light::cosine_hemisphere(uv);
            let d = (tx * l.x + ty * l.y + n * l.z).normalize_or_zero();
            let state = PathState {
                diffuse: 1,
                after_diffuse: true,
                ..PathState::camera(self.settings.diffuse_bounces, false)
            };
            self.trace(p, d, ignore, &thr, state, None, None, rng, c, out);
        }
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

/// `normal` as a unit vector. One whose length overflows or underflows
/// (`1e308,1e308,0`, `1e-320,0,0`) is scaled by its largest component
/// first: it has a direction, and was called "a zero vector".
pub(crate) fn unit_normal(normal: DVec3) -> Result<DVec3, TraceError> {
    if !normal.is_finite() {
        return Err(TraceError::BadInput(format!(
            "the normal {},{},{} must be finite",
            normal.x, normal.y, normal.z
        )));
    }
    normal
        .try_normalize()
        .or_else(|| (normal / normal.abs().max_element()).try_normalize())
        .ok_or_else(|| TraceError::BadInput("the normal must be a non-zero vector".into()))
}
