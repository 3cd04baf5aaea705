//! `gloam bench …` past its arguments (feature `cli`): which benchmark
//! runs, and what it prints on stdout — its JSON or its text; the binary
//! only writes it out.

use crate::cli::BenchCommand;
use crate::{BenchError, accuracy, plan_check, scale, throughput};

/// Why a benchmark command failed.
#[derive(Debug, thiserror::Error)]
pub enum BenchCommandError {
    #[error(transparent)]
    Bench(#[from] BenchError),
    #[error("finding the gloam binary to run each case")]
    Exe(#[source] std::io::Error),
    /// The plan check's own verdict (printed with its figures first).
    #[error("gloam bench plan")]
    Verdict(#[source] BenchError),
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// Writing to stdout failed (a closed pipe ends the command quietly).
    #[error("writing to stdout: {0}")]
    Stdout(#[source] std::io::Error),
}

/// Runs the benchmark `c` asks for; `out` writes text to stdout as given
/// (a JSON document ends with a newline). `guard` removes an output set
/// and kills child processes if the run is interrupted.
pub fn run(
    c: BenchCommand,
    out: &mut dyn FnMut(&str) -> std::io::Result<()>,
    guard: &gloam_io::RunGuard,
) -> Result<(), BenchCommandError> {
    let mut json = |v: &dyn erased::Json| -> Result<(), BenchCommandError> {
        let text = v.pretty()?;
        out(&format!("{text}\n")).map_err(BenchCommandError::Stdout)
    };
    let text = match c {
        BenchCommand::Accuracy(a) => {
            let as_json = a.json;
            let report = accuracy::run(&a.options()?, guard)?;
            if as_json {
                return json(&report.summary);
            }
            report.markdown
        }
        BenchCommand::Throughput(a) => {
            let t = throughput::run(&a.scene(), a.quick, a.threads)?;
            if a.json {
                return json(&t);
            }
            t.text()
        }
        BenchCommand::Scale(a) => {
            if let Some((case, dir)) = a.case()? {
                let (w, h) = (a.width.unwrap_or(160), a.height.unwrap_or(120));
                let spp = a.spp.unwrap_or(4);
                return json(&scale::run_case(case, dir, w, h, spp, a.threads, &a.set)?);
            }
            let exe = std::env::current_exe().map_err(BenchCommandError::Exe)?;
            let report = scale::run(&a.options(exe)?, guard)?;
            if a.json {
                return json(&report);
            }
            report.text()
        }
        BenchCommand::Plan(a) => {
            let scenes = a.scenes()?;
            let check =
                plan_check::run(&scenes, a.spp, a.share_spp, a.resolution_scale, a.threads)?;
            if a.json {
                json(&check.json())?;
            } else {
                out(&check.markdown()).map_err(BenchCommandError::Stdout)?;
            }
            return check.verdict().map_err(BenchCommandError::Verdict);
        }
    };
    out(&text).map_err(BenchCommandError::Stdout)
}

/// A serialisable value behind `dyn` (serde's `Serialize` is not object safe).
mod erased {
    pub trait Json {
        fn pretty(&self) -> Result<String, serde_json::Error>;
    }

    impl<T: serde::Serialize> Json for T {
        fn pretty(&self) -> Result<String, serde_json::Error> {
            serde_json::to_string_pretty(self)
        }
    }
}
