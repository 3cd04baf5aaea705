//! The effect plan: which effects a render of a scene has to simulate, and
//! why. Simulate only what the scene calls for — no area sources, no area
//! sampling; no specular materials, no recursion; no `[sky]`, no moon.
//!
//! The plan is an ordered list of [`Effect`]s with stable names (see
//! [`names`]); later stages (the sensor chain) append their own effects with
//! [`EffectPlan::extend`] or [`plan_with`].

use std::fmt;

use serde::Serialize;

use crate::{Scene, SkyConfig};

/// Stable effect names.
pub mod names {
    pub const AREA_SOURCES: &str = "area-sources";
    pub const SHAPED_POINT_SOURCES: &str = "shaped-point-sources";
    pub const POINT_SOURCES: &str = "point-sources";
    pub const DISTANT_SOURCES: &str = "distant-sources";
    pub const TRANSMISSIVE_OCCLUDERS: &str = "transmissive-occluders";
    pub const SPECULAR_RECURSION: &str = "specular-recursion";
    pub const INTERREFLECTION: &str = "interreflection";
    pub const DIRECT_VIEW: &str = "direct-view";
    pub const MOON: &str = "moon";
    pub const NIGHT_SKY: &str = "night-sky";
    pub const SUN: &str = "sun";
    pub const TWILIGHT_SKY: &str = "twilight-sky";
    pub const ATMOSPHERE: &str = "atmosphere";
    pub const SENSOR: &str = "sensor";
}

/// One effect: whether it is simulated and why, and — where a later stage
/// has estimated it — what it is worth.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Effect {
    pub name: String,
    pub enabled: bool,
    pub reason: String,
    /// The effect's estimated fraction of the band signal at the camera
    /// (largest over bands; an upper bound where marked in `reason`), or
    /// `null` where nothing has been estimated. The scene crate only reads
    /// structure; the tracer's pilot fills this in (`gloam_trace::plan`).
    pub estimated_share: Option<f64>,
}

impl Effect {
    pub fn new(name: impl Into<String>, enabled: bool, reason: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            enabled,
            reason: reason.into(),
            estimated_share: None,
        }
    }

    /// The same effect with an estimated share.
    pub fn with_share(mut self, share: f64) -> Self {
        self.estimated_share = Some(share);
        self
    }
}

/// The plan: effects in a fixed order. Serialises as
/// `{"effects":[{"name":…,"enabled":…,"reason":…}]}`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct EffectPlan {
    pub effects: Vec<Effect>,
}

impl EffectPlan {
    /// True when the effect is in the plan and enabled.
    pub fn is_enabled(&self, name: &str) -> bool {
        self.get(name).is_some_and(|e| e.enabled)
    }

    /// The effect called `name`.
    pub fn get(&self, name: &str) -> Option<&Effect> {
        self.effects.iter().find(|e| e.name == name)
    }

    /// Adds effects; one with the name of an existing effect replaces it in
    /// place (so a later stage can refine a decision, e.g. "sensor").
    pub fn extend(&mut self, extra: impl IntoIterator<Item = Effect>) {
        for e in extra {
            match self.effects.iter_mut().find(|x| x.name == e.name) {
                Some(x) => *x = e,
                None => self.effects.push(e),
            }
        }
    }

    /// Names of the enabled effects, in plan order.
    pub fn enabled(&self) -> Vec<&str> {
        self.effects
            .iter()
            .filter(|e| e.enabled)
            .map(|e| e.name.as_str())
            .collect()
    }
}

/// A readable table: `effect  on/off  reason`.
impl fmt::Display for EffectPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w = self
            .effects
            .iter()
            .map(|e| e.name.len())
            .max()
            .unwrap_or(6)
            .max(6);
        writeln!(f, "{:<w$}  {:<3}  {:>9}  reason", "effect", "on", "share")?;
        writeln!(f, "{:-<w$}  ---  ---------  {:-<40}", "", "")?;
        for e in &self.effects {
            let share = match e.estimated_share {
                Some(0.0) => "0".to_string(),
                Some(x) if x >= 1e-3 => format!("{:.1} %", 100.0 * x),
                Some(x) => format!("{x:.1e}"),
                None => "-".to_string(),
            };
            writeln!(
                f,
                "{:<w$}  {:<3}  {:>9}  {}",
                e.name,
                if e.enabled { "yes" } else { "no" },
                share,
                e.reason
            )?;
        }
        Ok(())
    }
}

/// `n thing(s)`.
fn count(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// A name list, shortened after a few entries.
fn list<S: AsRef<str>>(items: &[S]) -> String {
    const MAX: usize = 6;
    let mut s: Vec<&str> = items.iter().take(MAX).map(|x| x.as_ref()).collect();
    let more;
    if items.len() > MAX {
        more = format!("… {} more", items.len() - MAX);
        s.push(&more);
    }
    s.join(", ")
}

/// `(name, detail)` entries with runs of equal ones merged: the placements
/// of an instanced point source are listed once, as `name ×n detail`.
fn grouped<'a>(items: impl Iterator<Item = (&'a str, String)>) -> Vec<String> {
    let mut runs: Vec<(&str, String, usize)> = Vec::new();
    for (name, detail) in items {
        match runs.last_mut() {
            Some((n, d, k)) if *n == name && *d == detail => *k += 1,
            _ => runs.push((name, detail, 1)),
        }
    }
    runs.into_iter()
        .map(|(n, d, k)| {
            if k > 1 {
                format!("{n} ×{k}{d}")
            } else {
                format!("{n}{d}")
            }
        })
        .collect()
}

fn fmt_num(x: f64) -> String {
    if x == x.trunc() && x.abs() < 1e9 {
        format!("{}", x as i64)
    } else {
        format!("{x}")
    }
}

/// Which materials are actually on facets (flat or shared).
fn used_materials(scene: &Scene) -> Vec<bool> {
    let mut used = vec![false; scene.materials.len()];
    for f in scene
        .facets
        .iter()
        .chain(scene.shared.iter().flat_map(|s| &s.prototype))
    {
        used[f.material] = true;
    }
    used
}

/// The effect plan of a scene (scene effects only; see [`plan_with`]):
/// one effect per kind of light or light path, in a fixed order.
pub fn plan(scene: &Scene) -> EffectPlan {
    let used = used_materials(scene);
    let emitting = scene.emitting_facets();
    let mut effects = vec![
        area_sources(scene, &used, &emitting),
        shaped_point_sources(scene),
        isotropic_point_sources(scene),
        distant_sources(scene),
        transmissive_occluders(scene, &used),
        specular_recursion(scene, &used),
        interreflection(scene, &used, &emitting),
        direct_view(scene, &emitting),
    ];
    effects.extend(sky_effects(scene.sky.as_ref()));
    effects.push(sensor(scene));
    EffectPlan { effects }
}

/// Area sources: facets whose material emits, and how their emission is
/// shaped (Lambertian, an exponent, or a measured file).
fn area_sources(scene: &Scene, used: &[bool], emitting: &[usize]) -> Effect {
    let mut emitting_objects: Vec<&str> = Vec::new();
    for &i in emitting {
        let o = scene.facets[i].object.as_str();
        if !emitting_objects.contains(&o) {
            emitting_objects.push(o);
        }
    }
    if emitting.is_empty() {
        Effect::new(names::AREA_SOURCES, false, "no emitting facets")
    } else {
        let shaped: Vec<String> = scene
            .materials
            .iter()
            .enumerate()
            .filter(|(i, m)| {
                used[*i]
                    && m.emission
                        .as_ref()
                        .is_some_and(|e| e.shape_exponent > 0.0 || e.luminaire.is_some())
            })
            .map(
                |(_, m)| match m.emission.as_ref().and_then(|e| e.luminaire.as_ref()) {
                    // A measured distribution: its file, not an exponent.
                    Some(l) => format!(
                        "{} {}",
                        m.name,
                        l.file
                            .file_name()
                            .map_or_else(String::new, |f| f.to_string_lossy().into_owned())
                    ),
                    None => format!(
                        "{} m = {}",
                        m.name,
                        fmt_num(m.emission.as_ref().map_or(0.0, |e| e.shape_exponent))
                    ),
                },
            )
            .collect();
        let shape = if shaped.is_empty() {
            "Lambertian".to_string()
        } else {
            format!("shaped: {}", list(&shaped))
        };
        Effect::new(
            names::AREA_SOURCES,
            true,
            format!(
                "{} ({}); {shape}",
                count(emitting.len(), "emitting facet", "emitting facets"),
                list(&emitting_objects)
            ),
        )
    }
}

/// Point sources with a shape exponent m > 0.
fn shaped_point_sources(scene: &Scene) -> Effect {
    let n_shaped = scene.point_sources.iter().filter(|p| p.is_shaped()).count();
    let shaped = grouped(
        scene
            .point_sources
            .iter()
            .filter(|p| p.is_shaped())
            .map(|p| {
                (
                    p.name.as_str(),
                    format!(" m = {}", fmt_num(p.shape_exponent)),
                )
            }),
    );
    if shaped.is_empty() {
        Effect::new(
            names::SHAPED_POINT_SOURCES,
            false,
            "no point sources with shape exponent m > 0",
        )
    } else {
        Effect::new(
            names::SHAPED_POINT_SOURCES,
            true,
            format!(
                "{} with m > 0 ({})",
                count(n_shaped, "point source", "point sources"),
                list(&shaped)
            ),
        )
    }
}

/// Isotropic point sources (m = 0).
fn isotropic_point_sources(scene: &Scene) -> Effect {
    let n_shaped = scene.point_sources.iter().filter(|p| p.is_shaped()).count();
    let n_iso = scene.point_sources.len() - n_shaped;
    let iso = grouped(
        scene
            .point_sources
            .iter()
            .filter(|p| !p.is_shaped())
            .map(|p| (p.name.as_str(), String::new())),
    );
    if iso.is_empty() {
        Effect::new(
            names::POINT_SOURCES,
            false,
            "no isotropic point sources (m = 0)",
        )
    } else {
        Effect::new(
            names::POINT_SOURCES,
            true,
            format!(
                "{} ({})",
                count(n_iso, "isotropic point source", "isotropic point sources"),
                list(&iso)
            ),
        )
    }
}

/// Distant sources (parallel light from a direction).
fn distant_sources(scene: &Scene) -> Effect {
    let distant: Vec<&str> = scene
        .distant_sources
        .iter()
        .map(|d| d.name.as_str())
        .collect();
    if distant.is_empty() {
        Effect::new(names::DISTANT_SOURCES, false, "no distant sources")
    } else {
        let what = count(distant.len(), "distant source", "distant sources");
        Effect::new(
            names::DISTANT_SOURCES,
            true,
            format!("{what} ({})", list(&distant)),
        )
    }
}

/// Transmissive occluders: materials on facets that let light through.
fn transmissive_occluders(scene: &Scene, used: &[bool]) -> Effect {
    let transmissive: Vec<&str> = scene
        .materials
        .iter()
        .enumerate()
        .filter(|(i, m)| used[*i] && m.is_transmissive())
        .map(|(_, m)| m.name.as_str())
        .collect();
    if transmissive.is_empty() {
        Effect::new(
            names::TRANSMISSIVE_OCCLUDERS,
            false,
            "no transmissive materials on any facet",
        )
    } else {
        Effect::new(
            names::TRANSMISSIVE_OCCLUDERS,
            true,
            format!(
                "{} let light through ({}): shadow rays are attenuated, not stopped",
                count(transmissive.len(), "material", "materials"),
                list(&transmissive)
            ),
        )
    }
}

/// Specular recursion: materials on facets with a specular fraction.
fn specular_recursion(scene: &Scene, used: &[bool]) -> Effect {
    let specular: Vec<String> = scene
        .materials
        .iter()
        .enumerate()
        .filter(|(i, m)| used[*i] && m.is_specular())
        .map(|(_, m)| format!("{} {}", m.name, fmt_num(m.specular_fraction)))
        .collect();
    if specular.is_empty() {
        Effect::new(
            names::SPECULAR_RECURSION,
            false,
            "all materials on facets are purely diffuse",
        )
    } else {
        Effect::new(
            names::SPECULAR_RECURSION,
            true,
            format!(
                "{} with a specular fraction > 0 ({})",
                count(specular.len(), "material", "materials"),
                list(&specular)
            ),
        )
    }
}

/// Interreflection: light reflected diffusely more than once. The scene
/// crate can only say whether it is possible; the tracer's pilot
/// estimates its share and decides (gloam_trace::plan).
fn interreflection(scene: &Scene, used: &[bool], emitting: &[usize]) -> Effect {
    let reflecting: Vec<&str> = scene
        .materials
        .iter()
        .enumerate()
        .filter(|(i, m)| {
            used[*i] && m.specular_fraction < 1.0 && m.reflectance.values().iter().any(|&v| v > 0.0)
        })
        .map(|(_, m)| m.name.as_str())
        .collect();
    let lit = !emitting.is_empty()
        || !scene.point_sources.is_empty()
        || scene.sky.as_ref().is_some_and(|s| s.moon || s.night_sky);
    if reflecting.is_empty() || !lit {
        Effect::new(
            names::INTERREFLECTION,
            false,
            if lit {
                "no material on a facet reflects diffusely"
            } else {
                "nothing lights the scene"
            },
        )
        .with_share(0.0)
    } else {
        Effect::new(
            names::INTERREFLECTION,
            true,
            format!(
                "{} reflect diffusely ({}); the tracer's pilot estimates the share",
                count(reflecting.len(), "material", "materials"),
                list(&reflecting)
            ),
        )
    }
}

/// Direct view: an emitter or point source in the camera frustum, seen
/// from the side it emits to (occlusion is not checked).
fn direct_view(scene: &Scene, emitting: &[usize]) -> Effect {
    let cam = &scene.camera;
    let mut seen: Vec<String> = Vec::new();
    let mut seen_facets = 0usize;
    for &i in emitting {
        let f = &scene.facets[i];
        let front = (cam.position - f.centroid()).dot(f.normal()) > 0.0;
        if front && cam.frustum_overlaps(&f.vertices) {
            seen_facets += 1;
            if !seen.contains(&f.object) {
                seen.push(f.object.clone());
            }
        }
    }
    let mut seen_points = 0usize;
    let mut seen_lamps = Vec::new();
    for p in &scene.point_sources {
        let toward = (cam.position - p.position).dot(p.direction) > 0.0;
        if (!p.is_shaped() || toward) && cam.sees_point(p.position) {
            seen_points += 1;
            seen_lamps.push((p.name.as_str(), String::new()));
        }
    }
    seen.extend(grouped(seen_lamps.into_iter()));
    if seen.is_empty() {
        Effect::new(
            names::DIRECT_VIEW,
            false,
            "no emitter or point source faces the camera inside its field of view",
        )
    } else {
        let mut what = Vec::new();
        if seen_facets > 0 {
            what.push(count(seen_facets, "emitting facet", "emitting facets"));
        }
        if seen_points > 0 {
            what.push(count(seen_points, "point source", "point sources"));
        }
        Effect::new(
            names::DIRECT_VIEW,
            true,
            format!(
                "{} in the camera's field of view ({}): rendered as seen directly",
                what.join(" and "),
                list(&seen)
            ),
        )
    }
}

/// The sensor the scene names, if any.
fn sensor(scene: &Scene) -> Effect {
    match &scene.sensor {
        None => Effect::new(
            names::SENSOR,
            false,
            "no sensor in the scene: the output is at-aperture radiance",
        ),
        Some(s) => Effect::new(
            names::SENSOR,
            true,
            format!("sensor '{s}' (its stages are planned by the sensor crate)"),
        ),
    }
}

/// The sky terms: each off without a [sky] block, else as [sky] and the
/// Sun's elevation at its instant decide.
fn sky_effects(sky: Option<&SkyConfig>) -> [Effect; 5] {
    let Some(s) = sky else {
        let why = "no [sky] block (indoor scene)";
        return [
            Effect::new(names::MOON, false, why),
            Effect::new(names::NIGHT_SKY, false, why),
            Effect::new(names::SUN, false, why),
            Effect::new(names::TWILIGHT_SKY, false, why),
            Effect::new(
                names::ATMOSPHERE,
                false,
                format!("{why}: no atmospheric path"),
            ),
        ];
    };
    let when = format!(
        "{} at {:.3}°, {:.3}°",
        s.utc, s.latitude_deg, s.longitude_deg
    );
    [
        moon(s, &when),
        night_sky(s, &when),
        sun(s, &when),
        twilight_sky(s),
        atmosphere(s),
    ]
}

/// The Moon, when [sky] enables it.
fn moon(s: &SkyConfig, when: &str) -> Effect {
    if s.moon {
        Effect::new(
            names::MOON,
            true,
            format!(
                "moon = true in [sky] ({when}){}; its elevation and phase decide the level",
                if s.overcast { ", overcast" } else { "" }
            ),
        )
    } else {
        Effect::new(names::MOON, false, "moon = false in [sky]")
    }
}

/// The night sky (stars, airglow), when [sky] enables it.
fn night_sky(s: &SkyConfig, when: &str) -> Effect {
    if s.night_sky {
        Effect::new(
            names::NIGHT_SKY,
            true,
            format!("night_sky = true in [sky] ({when})"),
        )
    } else {
        Effect::new(names::NIGHT_SKY, false, "night_sky = false in [sky]")
    }
}

/// The Sun's direct beam, when it is up and not behind an overcast.
fn sun(s: &SkyConfig, when: &str) -> Effect {
    let sun_el = s.sun_elevation_deg();
    if s.sun_beam() {
        Effect::new(
            names::SUN,
            true,
            format!("the Sun is up ({sun_el:.2}° at {when}): its direct beam"),
        )
    } else if s.overcast && sun_el > 0.0 {
        Effect::new(
            names::SUN,
            false,
            "overcast: the deck passes the Sun's light as the twilight sky's",
        )
    } else {
        Effect::new(
            names::SUN,
            false,
            format!("the Sun is below the horizon ({sun_el:.2}°)"),
        )
    }
}

/// The twilight sky, while the Sun is at or above −18°.
fn twilight_sky(s: &SkyConfig) -> Effect {
    let sun_el = s.sun_elevation_deg();
    if s.twilight() {
        Effect::new(
            names::TWILIGHT_SKY,
            true,
            format!(
                "the Sun at {sun_el:.2}° (≥ −18°) lights the sky: twilight{}",
                if sun_el > 10.0 {
                    " (the model is validated up to +10°; daylight beyond is an extrapolation)"
                } else {
                    ""
                }
            ),
        )
    } else {
        Effect::new(
            names::TWILIGHT_SKY,
            false,
            format!("the Sun at {sun_el:.2}° (below −18°): astronomical night"),
        )
    }
}

/// The atmosphere sky light crosses, when any sky term is on.
fn atmosphere(s: &SkyConfig) -> Effect {
    if s.moon || s.night_sky || s.twilight() {
        Effect::new(
            names::ATMOSPHERE,
            true,
            format!(
                "sky light crosses the atmosphere (visibility {} km{})",
                fmt_num(s.visibility_km),
                if s.overcast { ", overcast" } else { "" }
            ),
        )
    } else {
        Effect::new(
            names::ATMOSPHERE,
            false,
            "[sky] has neither moon nor night sky enabled",
        )
    }
}

/// The scene's plan followed by `extra` effects (e.g. the sensor chain's
/// stages); an extra effect with an existing name replaces it in place.
pub fn plan_with(scene: &Scene, extra: impl IntoIterator<Item = Effect>) -> EffectPlan {
    let mut p = plan(scene);
    p.extend(extra);
    p
}
