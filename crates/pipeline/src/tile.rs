//! A tile of a render: tile K of N is a horizontal band of rows
//! (`gloam render --tile K/N`, sweeps); `gloam_sweep::tile` merges them.
//! Here, below the sweep, so a render request can cut and describe one.

use std::ops::Range;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::output::{OutputError, write_atomic};

/// The most tiles a render may be cut into.
pub const MAX_TILES: u32 = 4096;

/// The file a tile render writes beside its images.
pub const TILE_FILE: &str = "tile.json";

/// Tile `k` of `n` (1-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TileSpec {
    pub k: u32,
    pub n: u32,
}

impl TileSpec {
    /// `K/N` with 1 ≤ K ≤ N ≤ [`MAX_TILES`].
    pub fn parse(s: &str) -> Result<TileSpec, TileError> {
        let bad = || TileError::NotATile {
            text: s.to_string(),
        };
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let k: u32 = k.trim().parse().map_err(|_| bad())?;
        let n: u32 = n.trim().parse().map_err(|_| bad())?;
        if k == 0 || n == 0 || k > n || n > MAX_TILES {
            return Err(bad());
        }
        Ok(TileSpec { k, n })
    }

    /// Rows `⌊(K−1)H/N⌋ .. ⌊KH/N⌋` of an image `height` rows tall.
    pub fn rows(&self, height: u32) -> Result<Range<u32>, TileError> {
        if self.n > height {
            return Err(TileError::TooManyTiles { n: self.n, height });
        }
        let at = |k: u32| (k as u64 * height as u64 / self.n as u64) as u32;
        Ok(at(self.k - 1)..at(self.k))
    }
}

/// A tile that cannot be cut.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TileError {
    #[error("'{text}' is not a tile K/N with 1 <= K <= N <= {MAX_TILES} (e.g. 2/4)")]
    NotATile { text: String },
    #[error("{n} tiles of an image {height} rows tall would leave some empty")]
    TooManyTiles { n: u32, height: u32 },
}

impl std::fmt::Display for TileSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.k, self.n)
    }
}

/// What `tile.json` records: where the tile sits and what it was rendered
/// with, so [`merge`] can refuse tiles of different renders.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct TileInfo {
    pub format: String,
    pub tile: u32,
    pub of: u32,
    /// First row and one past the last, in the whole image.
    pub rows: [u32; 2],
    pub width: u32,
    pub height: u32,
    pub band_names: Vec<String>,
    /// The scene file as given.
    pub scene: String,
    /// The scene file's SHA-256 (absent in tiles of older versions).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene_sha256: Option<String>,
    /// The render settings (must agree between tiles).
    pub settings: serde_json::Value,
}

pub const TILE_FORMAT: &str = "gloam-tile/1";

/// Writes `DIR/tile.json` for tile `tile` (rows `rows` of a `width` ×
/// `height` image) of a render of `scene` (named as given).
pub fn write_tile_info(
    dir: &Path,
    tile: TileSpec,
    rows: Range<u32>,
    (width, height): (u32, u32),
    scene: &Path,
    out: &gloam_trace::RenderOutput,
) -> Result<(), OutputError> {
    let path = dir.join(TILE_FILE);
    let encode = |source: serde_json::Error| OutputError::Encode {
        path: path.clone(),
        source: Box::new(source),
    };
    let info = TileInfo {
        format: TILE_FORMAT.into(),
        tile: tile.k,
        of: tile.n,
        rows: [rows.start, rows.end],
        width,
        height,
        band_names: out.band_names.clone(),
        scene: scene.display().to_string(),
        scene_sha256: gloam_io::hash_file(scene).map(|f| f.sha256),
        settings: {
            // The thread count does not change the image.
            let mut s = serde_json::to_value(&out.settings).map_err(encode)?;
            if let Some(o) = s.as_object_mut() {
                o.remove("threads");
            }
            s
        },
    };
    write_atomic(
        &path,
        serde_json::to_string_pretty(&info)
            .map_err(encode)?
            .as_bytes(),
    )?;
    Ok(())
}
