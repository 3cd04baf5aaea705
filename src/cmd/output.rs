//! Output helpers shared by subcommands: atomic file writes and JSON printing.

use std::io::Write;
use std::path::Path;

use anyhow::Context;

/// Writes `bytes` to `path` atomically: a temporary file in the same
/// directory, fsynced, then renamed over the target. A crash or a full disk
/// never leaves a half-written output behind.
#[allow(dead_code)] // used by the output-writing commands
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    write_atomic_with(path, |f| f.write_all(bytes).map_err(Into::into))
}

/// Like [`write_atomic`], with the content produced by `fill` (for encoders
/// that write to a stream).
#[allow(dead_code)] // used by the output-writing commands
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut std::fs::File) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut tmp = tempfile::NamedTempFile::new_in(dir)
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

/// Prints a value as pretty JSON on stdout.
pub fn print_json(value: &impl serde::Serialize) -> anyhow::Result<()> {
    println!("{}", serde_json::to_string_pretty(value)?);
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
