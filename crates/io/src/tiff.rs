//! TIFF encoders: float32 images (radiance, one page per band) and the
//! 16-bit frame stack `frames.tiff`, appended page by page.

use std::path::{Path, PathBuf};

use crate::{EncodeError, FileError};

/// Writes a multi-page 32-bit float grey TIFF, one `w × h` page per slice
/// (e.g. one per spectral band), atomically; with `description`, each
/// page carries it as its ImageDescription.
pub fn write_f32_pages(
    path: &Path,
    w: usize,
    h: usize,
    pages: &[&[f32]],
    description: Option<&str>,
) -> Result<(), FileError> {
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut enc =
            tiff::encoder::TiffEncoder::new(&mut buf).map_err(|e| FileError::new(path, e))?;
        for page in pages {
            let Some(description) = description else {
                enc.write_image::<tiff::encoder::colortype::Gray32Float>(w as u32, h as u32, page)
                    .map_err(|e| FileError::new(path, e))?;
                continue;
            };
            let mut image = enc
                .new_image::<tiff::encoder::colortype::Gray32Float>(w as u32, h as u32)
                .map_err(|e| FileError::new(path, e))?;
            image
                .encoder()
                .write_tag(tiff::tags::Tag::ImageDescription, description)
                .map_err(|e| FileError::new(path, e))?;
            image
                .write_data(page)
                .map_err(|e| FileError::new(path, e))?;
        }
    }
    crate::write_atomic(path, buf.get_ref())
}

/// Classic TIFF addresses 4 GiB; a stack that would pass it is refused
/// (use PNG or FITS frames for longer captures).
pub const MAX_TIFF_STACK_BYTES: u64 = (4 << 30) - (64 << 20);

/// `frames.tiff`, one 16-bit page per frame, appended as frames come: the
/// file is a complete TIFF after every page (the encoder links each new
/// page into the chain as it finishes it). Counts are stored as
/// [`scaled_to_16`](crate::png::scaled_to_16) scales them, so viewers show a frame at its true
/// brightness; each page's `ImageDescription` states the scale.
pub struct TiffStack {
    path: PathBuf,
    encoder: tiff::encoder::TiffEncoder<std::fs::File>,
    bytes: u64,
    pages: u64,
}

impl TiffStack {
    pub fn create(path: &Path) -> Result<Self, EncodeError> {
        let file = std::fs::File::create(path).map_err(|e| encode_err(path, e))?;
        let encoder = tiff::encoder::TiffEncoder::new(file).map_err(|e| encode_err(path, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            encoder,
            bytes: 8,
            pages: 0,
        })
    }

    /// Appends one page; returns its index and the shift that recovers
    /// the counts from its samples (count = sample >> shift).
    pub fn append(
        &mut self,
        width: u32,
        height: u32,
        bits: u8,
        pixels: &[u16],
    ) -> Result<(u64, u8), EncodeError> {
        let page_bytes = pixels.len() as u64 * 2 + 1024;
        if self.bytes + page_bytes > MAX_TIFF_STACK_BYTES {
            return Err(encode_err(
                &self.path,
                format!(
                    "page {} would take the TIFF past 4 GiB; use --frame-format png or fits",
                    self.pages
                ),
            ));
        }
        let path = &self.path;
        let mut img = self
            .encoder
            .new_image::<tiff::encoder::colortype::Gray16>(width, height)
            .map_err(|e| encode_err(path, e))?;
        let (samples, shift) = crate::png::scaled_to_16(bits, pixels);
        let note = if shift != 0 {
            format!("{bits}-bit counts left-bit-replicated to 16 bits: count = sample >> {shift}")
        } else {
            "counts as they are (no scaling)".to_string()
        };
        let enc = img.encoder();
        // The samples span 0..=65 535 either way.
        enc.write_tag(tiff::tags::Tag::MaxSampleValue, u16::MAX)
            .and_then(|()| enc.write_tag(tiff::tags::Tag::ImageDescription, note.as_str()))
            .and_then(|()| {
                enc.write_tag(
                    tiff::tags::Tag::Software,
                    concat!("gloam ", env!("CARGO_PKG_VERSION")),
                )
            })
            .map_err(|e| encode_err(path, e))?;
        img.write_data(&samples).map_err(|e| encode_err(path, e))?;
        self.bytes += page_bytes;
        self.pages += 1;
        Ok((self.pages - 1, shift))
    }
}

fn encode_err(path: &Path, e: impl Into<Box<dyn std::error::Error + Send + Sync>>) -> EncodeError {
    EncodeError {
        path: path.to_path_buf(),
        source: e.into(),
    }
}
