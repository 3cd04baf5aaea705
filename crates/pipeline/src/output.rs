//! Output files: atomic writes, and the image encoders every command uses.

use std::path::{Path, PathBuf};

use ndarray::Array3;

/// Why an output file was not written, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("writing {}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: gloam_io::FileError,
    },
    #[error("encoding {}", path.display())]
    Encode {
        path: PathBuf,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error("encoding PNG")]
    Png(#[source] image::ImageError),
    #[error("preview buffer size")]
    PreviewSize,
    #[error(transparent)]
    Tiff(gloam_io::FileError),
    #[error("reading {}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("reading {}", path.display())]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
}

impl From<gloam_io::EncodeError> for OutputError {
    fn from(e: gloam_io::EncodeError) -> Self {
        OutputError::Encode {
            path: e.path,
            source: e.source,
        }
    }
}

/// Writes `bytes` to `path` atomically — the project's one atomic writer,
/// [`gloam_io::write_atomic`]: a uniquely named temporary file in the same
/// directory, fsynced, then renamed over the target.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    gloam_io::write_atomic(path, bytes).map_err(|source| OutputError::Write {
        path: path.to_path_buf(),
        source,
    })
}

/// Like [`write_atomic`], with the content produced by `fill` (for encoders
/// that write to a stream).
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut Vec<u8>) -> Result<(), Box<dyn std::error::Error + Send + Sync>>,
) -> Result<(), OutputError> {
    let mut bytes = Vec::new();
    fill(&mut bytes).map_err(|source| OutputError::Encode {
        path: path.to_path_buf(),
        source,
    })?;
    write_atomic(path, &bytes)
}

/// A 16-bit greyscale PNG of a frame's row-major `bits`-bit counts,
/// scaled to the full depth with `sBIT` declared so viewers show it
/// (see [`gloam_io::png::png_frame_bytes`]); gloam's readers return the
/// exact counts.
pub fn png16_bytes(
    width: u32,
    height: u32,
    bits: u8,
    pixels: &[u16],
) -> Result<Vec<u8>, OutputError> {
    Ok(gloam_io::png::png_frame_bytes(width, height, bits, pixels)?.0)
}

/// Float32 TIFF, one page per band.
pub fn write_tiff(path: &Path, radiance: &Array3<f64>) -> Result<(), OutputError> {
    let (_, h, w) = radiance.dim();
    let pages: Vec<Vec<f32>> = radiance
        .outer_iter()
        .map(|band| band.iter().map(|&v| v as f32).collect())
        .collect();
    let pages: Vec<&[f32]> = pages.iter().map(Vec::as_slice).collect();
    gloam_io::tiff::write_f32_pages(path, w, h, &pages, None).map_err(OutputError::Tiff)
}

/// Any array as `.npy` ([`gloam_io::npy::write_npy`]): radiance (float64,
/// band × row × column), samples per pixel (uint32, row × column), the
/// `--layers` stacks.
pub fn write_npy<A, D>(path: &Path, a: &ndarray::Array<A, D>) -> Result<(), OutputError>
where
    A: ndarray_npy::WritableElement,
    D: ndarray::Dimension,
{
    write_atomic_with(path, |f| Ok(gloam_io::npy::write_npy(f, a)?))
}

/// The preview's tone map: an asinh stretch around the scene's median
/// `m` (of the positive pixels of the first band),
/// `x = asinh(v/s) / asinh(W/s)` with softening `s = m/4` and white
/// `W = min(p99.5, 64 m)`. Dark and mid tones come out nearly logarithmic
/// (the median at asinh 4 / asinh 256 ≈ 34 % grey, code 86, whatever the scene's
/// absolute level), and lamps beyond 64× the median clip to white instead
/// of pushing the room into black, as scaling to the 99.5th percentile did.
pub struct ToneMap {
    pub soft: f64,
    pub white: f64,
}

impl ToneMap {
    /// The tone map of an image's values (non-positive values ignored).
    pub fn of(values: impl Iterator<Item = f64>) -> Self {
        let mut sorted: Vec<f64> = values.filter(|v| *v > 0.0 && v.is_finite()).collect();
        if sorted.is_empty() {
            return Self {
                soft: 1.0,
                white: 1.0,
            };
        }
        sorted.sort_by(f64::total_cmp);
        let at = |q: f64| sorted[((sorted.len() - 1) as f64 * q).round() as usize];
        let median = at(0.5);
        let white = at(0.995).min(64.0 * median).max(median);
        Self {
            soft: median / 4.0,
            white,
        }
    }

    /// 8-bit grey of a value.
    pub fn grey(&self, v: f64) -> u8 {
        let top = (self.white / self.soft).asinh();
        let x = if top > 0.0 {
            ((v.max(0.0) / self.soft).asinh() / top).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (x * 255.0).round() as u8
    }
}

/// First band through [`ToneMap`], 8 bits.
pub fn write_preview(path: &Path, radiance: &Array3<f64>) -> Result<(), OutputError> {
    let (_, h, w) = radiance.dim();
    let img = radiance.index_axis(ndarray::Axis(0), 0);
    let tone = ToneMap::of(img.iter().copied());
    let pixels: Vec<u8> = img.iter().map(|&v| tone.grey(v)).collect();
    let png =
        gloam_io::png::grey8_png(w as u32, h as u32, pixels).ok_or(OutputError::PreviewSize)?;
    write_atomic_with(path, |f| {
        f.extend(png?);
        Ok(())
    })
}

/// Adds `"provenance"` to the JSON object in `path` (a report or
/// calibration file written by a library that does not know the run).
pub fn add_provenance(path: &Path, provenance: &crate::Provenance) -> Result<(), OutputError> {
    // The file is this run's output, not an input.
    let text = gloam_io::read_text(
        path,
        gloam_io::MAX_TEXT_FILE_BYTES,
        &gloam_io::ReadLog::off(),
    )
    .map_err(|source| OutputError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let json_err = |source| OutputError::Json {
        path: path.to_path_buf(),
        source,
    };
    let mut v: serde_json::Value = serde_json::from_str(&text).map_err(json_err)?;
    if let Some(obj) = v.as_object_mut() {
        let mut provenance = provenance.clone();
        provenance.add_inputs_read();
        obj.insert(
            "provenance".into(),
            serde_json::to_value(&provenance).map_err(json_err)?,
        );
        let text = serde_json::to_string_pretty(&v).map_err(json_err)?;
        write_atomic(path, text.as_bytes())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_lands_at_asinh_4_over_asinh_256_and_lamps_clip() {
        // A room at 1 with 2 % lamps at 500: median 1, p99.5 = 500 > 64.
        let mut v: Vec<f64> = vec![1.0; 980];
        v.extend(std::iter::repeat_n(500.0, 20));
        let t = ToneMap::of(v.iter().copied());
        assert_eq!((t.soft, t.white), (0.25, 64.0));
        let want = (255.0 * 4f64.asinh() / 256f64.asinh()).round() as u8;
        assert_eq!(t.grey(1.0), want);
        assert_eq!(want, 86);
        assert_eq!(t.grey(500.0), 255);
        assert_eq!(t.grey(0.0), 0);
        // Scale-free: the same scene 1e-6 as bright looks the same.
        let t2 = ToneMap::of(v.iter().map(|x| x * 1e-6));
        assert_eq!(t2.grey(1e-6), want);
    }
}
