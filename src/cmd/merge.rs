//! `gloam merge TILE_DIR… --out DIR`: reassembles `gloam render --tile K/N`
//! outputs into the whole image, bit-identical to the untiled render
//! (the stacking and its checks are `gloam_sweep::tile::merge`).

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use gloam_pipeline::{OutputSet, Provenance};

use super::output::{write_atomic, write_npy, write_npy_u32, write_preview, write_tiff};

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
    let t = set.dir().to_path_buf();
    write_tiff(&t.join("radiance.tiff"), &m.radiance)?;
    write_npy(&t.join("radiance.npy"), &m.radiance)?;
    write_tiff(&t.join("stderr.tiff"), &m.std_error)?;
    write_npy(&t.join("stderr.npy"), &m.std_error)?;
    write_npy_u32(&t.join("spp.npy"), &m.spp)?;
    write_preview(&t.join("preview.png"), &m.radiance)?;
    let mut tiles = Vec::new();
    for d in &m.tiles {
        let p = d.join("radiance.npy");
        let bytes =
            gloam_spectra::input::read_bounded(&p, gloam_spectra::input::MAX_IMAGE_FILE_BYTES)
                .with_context(|| format!("reading {}", p.display()))?;
        tiles.push(serde_json::json!({
            "dir": d.display().to_string(),
            "radiance_npy_sha256": gloam_sweep::run::sha256_hex(&bytes),
        }));
    }
    provenance.add_inputs_read();
    let report = serde_json::json!({
        "scene": m.info.scene,
        "image": {"width": m.info.width, "height": m.info.height, "bands": m.info.band_names},
        "settings": m.info.settings,
        "merged_from": tiles,
        "provenance": provenance,
    });
    write_atomic(
        &t.join("report.json"),
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
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

/// Writes `DIR/tile.json` for tile `tile` of a render of `scene`.
pub fn write_tile_info(
    dir: &std::path::Path,
    tile: gloam_sweep::TileSpec,
    rows: std::ops::Range<u32>,
    (width, height): (u32, u32),
    scene: &std::path::Path,
    out: &gloam_trace::RenderOutput,
) -> anyhow::Result<()> {
    let info = gloam_sweep::tile::TileInfo {
        format: gloam_sweep::tile::TILE_FORMAT.into(),
        tile: tile.k,
        of: tile.n,
        rows: [rows.start, rows.end],
        width,
        height,
        band_names: out.band_names.clone(),
        scene: scene.display().to_string(),
        scene_sha256: gloam_pipeline::provenance::hash_file(scene).map(|f| f.sha256),
        settings: {
            // The thread count does not change the image.
            let mut s = serde_json::to_value(&out.settings)?;
            if let Some(o) = s.as_object_mut() {
                o.remove("threads");
            }
            s
        },
    };
    write_atomic(
        &dir.join(gloam_sweep::tile::TILE_FILE),
        serde_json::to_string_pretty(&info)?.as_bytes(),
    )?;
    Ok(())
}
