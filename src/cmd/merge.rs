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
    // The nearest part of --out that exists, resolved, and the rest as
    // given (it does not exist yet).
    let mut probe = args.out.clone();
    let mut rest = Vec::new();
    let out = loop {
        if let Ok(c) = std::fs::canonicalize(&probe) {
            break rest
                .iter()
                .rev()
                .fold(c, |p: std::path::PathBuf, part| p.join(part));
        }
        match (probe.file_name().map(|n| n.to_os_string()), probe.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name);
                probe = if parent.as_os_str().is_empty() {
                    std::path::PathBuf::from(".")
                } else {
                    parent.to_path_buf()
                };
            }
            _ => break std::env::current_dir()?.join(&args.out),
        }
    };
    for tile in &args.tiles {
        // --out naming a tile itself is the output set's own refusal
        // ("holds the input").
        if let Ok(t) = std::fs::canonicalize(tile)
            && out != t
            && out.starts_with(&t)
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
