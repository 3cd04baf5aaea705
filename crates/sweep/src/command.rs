//! `gloam sweep …` past its arguments (feature `cli`): plan and run, run
//! a task or a chunk, status, collect, submit to Slurm — the sequence of
//! calls the command makes, with the executor over the pipeline
//! ([`crate::exec::Pipeline`]). What it shows goes through [`SweepUi`]:
//! the binary draws the bar and writes the lines.

use std::path::PathBuf;

use crate::cli::{RunArgs, StatusArgs, SweepArgs, SweepCommand};
use crate::collect::CollectError;
use crate::exec::Pipeline as Exec;
use crate::run::{Outcome, RunSummary, ensure_all_done};
use crate::slurm::{self, SlurmError};
use crate::{SweepDir, SweepError};

/// What a sweep shows its user.
pub trait SweepUi: Sync {
    /// A result on stdout (a job id, a status table, JSON).
    fn out(&self, text: &str) -> Result<(), SweepCommandError>;
    /// A line on stderr, above the bar if one is drawn.
    fn say(&self, line: &str);
    /// Starts a bar over `total` tasks; false where none is drawn (then
    /// every task's line is said).
    fn start(&self, total: u64) -> bool;
    /// One more task done.
    fn inc(&self);
    /// The bar is done.
    fn finish(&self);
}

/// Why a sweep command failed.
#[derive(Debug, thiserror::Error)]
pub enum SweepCommandError {
    #[error("usage: gloam sweep SWEEP.toml --out DIR")]
    Usage,
    #[error(transparent)]
    Sweep(#[from] SweepError),
    #[error(transparent)]
    Collect(#[from] CollectError),
    #[error(transparent)]
    Slurm(#[from] SlurmError),
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("locating the gloam binary")]
    Exe(#[source] std::io::Error),
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    #[error("task {index} failed: {why}")]
    TaskFailed { index: usize, why: String },
    #[error("{} task(s) failed:\n{}", .0.len(), .0.join("\n"))]
    TasksFailed(Vec<String>),
    /// Writing to stdout failed (a closed pipe ends the command quietly).
    #[error("writing to stdout: {0}")]
    Stdout(#[source] std::io::Error),
}

/// Runs `gloam sweep` as `args` ask (a new plan records this run's
/// provenance).
pub fn run(args: SweepArgs, ui: &dyn SweepUi) -> Result<(), SweepCommandError> {
    match args.command {
        Some(SweepCommand::Run(r)) => run_tasks(r, ui),
        Some(SweepCommand::Status(s)) => status(s, ui),
        Some(SweepCommand::Collect(s)) => {
            let c = crate::collect::collect(&SweepDir::open(&s.dir)?)?;
            if s.json {
                return ui.out(&serde_json::to_string_pretty(&c)?);
            }
            let (n, done, failed, missing) = (c.rows, c.done, c.failed, c.missing);
            let csv = s.dir.join("results.csv");
            ui.say(&format!(
                "collected {n} task(s): {done} done, {failed} failed, {missing} not done → {}",
                csv.display()
            ));
            Ok(())
        }
        None => {
            let provenance = gloam_pipeline::Provenance::of_this_run(&gloam_io::ReadLog::off());
            plan_and_run(args, serde_json::to_value(provenance)?, ui)
        }
    }
}

fn plan_and_run(
    args: SweepArgs,
    provenance: serde_json::Value,
    ui: &dyn SweepUi,
) -> Result<(), SweepCommandError> {
    let (Some(file), Some(out)) = (&args.sweep, &args.out) else {
        return Err(SweepCommandError::Usage);
    };
    let argv: Vec<String> = std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    let sd = SweepDir::create(file, out, &argv, provenance)?;
    let n = sd.sweep.tasks.len();
    if args.slurm {
        return submit(&args, &sd, out, ui);
    }
    let summary = run_with_progress(&sd, args.jobs, None, ui)?;
    crate::collect::collect(&sd)?;
    ui.say(&format!(
        "{n} task(s): {} ran, {} already done, {} failed → {}",
        summary.ran,
        summary.skipped,
        summary.failed.len(),
        sd.dir.join("results.csv").display()
    ));
    Ok(ensure_all_done(&sd.status())?)
}

/// `--slurm`: writes the array job's script and (unless `--dry-run`)
/// submits it.
fn submit(
    args: &SweepArgs,
    sd: &SweepDir,
    out: &PathBuf,
    ui: &dyn SweepUi,
) -> Result<(), SweepCommandError> {
    let n = sd.sweep.tasks.len();
    let dir = std::fs::canonicalize(out)?;
    let exe = std::env::current_exe().map_err(SweepCommandError::Exe)?;
    let (opts, chunks) = (args.slurm_options(), sd.sweep.chunks.len());
    let script = slurm::write_script(&dir, &exe, chunks, &opts)?;
    if args.dry_run {
        let s = script.display();
        ui.say(&format!(
            "wrote {s} ({n} tasks in {chunks} array indices); submit with: sbatch {s}"
        ));
        return Ok(());
    }
    let job_id = slurm::submit_and_record(&dir, &script, chunks, opts)?.job_id;
    ui.out(&job_id)?;
    ui.say(&format!(
        "submitted job {job_id}: {n} tasks in {chunks} array indices; `gloam sweep status {}`",
        out.display()
    ));
    Ok(())
}

/// Runs `only` (a chunk) or every chunk, with a bar over tasks where the
/// front end draws one and a line per task otherwise.
fn run_with_progress(
    sd: &SweepDir,
    jobs: Option<usize>,
    only: Option<usize>,
    ui: &dyn SweepUi,
) -> Result<RunSummary, SweepCommandError> {
    let total = match only {
        Some(c) => sd.sweep.chunks.get(c).map_or(0, Vec::len),
        None => sd.sweep.tasks.len(),
    } as u64;
    let bar = ui.start(total);
    let on_task = |o: &Outcome| {
        if let Some(why) = o.rerun_note() {
            ui.say(&why);
        }
        let line = o.line(&sd.sweep.tasks[o.index]);
        if !bar || matches!(o.result, Some(Err(_))) {
            ui.say(&line);
        }
        ui.inc();
    };
    let s = match only {
        Some(c) => {
            let mut s = RunSummary::default();
            for o in sd.run_chunk(&Exec, c, jobs, &on_task)? {
                s.add(o);
            }
            s
        }
        None => sd.run_all(&Exec, jobs, &on_task)?,
    };
    ui.finish();
    Ok(s)
}

fn run_tasks(r: RunArgs, ui: &dyn SweepUi) -> Result<(), SweepCommandError> {
    let sd = SweepDir::open(&r.dir)?;
    if let Some(i) = r.task {
        let o = sd.run_task(&Exec, i)?;
        if let Some(why) = o.rerun_note() {
            ui.say(&why);
        }
        match o.result {
            Some(Err(e)) => {
                let why = e.to_string();
                return Err(SweepCommandError::TaskFailed { index: i, why });
            }
            Some(Ok(())) => ui.say(&format!("task {i} done in {:.2} s", o.seconds)),
            None => ui.say(&format!("task {i} already done")),
        }
        return Ok(());
    }
    let s = run_with_progress(&sd, r.jobs, r.chunk, ui)?;
    if !s.failed.is_empty() {
        let list = (s.failed.iter()).map(|(i, e)| format!("  task {i}: {e}"));
        return Err(SweepCommandError::TasksFailed(list.collect()));
    }
    Ok(())
}

fn status(s: StatusArgs, ui: &dyn SweepUi) -> Result<(), SweepCommandError> {
    let states = SweepDir::open(&s.dir)?.status();
    let sub = slurm::read_submission(&s.dir);
    let job = sub.as_ref().map(|j| slurm::job_states(&j.job_id));
    if s.json {
        let v = serde_json::json!({"tasks": states, "slurm": job});
        return ui.out(&serde_json::to_string_pretty(&v)?);
    }
    ui.out(&states.to_string())?;
    if let Some(j) = job {
        ui.out(&j.to_string())?;
    }
    Ok(())
}
