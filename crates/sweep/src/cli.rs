//! The command line's arguments for sweeps and tile merges (feature
//! `cli`), next to the code they drive; the binary dispatches and prints.

use std::path::PathBuf;

use clap::{Args, Subcommand};

use crate::slurm::SlurmOptions;

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
    /// Tasks run at once within a chunk (default: all cores; 1 to 1 024).
    #[arg(long, value_parser = jobs_in_range)]
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
    #[arg(long, value_parser = jobs_in_range)]
    pub jobs: Option<usize>,
}

/// `--jobs`: 1 to 1 024 tasks at once (0 ran nothing and said nothing).
fn jobs_in_range(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if (1..=1024).contains(&n) => Ok(n),
        Ok(n) => Err(format!("{n} is not in 1..=1024")),
        Err(e) => Err(format!("{e} (give a whole number in 1..=1024)")),
    }
}

#[derive(Args)]
pub struct StatusArgs {
    pub dir: PathBuf,
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct MergeArgs {
    /// Tile directories written by `gloam render --tile K/N` (any order,
    /// every tile of one render exactly once).
    #[arg(required = true)]
    pub tiles: Vec<PathBuf>,
    /// Output directory, published whole (refused when not empty, unless --force).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace a previous gloam output set at `--out` whole (only a set whose
    /// manifest.json lists every file there; never inputs, links or other files).
    #[arg(long)]
    pub force: bool,
}

impl SweepArgs {
    /// The `--slurm` options.
    pub fn slurm_options(&self) -> SlurmOptions {
        SlurmOptions {
            partition: self.partition.clone(),
            time: self.time.clone(),
            cpus_per_task: self.cpus_per_task,
            max_parallel: self.max_parallel,
            jobs: self.jobs,
        }
    }
}
