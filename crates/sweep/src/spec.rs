//! The sweep file: `[base]` values shared by every task and `[axes]` whose
//! product is the task list (see `docs/sweep.md`).
//!
//! Every value is checked when the file is read, so a bad gain or an
//! unknown setting fails before any task runs, with `file:line: field:`.

use gloam_io::toml_place::line_of_offset as line_of;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use sha2::{Digest, Sha256};
use toml::Spanned;

use crate::tile::{TileError, TileSpec};

/// The most tasks one sweep may have (the product of the axes is checked
/// against it before any list is built).
pub const MAX_TASKS: usize = 100_000;

/// Frames captured per camera task when the sweep does not say (two is the
/// fewest that give a temporal-noise estimate).
pub const DEFAULT_FRAMES: u32 = 2;

/// Keys with a meaning of their own; any other undotted key must be a
/// render setting (`--set` key), and a dotted key overrides the scene file.
pub const OWN_KEYS: &[&str] = &[
    "scene", "sensor", "flow", "seed", "gain", "frames", "agc", "noise", "tile", "size",
];

/// A sweep-file error, located.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    #[error("reading {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}: {field}: {message}")]
    Invalid {
        path: PathBuf,
        line: usize,
        field: String,
        message: String,
    },
}

/// What a task does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Flow {
    /// Render the scene (radiance), and capture it when there is a sensor.
    Render,
    /// Capture frames of the sensor's default uniform stimulus (no scene).
    Capture,
}

/// One axis: a key and its values (canonical strings, typed TOML values).
#[derive(Clone, Debug)]
pub struct Axis {
    pub name: String,
    pub values: Vec<toml::Value>,
    pub line: usize,
}

/// One task: a point of the axes' product.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Task {
    /// Position in the product (the last axis varies fastest).
    pub index: usize,
    /// Stable id: a hash of the task's axis values (not of its position, so
    /// it survives reordering the axes).
    pub id: String,
    /// The axis values, in axis order, as canonical strings.
    pub axes: Vec<(String, String)>,
    /// Noise seed, derived from the id and the sweep's `seed`.
    pub seed: u64,
    /// Tasks with the same key share their expensive work (the render).
    pub render_key: String,
    /// Index of the chunk (tasks sharing a render) this task belongs to.
    pub chunk: usize,
    #[serde(skip)]
    values: BTreeMap<String, toml::Value>,
}

/// A parsed sweep file and its task list.
#[derive(Clone, Debug)]
pub struct Sweep {
    /// The file (for messages).
    pub path: PathBuf,
    /// Relative scene and sensor paths are resolved against this.
    pub base_dir: PathBuf,
    pub axes: Vec<Axis>,
    pub tasks: Vec<Task>,
    /// Task indices per chunk, in order of first appearance.
    pub chunks: Vec<Vec<usize>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    base: Option<BTreeMap<Spanned<String>, Spanned<toml::Value>>>,
    axes: Option<BTreeMap<Spanned<String>, Spanned<toml::Value>>>,
}

/// The canonical text of a scalar (what a `--set KEY=VALUE` would say).
pub fn scalar_text(v: &toml::Value) -> Option<String> {
    match v {
        toml::Value::String(s) => Some(s.clone()),
        toml::Value::Integer(i) => Some(i.to_string()),
        toml::Value::Float(f) => Some(format!("{f}")),
        toml::Value::Boolean(b) => Some(b.to_string()),
        toml::Value::Datetime(d) => Some(d.to_string()),
        _ => None,
    }
}

fn sha_hex(bytes: &[u8]) -> String {
    let d = Sha256::digest(bytes);
    d.iter().map(|b| format!("{b:02x}")).collect()
}

impl Sweep {
    /// Reads and plans a sweep file; relative paths resolve against its
    /// directory. (Named on the command line, so listed by it: unlogged.)
    pub fn load(path: &Path) -> Result<Sweep, SpecError> {
        let text = gloam_io::read_text(
            path,
            gloam_io::MAX_TEXT_FILE_BYTES,
            &gloam_io::ReadLog::off(),
        )
        .map_err(|source| SpecError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let base_dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf();
        Self::parse(&text, path, &base_dir)
    }

    /// Parses sweep text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path, base_dir: &Path) -> Result<Sweep, SpecError> {
        let err = |span: Option<Range<usize>>, field: &str, message: String| SpecError::Invalid {
            path: path.to_path_buf(),
            line: span.map_or(1, |s| line_of(text, s.start)),
            field: field.to_string(),
            message,
        };
        let raw: Raw = toml::from_str(text).map_err(|e| {
            let at = e
                .span()
                .and_then(|s| gloam_io::toml_place::field_at_offset(text, s.start));
            let field = match at {
                Some(f) => f,
                None if e.message().contains("unknown field") => "(top level)".into(),
                None => "(toml)".into(),
            };
            err(e.span(), &field, e.message().trim().to_string())
        })?;
        // File order, not alphabetical: the product's order follows the file.
        let ordered = |m: Option<BTreeMap<Spanned<String>, Spanned<toml::Value>>>| {
            let mut v: Vec<_> = m.unwrap_or_default().into_iter().collect();
            v.sort_by_key(|(k, _)| k.span().start);
            v
        };
        let mut base = BTreeMap::new();
        // Each key's field and line, for errors about a task's keys.
        let mut key_lines: BTreeMap<String, (String, usize)> = BTreeMap::new();
        for (k, v) in ordered(raw.base) {
            let field = format!("base.{}", k.get_ref());
            key_lines.insert(
                k.get_ref().clone(),
                (field.clone(), line_of(text, k.span().start)),
            );
            check_value(k.get_ref(), v.get_ref())
                .map_err(|m| err(Some(k.span()), &field, m.to_string()))?;
            base.insert(k.get_ref().clone(), v.into_inner());
        }
        let mut axes = Vec::new();
        for (k, v) in ordered(raw.axes) {
            let name = k.get_ref().clone();
            let field = format!("axes.{name}");
            let span = Some(k.span());
            let values = axis_values(&name, v.get_ref())
                .map_err(|m| err(span.clone(), &field, m.to_string()))?;
            for (i, val) in values.iter().enumerate() {
                check_value(&name, val)
                    .map_err(|m| err(span.clone(), &format!("{field}[{i}]"), m.to_string()))?;
            }
            if base.contains_key(&name) {
                return Err(err(
                    span,
                    &field,
                    format!("'{name}' is both in [base] and an axis; keep one"),
                ));
            }
            key_lines.insert(name.clone(), (field, line_of(text, k.span().start)));
            axes.push(Axis {
                name,
                values,
                line: line_of(text, k.span().start),
            });
        }
        // The product's size, checked before anything is built.
        let count = task_count(&axes).ok_or_else(|| {
            err(
                None,
                "axes",
                format!(
                    "the axes' product exceeds {MAX_TASKS} tasks; split the sweep into several files"
                ),
            )
        })?;
        let mut tasks = Vec::with_capacity(count);
        let mut keys: BTreeMap<String, usize> = BTreeMap::new();
        let mut chunks: Vec<Vec<usize>> = Vec::new();
        for index in 0..count {
            let mut task = new_task(index, &axes, &base);
            let line = axes.first().map_or(1, |a| a.line);
            task.check().map_err(|m| {
                // The key the conflict is about, at its own line ([base] or
                // [axes]), not the [axes] table's first line.
                let (field, line) = m
                    .key()
                    .and_then(|k| key_lines.get(k).map(|(f, l)| (f.as_str(), *l)))
                    .unwrap_or(("axes", line));
                err(
                    None,
                    field,
                    format!("task {index} ({}): {m}", task.describe()),
                )
                .relocated(line)
            })?;
            let user_seed = task.user_seed();
            let seed_src = format!("gloam-sweep-seed\0{user_seed}\0{}", task.id);
            let d = Sha256::digest(seed_src.as_bytes());
            task.seed = u64::from_le_bytes(d[..8].try_into().expect("8 bytes"));
            task.render_key = task.compute_render_key();
            let next = chunks.len();
            let c = *keys.entry(task.render_key.clone()).or_insert(next);
            if c == next {
                chunks.push(Vec::new());
            }
            chunks[c].push(index);
            task.chunk = c;
            tasks.push(task);
        }
        Ok(Sweep {
            path: path.to_path_buf(),
            base_dir: base_dir.to_path_buf(),
            axes,
            tasks,
            chunks,
        })
    }

    /// A path from the sweep file, resolved against its directory.
    pub fn resolve(&self, p: &str) -> PathBuf {
        let p = Path::new(p);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base_dir.join(p)
        }
    }

    /// The task's scene, with its dotted overrides applied; `reads` notes
    /// the scene and the files it names.
    pub fn load_scene(
        &self,
        task: &Task,
        reads: &gloam_io::ReadLog,
    ) -> Result<gloam_scene::Scene, TaskSceneError> {
        let rel = task.text("scene").ok_or(TaskSceneError::NoScene)?;
        let path = self.resolve(&rel);
        let overrides = task.scene_overrides();
        if overrides.is_empty() {
            return Ok(gloam_scene::load(&path, reads)?);
        }
        let doc = overridden(&path, &overrides, reads)?;
        parse_overridden(&doc, &path, &overrides, reads)
    }

    /// Checks only the task's camera (its `camera.*` overrides applied): the
    /// build reads `[camera]` alone and nothing else reads it, so a task
    /// differing from a loaded one only in camera keys need not re-read its
    /// geometry (planning 2 000 camera widths of a 90 000-facet scene
    /// re-parsed the OBJ 2 000 times: 190 s).
    pub fn check_camera(&self, task: &Task) -> Result<(), TaskSceneError> {
        let rel = task.text("scene").ok_or(TaskSceneError::NoScene)?;
        let path = self.resolve(&rel);
        let overrides = task.scene_overrides();
        let off = gloam_io::ReadLog::off();
        let mut doc = overridden(&path, &overrides, &off)?;
        // A scene needs a band besides its camera; nothing else is read.
        doc.retain(|k, _| k == "units" || k == "camera" || k == "bands");
        parse_overridden(&doc, &path, &overrides, &off).map(|_| ())
    }

    /// The task's sensor: a preset name, or a `.toml` path resolved against
    /// the sweep file's directory.
    pub fn sensor(&self, task: &Task) -> Option<String> {
        let s = task.text("sensor")?;
        Some(if s.ends_with(".toml") {
            self.resolve(&s).display().to_string()
        } else {
            s
        })
    }
}

/// The scene file at `path` as a TOML table with `overrides` set.
fn overridden(
    path: &Path,
    overrides: &[(String, toml::Value)],
    reads: &gloam_io::ReadLog,
) -> Result<toml::Table, TaskSceneError> {
    let text = gloam_io::read_text(path, gloam_io::MAX_TEXT_FILE_BYTES, reads).map_err(|e| {
        TaskSceneError::Read {
            path: path.to_path_buf(),
            source: e.into(),
        }
    })?;
    let mut doc: toml::Table = toml::from_str(&text).map_err(|e| TaskSceneError::Read {
        path: path.to_path_buf(),
        source: e.into(),
    })?;
    for (key, value) in overrides {
        set_dotted(&mut doc, key, value.clone()).map_err(|source| TaskSceneError::Override {
            path: path.to_path_buf(),
            key: key.clone(),
            source,
        })?;
    }
    Ok(doc)
}

/// Builds the overridden table as a scene, its errors saying which
/// overrides were applied.
fn parse_overridden(
    doc: &toml::Table,
    path: &Path,
    overrides: &[(String, toml::Value)],
    reads: &gloam_io::ReadLog,
) -> Result<gloam_scene::Scene, TaskSceneError> {
    let text = toml::to_string(doc)?;
    let desc: Vec<String> = overrides
        .iter()
        .map(|(k, v)| format!("{k} = {}", scalar_text(v).unwrap_or_default()))
        .collect();
    gloam_scene::parse_str_noting(&text, path, reads).map_err(|source| {
        // An error at an overridden key: its line in the rewritten text is
        // no line of the scene file (camera.foo was blamed at base.toml:8,
        // `width = 32`); the sweep's override is named instead.
        if let gloam_scene::SceneError::Invalid { field, message, .. } = &source
            && overrides.iter().any(|(k, _)| {
                field == k
                    || field.starts_with(&format!("{k}."))
                    || field.starts_with(&format!("{k}["))
            })
        {
            return TaskSceneError::OverriddenKey {
                overrides: desc.join(", "),
                scene: path.to_path_buf(),
                field: field.clone(),
                message: message.clone(),
            };
        }
        TaskSceneError::Overridden {
            overrides: desc.join(", "),
            source,
        }
    })
}

/// How many tasks the axes' product makes; `None` past [`MAX_TASKS`].
fn task_count(axes: &[Axis]) -> Option<usize> {
    let mut count: usize = 1;
    for a in axes {
        count = count
            .checked_mul(a.values.len())
            .filter(|&n| n <= MAX_TASKS)?;
    }
    Some(count)
}

/// Task `index` of the product (mixed radix, last axis fastest): the base
/// values with its axes' picks, and its id from the picks; seed, render
/// key and chunk are set once it is checked.
fn new_task(index: usize, axes: &[Axis], base: &BTreeMap<String, toml::Value>) -> Task {
    // Mixed radix, last axis fastest.
    let mut rem = index;
    let mut picks = vec![0usize; axes.len()];
    for (j, a) in axes.iter().enumerate().rev() {
        picks[j] = rem % a.values.len();
        rem /= a.values.len();
    }
    let mut values = base.clone();
    let mut axis_text = Vec::with_capacity(axes.len());
    for (a, &p) in axes.iter().zip(&picks) {
        let v = a.values[p].clone();
        axis_text.push((a.name.clone(), scalar_text(&v).unwrap_or_default()));
        values.insert(a.name.clone(), v);
    }
    let mut sorted = axis_text.clone();
    sorted.sort();
    let id_src: String = sorted.iter().map(|(k, v)| format!("{k}={v}\n")).collect();
    let id = sha_hex(id_src.as_bytes())[..16].to_string();
    Task {
        index,
        id,
        axes: axis_text,
        seed: 0,
        render_key: String::new(),
        chunk: 0,
        values,
    }
}

impl SpecError {
    fn relocated(self, l: usize) -> SpecError {
        match self {
            SpecError::Invalid {
                path,
                field,
                message,
                ..
            } => SpecError::Invalid {
                path,
                line: l,
                field,
                message,
            },
            e => e,
        }
    }
}

/// Sets `a.b.c = value` in a TOML document, creating tables on the way.
fn set_dotted(doc: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), NotATable> {
    let parts: Vec<&str> = key.split('.').collect();
    let (last, path) = parts.split_last().expect("split yields one part");
    let mut t = doc;
    for p in path {
        let entry = t
            .entry(p.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        t = match entry {
            toml::Value::Table(t) => t,
            _ => return Err(NotATable(p.to_string())),
        };
    }
    t.insert(last.to_string(), value);
    Ok(())
}

/// A dotted override runs through a key of the scene file that holds a
/// value, not a table.
#[derive(Debug, thiserror::Error)]
#[error("'{0}' is not a table in the scene file")]
pub struct NotATable(pub String);

/// Why a task's scene could not be loaded, naming the file and the
/// sweep's overrides.
#[derive(Debug, thiserror::Error)]
pub enum TaskSceneError {
    #[error("this task has no scene (set `scene` in [base] or [axes])")]
    NoScene,
    #[error(transparent)]
    Scene(#[from] gloam_scene::SceneError),
    #[error("reading {}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error("{}: overriding {key}", path.display())]
    Override {
        path: PathBuf,
        key: String,
        #[source]
        source: NotATable,
    },
    #[error(transparent)]
    Rewrite(#[from] toml::ser::Error),
    #[error("with {overrides} from the sweep (the sweep's value, not a line of {}): {field}: {message}", scene.display())]
    OverriddenKey {
        overrides: String,
        scene: PathBuf,
        field: String,
        message: String,
    },
    #[error("with {overrides} from the sweep")]
    Overridden {
        overrides: String,
        #[source]
        source: gloam_scene::SceneError,
    },
}

/// What is wrong with one value of a sweep file (the [`SpecError`] that
/// carries it names the file, line and key).
#[derive(Debug, thiserror::Error)]
pub enum ValueError {
    #[error("an axis needs at least one value")]
    EmptyAxis,
    #[error("more than {MAX_TASKS} values")]
    TooManyValues,
    #[error("value {index} is not a string, number or boolean")]
    NotScalarAt { index: usize },
    #[error(
        "unknown key '{key}' in a range (expected from, count, step; a dotted scene key is quoted: \"camera.width\" = [...])"
    )]
    UnknownRangeKey { key: String },
    #[error("count must be an integer from 1 to {MAX_TASKS}")]
    BadCount,
    #[error("a range needs `from` and `count`")]
    IncompleteRange,
    #[error("the range overflows a 64-bit integer")]
    RangeOverflow,
    #[error("`from` and `step` must be numbers")]
    RangeNotNumbers,
    #[error("step 0 repeats one value `count` times (identical tasks)")]
    ZeroStep,
    #[error(
        "step {step:e} is lost in rounding: values {first} and {again} (from 0) of the range are both {value:e} (identical tasks)"
    )]
    RangeRepeats {
        step: f64,
        first: usize,
        again: usize,
        value: f64,
    },
    #[error("value {index} of the range (from + {index} × step) is not a finite number")]
    RangeNotFinite { index: usize },
    #[error("values {first} and {again} (from 0) are the same value: identical tasks")]
    RepeatedValue { first: usize, again: usize },
    #[error("an axis is a list of values or a range {{ from, count[, step] }}")]
    NotAnAxis,
    #[error("a table; a dotted scene key is quoted: \"{key}.…\" = value")]
    Table { key: String },
    #[error("expected {0}")]
    Expected(&'static str),
    #[error("unknown flow '{flow}' (this version runs: render, capture)")]
    UnknownFlow { flow: String },
    #[error(transparent)]
    Tile(TileError),
    #[error(transparent)]
    Size(SizeError),
    #[error("a dotted key needs a name between the dots")]
    EmptyDottedName,
    #[error("{source} (a sweep key is one of {}, a render setting or a dotted scene key)", OWN_KEYS.join(", "))]
    UnknownKey { source: gloam_trace::SettingsError },
    #[error("{0}")]
    TargetError(String),
}

/// `target_error = "camera"` or `"camera:K"` (any case): `Some` with `K` or
/// why it is not one; `None` for any other value (a relative error).
pub fn camera_target(
    text: &str,
) -> Option<Result<f64, gloam_pipeline::camera_goal::BadTargetError>> {
    use gloam_pipeline::camera_goal::TargetError;
    if !text.trim().to_ascii_lowercase().starts_with("camera") {
        return None;
    }
    Some(text.parse::<TargetError>().and_then(|t| match t {
        TargetError::Camera { k } => Ok(k),
        TargetError::Relative(_) => Err(gloam_pipeline::camera_goal::BadTargetError(text.into())),
    }))
}

/// A `size` that is not `WxH` with each from 1 to 16384.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("'{text}' is not a size WxH (e.g. 64x48, each 1 to 16384)")]
pub struct SizeError {
    pub text: String,
}

/// Keys a task allows on their own but not together.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Conflict {
    #[error("the render flow needs a scene")]
    RenderWithoutScene,
    #[error("a tile renders radiance only; sweep tiles without a sensor and merge them")]
    TileWithSensor,
    #[error("`size` is for the capture flow; a render's size is `camera.width`/`camera.height`")]
    SizeInRender,
    #[error("the capture flow needs a sensor")]
    CaptureWithoutSensor,
    /// The key named (the first of them): the error is blamed on its line,
    /// in [base] or [axes], not on the [axes] table's first key.
    #[error("the capture flow takes no scene, tile or scene keys (`{0}` is one)")]
    CaptureWithScene(String),
    #[error("the capture flow takes no render settings (`{0}` is one)")]
    CaptureWithSettings(String),
    #[error("a fixed gain and agc = true exclude each other")]
    GainAndAgc,
    #[error("gain and agc need a sensor")]
    GainWithoutSensor,
    /// `frames` and `noise` were taken without a camera and did nothing.
    #[error(
        "`{0}` is a camera key and needs a sensor (without one the task renders radiance only)"
    )]
    CameraKeyWithoutSensor(&'static str),
    #[error(
        "target_error = \"camera\" needs a sensor (the render is sampled to the camera's noise)"
    )]
    CameraTargetWithoutSensor,
    #[error(
        "target_error = \"camera\" with noise = false: frames without temporal noise hide no render error; give a relative target_error or spp"
    )]
    CameraTargetWithoutNoise,
}

impl Conflict {
    /// The key a conflict is blamed on, when one key is at fault.
    fn key(&self) -> Option<&str> {
        match self {
            Conflict::CaptureWithScene(k) | Conflict::CaptureWithSettings(k) => Some(k),
            Conflict::TileWithSensor => Some("tile"),
            Conflict::SizeInRender => Some("size"),
            Conflict::GainAndAgc => Some("agc"),
            Conflict::CameraTargetWithoutSensor => Some("target_error"),
            Conflict::CameraTargetWithoutNoise => Some("noise"),
            Conflict::CameraKeyWithoutSensor(k) => Some(k),
            _ => None,
        }
    }
}

/// An axis's values: a list of scalars, or `{ from, count[, step] }`.
fn axis_values(key: &str, v: &toml::Value) -> Result<Vec<toml::Value>, ValueError> {
    match v {
        toml::Value::Array(a) => {
            if a.is_empty() {
                return Err(ValueError::EmptyAxis);
            }
            if a.len() > MAX_TASKS {
                return Err(ValueError::TooManyValues);
            }
            for (i, x) in a.iter().enumerate() {
                if scalar_text(x).is_none() {
                    return Err(ValueError::NotScalarAt { index: i });
                }
            }
            // The same value twice would be two identical tasks (numbers
            // compared as numbers: 2 and 2.0 are one value). Sorted, so a
            // long axis costs n log n.
            let mut keyed: Vec<(String, usize)> = a
                .iter()
                .enumerate()
                .map(|(i, x)| {
                    let key = match x {
                        toml::Value::Integer(n) => format!("n:{n}"),
                        toml::Value::Float(f) if f.fract() == 0.0 && f.abs() < 9.0e15 => {
                            format!("n:{}", *f as i64)
                        }
                        toml::Value::Float(f) => format!("f:{f:e}"),
                        other => text_key(key, &scalar_text(other).unwrap_or_default()),
                    };
                    (key, i)
                })
                .collect();
            keyed.sort();
            if let Some(w) = keyed.windows(2).find(|w| w[0].0 == w[1].0) {
                let (first, again) = (w[0].1.min(w[1].1), w[0].1.max(w[1].1));
                return Err(ValueError::RepeatedValue { first, again });
            }
            Ok(a.clone())
        }
        toml::Value::Table(t) => {
            for k in t.keys() {
                if !["from", "count", "step"].contains(&k.as_str()) {
                    return Err(ValueError::UnknownRangeKey { key: k.clone() });
                }
            }
            let count = match t.get("count") {
                Some(toml::Value::Integer(n)) if *n >= 1 && (*n as u64) <= MAX_TASKS as u64 => {
                    *n as usize
                }
                Some(_) => return Err(ValueError::BadCount),
                None => return Err(ValueError::IncompleteRange),
            };
            let zero_step = t
                .get("step")
                .and_then(|s| s.as_float().or(s.as_integer().map(|i| i as f64)))
                .is_some_and(|s| s == 0.0);
            if zero_step && count > 1 {
                return Err(ValueError::ZeroStep);
            }
            match (t.get("from"), t.get("step")) {
                (Some(toml::Value::Integer(a)), None | Some(toml::Value::Integer(_))) => {
                    let step = t.get("step").and_then(|s| s.as_integer()).unwrap_or(1);
                    (0..count as i64)
                        .map(|i| {
                            i.checked_mul(step)
                                .and_then(|d| a.checked_add(d))
                                .map(toml::Value::Integer)
                                .ok_or(ValueError::RangeOverflow)
                        })
                        .collect()
                }
                (Some(from), step) => {
                    let a = from.as_float().or(from.as_integer().map(|i| i as f64));
                    let s = match step {
                        None => Some(1.0),
                        Some(s) => s.as_float().or(s.as_integer().map(|i| i as f64)),
                    };
                    match (a, s) {
                        (Some(a), Some(s)) if a.is_finite() && s.is_finite() => {
                            float_range(a, s, count)
                        }
                        _ => Err(ValueError::RangeNotNumbers),
                    }
                }
                (None, _) => Err(ValueError::IncompleteRange),
            }
        }
        _ => Err(ValueError::NotAnAxis),
    }
}

/// `count` values `a + i·s`. Each is finite, and no two are one number:
/// a step lost in rounding (`from = 0.01, step = 1e-18`) made identical
/// tasks, and `from = 1e308, step = 1e308` an infinite value.
fn float_range(a: f64, s: f64, count: usize) -> Result<Vec<toml::Value>, ValueError> {
    let mut out: Vec<toml::Value> = Vec::with_capacity(count);
    let mut last = None;
    for i in 0..count {
        let v = a + i as f64 * s;
        if !v.is_finite() {
            return Err(ValueError::RangeNotFinite { index: i });
        }
        if last == Some(v) {
            return Err(ValueError::RangeRepeats {
                step: s,
                first: i - 1,
                again: i,
                value: v,
            });
        }
        last = Some(v);
        out.push(toml::Value::Float(v));
    }
    Ok(out)
}

/// A text value of `key` as the task reads it, for finding one value
/// given twice: `" 1/2"` and `"1/2"` were two tasks rendering one tile,
/// `"./a.toml"` and `"a.toml"` one scene. Tiles and sizes as parsed,
/// paths without `.` components, words of a setting trimmed and in lower
/// case (settings take either) and numbers as numbers; a dotted scene
/// key's string is the scene's own and kept as written.
fn text_key(key: &str, text: &str) -> String {
    let t = text.trim();
    match key {
        "scene" | "sensor" => {
            let p: PathBuf = Path::new(text)
                .components()
                .filter(|c| !matches!(c, std::path::Component::CurDir))
                .collect();
            format!("t:{}", p.display())
        }
        "tile" => match TileSpec::parse(text) {
            Ok(tile) => format!("t:{}/{}", tile.k, tile.n),
            Err(_) => format!("t:{text}"),
        },
        "size" => match parse_size(text) {
            Ok((w, h)) => format!("t:{w}x{h}"),
            Err(_) => format!("t:{text}"),
        },
        k if k.contains('.') => format!("t:{text}"),
        _ => match t.parse::<f64>() {
            Ok(f) if f.fract() == 0.0 && f.abs() < 9.0e15 => format!("n:{}", f as i64),
            Ok(f) if f.is_finite() => format!("f:{f:e}"),
            _ => format!("t:{}", t.to_ascii_lowercase()),
        },
    }
}

/// Checks one value of `key` (in [base] or an axis).
fn check_value(key: &str, v: &toml::Value) -> Result<(), ValueError> {
    if v.is_table() {
        return Err(ValueError::Table { key: key.into() });
    }
    let text = scalar_text(v).ok_or(ValueError::Expected("a string, number or boolean"))?;
    match key {
        "scene" | "sensor" => match v {
            toml::Value::String(s) if !s.is_empty() => Ok(()),
            _ => Err(ValueError::Expected("a non-empty string")),
        },
        "flow" => match text.as_str() {
            "render" | "capture" => Ok(()),
            other => Err(ValueError::UnknownFlow { flow: other.into() }),
        },
        "seed" => match v {
            toml::Value::Integer(i) if *i >= 0 => Ok(()),
            _ => Err(ValueError::Expected("a non-negative integer")),
        },
        "gain" => match v.as_float().or(v.as_integer().map(|i| i as f64)) {
            Some(g) if g.is_finite() && g > 0.0 => Ok(()),
            _ => Err(ValueError::Expected("a positive number")),
        },
        "frames" => match v {
            toml::Value::Integer(i) if (1..=10_000).contains(i) => Ok(()),
            _ => Err(ValueError::Expected("an integer from 1 to 10000")),
        },
        "agc" | "noise" => match v {
            toml::Value::Boolean(_) => Ok(()),
            _ => Err(ValueError::Expected("true or false")),
        },
        "tile" => TileSpec::parse(&text).map(|_| ()).map_err(ValueError::Tile),
        "size" => parse_size(&text).map(|_| ()).map_err(ValueError::Size),
        // `camera` / `camera:K`: the camera's own noise (as `gloam render
        // --target-error camera[:K]`); a number is the render setting.
        "target_error" if camera_target(&text).is_some() => camera_target(&text)
            .into_iter()
            .try_for_each(|r| r.map(|_| ()))
            .map_err(|e| ValueError::TargetError(e.to_string())),
        k if k.contains('.') => {
            if k.split('.').any(str::is_empty) {
                Err(ValueError::EmptyDottedName)
            } else {
                Ok(())
            }
        }
        k => {
            let mut s = gloam_trace::RenderSettings::default();
            s.set(k, &text)
                .map_err(|source| ValueError::UnknownKey { source })
        }
    }
}

/// `WxH`, each from 1 to 16384.
pub fn parse_size(s: &str) -> Result<(u32, u32), SizeError> {
    let bad = || SizeError { text: s.into() };
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
        return Err(bad());
    }
    Ok((w, h))
}

impl Task {
    /// A value as text (the base's or this task's axis value).
    pub fn text(&self, key: &str) -> Option<String> {
        self.values.get(key).and_then(scalar_text)
    }

    /// `key=value` of the axis values, for messages.
    pub fn describe(&self) -> String {
        if self.axes.is_empty() {
            return "the base".into();
        }
        // A long number in exponent form: `gain = [1e300]` was named in
        // 301 digits.
        let shown = |v: &str| match v.parse::<f64>() {
            Ok(x) if v.len() > 20 => gloam_spectra::num(x),
            _ => v.to_string(),
        };
        self.axes
            .iter()
            .map(|(k, v)| format!("{k}={}", shown(v)))
            .collect::<Vec<_>>()
            .join(" ")
    }

    pub fn flow(&self) -> Flow {
        match self.text("flow").as_deref() {
            Some("capture") => Flow::Capture,
            Some(_) => Flow::Render,
            None if self.values.contains_key("scene") => Flow::Render,
            None => Flow::Capture,
        }
    }

    /// The sweep's `seed` (default 0): the render's seed, and the root of
    /// the task's noise seed.
    pub fn user_seed(&self) -> u64 {
        self.values
            .get("seed")
            .and_then(|v| v.as_integer())
            .map_or(0, |i| i as u64)
    }

    pub fn gain(&self) -> Option<f64> {
        let v = self.values.get("gain")?;
        v.as_float().or(v.as_integer().map(|i| i as f64))
    }

    pub fn frames(&self) -> u32 {
        self.values
            .get("frames")
            .and_then(|v| v.as_integer())
            .map_or(DEFAULT_FRAMES, |i| i as u32)
    }

    pub fn agc(&self) -> bool {
        self.values
            .get("agc")
            .and_then(|v| v.as_bool())
            .unwrap_or(false)
    }

    pub fn noise(&self) -> bool {
        self.values
            .get("noise")
            .and_then(|v| v.as_bool())
            .unwrap_or(true)
    }

    pub fn tile(&self) -> Option<TileSpec> {
        TileSpec::parse(&self.text("tile")?).ok()
    }

    pub fn size(&self) -> Option<(u32, u32)> {
        parse_size(&self.text("size")?).ok()
    }

    /// Render settings `(key, value)` of this task (not `seed`).
    pub fn setting_pairs(&self) -> Vec<(String, String)> {
        self.values
            .iter()
            .filter(|(k, _)| !OWN_KEYS.contains(&k.as_str()) && !k.contains('.'))
            .filter(|(k, _)| k.as_str() != "target_error" || self.camera_target().is_none())
            .map(|(k, v)| (k.clone(), scalar_text(v).unwrap_or_default()))
            .collect()
    }

    /// `K` of `target_error = "camera[:K]"` (checked when the file was
    /// read), if the task has one.
    pub fn camera_target(&self) -> Option<f64> {
        camera_target(&self.text("target_error")?)?.ok()
    }

    /// The task's render settings, its seed the sweep's `seed`.
    pub fn render_settings(
        &self,
    ) -> Result<gloam_trace::RenderSettings, gloam_trace::SettingsError> {
        let mut s = gloam_trace::RenderSettings::default();
        for (k, v) in self.setting_pairs() {
            s.set(&k, &v)?;
        }
        s.seed = self.user_seed();
        // As `gloam render --target-error camera`: a first round of one
        // sample per replicate unless `spp` is given.
        if self.camera_target().is_some() && !self.values.contains_key("spp") {
            s.spp = 2;
        }
        Ok(s)
    }

    /// Dotted keys: values that override the scene file.
    pub fn scene_overrides(&self) -> Vec<(String, toml::Value)> {
        self.values
            .iter()
            .filter(|(k, _)| k.contains('.'))
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect()
    }

    /// Combinations the keys allow on their own but not together.
    fn check(&self) -> Result<(), Conflict> {
        let has = |k: &str| self.values.contains_key(k);
        match self.flow() {
            Flow::Render => {
                if !has("scene") {
                    return Err(Conflict::RenderWithoutScene);
                }
                if has("tile") && has("sensor") {
                    return Err(Conflict::TileWithSensor);
                }
                if has("size") {
                    return Err(Conflict::SizeInRender);
                }
            }
            Flow::Capture => {
                if !has("sensor") {
                    return Err(Conflict::CaptureWithoutSensor);
                }
                let scene_key = ["scene", "tile"]
                    .into_iter()
                    .find(|k| has(k))
                    .map(String::from)
                    .or_else(|| self.scene_overrides().into_iter().next().map(|(k, _)| k));
                if let Some(k) = scene_key {
                    return Err(Conflict::CaptureWithScene(k));
                }
                if let Some((k, _)) = self.setting_pairs().into_iter().next() {
                    return Err(Conflict::CaptureWithSettings(k));
                }
            }
        }
        if has("gain") && has("agc") && self.agc() {
            return Err(Conflict::GainAndAgc);
        }
        if !has("sensor") && (has("gain") || has("agc")) && self.flow() == Flow::Render {
            return Err(Conflict::GainWithoutSensor);
        }
        if !has("sensor") && self.flow() == Flow::Render {
            for key in ["frames", "noise"] {
                if has(key) {
                    return Err(Conflict::CameraKeyWithoutSensor(key));
                }
            }
        }
        if self.camera_target().is_some() {
            if !has("sensor") {
                return Err(Conflict::CameraTargetWithoutSensor);
            }
            if !self.noise() {
                return Err(Conflict::CameraTargetWithoutNoise);
            }
        }
        Ok(())
    }

    /// Everything the shared work (a render) depends on; capture tasks
    /// share nothing.
    fn compute_render_key(&self) -> String {
        if self.flow() == Flow::Capture {
            return format!("task:{}", self.id);
        }
        let mut src = String::from("render\n");
        // Sampled to the camera's noise, the render depends on the gain.
        let camera_only: &[&str] = match self.camera_target() {
            Some(_) => &["frames", "noise", "flow"],
            None => &["gain", "frames", "agc", "noise", "flow"],
        };
        for (k, v) in &self.values {
            // Camera-only keys do not change the radiance.
            if camera_only.contains(&k.as_str()) {
                continue;
            }
            src.push_str(&format!("{k}={}\n", scalar_text(v).unwrap_or_default()));
        }
        sha_hex(src.as_bytes())[..16].to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Sweep, SpecError> {
        Sweep::parse(text, Path::new("t.toml"), Path::new("/base"))
    }

    const GRID: &str = r#"
[base]
scene = "s.toml"
sensor = "gen3-gaas-iccd"
[axes]
gain = [20, 100, 500]
spp = [1, 2]
seed = { from = 7, count = 2 }
"#;

    /// A zero step or a value given twice would make identical tasks:
    /// refused, naming the values (numbers compared as numbers); distinct
    /// values that print alike as floats are kept.
    #[test]
    fn repeated_values_and_zero_steps_are_refused() {
        for (axis, want) in [
            ("gain = [20, 100, 20]", "values 0 and 2"),
            ("gain = [20, 20.0]", "values 0 and 1"),
            ("gain = { from = 20, count = 3, step = 0 }", "step 0"),
            ("gain = { from = 2.5, count = 2, step = 0.0 }", "step 0"),
            ("sensor = [\"a\", \"b\", \"a\"]", "values 0 and 2"),
        ] {
            let text = format!(
                "[base]\nscene = \"s.toml\"\nsensor = \"gen3-gaas-iccd\"\n[axes]\n{axis}\n"
            );
            let e = parse(&text)
                .err()
                .map(|e| format!("{e:#}"))
                .unwrap_or_default();
            let chain = format!("{:?}", parse(&text).err());
            assert!(
                e.contains(want) || chain.contains(want),
                "{axis}: {e} / {chain}"
            );
        }
        for ok in [
            "gain = { from = 20, count = 1, step = 0 }",
            "gain = [0.1, 0.10000000000000002]",
            "gain = [20, 21]",
        ] {
            let text =
                format!("[base]\nscene = \"s.toml\"\nsensor = \"gen3-gaas-iccd\"\n[axes]\n{ok}\n");
            assert!(parse(&text).is_ok(), "{ok}: {:?}", parse(&text).err());
        }
    }

    /// `target_error = "camera[:K]"` is the camera target: K checked where
    /// it stands, a sensor and noise required, and — the render depending
    /// on the gain — gains no longer share a render; a number stays the
    /// render setting.
    #[test]
    fn a_camera_target_is_checked_and_splits_renders_by_gain() {
        let base = "[base]\nscene = \"s.toml\"\nsensor = \"gen3-gaas-iccd\"\n";
        let s = parse(&format!(
            "{base}target_error = \"camera:0.5\"\n[axes]\ngain = [20, 100, 500]\n"
        ))
        .unwrap();
        assert_eq!(s.chunks.len(), 3);
        let t = &s.tasks[0];
        assert_eq!(t.camera_target(), Some(0.5));
        assert!(t.setting_pairs().iter().all(|(k, _)| k != "target_error"));
        assert_eq!(t.render_settings().unwrap().spp, 2);
        assert_eq!(t.render_settings().unwrap().target_error, None);
        // `spp` given stays; a relative target is the render setting.
        let s = parse(&format!("{base}target_error = \"camera\"\nspp = 8\n")).unwrap();
        assert_eq!(s.tasks[0].render_settings().unwrap().spp, 8);
        let s = parse(&format!(
            "{base}target_error = 0.05\n[axes]\ngain = [20, 100]\n"
        ))
        .unwrap();
        assert_eq!((s.chunks.len(), s.tasks[0].camera_target()), (1, None));
        assert_eq!(
            s.tasks[0].render_settings().unwrap().target_error,
            Some(0.05)
        );
        // Mistakes, located.
        for (text, want) in [
            (
                format!("{base}\ntarget_error = \"camera:2\"\n"),
                "t.toml:5: base.target_error: --target-error \"camera:2\"",
            ),
            (
                format!("{base}[axes]\ntarget_error = [\"camera\", \"camera:x\"]\n"),
                "axes.target_error[1]",
            ),
            (
                "[base]\nscene = \"s.toml\"\ntarget_error = \"camera\"\n".to_string(),
                "needs a sensor",
            ),
            (
                format!("{base}target_error = \"camera\"\nnoise = false\n"),
                "noise = false",
            ),
        ] {
            let e = parse(&text).unwrap_err().to_string();
            assert!(e.contains(want), "{text}: {e}");
        }
    }

    #[test]
    fn tasks_are_the_product_with_stable_ids_and_shared_renders() {
        let s = parse(GRID).unwrap();
        assert_eq!(s.tasks.len(), 3 * 2 * 2);
        // The last axis varies fastest.
        assert_eq!(s.tasks[1].axes[2], ("seed".to_string(), "8".to_string()));
        assert_eq!(s.tasks[2].axes[1], ("spp".to_string(), "2".to_string()));
        let ids: std::collections::BTreeSet<_> = s.tasks.iter().map(|t| &t.id).collect();
        assert_eq!(ids.len(), 12);
        let seeds: std::collections::BTreeSet<_> = s.tasks.iter().map(|t| t.seed).collect();
        assert_eq!(seeds.len(), 12);
        // Gains share a render: one chunk per (spp, seed).
        assert_eq!(s.chunks.len(), 2 * 2);
        assert!(s.chunks.iter().all(|c| c.len() == 3));
        // Reordering the axes reorders the tasks but keeps each one's id and seed.
        let swapped = GRID.replace(
            "gain = [20, 100, 500]\nspp = [1, 2]",
            "spp = [1, 2]\ngain = [20, 100, 500]",
        );
        let r = parse(&swapped).unwrap();
        for t in &s.tasks {
            let same = r.tasks.iter().find(|u| u.id == t.id).unwrap();
            assert_eq!(same.seed, t.seed);
            assert_eq!(same.render_key, t.render_key);
        }
        assert_ne!(r.tasks[2].id, s.tasks[2].id);
    }

    #[test]
    fn mistakes_name_line_and_field() {
        let e = parse("[base]\nscene = \"s.toml\"\n[axes]\n\nspp = [1, -2]\n").unwrap_err();
        assert!(e.to_string().starts_with("t.toml:5: axes.spp[1]:"), "{e}");
        let e = parse("[base]\nscene = \"s.toml\"\ncamera.width = 3\n").unwrap_err();
        assert!(e.to_string().contains("quoted"), "{e}");
        let e = parse("[axes]\nseed = { from = 0, count = 1000 }\nspp = { from = 1, count = 1000 }\n[base]\nscene = \"s\"\n").unwrap_err();
        assert!(e.to_string().contains("exceeds 100000"), "{e}");
        let e = parse("[base]\nsensor = \"x\"\nspp = 2\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("capture flow takes no render settings"),
            "{e}"
        );
        // Round 13: a capture-flow conflict in [base] is blamed on the key
        // at fault and its line, not on the first axis.
        let e = parse(
            "[base]\nscene = \"s.toml\"\nflow = \"capture\"\nsensor = \"x\"\n[axes]\ngain = [100, 200]\n",
        )
        .unwrap_err();
        assert!(e.to_string().starts_with("t.toml:2: base.scene:"), "{e}");
        let e = parse("[base]\nsensor = \"x\"\nspp = 1\n[axes]\ngain = [100, 200]\n").unwrap_err();
        assert!(e.to_string().starts_with("t.toml:3: base.spp:"), "{e}");
        let e = parse("[base]\nsensor = \"x\"\n\"camera.width\" = 8\n[axes]\ngain = [100, 200]\n")
            .unwrap_err();
        assert!(
            e.to_string().starts_with("t.toml:3: base.camera.width:"),
            "{e}"
        );
        let e =
            parse("[base]\nsensor = \"x\"\n[axes]\ngain = [100, 200]\nspp = [1, 2]\n").unwrap_err();
        assert!(e.to_string().starts_with("t.toml:5: axes.spp:"), "{e}");
    }
}
