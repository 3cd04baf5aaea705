//! `gloam sweep SWEEP.toml --out DIR [--slurm …]`, `gloam sweep run|status|collect DIR`.
//!
//! The arguments are [`gloam_sweep::cli`]; planning, records, resuming,
//! Slurm, the results table and the executor are `gloam-sweep`; this file
//! is dispatch, the progress display and printing.

use anyhow::{Context, bail};
use gloam_sweep::SweepDir;
pub use gloam_sweep::cli::SweepArgs;
use gloam_sweep::cli::{RunArgs, StatusArgs, SweepCommand};
use gloam_sweep::exec::Pipeline as Exec;
use gloam_sweep::run::{Outcome, RunSummary, ensure_all_done};
use gloam_sweep::slurm;

use super::output::print_json;

pub fn run(args: SweepArgs) -> anyhow::Result<()> {
    match args.command {
        Some(SweepCommand::Run(r)) => run_tasks(r),
        Some(SweepCommand::Status(s)) => status(s),
        Some(SweepCommand::Collect(s)) => {
            let c = gloam_sweep::collect::collect(&SweepDir::open(&s.dir)?)?;
            if s.json {
                return print_json(&c);
            }
            let (n, done, failed, missing) = (c.rows, c.done, c.failed, c.missing);
            let csv = s.dir.join("results.csv");
            eprintln!(
                "collected {n} task(s): {done} done, {failed} failed, {missing} not done → {}",
                csv.display()
            );
            Ok(())
        }
        None => plan_and_run(args),
    }
}

fn plan_and_run(args: SweepArgs) -> anyhow::Result<()> {
    let (Some(file), Some(out)) = (&args.sweep, &args.out) else {
        bail!("usage: gloam sweep SWEEP.toml --out DIR");
    };
    let argv: Vec<String> = std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    let provenance = serde_json::to_value(gloam_pipeline::Provenance::of_this_run())?;
    let sd = SweepDir::create(file, out, &argv, provenance)?;
    let n = sd.sweep.tasks.len();
    if args.slurm {
        let dir = std::fs::canonicalize(out)?;
        let exe = std::env::current_exe().context("locating the gloam binary")?;
        let (opts, chunks) = (args.slurm_options(), sd.sweep.chunks.len());
        let script = slurm::write_script(&dir, &exe, chunks, &opts)?;
        if args.dry_run {
            let s = script.display();
            eprintln!("wrote {s} ({n} tasks in {chunks} array indices); submit with: sbatch {s}");
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
    gloam_sweep::collect::collect(&sd)?;
    eprintln!(
        "{n} task(s): {} ran, {} already done, {} failed → {}",
        summary.ran,
        summary.skipped,
        summary.failed.len(),
        sd.dir.join("results.csv").display()
    );
    Ok(ensure_all_done(&sd.status())?)
}

/// Runs `only` (a chunk) or every chunk, with a bar over tasks on a
/// terminal and a line per task otherwise.
fn run_with_progress(
    sd: &SweepDir,
    jobs: Option<usize>,
    only: Option<usize>,
) -> anyhow::Result<RunSummary> {
    let total = match only {
        Some(c) => sd.sweep.chunks.get(c).map_or(0, Vec::len),
        None => sd.sweep.tasks.len(),
    } as u64;
    let template = "{bar:40} {pos}/{len} tasks {elapsed}/{eta} {msg}";
    let bar = super::progress::bar(template, "█░", total);
    let say = |line: &str| match &bar {
        Some(b) => b.suspend(|| eprintln!("{line}")),
        None => eprintln!("{line}"),
    };
    let on_task = |o: &Outcome| {
        if let Some(why) = o.rerun_note() {
            say(&why);
        }
        let line = o.line(&sd.sweep.tasks[o.index]);
        if bar.is_none() || matches!(o.result, Some(Err(_))) {
            say(&line);
        }
        if let Some(b) = &bar {
            b.inc(1);
        }
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
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    Ok(s)
}

fn run_tasks(r: RunArgs) -> anyhow::Result<()> {
    let sd = SweepDir::open(&r.dir)?;
    if let Some(i) = r.task {
        let o = sd.run_task(&Exec, i)?;
        if let Some(why) = o.rerun_note() {
            eprintln!("{why}");
        }
        match o.result {
            Some(Err(e)) => bail!("task {i} failed: {e}"),
            Some(Ok(())) => eprintln!("task {i} done in {:.2} s", o.seconds),
            None => eprintln!("task {i} already done"),
        }
        return Ok(());
    }
    let s = run_with_progress(&sd, r.jobs, r.chunk)?;
    if !s.failed.is_empty() {
        let list: Vec<String> = (s.failed.iter())
            .map(|(i, e)| format!("  task {i}: {e}"))
            .collect();
        bail!("{} task(s) failed:\n{}", s.failed.len(), list.join("\n"));
    }
    Ok(())
}

fn status(s: StatusArgs) -> anyhow::Result<()> {
    let states = SweepDir::open(&s.dir)?.status();
    let sub = slurm::read_submission(&s.dir);
    let job = sub.as_ref().map(|j| slurm::job_states(&j.job_id));
    if s.json {
        return print_json(&serde_json::json!({"tasks": states, "slurm": job}));
    }
    outln!("{states}");
    if let Some(j) = job {
        outln!("{j}");
    }
    Ok(())
}
