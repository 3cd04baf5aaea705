#![doc = include_str!("../README.md")]

#[cfg(feature = "cli")]
pub mod cli;
pub mod collect;
pub mod exec;
pub mod figures;
pub mod run;
pub mod slurm;
pub mod spec;
pub mod tile;

pub use run::{Executor, Figures, SweepDir, SweepError, TaskError};
pub use spec::{Flow, Sweep, Task};
pub use tile::TileSpec;
