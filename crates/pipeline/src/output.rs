//! Output files: atomic writes, and the image encoders every command uses.

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use ndarray::Array3;

/// Writes `bytes` to `path` atomically: a temporary file in the same
/// directory, fsynced, then renamed over the target. A crash or a full disk
/// never leaves a half-written output behind.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    write_atomic_with(path, |f| f.write_all(bytes).map_err(Into::into))
}

/// Like [`write_atomic`], with the content produced by `fill` (for encoders
/// that write to a stream).
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut std::fs::File) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    // Mode 0666 less the umask, as `File::create` gives (tempfile's own
    // default is 0600).
    let mut builder = tempfile::Builder::new();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder
        .tempfile_in(dir)
        .with_context(|| format!("creating a temporary file in {}", dir.display()))?;
    fill(tmp.as_file_mut()).with_context(|| format!("writing {}", path.display()))?;
    tmp.as_file()
        .sync_all()
        .with_context(|| format!("syncing {}", path.display()))?;
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("renaming into {}", path.display()))?;
    Ok(())
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
    let (nb, h, w) = radiance.dim();
    write_atomic_with(path, |f| {
        let mut enc = tiff::encoder::TiffEncoder::new(f)?;
        for b in 0..nb {
            let page: Vec<f32> = radiance
                .index_axis(ndarray::Axis(0), b)
                .iter()
                .map(|&v| v as f32)
                .collect();
            enc.write_image::<tiff::encoder::colortype::Gray32Float>(w as u32, h as u32, &page)?;
        }
        Ok(())
    })
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
        let mut w = std::io::BufWriter::new(f);
        gray.write_to(&mut w, image::ImageFormat::Png)?;
        std::io::Write::flush(&mut w)?;
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
