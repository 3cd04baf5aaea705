//! `gloam sweep SWEEP.toml --out DIR [--slurm …]`, `gloam sweep run|status|collect DIR`.
//!
//! Planning, records, resuming, Slurm, the results table and the executor
//! that runs a task over the render and camera code are `gloam-sweep`;
//! this file is the arguments and the progress display.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use gloam_sweep::SweepDir;
use gloam_sweep::exec::Pipeline as Exec;
use gloam_sweep::run::{Outcome, ensure_all_done};
use gloam_sweep::slurm::{self, SlurmOptions};

use super::output::print_json;

#[derive(Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    pub command: Option<SweepCommand>,
    /// The sweep file (TOML, see docs/sweep.md).
    #[arg(required = true)]
    pub sweep: Option<PathBuf>,
    /// The sweep directory (plan, task records, results).
    #[arg(long, required = true)]
    pub out: Option<PathBuf>,
    /// Tasks run at once within a chunk (default: all cores).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Write DIR/sweep.sbatch (an array job, one index per chunk of tasks
    /// sharing a render) and submit it with sbatch.
    #[arg(long)]
    pub slurm: bool,
    /// With --slurm: only write the script.
    #[arg(long, requires = "slurm")]
    pub dry_run: bool,
    #[arg(long, requires = "slurm")]
    pub partition: Option<String>,
    /// Slurm time limit per array task (e.g. 30, 01:00:00).
    #[arg(long, requires = "slurm")]
    pub time: Option<String>,
    #[arg(long, requires = "slurm")]
    pub cpus_per_task: Option<u32>,
    /// At most K array tasks at once.
    #[arg(long, requires = "slurm", value_name = "K")]
    pub max_parallel: Option<u32>,
}

#[derive(Subcommand)]
pub enum SweepCommand {
    /// Run tasks of a planned sweep (all pending ones, one --task, or one
    /// --chunk: what each Slurm array index calls).
    Run(RunArgs),
    /// Task states from the records (and Slurm's, after --slurm).
    Status(StatusArgs),
    /// Gather every task's figures into DIR/results.csv and .json, and plots.
    Collect(StatusArgs),
}

#[derive(Args)]
pub struct RunArgs {
    pub dir: PathBuf,
    #[arg(long, conflicts_with = "chunk")]
    pub task: Option<usize>,
    #[arg(long)]
    pub chunk: Option<usize>,
    #[arg(long)]
    pub jobs: Option<usize>,
}

#[derive(Args)]
pub struct StatusArgs {
    pub dir: PathBuf,
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: SweepArgs) -> anyhow::Result<()> {
    match args.command {
        Some(SweepCommand::Run(r)) => run_tasks(r),
        Some(SweepCommand::Status(s)) => status(s),
        Some(SweepCommand::Collect(s)) => {
            let sd = SweepDir::open(&s.dir)?;
            let c = gloam_sweep::collect::collect(&sd)?;
            if s.json {
                print_json(&c)?;
            } else {
                eprintln!(
                    "collected {} task(s): {} done, {} failed, {} not done → {}",
                    c.rows,
                    c.done,
                    c.failed,
                    c.missing,
                    s.dir.join("results.csv").display()
                );
            }
            Ok(())
        }
        None => plan_and_run(args),
    }
}

fn plan_and_run(args: SweepArgs) -> anyhow::Result<()> {
    let (Some(file), Some(out)) = (args.sweep, args.out) else {
        bail!("usage: gloam sweep SWEEP.toml --out DIR");
    };
    let argv: Vec<String> = std::env::args().collect();
    let provenance = serde_json::to_value(gloam_pipeline::Provenance::of_this_run())?;
    let sd = SweepDir::create(&file, &out, &argv, provenance)?;
    let n = sd.sweep.tasks.len();
    if args.slurm {
        let dir = std::fs::canonicalize(&out)?;
        let exe = std::env::current_exe().context("locating the gloam binary")?;
        let opts = SlurmOptions {
            partition: args.partition,
            time: args.time,
            cpus_per_task: args.cpus_per_task,
            max_parallel: args.max_parallel,
        };
        let chunks = sd.sweep.chunks.len();
        let script = slurm::write_script(&dir, &exe, chunks, &opts)?;
        if args.dry_run {
            eprintln!(
                "wrote {} ({n} tasks in {chunks} array indices); submit with: sbatch {}",
                script.display(),
                script.display()
            );
            return Ok(());
        }
        let job_id = slurm::submit_and_record(&dir, &script, chunks, opts)?.job_id;
        outln!("{job_id}");
        eprintln!(
            "submitted job {job_id}: {n} tasks in {chunks} array indices; `gloam sweep status {}`",
            out.display()
        );
        return Ok(());
    }
    let summary = run_with_progress(&sd, args.jobs, None)?;
    let c = gloam_sweep::collect::collect(&sd)?;
    eprintln!(
        "{} task(s): {} ran, {} already done, {} failed → {}",
        n,
        summary.ran,
        summary.skipped,
        summary.failed.len(),
        sd.dir.join("results.csv").display()
    );
    let _ = c;
    ensure_all_done(&sd.status())
}

/// Runs `only` (a chunk) or every chunk, with a bar over tasks on a
/// terminal and a line per task otherwise.
fn run_with_progress(
    sd: &SweepDir,
    jobs: Option<usize>,
    only: Option<usize>,
) -> anyhow::Result<gloam_sweep::run::RunSummary> {
    let total = match only {
        Some(c) => sd.sweep.chunks.get(c).map_or(0, Vec::len),
        None => sd.sweep.tasks.len(),
    } as u64;
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(total);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} tasks {elapsed}/{eta} {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let on_task = |o: &Outcome| {
        if let Some(why) = rerun_note(o) {
            match &bar {
                Some(b) => b.suspend(|| eprintln!("{why}")),
                None => eprintln!("{why}"),
            }
        }
        let t = &sd.sweep.tasks[o.index];
        let line = match &o.result {
            None => format!("task {} ({}) already done", o.index, t.describe()),
            Some(Ok(())) => format!(
                "task {} ({}) done in {:.2} s",
                o.index,
                t.describe(),
                o.seconds
            ),
            Some(Err(e)) => format!("task {} ({}) failed: {e}", o.index, t.describe()),
        };
        match &bar {
            Some(b) => {
                if matches!(o.result, Some(Err(_))) {
                    b.suspend(|| eprintln!("{line}"));
                }
                b.inc(1);
            }
            None => eprintln!("{line}"),
        }
    };
    let s = match only {
        Some(c) => {
            let mut s = gloam_sweep::run::RunSummary::default();
            for o in sd.run_chunk(&Exec, c, jobs, &on_task)? {
                s.add(o);
            }
            s
        }
        None => sd.run_all(&Exec, jobs, &on_task)?,
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    Ok(s)
}

/// Why a task recorded done ran again, when it did.
fn rerun_note(o: &Outcome) -> Option<String> {
    (!o.rerun_because.is_empty()).then(|| {
        format!(
            "task {}: its record is stale ({} since it ran); running it again",
            o.index,
            o.rerun_because.join(", ")
        )
    })
}

fn run_tasks(r: RunArgs) -> anyhow::Result<()> {
    let sd = SweepDir::open(&r.dir)?;
    if let Some(i) = r.task {
        let o = sd.run_task(&Exec, i)?;
        if let Some(why) = rerun_note(&o) {
            eprintln!("{why}");
        }
        return match o.result {
            None => {
                eprintln!("task {i} already done");
                Ok(())
            }
            Some(Ok(())) => {
                eprintln!("task {i} done in {:.2} s", o.seconds);
                Ok(())
            }
            Some(Err(e)) => bail!("task {i} failed: {e}"),
        };
    }
    let s = run_with_progress(&sd, r.jobs, r.chunk)?;
    if !s.failed.is_empty() {
        let list: Vec<String> = s
            .failed
            .iter()
            .map(|(i, e)| format!("  task {i}: {e}"))
            .collect();
        bail!("{} task(s) failed:\n{}", s.failed.len(), list.join("\n"));
    }
    Ok(())
}

fn status(s: StatusArgs) -> anyhow::Result<()> {
    let sd = SweepDir::open(&s.dir)?;
    let states = sd.status();
    let sub = slurm::read_submission(&s.dir);
    let job = sub.as_ref().map(|j| slurm::job_states(&j.job_id));
    if s.json {
        return print_json(&serde_json::json!({"tasks": states, "slurm": job}));
    }
    outln!(
        "{} task(s): {} done, {} failed, {} pending{}",
        states.total,
        states.done,
        states.failed.len(),
        states.pending,
        if states.changed.is_empty() {
            String::new()
        } else {
            format!(
                ", {} with changed outputs or inputs (will rerun)",
                states.changed.len()
            )
        }
    );
    for f in &states.failed {
        outln!("  failed: task {} ({}): {}", f.index, f.axes, f.error);
    }
    if let Some(j) = job {
        let st: Vec<String> = j.states.iter().map(|(k, v)| format!("{k} {v}")).collect();
        outln!(
            "slurm job {} ({}): {}{}",
            j.job_id,
            j.source,
            if st.is_empty() {
                "nothing queued or running".into()
            } else {
                st.join(", ")
            },
            j.note.map(|n| format!(" [{n}]")).unwrap_or_default()
        );
    }
    Ok(())
}
