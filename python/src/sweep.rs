//! Sweeps (`gloam sweep SWEEP.toml --out DIR`): plan, run locally with
//! progress, collect.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

use pyo3::prelude::*;

use gloam_sweep::SweepDir;
use gloam_sweep::exec::Pipeline;
use gloam_sweep::run::{Outcome, RunSummary};

use crate::convert::{Count, to_py_as};
use crate::interrupt::{ProgressSink, detached_with_stop};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    Ok(())
}

/// Plans and runs the sweep file ``path`` into the directory ``out`` on
/// this machine, as ``gloam sweep SWEEP.toml --out DIR`` (docs/sweep.md):
/// tasks already done are skipped (a rerun resumes), ``jobs`` tasks of a
/// chunk run at once (default: all cores), and ``results.csv``/``.json``
/// are collected at the end. ``progress`` (``True`` for a tqdm bar, or a
/// callable ``progress(done, total, "tasks")``) is told as each task
/// ends. Returns a ``SweepResult`` (a dict with attribute access): ``dir``,
/// ``tasks``, ``ran``, ``skipped``, ``failed`` (``[index, message]``) and
/// ``results`` (``results.json``: ``columns``, ``rows``). Ctrl-C stops it between
/// chunks of tasks; the tasks finished are kept and a rerun resumes.
#[pyfunction]
#[pyo3(signature = (path, out, jobs = None, progress = None))]
fn sweep<'py>(
    py: Python<'py>,
    path: PathBuf,
    out: PathBuf,
    jobs: Option<Count<usize>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let jobs = jobs.map(|j| j.0);
    let sink = ProgressSink::new(py, progress, "sweep")?;
    let argv = vec![
        "python".to_string(),
        "gloam.sweep".to_string(),
        path.display().to_string(),
        out.display().to_string(),
    ];
    let r = detached_with_stop(py, &sink, |stop, rep| {
        let provenance = serde_json::to_value(gloam_pipeline::Provenance::of_this_run(
            &gloam_io::ReadLog::off(),
        ))?;
        let sd = SweepDir::create(&path, &out, &argv, provenance)?;
        let total = sd.sweep.tasks.len() as u64;
        let done = AtomicU64::new(0);
        rep.set("tasks", 0, total);
        let on_task = |_: &Outcome| {
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            rep.set("tasks", d, total);
        };
        let mut summary = RunSummary::default();
        for c in 0..sd.sweep.chunks.len() {
            if stop.load(Ordering::Relaxed) {
                anyhow::bail!("interrupted");
            }
            for o in sd.run_chunk(&Pipeline, c, jobs, &on_task)? {
                summary.add(o);
            }
        }
        gloam_sweep::collect::collect(&sd)?;
        let results_path = sd.dir.join("results.json");
        let results: serde_json::Value = serde_json::from_str(&gloam_io::read_text(
            &results_path,
            gloam_io::MAX_TEXT_FILE_BYTES,
            &gloam_io::ReadLog::off(),
        )?)?;
        Ok(serde_json::json!({
            "dir": sd.dir.display().to_string(),
            "tasks": total,
            "ran": summary.ran,
            "skipped": summary.skipped,
            "failed": summary.failed,
            "results": results,
        }))
    })?;
    to_py_as(py, &r, "SweepResult")
}
