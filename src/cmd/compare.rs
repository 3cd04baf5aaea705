//! `gloam compare TRUTH SYNTHETIC --regions REGIONS [--json]`: Spearman rank
//! correlation and RMS difference of region means between two images.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;

use gloam_calib::io::read_grey;
use gloam_calib::validate::{compare_images, load_regions};

#[derive(Args)]
pub struct CompareArgs {
    /// Reference image (e.g. a calibrated radiance TIFF).
    pub truth: PathBuf,
    /// Image to validate (e.g. a gloam render), same size.
    pub synthetic: PathBuf,
    /// Ground-control regions: JSON array of {name,x,y,width,height} or TOML [[region]].
    #[arg(long)]
    pub regions: PathBuf,
    /// Print the figures as JSON ({"spearman_rho", "rms", "regions"}).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: CompareArgs) -> anyhow::Result<()> {
    // The small input first: a bad regions file is named before any image
    // is decoded.
    let regions = load_regions(&args.regions)?;
    let t = read_grey(&args.truth).context("reading the truth image")?;
    let s = read_grey(&args.synthetic).context("reading the synthetic image")?;
    if (t.width, t.height) != (s.width, s.height) {
        bail!(
            "the images differ in size: {}×{} vs {}×{}",
            t.width,
            t.height,
            s.width,
            s.height
        );
    }
    let c = compare_images(&t.data, &s.data, t.width, t.height, &regions)?;
    if args.json {
        super::output::print_json(&c)?;
    } else {
        outln!("{:<24} {:>14} {:>14}", "region", "truth", "synthetic");
        for r in &c.regions {
            outln!("{:<24} {:>14.6e} {:>14.6e}", r.name, r.truth, r.synthetic);
        }
        outln!("Spearman rho = {:.6}", c.spearman_rho);
        outln!("RMS difference = {:.6e}", c.rms);
    }
    Ok(())
}
