//! `gloam merge TILE_DIR… --out DIR`: reassembles `gloam render --tile K/N`
//! outputs into the whole image, bit-identical to the untiled render
//! (the stacking, its checks and the files written are `gloam_sweep::tile`).

use gloam_io::OutputSet;
use gloam_pipeline::Provenance;
pub use gloam_sweep::cli::MergeArgs;

pub fn run(args: MergeArgs, guard: &gloam_io::RunGuard) -> anyhow::Result<()> {
    // Begun first: --out inside a tile directory (an input) is refused by
    // OutputSet::begin, as for every command that writes a set, before a
    // tile is read.
    let set = OutputSet::begin(&args.out, args.force, false, guard)?;
    let mut provenance = Provenance::of_this_run(&gloam_io::ReadLog::new());
    let m = gloam_sweep::tile::merge(&args.tiles, provenance.reads())?;
    m.write(set.dir(), &mut provenance)?;
    set.publish(&provenance, None)?;
    let (n, w, h) = (m.tiles.len(), m.info.width, m.info.height);
    eprintln!("merged {n} tile(s) into {w}×{h} → {}", args.out.display());
    Ok(())
}
