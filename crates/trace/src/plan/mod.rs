//! The quantitative half of the effect plan: what each effect is worth at
//! the camera, estimated by a cheap pilot, and the decision that follows.
//!
//! The scene crate's plan says which effects are *possible*; the tracer
//! knows what they cost and can estimate what they bring. Interreflection
//! is decided here: a pilot radiosity cache (`PILOT_TEXELS` texels,
//! `PILOT_RAYS` gather rays each) and a coarse grid of camera rays give the
//! indirect light's share of the band signal over the pixels that see a
//! surface and no emitter, neither in the pixel nor in its eight
//! neighbours (all pixels when every pixel does, as in a furnace); the
//! effect is simulated when that share exceeds `tolerance`.
//!
//! "Share" is the share of the *mean* over that pixel set — the pixels
//! `--target-error` governs, and the set `gloam bench plan` measures over
//! (`gloam_bench::truth::no_emitter_mask`; a pixel that shows
//! a point source shows an emitter). Pixels beside an emitter are left
//! out because their footprint holds some of it: at a quarter of the
//! night scenes' resolution they held the street lamps'
//! heads, whose radiance swamped the mean (the measured interreflection
//! share of `night-full-moon-lamps` was 4.8 % over whole-facet pixels, 2.7 %
//! over the pixel centres the pilot saw, 2.0 % over this set; the pilot
//! says 1.7 %). Every share also samples a window around each point
//! source's image (`Tracer::pilot_samples`), more densely where a pixel's
//! footprint is long against the source's height: a lamp's housing and
//! pool are a few pixels the grid misses. Light terms are also judged
//! per pixel (the 90th percentile, [`PartShares::pixel_p90`]), since one
//! source can be all the light a few pixels get. The pilot's bounce ratio
//! q (the enclosure's multiple-bounce albedo) also fixes how
//! many bounces brute-force path tracing needs for its truncated remainder
//! `share · q^k` to fall below the tolerance.

use glam::DVec3;
use gloam_scene::Scene;
use gloam_scene::plan::{EffectPlan, names};
use serde::Serialize;

use crate::indirect::{CacheSize, CacheSummary};
use crate::lights::Term;
use crate::settings::{Indirect, RenderSettings};
use crate::tracer::{PathState, RayCounts, TraceError, Tracer, stream};

mod pilot;

/// Pilot cache size: coarse, but the share it estimates only decides.
pub const PILOT_TEXELS: u32 = 1024;
pub const PILOT_RAYS: u32 = 64;
/// Pilot camera grid (at most; never finer than the image).
pub const PILOT_COLS: u32 = 64;
pub const PILOT_ROWS: u32 = 48;
/// Final-gather rays per pilot pixel.
pub const PILOT_GATHER: usize = 64;
/// Final-gather rays per pilot point inside a window, at least.
pub const PILOT_GATHER_MIN: usize = 4;

/// How interreflection was decided for a render (in `report.json`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct InterreflectionDecision {
    /// `off`, `cache` or `path` (what ran).
    pub method: String,
    /// The pilot's estimated share per band, over non-emitter pixels.
    pub estimated_share_by_band: Vec<(String, f64)>,
    /// Largest over bands (`None` when no pilot ran).
    pub estimated_share: Option<f64>,
    /// Pilot bounce ratio q.
    pub bounce_ratio: Option<f64>,
    /// Path tracing: the bounces used.
    pub diffuse_bounces: u32,
    pub reason: String,
    pub pilot_seconds: f64,
    /// The pilot's shares of the other light terms (None: no pilot ran).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub parts: Option<PartShares>,
    /// The full cache's solve (method `cache`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cache: Option<CacheSummary>,
    /// Method `path`: how many hot facets its bounces are guided toward
    /// (`path_guide`; absent when none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub guided_facets: Option<usize>,
}

/// What the pilot measured.
struct Pilot {
    share_by_band: Vec<f64>,
    ratio: f64,
    seconds: f64,
    /// Shares (largest over bands, over the pilot's pixels that do not see
    /// an emitter, or all pixels when every one does) of the direct-light
    /// terms and of emitters seen directly (over all pixels).
    parts: PartShares,
}

/// The pilot's shares of the other light terms. A light term's share is
/// its share of the whole signal with the interreflection it feeds (split
/// among the terms as one bounce of each splits), over the
/// interreflection pixel set.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct PartShares {
    /// Each light term's share (in JSON, one key per term).
    #[serde(flatten)]
    pub terms: TermShares,
    /// Emitters seen directly, share of the whole image's signal.
    pub direct_view: f64,
    /// Specular recursion: the change of the signal over the pilot's
    /// non-emitter pixels when mirror bounces are left out (None: no
    /// material on a facet reflects specularly).
    pub specular_recursion: Option<f64>,
    /// Transmissive occluders: the change when they stop light instead of
    /// attenuating it (None: nothing transmissive).
    pub transmissive_occluders: Option<f64>,
    /// The atmosphere (an upper bound): the Moon's direct light lost on its
    /// slant path, `moon · (1/T(550 nm) − 1)`, plus the whole dome term
    /// (scattered moonlight exists only through the atmosphere). None: no
    /// sky.
    pub atmosphere: Option<f64>,
    /// Whether the plan keeps specular recursion and transmissive
    /// occluders (each is left out when worth no more than the tolerance).
    pub specular_simulated: bool,
    pub transmissive_simulated: bool,
    pub tolerance: f64,
    /// Each light term's 90th percentile over the pilot's pixels of its
    /// share of the pixel, `part / max(pixel, 5 % of the mean pixel)`.
    pub pixel_p90: TermShares,
    /// Light terms the plan leaves out (worth ≤ tolerance in the mean and
    /// at the 90th percentile).
    pub skipped: Vec<String>,
    /// Whether the pilot's pixels saw any signal at all; with none, a
    /// share of 0 is no evidence, and no light term is left out (a probe
    /// may ask about points the camera does not see).
    pub signal_seen: bool,
}

/// A value per light term, by [`Term`]; in JSON one key per term
/// (`area_sources`, …).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TermShares([f64; Term::COUNT]);

impl TermShares {
    /// Light term `t`'s value.
    pub(crate) fn get(&self, t: Term) -> f64 {
        self.0[t as usize]
    }

    /// Values by term number.
    pub(crate) fn from_fn(f: impl FnMut(usize) -> f64) -> Self {
        Self(std::array::from_fn(f))
    }
}

impl Serialize for TermShares {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(Term::COUNT))?;
        for t in Term::ALL {
            m.serialize_entry(t.key(), &self.get(t))?;
        }
        m.end()
    }
}

/// What the pilot decided (see the module docs): the interreflection
/// decision with the shares it measured, the diffuse bounces path tracing
/// takes, and the effects left out as worth no more than the tolerance.
/// [`Tracer::plan`] makes it without changing the tracer;
/// [`Tracer::adopt`] takes it.
pub(crate) struct RenderPlan {
    pub(crate) decision: InterreflectionDecision,
    /// Diffuse bounces per path (0 unless the method is path tracing).
    pub(crate) diffuse_bounces: u32,
    /// Effects the pilot found worth no more than the tolerance.
    pub(crate) skip: crate::settings::Dropped,
    /// Whether a pilot ran (else the plan follows from the settings alone).
    pub(crate) piloted: bool,
}

impl Tracer {
    /// The pilot's plan for this tracer's scene and settings: reads the
    /// tracer, changes nothing.
    pub(crate) fn plan(&self) -> RenderPlan {
        let s = &self.settings;
        let tol = s.tolerance;
        // Shared instances have no facets of their own for the cache's
        // texels: their interreflection is path-traced, and the pilot
        // (whose estimate is a coarse cache) does not run.
        let shared = self.geom.has_shared();
        let requested = s.requested_indirect();
        let mut d = InterreflectionDecision::default();
        let mut skip = crate::settings::Dropped::default();
        let possible = self.mats.iter().any(|m| m.has_diffuse)
            && (Term::ALL.iter().any(|t| t.present(self)) || self.sky.is_some());
        let pilot =
            (possible && !shared && (requested == Indirect::Auto || s.diffuse_bounces == 0))
                .then(|| self.pilot(requested != Indirect::Off));
        if let Some(p) = &pilot {
            let share = p.share_by_band.iter().copied().fold(0.0, f64::max);
            d.estimated_share = Some(share);
            d.estimated_share_by_band = self
                .wl
                .band_names
                .iter()
                .cloned()
                .zip(p.share_by_band.iter().copied())
                .collect();
            d.bounce_ratio = Some(p.ratio);
            d.pilot_seconds = p.seconds;
            d.parts = Some(p.parts.clone());
        } else if !possible {
            d.estimated_share = Some(0.0);
        }
        if let Some(parts) = d.parts.as_mut() {
            self.decide_specular_and_transmission(parts, &d.estimated_share_by_band, &mut skip);
        }
        // Unpiloted, shared instances' interreflection is taken to matter.
        let share = d
            .estimated_share
            .unwrap_or(if shared && possible { 1.0 } else { 0.0 });
        let shared_facets = shared.then_some(self.preparation.shared_facets);
        let method =
            interreflection_method(requested, share, tol, possible, shared_facets, s, &mut d);
        let mut diffuse_bounces = 0;
        if method == Indirect::Path {
            diffuse_bounces = s.diffuse_bounces;
            if diffuse_bounces == 0 {
                // share · q^k ≤ tol.
                let q = d.bounce_ratio.unwrap_or(0.5).clamp(1e-6, 0.999_999);
                let k = if share > tol {
                    ((tol / share).ln() / q.ln()).ceil() + 1.0
                } else {
                    1.0
                };
                diffuse_bounces = (k as u32).clamp(1, 100_000);
                d.reason.push_str(&format!(
                    "; {diffuse_bounces} bounces so the truncated remainder share·q^k < tolerance (q = {q:.3})"
                ));
            }
            d.diffuse_bounces = diffuse_bounces;
        }
        d.method = match method {
            Indirect::Cache => "cache",
            Indirect::Path => "path",
            _ => "off",
        }
        .into();
        RenderPlan {
            decision: d,
            diffuse_bounces,
            skip,
            piloted: pilot.is_some(),
        }
    }

    /// Takes `plan`: its bounces and skipped effects, and with `solve` the
    /// full cache when its method is `cache`.
    pub(crate) fn adopt(&mut self, plan: RenderPlan, solve: bool) {
        let mut d = plan.decision;
        self.settings.diffuse_bounces = plan.diffuse_bounces;
        self.skip = plan.skip;
        if d.method == "cache" && solve {
            let step = crate::prep::Preparation::begin("cache", self.observer.as_ref());
            let cache = self.build_cache_split(self.render_cache_size(), self.layer_groups());
            self.preparation.end(step, self.observer.clone().as_ref());
            d.cache = Some(cache.summary.clone());
            self.cache = Some(cache);
        }
        self.interreflection = d;
    }

    /// This tracer's world under other settings, with nothing planned: the
    /// pilot's probes of an effect left out.
    fn with_settings(&self, settings: RenderSettings) -> Tracer {
        Tracer {
            world: self.world.clone(),
            settings,
            cache: None,
            interreflection: Default::default(),
            skip: Default::default(),
            build_seconds: 0.0,
            preparation: Default::default(),
            observer: None,
            guide: None,
        }
    }

    /// Estimates specular recursion, transmissive occluders and the
    /// atmosphere (see [`PartShares`]) and leaves out (in `skip`) the first
    /// two when each is worth no more than the tolerance (never under
    /// `all_effects`), and any light term worth no more. `ir_share` (per
    /// band) rescales the direct-light sums of [`Tracer::pilot_traced`] to
    /// the whole signal.
    fn decide_specular_and_transmission(
        &self,
        parts: &mut PartShares,
        ir_share: &[(String, f64)],
        skip: &mut crate::settings::Dropped,
    ) {
        let tol = self.settings.tolerance;
        parts.tolerance = tol;
        let spec =
            self.mats.iter().any(|m| !m.ks.is_empty()) && !self.settings.drop.specular_recursion;
        let trans = self.mats.iter().any(|m| m.trans.is_some())
            && !self.settings.drop.transmissive_occluders;
        if spec || trans {
            let mut direct_only = self.settings.clone();
            direct_only.diffuse_bounces = 0;
            let full = self.with_settings(direct_only.clone()).pilot_traced();
            let share = |set: fn(&mut RenderSettings)| -> f64 {
                let mut without = direct_only.clone();
                set(&mut without);
                let without = self.with_settings(without).pilot_traced();
                full.iter()
                    .zip(&without)
                    .enumerate()
                    .map(|(b, (f, w))| {
                        let ir = ir_share.get(b).map_or(0.0, |x| x.1).clamp(0.0, 0.99);
                        let whole = f / (1.0 - ir);
                        if whole > 0.0 {
                            (f - w).abs() / whole
                        } else {
                            0.0
                        }
                    })
                    .fold(0.0, f64::max)
            };
            if spec {
                parts.specular_recursion = Some(share(|s| s.drop.specular_recursion = true));
            }
            if trans {
                parts.transmissive_occluders =
                    Some(share(|s| s.drop.transmissive_occluders = true));
            }
        }
        let keep = |x: Option<f64>, all: bool| x.is_some_and(|x| x > tol || all);
        parts.specular_simulated = keep(parts.specular_recursion, self.settings.all_effects);
        parts.transmissive_simulated =
            keep(parts.transmissive_occluders, self.settings.all_effects);
        if spec && !parts.specular_simulated {
            skip.specular_recursion = true;
        }
        if trans && !parts.transmissive_simulated {
            skip.transmissive_occluders = true;
        }
        // Light terms the scene has: left out only when worth no more than
        // the tolerance both in the mean and at the 90th percentile of the
        // pixels (a source can be all the light a few pixels get).
        if !self.settings.all_effects && parts.signal_seen {
            for t in Term::ALL {
                let (mean, p90) = (parts.terms.get(t), parts.pixel_p90.get(t));
                if t.present(self) && mean.max(p90) <= tol {
                    parts.skipped.push(t.name().to_string());
                    skip.set(t.name());
                }
            }
        }
        if let Some(sky) = &self.sky {
            let s = &sky.summary;
            let t = gloam_sky::Atmosphere::new(s.height_m, s.visibility_km)
                .map(|a| a.direct_transmittance(550.0, s.moon_elevation_deg))
                .unwrap_or(1.0);
            let lost = if t > 0.0 && s.moon_direct {
                parts.terms.get(Term::Moon) * (1.0 / t - 1.0)
            } else {
                0.0
            };
            parts.atmosphere = Some(lost + parts.terms.get(Term::NightSky));
        }
    }
}

/// The interreflection method for the `requested` one, given the pilot's
/// `share` of the signal, with its reason in `d`. With shared instances
/// (`shared_facets` placed facets) the cache, which needs facets of its
/// own for its texels, gives way to path tracing.
fn interreflection_method(
    requested: Indirect,
    share: f64,
    tol: f64,
    possible: bool,
    shared_facets: Option<u64>,
    s: &RenderSettings,
    d: &mut InterreflectionDecision,
) -> Indirect {
    if let Some(n) = shared_facets
        && (requested == Indirect::Cache || (requested == Indirect::Auto && share > tol))
    {
        d.reason = format!(
            "shared instances ({n} placed facets) have no facets of their own for the radiosity cache: path tracing"
        );
        return Indirect::Path;
    }
    match requested {
        Indirect::Auto if share > tol => {
            d.reason = format!(
                "pilot: interreflection is {:.2} % of the signal (> tolerance {:.2} %): radiosity cache + final gather",
                100.0 * share,
                100.0 * tol
            );
            Indirect::Cache
        }
        Indirect::Auto => {
            d.reason = if possible {
                format!(
                    "pilot: interreflection is at most the tolerance {:.2e} of the signal (pilot {:.2e}; below the tolerance the coarse pilot claims only the bound): not simulated",
                    tol, share
                )
            } else {
                "no diffusely reflecting material, or nothing lights the scene".into()
            };
            Indirect::Off
        }
        Indirect::Off if s.drop.interreflection => {
            d.reason = "dropped (drop = interreflection): direct light only".into();
            Indirect::Off
        }
        Indirect::Off => {
            d.reason = "indirect = off (set by the user): direct light only".into();
            Indirect::Off
        }
        Indirect::Cache => {
            d.reason = "indirect = cache (set by the user)".into();
            Indirect::Cache
        }
        Indirect::Path => {
            d.reason = "brute-force path tracing (set by the user)".into();
            Indirect::Path
        }
    }
}

/// The effect plan of `scene` as a render with `settings` would run it:
/// the scene's structural plan with the tracer's pilot estimate and
/// decision for interreflection.
pub fn effect_plan(scene: &Scene, settings: &RenderSettings) -> Result<EffectPlan, TraceError> {
    Ok(effect_plan_observed(scene, settings, None)?.0)
}

/// As [`effect_plan`], telling `observer` about each preparation step, and
/// returning where the preparation's time and memory went.
pub fn effect_plan_observed(
    scene: &Scene,
    settings: &RenderSettings,
    observer: Option<crate::prep::PrepObserver>,
) -> Result<(EffectPlan, crate::prep::Preparation), TraceError> {
    let t = Tracer::prepare_observed(scene, settings, false, observer)?;
    Ok((t.effect_plan(scene), t.preparation))
}

impl Tracer {
    /// The effect plan this tracer runs: `scene`'s structural plan with the
    /// pilot's interreflection decision and the shares it measured. The one
    /// place the plan of a render is put together (`gloam plan`, and `gloam
    /// render` and the Python package through `gloam_pipeline`'s
    /// `RenderJob`). `scene` is the
    /// scene as its user wrote it: a band added for a camera
    /// (`gloam_pipeline::detected`) is no effect of the scene's.
    pub fn effect_plan(&self, scene: &Scene) -> EffectPlan {
        let mut plan = gloam_scene::plan::plan(scene);
        plan.extend([interreflection_effect(&self.interreflection)]);
        annotate_shares(&mut plan, &self.interreflection);
        plan
    }
}

/// Fills in `estimated_share` of the light terms the pilot measured. These
/// terms stay as the scene plan decided (a term the scene has is simulated:
/// the pilot reports its worth; a term it lacks is exactly 0).
pub fn annotate_shares(plan: &mut EffectPlan, d: &InterreflectionDecision) {
    let Some(p) = &d.parts else { return };
    for e in &mut plan.effects {
        let decided = |e: &mut gloam_scene::plan::Effect, share: f64, kept: bool, what: &str| {
            e.estimated_share = Some(share);
            if e.enabled && !kept {
                e.enabled = false;
                e.reason = format!(
                    "pilot: {what} is {share:.2e} of the signal (≤ tolerance {:.2e}): not simulated ({})",
                    p.tolerance, e.reason
                );
            } else if e.enabled {
                e.reason = format!(
                    "pilot: {what} is {:.2} % of the signal (> tolerance {:.2} %): {}",
                    100.0 * share,
                    100.0 * p.tolerance,
                    e.reason
                );
            }
        };
        match (
            e.name.as_str(),
            p.specular_recursion,
            p.transmissive_occluders,
        ) {
            (names::SPECULAR_RECURSION, Some(x), _) => {
                decided(e, x, p.specular_simulated, "specular recursion");
                continue;
            }
            (names::TRANSMISSIVE_OCCLUDERS, _, Some(x)) => {
                decided(
                    e,
                    x,
                    p.transmissive_simulated,
                    "light through transmissive occluders",
                );
                continue;
            }
            _ => {}
        }
        if e.name == names::ATMOSPHERE
            && let Some(x) = p.atmosphere
        {
            e.estimated_share = Some(x);
            e.reason.push_str(" (share: an upper bound, Moon's slant-path loss + dome; the sky model has no airless mode)");
            continue;
        }
        let term = Term::by_name(&e.name).map(|t| (p.terms.get(t), p.pixel_p90.get(t)));
        if let Some((mean, p90)) = term {
            if p.skipped.contains(&e.name) {
                e.enabled = false;
                e.reason = format!(
                    "pilot: {mean:.2e} of the signal, {p90:.2e} of the pixel at the 90th percentile (both ≤ tolerance {:.2e}): not simulated ({})",
                    p.tolerance, e.reason
                );
                e.estimated_share = Some(mean);
            } else {
                if e.enabled {
                    e.reason.push_str(&format!(
                        " (pilot: {mean:.2e} of the signal, {p90:.2e} of the pixel at the 90th percentile)"
                    ));
                }
                e.estimated_share.get_or_insert(mean);
            }
        } else if e.name == names::DIRECT_VIEW {
            e.estimated_share.get_or_insert(p.direct_view);
        }
    }
}

/// The plan entry for a decision.
pub fn interreflection_effect(d: &InterreflectionDecision) -> gloam_scene::plan::Effect {
    let mut e =
        gloam_scene::plan::Effect::new(names::INTERREFLECTION, d.method != "off", d.reason.clone());
    e.estimated_share = d.estimated_share;
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pilot's samples stand for the whole image (weights in pixels
    /// sum to its pixel count), and the road lamp's window of
    /// `street-switch-on` covers both its image and its pool's: the road
    /// under the lamp, 8 m below it, which is the surface in its brightest
    /// lattice direction or nearer.
    #[test]
    fn pilot_window_covers_the_lamp_and_its_pool() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../sims/street-switch-on/scene.toml"
        );
        let mut scene =
            gloam_scene::load(std::path::Path::new(path), &gloam_io::ReadLog::off()).unwrap();
        scene.camera.width = 80;
        scene.camera.height = 60;
        let t = Tracer::new(&scene, &RenderSettings::default()).unwrap();
        let s = t.pilot_samples(PILOT_COLS, PILOT_ROWS);
        let total: f64 = s.iter().map(|p| p.2).sum();
        assert!((total - 4800.0).abs() < 1e-9, "{total}");
        let covered = |p: DVec3| {
            let (x, y) = t.camera.project(p).unwrap();
            let (px, py) = (x.floor(), y.floor());
            s.iter()
                .any(|q| !q.3 && q.0.floor() == px && q.1.floor() == py)
        };
        assert!(covered(DVec3::new(175.0, -3.5, 8.0)));
        assert!(covered(DVec3::new(175.0, -3.5, 0.0)));
        // The grid's own points (3072) are all there, those inside a
        // window at weight 0.
        assert_eq!(s.iter().filter(|q| q.3).count(), 3072);
    }
}
