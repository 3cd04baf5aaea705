//! The light sources, by family: area sources (`area.rs`), point sources
//! (`point.rs`), and the sky — the Moon's beam and the dome (`sky.rs`;
//! the sky's model stays in `sky_light.rs`, this is its use as a light).
//! Each family holds its data as prepared from the scene and the
//! `impl Tracer` methods that compute its direct light at a shading point;
//! this module holds what they share (adding emission through a shadow
//! ray, the light tree across families, the light samples' strata).
//!
//! This is the first step of issue 44 (the tracer in pbrt-v4's shape):
//! the families are apart, a common light interface (pbrt's `Light`,
//! `LightSampler`) is to come; until then `Tracer` calls each family's
//! methods by name.

mod area;
mod point;
mod sky;

use glam::DVec3;
use rand_pcg::Pcg64Mcg;

pub(crate) use area::{AreaSource, area_footprints, area_sources};
pub(crate) use point::{PointLight, point_lights};
pub use sky::SkyProbeResult;
pub(crate) use sky::{SkyState, build_sky};

use crate::light::Light;
use crate::settings::{Estimator, RenderSettings};
use crate::spectral::Wavelengths;
use crate::tracer::{RayCounts, Tracer, mix64};

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

/// `cos^m` for `cos > 0` (0 behind), and 1 for m = 0 (Lambertian /
/// isotropic, whatever the cosine).
fn shaping(cos: f64, m: f64) -> f64 {
    if m == 0.0 {
        1.0
    } else if cos <= 0.0 {
        0.0
    } else {
        cos.powf(m)
    }
}

impl Tracer {
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

    /// Direct light from the emitters the light tree picks at `p`, split as
    /// `[area sources, isotropic point sources, shaped point sources]`: each
    /// pick's usual estimate (area: `analytic_source`; point: one shadow
    /// ray) times its 1/pmf, so each part is unbiased. Categories in
    /// `skipped` are neither traced nor counted. The area part is clamped at
    /// 0 per wavelength like `analytic`'s sum.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn tree_irradiance(
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
        let mut parts = [like.dark_like(), like.dark_like(), like.dark_like()];
        let mut picks = Vec::new();
        tree.select_in(p, n, branches, rng, &mut picks);
        let mut area_picks: Vec<(&AreaSource, f64)> = Vec::new();
        for &(l, w) in &picks {
            match l {
                LightRef::Area(i) if !skipped[0] => area_picks.push((&self.area[i as usize], w)),
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
            self.analytic_picks(&area_picks, p, n, ignore, strata, rng, c, &mut parts[0]);
        }
        parts
    }
}

/// The light tree over `area` (with the `analytic` estimator; the other
/// estimators keep their loop over every area source) and `points`, when the
/// scene has more than `light_tree_min_lights` emitters; `None` keeps
/// today's exhaustive path, bit for bit.
pub(crate) fn build_light_tree(
    area: &[AreaSource],
    points: &[PointLight],
    wl: &Wavelengths,
    settings: &RenderSettings,
    mpu: f64,
    extent: f64,
) -> Option<crate::light_tree::LightTree> {
    use crate::light_tree::LightTree;
    if (area.len() + points.len()) as u64 <= settings.light_tree_min_lights as u64 {
        return None;
    }
    let mut infos = Vec::with_capacity(area.len() + points.len());
    if settings.estimator == Estimator::Analytic {
        infos.extend(area.iter().enumerate().map(|(i, s)| s.tree_info(i)));
    }
    let mpu2 = (mpu * mpu).max(f64::MIN_POSITIVE);
    infos.extend(
        points
            .iter()
            .enumerate()
            .map(|(i, l)| l.tree_info(i, wl, mpu2)),
    );
    LightTree::build(infos, extent, settings.light_tree_branches)
}

/// A scalar size of an emitter for the tree: the band total, or (emitting
/// only outside every band) the spectral sum, so an emitter never gets
/// weight 0 while it emits at some slot.
fn tree_size(v: &[f64], total: f64) -> f64 {
    if total > 0.0 {
        total
    } else {
        v.iter().map(|x| x.max(0.0)).sum()
    }
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
