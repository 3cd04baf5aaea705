//! `gloam bench accuracy SCENE --out DIR …`, `gloam bench throughput` and
//! `gloam bench plan`: arguments and printing. The measuring — truths,
//! masks, metrics, the reference cache, the Pareto front — is
//! [`gloam_pipeline::bench`], whose docs say what each figure means.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::{Args, Subcommand};
use gloam_pipeline::bench::{self, accuracy, find_path, plan_check, throughput};

use super::output::print_json;

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Error against the truth and wall time across the accuracy settings.
    Accuracy(AccuracyArgs),
    /// Rays/s, sensor-chain frames/s and protocol codec GB/s.
    Throughput(ThroughputArgs),
    /// Time the effect plan saves: each sim rendered with the plan and with
    /// every effect forced on (`all_effects`), images checked to agree.
    Plan(PlanBenchArgs),
}

#[derive(Args)]
pub struct PlanBenchArgs {
    /// Scene files (default: every `sims/*/scene.toml`).
    pub scenes: Vec<PathBuf>,
    /// Camera samples per pixel (default 1: the plan's saving per sample).
    #[arg(long, default_value_t = 1)]
    pub spp: u32,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct AccuracyArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Output directory: accuracy.csv, accuracy.png, summary.md, the
    /// cached reference.
    #[arg(long)]
    pub out: PathBuf,
    /// Total wall-time budget, seconds (the sweep stops cleanly when spent).
    #[arg(long, default_value_t = 120.0)]
    pub budget_s: f64,
    /// Also render with every effect forced on and report the time the
    /// effect plan saves (the tracer's `all_effects` setting).
    #[arg(long)]
    pub all_effects: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print the summary as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct ThroughputArgs {
    /// Scene for the ray figures (default: the office room).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Fewer frames and shorter timings (for tests).
    #[arg(long)]
    pub quick: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(c: BenchCommand) -> anyhow::Result<()> {
    match c {
        BenchCommand::Accuracy(a) => {
            let report = accuracy::run(&accuracy::AccuracyOptions {
                scene: find_path(&a.scene),
                out: a.out,
                budget_s: a.budget_s,
                all_effects: a.all_effects,
                threads: a.threads,
            })?;
            if a.json {
                print_json(&report.summary)
            } else {
                out!("{}", report.markdown);
                Ok(())
            }
        }
        BenchCommand::Throughput(a) => {
            let scene = find_path(
                a.scene
                    .as_deref()
                    .unwrap_or(Path::new("sims/office-room/scene.toml")),
            );
            let t = throughput::run(&scene, a.quick, a.threads)?;
            if a.json {
                print_json(&t)
            } else {
                out!("{}", t.text());
                Ok(())
            }
        }
        BenchCommand::Plan(a) => {
            let scenes: Vec<PathBuf> = if a.scenes.is_empty() {
                bench::default_scenes()?
            } else {
                a.scenes.iter().map(|p| find_path(p)).collect()
            };
            let check = plan_check::run(&scenes, a.spp, a.threads)?;
            if a.json {
                print_json(&check.json())?;
            } else {
                out!("{}", check.markdown());
            }
            check.verdict().context("gloam bench plan")
        }
    }
}
