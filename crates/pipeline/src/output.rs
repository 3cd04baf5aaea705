//! Output files: atomic writes, and the image encoders every command uses.

use std::path::Path;

use anyhow::Context;
use ndarray::Array3;

/// Writes `bytes` to `path` atomically — the project's one atomic writer,
/// [`gloam_calib::report::write_bytes`]: a uniquely named temporary file in
/// the same directory, fsynced, then renamed over the target.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    gloam_calib::report::write_bytes(path, bytes)
        .with_context(|| format!("writing {}", path.display()))
}

/// Like [`write_atomic`], with the content produced by `fill` (for encoders
/// that write to a stream).
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut Vec<u8>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut bytes = Vec::new();
    fill(&mut bytes).with_context(|| format!("encoding {}", path.display()))?;
    write_atomic(path, &bytes)
}

/// A 16-bit greyscale PNG of row-major `pixels` (any bit depth up to 16 is
/// stored unscaled in the 16-bit container, so counts survive exactly).
pub fn png16_bytes(width: u32, height: u32, pixels: &[u16]) -> anyhow::Result<Vec<u8>> {
    use anyhow::Context;
    use image::ImageEncoder;
    let mut bytes = Vec::with_capacity(pixels.len() * 2 + 1024);
    // The encoder takes 16-bit samples in native byte order (PNG itself is big-endian).
    let ne: Vec<u8> = pixels.iter().flat_map(|p| p.to_ne_bytes()).collect();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(&ne, width, height, image::ExtendedColorType::L16)
        .context("encoding PNG")?;
    Ok(bytes)
}

pub fn write_tiff(path: &Path, radiance: &Array3<f64>) -> anyhow::Result<()> {
    let (_, h, w) = radiance.dim();
    let pages: Vec<Vec<f32>> = radiance
        .outer_iter()
        .map(|band| band.iter().map(|&v| v as f32).collect())
        .collect();
    let pages: Vec<&[f32]> = pages.iter().map(Vec::as_slice).collect();
    Ok(gloam_calib::io::write_tiff_f32_pages(path, w, h, &pages)?)
}

pub fn write_npy(path: &Path, radiance: &Array3<f64>) -> anyhow::Result<()> {
    use ndarray_npy::WriteNpyExt;
    write_atomic_with(path, |f| {
        let mut w = std::io::BufWriter::new(f);
        radiance.write_npy(&mut w)?;
        // Flush here: a BufWriter dropped with unwritten data loses the error.
        std::io::Write::flush(&mut w)?;
        Ok(())
    })
}

pub fn write_npy_u32(path: &Path, a: &ndarray::Array2<u32>) -> anyhow::Result<()> {
    use ndarray_npy::WriteNpyExt;
    write_atomic_with(path, |f| {
        let mut w = std::io::BufWriter::new(f);
        a.write_npy(&mut w)?;
        std::io::Write::flush(&mut w)?;
        Ok(())
    })
}

/// First band, divided by its 99.5th percentile, gamma 1/2.2, 8 bits.
pub fn write_preview(path: &Path, radiance: &Array3<f64>) -> anyhow::Result<()> {
    let (_, h, w) = radiance.dim();
    let img = radiance.index_axis(ndarray::Axis(0), 0);
    let mut sorted: Vec<f64> = img.iter().copied().filter(|v| *v > 0.0).collect();
    sorted.sort_by(f64::total_cmp);
    let scale = if sorted.is_empty() {
        1.0
    } else {
        sorted[((sorted.len() - 1) as f64 * 0.995) as usize]
    };
    let pixels: Vec<u8> = img
        .iter()
        .map(|&v| {
            let x = (v / scale).clamp(0.0, 1.0).powf(1.0 / 2.2);
            (x * 255.0).round() as u8
        })
        .collect();
    let gray =
        image::GrayImage::from_raw(w as u32, h as u32, pixels).context("preview buffer size")?;
    write_atomic_with(path, |f| {
        gray.write_to(&mut std::io::Cursor::new(f), image::ImageFormat::Png)?;
        Ok(())
    })
}

/// Adds `"provenance"` to the JSON object in `path` (a report or
/// calibration file written by a library that does not know the run).
pub fn add_provenance(path: &Path, provenance: &crate::Provenance) -> anyhow::Result<()> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("reading {}", path.display()))?;
    if let Some(obj) = v.as_object_mut() {
        obj.insert("provenance".into(), serde_json::to_value(provenance)?);
        write_atomic(path, serde_json::to_string_pretty(&v)?.as_bytes())?;
    }
    Ok(())
}
