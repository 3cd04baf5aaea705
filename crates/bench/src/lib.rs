#![doc = include_str!("../README.md")]
//!
//! `gloam bench accuracy SCENE --out DIR …` and `gloam bench throughput`:
//! what accuracy costs in time, and every performance figure the README
//! quotes.
//!
//! **accuracy** sweeps the settings that trade accuracy for time and, for
//! each run, records wall time and the error against the truth:
//!
//! - *closed form* when the scene has one: no point sources, no sky, area
//!   sources with integer shape exponents, no specular or transmissive
//!   material, and all non-emitting facets in one plane (nothing can occlude
//!   an emitter from them: `sims/panel-validation`). The truth of a pixel is
//!   `(1/π) Σ_s F_s(p) ∫ R_b ρ L_s dλ`, with `F_s` Lambert's/Arvo's factor
//!   (`gloam_trace::closed_form`) averaged over an 8 × 8 grid of sub-pixel
//!   primary hits, and the band integral exact (lines included).
//! - otherwise a *reference* render (analytic, high spp, 1 nm grid, as two
//!   independent halves), cached in `DIR/reference.npy` with its key (scene
//!   hash + settings) in `DIR/reference.json`. The halves give the
//!   reference's own noise, which is subtracted from each run's mean squared
//!   error, so the error reported is that of the run alone.
//!
//! Only pixels whose primary hits (4 × 4 sub-pixel rays) all land on
//! non-emitting facets count: the floor/room irradiance map, not the
//! directly viewed lamps (exact by construction). Errors:
//! `rel_rms_error = sqrt(Σ(x − t)² / Σ t²)` over those pixels and all bands,
//! `max_rel_error = max |x − t| / t` over pixels with `t` above 1 % of the
//! band's mean.
//!
//! The reference, like the default, has `diffuse_bounces = 0`: on the
//! office room the `diffuse_bounces` rows therefore measure the
//! inter-reflected light the default leaves out, not an error. The
//! `spectral_step_nm` rows use a clear-mercury copy of a scene whose own
//! sources have no emission lines (the panel), where the truth stays exact.
//!
//! **plan** renders each sim with the effect plan and with `all_effects`
//! (every estimator path forced on), and checks that the two images differ
//! by less than 1.5 × the seed-to-seed difference of the planned render.

//!
//! The command line (`src/cmd/bench.rs`) parses arguments and prints; the
//! measuring happens here.

/// `eprintln!` that never panics (std's does when stderr is full or
/// closed): the message is lost, the run is not.
macro_rules! eprintln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

/// `ensure_valid!(cond, "fmt", …)`: returns [`BenchError::Invalid`] with
/// the message when `cond` does not hold (the benchmarks' argument and
/// self-consistency checks).
macro_rules! ensure_valid {
    ($cond:expr, $($fmt:tt)+) => {
        if !$cond {
            return Err($crate::BenchError::Invalid(format!($($fmt)+)));
        }
    };
}

pub mod accuracy;
pub mod accuracy_mitsuba;
pub mod child;
#[cfg(feature = "cli")]
pub mod cli;
#[cfg(feature = "cli")]
pub mod command;
pub mod metrics;
pub mod plan_check;
pub mod resolution;
pub mod scale;
pub mod scale_instances;
pub mod throughput;
pub mod truth;

use std::path::{Path, PathBuf};

/// A path as given when it exists; otherwise the same relative path under
/// the nearest ancestor of the working directory that has it (so `gloam
/// bench` finds `sims/…` from anywhere inside a checkout, and an installed
/// binary run from a checkout finds them too).
pub fn find_path(p: &Path) -> PathBuf {
    if p.exists() || p.is_absolute() {
        return p.to_path_buf();
    }
    if let Ok(cwd) = std::env::current_dir() {
        for dir in cwd.ancestors().skip(1) {
            let alt = dir.join(p);
            if alt.exists() {
                return alt;
            }
        }
    }
    p.to_path_buf()
}

/// Why a benchmark could not run, or failed its own check, naming the
/// directory, setting or check at fault.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error("listing {}", path.display())]
    List {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Scene(#[from] gloam_scene::SceneError),
    #[error(transparent)]
    Trace(#[from] gloam_trace::TraceError),
    #[error(transparent)]
    Setting(#[from] gloam_trace::SettingsError),
    #[error("gloam-trace has no setting to force every effect on ({0})")]
    NoForcingSetting(#[source] gloam_trace::SettingsError),
    #[error(transparent)]
    Sensor(#[from] gloam_sensor::ConfigError),
    #[error(transparent)]
    Capture(#[from] gloam_sensor::CaptureError),
    #[error("starting the benchmark's thread pool")]
    ThreadPool(#[from] rayon::ThreadPoolBuildError),
    #[error("encoding a chunk: {0}")]
    Encode(String),
    /// `--out`'s output set refused or not published.
    #[error(transparent)]
    OutputSet(#[from] gloam_io::output_set::OutputSetError),
    /// A check the benchmark makes of its own results failed.
    #[error("{0}")]
    Check(&'static str),
    /// A file or directory the benchmark reads or writes.
    #[error("{action} {}", path.display())]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A flag, size or scene the benchmark cannot use; the message names
    /// the flag or the scene and the allowed range.
    #[error("{0}")]
    Invalid(String),
    /// A child process (a case's `gloam`, Mitsuba 3's `python3`) failed.
    #[error("{what}: {why}")]
    Child { what: String, why: String },
    /// A plot could not be drawn or written.
    #[error("drawing {}: {why}", path.display())]
    Plot { path: PathBuf, why: String },
    #[error("encoding or decoding a report as JSON")]
    Json(#[from] serde_json::Error),
    #[error(transparent)]
    Output(#[from] gloam_pipeline::output::OutputError),
}

impl BenchError {
    /// An I/O error's mapper naming the action and the path.
    pub(crate) fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        move |source| BenchError::Io {
            action,
            path,
            source,
        }
    }
}

/// Every `sims/*/scene.toml`, sorted.
pub fn default_scenes() -> Result<Vec<PathBuf>, BenchError> {
    let dir = find_path(Path::new("sims"));
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|source| BenchError::List {
            path: dir.clone(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path().join("scene.toml")))
        .filter(|p| p.exists())
        .collect();
    v.sort();
    Ok(v)
}

/// A benchmark's report lists no reads (only `bench accuracy`'s manifest
/// does, from its own log): what the others read goes unlogged.
pub(crate) fn unlisted() -> gloam_io::ReadLog {
    gloam_io::ReadLog::off()
}
