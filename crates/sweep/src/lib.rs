#![doc = include_str!("../README.md")]

/// `eprintln!` that never panics (std's does when stderr is full or
/// closed): the message is lost, the run is not.
macro_rules! eprintln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

#[cfg(feature = "cli")]
pub mod cli;
pub mod collect;
#[cfg(feature = "cli")]
pub mod command;
pub mod exec;
pub mod figures;
pub mod preflight;
pub mod run;
pub mod slurm;
pub mod spec;
pub mod tile;

pub use run::{Executor, Figures, SweepDir, SweepError, TaskError};
pub use spec::{Flow, Sweep, Task};
pub use tile::TileSpec;
