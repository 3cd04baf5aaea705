//! Area sources: emitting facets, `cos^m` or a measured luminaire's
//! (γ, C) table, and their direct light by the three estimators
//! (`analytic`, `solid-angle`, `dirsig2001`; see the crate docs).

use glam::DVec3;
use gloam_scene::Scene;
use rand::Rng;
use rand_pcg::Pcg64Mcg;

use super::{LightStrata, add_emission, shaping, tree_size};
use crate::closed_form;
use crate::light::Light;
use crate::lights::tree::{Cone, LightInfo, LightRef};
use crate::sampling::{SphericalRectangle, SphericalTriangle, sample_triangle_area};
use crate::settings::{Estimator, Occlusion, RenderSettings};
use crate::spectral::Wavelengths;
use crate::tracer::{RayCounts, Tracer, latin_hypercube, stream};

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

/// The scene's emitting facets as area sources (centred coordinates), and
/// each facet's index among them (`u32::MAX`: not an emitter). Draws the
/// 2001 method's sample points from their own stream.
pub(crate) fn area_sources(
    scene: &Scene,
    settings: &RenderSettings,
    wl: &Wavelengths,
    origin: DVec3,
    facet_verts: &[Vec<DVec3>],
    facet_normal: &[DVec3],
) -> (Vec<AreaSource>, Vec<u32>) {
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
    (area, facet_source)
}

/// Which pixels each area source's face covers, for the faces the camera
/// sees computed apart from its samples (`direct_view.rs`).
pub(crate) fn area_footprints(
    camera: &gloam_scene::Camera,
    area: &[AreaSource],
) -> crate::direct_view::Footprints {
    let sources: Vec<(Vec<[DVec3; 3]>, bool)> = area
        .iter()
        .map(|s| {
            let faces = (camera.position - s.centroid).dot(s.normal) > 0.0;
            (s.tris.clone(), faces)
        })
        .collect();
    crate::direct_view::Footprints::build(camera, &sources)
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

    /// Its entry in the light tree, as source `i`: its bounds, `L·A` (the
    /// on-axis intensity, scene units) and its emission cone.
    pub(super) fn tree_info(&self, i: usize) -> LightInfo {
        let (lo, hi) = self.verts.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), v| (lo.min(*v), hi.max(*v)),
        );
        LightInfo {
            light: LightRef::Area(i as u32),
            lo,
            hi,
            // L·A: the on-axis intensity (scene units).
            phi: tree_size(&self.radiance, self.size) * self.area,
            cone: Cone {
                axis: self.normal,
                theta_o: 0.0,
                theta_e: std::f64::consts::FRAC_PI_2,
                // Projected area × cos^m shaping; a table is
                // bounded by its I_max (phi) with no falloff assumed.
                exponent: match self.profile {
                    Profile::CosPower(m) => m + 1.0,
                    Profile::Table { .. } => 0.0,
                },
            },
        }
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

impl Tracer {
    /// The area sources' centroids (centred coordinates), in source order.
    pub(crate) fn area_centroids(&self) -> Vec<DVec3> {
        self.area.iter().map(|s| s.centroid).collect()
    }

    /// Every area source's part of [`Tracer::irradiance`], by the chosen
    /// estimator (`LightSource::Area(AreaSet::Every)`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn area_irradiance(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        // Not called when the light tree picks the area sources, nor when
        // there are none (`LightSampler::every`).
        match self.settings.estimator {
            Estimator::Analytic => {
                let every: Vec<(&AreaSource, f64)> = self.area.iter().map(|s| (s, 1.0)).collect();
                self.analytic(&every, p, n, ignore, strata, rng, c, out)
            }
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

    /// The `analytic` estimator (see the crate docs, "Occlusion rule") over
    /// `picks` `(source, weight)` at `p`, into `out`: every area source
    /// with weight 1, or the light tree's picks with their 1/pmf. Closed
    /// forms first, for the shadow-ray shares, then each source's
    /// `analytic_source` estimate times its weight (a source whose every
    /// sample is blocked at a wavelength contributes exactly 0 there); the
    /// sum is clamped at 0 per wavelength (the control variate can
    /// undershoot in deep penumbra).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn analytic(
        &self,
        picks: &[(&AreaSource, f64)],
        p: DVec3,
        n: DVec3,
        ignore: u32,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let area_picks: Vec<(&AreaSource, Option<f64>, f64)> = picks
            .iter()
            .map(|&(s, w)| {
                let f = if s.facet == ignore {
                    Some(0.0)
                } else {
                    s.m_int.map(|m| {
                        closed_form::shaped_polygon_irradiance_factor(p, n, &s.verts, s.normal, m)
                    })
                };
                (s, f, w)
            })
            .collect();
        let total: f64 = area_picks
            .iter()
            .map(|(s, f, w)| f.unwrap_or(0.0) * s.size * w)
            .sum();
        let mut samples = Vec::new();
        let mut occ = vec![0.0; out.len()];
        let mut area = out.dark_like();
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
        out.add_clamped(&area);
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
}
