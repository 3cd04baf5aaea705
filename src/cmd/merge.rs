//! `gloam merge TILE_DIR… --out DIR`: reassembles `gloam render --tile K/N`
//! outputs into the whole image, bit-identical to the untiled render
//! (the stacking, its checks and the files written are `gloam_sweep::tile`).

use std::path::PathBuf;

use clap::Args;
use gloam_pipeline::{OutputSet, Provenance};

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

pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    let mut provenance = Provenance::of_this_run();
    let m = gloam_sweep::tile::merge(&args.tiles)?;
    let set = OutputSet::begin(&args.out, args.force, false)?;
    m.write(set.dir(), &mut provenance)?;
    set.publish(&provenance, None)?;
    eprintln!(
        "merged {} tile(s) into {}×{} → {}",
        m.tiles.len(),
        m.info.width,
        m.info.height,
        args.out.display()
    );
    Ok(())
}
