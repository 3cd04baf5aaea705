//! `gloam compare TRUTH SYNTHETIC --regions REGIONS [--json]`: Spearman rank
//! correlation and RMS difference of region means between two images.

use anyhow::{Context, bail};

pub use gloam_calib::cli::CompareArgs;
use gloam_calib::io::read_grey;
use gloam_calib::validate::{compare_images, load_regions};

pub fn run(args: CompareArgs) -> anyhow::Result<()> {
    // The small input first: a bad regions file is named before any image
    // is decoded.
    let off = gloam_io::ReadLog::off(); // compare writes no manifest
    let regions = load_regions(&args.regions, &off)?;
    let t = read_grey(&args.truth, &off).context("reading the truth image")?;
    let s = read_grey(&args.synthetic, &off).context("reading the synthetic image")?;
    if (t.width, t.height) != (s.width, s.height) {
        let (tw, th, sw, sh) = (t.width, t.height, s.width, s.height);
        bail!("the images differ in size: {tw}×{th} vs {sw}×{sh}");
    }
    let c = compare_images(&t.data, &s.data, t.width, t.height, &regions)?;
    if args.json {
        return super::print_json(&c);
    }
    outln!("{:<24} {:>14} {:>14}", "region", "truth", "synthetic");
    for r in &c.regions {
        outln!("{:<24} {:>14.6e} {:>14.6e}", r.name, r.truth, r.synthetic);
    }
    outln!("Spearman rho = {:.6}", c.spearman_rho);
    outln!("RMS difference = {:.6e}", c.rms);
    Ok(())
}
