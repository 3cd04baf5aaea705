//! gloam-sweep: a validation campaign as a grid of independent,
//! deterministic tasks, run on one machine or as a Slurm array job.
//!
//! - [`spec`]: the sweep file (`[base]`, `[axes]`) and its task list, each
//!   task with a stable id, a seed derived from it, and the key of the
//!   render it shares with other tasks;
//! - [`run`]: the sweep directory, task records with output hashes
//!   (resumable), and running tasks through an [`run::Executor`];
//! - [`exec`]: the executor over gloam's render and camera code
//!   ([`exec::Pipeline`]), writing frames with the pipeline's
//!   `frames.jsonl` record;
//! - [`slurm`]: the array-job script, `sbatch`, `sacct`/`squeue`;
//! - [`collect`]: `results.csv`/`.json` and plots;
//! - [`tile`]: tiled renders (horizontal bands) and their merge;
//! - [`figures`]: a frame stack's mean DN, temporal noise and SNR.
//!
//! The format and commands are documented in `docs/sweep.md`.

pub mod collect;
pub mod exec;
pub mod figures;
pub mod run;
pub mod slurm;
pub mod spec;
pub mod tile;

pub use run::{Executor, Figures, SweepDir};
pub use spec::{Flow, Sweep, Task};
pub use tile::TileSpec;
