//! `gloam bench`'s arguments and the options they give (the measuring is
//! [`crate`]).

use std::path::{Path, PathBuf};

use clap::{Args, Subcommand};

use crate::{BenchError, accuracy, find_path, resolution, scale};

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Error against the truth and wall time across the accuracy settings.
    Accuracy(AccuracyArgs),
    /// Rays/s, sensor-chain frames/s and protocol codec GB/s.
    Throughput(ThroughputArgs),
    /// Time the effect plan saves: each sim rendered with the plan and with
    /// every effect forced on (`all_effects`), images checked to agree.
    Plan(PlanBenchArgs),
    /// Preparation time, peak memory, rays/s and time to a 1 % image
    /// against the number of triangles (10³ … 10⁶) and of lamps (1 … 10⁴),
    /// on scenes generated in Rust, each case in its own process.
    Scale(ScaleArgs),
}

#[derive(Args)]
pub struct ScaleArgs {
    /// Output directory: scale.json and scale.png (required unless --case).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Triangle counts, comma-separated (e.g. 1e3,1e4,1e5,1e6; default
    /// those, --quick: 1e3).
    #[arg(long)]
    pub triangles: Option<String>,
    /// Lamp counts, comma-separated (e.g. 1,10,100,1e3,1e4; default those,
    /// --quick: 1,10,100).
    #[arg(long)]
    pub lamps: Option<String>,
    /// Placements of a 49 728-triangle model, shared (two-level BVH),
    /// comma-separated (default 10,1e3,2012 — 10⁸ placed triangles;
    /// --quick: none).
    #[arg(long)]
    pub instances: Option<String>,
    /// Small sizes, a small image, a 60 s timeout: a smoke run of seconds.
    #[arg(long)]
    pub quick: bool,
    /// Image width per case, pixels (default 160, --quick 64).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height per case, pixels (default 120, --quick 48).
    #[arg(long)]
    pub height: Option<u32>,
    /// Camera samples per pixel (default 4, --quick 2).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Wall-time limit per case, seconds (default 900, --quick 60); a case
    /// that outlives it is killed and recorded as `timeout`.
    #[arg(long)]
    pub timeout_s: Option<f64>,
    /// Do not run the Mitsuba 3 comparison even when `import mitsuba` works.
    #[arg(long)]
    pub no_mitsuba: bool,
    /// Worker threads per case (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Render settings for every case, KEY=VALUE (repeatable; e.g.
    /// `--set light_tree_split=fixed` to compare the light tree's rules).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Run one case in this process and print its figures as JSON (what
    /// the bench runs in each child process): `triangles:N`, `lamps:N` or
    /// `instances:N`.
    #[arg(long, hide = true)]
    pub case: Option<String>,
    /// Where the child writes its generated scene.
    #[arg(long, hide = true, requires = "case")]
    pub case_dir: Option<PathBuf>,
}

#[derive(Args)]
pub struct PlanBenchArgs {
    /// Scene files (default: every `sims/*/scene.toml`).
    pub scenes: Vec<PathBuf>,
    /// Camera samples per pixel (default 1: the plan's saving per sample;
    /// 1 to 65 536, the renderer's own limit).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=gloam_trace::settings::MAX_SPP as i64))]
    pub spp: u32,
    /// Camera samples per pixel of the renders that measure each effect's
    /// share (a sub-pixel pool's share is noise at 1 spp).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=gloam_trace::settings::MAX_SPP as i64))]
    pub share_spp: u32,
    /// Multiplies each scene camera's width and height (the field of view
    /// is kept): a quicker check on a shared machine (above 0, at most 4).
    #[arg(long, default_value_t = 1.0, value_parser = resolution_scale_in_range)]
    pub resolution_scale: f64,
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
    /// cached references, manifest.json — one output set, published whole.
    #[arg(long)]
    pub out: PathBuf,
    /// Replace a previous gloam output set at `--out` whole (only a set whose
    /// manifest.json lists every file there; never inputs, links or other
    /// files). Its cached references are carried over and reused.
    #[arg(long)]
    pub force: bool,
    /// Wall-time budget, seconds: the optional rows stop when it is spent.
    /// The reference (at least 256 spp), each estimator's first rung and
    /// Mitsuba 3 (up to the larger of half the budget and 60 s) run
    /// whatever it is; summary.md and `over_budget_s` say by how much a run
    /// went past it. At most 1e6 s.
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
    /// Skip the side-by-side with Mitsuba 3 (run whenever `python3` can
    /// import `mitsuba`).
    #[arg(long)]
    pub no_mitsuba: bool,
    /// The resolution axis: for each `resolution_scale` of this
    /// comma-separated list (each > 0 and ≤ 4, e.g. 0.125,0.25,0.5,1), the
    /// default render (`--target-error 0.02`) against a truth at the same
    /// scale: its mean bias over the pixels that see no emitter and over
    /// all pixels with a surface, per sixth of the image, and the time.
    #[arg(long, value_name = "LIST")]
    pub resolution_scales: Option<String>,
    /// With --resolution-scales: run only the resolution axis (skip the
    /// rest of the sweep).
    #[arg(long, requires = "resolution_scales")]
    pub resolution_only: bool,
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

impl AccuracyArgs {
    /// The sweep's options; a bad `--resolution-scales` list is an error
    /// naming the flag and the value.
    pub fn options(self) -> Result<accuracy::AccuracyOptions, BenchError> {
        let resolution_scales = match &self.resolution_scales {
            Some(list) => Some(resolution::parse_scales(list)?),
            None => None,
        };
        Ok(accuracy::AccuracyOptions {
            scene: find_path(&self.scene),
            out: self.out,
            budget_s: self.budget_s,
            all_effects: self.all_effects,
            threads: self.threads,
            mitsuba: !self.no_mitsuba,
            resolution_scales,
            resolution_only: self.resolution_only,
            force: self.force,
        })
    }
}

impl ThroughputArgs {
    /// The scene for the ray figures, found from the working directory.
    pub fn scene(&self) -> PathBuf {
        let default = Path::new("sims/office-room/scene.toml");
        find_path(self.scene.as_deref().unwrap_or(default))
    }
}

impl PlanBenchArgs {
    /// The scenes given, or every `sims/*/scene.toml`.
    pub fn scenes(&self) -> Result<Vec<PathBuf>, crate::BenchError> {
        if self.scenes.is_empty() {
            crate::default_scenes()
        } else {
            Ok(self.scenes.iter().map(|p| find_path(p)).collect())
        }
    }
}

impl ScaleArgs {
    /// `--case`'s child run: the case and its scratch directory.
    pub fn case(&self) -> Result<Option<(scale::Case, &Path)>, BenchError> {
        let Some(case) = &self.case else {
            return Ok(None);
        };
        let dir = (self.case_dir.as_deref()).ok_or_else(|| {
            BenchError::Invalid(
                "--case needs --case-dir (the scratch directory for the scene)".into(),
            )
        })?;
        Ok(Some((scale::Case::parse(case)?, dir)))
    }

    /// The whole bench's options, each case run by `exe`.
    pub fn options(&self, exe: PathBuf) -> Result<scale::ScaleOptions, BenchError> {
        let out = (self.out.clone()).ok_or_else(|| {
            BenchError::Invalid(
                "gloam bench scale: --out DIR is required (where scale.json and scale.png go)"
                    .into(),
            )
        })?;
        let mut opts = scale::ScaleOptions::new(self.quick, out, exe);
        if let Some(t) = &self.triangles {
            opts.triangles = scale::parse_counts(t, "triangles", scale::MAX_TRIANGLES)?;
        }
        if let Some(l) = &self.lamps {
            opts.lamps = scale::parse_counts(l, "lamps", scale::MAX_LAMPS)?;
        }
        if let Some(n) = &self.instances {
            opts.instances = scale::parse_counts(n, "instances", scale::MAX_PLACEMENTS)?;
        }
        opts.width = self.width.unwrap_or(opts.width);
        opts.height = self.height.unwrap_or(opts.height);
        opts.spp = self.spp.unwrap_or(opts.spp);
        opts.timeout_s = self.timeout_s.unwrap_or(opts.timeout_s);
        opts.threads = self.threads;
        opts.no_mitsuba |= self.no_mitsuba;
        // Checked here, so a bad key fails before any case runs.
        let mut check = gloam_trace::RenderSettings::default();
        for pair in &self.set {
            check.set_pair(pair)?;
        }
        opts.set = self.set.clone();
        Ok(opts)
    }
}

/// `bench plan --resolution-scale`: finite, above 0, at most 4 (0 ended
/// in a misleading share mismatch).
fn resolution_scale_in_range(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 && x <= 4.0 => Ok(x),
        Ok(x) => Err(format!("{} is not in (0, 4]", gloam_spectra::num(x))),
        Err(e) => Err(format!("{e} (give a number in (0, 4])")),
    }
}
