//! `gloam merge TILE_DIR… --out DIR`: reassembles `gloam render --tile K/N`
//! outputs into the whole image, bit-identical to the untiled render
//! (the stacking and its checks are `gloam_sweep::tile::merge`).

use std::path::PathBuf;

use anyhow::{Context, ensure};
use clap::Args;

#[derive(Args)]
pub struct MergeArgs {
    /// Tile directories written by `gloam render --tile K/N` (any order,
    /// every tile of one render exactly once).
    #[arg(required = true)]
    pub tiles: Vec<PathBuf>,
    /// Output directory (must not exist, or be empty); written whole, at once.
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    let m = gloam_sweep::tile::merge(&args.tiles)?;
    if args.out.exists() {
        let empty = std::fs::read_dir(&args.out)
            .with_context(|| format!("reading {}", args.out.display()))?
            .next()
            .is_none();
        ensure!(
            empty,
            "{} exists and is not empty; merge into a new directory",
            args.out.display()
        );
    }
    let parent = match args.out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).with_context(|| format!("creating {}", parent.display()))?;
    let tmp = tempfile::Builder::new()
        .prefix(".merge-")
        .tempdir_in(&parent)
        .with_context(|| format!("creating a temporary directory in {}", parent.display()))?;
    let t = tmp.path();
    super::render::write_tiff(&t.join("radiance.tiff"), &m.radiance)?;
    super::render::write_npy(&t.join("radiance.npy"), &m.radiance)?;
    super::render::write_tiff(&t.join("stderr.tiff"), &m.std_error)?;
    super::render::write_npy(&t.join("stderr.npy"), &m.std_error)?;
    super::render::write_npy_u32(&t.join("spp.npy"), &m.spp)?;
    super::render::write_preview(&t.join("preview.png"), &m.radiance)?;
    let tiles: Vec<serde_json::Value> = m
        .tiles
        .iter()
        .map(|d| {
            let bytes = std::fs::read(d.join("radiance.npy")).unwrap_or_default();
            serde_json::json!({
                "dir": d.display().to_string(),
                "radiance_npy_sha256": gloam_sweep::run::sha256_hex(&bytes),
            })
        })
        .collect();
    let report = serde_json::json!({
        "gloam_version": env!("CARGO_PKG_VERSION"),
        "command_line": std::env::args().collect::<Vec<_>>(),
        "scene": m.info.scene,
        "image": {"width": m.info.width, "height": m.info.height, "bands": m.info.band_names},
        "settings": m.info.settings,
        "merged_from": tiles,
    });
    std::fs::write(
        t.join("report.json"),
        serde_json::to_string_pretty(&report)?,
    )?;
    if args.out.exists() {
        std::fs::remove_dir(&args.out)
            .with_context(|| format!("replacing {}", args.out.display()))?;
    }
    let kept = tmp.keep();
    std::fs::rename(&kept, &args.out)
        .with_context(|| format!("renaming into {}", args.out.display()))?;
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
        settings: {
            // The thread count does not change the image.
            let mut s = serde_json::to_value(&out.settings)?;
            if let Some(o) = s.as_object_mut() {
                o.remove("threads");
            }
            s
        },
    };
    super::output::write_atomic(
        &dir.join(gloam_sweep::tile::TILE_FILE),
        serde_json::to_string_pretty(&info)?.as_bytes(),
    )
}
