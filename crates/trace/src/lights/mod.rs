//! The light sources, by family: area sources (`area.rs`), point sources
//! (`point.rs`), and the sky — the Moon's beam and the dome (`sky.rs`;
//! the sky's model stays in `sky_light.rs`, this is its use as a light).
//! Each family holds its data as prepared from the scene and the
//! `impl Tracer` methods that compute its direct light at a shading point.
//!
//! Over the families, one interface (issue 44, after pbrt-v4's `Light`
//! and `LightSampler`): a [`LightSource`] (`Point`, `Area`, `Moon`,
//! `Dome`) has a [`Term`] — the five parts the effect plan knows and
//! `drop` names — and its direct irradiance at a shading point by its
//! family's estimator; the [`LightSampler`] (`sampler.rs`) yields a
//! shading point's lights with their weights (every light with 1, and the
//! light tree's picks with their 1/pmf); [`Tracer::direct_light`] is the
//! one loop over them, sending each term where a [`Route`] says. Adding a
//! family is a file here, an arm of [`LightSource`] (and of [`Term`] if
//! it is a new term), and its place in [`LightSampler::every`].
//!
//! Area sources enter as one [`AreaSet`], not one by one: the `analytic`
//! estimator shares the closed-form total between them (each one's
//! shadow-ray count follows its share) and clamps their sum at 0, so they
//! are estimated together. The light tree's bounds stay per emitter
//! (`AreaSource::tree_info`, `PointLight::tree_info`).
//!
//! This module also holds what the families share: adding emission
//! through a shadow ray, the light tree's construction, the light
//! samples' strata.

mod area;
mod distant;
mod point;
mod sampler;
mod sky;
pub(crate) mod tree;

use glam::DVec3;
use rand_pcg::Pcg64Mcg;

pub(crate) use area::{AreaSource, area_footprints, area_sources};
pub(crate) use distant::{DistantLight, distant_lights};
pub(crate) use point::{PointLight, point_lights};
use sampler::LightSampler;
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

    /// Direct light at `p` (normal `n`, on facet `ignore`) from every
    /// light the [`LightSampler`] yields, each term sent where `routes`
    /// says ([`Route`], indexed by [`Term`]): `To(i)` adds it to
    /// `bufs[i]`, `Scratch` computes and discards it (its random numbers
    /// are still drawn), `Skip` neither computes nor counts it. The light
    /// tree's picks are averaged over `tree_repeats` selections of at most
    /// `branches` picks each; within a selection each term gathers in a
    /// buffer of its own and is added to its destination once.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn direct_light(
        &self,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        tree_repeats: u32,
        branches: usize,
        strata: Option<LightStrata>,
        routes: [Route; Term::COUNT],
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        bufs: &mut [&mut Light],
    ) {
        let sampler = LightSampler::new(self);
        // Dropped terms are discarded whole: no groups.
        let nwl = bufs[0].len();
        for (light, w) in sampler.every() {
            match routes[light.term() as usize] {
                Route::Skip => {}
                Route::Scratch => {
                    let scratch = &mut Light::dark(nwl, 0);
                    light.irradiance(self, p, n, ignore, w, strata, rng, c, scratch)
                }
                Route::To(i) => light.irradiance(self, p, n, ignore, w, strata, rng, c, bufs[i]),
            }
        }
        if sampler.tree().is_none() {
            return;
        }
        let repeats = tree_repeats.max(1);
        let w = 1.0 / repeats as f64;
        for _ in 0..repeats {
            // A part per term the tree picked (area and point sources).
            let mut parts: [Option<Light>; Term::COUNT] = Default::default();
            for (light, pw) in sampler.pick(p, n, branches, rng) {
                let k = light.term() as usize;
                if !matches!(routes[k], Route::Skip) {
                    let part = parts[k].get_or_insert_with(|| bufs[0].dark_like());
                    light.irradiance(self, p, n, ignore, pw, strata, rng, c, part);
                }
            }
            // w = 1 for one selection: x · 1 is x exactly. A term with no
            // pick adds nothing: the sums here start at +0 and only grow by
            // `+=`, so they never hold −0, and x + 0 = x.
            for (part, route) in parts.iter().zip(routes) {
                if let (Some(part), Route::To(i)) = (part, route) {
                    bufs[i].add_each(part, |o, x| {
                        o.iter_mut().zip(x).for_each(|(o, x)| *o += w * x)
                    });
                }
            }
        }
    }
}

/// The light terms the effect plan knows and `drop` names; a term's
/// number is its place in [`Tracer::direct_light`]'s `routes`, in the
/// pilot's `irradiance_parts` and in [`crate::plan::TermShares`]. A new
/// term is an arm here and in each `match` below (the compiler lists
/// them); everything keyed by term — routes, `drop`, the pilot's parts,
/// the plan's shares and their JSON — follows from [`Term::ALL`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Term {
    /// Area sources (`area-sources`).
    Area = 0,
    /// Isotropic point sources (`point-sources`).
    Point = 1,
    /// Shaped and measured point sources (`shaped-point-sources`).
    ShapedPoint = 2,
    /// The Moon's beam (`moon`).
    Moon = 3,
    /// The sky dome (`night-sky`).
    NightSky = 4,
    /// Distant (directional) sources (`distant-sources`).
    Distant = 5,
    /// The Sun's direct beam (`sun`).
    Sun = 6,
    /// Sunlight scattered by the twilight sky (`twilight-sky`).
    Twilight = 7,
}

impl Term {
    /// How many terms there are.
    pub(crate) const COUNT: usize = 8;

    /// In order of their numbers.
    pub(crate) const ALL: [Term; Term::COUNT] = [
        Term::Area,
        Term::Point,
        Term::ShapedPoint,
        Term::Moon,
        Term::NightSky,
        Term::Distant,
        Term::Sun,
        Term::Twilight,
    ];

    /// Its effect name: the effect plan's, `drop`'s and the pilot's.
    pub(crate) const fn name(self) -> &'static str {
        use gloam_scene::plan::names;
        match self {
            Term::Area => names::AREA_SOURCES,
            Term::Point => names::POINT_SOURCES,
            Term::ShapedPoint => names::SHAPED_POINT_SOURCES,
            Term::Moon => names::MOON,
            Term::NightSky => names::NIGHT_SKY,
            Term::Distant => names::DISTANT_SOURCES,
            Term::Sun => names::SUN,
            Term::Twilight => names::TWILIGHT_SKY,
        }
    }

    /// Its key in JSON (the plan's `parts`, the settings' `drop`): the
    /// name in snake case.
    pub(crate) const fn key(self) -> &'static str {
        match self {
            Term::Area => "area_sources",
            Term::Point => "point_sources",
            Term::ShapedPoint => "shaped_point_sources",
            Term::Moon => "moon",
            Term::NightSky => "night_sky",
            Term::Distant => "distant_sources",
            Term::Sun => "sun",
            Term::Twilight => "twilight_sky",
        }
    }

    /// The term with effect name `name`.
    pub(crate) fn by_name(name: &str) -> Option<Term> {
        Term::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Whether the prepared scene has a light under this term (the plan
    /// leaves out only terms a scene has).
    pub(crate) fn present(self, t: &Tracer) -> bool {
        match self {
            Term::Area => !t.area.is_empty(),
            Term::Point => t.points.iter().any(|l| !l.is_shaped()),
            Term::ShapedPoint => t.points.iter().any(|l| l.is_shaped()),
            Term::Moon => t.sky.as_ref().is_some_and(|s| s.moon_dir.is_some()),
            Term::NightSky => t.sky.as_ref().is_some_and(|s| s.dome),
            Term::Distant => !t.distant.is_empty(),
            Term::Sun => t.sky.as_ref().is_some_and(|s| s.sun.is_some()),
            Term::Twilight => t.sky.as_ref().is_some_and(|s| s.twilight.is_some()),
        }
    }

    /// Whether its estimate draws random numbers: then a dropped term is
    /// still computed, into a scratch buffer, so the render shares every
    /// other random number with the full one (the difference is the term,
    /// not noise: `gloam bench plan`); a dropped term that draws none is
    /// not computed at all.
    pub(crate) fn draws_random(self) -> bool {
        match self {
            Term::Area | Term::NightSky | Term::Twilight => true,
            Term::Point | Term::ShapedPoint | Term::Moon | Term::Distant | Term::Sun => false,
        }
    }

    /// A smooth term: extended emitters, with no pools or shadow edges
    /// sharper than a cache texel (`tracer::Smooth`).
    pub(crate) fn is_smooth(self) -> bool {
        match self {
            Term::Area | Term::NightSky | Term::Twilight => true,
            Term::Point | Term::ShapedPoint | Term::Moon | Term::Distant | Term::Sun => false,
        }
    }
}

/// Where [`Tracer::direct_light`] sends a term's light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Route {
    /// Not computed: no shadow rays, no random numbers.
    Skip,
    /// Computed and discarded (a dropped term that draws random numbers).
    Scratch,
    /// Added to buffer `i`.
    To(usize),
}

/// A light source: one interface over the families. The per-family data
/// and estimators stay in their files (`area.rs`, `point.rs`, `sky.rs`);
/// this dispatches.
#[derive(Clone)]
pub(crate) enum LightSource<'a> {
    /// A point source, isotropic or shaped (`cos^m`, measured): one shadow
    /// ray.
    Point(&'a PointLight),
    /// Area sources, estimated together (see [`AreaSet`]).
    Area(AreaSet<'a>),
    /// The Moon's beam: a directional source, one shadow ray.
    Moon(&'a SkyState),
    /// A distant source, or the Sun's beam: one shadow ray.
    Distant(&'a DistantLight),
    /// The twilight sky: `sky_samples` cosine-weighted shadow rays.
    Twilight(sky::Dome<'a>),
    /// The sky dome: `sky_samples` cosine-weighted shadow rays.
    Dome(&'a SkyState),
}

/// Area sources as their estimators take them: together, since the
/// `analytic` estimator shares the closed-form total between them (each
/// one's shadow-ray count follows its share) and clamps their sum at 0.
#[derive(Clone)]
pub(crate) enum AreaSet<'a> {
    /// Every area source, by the chosen estimator.
    Every,
    /// The light tree's picks, each with its 1/pmf (`analytic`).
    Picked(Vec<(&'a AreaSource, f64)>),
}

impl LightSource<'_> {
    /// The term its light counts under.
    pub(crate) fn term(&self) -> Term {
        match self {
            LightSource::Point(l) if l.is_shaped() => Term::ShapedPoint,
            LightSource::Point(_) => Term::Point,
            LightSource::Area(_) => Term::Area,
            LightSource::Moon(_) => Term::Moon,
            LightSource::Dome(_) => Term::NightSky,
            LightSource::Distant(l) => l.term,
            LightSource::Twilight(_) => Term::Twilight,
        }
    }

    /// Its direct irradiance at `p` (normal `n`, on facet `ignore`) times
    /// `weight` (the sampler's 1/pmf; the lights no tree picks — Moon,
    /// dome, every area source — always have 1, and picked area sources
    /// carry their own), added to `out` and its light groups: the family's
    /// own estimator. `strata` feed the area sources' light samples.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn irradiance(
        &self,
        t: &Tracer,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        weight: f64,
        strata: Option<LightStrata>,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        match self {
            LightSource::Point(l) => t.point_irradiance(l, p, n, ignore, weight, c, out),
            LightSource::Area(AreaSet::Every) => {
                t.area_irradiance(p, n, ignore, strata, rng, c, out)
            }
            LightSource::Area(AreaSet::Picked(picks)) => {
                t.analytic(picks, p, n, ignore, strata, rng, c, out)
            }
            LightSource::Moon(sky) => t.moon_irradiance(sky, p, n, ignore, c, out),
            LightSource::Dome(sky) => t.dome_irradiance(sky, p, n, ignore, rng, c, out),
            LightSource::Distant(l) => t.distant_irradiance(l, p, n, ignore, c, out),
            LightSource::Twilight(dome) => t.dome_from(*dome, p, n, ignore, rng, c, out),
        }
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
) -> Option<crate::lights::tree::LightTree> {
    use crate::lights::tree::{LightTree, Split};
    use crate::settings::LightTreeSplit;
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
    let rule = match settings.light_tree_split {
        LightTreeSplit::Fixed => Split::Fixed {
            branches: settings.light_tree_branches as usize,
        },
        LightTreeSplit::Adaptive => Split::Adaptive {
            threshold: settings.light_split_threshold,
            max_picks: settings.light_tree_max_picks as usize,
        },
    };
    LightTree::build(infos, extent, rule)
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
