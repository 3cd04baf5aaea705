//! Tiled renders: tile K of N is a horizontal band of rows, and [`merge`]
//! stacks the bands back into the whole image.
//!
//! Bands rather than a grid because a band is contiguous in every output
//! array (band × row × column), so merging is a concatenation, and the
//! tracer's per-pixel random streams are keyed by the pixel's index in the
//! whole image, so each pixel of a band is bit-identical to the untiled one.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use gloam_pipeline::Provenance;
use gloam_pipeline::output::OutputError;
use gloam_pipeline::output::{write_atomic, write_npy, write_preview, write_tiff};
use ndarray::{Array2, Array3, Axis};

pub use gloam_pipeline::tile::{
    MAX_TILES, TILE_FILE, TILE_FORMAT, TileError, TileInfo, TileSpec, write_tile_info,
};

/// Why tiles could not be written, checked or merged, naming the file
/// or directory at fault (or what differs between tiles).
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error(transparent)]
    Output(#[from] OutputError),
    #[error("encoding {what} as JSON")]
    Encode {
        what: &'static str,
        #[source]
        source: serde_json::Error,
    },
    #[error("reading {}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error("reading {} (is {} a `gloam render --tile` output?)", path.display(), dir.display())]
    NoTileInfo {
        path: PathBuf,
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("reading {} (a tile is a published `gloam render --tile` set or a sweep task; without its manifest its files cannot be checked)", path.display())]
    NoManifest {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: not a {what}", path.display())]
    NotA {
        path: PathBuf,
        what: &'static str,
        #[source]
        source: serde_json::Error,
    },
    /// A tile file that is not what a whole, unaltered tile holds.
    #[error("{}: {problem}", path.display())]
    Invalid { path: PathBuf, problem: String },
    #[error(transparent)]
    Hash(#[from] crate::run::SweepError),
    #[error("no tile directories given")]
    NoTiles,
    #[error("{} is a tile of another render than {}: {} differ{}", dir.display(), first.display(), differences.join("; "), if differences.len() == 1 { "s" } else { "" })]
    AnotherRender {
        dir: PathBuf,
        first: PathBuf,
        differences: Vec<String>,
    },
    #[error("tile {tile} given twice: {} and {}", a.display(), b.display())]
    Twice {
        tile: String,
        a: PathBuf,
        b: PathBuf,
    },
    #[error("missing tiles: {}", .0.join(", "))]
    Missing(Vec<String>),
    #[error("stacking the tiles' arrays")]
    Stack(#[from] ndarray::ShapeError),
}

impl MergeError {
    fn invalid(path: &Path, problem: String) -> MergeError {
        MergeError::Invalid {
            path: path.to_path_buf(),
            problem,
        }
    }
}

/// `Err(MergeError::Invalid)` unless `ok`.
fn ensure_valid(ok: bool, path: &Path, problem: impl FnOnce() -> String) -> Result<(), MergeError> {
    if ok {
        Ok(())
    } else {
        Err(MergeError::invalid(path, problem()))
    }
}

/// The arrays of a merged (or single) render.
pub struct Merged {
    pub radiance: Array3<f64>,
    pub std_error: Array3<f64>,
    pub spp: Array2<u32>,
    pub info: TileInfo,
    /// The tile directories in tile order.
    pub tiles: Vec<PathBuf>,
}

impl Merged {
    /// Writes the whole image into `dir` as `gloam render` writes it
    /// (radiance, standard error and spp as `.npy`/`.tiff`, a preview) and
    /// `report.json` naming each tile with its `radiance.npy` hash; the
    /// tiles' files read here join `provenance`'s inputs.
    pub fn write(&self, dir: &Path, provenance: &mut Provenance) -> Result<(), MergeError> {
        write_tiff(&dir.join("radiance.tiff"), &self.radiance)?;
        write_npy(&dir.join("radiance.npy"), &self.radiance)?;
        write_tiff(&dir.join("stderr.tiff"), &self.std_error)?;
        write_npy(&dir.join("stderr.npy"), &self.std_error)?;
        write_npy(&dir.join("spp.npy"), &self.spp)?;
        write_preview(&dir.join("preview.png"), &self.radiance)?;
        let mut tiles = Vec::new();
        for d in &self.tiles {
            let p = d.join("radiance.npy");
            let bytes =
                gloam_io::read_bounded(&p, gloam_io::MAX_IMAGE_FILE_BYTES, provenance.reads())
                    .map_err(|e| MergeError::Read {
                        path: p.clone(),
                        source: e.into(),
                    })?;
            tiles.push(MergedTile {
                dir: d.display().to_string(),
                radiance_npy_sha256: crate::run::sha256_hex(&bytes),
            });
        }
        provenance.add_inputs_read();
        let report = MergeReport {
            scene: &self.info.scene,
            image: MergedImage {
                width: self.info.width,
                height: self.info.height,
                bands: &self.info.band_names,
            },
            settings: &self.info.settings,
            merged_from: tiles,
            provenance,
        };
        write_atomic(
            &dir.join("report.json"),
            serde_json::to_string_pretty(&report)
                .map_err(|source| MergeError::Encode {
                    what: "report.json",
                    source,
                })?
                .as_bytes(),
        )?;
        Ok(())
    }
}

/// A merged image's `report.json`: the tiles' scene and settings, and each
/// tile's directory with its radiance's hash.
#[derive(serde::Serialize)]
struct MergeReport<'a> {
    scene: &'a str,
    image: MergedImage<'a>,
    settings: &'a serde_json::Value,
    merged_from: Vec<MergedTile>,
    provenance: &'a Provenance,
}

#[derive(serde::Serialize)]
struct MergedImage<'a> {
    width: u32,
    height: u32,
    bands: &'a [String],
}

#[derive(serde::Serialize)]
struct MergedTile {
    dir: String,
    radiance_npy_sha256: String,
}

fn read_info(dir: &Path, reads: &gloam_io::ReadLog) -> Result<TileInfo, MergeError> {
    let p = dir.join(TILE_FILE);
    let text = gloam_io::read_text(&p, gloam_io::MAX_TEXT_FILE_BYTES, reads).map_err(|source| {
        MergeError::NoTileInfo {
            path: p.clone(),
            dir: dir.to_path_buf(),
            source,
        }
    })?;
    let info: TileInfo = serde_json::from_str(&text).map_err(|e| MergeError::Read {
        path: p.clone(),
        source: e.into(),
    })?;
    ensure_valid(info.format == TILE_FORMAT, &p, || {
        format!("format '{}', expected '{TILE_FORMAT}'", info.format)
    })?;
    let want = TileSpec {
        k: info.tile,
        n: info.of,
    }
    .rows(info.height)
    .map_err(|e| MergeError::invalid(&p, e.to_string()))?;
    ensure_valid(
        TileSpec::parse(&format!("{}/{}", info.tile, info.of)).is_ok()
            && info.rows == [want.start, want.end],
        &p,
        || {
            format!(
                "rows {:?} are not tile {}/{} of {} rows",
                info.rows, info.tile, info.of, info.height
            )
        },
    )?;
    Ok(info)
}

/// Reads an `.npy` whose shape must be `shape`, refusing a file larger
/// than that shape needs (no allocation from an untrusted header).
fn read_npy_checked<A>(
    path: &Path,
    shape: &[usize],
    elem: usize,
    reads: &gloam_io::ReadLog,
) -> Result<A, MergeError>
where
    A: ndarray_npy::ReadNpyExt + HasShape,
{
    let read = |e: Box<dyn std::error::Error + Send + Sync>| MergeError::Read {
        path: path.to_path_buf(),
        source: e,
    };
    let need = shape.iter().product::<usize>().saturating_mul(elem);
    let len = std::fs::metadata(path).map_err(|e| read(e.into()))?.len();
    ensure_valid(len <= need as u64 + 65_536, path, || {
        format!("{len} bytes, more than a {shape:?} array needs")
    })?;
    let f = gloam_io::open_bounded(path, gloam_io::MAX_IMAGE_FILE_BYTES, reads)
        .map_err(|e| read(e.into()))?;
    let a = A::read_npy(std::io::BufReader::new(f)).map_err(|e| read(e.into()))?;
    ensure_valid(a.dims() == shape, path, || {
        format!("shape {:?}, expected {:?}", a.dims(), shape)
    })?;
    Ok(a)
}

/// The shape of an array read from `.npy`.
pub trait HasShape {
    fn dims(&self) -> Vec<usize>;
}
impl HasShape for Array3<f64> {
    fn dims(&self) -> Vec<usize> {
        self.shape().to_vec()
    }
}
impl HasShape for Array2<u32> {
    fn dims(&self) -> Vec<usize> {
        self.shape().to_vec()
    }
}

/// The files of a tile that [`merge`] reads; each must be listed in the
/// tile's `manifest.json` with its current SHA-256.
pub const TILE_FILES: [&str; 4] = [TILE_FILE, "radiance.npy", "stderr.npy", "spp.npy"];

/// Checks the tile directory `dir` against its `manifest.json` (a
/// `gloam render --tile` set) or its `task.json` (a sweep task): a whole
/// tile that lists every file in [`TILE_FILES`] with the SHA-256 the file
/// has now. Returns the render's inputs (path → SHA-256) from the record.
pub fn verify_tile_manifest(
    dir: &Path,
    reads: &gloam_io::ReadLog,
) -> Result<BTreeMap<String, String>, MergeError> {
    let mp = dir.join("manifest.json");
    let tp = dir.join(crate::run::RECORD_FILE);
    let task = !mp.exists() && tp.is_file();
    let rp = if task { &tp } else { &mp };
    let text = gloam_io::read_text(rp, gloam_io::MAX_TEXT_FILE_BYTES, reads).map_err(|source| {
        MergeError::NoManifest {
            path: rp.clone(),
            source,
        }
    })?;
    let not_a = |what| {
        move |source| MergeError::NotA {
            path: rp.clone(),
            what,
            source,
        }
    };
    // A key given twice (`"complete": false, "complete": true`) was read
    // as its last value: refused, as a contradicting record.
    let m: serde_json::Value =
        gloam_io::json::parse_value(&text).map_err(not_a("gloam manifest"))?;
    let (whole, hashes, inputs): (bool, BTreeMap<String, String>, BTreeMap<String, String>) =
        if task {
            let r: crate::run::TaskRecord =
                serde_json::from_value(m).map_err(not_a("sweep task record"))?;
            (r.status == crate::run::Status::Done, r.outputs, r.inputs)
        } else {
            let files = m.get("files").and_then(|f| f.as_array()).ok_or_else(|| {
                MergeError::invalid(rp, "no \"files\" list; not a gloam manifest".into())
            })?;
            let pairs = |list: Option<&Vec<serde_json::Value>>| -> BTreeMap<String, String> {
                list.into_iter()
                    .flatten()
                    .filter_map(|f| {
                        Some((
                            f.get("path")?.as_str()?.to_string(),
                            f.get("sha256")?.as_str()?.to_string(),
                        ))
                    })
                    .collect()
            };
            (
                m.get("complete") == Some(&serde_json::Value::Bool(true)),
                pairs(Some(files)),
                pairs(m.pointer("/provenance/inputs").and_then(|i| i.as_array())),
            )
        };
    ensure_valid(whole, rp, || {
        "the render stopped early or failed; it is not a whole tile".into()
    })?;
    for name in TILE_FILES {
        let p = dir.join(name);
        let Some(want) = hashes.get(name) else {
            // A whole render's set lists no tile.json because it has none:
            // it is not a tile, not an altered one.
            if name == TILE_FILE && !hashes.contains_key(TILE_FILE) && !p.exists() {
                return Err(MergeError::invalid(
                    dir,
                    "not a tile: it holds no tile.json (a whole render, not `gloam render --tile K/N`)".into(),
                ));
            }
            return Err(MergeError::invalid(
                &p,
                format!(
                    "not listed in {} with a SHA-256; the tile set was altered",
                    rp.display()
                ),
            ));
        };
        let have = crate::run::sha256_file(&p)?;
        ensure_valid(&have == want, &p, || {
            format!(
                "changed since the render wrote it (its SHA-256 is {have}, {} records {want}); refusing to merge it",
                rp.display()
            )
        })?;
    }
    Ok(inputs)
}

/// What differs between two tiles' records (empty when they are tiles of
/// one render), each as `what (this vs that)`.
pub fn differences(a: &TileInfo, b: &TileInfo) -> Vec<String> {
    let mut d = Vec::new();
    match (&a.scene_sha256, &b.scene_sha256) {
        (Some(x), Some(y)) if x != y => d.push(format!(
            "scene ({} with SHA-256 {x} vs {} with SHA-256 {y})",
            a.scene, b.scene
        )),
        (Some(_), Some(_)) => {}
        _ if a.scene != b.scene => d.push(format!("scene ({} vs {})", a.scene, b.scene)),
        _ => {}
    }
    if (a.width, a.height) != (b.width, b.height) {
        d.push(format!(
            "image size ({}×{} vs {}×{})",
            a.width, a.height, b.width, b.height
        ));
    }
    if a.band_names != b.band_names {
        // At most a few names each: a forged list of 100 000 printed a
        // 400 KB error line.
        let few = |names: &[String]| {
            const SHOWN: usize = 8;
            let head = names
                .iter()
                .take(SHOWN)
                .cloned()
                .collect::<Vec<_>>()
                .join(",");
            match names.len() {
                n if n > SHOWN => format!("{n} bands: {head},…"),
                _ => head,
            }
        };
        d.push(format!(
            "bands ({} vs {})",
            few(&a.band_names),
            few(&b.band_names)
        ));
    }
    if a.settings != b.settings {
        let empty = serde_json::Map::new();
        let (x, y) = (
            a.settings.as_object().unwrap_or(&empty),
            b.settings.as_object().unwrap_or(&empty),
        );
        let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
        keys.sort();
        keys.dedup();
        let null = serde_json::Value::Null;
        let diffs: Vec<String> = keys
            .into_iter()
            .filter(|k| x.get(*k) != y.get(*k))
            .map(|k| {
                format!(
                    "{k} {} vs {}",
                    x.get(k).unwrap_or(&null),
                    y.get(k).unwrap_or(&null)
                )
            })
            .collect();
        d.push(if diffs.is_empty() {
            "settings".to_string()
        } else {
            format!("settings ({})", diffs.join(", "))
        });
    }
    if a.of != b.of {
        d.push(format!("tile count ({} vs {})", a.of, b.of));
    }
    d
}

/// Inputs (path → SHA-256) recorded by both tiles' manifests whose hashes
/// differ: the same scene path with an edited OBJ, spectrum or sensor file.
fn input_differences(a: &BTreeMap<String, String>, b: &BTreeMap<String, String>) -> Vec<String> {
    a.iter()
        .filter_map(|(p, h)| {
            let g = b.get(p)?;
            (g != h).then(|| format!("input {p} (SHA-256 {h} vs {g})"))
        })
        .collect()
}

/// Stacks the tiles in `dirs` (any order, every tile of one render exactly
/// once) into the whole image. Each tile's files must be what its
/// manifest says, and all tiles must come from one render (the same scene
/// and inputs, size, bands, settings and tile count); a refusal names the
/// file, or what differs.
pub fn merge(dirs: &[PathBuf], reads: &gloam_io::ReadLog) -> Result<Merged, MergeError> {
    if dirs.is_empty() {
        return Err(MergeError::NoTiles);
    }
    let mut tiles: Vec<(TileInfo, PathBuf)> = Vec::with_capacity(dirs.len());
    let mut inputs = Vec::with_capacity(dirs.len());
    for d in dirs {
        inputs.push(verify_tile_manifest(d, reads)?);
        tiles.push((read_info(d, reads)?, d.clone()));
    }
    let first = tiles[0].0.clone();
    for ((t, d), ins) in tiles.iter().zip(&inputs) {
        let mut diff = differences(t, &first);
        diff.extend(input_differences(ins, &inputs[0]));
        if !diff.is_empty() {
            return Err(MergeError::AnotherRender {
                dir: d.clone(),
                first: tiles[0].1.clone(),
                differences: diff,
            });
        }
    }
    tiles.sort_by_key(|(t, _)| t.tile);
    for w in tiles.windows(2) {
        if w[0].0.tile == w[1].0.tile {
            return Err(MergeError::Twice {
                tile: format!("{}/{}", w[0].0.tile, first.of),
                a: w[0].1.clone(),
                b: w[1].1.clone(),
            });
        }
    }
    if tiles.len() != first.of as usize {
        let have: Vec<u32> = tiles.iter().map(|(t, _)| t.tile).collect();
        let missing: Vec<String> = (1..=first.of)
            .filter(|k| !have.contains(k))
            .map(|k| format!("{k}/{}", first.of))
            .collect();
        return Err(MergeError::Missing(missing));
    }
    let nb = first.band_names.len();
    let (w, h) = (first.width as usize, first.height as usize);
    let mut parts_r = Vec::new();
    let mut parts_e = Vec::new();
    let mut parts_s = Vec::new();
    for (t, d) in &tiles {
        let rows = (t.rows[1] - t.rows[0]) as usize;
        parts_r.push(read_npy_checked::<Array3<f64>>(
            &d.join("radiance.npy"),
            &[nb, rows, w],
            8,
            reads,
        )?);
        parts_e.push(read_npy_checked::<Array3<f64>>(
            &d.join("stderr.npy"),
            &[nb, rows, w],
            8,
            reads,
        )?);
        parts_s.push(read_npy_checked::<Array2<u32>>(
            &d.join("spp.npy"),
            &[rows, w],
            4,
            reads,
        )?);
    }
    let cat3 = |parts: &[Array3<f64>]| {
        let views: Vec<_> = parts.iter().map(|a| a.view()).collect();
        ndarray::concatenate(Axis(1), &views)
    };
    let radiance = cat3(&parts_r)?;
    let std_error = cat3(&parts_e)?;
    let views: Vec<_> = parts_s.iter().map(|a| a.view()).collect();
    let spp = ndarray::concatenate(Axis(0), &views)?;
    if radiance.dim() != (nb, h, w) {
        return Err(MergeError::Stack(ndarray::ShapeError::from_kind(
            ndarray::ErrorKind::IncompatibleShape,
        )));
    }
    let mut info = first;
    info.tile = 1;
    info.of = 1;
    info.rows = [0, h as u32];
    Ok(Merged {
        radiance,
        std_error,
        spp,
        info,
        tiles: tiles.into_iter().map(|(_, d)| d).collect(),
    })
}

#[cfg(test)]
mod tests {

    /// Round 12 of issue 46: a forged tile of 100 000 band names printed
    /// every one of them (a 400 KB error line); a few are shown, with the
    /// count.
    #[test]
    fn band_lists_that_differ_are_shown_short() {
        let tile = |names: Vec<String>| TileInfo {
            format: "gloam-tile/1".into(),
            tile: 1,
            of: 2,
            rows: [0, 1],
            width: 4,
            height: 2,
            band_names: names,
            scene: "s.toml".into(),
            scene_sha256: None,
            settings: serde_json::Value::Null,
        };
        let d = differences(
            &tile(vec!["vis".into(); 100_000]),
            &tile(vec!["vis".into()]),
        );
        assert_eq!(d.len(), 1, "{d:?}");
        assert!(d[0].starts_with("bands (100000 bands: vis,vis"), "{}", d[0]);
        assert!(d[0].len() < 200, "{}", d[0].len());
    }
    use super::*;

    #[test]
    fn bands_cover_every_row_once() {
        for h in [1u32, 2, 7, 48, 577] {
            for n in 1..=h.min(9) {
                let mut next = 0;
                for k in 1..=n {
                    let r = TileSpec { k, n }.rows(h).unwrap();
                    assert_eq!(r.start, next);
                    assert!(r.end > r.start);
                    next = r.end;
                }
                assert_eq!(next, h);
            }
        }
        assert!(TileSpec { k: 1, n: 5 }.rows(4).is_err());
    }

    #[test]
    fn tile_specs_parse_or_explain() {
        assert_eq!(TileSpec::parse("2/4"), Ok(TileSpec { k: 2, n: 4 }));
        for bad in ["0/4", "5/4", "4", "a/b", "1/0", "1/99999"] {
            assert!(
                TileSpec::parse(bad)
                    .unwrap_err()
                    .to_string()
                    .contains("K/N"),
                "{bad}"
            );
        }
    }
}
