//! Sequence files: how a still scene's light groups change over time.
//!
//! Radiance is linear in each light group's emission, so a night that
//! changes — a lamp switching on, a discharge lamp's mains flicker, a
//! dimming ramp — is a weighted sum of per-group layers rendered once
//! (`gloam render --layers`). A sequence file names the frame rate, the
//! number of frames and, per group, its relative intensity over time:
//!
//! ```toml
//! scene = "scene.toml"              # relative to this file
//! frame_rate_hz = 25.0
//! frames = 300
//!
//! [groups.street-lamps]
//! # (time s, relative intensity): linear between keys, held before the
//! # first and after the last; two keys at one time make a step.
//! keys = [[0.0, 0.0], [4.0, 0.0], [4.0, 1.0]]
//! # A discharge lamp on 50 Hz mains: its light ripples at 100 Hz,
//! # I(t) = 1 − depth·cos(4π·mains_hz·t), mean 1.
//! flicker = { mains_hz = 50.0, depth = 0.3 }
//! ```
//!
//! Groups the file does not name keep intensity 1. A frame sees each
//! group's intensity *averaged over its exposure window*, computed in
//! closed form (piecewise-linear keys times the flicker cosine), so a
//! lamp that switches on mid-exposure gives the fraction of the window it
//! was on, and a short gate samples the flicker's phase.
//!
//! Moving bodies (`[[move]]`) cannot be a weighted sum: a car changes
//! every group's light (its shadow, its reflections). A move names scene
//! tables that travel as one rigid body — objects and point sources, a
//! car's body and its headlights — and keys its pose over time:
//!
//! ```toml
//! [[move]]
//! objects = ["car"]                 # [objects.NAME] tables, all placements
//! point_sources = ["headlights"]    # [point_sources.NAME] tables
//! # (time s, x, y, z[, rotate_z_deg]): p ↦ R_z(θ)·p + (x, y, z) applied to
//! # the tables as the scene writes them; linear between keys, held
//! # outside them.
//! keys = [[0.0, -60.0, 0.0, 0.0], [4.0, 60.0, 0.0, 0.0]]
//! ```
//!
//! A frame sees each body at its pose at mid-exposure ([`Sequence::poses_at`]);
//! [`Sequence::scene_at`] builds the scene with the bodies so placed, which
//! the pipeline renders once per distinct pose.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use glam::DVec3;

use crate::build::num;
use crate::error::{FieldPath, Locator, SceneError};
use crate::instance::Xform;
use crate::{Luminaire, Scene};

mod sky;
pub use sky::{
    DEGREES_PER_RENDER, MAX_ON_LUX, MAX_RUN_UP_S, MAX_SKY_RENDERS, MAX_TIME_SCALE, Photocell,
    SkyClock,
};

/// Most frames a sequence may have (an hour at 277 Hz).
pub const MAX_SEQUENCE_FRAMES: u32 = 1_000_000;
/// Highest frame rate, Hz.
pub const MAX_FRAME_RATE_HZ: f64 = 10_000.0;
/// Most keys in one group's track.
pub const MAX_KEYS: usize = 100_000;
/// Highest mains frequency a flicker may name, Hz.
pub const MAX_MAINS_HZ: f64 = 1_000.0;
/// Largest relative intensity a key may give.
pub const MAX_INTENSITY: f64 = 1e12;
/// Most `[[move]]` bodies in one file.
pub const MAX_MOVES: usize = 100;
/// Largest coordinate a pose key may give, scene units (as the scene's
/// own coordinates).
pub const MAX_POSE_COORDINATE: f64 = 1e12;

/// A checked sequence file.
#[derive(Clone, Debug)]
pub struct Sequence {
    /// The sequence file itself (for messages and provenance).
    pub path: PathBuf,
    /// The scene, resolved against the sequence file's directory.
    pub scene: PathBuf,
    pub frame_rate_hz: f64,
    pub frames: u32,
    /// The line of `frame_rate_hz`, for a sky clock the sequence's own
    /// length makes too long (errors found once the clock is bound).
    frame_rate_line: usize,
    /// Group name → its track, for the groups the file names.
    pub groups: BTreeMap<String, Track>,
    /// Group name → the line of its table, for errors found later (a name
    /// the scene does not have).
    group_lines: BTreeMap<String, usize>,
    /// The `[[move]]` bodies, in file order.
    pub moves: Vec<Move>,
    /// The `[sky]` clock: the sky's time moving with the sequence's
    /// ([`Sequence::bind_sky`] ties it to the scene).
    pub sky: Option<SkyClock>,
}

/// One `[[move]]`: scene tables that travel as one rigid body.
#[derive(Clone, Debug, PartialEq)]
pub struct Move {
    /// `[objects.NAME]` tables (every placement of each).
    pub objects: Vec<String>,
    /// `[point_sources.NAME]` tables (every placement of each).
    pub point_sources: Vec<String>,
    /// Keyed poses, times non-decreasing; at least one.
    pub keys: Vec<PoseKey>,
    /// Lines of `move[i]`, its `objects` and `point_sources` and `keys`
    /// entries, for errors found against the scene.
    lines: MoveLines,
}

#[derive(Clone, Debug, Default, PartialEq)]
struct MoveLines {
    table: usize,
    objects: usize,
    point_sources: usize,
}

/// A body's pose at one time: `p ↦ R_z(rotate_z_deg)·p + translate`,
/// applied to its tables as the scene writes them (after their own
/// transforms and placements). The scene as written is the identity pose.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Pose {
    /// Scene units.
    pub translate: [f64; 3],
    /// Counter-clockwise about +z seen from above, degrees.
    pub rotate_z_deg: f64,
}

impl Pose {
    /// The pose that leaves the scene as written.
    pub const IDENTITY: Pose = Pose {
        translate: [0.0; 3],
        rotate_z_deg: 0.0,
    };

    /// The same pose to the bit (`-0.0` and `0.0` differ, and so may the
    /// renders' last bits): what a pose cache keys on.
    pub fn bits(&self) -> [u64; 4] {
        let [x, y, z] = self.translate;
        [x, y, z, self.rotate_z_deg].map(f64::to_bits)
    }

    fn xform(&self) -> Xform {
        Xform::new(DVec3::ONE, self.rotate_z_deg, DVec3::from(self.translate))
    }
}

/// One key of a move: its time and pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseKey {
    pub time_s: f64,
    pub pose: Pose,
}

/// One group's relative intensity over time.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// (time s, intensity), times non-decreasing; at least one key.
    pub keys: Vec<(f64, f64)>,
    pub flicker: Option<Flicker>,
    /// Keys set by a photocell from the sky's light ([`Sequence::bind_sky`];
    /// off until then).
    pub photocell: Option<Photocell>,
}

/// Mains flicker of a discharge lamp: `I(t) = 1 − depth·cos(4π f t)`.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Flicker {
    pub mains_hz: f64,
    /// Modulation depth, 0 (steady) … 1 (dark at each zero crossing).
    pub depth: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSequence {
    scene: String,
    frame_rate_hz: f64,
    frames: u32,
    #[serde(default)]
    groups: BTreeMap<String, RawTrack>,
    #[serde(default, rename = "move")]
    moves: Vec<RawMove>,
    sky: Option<sky::RawSkyClock>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMove {
    #[serde(default)]
    objects: Vec<String>,
    #[serde(default)]
    point_sources: Vec<String>,
    #[serde(default)]
    keys: Vec<Vec<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTrack {
    #[serde(default)]
    keys: Vec<Vec<f64>>,
    flicker: Option<Flicker>,
    photocell: Option<Photocell>,
}

/// Reads and checks a sequence file (bounded read, errors as
/// `file:line: field: message`).
/// `reads` notes the file.
pub fn load_sequence(path: &Path, reads: &gloam_io::ReadLog) -> Result<Sequence, SceneError> {
    let text =
        gloam_io::read_text(path, gloam_io::MAX_TEXT_FILE_BYTES, reads).map_err(|source| {
            SceneError::Io {
                path: path.to_path_buf(),
                what: "sequence",
                source,
            }
        })?;
    parse_sequence(&text, path)
}

/// Parses and checks sequence text; `path` names the file and is the base
/// of the relative scene path.
pub fn parse_sequence(text: &str, path: &Path) -> Result<Sequence, SceneError> {
    let loc = Locator::new(text, path);
    let raw: RawSequence = toml::from_str(text).map_err(|e| loc.error_at(e.span(), e.message()))?;
    let field = |p: &[&str]| p.iter().fold(FieldPath::root(), |f, k| f.key(k));
    if !(raw.frame_rate_hz.is_finite()
        && raw.frame_rate_hz > 0.0
        && raw.frame_rate_hz <= MAX_FRAME_RATE_HZ)
    {
        return Err(loc.error(
            &field(&["frame_rate_hz"]),
            format!(
                "must be a frame rate in (0, {MAX_FRAME_RATE_HZ}] Hz, not {}",
                num(raw.frame_rate_hz)
            ),
        ));
    }
    if raw.frames == 0 || raw.frames > MAX_SEQUENCE_FRAMES {
        return Err(loc.error(
            &field(&["frames"]),
            format!(
                "must be 1 … {MAX_SEQUENCE_FRAMES} frames, not {}",
                raw.frames
            ),
        ));
    }
    if raw.scene.trim().is_empty() {
        return Err(loc.error(&field(&["scene"]), "names no scene file"));
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let scene = base.join(&raw.scene);
    let mut groups = BTreeMap::new();
    let mut group_lines = BTreeMap::new();
    let clock = sky::parse_clock(&loc, raw.sky)?;
    for (name, t) in raw.groups {
        let line = loc.error(&field(&["groups", &name]), "").line();
        group_lines.insert(name.clone(), line);
        let track = track(&loc, &field(&["groups", &name]), t, clock.is_some())?;
        groups.insert(name, track);
    }
    let moves = parse_moves(&loc, raw.moves)?;
    let frame_rate_line = loc.error(&field(&["frame_rate_hz"]), "").line();
    Ok(Sequence {
        path: path.to_path_buf(),
        scene,
        frame_rate_hz: raw.frame_rate_hz,
        frames: raw.frames,
        frame_rate_line,
        groups,
        group_lines,
        moves,
        sky: clock,
    })
}

/// One light group's track: keys (or a photocell, never both), each
/// `[time_s, intensity]`, forward in time, and its mains flicker.
fn track(loc: &Locator, group: &FieldPath, t: RawTrack, clock: bool) -> Result<Track, SceneError> {
    let here = |k: &str| group.key(k);
    if let Some(p) = &t.photocell {
        sky::check_photocell(loc, &here("photocell"), p, clock)?;
        if !t.keys.is_empty() {
            return Err(loc.error(
                &here("keys"),
                "a group is keyed or switched by its photocell, not both",
            ));
        }
    } else if t.keys.is_empty() {
        return Err(loc.error(&here("keys"), "needs at least one [time_s, intensity] key"));
    }
    if t.keys.len() > MAX_KEYS {
        return Err(loc.error(
            &here("keys"),
            format!("has {} keys; at most {MAX_KEYS}", t.keys.len()),
        ));
    }
    let mut keys = intensity_keys(loc, &here("keys"), &t.keys)?;
    if let Some(f) = t.flicker {
        if !(f.mains_hz.is_finite() && f.mains_hz > 0.0 && f.mains_hz <= MAX_MAINS_HZ) {
            return Err(loc.error(
                &here("flicker"),
                format!(
                    "mains_hz must be in (0, {MAX_MAINS_HZ}], not {}",
                    num(f.mains_hz)
                ),
            ));
        }
        if !(f.depth.is_finite() && (0.0..=1.0).contains(&f.depth)) {
            return Err(loc.error(
                &here("flicker"),
                format!("depth must be in [0, 1], not {}", num(f.depth)),
            ));
        }
    }
    if t.photocell.is_some() {
        // Off until the clock is bound to the scene's sky.
        keys.push((0.0, 0.0));
    }
    Ok(Track {
        keys,
        flicker: t.flicker,
        photocell: t.photocell,
    })
}

/// A group's `[time_s, intensity]` keys: two numbers each, forward in
/// time, at most two at one time (a step), intensities in range.
fn intensity_keys(
    loc: &Locator,
    field: &FieldPath,
    raw: &[Vec<f64>],
) -> Result<Vec<(f64, f64)>, SceneError> {
    let mut last = f64::NEG_INFINITY;
    let mut keys: Vec<(f64, f64)> = Vec::with_capacity(raw.len());
    for (i, k) in raw.iter().enumerate() {
        let at = field.index(i);
        // A third number was dropped unseen ([0, 1, 2] read as [0, 1]).
        let &[time, value] = k.as_slice() else {
            return Err(loc.error(
                &at,
                format!("has {} numbers: a key is [time_s, intensity]", k.len()),
            ));
        };
        check_key_time(loc, &at, time, last)?;
        // Two keys at one time make a step; a third there is never
        // seen (the step goes from the first to the last).
        if i >= 2 && keys[i - 2].0 == time && keys[i - 1].0 == time {
            return Err(loc.error(
                &at,
                format!(
                    "a third key at {} s: two keys at one time make a step, a third is never seen",
                    num(time)
                ),
            ));
        }
        if !(value.is_finite() && (0.0..=MAX_INTENSITY).contains(&value)) {
            return Err(loc.error(
                &at,
                format!("intensity {} must be in [0, {MAX_INTENSITY:e}]", num(value)),
            ));
        }
        last = time;
        keys.push((time, value));
    }
    Ok(keys)
}

/// A key's time: finite, ≥ 0 and not before the previous key's `last`.
fn check_key_time(loc: &Locator, at: &FieldPath, time: f64, last: f64) -> Result<(), SceneError> {
    if !(time.is_finite() && time >= 0.0) {
        return Err(loc.error(at, format!("time {} s must be finite and ≥ 0", num(time))));
    }
    if time < last {
        return Err(loc.error(
            at,
            format!(
                "time {} s comes before the previous key's {} s: keys go forward in time",
                num(time),
                num(last)
            ),
        ));
    }
    Ok(())
}

/// Checks the `[[move]]` tables: something to move, at most [`MAX_MOVES`],
/// keys `[time_s, x, y, z]` or `[time_s, x, y, z, rotate_z_deg]` (all of
/// one length), finite, bounded, forward in time; no table in two moves.
fn parse_moves(loc: &Locator, raw: Vec<RawMove>) -> Result<Vec<Move>, SceneError> {
    let root = FieldPath::root().key("move");
    if raw.len() > MAX_MOVES {
        return Err(loc.error(
            &root,
            format!("{} moving bodies; at most {MAX_MOVES}", raw.len()),
        ));
    }
    let mut moves: Vec<Move> = Vec::with_capacity(raw.len());
    for (m, r) in raw.into_iter().enumerate() {
        let here = root.index(m);
        if r.objects.is_empty() && r.point_sources.is_empty() {
            return Err(loc.error(
                &here,
                "moves nothing: name `objects = [\"…\"]` and/or `point_sources = [\"…\"]` of the scene",
            ));
        }
        check_moved_names(loc, &here, &r, &moves)?;
        let kf = here.key("keys");
        if r.keys.is_empty() {
            return Err(loc.error(
                &kf,
                "needs at least one [time_s, x, y, z] or [time_s, x, y, z, rotate_z_deg] key",
            ));
        }
        if r.keys.len() > MAX_KEYS {
            return Err(loc.error(
                &kf,
                format!("has {} keys; at most {MAX_KEYS}", r.keys.len()),
            ));
        }
        let keys = pose_keys(loc, &kf, &r.keys)?;
        let line = |f: &FieldPath| loc.error(f, "").line();
        let lines = MoveLines {
            table: line(&here),
            objects: line(&here.key("objects")),
            point_sources: line(&here.key("point_sources")),
        };
        moves.push(Move {
            objects: r.objects,
            point_sources: r.point_sources,
            keys,
            lines,
        });
    }
    Ok(moves)
}

/// No table is moved by two bodies, nor named twice in one.
fn check_moved_names(
    loc: &Locator,
    here: &FieldPath,
    r: &RawMove,
    moves: &[Move],
) -> Result<(), SceneError> {
    for (kind, names) in [("objects", &r.objects), ("point_sources", &r.point_sources)] {
        for (i, name) in names.iter().enumerate() {
            let taken = moves.iter().any(|o| {
                let theirs = if kind == "objects" {
                    &o.objects
                } else {
                    &o.point_sources
                };
                theirs.contains(name)
            }) || names[..i].contains(name);
            if taken {
                return Err(loc.error(
                    &here.key(kind).index(i),
                    format!("{kind}.{name} is named twice: a table moves with one body"),
                ));
            }
        }
    }
    Ok(())
}

/// A move's pose keys: all of one length, finite, within the pose
/// limits, forward in time.
fn pose_keys(loc: &Locator, kf: &FieldPath, raw: &[Vec<f64>]) -> Result<Vec<PoseKey>, SceneError> {
    let width = raw[0].len();
    let mut keys = Vec::with_capacity(raw.len());
    let mut last = f64::NEG_INFINITY;
    for (i, k) in raw.iter().enumerate() {
        let at = kf.index(i);
        if !(k.len() == 4 || k.len() == 5) || k.len() != width {
            return Err(loc.error(
                &at,
                format!(
                    "has {} numbers: every key is [time_s, x, y, z] or every key [time_s, x, y, z, rotate_z_deg]",
                    k.len()
                ),
            ));
        }
        let time = k[0];
        check_key_time(loc, &at, time, last)?;
        if let Some(v) = k[1..4]
            .iter()
            .find(|v| !(v.is_finite() && v.abs() <= MAX_POSE_COORDINATE))
        {
            return Err(loc.error(
                &at,
                format!(
                    "{} is not a finite pose coordinate within ±{MAX_POSE_COORDINATE:e}",
                    num(*v)
                ),
            ));
        }
        if let Some(&r) = k.get(4)
            && !crate::instance::rotation_ok(r)
        {
            return Err(loc.error(
                &at,
                format!(
                    "rotate_z_deg {} is not a finite angle within ±{:e} degrees (a turn is 360; reduce the angle)",
                    num(r),
                    crate::instance::MAX_ROTATION_DEG
                ),
            ));
        }
        last = time;
        keys.push(PoseKey {
            time_s: time,
            pose: Pose {
                translate: [k[1], k[2], k[3]],
                rotate_z_deg: k.get(4).copied().unwrap_or(0.0),
            },
        });
    }
    Ok(keys)
}

impl Sequence {
    /// The line of `frame_rate_hz` in the sequence file, for errors found
    /// once a camera is known (an analogue camera's fixed video rate).
    pub fn frame_rate_line(&self) -> usize {
        self.frame_rate_line
    }

    /// Seconds from one frame's start to the next.
    pub fn frame_period_s(&self) -> f64 {
        1.0 / self.frame_rate_hz
    }

    /// Start time of frame `i`, s.
    pub fn frame_start_s(&self, i: u32) -> f64 {
        f64::from(i) / self.frame_rate_hz
    }

    /// Refuses a group the scene does not have, naming the sequence file's
    /// line and the scene's groups.
    pub fn check_groups<'a>(
        &self,
        scene_groups: impl IntoIterator<Item = &'a str> + Clone,
    ) -> Result<(), SceneError> {
        for name in self.groups.keys() {
            if !scene_groups.clone().into_iter().any(|g| g == name) {
                let known: Vec<&str> = scene_groups.clone().into_iter().collect();
                return Err(SceneError::Invalid {
                    path: self.path.clone(),
                    line: self.group_lines.get(name).copied().unwrap_or(1),
                    column: 1,
                    field: format!("groups.{name}"),
                    message: format!(
                        "the scene {} has no light group '{name}' (its groups: {})",
                        self.scene.display(),
                        known.join(", ")
                    ),
                });
            }
        }
        Ok(())
    }

    /// Refuses a group whose brightest moment — its largest key × its
    /// flicker's peak `1 + depth` — times the emission of one of its
    /// sources passes [`crate::build::MAX_EMISSION`]: each factor is held
    /// to its own bound (keys to [`MAX_INTENSITY`], emission to 1e20), but
    /// the frames see their product (1e31 in issue 46). For a measured
    /// area luminaire the emission counted is its peak intensity.
    pub fn check_emission(&self, scene: &Scene) -> Result<(), SceneError> {
        use crate::build::{MAX_EMISSION, spectrum_peak};
        let lg = &scene.light_groups;
        for (name, track) in &self.groups {
            let Some(gi) = lg.groups.iter().position(|g| &g.name == name) else {
                continue;
            };
            let key = track.keys.iter().map(|k| k.1).fold(0.0f64, f64::max);
            let factor = key * track.flicker.map_or(1.0, |f| 1.0 + f.depth);
            if factor <= 1.0 {
                continue;
            }
            let mut sources: Vec<(String, &gloam_spectra::Spectrum)> = Vec::new();
            for (k, o) in scene.objects.iter().enumerate() {
                if lg.object.get(k) == Some(&Some(gi)) {
                    if let Some(e) = &scene.materials[o.material].emission {
                        sources.push((format!("objects.{}", o.name), &e.radiance_w_m2_sr_nm));
                    }
                }
            }
            for (t, g) in scene.point_source_groups.iter().enumerate() {
                if lg.point_table.get(t) == Some(&gi) {
                    for p in &scene.point_sources[g.first..g.first + g.instances] {
                        sources.push((format!("point_sources.{}", g.name), &p.intensity_w_sr_nm));
                    }
                }
            }
            for (d, src) in scene.distant_sources.iter().enumerate() {
                if lg.distant.get(d) == Some(&gi) {
                    sources.push((
                        format!("distant_sources.{}", src.name),
                        &src.irradiance_w_m2_nm,
                    ));
                }
            }
            for (source, s) in sources {
                let peak = spectrum_peak(s);
                let seen = peak * factor;
                if seen.is_nan() || seen > MAX_EMISSION {
                    let flicker = match track.flicker {
                        Some(f) if f.depth > 0.0 => {
                            format!(" × flicker peak {}", num(1.0 + f.depth))
                        }
                        _ => String::new(),
                    };
                    return Err(SceneError::Invalid {
                        path: self.path.clone(),
                        line: self.group_lines.get(name).copied().unwrap_or(1),
                        column: 1,
                        field: format!("groups.{name}.keys"),
                        message: format!(
                            "the largest key {}{flicker} times {source}'s peak emission {peak:e} (scene {}) gives {seen:e} per nm, out of range (at most {MAX_EMISSION:e}); lower the keys or the source",
                            num(key),
                            self.scene.display()
                        ),
                    });
                }
            }
        }
        Ok(())
    }

    /// Each of `scene_groups`' mean relative intensity over the window
    /// `[t0, t1]` s (1 for a group the file does not name).
    pub fn weights<'a>(
        &self,
        scene_groups: impl IntoIterator<Item = &'a str>,
        t0: f64,
        t1: f64,
    ) -> Vec<f64> {
        scene_groups
            .into_iter()
            .map(|g| self.groups.get(g).map_or(1.0, |t| t.mean_over(t0, t1)))
            .collect()
    }
}

impl Sequence {
    /// Refuses a move naming a table the scene lacks, with the sequence
    /// file's line and the scene's tables of that kind.
    pub fn check_moves(&self, scene: &Scene) -> Result<(), SceneError> {
        for (m, mv) in self.moves.iter().enumerate() {
            let kinds: [(&str, &[String], Vec<&str>, usize); 2] = [
                (
                    "objects",
                    &mv.objects,
                    scene.objects.iter().map(|o| o.name.as_str()).collect(),
                    mv.lines.objects,
                ),
                (
                    "point_sources",
                    &mv.point_sources,
                    (scene.point_source_groups.iter())
                        .map(|g| g.name.as_str())
                        .collect(),
                    mv.lines.point_sources,
                ),
            ];
            for (kind, names, known, line) in kinds {
                if let Some((i, name)) = names
                    .iter()
                    .enumerate()
                    .find(|(_, n)| !known.contains(&n.as_str()))
                {
                    return Err(SceneError::Invalid {
                        path: self.path.clone(),
                        line: if line > 0 { line } else { mv.lines.table },
                        column: 1,
                        field: format!("move[{m}].{kind}[{i}]"),
                        message: format!(
                            "the scene {} has no [{kind}.{name}] (its {kind}: {})",
                            self.scene.display(),
                            if known.is_empty() {
                                "none".into()
                            } else {
                                known.join(", ")
                            }
                        ),
                    });
                }
            }
            // The scene's coordinate limit holds at every pose, as it does
            // for the tables where the scene puts them: |R p + t| ≤ |p| +
            // |t| for any turn about +z, so checking each key bounds the
            // path between keys too.
            let reach = scene
                .objects
                .iter()
                .filter(|o| mv.objects.contains(&o.name))
                .flat_map(|o| scene.facets[o.facets()].iter())
                .flat_map(|f| f.vertices.iter().copied())
                .chain(
                    scene
                        .shared
                        .iter()
                        .filter(|sh| mv.objects.contains(&scene.objects[sh.object].name))
                        .flat_map(|sh| sh.placed_corners()),
                )
                .chain(
                    scene
                        .point_source_groups
                        .iter()
                        .filter(|g| mv.point_sources.contains(&g.name))
                        .flat_map(|g| scene.point_sources[g.first..g.first + g.instances].iter())
                        .map(|p| p.position),
                )
                .map(|v| v.length())
                .fold(0.0f64, f64::max);
            let lim = crate::build::MAX_COORDINATE;
            if let Some((k, key)) = mv
                .keys
                .iter()
                .enumerate()
                .find(|(_, k)| reach + glam::DVec3::from(k.pose.translate).length() > lim)
            {
                return Err(SceneError::Invalid {
                    path: self.path.clone(),
                    line: mv.lines.table,
                    column: 1,
                    field: format!("move[{m}].keys[{k}]"),
                    message: format!(
                        "at t = {} s the body would reach {:.4e} scene units from the origin, past the scene's limit of {lim:e}",
                        key.time_s,
                        reach + glam::DVec3::from(key.pose.translate).length()
                    ),
                });
            }
        }
        Ok(())
    }

    /// Refuses moving bodies where `user` mixes layers rendered once (a
    /// live device, a caller with its own layers): a body's pose changes
    /// every layer, so ignoring its `[[move]]` would be silently wrong.
    pub fn check_static(&self, user: &str) -> Result<(), SceneError> {
        self.check_still_sky(user)?;
        self.check_still_bodies(user)
    }

    /// Refuses a `[sky]` clock for `user`, which mixes layers rendered once.
    pub fn check_still_sky(&self, user: &str) -> Result<(), SceneError> {
        if let Some(c) = &self.sky {
            return Err(SceneError::Invalid {
                path: self.path.clone(),
                line: c.line,
                column: 1,
                field: "sky".into(),
                message: format!(
                    "{user} mixes layers rendered once and cannot move the sky's clock (the sky changes every layer): use `gloam sequence`, which renders the sky at its instants, or drop the [sky] table"
                ),
            });
        }
        Ok(())
    }

    /// Refuses `[[move]]` bodies for `user`, which mixes layers of one pose.
    pub fn check_still_bodies(&self, user: &str) -> Result<(), SceneError> {
        match self.moves.first() {
            None => Ok(()),
            Some(m) => Err(SceneError::Invalid {
                path: self.path.clone(),
                line: m.lines.table,
                column: 1,
                field: "move[0]".into(),
                message: format!(
                    "{user} mixes layers rendered once and cannot move bodies (a body changes every layer): use `gloam sequence`, which renders each pose, or drop the [[move]] tables"
                ),
            }),
        }
    }

    /// Each move's pose at time `t` s (in file order).
    pub fn poses_at(&self, t: f64) -> Vec<Pose> {
        self.moves.iter().map(|m| m.pose_at(t)).collect()
    }

    /// The line of `move[m]` (for errors the pipeline finds, e.g. a path
    /// with more distinct poses than it renders).
    pub fn move_line(&self, m: usize) -> usize {
        self.moves.get(m).map_or(1, |mv| mv.lines.table)
    }

    /// [`Sequence::scene_at`], refusing a pose that lays a moved facet
    /// exactly on another (the same vertices): a ray cannot tell which it
    /// hits, and light sampling would count both — the check a scene file
    /// gets at load, here at each pose rendered.
    pub fn scene_at_checked(&self, scene: &Scene, poses: &[Pose]) -> Result<Scene, SceneError> {
        let out = self.scene_at(scene, poses);
        let pair =
            crate::build::first_coincident_pair(&out.facets).map_err(|m| SceneError::Invalid {
                path: self.path.clone(),
                line: self.moves.first().map_or(1, |m| m.lines.table),
                column: 1,
                field: "move".into(),
                message: format!("{m}: out of memory checking the pose"),
            })?;
        let names = match pair {
            Some((a, b)) => {
                let (fa, fb) = (&out.facets[a], &out.facets[b]);
                Some((fa.object.clone(), fb.object.clone(), fb.vertices.len()))
            }
            // Shared placements are checked where their boxes meet.
            None => crate::coincide::first_coincident_shared(&out.facets, &out.shared)
                .map_err(|m| SceneError::Invalid {
                    path: self.path.clone(),
                    line: self.moves.first().map_or(1, |m| m.lines.table),
                    column: 1,
                    field: "move".into(),
                    message: format!("{m} (at a pose of the moves)"),
                })?
                .map(|(a, b)| {
                    let name = |w| {
                        let (k, _) = crate::build::describe_who(&out.objects, &out.shared, w);
                        out.objects[k].name.clone()
                    };
                    let n = match b {
                        crate::coincide::Who::Facet(i) => out.facets[i].vertices.len(),
                        crate::coincide::Who::Placed { shared, facet, .. } => {
                            out.shared[shared].prototype[facet].vertices.len()
                        }
                    };
                    (name(a), name(b), n)
                }),
        };
        let Some((fa_object, fb_object, n_vertices)) = names else {
            return Ok(out);
        };
        let m = self
            .moves
            .iter()
            .position(|mv| mv.objects.contains(&fb_object) || mv.objects.contains(&fa_object))
            .unwrap_or(0);
        let pose = poses.get(m).copied().unwrap_or(Pose::IDENTITY);
        Err(SceneError::Invalid {
            path: self.path.clone(),
            line: self.move_line(m),
            column: 1,
            field: format!("move[{m}]"),
            message: format!(
                "at its pose (translate {:?}, rotate_z_deg {}) a facet of [objects.{}] lies exactly on one of [objects.{}] (the same {} vertices): a ray cannot tell which it hits and light sampling would count both; change the keys so the bodies do not meet face to face",
                pose.translate, pose.rotate_z_deg, fb_object, fa_object, n_vertices
            ),
        })
    }

    /// `scene` with each move's tables at its pose in `poses` (one per
    /// move; [`Sequence::check_moves`] first). Facets and point sources
    /// are moved in place, so facet and source indices, light groups and
    /// everything else stay the scene's: the render of the result is the
    /// render of a scene file that writes those tables at that pose (the
    /// same arithmetic as an object's own `rotate_z_deg`/`translate`).
    pub fn scene_at(&self, scene: &Scene, poses: &[Pose]) -> Scene {
        let mut out = scene.clone();
        for (mv, pose) in self.moves.iter().zip(poses) {
            if pose.bits() == Pose::IDENTITY.bits() {
                continue;
            }
            let x = pose.xform();
            for o in scene
                .objects
                .iter()
                .filter(|o| mv.objects.contains(&o.name))
            {
                for f in &mut out.facets[o.facets()] {
                    for v in &mut f.vertices {
                        *v = x.point(*v);
                    }
                }
            }
            // Shared placements move as their copies would: the pose after
            // each placement's own transform.
            let moved = x.affine();
            for sh in out.shared.iter_mut() {
                if mv.objects.contains(&scene.objects[sh.object].name) {
                    sh.placements.iter_mut().for_each(|a| *a = moved * *a);
                }
            }
            let tables = scene.point_source_groups.iter();
            for g in tables.filter(|g| mv.point_sources.contains(&g.name)) {
                for p in &mut out.point_sources[g.first..g.first + g.instances] {
                    p.position = x.point(p.position);
                    p.direction = x.direction(p.direction).normalize_or_zero();
                    // A rotation about +z keeps the C0 axis perpendicular to
                    // the nadir and the nadir's angle to −z (the tilt factor).
                    if let Some(l) = &p.luminaire {
                        let c0 = crate::build::perpendicular(x.direction(l.c0), p.direction)
                            .unwrap_or(l.c0);
                        p.luminaire = Some(Luminaire { c0, ..l.clone() });
                    }
                }
            }
        }
        out
    }
}

impl Move {
    /// The pose at `t` s: translation and angle linear between keys, held
    /// before the first and after the last (at a step, the later key).
    pub fn pose_at(&self, t: f64) -> Pose {
        let k = &self.keys;
        let i = k.partition_point(|key| key.time_s <= t);
        if i == 0 {
            return k[0].pose;
        }
        if i == k.len() {
            return k[k.len() - 1].pose;
        }
        let (a, b) = (k[i - 1], k[i]);
        let span = b.time_s - a.time_s;
        if span <= 0.0 {
            return b.pose;
        }
        let u = (t - a.time_s) / span;
        let lerp = |p: f64, q: f64| p + (q - p) * u;
        let (pa, pb) = (a.pose.translate, b.pose.translate);
        Pose {
            translate: [lerp(pa[0], pb[0]), lerp(pa[1], pb[1]), lerp(pa[2], pb[2])],
            rotate_z_deg: lerp(a.pose.rotate_z_deg, b.pose.rotate_z_deg),
        }
    }
}

impl Track {
    /// The keys' piecewise-linear intensity at `t` (held outside them; at a
    /// step, the later key).
    pub fn keyed_at(&self, t: f64) -> f64 {
        keyed_at(&self.keys, t)
    }

    /// Intensity at `t`: the keys times the flicker.
    pub fn at(&self, t: f64) -> f64 {
        self.keyed_at(t) * self.flicker.map_or(1.0, |f| f.at(t))
    }

    /// Mean intensity over `[t0, t1]`, exact: the window is cut at the keys,
    /// and on each piece the linear key `a + b t` times `1 − d cos(ω t)`
    /// integrates in closed form. A window of zero width gives the value
    /// at `t0`.
    pub fn mean_over(&self, t0: f64, t1: f64) -> f64 {
        let (t0, t1) = if t1 < t0 { (t1, t0) } else { (t0, t1) };
        let width = t1 - t0;
        if width <= 0.0 || !width.is_finite() {
            return self.at(t0);
        }
        // Cut points: the window's ends and the keys strictly inside.
        let mut cuts = vec![t0];
        cuts.extend(
            self.keys
                .iter()
                .map(|&(t, _)| t)
                .filter(|&t| t > t0 && t < t1),
        );
        cuts.push(t1);
        cuts.dedup();
        let mut sum = 0.0f64;
        for w in cuts.windows(2) {
            let (a, b) = (w[0], w[1]);
            if b <= a {
                continue;
            }
            // On (a, b) the keys are linear: v(t) = va + s (t − a), taken
            // from inside the piece so a step at `a` counts its later side.
            let mid = 0.5 * (a + b);
            let (vm, s) = self.slope_at(mid);
            let va = vm - s * (mid - a);
            sum += linear_times_flicker(va, s, a, b, self.flicker);
        }
        sum / width
    }

    /// (value, slope) of the keys at `t` inside a piece.
    fn slope_at(&self, t: f64) -> (f64, f64) {
        let k = &self.keys;
        let i = k.partition_point(|&(time, _)| time <= t);
        if i == 0 || i == k.len() {
            return (self.keyed_at(t), 0.0);
        }
        let ((ta, va), (tb, vb)) = (k[i - 1], k[i]);
        let span = tb - ta;
        if span <= 0.0 {
            return (vb, 0.0);
        }
        let s = (vb - va) / span;
        (va + s * (t - ta), s)
    }
}

/// Piecewise-linear `(time, value)` keys at `t` (held outside them; at a
/// step, the later key).
fn keyed_at(k: &[(f64, f64)], t: f64) -> f64 {
    // The last key at or before t.
    let i = k.partition_point(|&(time, _)| time <= t);
    if i == 0 {
        return k[0].1;
    }
    if i == k.len() {
        return k[k.len() - 1].1;
    }
    let ((ta, va), (tb, vb)) = (k[i - 1], k[i]);
    let span = tb - ta;
    if span <= 0.0 {
        return vb;
    }
    va + (vb - va) * (t - ta) / span
}

impl Flicker {
    /// `2π · 2 · mains_hz`: the ripple's angular frequency, rad/s.
    fn omega(&self) -> f64 {
        4.0 * std::f64::consts::PI * self.mains_hz
    }

    /// Relative intensity at `t`, mean 1.
    pub fn at(&self, t: f64) -> f64 {
        1.0 - self.depth * (self.omega() * t).cos()
    }
}

/// ∫ₐᵇ (va + s (t − a)) (1 − d cos ω t) dt.
fn linear_times_flicker(va: f64, s: f64, a: f64, b: f64, flicker: Option<Flicker>) -> f64 {
    let h = b - a;
    let plain = va * h + 0.5 * s * h * h;
    let Some(f) = flicker else {
        return plain;
    };
    let w = f.omega();
    // With u = t − a: ∫₀ʰ (va + s u) cos(ω (a + u)) du
    //   = va [sin ω(a+u)]/ω + s ([u sin ω(a+u)]/ω + [cos ω(a+u)]/ω²), 0…h.
    let (sa, ca) = (w * a).sin_cos();
    let (sb, cb) = (w * b).sin_cos();
    let osc = va * (sb - sa) / w + s * (h * sb / w + (cb - ca) / (w * w));
    plain - f.depth * osc
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(keys: &[(f64, f64)], flicker: Option<Flicker>) -> Track {
        Track {
            keys: keys.to_vec(),
            flicker,
            photocell: None,
        }
    }

    /// The mean by a fine midpoint sum: the independent answer.
    fn numeric_mean(t: &Track, a: f64, b: f64) -> f64 {
        let n = 200_000;
        let h = (b - a) / f64::from(n);
        (0..n)
            .map(|i| t.at(a + (f64::from(i) + 0.5) * h))
            .sum::<f64>()
            / f64::from(n)
    }

    #[test]
    fn a_step_inside_the_window_gives_the_fraction_it_was_on() {
        let t = track(&[(0.0, 0.0), (4.0, 0.0), (4.0, 1.0)], None);
        assert_eq!(t.mean_over(3.0, 3.04), 0.0);
        assert_eq!(t.mean_over(4.0, 4.04), 1.0);
        assert!((t.mean_over(3.99, 4.03) - 0.75).abs() < 1e-12);
        assert_eq!(t.keyed_at(4.0), 1.0);
        assert_eq!(t.keyed_at(100.0), 1.0);
    }

    #[test]
    fn flicker_and_ramps_average_as_the_integral_does() {
        let f = Flicker {
            mains_hz: 50.0,
            depth: 0.7,
        };
        let t = track(
            &[(0.0, 0.2), (0.013, 1.0), (0.05, 0.4), (0.05, 2.0)],
            Some(f),
        );
        for (a, b) in [(0.0, 0.04), (0.001, 0.0011), (0.012, 0.061), (0.3, 0.34)] {
            let exact = t.mean_over(a, b);
            let num = numeric_mean(&t, a, b);
            assert!(
                (exact - num).abs() < 1e-7 * num.abs().max(1.0),
                "{a}..{b}: {exact} vs {num}"
            );
        }
        // A whole number of ripple periods (10 ms at 50 Hz) averages to 1.
        let steady = track(&[(0.0, 1.0)], Some(f));
        assert!((steady.mean_over(0.0137, 0.0337) - 1.0).abs() < 1e-12);
        // A short gate at a zero crossing of the mains sees the dip.
        assert!((steady.mean_over(0.0, 1e-7) - 0.3).abs() < 1e-6);
    }

    #[test]
    fn files_parse_and_bad_ones_name_their_line() {
        let p = Path::new("/tmp/x/seq.toml");
        let s = parse_sequence(
            "scene = \"scene.toml\"\nframe_rate_hz = 25\nframes = 300\n[groups.lamps]\nkeys = [[0, 0], [4, 1]]\n",
            p,
        )
        .unwrap();
        assert_eq!(s.scene, Path::new("/tmp/x/scene.toml"));
        assert_eq!(s.frames, 300);
        assert_eq!(s.weights(["lamps", "moon"], 2.0, 2.0), vec![0.5, 1.0]);
        let e = s.check_groups(["moon", "sky"]).unwrap_err().to_string();
        assert!(e.starts_with("/tmp/x/seq.toml:4: groups.lamps:"), "{e}");
        for (text, line, what) in [
            (
                "scene = \"s\"\nframe_rate_hz = 0\nframes = 3\n",
                2,
                "frame_rate_hz",
            ),
            (
                "scene = \"s\"\nframe_rate_hz = 25\nframes = 0\n",
                3,
                "frames",
            ),
            (
                "scene = \"s\"\nframe_rate_hz = 25\nframes = 3\n[groups.a]\nkeys = [[1, 0], [0.5, 1]]\n",
                5,
                "groups.a.keys[1]",
            ),
            (
                "scene = \"s\"\nframe_rate_hz = 25\nframes = 3\n[groups.a]\nkeys = [[0, 1]]\nflicker = { mains_hz = 50, depth = 2 }\n",
                6,
                "groups.a.flicker",
            ),
            (
                "scene = \"s\"\nframe_rate_hz = 25\nframes = 3\nfps = 2\n",
                4,
                "fps",
            ),
            // Issue 46, round 3: a key's third number was dropped unseen,
            // a third key at one time never seen, and 1e308 printed as
            // 309 digits.
            (
                "scene = \"s\"\nframe_rate_hz = 25\nframes = 3\n[groups.a]\nkeys = [[0, 1, 2]]\n",
                5,
                "groups.a.keys[0]: has 3 numbers: a key is [time_s, intensity]",
            ),
            (
                "scene = \"s\"\nframe_rate_hz = 25\nframes = 3\n[groups.a]\nkeys = [[0]]\n",
                5,
                "groups.a.keys[0]: has 1 numbers",
            ),
            (
                "scene = \"s\"\nframe_rate_hz = 25\nframes = 3\n[groups.a]\nkeys = [[0, 0], [2, 0], [2, 1], [2, 0.5]]\n",
                5,
                "groups.a.keys[3]: a third key at 2 s",
            ),
            (
                "scene = \"s\"\nframe_rate_hz = 1e308\nframes = 3\n",
                2,
                "not 1e308",
            ),
            (
                "scene = \"s\"\nframe_rate_hz = 25\nframes = 3\n[groups.a]\nkeys = [[0, 1e300]]\n",
                5,
                "intensity 1e300 must be",
            ),
            // Issue 46, round 12: a key under `[[move]]` was placed in
            // "(document)".
            (
                "scene = \"s\"\nframe_rate_hz = 25\nframes = 3\n[[move]]\nobjects = [\"car\"]\nkeys = [[0, 1, 2, 3]]\n[[move]]\nobjects = [\"van\"]\nkeys = [[0, 1, 2, 3]]\nframe_rate = 3\n",
                10,
                "move[1].frame_rate: unknown field `frame_rate`",
            ),
        ] {
            let e = parse_sequence(text, p).unwrap_err();
            let msg = e.to_string();
            assert_eq!(e.line(), line, "{msg}");
            assert!(msg.contains(what), "{msg}");
        }
    }

    const MOVE: &str = "scene = \"s.toml\"\nframe_rate_hz = 25\nframes = 3\n[[move]]\nobjects = [\"car\"]\npoint_sources = [\"heads\"]\nkeys = [[1, 0, 0, 0, 0], [3, 10, 2, 0, 90]]\n";

    #[test]
    fn a_move_s_pose_is_linear_between_keys_and_held_outside() {
        let s = parse_sequence(MOVE, Path::new("seq.toml")).unwrap();
        let m = &s.moves[0];
        assert_eq!(m.pose_at(0.0), Pose::IDENTITY);
        assert_eq!(
            m.pose_at(2.0),
            Pose {
                translate: [5.0, 1.0, 0.0],
                rotate_z_deg: 45.0
            }
        );
        assert_eq!(m.pose_at(9.0).translate, [10.0, 2.0, 0.0]);
        let e = s.check_static("gloam device --sequence").unwrap_err();
        assert_eq!((e.line(), e.field()), (4, "move[0]"), "{e}");
        // Held poses are the same to the bit: one render serves them.
        assert_eq!(m.pose_at(3.5).bits(), m.pose_at(100.0).bits());
    }

    #[test]
    fn a_scene_at_a_pose_moves_its_tables_only() {
        let scene = crate::parse_str(
            "units = \"m\"\n[camera]\nposition = [0, -10, 1]\nlook_at = [0, 0, 0]\nfov_deg = 60\nwidth = 4\nheight = 4\n[bands.v]\nlo_nm = 400\nhi_nm = 700\n[materials.m]\nreflectance = 0.5\n[objects.car]\nmaterial = \"m\"\nquad = { center = [1, 0, 0], size = [1, 1], normal = [0, 0, 1] }\n[objects.road]\nmaterial = \"m\"\nquad = { center = [0, 0, -1], size = [9, 9], normal = [0, 0, 1] }\n[point_sources.heads]\nposition = [1, 0, 1]\ndirection = [1, 0, 0]\nvalue = 1\n",
            Path::new("s.toml"),
        )
        .unwrap();
        let s = parse_sequence(MOVE, Path::new("seq.toml")).unwrap();
        s.check_moves(&scene).unwrap();
        let at = s.scene_at(&scene, &s.poses_at(3.0));
        // Turned 90° about +z, then moved by (10, 2, 0): (1, 0, 1) → (10, 3, 1).
        let p = &at.point_sources[0];
        assert!((p.position - DVec3::new(10.0, 3.0, 1.0)).length() < 1e-12);
        assert!((p.direction - DVec3::Y).length() < 1e-12);
        let c = at.facets[scene.objects[0].facets()][0].centroid();
        assert!((c - DVec3::new(10.0, 3.0, 0.0)).length() < 1e-12, "{c}");
        assert_eq!(at.facets[1], scene.facets[1]);
        // A table the scene lacks: the sequence file's line and the names.
        let e = parse_sequence(
            &MOVE.replace("[\"car\"]", "[\"truck\"]"),
            Path::new("seq.toml"),
        )
        .unwrap()
        .check_moves(&scene)
        .unwrap_err();
        assert_eq!(e.line(), 5, "{e}");
        let msg = e.to_string();
        assert!(
            msg.contains("move[0].objects[0]")
                && msg.contains("[objects.truck]")
                && msg.contains("car, road"),
            "{msg}"
        );
    }

    #[test]
    fn a_move_carries_shared_placements_as_their_copies() {
        // The car placed twice, shared or copied: at the pose, each shared
        // placement maps the prototype onto the moved copy.
        let text = |how: &str| {
            format!(
                "units = \"m\"\n[camera]\nposition = [0, -10, 1]\nlook_at = [0, 0, 0]\nfov_deg = 60\nwidth = 4\nheight = 4\n[bands.v]\nlo_nm = 400\nhi_nm = 700\n[materials.m]\nreflectance = 0.5\n[objects.car]\nmaterial = \"m\"\nquad = {{ center = [1, 0, 0], size = [1, 1], normal = [0, 0, 1] }}\ninstancing = \"{how}\"\ninstances = [{{ translate = [0, 1, 0] }}, {{ rotate_z_deg = 30, scale = 2 }}]\n[point_sources.heads]\nposition = [1, 0, 1]\nvalue = 1\n"
            )
        };
        let s = parse_sequence(MOVE, Path::new("seq.toml")).unwrap();
        let shared = crate::parse_str(&text("shared"), Path::new("s.toml")).unwrap();
        let copies = crate::parse_str(&text("expand"), Path::new("s.toml")).unwrap();
        s.check_moves(&shared).unwrap();
        let (a, b) = (
            s.scene_at(&shared, &s.poses_at(2.0)),
            s.scene_at(&copies, &s.poses_at(2.0)),
        );
        let sh = &a.shared[0];
        for (k, x) in sh.placements.iter().enumerate() {
            let want = &b.facets[copies.objects[0].instance_facets(k)][0].vertices;
            for (v, w) in sh.prototype[0].vertices.iter().zip(want) {
                let got = x.transform_point3(*v);
                assert!((got - *w).length() < 1e-12, "{got} vs {w}");
            }
        }
        assert_ne!(a.shared[0].placements, shared.shared[0].placements);
    }

    #[test]
    fn a_pose_that_lays_a_body_on_another_is_refused() {
        // The car's quad, moved by (10, 2, 0) at t = 3 s, lands exactly on
        // a second quad put there.
        let scene = crate::parse_str(
            "units = \"m\"\n[camera]\nposition = [0, -10, 1]\nlook_at = [0, 0, 0]\nfov_deg = 60\nwidth = 4\nheight = 4\n[bands.v]\nlo_nm = 400\nhi_nm = 700\n[materials.m]\nreflectance = 0.5\n[objects.car]\nmaterial = \"m\"\nquad = { center = [1, 0, 0], size = [1, 1], normal = [0, 0, 1] }\n[objects.parked]\nmaterial = \"m\"\nquad = { center = [11, 2, 0], size = [1, 1], normal = [0, 0, 1] }\n[point_sources.heads]\nposition = [1, 0, 1]\nvalue = 1\n",
            Path::new("s.toml"),
        )
        .unwrap();
        let s = parse_sequence(
            &MOVE.replace("[3, 10, 2, 0, 90]", "[3, 10, 2, 0, 0]"),
            Path::new("seq.toml"),
        )
        .unwrap();
        s.check_moves(&scene).unwrap();
        // Half way it is clear; at the last key it is on the parked quad.
        assert!(s.scene_at_checked(&scene, &s.poses_at(2.0)).is_ok());
        let e = s.scene_at_checked(&scene, &s.poses_at(3.0)).unwrap_err();
        assert_eq!((e.line(), e.field()), (4, "move[0]"), "{e}");
        let msg = e.to_string();
        assert!(
            msg.contains("[objects.car]") && msg.contains("[objects.parked]"),
            "{msg}"
        );
    }

    #[test]
    fn bad_moves_name_their_line_and_key() {
        let p = Path::new("seq.toml");
        for (text, line, what) in [
            (
                MOVE.replace("[3, 10, 2, 0, 90]", "[0.5, 10, 2, 0, 90]"),
                7,
                "keys go forward",
            ),
            (
                MOVE.replace("[3, 10, 2, 0, 90]", "[3, 10, 2, 0]"),
                7,
                "every key",
            ),
            (
                MOVE.replace("[3, 10, 2, 0, 90]", "[3, 1e300, 2, 0, 0]"),
                7,
                "pose coordinate",
            ),
            (
                MOVE.replace("objects = [\"car\"]\npoint_sources = [\"heads\"]\n", ""),
                4,
                "moves nothing",
            ),
            // A turn past ±1e6° would keep no bit of its angle (issue 46).
            (
                MOVE.replace("[3, 10, 2, 0, 90]", "[3, 10, 2, 0, 1e300]"),
                7,
                "rotate_z_deg 1e300 is not a finite angle within ±1e6 degrees",
            ),
            (
                MOVE.replace("[3, 10, 2, 0, 90]", "[3, 10, 2, 0, -1000000.5]"),
                7,
                "rotate_z_deg -1000000.5 is not a finite angle within ±1e6",
            ),
            (
                MOVE.replace("[\"heads\"]", "[\"heads\", \"heads\"]"),
                6,
                "named twice",
            ),
            (
                MOVE.replace("keys = [[1, 0, 0, 0, 0], [3, 10, 2, 0, 90]]", "keys = []"),
                7,
                "at least one",
            ),
        ] {
            let e = parse_sequence(&text, p).unwrap_err();
            let msg = e.to_string();
            assert_eq!(e.line(), line, "{msg}");
            assert!(
                msg.starts_with("seq.toml:") && msg.contains("move[0]") && msg.contains(what),
                "{msg}"
            );
        }
    }
}
