//! The integrators: what light a ray brings back, vertex by vertex, in
//! the order the light is met along the path (pbrt-v4's `Integrator`,
//! over one [`Tracer`]).
//!
//! [`Tracer::trace`] walks a ray through transmissive facets; at each
//! surface it meets, the vertex adds, in this order (the order fixes which
//! random numbers each step draws, so a render is reproducible bit for
//! bit):
//!
//! 1. the emitter seen along the ray ([`Tracer::emitted`]), or on escape
//!    the sky dome ([`Tracer::escaped`]);
//! 2. **direct light** ([`Tracer::direct_at`]): every light the light
//!    sampler yields, by its family's estimator (`lights/`);
//! 3. interreflection, by one of two integrators the plan chooses
//!    (exclusive): the **radiosity cache with a final gather**
//!    ([`Tracer::cached_at`], `indirect/`), or **path tracing**'s diffuse
//!    bounce with Russian roulette ([`Tracer::path_bounce`], after the
//!    specular step below);
//! 4. specular recursion up to `recursion` ([`Tracer::specular_at`]);
//! 5. straight on through a transmissive facet.
//!
//! With `indirect = off` only steps 1, 2, 4 and 5 run: the direct
//! integrator.

use glam::DVec3;
use rand::Rng;
use rand_pcg::Pcg64Mcg;

use crate::light::Light;
use crate::lights::LightStrata;
use crate::tracer::{RayCounts, Tracer};
use crate::world::MatSpec;

/// Where a ray of [`Tracer::trace`] is in its path: what it adds where it
/// lands and how far it may go on.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathState {
    /// 1 for camera rays, +1 per specular bounce (up to `recursion`).
    pub(crate) spec_depth: u32,
    /// Diffuse bounces taken; a diffuse vertex bounces on while fewer
    /// than `max_diffuse` (`diffuse_bounces`: 0 unless path tracing).
    pub(crate) diffuse: u32,
    pub(crate) max_diffuse: u32,
    /// After a diffuse bounce emitter hits are not added (next-event
    /// estimation counted them) and the cache is not read.
    pub(crate) after_diffuse: bool,
    /// A render's camera ray: the faces [`crate::direct_view`] computes
    /// apart are not added where it meets them.
    pub(crate) view_apart: bool,
}

impl PathState {
    /// A camera ray (or a probe's), the render's bounces.
    pub(crate) fn camera(max_diffuse: u32, view_apart: bool) -> Self {
        Self {
            spec_depth: 1,
            diffuse: 0,
            max_diffuse,
            after_diffuse: false,
            view_apart,
        }
    }
}

/// A surface a ray met: the point (centred), its facet, the normal on
/// the side the ray came from, and the facet's material.
struct Vertex<'a> {
    p: DVec3,
    f: u32,
    /// Geometric normal, flipped toward the incoming ray.
    ns: DVec3,
    /// Whether the ray met the facet's front (its geometric normal's side).
    front: bool,
    mat: &'a MatSpec,
}

impl Tracer {
    /// Spectral radiance arriving along the unit ray `(o, d)` (centred), times
    /// `thr`, added to `acc`, from where `state` says the ray is in its
    /// path (see [`PathState`]); the steps in the module's order.
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
        state: PathState,
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
            if pass > 0 || state.spec_depth > 1 || state.after_diffuse {
                c.secondary += 1;
            }
            let eps = if ignore == u32::MAX {
                0.0
            } else {
                self.geom.epsilon(o)
            };
            let Some(hit) = self.geom.intersect(o, d, eps, f64::INFINITY, ignore) else {
                self.escaped(d, &thr, state, acc);
                return met_emitter;
            };
            let f = hit.facet;
            let ng = self.normal_of(f);
            let front = d.dot(ng) < 0.0;
            let v = Vertex {
                p: o + d * hit.t,
                f,
                ns: if front { ng } else { -ng },
                front,
                mat: self.mat_of(f),
            };
            met_emitter |= self.emitted(&v, d, &thr, state, acc);
            self.direct_at(&v, &thr, strata.take(), rng, c, acc);
            self.cached_at(&v, &thr, state, gather.take(), rng, c, acc);
            self.specular_at(&v, d, &thr, state, rng, c, acc);
            self.path_bounce(&v, &thr, state, rng, c, acc);

            // Step 5: straight through a transmissive facet.
            match &v.mat.trans {
                Some(tr)
                    if !(self.settings.drop.transmissive_occluders
                        || self.skip.transmissive_occluders) =>
                {
                    thr.iter_mut().zip(tr).for_each(|(a, b)| *a *= b);
                    if thr.iter().all(|&x| x == 0.0) {
                        return met_emitter;
                    }
                    o = v.p;
                    ignore = f;
                }
                _ => return met_emitter,
            }
        }
        met_emitter
    }

    /// Step 1: a ray that escaped: the sky dome's radiance in its direction,
    /// and the twilight sky's when the Sun lights it (not after a diffuse
    /// bounce, whose vertex sampled the domes).
    fn escaped(&self, d: DVec3, thr: &[f64], state: PathState, acc: &mut Light) {
        let Some(sky) = self.sky.as_ref().filter(|_| !state.after_diffuse) else {
            return;
        };
        let mut l = vec![0.0; sky.nc];
        let domes = std::iter::once((&sky.table, sky.sky_group))
            .chain(sky.twilight.as_ref().map(|t| (t, sky.twilight_group)));
        for (table, group) in domes {
            table.radiance_into(d, &mut l);
            acc.add_from(group, |a| {
                a[..sky.nc]
                    .iter_mut()
                    .zip(thr)
                    .zip(&l)
                    .for_each(|((a, t), l)| *a += t * l)
            });
        }
    }

    /// Step 1: an emitter seen along the ray: `L cos^m(α)` from the front (not
    /// after a diffuse bounce, whose vertex sampled it; not a face
    /// [`crate::direct_view`] computes apart). Returns whether a camera
    /// ray met an emitter's front that it added.
    fn emitted(
        &self,
        v: &Vertex,
        d: DVec3,
        thr: &[f64],
        state: PathState,
        acc: &mut Light,
    ) -> bool {
        let src = self.source_of(v.f);
        let seen_directly = state.spec_depth == 1 && !state.after_diffuse;
        let apart = seen_directly && state.view_apart && self.view.apart(src);
        if src != u32::MAX
            && v.front
            && !state.after_diffuse
            && !apart
            && !(seen_directly && self.settings.drop.direct_view)
        {
            let s = &self.area[src as usize];
            let ng = self.normal_of(v.f);
            let g = s.shape(-d.dot(ng), -d);
            acc.add_from(s.group, |a| {
                a.iter_mut()
                    .zip(thr)
                    .zip(&s.radiance)
                    .for_each(|((a, t), l)| *a += g * t * l)
            });
        }
        seen_directly && src != u32::MAX && v.front && !apart
    }

    /// Step 2: direct light on the Lambertian part, `L = kd E / π`: the direct
    /// integrator, every render's first term.
    fn direct_at(
        &self,
        v: &Vertex,
        thr: &[f64],
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        acc: &mut Light,
    ) {
        if !(v.mat.has_diffuse || self.settings.all_effects) {
            return;
        }
        let mut e = acc.dark_like();
        self.irradiance_with(v.p, v.ns, v.f, 1, usize::MAX, strata, rng, c, &mut e);
        let inv_pi = std::f64::consts::FRAC_1_PI;
        acc.add_each(&e, |acc, e| {
            for (((a, t), k), e) in acc.iter_mut().zip(thr).zip(&v.mat.kd).zip(e) {
                *a += t * k * e * inv_pi;
            }
        });
    }

    /// Step 3: diffuse interreflection from the radiosity cache and its final
    /// gather (`indirect/`): not after a path-traced diffuse bounce (the
    /// two integrators are exclusive).
    #[allow(clippy::too_many_arguments)]
    fn cached_at(
        &self,
        v: &Vertex,
        thr: &[f64],
        state: PathState,
        gather: Option<&[[f64; 2]]>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        acc: &mut Light,
    ) {
        let Some(cache) = &self.cache else {
            return;
        };
        if !v.mat.has_diffuse || state.after_diffuse {
            return;
        }
        let inv_pi = std::f64::consts::FRAC_1_PI;
        let scale: Vec<f64> = thr
            .iter()
            .zip(&v.mat.kd)
            .map(|(t, k)| t * k * inv_pi)
            .collect();
        self.cached_indirect(cache, v.p, v.ns, v.f, v.front, &scale, gather, rng, c, acc);
    }

    /// Step 4: specular recursion (mirror reflection of the specular part) up
    /// to `recursion`. A dropped recursion is traced into a scratch
    /// buffer, so the other random numbers stay those of the full render.
    #[allow(clippy::too_many_arguments)]
    fn specular_at(
        &self,
        v: &Vertex,
        d: DVec3,
        thr: &[f64],
        state: PathState,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        acc: &mut Light,
    ) {
        let reflects = !v.mat.ks.is_empty() || self.settings.all_effects;
        let deeper = state.spec_depth < self.settings.recursion;
        if !reflects || !deeper || self.skip.specular_recursion {
            return;
        }
        let r = d - 2.0 * d.dot(v.ns) * v.ns;
        let t2: Vec<f64> = if v.mat.ks.is_empty() {
            vec![0.0; thr.len()]
        } else {
            thr.iter().zip(&v.mat.ks).map(|(a, b)| a * b).collect()
        };
        let mut scratch;
        let target = if self.settings.drop.specular_recursion {
            scratch = Light::dark(acc.len(), 0);
            &mut scratch
        } else {
            acc
        };
        let state = PathState {
            spec_depth: state.spec_depth + 1,
            after_diffuse: false,
            view_apart: false,
            ..state
        };
        self.trace(v.p, r, v.f, &t2, state, None, None, rng, c, target);
    }

    /// Step 3': the path integrator's diffuse bounce, with Russian roulette
    /// from `rr_start` bounces on (only while fewer than `max_diffuse`:
    /// none unless the plan path-traces interreflection).
    fn path_bounce(
        &self,
        v: &Vertex,
        thr: &[f64],
        state: PathState,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        acc: &mut Light,
    ) {
        if !(v.mat.has_diffuse && state.diffuse < state.max_diffuse) {
            return;
        }
        let mut t2: Vec<f64> = thr.iter().zip(&v.mat.kd).map(|(a, b)| a * b).collect();
        if state.diffuse >= self.settings.rr_start {
            let q = v
                .mat
                .kd
                .iter()
                .copied()
                .fold(0.0, f64::max)
                .clamp(0.05, 0.95);
            if rng.random::<f64>() < q {
                t2.iter_mut().for_each(|x| *x /= q);
            } else {
                return;
            }
        }
        let Some(dir) = self.bounce_direction(v.p, v.ns, v.f, rng, &mut t2) else {
            return;
        };
        let state = PathState {
            diffuse: state.diffuse + 1,
            after_diffuse: true,
            view_apart: false,
            ..state
        };
        self.trace(v.p, dir, v.f, &t2, state, None, None, rng, c, acc);
    }

    /// A diffuse bounce's direction from `p` (shading normal `ns`, on
    /// facet `f`): cosine-weighted, or with a bounce guide (`guide.rs`)
    /// drawn from its one-sample mixture, `t2` then scaled by
    /// (cos/π) / pdf. None when a guided draw falls behind the surface.
    fn bounce_direction(
        &self,
        p: DVec3,
        ns: DVec3,
        f: u32,
        rng: &mut Pcg64Mcg,
        t2: &mut [f64],
    ) -> Option<DVec3> {
        let local = self.guide.as_ref().and_then(|g| g.at(p, ns, f));
        let guided = local.is_some() && rng.random::<f64>() < crate::guide::GUIDED_FRACTION;
        let (tx, ty) = orthonormal(ns);
        let u1: f64 = rng.random();
        let u2: f64 = rng.random();
        let dir = match &local {
            Some(l) if guided => l.sample(p, [u1, u2, rng.random()])?,
            _ => {
                let r = u1.sqrt();
                let phi = 2.0 * std::f64::consts::PI * u2;
                (tx * (r * phi.cos()) + ty * (r * phi.sin()) + ns * (1.0 - u1).max(0.0).sqrt())
                    .normalize()
            }
        };
        if let Some(l) = &local {
            let cos = dir.dot(ns);
            if cos <= 0.0 {
                return None;
            }
            let a = crate::guide::GUIDED_FRACTION;
            let cos_pdf = cos * std::f64::consts::FRAC_1_PI;
            let w = cos_pdf / ((1.0 - a) * cos_pdf + a * l.pdf(p, dir));
            t2.iter_mut().for_each(|x| *x *= w);
        }
        Some(dir)
    }
}

fn orthonormal(n: DVec3) -> (DVec3, DVec3) {
    let a = if n.x.abs() > 0.9 { DVec3::Y } else { DVec3::X };
    let t = n.cross(a).normalize();
    (t, n.cross(t))
}
