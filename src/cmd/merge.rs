//! `gloam merge TILE_DIR… --out DIR`: reassembles `gloam render --tile K/N`
//! outputs into the whole image, bit-identical to the untiled render
//! (the stacking, its checks and the files written are `gloam_sweep::tile`).

use gloam_pipeline::{OutputSet, Provenance};
pub use gloam_sweep::cli::MergeArgs;

pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    refuse_out_inside_a_tile(&args)?;
    let mut provenance = Provenance::of_this_run();
    let m = gloam_sweep::tile::merge(&args.tiles)?;
    let set = OutputSet::begin(&args.out, args.force, false)?;
    m.write(set.dir(), &mut provenance)?;
    set.publish(&provenance, None)?;
    let (n, w, h) = (m.tiles.len(), m.info.width, m.info.height);
    eprintln!("merged {n} tile(s) into {w}×{h} → {}", args.out.display());
    Ok(())
}

/// `--out` inside a tile directory would add the merged set to an input
/// (and a later merge of the same tiles would meet it there): refused.
/// Compared canonically (links and `..` resolved) from the nearest part of
/// `--out` that exists.
fn refuse_out_inside_a_tile(args: &MergeArgs) -> anyhow::Result<()> {
    let mut probe = args.out.as_path();
    let existing = loop {
        if let Ok(c) = std::fs::canonicalize(probe) {
            break c;
        }
        match probe.parent() {
            Some(p) if !p.as_os_str().is_empty() => probe = p,
            _ => break std::env::current_dir()?,
        }
    };
    for tile in &args.tiles {
        if let Ok(t) = std::fs::canonicalize(tile)
            && existing.starts_with(&t)
        {
            anyhow::bail!(
                "--out {}: inside the tile directory {}; write the merged image outside its inputs",
                args.out.display(),
                tile.display()
            );
        }
    }
    Ok(())
}
