//! The sky's clock: dusk and dawn, time-compressed, in a sequence.
//!
//! ```toml
//! [sky]
//! utc_at_start = "2025-10-21T22:15:00Z"   # default: the scene's [sky] utc
//! time_scale = 360.0                      # sky seconds per sequence second
//! renders = 20                            # default: one per degree of Sun
//!
//! [groups.street_lamps]
//! # On when the site's horizontal illuminance falls below on_lux, reaching
//! # full output run_up_s (sky seconds) later: a lamp's photocell.
//! photocell = { on_lux = 20.0, run_up_s = 180.0 }
//! ```
//!
//! The sky changes every group's light (the Sun, its sky, the Moon move),
//! so it cannot be a weight on layers rendered once. The scene is rendered
//! at `renders` instants spread evenly over the sequence ([`Sequence::sky_key_times_s`]),
//! and a frame between two of them takes each layer's pixels
//! geometrically between theirs (`a^{1−f} b^f`: exact for light that
//! falls exponentially, as twilight does — ×2.5 per degree of Sun — where
//! linear mixing is 11 % too bright halfway between renders a degree
//! apart; linearly where either is zero).
//!
//! The photocell sees the sky model's horizontal illuminance at the site
//! (`gloam sky`'s: the Sun's direct and sky light, and the Moon and night
//! sky where the scene has them), not the rendered image: a lamp's
//! photocell looks up at the sky. Its switching instants are found to a
//! hundredth of a frame and become the group's keys.

use gloam_sky::UtcInstant;
use serde::Deserialize;

use super::Sequence;
use crate::build::num;
use crate::error::{FieldPath, Locator, SceneError};
use crate::{Scene, SkyConfig};

/// Fastest sky clock: a day in under a second of sequence.
pub const MAX_TIME_SCALE: f64 = 1e5;
/// Degrees of Sun travel between two renders past which the clock warns:
/// twice the default's spacing.
pub const WARN_DEGREES_PER_RENDER: f64 = 2.0 * DEGREES_PER_RENDER;
/// Most renders of the sky a sequence may ask for.
pub const MAX_SKY_RENDERS: u32 = 1000;
/// The default spacing of the sky's renders, degrees of Sun elevation.
pub const DEGREES_PER_RENDER: f64 = 1.0;
/// Longest step between samples of the Sun's path, sky seconds (the Sun
/// moves at most 2.5° in it).
const PATH_STEP_S: f64 = 600.0;
/// Longest sky time a clock may run, s (a leap year).
pub const MAX_SKY_SPAN_S: f64 = 366.0 * 86_400.0;
/// Brightest photocell threshold, lux (full daylight is ~10⁵ lx).
pub const MAX_ON_LUX: f64 = 1e5;
/// Most times a photocell may switch over a clock (each is found by
/// bisection on the sky model).
pub const MAX_PHOTOCELL_SWITCHES: usize = 20;
/// Longest lamp run-up, sky seconds (an hour).
pub const MAX_RUN_UP_S: f64 = 3600.0;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSkyClock {
    utc_at_start: Option<String>,
    time_scale: f64,
    renders: Option<u32>,
}

/// A lamp's photocell: on below `on_lux` of horizontal illuminance,
/// reaching full output `run_up_s` of sky time after switching on (a
/// high-pressure sodium lamp takes minutes); off again at once above it.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Photocell {
    pub on_lux: f64,
    #[serde(default)]
    pub run_up_s: f64,
}

/// The sequence's `[sky]` clock.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyClock {
    /// The sky's instant at the sequence's t = 0 (the scene's `[sky] utc`
    /// when the file gives none, set by [`Sequence::bind_sky`]).
    pub start: Option<UtcInstant>,
    /// Sky seconds per sequence second.
    pub time_scale: f64,
    /// Renders asked for (`None`: one per degree of Sun elevation).
    pub renders: Option<u32>,
    /// Sequence times of the sky's renders, s (set by `bind_sky`).
    pub key_times_s: Vec<f64>,
    /// The photocell's illuminance at each render's instant, lux.
    pub key_lux: Vec<f64>,
    /// The Sun's elevation at each render's instant, degrees.
    pub key_sun_deg: Vec<f64>,
    /// What the user should know about the clock as bound (renders far
    /// apart in the Sun's travel), for stderr and `report.json`.
    pub warnings: Vec<String>,
    pub(super) line: usize,
}

pub(super) fn parse_clock(
    loc: &Locator,
    raw: Option<RawSkyClock>,
) -> Result<Option<SkyClock>, SceneError> {
    let Some(r) = raw else {
        return Ok(None);
    };
    let at = |k: &str| FieldPath::root().key("sky").key(k);
    let start = match r.utc_at_start {
        None => None,
        Some(text) => Some(UtcInstant::parse_iso8601(&text).map_err(|e| {
            loc.error(
                &at("utc_at_start"),
                format!("'{text}' is not an ISO 8601 UTC instant: {e}"),
            )
        })?),
    };
    if !(r.time_scale.is_finite() && r.time_scale > 0.0 && r.time_scale <= MAX_TIME_SCALE) {
        return Err(loc.error(
            &at("time_scale"),
            format!(
                "must be sky seconds per sequence second in (0, {MAX_TIME_SCALE:e}], not {}",
                num(r.time_scale)
            ),
        ));
    }
    if let Some(n) = r.renders
        && !(2..=MAX_SKY_RENDERS).contains(&n)
    {
        return Err(loc.error(
            &at("renders"),
            format!("must be 2 … {MAX_SKY_RENDERS} renders of the sky, not {n}"),
        ));
    }
    Ok(Some(SkyClock {
        start,
        time_scale: r.time_scale,
        renders: r.renders,
        key_times_s: Vec::new(),
        key_lux: Vec::new(),
        key_sun_deg: Vec::new(),
        warnings: Vec::new(),
        line: loc.error(&FieldPath::root().key("sky"), "").line(),
    }))
}

/// Checks a photocell's numbers (`at` names its field).
pub(super) fn check_photocell(
    loc: &Locator,
    at: &FieldPath,
    p: &Photocell,
    clock: bool,
) -> Result<(), SceneError> {
    if !clock {
        return Err(loc.error(
            at,
            "a photocell needs the sequence's [sky] clock (utc_at_start, time_scale): without it the sky does not change",
        ));
    }
    if !(p.on_lux.is_finite() && p.on_lux > 0.0 && p.on_lux <= MAX_ON_LUX) {
        return Err(loc.error(
            at,
            format!(
                "on_lux must be in (0, {MAX_ON_LUX:e}] lx, not {}",
                num(p.on_lux)
            ),
        ));
    }
    if !(p.run_up_s.is_finite() && (0.0..=MAX_RUN_UP_S).contains(&p.run_up_s)) {
        return Err(loc.error(
            at,
            format!(
                "run_up_s must be in [0, {MAX_RUN_UP_S}] s, not {}",
                num(p.run_up_s)
            ),
        ));
    }
    Ok(())
}

/// The photocell's illuminance: the sky model's horizontal illuminance at
/// `t` over the scene's site, with the Moon and night sky as the scene
/// has them, lux.
fn horizontal_lux(sky: &SkyConfig, t: UtcInstant) -> Result<f64, gloam_sky::SkyError> {
    let site = gloam_sky::Site::new(sky.latitude_deg, sky.longitude_deg, sky.height_m)?;
    let cloud = match sky.overcast {
        true => gloam_sky::Cloud::Overcast,
        false => gloam_sky::Cloud::Clear,
    };
    let g = gloam_sky::ground_illuminance(t, &site, sky.visibility_km, cloud, false)?;
    let e = g.illuminance_lux;
    let moon = if sky.moon {
        e.moon_direct + e.moon_sky
    } else {
        0.0
    };
    let night = if sky.night_sky { e.night_sky } else { 0.0 };
    let sun = gloam_sky::report::TwilightLux::at(t, &site, sky.visibility_km, cloud, 0.0)?;
    Ok(moon + night + sun.total_with_moon_and_night_sky)
}

impl Sequence {
    /// The sequence's length, s: the last frame's end.
    pub fn duration_s(&self) -> f64 {
        f64::from(self.frames) / self.frame_rate_hz
    }

    /// Refuses a photocell on the sky's own groups: the sky switched by
    /// its own light, which the clock moves.
    fn refuse_sky_photocells(&self) -> Result<(), SceneError> {
        let sky_groups = [
            crate::groups::SUN_GROUP,
            crate::groups::TWILIGHT_GROUP,
            crate::groups::MOON_GROUP,
            crate::groups::SKY_GROUP,
        ];
        let clock_line = self.sky.as_ref().map_or(1, |c| c.line);
        for (name, track) in &self.groups {
            if track.photocell.is_some() && sky_groups.contains(&name.as_str()) {
                return Err(SceneError::Invalid {
                    path: self.path.clone(),
                    line: self.group_lines.get(name).copied().unwrap_or(clock_line),
                    column: 1,
                    field: format!("groups.{name}.photocell"),
                    message: format!(
                        "'{name}' is the sky's own light, which the clock moves; a photocell switches a lamp's group"
                    ),
                });
            }
        }
        Ok(())
    }

    /// Ties the `[sky]` clock to `scene`: its start (the scene's instant
    /// unless the file gives one), the renders' times, the photocells'
    /// keys, and the Sun's groups in `scene` wherever the clock lights
    /// them (every render fills the same groups). Does nothing without a
    /// clock; refuses one over a scene without `[sky]`.
    pub fn bind_sky(&mut self, scene: &mut Scene) -> Result<(), SceneError> {
        self.check_emission(scene)?;
        if self.sky.is_some() {
            // Before the clock's readings (seconds of sky): a group — a
            // photocell's too — the scene lacks, or a photocell on the
            // sky's own light, was refused only after them (the Sun's two
            // groups the clock may add below).
            let groups: Vec<&str> = scene
                .light_groups
                .groups
                .iter()
                .map(|g| g.name.as_str())
                .collect();
            let sunlight = [crate::groups::SUN_GROUP, crate::groups::TWILIGHT_GROUP];
            let added = sunlight.into_iter().filter(|g| !groups.contains(g));
            self.check_groups(groups.iter().copied().chain(added))?;
            self.refuse_sky_photocells()?;
            // A move the scene cannot make, too (12 s of readings first).
            self.check_moves(scene)?;
        }
        let Some(mut clock) = self.sky.take() else {
            return Ok(());
        };
        let bound = self.bind_clock(&mut clock, scene);
        self.sky = Some(clock);
        bound
    }

    fn sky_err(&self, line: usize, field: &str, message: String) -> SceneError {
        SceneError::Invalid {
            path: self.path.clone(),
            line,
            column: 1,
            field: field.into(),
            message,
        }
    }

    /// [`Sequence::bind_sky`] with the clock out of `self` while it binds.
    fn bind_clock(&mut self, clock: &mut SkyClock, scene: &mut Scene) -> Result<(), SceneError> {
        let duration = self.duration_s();
        let Some(sky) = scene.sky.clone() else {
            return Err(self.sky_err(
                clock.line,
                "sky",
                format!(
                    "the scene {} has no [sky] for the clock to move",
                    self.scene.display()
                ),
            ));
        };
        let start = *clock.start.get_or_insert(sky.instant);
        self.check_span(clock, start)?;
        let (time_scale, line) = (clock.time_scale, clock.line);
        let at = move |t: f64| start.plus_seconds(t * time_scale);
        let (path_deg, travel) = self.sun_path(clock, &sky, &at)?;
        let n = self.render_count(clock, travel)?;
        clock.key_times_s = (0..n)
            .map(|k| duration * f64::from(k) / f64::from(n - 1))
            .collect();
        clock.key_sun_deg = clock
            .key_times_s
            .iter()
            .map(|&t| sky.sun_elevation_deg_at(at(t)))
            .collect();
        let lux = |t: f64| {
            horizontal_lux(&sky, at(t)).map_err(|e| {
                self.sky_err(
                    line,
                    "sky",
                    format!("the sky at {}: {e}", at(t).to_iso8601()),
                )
            })
        };
        clock.key_lux = key_lux(&clock.key_times_s, &lux)?;
        // Every render fills the same groups: the Sun's where any instant
        // of the clock has it.
        let beam = path_deg.iter().any(|&d| d > 0.0) && !sky.overcast;
        let twilight = path_deg
            .iter()
            .any(|&d| d >= gloam_sky::twilight::TWILIGHT_MIN_SUN_ELEVATION_DEG);
        scene.light_groups.with_sunlight(beam, twilight);
        let keys = self.photocell_tracks(clock, &lux)?;
        for (name, k) in keys {
            if let Some(track) = self.groups.get_mut(&name) {
                track.keys = k;
            }
        }
        Ok(())
    }

    /// The clock's sky time stays within the sky model's years and a year.
    fn check_span(&self, clock: &SkyClock, start: UtcInstant) -> Result<(), SceneError> {
        let span_s = self.duration_s() * clock.time_scale;
        // Checked, not saturated: a clock that ran past the sky model's
        // last year stood still at its start, every later frame that sky.
        let in_years = |e: &UtcInstant| {
            (gloam_sky::time::MIN_YEAR..=gloam_sky::time::MAX_YEAR).contains(&e.to_calendar().0)
        };
        let past = match start.checked_plus_seconds(span_s) {
            Ok(end) if in_years(&end) => None,
            _ => Some(format!(
                "past the sky model's years {}–{}",
                gloam_sky::time::MIN_YEAR,
                gloam_sky::time::MAX_YEAR
            )),
        };
        let long = (span_s > MAX_SKY_SPAN_S).then(|| {
            format!(
                "more than a year ({} s): a clock for dusk and dawn, not the seasons",
                num(MAX_SKY_SPAN_S)
            )
        });
        // A sequence that itself lasts more than the clock may run is the
        // frames' rate to blame, not the clock's scale (`frame_rate_hz =
        // 1e-300` was named `sky.time_scale`).
        let (line, key) = if self.duration_s() > MAX_SKY_SPAN_S {
            (self.frame_rate_line, "frame_rate_hz")
        } else {
            (clock.line, "sky.time_scale")
        };
        match past.or(long) {
            Some(why) => Err(self.sky_err(
                line,
                key,
                format!(
                    "the clock runs {} sky seconds ({} frames at {} Hz × {}) from {}, {why}",
                    num(span_s),
                    self.frames,
                    num(self.frame_rate_hz),
                    num(clock.time_scale),
                    start.to_iso8601(),
                ),
            )),
            None => Ok(()),
        }
    }

    /// The Sun's path, sampled at least every PATH_STEP_S of sky time
    /// (256 samples spread over weeks all fell near one hour of the day
    /// and saw the Sun stand still), and its travel in degrees, which sets
    /// the default number of renders; a path longer than the renders can
    /// follow is refused, not rendered at fewer renders than a degree each.
    fn sun_path(
        &self,
        clock: &SkyClock,
        sky: &SkyConfig,
        at: &dyn Fn(f64) -> UtcInstant,
    ) -> Result<(Vec<f64>, f64), SceneError> {
        let duration = self.duration_s();
        let span_s = duration * clock.time_scale;
        let samples = (span_s / PATH_STEP_S).ceil().max(256.0);
        let most = f64::from(MAX_SKY_RENDERS - 1) * DEGREES_PER_RENDER;
        let mut path_deg: Vec<f64> = Vec::new();
        let mut travel = 0.0;
        let mut i = 0.0;
        while i <= samples {
            let d = sky.sun_elevation_deg_at(at(duration * i / samples));
            if let Some(&last) = path_deg.last() {
                travel += (d - last).abs();
            }
            path_deg.push(d);
            if clock.renders.is_none() && travel > most {
                return Err(self.sky_err(
                    clock.line,
                    "sky.time_scale",
                    format!(
                        "the Sun travels more than {most}° over the clock's {} sky seconds, past the {MAX_SKY_RENDERS} renders at {DEGREES_PER_RENDER}° each: slow the clock, shorten the sequence, or give `renders`",
                        num(span_s)
                    ),
                ));
            }
            i += 1.0;
        }
        Ok((path_deg, travel))
    }

    /// How many renders of the sky: as the file asks (at most one per
    /// frame and one more), else one per degree of the Sun's travel; a
    /// spacing too wide to follow twilight is warned of in the clock.
    fn render_count(&self, clock: &mut SkyClock, travel: f64) -> Result<u32, SceneError> {
        // Each render's instant costs a twilight sky (about a second) for
        // its illuminance: renders between frames no frame uses were that
        // cost for nothing (`renders = 1000` over 2 frames: ~17 minutes
        // before the first frame). The default follows the frames too.
        let most_renders = self.frames.saturating_add(1).min(MAX_SKY_RENDERS);
        if let Some(r) = clock.renders
            && r > most_renders.max(2)
        {
            return Err(self.sky_err(
                clock.line,
                "sky.renders",
                format!(
                    "{r} renders of the sky for {} frames: at most one per frame and one more ({}); a render between two frames is never used",
                    self.frames,
                    most_renders.max(2)
                ),
            ));
        }
        let by_travel = (travel / DEGREES_PER_RENDER).ceil() as u32 + 1;
        let default_n = by_travel.clamp(2, most_renders.max(2));
        let n = clock.renders.unwrap_or(default_n);
        clock.warnings.clear();
        let per_render = travel / f64::from(n - 1);
        if per_render > WARN_DEGREES_PER_RENDER {
            let warning = self.spacing_warning(clock, travel, n, (default_n, by_travel));
            clock.warnings.push(warning);
        }
        Ok(n)
    }

    /// Renders far apart in the Sun's travel are rendered as asked, but
    /// said: a frame between two renders takes the light geometrically
    /// between them, exact only for light falling at one exponential
    /// rate, and twilight's rate changes with the Sun's elevation.
    /// `defaults`: the default count, and one per degree of travel.
    fn spacing_warning(
        &self,
        clock: &SkyClock,
        travel: f64,
        n: u32,
        (default_n, by_travel): (u32, u32),
    ) -> String {
        let per_render = travel / f64::from(n - 1);
        let frames = self.frames;
        let default = match default_n == by_travel {
            true => format!("{default_n} (one per {DEGREES_PER_RENDER}° of Sun)"),
            false => format!(
                "{default_n}, as many as {frames} frames allow (one per {DEGREES_PER_RENDER}° of Sun would be {by_travel})"
            ),
        };
        let why = match clock.renders {
            Some(r) if r < default_n => {
                format!("`renders = {r}`; the default would use {default}")
            }
            Some(r) => format!(
                "`renders = {r}`, as many as {frames} frames allow (one per frame and one more)"
            ),
            None => format!("{n} renders, the default: {default}"),
        };
        format!(
            "warning: {}:{}: sky: {why} over {:.1}° of the Sun's travel, {:.1}° between renders: each frame between two renders takes the light geometrically between them, exact only where it falls at one exponential rate — twilight's rate changes with the Sun's elevation, so frames far from a render may be off",
            self.path.display(),
            clock.line,
            travel,
            per_render
        )
    }

    /// Each photocell group's keys from the renders' illuminances; the
    /// sky's own groups cannot have one, and a photocell may switch only
    /// so often.
    fn photocell_tracks(
        &self,
        clock: &SkyClock,
        lux: &(dyn Fn(f64) -> Result<f64, SceneError> + Sync),
    ) -> Result<Vec<(String, Keys)>, SceneError> {
        let step = self.frame_period_s() * 0.01;
        let key_lux = &clock.key_lux;
        let mut out = Vec::new();
        for (name, track) in self.groups.iter() {
            let Some(p) = track.photocell else { continue };
            let line = self.group_lines.get(name).copied().unwrap_or(clock.line);
            let on = |l: f64| l < p.on_lux;
            let switches = key_lux.windows(2).filter(|w| on(w[0]) != on(w[1])).count();
            if switches > MAX_PHOTOCELL_SWITCHES {
                // Each switch is found by bisection on the sky model (about
                // a second an evaluation): a clock over weeks switching at
                // every dusk and dawn ran for hours before the first frame.
                return Err(self.sky_err(
                    line,
                    &format!("groups.{name}.photocell"),
                    format!(
                        "switches {switches} times over the clock's renders; at most {MAX_PHOTOCELL_SWITCHES}: a clock for a dusk or a dawn, not for weeks"
                    ),
                ));
            }
            let keys =
                photocell_keys(&p, &clock.key_times_s, key_lux, lux, step, clock.time_scale)?;
            out.push((name.clone(), keys));
        }
        Ok(out)
    }

    /// The sky's instant at sequence time `t` s (with a bound clock).
    pub fn sky_instant_at(&self, t: f64) -> Option<UtcInstant> {
        let c = self.sky.as_ref()?;
        Some(c.start?.plus_seconds(t * c.time_scale))
    }

    /// The sequence times of the sky's renders (empty without a clock).
    pub fn sky_key_times_s(&self) -> &[f64] {
        self.sky.as_ref().map_or(&[], |c| &c.key_times_s)
    }

    /// The two sky renders around `t` and how far `t` lies from the first
    /// to the second (0…1; the same render twice outside them).
    pub fn sky_bracket(&self, t: f64) -> Option<(usize, usize, f64)> {
        let k = self.sky_key_times_s();
        if k.is_empty() {
            return None;
        }
        let i = k.partition_point(|&x| x <= t);
        if i == 0 {
            return Some((0, 0, 0.0));
        }
        if i == k.len() {
            return Some((i - 1, i - 1, 0.0));
        }
        let (a, b) = (k[i - 1], k[i]);
        let f = if b > a { (t - a) / (b - a) } else { 0.0 };
        Some((i - 1, i, f.clamp(0.0, 1.0)))
    }

    /// The photocell's illuminance at `t`, lux: geometric between the
    /// renders' instants (as the images are).
    pub fn sky_lux_at(&self, t: f64) -> Option<f64> {
        let (a, b, f) = self.sky_bracket(t)?;
        let l = &self.sky.as_ref()?.key_lux;
        Some(gloam_spectra::geometric_between(l[a], l[b], f))
    }

    /// `scene` under the sky of render `key` (its `[sky]` instant moved;
    /// everything else, light groups included, the scene's).
    pub fn scene_at_sky(&self, scene: &Scene, key: usize) -> Scene {
        let mut out = scene.clone();
        let t = self.sky_key_times_s().get(key).copied();
        if let (Some(sky), Some(t)) = (out.sky.as_mut(), t)
            && let Some(instant) = self.sky_instant_at(t)
        {
            sky.instant = instant;
            sky.utc = instant.to_iso8601();
        }
        out
    }
}

/// A group's weight keys: (sequence time s, weight).
type Keys = Vec<(f64, f64)>;

/// The site's illuminance at each render: each reading is a whole
/// twilight sky (its diffuse field, built once a process, then a dome of
/// lines of sight), so the first alone, which builds the field, the rest
/// side by side.
fn key_lux(
    times: &[f64],
    lux: &(dyn Fn(f64) -> Result<f64, SceneError> + Sync),
) -> Result<Vec<f64>, SceneError> {
    Ok(match times.split_first() {
        None => Vec::new(),
        Some((&first, rest)) => {
            use rayon::prelude::*;
            let mut v = vec![lux(first)?];
            v.extend(
                rest.par_iter()
                    .map(|&t| lux(t))
                    .collect::<Result<Vec<_>, _>>()?,
            );
            v
        }
    })
}

/// A photocell's keys: its state at each render's instant, each change
/// located to `step` s ([`locate_switch`]), switching on as a ramp of
/// `run_up_s` sky seconds (`time_scale` per sequence second) and off as a
/// step.
fn photocell_keys(
    p: &Photocell,
    times: &[f64],
    lux: &[f64],
    lux_at: &dyn Fn(f64) -> Result<f64, SceneError>,
    step: f64,
    time_scale: f64,
) -> Result<Vec<(f64, f64)>, SceneError> {
    let on = |l: f64| l < p.on_lux;
    let ramp = p.run_up_s / time_scale;
    let mut keys = vec![(0.0, if on(lux[0]) { 1.0 } else { 0.0 })];
    for k in 1..times.len() {
        if on(lux[k]) == on(lux[k - 1]) {
            continue;
        }
        let (t, _) = locate_switch(
            p.on_lux,
            (times[k - 1], lux[k - 1]),
            (times[k], lux[k]),
            lux_at,
            step,
        )?;
        let last = *keys.last().unwrap_or(&(0.0, 0.0));
        // The value reached at t (a ramp cut short by switching off).
        let now = super::keyed_at(&keys, t);
        let t = t.max(last.0);
        if on(lux[k]) {
            keys.push((t, now));
            keys.push((t + ramp, 1.0));
        } else {
            // Keys stay in time order: a ramp still rising ends here.
            keys.retain(|&(kt, _)| kt <= t);
            keys.push((t, now));
            keys.push((t, 0.0));
        }
    }
    Ok(keys)
}

/// Where the light crosses `on_lux` between `a` and `b` (time, lux; one
/// on each side): the first instant of the later state, at most `step`
/// after the last instant found in the earlier one — as a bisection finds
/// it, in fewer readings, each a whole twilight sky (issue 46: ~0.2–0.3 s
/// each, a dozen a switch). Twilight's light falls nearly exponentially,
/// so its logarithm is nearly straight in time: the ITP method (Oliveira &
/// Takahashi 2020, ACM TOMS 47:5) interpolates on it — false position,
/// truncated towards the midpoint and projected to stay within the
/// bisection's own bound — so it takes at most one reading more than a
/// bisection and, on smooth light, a few. Returns the instant and the
/// readings taken.
fn locate_switch(
    on_lux: f64,
    a: (f64, f64),
    b: (f64, f64),
    lux_at: &dyn Fn(f64) -> Result<f64, SceneError>,
    step: f64,
) -> Result<(f64, usize), SceneError> {
    let on = |l: f64| l < on_lux;
    // Negative in the earlier state, positive in the later one.
    let before = on(a.1);
    let sign = if before { 1.0 } else { -1.0 };
    let g = |l: f64| sign * (l.max(f64::MIN_POSITIVE).ln() - on_lux.ln());
    let (mut lo, mut hi) = (a.0, b.0);
    let (mut g_lo, mut g_hi) = (g(a.1).min(-f64::MIN_POSITIVE), g(b.1).max(0.0));
    let eps = 0.5 * step;
    let n_half = ((hi - lo) / step).log2().ceil().max(0.0);
    let n_max = n_half + 1.0;
    let kappa1 = 0.05 / (hi - lo);
    let (mut j, mut readings) = (0.0, 0);
    while hi - lo > step && j <= n_max + 1.0 {
        let width = hi - lo;
        let mid = 0.5 * (lo + hi);
        let r = (eps * (n_max - j).exp2() - 0.5 * width).max(0.0);
        let delta = kappa1 * width * width;
        let x_f = (g_hi * lo - g_lo * hi) / (g_hi - g_lo);
        let x_f = if x_f.is_finite() { x_f } else { mid };
        let sigma = (mid - x_f).signum();
        let x_t = if delta <= (mid - x_f).abs() {
            x_f + sigma * delta
        } else {
            mid
        };
        let mut m = if (x_t - mid).abs() <= r {
            x_t
        } else {
            mid - sigma * r
        };
        // A point within `step` of an end moves to just under `step` past
        // it, so that the next reading can close the bracket (kept within
        // the projection's bound).
        if m - lo < step {
            m = (lo + 0.999 * step).min(mid + r);
        } else if hi - m < step {
            m = (hi - 0.999 * step).max(mid - r);
        }
        let l = lux_at(m)?;
        readings += 1;
        if on(l) == before {
            (lo, g_lo) = (m, g(l).min(-f64::MIN_POSITIVE));
        } else {
            (hi, g_hi) = (m, g(l).max(0.0));
        }
        j += 1.0;
    }
    Ok((hi, readings))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_photocell_switches_where_the_light_crosses_its_threshold() {
        // Light falling as 100·e^{−t} lx: below 20 lx at t = ln 5.
        let f = |t: f64| 100.0 * (-t).exp();
        let times: Vec<f64> = (0..=10).map(f64::from).collect();
        let lux: Vec<f64> = times.iter().map(|&t| f(t)).collect();
        let p = Photocell {
            on_lux: 20.0,
            run_up_s: 120.0,
        };
        let keys = photocell_keys(&p, &times, &lux, &|t| Ok(f(t)), 1e-6, 60.0).unwrap();
        let t_on = 5f64.ln();
        assert_eq!(keys.len(), 3);
        assert_eq!(keys[0], (0.0, 0.0));
        assert!((keys[1].0 - t_on).abs() < 2e-6, "{keys:?}");
        assert_eq!(keys[1].1, 0.0);
        // 120 sky seconds at 60× is 2 s of sequence.
        assert!((keys[2].0 - (t_on + 2.0)).abs() < 2e-6);
        assert_eq!(keys[2].1, 1.0);
        // Dawn: rising light switches it off at once.
        let g = |t: f64| f(10.0 - t);
        let lux: Vec<f64> = times.iter().map(|&t| g(t)).collect();
        let keys = photocell_keys(&p, &times, &lux, &|t| Ok(g(t)), 1e-6, 60.0).unwrap();
        assert_eq!(keys[0], (0.0, 1.0));
        assert!((keys[1].0 - (10.0 - t_on)).abs() < 2e-6, "{keys:?}");
        assert_eq!((keys[1].1, keys[2].1), (1.0, 0.0));
    }

    /// The bisection [`locate_switch`] replaced: the later state's first
    /// instant found, halving to `step`; its readings.
    fn bisect_switch(
        on_lux: f64,
        a: (f64, f64),
        b: (f64, f64),
        lux_at: &dyn Fn(f64) -> f64,
        step: f64,
    ) -> (f64, usize) {
        let on = |l: f64| l < on_lux;
        let (mut lo, mut hi, mut n) = (a.0, b.0, 0);
        for _ in 0..60 {
            if hi - lo <= step {
                break;
            }
            let mid = 0.5 * (lo + hi);
            n += 1;
            if on(lux_at(mid)) == on(a.1) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (hi, n)
    }

    /// `locate_switch` finds the crossing the bisection found, to `step`,
    /// and brackets it (the earlier state within `step` before it), on
    /// light that falls exponentially, at a changing rate, linearly, to
    /// zero, and as a near-step — never in many more readings, and in far
    /// fewer on twilight-like light.
    #[test]
    fn the_switch_is_where_the_bisection_found_it_in_fewer_readings() {
        type Light = Box<dyn Fn(f64) -> f64>;
        let lights: Vec<(&str, Light)> = vec![
            ("exponential", Box::new(|t| 1e3 * (-2.3 * t).exp())),
            (
                "twilight",
                Box::new(|t| 1e3 * (-(0.3 * t + 0.05 * t * t)).exp()),
            ),
            ("dawn", Box::new(|t| 1e-3 * (0.4 * t + 0.06 * t * t).exp())),
            ("linear", Box::new(|t| 1e3 * (1.0 - t / 11.0))),
            ("to zero", Box::new(|t| (1e3 * (1.0 - t / 3.0)).max(0.0))),
            (
                "near-step",
                Box::new(|t| 1e3 / (1.0 + (40.0 * (t - 7.3)).exp())),
            ),
        ];
        let (step, mut old_total, mut new_total) = (4e-6, 0, 0);
        for (name, f) in &lights {
            for on_lux in [0.5, 16.0, 300.0] {
                let (a, b) = ((0.0, f(0.0)), (10.0, f(10.0)));
                if (a.1 < on_lux) == (b.1 < on_lux) {
                    continue;
                }
                let (t_old, n_old) = bisect_switch(on_lux, a, b, &|t| f(t), step);
                let (t_new, n_new) = locate_switch(on_lux, a, b, &|t| Ok(f(t)), step).unwrap();
                assert!(
                    (t_new - t_old).abs() <= step,
                    "{name} at {on_lux} lx: {t_new} vs {t_old}"
                );
                // The later state at t_new, the earlier at most step before.
                let later = f(t_new) < on_lux;
                assert_eq!(later, b.1 < on_lux, "{name} at {on_lux} lx");
                assert!(n_new <= n_old + 4, "{name}: {n_new} vs {n_old} readings");
                old_total += n_old;
                new_total += n_new;
                eprintln!("{name} at {on_lux} lx: {n_old} → {n_new} readings");
            }
        }
        assert!(3 * new_total < 2 * old_total, "{new_total} vs {old_total}");
    }

    /// On the sky model itself (dusk-street's evening: Rochester NY from
    /// 2025-10-21T22:08Z, 1000 frames at 25 Hz, the sky at 160×, a
    /// photocell at 16 lx), the switch is where the bisection put it, to a
    /// hundredth of a frame, in fewer readings of the sky.
    #[test]
    fn the_photocell_switches_at_the_bisections_instant_on_the_sky_model() {
        let scene = crate::parse_str(
            "units = \"m\"\n[camera]\nposition = [0, -10, 2]\nlook_at = [0, 0, 2]\nfov_deg = 60\nwidth = 4\nheight = 4\n[bands.v]\nlo_nm = 400\nhi_nm = 700\n[sky]\nutc = \"2025-10-21T22:08:00Z\"\nlatitude_deg = 43.0844\nlongitude_deg = -77.6749\nheight_m = 170.0\nmoon = false\n",
            std::path::Path::new("s.toml"),
        )
        .unwrap();
        let sky = scene.sky.clone().unwrap();
        let (start, scale, frame) = (sky.instant, 160.0, 1.0 / 25.0);
        let at = |t: f64| start.plus_seconds(t * scale);
        let lux = |t: f64| horizontal_lux(&sky, at(t)).unwrap();
        let step = 0.01 * frame;
        // The two renders a degree of Sun apart around the 16 lx crossing
        // (sequence seconds 12.3 and 14.2 of dusk-street's 21 renders).
        let (a, b) = ((12.0, lux(12.0)), (14.0, lux(14.0)));
        assert!(a.1 > 16.0 && b.1 < 16.0, "{a:?} {b:?}");
        let t0 = std::time::Instant::now();
        let (t_old, n_old) = bisect_switch(16.0, a, b, &lux, step);
        let old_s = t0.elapsed().as_secs_f64();
        let t0 = std::time::Instant::now();
        let (t_new, n_new) = locate_switch(16.0, a, b, &|t| Ok(lux(t)), step).unwrap();
        let new_s = t0.elapsed().as_secs_f64();
        eprintln!(
            "switch at {t_new:.5} s (bisection {t_old:.5} s): {n_old} readings in {old_s:.2} s → {n_new} in {new_s:.2} s"
        );
        assert!((t_new - t_old).abs() <= step, "{t_new} vs {t_old}");
        assert!(lux(t_new) < 16.0 && lux(t_new - step) >= 16.0);
        assert!(2 * n_new <= n_old, "{n_new} vs {n_old} readings");
    }
}
