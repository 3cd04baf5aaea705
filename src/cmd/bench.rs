//! `gloam bench accuracy|throughput|plan|scale`: the arguments are
//! [`gloam_bench::cli`], what runs and prints [`gloam_bench::command`],
//! whose docs say what each figure means.

pub use gloam_bench::cli::BenchCommand;
use gloam_bench::command::BenchCommandError;

pub fn run(c: BenchCommand, guard: &gloam_io::RunGuard) -> anyhow::Result<()> {
    let mut out = |text: &str| {
        use std::io::Write as _;
        write!(std::io::stdout(), "{text}")
    };
    match gloam_bench::command::run(c, &mut out, guard) {
        // A closed pipe ends the command quietly, as `out!` does.
        Err(BenchCommandError::Stdout(e)) => Err(crate::StdoutClosed(e).into()),
        r => Ok(r?),
    }
}
