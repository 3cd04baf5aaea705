//! `gloam`: the command line. Thin by design — argument parsing, progress and
//! output files live here; all behaviour lives in the `crates/` libraries.

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use gloam_io::RunGuard;

/// `println!` that returns an error instead of panicking when stdout is
/// closed (`gloam plan … | head -1`); `main` ends such a run quietly.
macro_rules! outln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($t)*).map_err($crate::StdoutClosed)?;
    }};
}

/// `print!` counterpart of [`outln!`].
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout(), $($t)*).map_err($crate::StdoutClosed)?;
    }};
}

/// `eprintln!` that never panics (std's does when stderr is full or
/// closed: `2>/dev/full` ended every run with a panic): the message is
/// lost, the run and its exit status are not. Defined before `mod cmd` so
/// every command's messages go through them.
macro_rules! eprintln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

mod cmd;

/// mimalloc: a tracer's vertices allocate small spectral buffers by the
/// million; glibc's malloc/free were 9 % of a direct-light render's CPU time.
#[global_allocator]
static ALLOC: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// mimalloc's `mi_option_purge_delay` (its place in `mi_option_e` in
/// `mimalloc.h`, v2 and v3 alike; the Rust binding lists the options
/// around it but not it). A test checks it reads v3's default, 1 000 ms.
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// Freed pages stay with the process instead of going back to the OS
/// a second later: an adaptive render frees and re-touches the same few
/// megabytes every round, and each re-touch was a page fault that the
/// kernel zero-filled (office, direct light to 1 %: 69 000 faults and
/// 3.0–3.2 s of CPU, 430 faults and 2.5–2.6 s without purging). The
/// process keeps its peak — a command, not a daemon's steady state.
fn keep_freed_pages() {
    // SAFETY: sets an option of the allocator this binary links; mimalloc
    // reads the option at each purge decision, so any time is valid.
    unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1) }
}

/// No transparent huge pages for this process: each first touch of a
/// 2 MiB page had the kernel zero all of it, and an adaptive render
/// touches the allocator's pages sparsely (office, direct light to 1 %,
/// one thread: 2.07–2.11 s of CPU, 0.36–0.40 s of it the kernel's
/// clearing of huge pages; 1.78–1.89 s with 4 KiB pages). The kernel
/// checks the flag at each fault, so it holds for every page touched
/// from here on. Where the call is refused (an old kernel) nothing
/// changes but the speed.
fn no_huge_pages() {
    #[cfg(target_os = "linux")]
    // SAFETY: prctl with integer arguments only; it sets a flag of this
    // process and touches no memory of ours.
    unsafe {
        libc::prctl(libc::PR_SET_THP_DISABLE, 1, 0, 0, 0);
    }
}

/// A failed write to stdout. A closed pipe ends the command quietly with
/// success, as `head` expects of the writer it cut off (ripgrep does the
/// same); other write errors are reported.
#[derive(Debug)]
struct StdoutClosed(std::io::Error);

impl std::fmt::Display for StdoutClosed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "writing to stdout: {}", self.0)
    }
}

impl std::error::Error for StdoutClosed {}

/// Low-light-level imaging: spectral ray tracer, intensified camera chain,
/// frame grabbers and calibration.
#[derive(Parser)]
#[command(
    name = "gloam",
    version = gloam_pipeline::provenance::VERSION_WITH_COMMIT,
    about,
    propagate_version = true
)]
struct Cli {
    /// Log detail for diagnostics (also settable with RUST_LOG).
    #[arg(long, global = true, default_value = "warn")]
    log: String,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print the effect plan of a scene: which effects are simulated and why.
    Plan(cmd::plan::PlanArgs),
    /// The built-in spectral library and band integrals.
    #[command(subcommand)]
    Spectra(cmd::spectra::SpectraCommand),
    /// Moon and Sun positions and lunar phase; good collection nights (--find).
    Ephem(cmd::ephem::EphemArgs),
    /// Ground illuminance from the Moon and the night sky (lux, spectra).
    Sky(cmd::sky::SkyArgs),
    /// Render band radiance images of a scene (TIFF, NPY, PNG preview, report).
    Render(cmd::render::RenderArgs),
    /// A night that changes (a sequence file: light groups switching, ramps, flicker) through a camera and its AGC.
    Sequence(cmd::sequence::SequenceArgs),
    /// Irradiance at a point, or one pixel's radiance, without a full render.
    Probe(cmd::probe::ProbeArgs),
    /// Serve the simulated camera as a device: emulated on a pseudo-terminal (--pty) or as a GigE Vision camera (--gige).
    Device(cmd::device::DeviceArgs),
    /// Capture frames from a grabber (sim:, serial:, usb:, genicam: GigE Vision / USB3 Vision) into PNG, FITS or TIFF frames and frames.jsonl.
    Capture(cmd::capture::CaptureArgs),
    /// List serial ports, USB devices and simulated cameras.
    Grabbers(cmd::grabbers::GrabbersArgs),
    /// Calibration flows over any grabber: radiance LUT, apply, AGC, photon transfer, MTF.
    #[command(subcommand)]
    Calibrate(cmd::calibrate::CalibrateCommand),
    /// Compare two images over ground-control regions (Spearman rho, RMS).
    Compare(cmd::compare::CompareArgs),
    /// Benchmarks: accuracy against time (`accuracy`), throughput figures.
    #[command(subcommand)]
    Bench(cmd::bench::BenchCommand),
    /// Sensor presets and their derived figures (DN per photoelectron, noise, saturation).
    #[command(subcommand)]
    Sensor(cmd::sensor::SensorCommand),
    /// Campaign sweeps: a grid of tasks run locally or as a Slurm array job.
    Sweep(cmd::sweep::SweepArgs),
    /// Reassemble `render --tile K/N` outputs into the whole image.
    Merge(cmd::merge::MergeArgs),
    /// Scan lines of a simulated camera's video as an oscilloscope shows them.
    Scope(cmd::scope::ScopeArgs),
    // New subcommands: add a variant here and its arm in `run` below; the
    // implementation lives in `src/cmd/<name>.rs`.
}

fn run(cli: Cli, guard: &RunGuard) -> anyhow::Result<()> {
    match cli.command {
        Command::Plan(args) => cmd::plan::run(args),
        Command::Sensor(c) => cmd::sensor::run(c),
        Command::Calibrate(c) => cmd::calibrate::run(c, guard),
        Command::Compare(args) => cmd::compare::run(args),
        Command::Device(args) => cmd::device::run(args),
        Command::Capture(args) => cmd::capture::run(args, guard),
        Command::Grabbers(args) => cmd::grabbers::run(args),
        Command::Spectra(c) => cmd::spectra::run(c),
        Command::Ephem(args) => cmd::ephem::run(args),
        Command::Sky(args) => cmd::sky::run(args),
        Command::Render(args) => cmd::render::run(args, guard),
        Command::Sequence(args) => cmd::sequence::run(args, guard),
        Command::Probe(args) => cmd::probe::run(args),
        Command::Bench(c) => cmd::bench::run(c, guard),
        Command::Sweep(args) => cmd::sweep::run(args),
        Command::Merge(args) => cmd::merge::run(args, guard),
        Command::Scope(args) => cmd::scope::run(args, guard),
    }
}

/// The stack the command runs on: its own thread's, so a small main-thread
/// stack (`ulimit -s 64` aborted every command, even `--help`) does not
/// decide it. Reserved, not committed: pages are touched as used.
const MAIN_STACK_BYTES: usize = 64 << 20;

fn main() -> ExitCode {
    keep_freed_pages();
    no_huge_pages();
    gloam_pipeline::cli::process::file_size_limit_is_an_error();
    let spawned = std::thread::Builder::new()
        .name("gloam".into())
        .stack_size(MAIN_STACK_BYTES)
        .spawn(gloam_main);
    match spawned {
        // A panic has printed its message; 101 as Rust's own.
        Ok(h) => h.join().unwrap_or(ExitCode::from(101)),
        Err(e) => {
            eprintln!("error: starting the main thread ({MAIN_STACK_BYTES} bytes of stack): {e}");
            ExitCode::FAILURE
        }
    }
}

fn gloam_main() -> ExitCode {
    use clap::{CommandFactory, FromArgMatches};
    use gloam_pipeline::cli::process::{negative_numbers_are_values, parse_command_line};
    if let Err(e) = gloam_pipeline::cli::process::start_workers() {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    let command = negative_numbers_are_values(cmd::capture::with_out_help(Cli::command()));
    let matches = match parse_command_line(command) {
        Ok(m) => m,
        Err(exit) => return exit,
    };
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    gloam_pipeline::cli::process::init_logging(&cli.log);
    let guard = gloam_pipeline::cli::process::guard_this_run(&matches);
    match run(cli, &guard) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e)
            if e.chain().any(|c| {
                c.downcast_ref::<StdoutClosed>()
                    .is_some_and(|s| s.0.kind() == std::io::ErrorKind::BrokenPipe)
            }) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            // Plain `error: cause: cause…` on stderr, never a backtrace.
            eprintln!(
                "error: {}",
                gloam_pipeline::cli::process::short_numbers(&format!("{e:#}"))
            );
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    /// The option number is mimalloc's purge delay: unset, it reads the
    /// default mimalloc v3 (what libmimalloc-sys builds) gives it in
    /// `options.c`, 1 000 ms, which neither neighbour has (eager commit
    /// delay 1, NUMA nodes 0).
    #[test]
    fn the_purge_delay_option_is_mimallocs() {
        if std::env::var_os("MIMALLOC_PURGE_DELAY").is_some() {
            return;
        }
        // SAFETY: reads an option of the linked allocator.
        let get = |o| unsafe { libmimalloc_sys::mi_option_get(o) };
        assert_eq!(get(super::MI_OPTION_PURGE_DELAY), 1000);
        assert_eq!(get(super::MI_OPTION_PURGE_DELAY - 1), 1);
        assert_eq!(get(super::MI_OPTION_PURGE_DELAY + 1), 0);
    }
}
