//! A sweep directory: the plan, one record per task, and running tasks.
//!
//! ```text
//! DIR/sweep.toml          the sweep file as planned (tasks re-plan from it)
//! DIR/plan.json           provenance and the task list
//! DIR/tasks/NNNNN/        one task's outputs and task.json (its record)
//! DIR/results.csv, .json  from `collect`
//! ```
//!
//! A task's directory is written under a temporary name and renamed into
//! place with its record inside, so a task is either wholly there or not
//! at all: a killed run leaves no half-finished task, and a rerun skips
//! exactly the tasks whose record says done and whose output hashes match.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use gloam_io::ReadLog;
use gloam_pipeline::output::{OutputError, write_atomic};

use crate::spec::{SpecError, Sweep, Task};

/// An executor's error, kept whole until the task's record states its chain.
pub type TaskError = Box<dyn std::error::Error + Send + Sync>;

/// Why a sweep directory could not be planned, opened or run (a task's
/// own failure is not one: it goes into the task's record).
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    #[error("{what} {}", path.display())]
    Io {
        what: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("reading {} (is {} a sweep directory?)", plan.display(), dir.display())]
    NotASweep {
        plan: PathBuf,
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{} holds another sweep (its tasks differ from {}'s); use a new --out or remove it", dir.display(), file.display())]
    AnotherSweep { dir: PathBuf, file: PathBuf },
    #[error("{}: format '{found}', expected '{PLAN_FORMAT}'", path.display())]
    Format { path: PathBuf, found: String },
    #[error("{} changed since it was planned", .0.display())]
    Changed(PathBuf),
    #[error("{}: {planned} tasks planned, {now} now", path.display())]
    TaskCount {
        path: PathBuf,
        planned: usize,
        now: usize,
    },
    #[error(transparent)]
    Preflight(#[from] crate::preflight::PreflightError),
    #[error("task {index} is outside 0..{count}")]
    NoTask { index: usize, count: usize },
    #[error("chunk {index} is outside 0..{count}")]
    NoChunk { index: usize, count: usize },
    #[error("task outputs are files; {} is not", .0.display())]
    NotAFile(PathBuf),
    #[error("renaming {} to {}", from.display(), to.display())]
    Rename {
        from: PathBuf,
        to: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{} (JSON)", path.display())]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("starting the task pool")]
    Pool(#[source] rayon::ThreadPoolBuildError),
    #[error("{} task(s) failed:\n{}", .0.len(), .0.join("\n"))]
    Failed(Vec<String>),
    #[error(transparent)]
    Spec(#[from] SpecError),
    #[error(transparent)]
    Output(#[from] OutputError),
}

fn io(what: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> SweepError {
    let path = path.to_path_buf();
    move |source| SweepError::Io { what, path, source }
}

fn json(path: &Path) -> impl FnOnce(serde_json::Error) -> SweepError {
    let path = path.to_path_buf();
    move |source| SweepError::Json { path, source }
}

/// An error and its causes, `outer: cause: cause`, as a record keeps it.
pub fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    // Bounded: a chain is finite, but guard a cyclic one.
    for _ in 0..64 {
        let Some(c) = cause else { break };
        s.push_str(": ");
        s.push_str(&c.to_string());
        cause = c.source();
    }
    s
}

/// The figures a task reports (non-finite values are recorded as null).
pub type Figures = BTreeMap<String, f64>;

/// Runs the tasks of a sweep: [`crate::exec::Pipeline`] over the render and
/// camera code; a trait so the record keeping is tested without rendering.
pub trait Executor: Sync {
    /// The work shared by the tasks of one chunk (e.g. the scene's radiance).
    type Shared: Sync;
    /// Computes the shared work of `task`'s chunk once, noting the files
    /// it reads in `reads` (the inputs of every task of the chunk).
    fn prepare(
        &self,
        sweep: &Sweep,
        task: &Task,
        reads: &gloam_io::ReadLog,
    ) -> Result<Self::Shared, TaskError>;
    /// Runs one task, writing its output files into `out` (an empty
    /// directory), and returns its figures; the files it reads are noted
    /// in `reads` (the task's own log).
    fn run(
        &self,
        sweep: &Sweep,
        task: &Task,
        shared: &Self::Shared,
        out: &Path,
        reads: &gloam_io::ReadLog,
    ) -> Result<Figures, TaskError>;
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    Done,
    Failed,
}

/// `tasks/NNNNN/task.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TaskRecord {
    pub index: usize,
    pub id: String,
    pub status: Status,
    pub axes: BTreeMap<String, String>,
    pub seed: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    pub figures: BTreeMap<String, Option<f64>>,
    /// Output file → SHA-256 (hex).
    pub outputs: BTreeMap<String, String>,
    /// Every file the task read (scene, OBJ, spectra, sensor file, …) →
    /// its SHA-256 when the task ran: a rerun redoes the task when one
    /// changed (absent in records of older versions).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub inputs: BTreeMap<String, String>,
    pub seconds: f64,
    pub host: String,
    pub gloam_version: String,
}

pub const RECORD_FILE: &str = "task.json";

/// `plan.json`: where the sweep came from and what it holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PlanFile {
    pub format: String,
    pub gloam_version: String,
    pub command_line: Vec<String>,
    /// The sweep file as given, and its directory (absolute), against
    /// which its relative paths resolve.
    pub sweep_file: String,
    pub base_dir: String,
    pub sweep_sha256: String,
    pub axes: Vec<String>,
    pub task_count: usize,
    pub chunk_count: usize,
    pub tasks: Vec<serde_json::Value>,
    /// The caller's provenance record (git commit, time, hashed inputs).
    #[serde(default)]
    pub provenance: serde_json::Value,
}

pub const PLAN_FORMAT: &str = "gloam-sweep/1";

/// An opened sweep directory.
pub struct SweepDir {
    pub dir: PathBuf,
    pub sweep: Sweep,
    /// SHA-256 of input files as they are now, hashed once per run.
    input_hashes: std::sync::Mutex<BTreeMap<String, Option<String>>>,
}

/// What happened to one task in a run.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub index: usize,
    pub id: String,
    /// None: skipped (already done).
    pub result: Option<Result<(), TaskFailure>>,
    pub seconds: f64,
    /// Why a task recorded done ran again: its inputs that changed since
    /// (`path changed`, `path is no longer readable`); the front end says so.
    pub rerun_because: Vec<String>,
}

impl Outcome {
    /// One line saying what happened to the task.
    pub fn line(&self, task: &Task) -> String {
        let (i, t) = (self.index, task.describe());
        match &self.result {
            None => format!("task {i} ({t}) already done"),
            Some(Ok(())) => format!("task {i} ({t}) done in {:.2} s", self.seconds),
            Some(Err(e)) => format!("task {i} ({t}) failed: {e}"),
        }
    }

    /// Why a task recorded done ran again, when it did.
    pub fn rerun_note(&self) -> Option<String> {
        (!self.rerun_because.is_empty()).then(|| {
            format!(
                "task {}: its record is stale ({} since it ran); running it again",
                self.index,
                self.rerun_because.join(", ")
            )
        })
    }
}

/// Why a task failed: its executor's error chain, as its record keeps it
/// (the [`Outcome`] names the task).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, thiserror::Error)]
#[serde(transparent)]
#[error("{message}")]
pub struct TaskFailure {
    pub message: String,
}

/// Counts of a run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RunSummary {
    pub ran: usize,
    pub skipped: usize,
    pub failed: Vec<(usize, TaskFailure)>,
}

impl RunSummary {
    /// Counts one task's outcome.
    pub fn add(&mut self, o: Outcome) {
        match o.result {
            None => self.skipped += 1,
            Some(Ok(())) => self.ran += 1,
            Some(Err(e)) => {
                self.ran += 1;
                self.failed.push((o.index, e));
            }
        }
    }
}

pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

pub(crate) fn sha256_file(path: &Path) -> Result<String, SweepError> {
    // Hashing, not reading an input.
    let mut f = gloam_io::open_bounded(path, gloam_io::MAX_IMAGE_FILE_BYTES, &ReadLog::off())
        .map_err(io("reading", path))?;
    let mut h = Sha256::new();
    std::io::copy(&mut f, &mut h).map_err(io("reading", path))?;
    Ok(h.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// The sweep directory's own files (its plan, its copy of the sweep
/// file, task records) are state, not a task's inputs: read unlogged.
fn own_file() -> ReadLog {
    ReadLog::off()
}

fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| "unknown".into())
}

impl SweepDir {
    /// Plans `sweep_file` into `dir`: writes `sweep.toml` and `plan.json`,
    /// or, when `dir` already holds this sweep, opens it to resume. A
    /// different sweep in `dir` is an error.
    pub fn create(
        sweep_file: &Path,
        dir: &Path,
        command_line: &[String],
        provenance: serde_json::Value,
    ) -> Result<Self, SweepError> {
        let text = gloam_io::read_text(sweep_file, gloam_io::MAX_TEXT_FILE_BYTES, &own_file())
            .map_err(io("reading", sweep_file))?;
        let base_dir = sweep_file
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let base_dir = std::fs::canonicalize(base_dir).map_err(io("resolving", base_dir))?;
        let sweep = Sweep::parse(&text, sweep_file, &base_dir)?;
        crate::preflight::check(&sweep)?;
        let sha = sha256_hex(text.as_bytes());
        if dir.join("plan.json").exists() {
            let old = Self::open(dir)?;
            let ids = |s: &Sweep| s.tasks.iter().map(|t| t.id.clone()).collect::<Vec<_>>();
            if ids(&old.sweep) != ids(&sweep) || old.sweep.base_dir != sweep.base_dir {
                return Err(SweepError::AnotherSweep {
                    dir: dir.to_path_buf(),
                    file: sweep_file.to_path_buf(),
                });
            }
            return Ok(old);
        }
        std::fs::create_dir_all(dir.join("tasks")).map_err(io("creating", dir))?;
        let plan_path = dir.join("plan.json");
        let plan = PlanFile {
            format: PLAN_FORMAT.into(),
            gloam_version: env!("CARGO_PKG_VERSION").into(),
            command_line: command_line.to_vec(),
            sweep_file: sweep_file.display().to_string(),
            base_dir: base_dir.display().to_string(),
            sweep_sha256: sha,
            axes: sweep.axes.iter().map(|a| a.name.clone()).collect(),
            task_count: sweep.tasks.len(),
            chunk_count: sweep.chunks.len(),
            tasks: sweep
                .tasks
                .iter()
                .map(serde_json::to_value)
                .collect::<Result<_, _>>()
                .map_err(json(&plan_path))?,
            provenance,
        };
        // The sweep text first: plan.json is what marks the directory planned.
        write_atomic(&dir.join("sweep.toml"), text.as_bytes())?;
        let text = serde_json::to_string_pretty(&plan).map_err(json(&plan_path))?;
        write_atomic(&plan_path, text.as_bytes())?;
        Ok(SweepDir {
            dir: dir.to_path_buf(),
            sweep,
            input_hashes: Default::default(),
        })
    }

    /// Opens a planned sweep directory.
    pub fn open(dir: &Path) -> Result<Self, SweepError> {
        let pp = dir.join("plan.json");
        let text = gloam_io::read_text(&pp, gloam_io::MAX_TEXT_FILE_BYTES, &own_file()).map_err(
            |source| SweepError::NotASweep {
                plan: pp.clone(),
                dir: dir.to_path_buf(),
                source,
            },
        )?;
        let plan: PlanFile = serde_json::from_str(&text).map_err(json(&pp))?;
        if plan.format != PLAN_FORMAT {
            let (path, found) = (pp, plan.format);
            return Err(SweepError::Format { path, found });
        }
        let sp = dir.join("sweep.toml");
        let text = gloam_io::read_text(&sp, gloam_io::MAX_TEXT_FILE_BYTES, &own_file())
            .map_err(io("reading", &sp))?;
        if sha256_hex(text.as_bytes()) != plan.sweep_sha256 {
            return Err(SweepError::Changed(sp));
        }
        let sweep = Sweep::parse(&text, &sp, Path::new(&plan.base_dir))?;
        if sweep.tasks.len() != plan.task_count {
            let (planned, now) = (plan.task_count, sweep.tasks.len());
            return Err(SweepError::TaskCount {
                path: pp,
                planned,
                now,
            });
        }
        Ok(SweepDir {
            dir: dir.to_path_buf(),
            sweep,
            input_hashes: Default::default(),
        })
    }

    pub fn plan(&self) -> Result<PlanFile, SweepError> {
        let pp = self.dir.join("plan.json");
        let text = gloam_io::read_text(&pp, gloam_io::MAX_TEXT_FILE_BYTES, &own_file())
            .map_err(io("reading", &pp))?;
        serde_json::from_str(&text).map_err(json(&pp))
    }

    pub fn task_dir(&self, index: usize) -> PathBuf {
        self.dir.join("tasks").join(format!("{index:05}"))
    }

    /// The task's record, if it has one that belongs to this task.
    pub fn record(&self, index: usize) -> Option<TaskRecord> {
        let p = self.task_dir(index).join(RECORD_FILE);
        let r: TaskRecord = serde_json::from_str(
            &gloam_io::read_text(&p, gloam_io::MAX_TEXT_FILE_BYTES, &own_file()).ok()?,
        )
        .ok()?;
        (r.id == self.sweep.tasks.get(index)?.id).then_some(r)
    }

    /// Done, with every recorded output present and unchanged, and every
    /// input it read unchanged.
    pub fn is_done(&self, index: usize) -> bool {
        let Some(r) = self.record(index) else {
            return false;
        };
        let dir = self.task_dir(index);
        r.status == Status::Done
            && r.outputs
                .iter()
                .all(|(f, h)| sha256_file(&dir.join(f)).is_ok_and(|x| &x == h))
            && self.changed_inputs(&r).is_empty()
    }

    /// The inputs of a task record whose content changed since the task
    /// ran (or that are gone), as `path (why)`.
    pub fn changed_inputs(&self, r: &TaskRecord) -> Vec<String> {
        r.inputs
            .iter()
            .filter_map(|(p, h)| {
                let now = self.current_hash(p);
                match now {
                    Some(x) if &x == h => None,
                    Some(_) => Some(format!("{p} changed")),
                    None => Some(format!("{p} is no longer readable")),
                }
            })
            .collect()
    }

    fn current_hash(&self, path: &str) -> Option<String> {
        if let Ok(c) = self.input_hashes.lock()
            && let Some(h) = c.get(path)
        {
            return h.clone();
        }
        let h = sha256_file(Path::new(path)).ok();
        if let Ok(mut c) = self.input_hashes.lock() {
            c.insert(path.to_string(), h.clone());
        }
        h
    }

    /// Why a task recorded done runs again: the inputs that changed.
    fn why_rerun(&self, index: usize) -> Vec<String> {
        match self.record(index) {
            Some(r) if r.status == Status::Done => self.changed_inputs(&r),
            _ => Vec::new(),
        }
    }

    /// Runs `index` if it is not done.
    pub fn run_task<E: Executor>(&self, exec: &E, index: usize) -> Result<Outcome, SweepError> {
        let count = self.sweep.tasks.len();
        if index >= count {
            return Err(SweepError::NoTask { index, count });
        }
        if self.is_done(index) {
            return Ok(self.skipped(index));
        }
        let rerun_because = self.why_rerun(index);
        let task = &self.sweep.tasks[index];
        let t0 = Instant::now();
        let read = ReadLog::new();
        let shared = exec.prepare(&self.sweep, task, &read);
        let read = read.reads();
        let o = match shared {
            Ok(s) => self.run_prepared(exec, index, Ok(&s), &read, t0),
            Err(e) => self.run_prepared::<E>(exec, index, Err(&chain(&*e)), &read, t0),
        }?;
        Ok(Outcome { rerun_because, ..o })
    }

    fn skipped(&self, index: usize) -> Outcome {
        Outcome {
            index,
            id: self.sweep.tasks[index].id.clone(),
            result: None,
            seconds: 0.0,
            rerun_because: Vec::new(),
        }
    }

    /// Runs the pending tasks of chunk `c`, preparing its shared work once.
    /// `jobs` tasks run at once (None: all cores).
    pub fn run_chunk<E: Executor>(
        &self,
        exec: &E,
        c: usize,
        jobs: Option<usize>,
        on_task: &(dyn Fn(&Outcome) + Sync),
    ) -> Result<Vec<Outcome>, SweepError> {
        let count = self.sweep.chunks.len();
        let members = (self.sweep.chunks.get(c)).ok_or(SweepError::NoChunk { index: c, count })?;
        let mut outcomes = Vec::new();
        let mut pending = Vec::new();
        let mut rerun_because = BTreeMap::new();
        for &i in members {
            if self.is_done(i) {
                let o = self.skipped(i);
                on_task(&o);
                outcomes.push(o);
            } else {
                rerun_because.insert(i, self.why_rerun(i));
                pending.push(i);
            }
        }
        let Some(&first) = pending.first() else {
            return Ok(outcomes);
        };
        let t0 = Instant::now();
        let read = ReadLog::new();
        let shared =
            (exec.prepare(&self.sweep, &self.sweep.tasks[first], &read)).map_err(|e| chain(&*e));
        let read = read.reads();
        let run_one = |i: usize| -> Result<Outcome, SweepError> {
            let t = if i == first { t0 } else { Instant::now() };
            let o = match &shared {
                Ok(s) => self.run_prepared(exec, i, Ok(s), &read, t)?,
                Err(e) => self.run_prepared::<E>(exec, i, Err(e), &read, t)?,
            };
            let o = Outcome {
                rerun_because: rerun_because.get(&i).cloned().unwrap_or_default(),
                ..o
            };
            on_task(&o);
            Ok(o)
        };
        let ran: Vec<Result<Outcome, SweepError>> = match jobs {
            Some(1) => pending.iter().map(|&i| run_one(i)).collect(),
            Some(n) => rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(SweepError::Pool)?
                .install(|| pending.par_iter().map(|&i| run_one(i)).collect()),
            None => pending.par_iter().map(|&i| run_one(i)).collect(),
        };
        for r in ran {
            outcomes.push(r?);
        }
        Ok(outcomes)
    }

    /// Every chunk in turn (each chunk's render uses all cores).
    pub fn run_all<E: Executor>(
        &self,
        exec: &E,
        jobs: Option<usize>,
        on_task: &(dyn Fn(&Outcome) + Sync),
    ) -> Result<RunSummary, SweepError> {
        self.remove_stale_temporaries();
        let mut s = RunSummary::default();
        for c in 0..self.sweep.chunks.len() {
            for o in self.run_chunk(exec, c, jobs, on_task)? {
                s.add(o);
            }
        }
        Ok(s)
    }

    /// Temporary task directories left by a killed run.
    fn remove_stale_temporaries(&self) {
        if let Ok(rd) = std::fs::read_dir(self.dir.join("tasks")) {
            for e in rd.flatten() {
                if e.file_name().to_string_lossy().starts_with(".tmp") {
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
        }
    }

    /// Runs one task with its chunk's shared work (or the error that
    /// preparing it gave) and publishes its directory.
    fn run_prepared<E: Executor>(
        &self,
        exec: &E,
        index: usize,
        shared: Result<&E::Shared, &str>,
        prepare_read: &[gloam_io::FileRead],
        t0: Instant,
    ) -> Result<Outcome, SweepError> {
        let task = &self.sweep.tasks[index];
        let tasks_dir = self.dir.join("tasks");
        std::fs::create_dir_all(&tasks_dir).map_err(io("creating", &tasks_dir))?;
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".tmp-{index:05}-"))
            .tempdir_in(&tasks_dir)
            .map_err(io("creating a temporary directory in", &tasks_dir))?;
        // The task's own log: tasks run in parallel, each with its reads.
        let run_read = ReadLog::new();
        let result = match shared {
            Ok(s) => exec
                .run(&self.sweep, task, s, tmp.path(), &run_read)
                .map_err(|e| chain(&*e)),
            Err(e) => Err(e.to_string()),
        };
        let inputs = input_hashes(prepare_read.iter().chain(&run_read.reads()));
        let mut record = TaskRecord {
            index,
            id: task.id.clone(),
            status: Status::Done,
            axes: task.axes.iter().cloned().collect(),
            seed: task.seed,
            error: None,
            figures: BTreeMap::new(),
            outputs: BTreeMap::new(),
            inputs,
            seconds: 0.0,
            host: host(),
            gloam_version: env!("CARGO_PKG_VERSION").into(),
        };
        match &result {
            Ok(figs) => {
                record.figures = figs
                    .iter()
                    .map(|(k, v)| (k.clone(), v.is_finite().then_some(*v)))
                    .collect();
                record.outputs = output_hashes(tmp.path())?;
            }
            Err(e) => {
                record.status = Status::Failed;
                record.error = Some(e.clone());
                // A failed task keeps no partial outputs.
                let rd = std::fs::read_dir(tmp.path()).map_err(io("listing", tmp.path()))?;
                for e in rd.flatten() {
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
        record.seconds = t0.elapsed().as_secs_f64();
        let rp = tmp.path().join(RECORD_FILE);
        write_atomic(
            &rp,
            (serde_json::to_string_pretty(&record).map_err(json(&rp))?).as_bytes(),
        )?;
        let dest = self.task_dir(index);
        if dest.exists() {
            std::fs::remove_dir_all(&dest).map_err(io("replacing", &dest))?;
        }
        let kept = tmp.keep();
        std::fs::rename(&kept, &dest).map_err(|source| SweepError::Rename {
            from: kept,
            to: dest,
            source,
        })?;
        Ok(Outcome {
            index,
            id: task.id.clone(),
            result: Some(
                result
                    .map(|_| ())
                    .map_err(|message| TaskFailure { message }),
            ),
            seconds: record.seconds,
            rerun_because: Vec::new(),
        })
    }

    /// Task states from the records.
    pub fn status(&self) -> TaskStates {
        let mut s = TaskStates {
            total: self.sweep.tasks.len(),
            ..Default::default()
        };
        for t in &self.sweep.tasks {
            match self.record(t.index) {
                Some(r) if r.status == Status::Done && self.is_done(t.index) => s.done += 1,
                Some(r) if r.status == Status::Failed => s.failed.push(FailedTask {
                    index: t.index,
                    id: t.id.clone(),
                    axes: t.describe(),
                    error: r.error.unwrap_or_default(),
                }),
                Some(_) => s.changed.push(t.index),
                None => s.pending += 1,
            }
        }
        s
    }
}

/// What a task read (its chunk's shared work and its own run), each file
/// once, by path, with its hash (recorded at the read, else hashed now).
fn input_hashes<'a>(
    reads: impl Iterator<Item = &'a gloam_io::FileRead>,
) -> BTreeMap<String, String> {
    let mut inputs = BTreeMap::new();
    for r in reads {
        let p = r.path.display().to_string();
        if inputs.contains_key(&p) {
            continue;
        }
        let h = match &r.sha256 {
            Some(h) => Some(h.clone()),
            None => sha256_file(&r.path).ok(),
        };
        if let Some(h) = h {
            inputs.insert(p, h);
        }
    }
    inputs
}

/// A finished task's outputs, by file name, with their hashes; anything
/// but a plain file there is an error.
fn output_hashes(dir: &Path) -> Result<BTreeMap<String, String>, SweepError> {
    let mut outputs = BTreeMap::new();
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .and_then(|rd| rd.map(|e| e.map(|e| e.path())).collect())
        .map_err(io("listing", dir))?;
    files.sort();
    for f in files {
        if !f.is_file() {
            return Err(SweepError::NotAFile(f));
        }
        let name = f
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        outputs.insert(name, sha256_file(&f)?);
    }
    Ok(outputs)
}

/// What the records say.
#[derive(Clone, Debug, Default, Serialize)]
pub struct TaskStates {
    pub total: usize,
    pub done: usize,
    pub pending: usize,
    pub failed: Vec<FailedTask>,
    /// Recorded done, but an output is missing or its hash changed.
    pub changed: Vec<usize>,
}

#[derive(Clone, Debug, Serialize)]
pub struct FailedTask {
    pub index: usize,
    pub id: String,
    pub axes: String,
    pub error: String,
}

/// `gloam sweep status`'s text: the counts, then each failed task.
impl std::fmt::Display for TaskStates {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (n, done, failed) = (self.total, self.done, self.failed.len());
        write!(
            f,
            "{n} task(s): {done} done, {failed} failed, {} pending",
            self.pending
        )?;
        if !self.changed.is_empty() {
            let k = self.changed.len();
            write!(f, ", {k} with changed outputs or inputs (will rerun)")?;
        }
        for t in &self.failed {
            write!(f, "\n  failed: task {} ({}): {}", t.index, t.axes, t.error)?;
        }
        Ok(())
    }
}

/// Checks that no tasks are left to do.
pub fn ensure_all_done(s: &TaskStates) -> Result<(), SweepError> {
    if !s.failed.is_empty() {
        let list: Vec<String> = s
            .failed
            .iter()
            .map(|f| format!("  task {} ({}): {}", f.index, f.axes, f.error))
            .collect();
        return Err(SweepError::Failed(list));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A task's record keeps its executor's error as anyhow prints it
    /// (`outer: cause: cause`), the form records had before the boxing.
    #[test]
    fn chain_reads_as_anyhow_alternate() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let e = anyhow::Error::new(io)
            .context("reading scene.toml")
            .context("task 3");
        let expected = format!("{e:#}");
        let boxed: TaskError = e.into();
        assert_eq!(chain(&*boxed), expected);
        assert_eq!(expected, "task 3: reading scene.toml: no such file");
    }

    /// Opening a directory that is not a sweep names both files.
    #[test]
    fn open_names_the_missing_plan() {
        let dir = tempfile::tempdir().unwrap();
        let Err(e) = SweepDir::open(dir.path()) else {
            panic!("opened an empty directory as a sweep");
        };
        assert!(matches!(e, SweepError::NotASweep { .. }));
        let text = e.to_string();
        assert!(
            text.contains("plan.json") && text.contains("a sweep directory?"),
            "{text}"
        );
    }
}
