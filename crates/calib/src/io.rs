//! Image files for the CLI-facing flows: digital-count images (PNG/TIFF,
//! 8 or 16 bit grey), float images (TIFF 32-bit float, or any of the
//! former), 32-bit float TIFF output, and the per-frame gain recorded in
//! `frames.jsonl` by `gloam capture`.

use std::path::Path;

use crate::error::CalibError;

/// A grey image as f64, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct GreyImage {
    pub width: usize,
    pub height: usize,
    pub data: Vec<f64>,
}

fn is_tiff(path: &Path) -> bool {
    matches!(
        path.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref(),
        Some("tif" | "tiff")
    )
}

/// Reads a grey image of any supported depth (u8, u16, f32 TIFF, …),
/// noting it in `reads`.
pub fn read_grey(path: &Path, reads: &gloam_io::ReadLog) -> Result<GreyImage, CalibError> {
    if is_tiff(path) {
        let bytes = gloam_io::read_bounded(path, gloam_io::MAX_IMAGE_FILE_BYTES, reads)
            .map_err(|e| CalibError::file(path, e))?;
        let mut d = tiff::decoder::Decoder::new(std::io::Cursor::new(bytes))
            .map_err(|e| CalibError::file(path, e))?;
        let (w, h) = d.dimensions().map_err(|e| CalibError::file(path, e))?;
        let ct = d.colortype().map_err(|e| CalibError::file(path, e))?;
        if !matches!(ct, tiff::ColorType::Gray(_)) {
            return Err(CalibError::file(
                path,
                format!("expected a grey image, found {ct:?}"),
            ));
        }
        use tiff::decoder::DecodingResult as R;
        let data: Vec<f64> = match d.read_image().map_err(|e| CalibError::file(path, e))? {
            R::U8(v) => v.into_iter().map(f64::from).collect(),
            R::U16(v) => v.into_iter().map(f64::from).collect(),
            R::U32(v) => v.into_iter().map(f64::from).collect(),
            R::F32(v) => v.into_iter().map(f64::from).collect(),
            R::F64(v) => v,
            _ => return Err(CalibError::file(path, "unsupported TIFF sample format")),
        };
        if data.len() != w as usize * h as usize {
            return Err(CalibError::file(
                path,
                "TIFF holds more than one sample per pixel",
            ));
        }
        return Ok(GreyImage {
            width: w as usize,
            height: h as usize,
            data,
        });
    }
    let bytes = gloam_io::read_bounded(path, gloam_io::MAX_IMAGE_FILE_BYTES, reads)
        .map_err(|e| CalibError::file(path, e))?;
    if is_fits(&bytes) {
        let f = decode_fits_counts(&bytes).map_err(|e| CalibError::file(path, e))?;
        return Ok(GreyImage {
            width: f.width,
            height: f.height,
            data: f.counts.into_iter().map(f64::from).collect(),
        });
    }
    grey_of_bytes(path, bytes)
}

/// A PNG or other non-TIFF grey image from its bytes.
fn grey_of_bytes(path: &Path, bytes: Vec<u8>) -> Result<GreyImage, CalibError> {
    if bytes.starts_with(PNG_SIGNATURE) {
        let p = decode_png_counts(&bytes).map_err(|e| CalibError::file(path, e))?;
        return Ok(GreyImage {
            width: p.width as usize,
            height: p.height as usize,
            data: p.counts.into_iter().map(f64::from).collect(),
        });
    }
    let img = image::load_from_memory(&bytes).map_err(|e| match e {
        // The decoder's own "could not be determined" names no format.
        image::ImageError::Unsupported(_) => CalibError::file(
            path,
            "not an image gloam reads (a PNG, FITS or TIFF of grey counts)",
        ),
        e => CalibError::file(path, e),
    })?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let data = match img {
        image::DynamicImage::ImageLuma8(b) => b.into_raw().into_iter().map(f64::from).collect(),
        image::DynamicImage::ImageLuma16(b) => b.into_raw().into_iter().map(f64::from).collect(),
        other => {
            return Err(CalibError::file(
                path,
                format!("expected a grey image, found {:?}", other.color()),
            ));
        }
    };
    Ok(GreyImage {
        width: w,
        height: h,
        data,
    })
}

const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";

/// The counts of a grey PNG, with the bits that carry them.
#[derive(Clone, Debug, PartialEq)]
pub struct PngCounts {
    pub width: u32,
    pub height: u32,
    /// Significant bits: the `sBIT` chunk's, else the sample depth.
    pub bits: u8,
    /// Row-major counts, each below 2^bits.
    pub counts: Vec<u16>,
}

/// Why a PNG's counts could not be read.
#[derive(Debug, thiserror::Error)]
pub enum PngCountsError {
    #[error(transparent)]
    Decode(#[from] png::DecodingError),
    #[error("expected an 8- or 16-bit grey PNG, found {colour:?} at {depth} bits")]
    NotGrey { colour: png::ColorType, depth: u8 },
    #[error("image larger than the decoder's output buffer")]
    TooLarge,
    #[error(
        "sBIT {sbit:?} is not one significant-bit count in 1..={depth} for a {depth}-bit grey PNG: the samples' scale is unknown"
    )]
    BadSbit { sbit: Vec<u8>, depth: u8 },
}

/// The largest decoded PNG accepted, bytes (a 16-bit 16 384 × 16 384 frame).
pub const MAX_PNG_DECODED_BYTES: usize = 1 << 29;

/// Decodes a grey PNG (8 or 16 bits per sample) into counts, honouring
/// `sBIT`: a PNG whose samples carry fewer significant bits `b` than its
/// depth `d` holds them scaled to the full depth (PNG specification §12.4,
/// by left-bit replication or linear scaling), and the counts are
/// `sample >> (d − b)`, exact for either scaling. gloam writes its frames
/// that way (so viewers show them) and reads them back here.
pub fn decode_png_counts(bytes: &[u8]) -> Result<PngCounts, PngCountsError> {
    let limits = png::Limits {
        bytes: MAX_PNG_DECODED_BYTES,
    };
    let mut dec = png::Decoder::new_with_limits(std::io::Cursor::new(bytes), limits);
    dec.set_transformations(png::Transformations::IDENTITY);
    let mut reader = dec.read_info()?;
    let info = reader.info();
    let (colour, depth) = (info.color_type, info.bit_depth as u8);
    if colour != png::ColorType::Grayscale || !matches!(depth, 8 | 16) {
        return Err(PngCountsError::NotGrey { colour, depth });
    }
    let (width, height) = (info.width, info.height);
    let bits = match info.sbit.as_deref() {
        None => depth,
        Some([b]) if (1..=depth).contains(b) => *b,
        // Not a grey image's sBIT (one byte in 1..=depth): the scale of
        // the samples is unknown, so no count can be read from them.
        Some(other) => {
            return Err(PngCountsError::BadSbit {
                sbit: other.to_vec(),
                depth,
            });
        }
    };
    let size = reader
        .output_buffer_size()
        .ok_or(PngCountsError::TooLarge)?;
    if size > MAX_PNG_DECODED_BYTES {
        return Err(PngCountsError::TooLarge);
    }
    let mut buf = vec![0u8; size];
    let out = reader.next_frame(&mut buf)?;
    buf.truncate(out.buffer_size());
    let shift = depth - bits;
    let counts = if depth == 16 {
        buf.chunks_exact(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]) >> shift)
            .collect()
    } else {
        buf.iter().map(|&v| u16::from(v >> shift)).collect()
    };
    Ok(PngCounts {
        width,
        height,
        bits,
        counts,
    })
}

/// Reads a digital-count image (integers 0..=65535): a PNG (`sBIT`
/// honoured), a FITS frame ([`decode_fits_counts`]), or a one-page TIFF
/// (gloam's frame stacks: the scale its description states undone). A
/// multi-page TIFF needs its page named: [`read_frame_counts`].
pub fn read_counts(
    path: &Path,
    reads: &gloam_io::ReadLog,
) -> Result<(usize, usize, Vec<u16>), CalibError> {
    read_frame_counts(path, &StoredAt::default(), reads)
}

/// The frame formats gloam writes and reads back (`--frame-format`,
/// `gloam_io::frames::FrameFormat::NAMES`; the writers are
/// `gloam_pipeline::frame_files`').
pub const FRAME_FORMAT_NAMES: [&str; 3] = gloam_io::frames::FrameFormat::NAMES;

/// Where one frame's counts sit in its file (its `frames.jsonl` line's
/// `stored`), as the one reader of the log gives it.
pub use gloam_io::frames::{FrameLine, StoredAt};

fn is_fits(bytes: &[u8]) -> bool {
    bytes.starts_with(b"SIMPLE  =")
}

fn is_tiff_bytes(bytes: &[u8]) -> bool {
    bytes.starts_with(b"II*\0") || bytes.starts_with(b"MM\0*")
}

/// The shift gloam's frame TIFFs state in their `ImageDescription`
/// (`… count = sample >> N`); `None` for any other description.
pub fn tiff_stated_shift(description: &str) -> Option<u8> {
    let n = description.rsplit_once("count = sample >> ")?.1;
    n.trim().parse::<u8>().ok().filter(|s| *s < 16)
}

/// The counts of one frame of any format gloam writes (`--frame-format
/// png|fits|tiff`): PNG with `sBIT`, FITS (BITPIX 8/16, BZERO), or page
/// `at.page` of a TIFF (needed when it holds more than one), its samples
/// shifted right by `at.sample_shift` (else by what the page's description
/// states; else as they are). `reads` notes the file.
pub fn read_frame_counts(
    path: &Path,
    at: &StoredAt,
    reads: &gloam_io::ReadLog,
) -> Result<(usize, usize, Vec<u16>), CalibError> {
    let bytes = gloam_io::read_bounded(path, gloam_io::MAX_IMAGE_FILE_BYTES, reads)
        .map_err(|e| CalibError::file(path, e))?;
    if is_tiff_bytes(&bytes) || (is_tiff(path) && !is_fits(&bytes)) {
        let mut pages = TiffPages::new(path, bytes)?;
        return pages.counts(at);
    }
    if at.page.is_some_and(|p| p > 0) {
        return Err(CalibError::file(
            path,
            format!(
                "page {} asked for, but only a multi-page TIFF has pages",
                at.page.unwrap_or(0)
            ),
        ));
    }
    if is_fits(&bytes) {
        let f = decode_fits_counts(&bytes).map_err(|e| CalibError::file(path, e))?;
        return Ok((f.width, f.height, f.counts));
    }
    counts_of_grey(path, grey_of_bytes(path, bytes)?)
}

/// An open TIFF whose pages are read in order (a frame stack read frame
/// by frame decodes each page once; going back reopens it).
pub struct TiffPages {
    path: std::path::PathBuf,
    bytes: std::sync::Arc<Vec<u8>>,
    decoder: tiff::decoder::Decoder<std::io::Cursor<ArcBytes>>,
    page: u64,
}

/// Shared bytes as a cursor's buffer.
#[derive(Clone)]
struct ArcBytes(std::sync::Arc<Vec<u8>>);

impl AsRef<[u8]> for ArcBytes {
    fn as_ref(&self) -> &[u8] {
        &self.0
    }
}

/// Most pages a frame TIFF may hold (a capture's stack is below 4 GiB;
/// 2^20 pages of even one pixel would pass it).
pub const MAX_TIFF_PAGES: u64 = 1 << 20;

impl TiffPages {
    pub fn new(path: &Path, bytes: Vec<u8>) -> Result<Self, CalibError> {
        let bytes = std::sync::Arc::new(bytes);
        let decoder = tiff::decoder::Decoder::new(std::io::Cursor::new(ArcBytes(bytes.clone())))
            .map_err(|e| CalibError::file(path, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            bytes,
            decoder,
            page: 0,
        })
    }

    /// Opens the TIFF at `path`, noting it in `reads`.
    pub fn open(path: &Path, reads: &gloam_io::ReadLog) -> Result<Self, CalibError> {
        let bytes = gloam_io::read_bounded(path, gloam_io::MAX_IMAGE_FILE_BYTES, reads)
            .map_err(|e| CalibError::file(path, e))?;
        Self::new(path, bytes)
    }

    fn seek(&mut self, page: u64) -> Result<(), CalibError> {
        let path = self.path.clone();
        if page < self.page {
            *self = Self::new(&path, (*self.bytes).clone())?;
        }
        while self.page < page {
            if !self.decoder.more_images() {
                return Err(CalibError::file(
                    &path,
                    format!("no page {page}: the TIFF holds {} page(s)", self.page + 1),
                ));
            }
            self.decoder
                .next_image()
                .map_err(|e| CalibError::file(&path, e))?;
            self.page += 1;
        }
        Ok(())
    }

    /// How many pages the TIFF holds (counted up to [`MAX_TIFF_PAGES`]).
    pub fn count(&self) -> Result<u64, CalibError> {
        let mut d = tiff::decoder::Decoder::new(std::io::Cursor::new(ArcBytes(self.bytes.clone())))
            .map_err(|e| CalibError::file(&self.path, e))?;
        let mut n = 1;
        while d.more_images() && n < MAX_TIFF_PAGES {
            d.next_image()
                .map_err(|e| CalibError::file(&self.path, e))?;
            n += 1;
        }
        Ok(n)
    }

    /// The counts of page `at.page` (a TIFF of more pages must name one).
    pub fn counts(&mut self, at: &StoredAt) -> Result<(usize, usize, Vec<u16>), CalibError> {
        let path = self.path.clone();
        let page = match at.page {
            Some(p) => p,
            None => {
                let n = self.count()?;
                if n > 1 {
                    return Err(CalibError::file(
                        &path,
                        format!(
                            "holds {n} pages (frames): name the frame's page (`calibrate apply --page N`, or its frames.jsonl line's \"stored\".\"page\")"
                        ),
                    ));
                }
                0
            }
        };
        self.seek(page)?;
        let d = &mut self.decoder;
        let (w, h) = d.dimensions().map_err(|e| CalibError::file(&path, e))?;
        let ct = d.colortype().map_err(|e| CalibError::file(&path, e))?;
        if !matches!(ct, tiff::ColorType::Gray(_)) {
            return Err(CalibError::file(
                &path,
                format!("page {page}: expected a grey image, found {ct:?}"),
            ));
        }
        let shift = match at.sample_shift {
            Some(s) => s,
            None => d
                .get_tag_ascii_string(tiff::tags::Tag::ImageDescription)
                .ok()
                .as_deref()
                .and_then(tiff_stated_shift)
                .unwrap_or(0),
        };
        if shift >= 16 {
            return Err(CalibError::file(
                &path,
                format!("page {page}: sample shift {shift} leaves no bits"),
            ));
        }
        use tiff::decoder::DecodingResult as R;
        let counts: Vec<u16> = match d.read_image().map_err(|e| CalibError::file(&path, e))? {
            R::U8(v) => v.into_iter().map(|s| u16::from(s) >> shift).collect(),
            R::U16(v) => v.into_iter().map(|s| s >> shift).collect(),
            // Counts held as wider integers or floats: whole values only.
            other => {
                let data: Vec<f64> = match other {
                    R::U32(v) => v.into_iter().map(f64::from).collect(),
                    R::F32(v) => v.into_iter().map(f64::from).collect(),
                    R::F64(v) => v,
                    _ => {
                        return Err(CalibError::file(
                            &path,
                            format!("page {page}: unsupported TIFF sample format"),
                        ));
                    }
                };
                let g = GreyImage {
                    width: w as usize,
                    height: h as usize,
                    data,
                };
                counts_of_grey(&path, g)?.2
            }
        };
        if counts.len() != w as usize * h as usize {
            return Err(CalibError::file(
                &path,
                format!("page {page}: more than one sample per pixel"),
            ));
        }
        Ok((w as usize, h as usize, counts))
    }
}

/// The counts of a FITS frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FitsCounts {
    pub width: usize,
    pub height: usize,
    pub counts: Vec<u16>,
    /// The header's cards up to END, as (keyword, value text): strings
    /// without their quotes, other values up to the comment.
    pub cards: Vec<(String, String)>,
}

/// Most header blocks read before END (a frame's header takes one or two).
pub const MAX_FITS_HEADER_BLOCKS: usize = 64;

/// The largest FITS frame accepted, pixels (as [`MAX_PNG_DECODED_BYTES`]
/// of 16-bit samples).
pub const MAX_FITS_PIXELS: usize = MAX_PNG_DECODED_BYTES / 2;

/// Decodes a FITS file's primary HDU as digital counts: a 2-D image of
/// BITPIX 8 (unsigned bytes) or 16 (big-endian, plus BZERO: 32768 for the
/// unsigned counts gloam writes), BSCALE 1. Every value must land on a
/// count 0..=65535. Errors name the card or value at fault.
pub fn decode_fits_counts(bytes: &[u8]) -> Result<FitsCounts, String> {
    const BLOCK: usize = 2880;
    let mut cards = Vec::new();
    let mut cards_at: Vec<usize> = Vec::new();
    let mut end = None;
    for (i, card) in bytes
        .chunks_exact(80)
        .take(MAX_FITS_HEADER_BLOCKS * BLOCK / 80)
        .enumerate()
    {
        // Reached without an END card, this is the data unit: say so
        // (it was "header card 37 is not ASCII").
        let card = std::str::from_utf8(card).map_err(|_| {
            format!(
                "header card {} is not ASCII: the header has no END card before it",
                i + 1
            )
        })?;
        let key = card[..8].trim_end().to_string();
        if key == "END" {
            end = Some(i);
            break;
        }
        if &card[8..10] != "= " {
            continue; // COMMENT, HISTORY, blank
        }
        let v = card[10..].trim_start();
        let value = match v.strip_prefix('\'') {
            Some(s) => {
                // '' is a quote inside the string.
                let mut out = String::new();
                let mut it = s.chars().peekable();
                while let Some(c) = it.next() {
                    if c == '\'' {
                        if it.peek() == Some(&'\'') {
                            it.next();
                            out.push('\'');
                            continue;
                        }
                        break;
                    }
                    out.push(c);
                }
                out.trim_end().to_string()
            }
            None => v.split('/').next().unwrap_or("").trim().to_string(),
        };
        // A keyword given twice is refused, never resolved by order (the
        // first would win here, the last in another reader).
        if let Some(first) = cards.iter().position(|(k, _): &(String, String)| *k == key) {
            return Err(format!(
                "header card {} repeats {key} (first at card {}): one keyword, two values",
                i + 1,
                cards_at[first] + 1
            ));
        }
        cards.push((key, value));
        cards_at.push(i);
    }
    let end = end.ok_or_else(|| {
        format!(
            "no END card in the first {MAX_FITS_HEADER_BLOCKS} header blocks: not a FITS header"
        )
    })?;
    let get = |k: &str| {
        cards
            .iter()
            .find(|(key, _)| key == k)
            .map(|(_, v)| v.as_str())
    };
    let int = |k: &str| -> Result<i64, String> {
        let v = get(k).ok_or_else(|| format!("no {k} card"))?;
        v.parse::<i64>()
            .map_err(|_| format!("{k} = {v} is not an integer"))
    };
    if get("SIMPLE") != Some("T") {
        return Err("SIMPLE is not T: not a standard FITS file".into());
    }
    let bitpix = int("BITPIX")?;
    if int("NAXIS")? != 2 {
        return Err(format!(
            "NAXIS = {}: a frame is a 2-D image",
            get("NAXIS").unwrap_or("?")
        ));
    }
    let (w, h) = (int("NAXIS1")?, int("NAXIS2")?);
    if w < 1 || h < 1 || w.saturating_mul(h) > MAX_FITS_PIXELS as i64 {
        return Err(format!(
            "NAXIS1 × NAXIS2 = {w} × {h}: not a frame of 1 to {MAX_FITS_PIXELS} pixels"
        ));
    }
    let num = |k: &str, default: f64| -> Result<f64, String> {
        match get(k) {
            None => Ok(default),
            Some(v) => v
                .replace(['D', 'd'], "E")
                .parse::<f64>()
                .map_err(|_| format!("{k} = {v} is not a number")),
        }
    };
    let (bzero, bscale) = (num("BZERO", 0.0)?, num("BSCALE", 1.0)?);
    if bscale != 1.0 || bzero.fract() != 0.0 {
        return Err(format!(
            "BSCALE = {bscale}, BZERO = {bzero}: digital counts need BSCALE 1 and a whole BZERO"
        ));
    }
    let bytes_per = match bitpix {
        8 => 1,
        16 => 2,
        other => {
            return Err(format!(
                "BITPIX = {other}: digital counts are BITPIX 8 or 16"
            ));
        }
    };
    let n = (w * h) as usize;
    let data_at = (end * 80 + 80).div_ceil(BLOCK) * BLOCK;
    let data = bytes
        .get(data_at..)
        .filter(|d| d.len() >= n * bytes_per)
        .ok_or_else(|| {
            format!(
                "the data unit holds {} bytes, {w} × {h} pixels at BITPIX {bitpix} need {}",
                bytes.len().saturating_sub(data_at),
                n * bytes_per
            )
        })?;
    let zero = bzero as i64;
    let mut counts = Vec::with_capacity(n);
    for i in 0..n {
        let raw = if bytes_per == 1 {
            i64::from(data[i])
        } else {
            i64::from(i16::from_be_bytes([data[2 * i], data[2 * i + 1]]))
        };
        let c = raw + zero;
        let c = u16::try_from(c).map_err(|_| {
            format!(
                "pixel {i} (row {}, column {}) holds {c} after BZERO: not a count 0–65535",
                i / w as usize,
                i % w as usize
            )
        })?;
        counts.push(c);
    }
    Ok(FitsCounts {
        width: w as usize,
        height: h as usize,
        counts,
        cards,
    })
}

fn counts_of_grey(path: &Path, g: GreyImage) -> Result<(usize, usize, Vec<u16>), CalibError> {
    let mut out = Vec::with_capacity(g.data.len());
    for v in &g.data {
        if !(v.fract() == 0.0 && (0.0..=65535.0).contains(v)) {
            return Err(CalibError::file(
                path,
                format!("pixel value {v} is not a digital count (integer 0–65535)"),
            ));
        }
        out.push(*v as u16);
    }
    Ok((g.width, g.height, out))
}

/// Writes a 32-bit float grey TIFF.
pub fn write_tiff_f32(path: &Path, w: usize, h: usize, data: &[f32]) -> Result<(), CalibError> {
    write_tiff_f32_pages(path, w, h, &[data])
}

/// The ImageDescription `calibrate apply` gives its radiance TIFFs: how it
/// knows a file at its OUTPUT path is its own to replace.
pub const APPLIED_DESCRIPTION: &str = "gloam calibrate apply: band radiance, W m-2 sr-1";

/// Writes a 32-bit float grey TIFF with an ImageDescription, atomically.
pub fn write_tiff_f32_described(
    path: &Path,
    w: usize,
    h: usize,
    data: &[f32],
    description: &str,
) -> Result<(), CalibError> {
    Ok(gloam_io::tiff::write_f32_pages(
        path,
        w,
        h,
        &[data],
        Some(description),
    )?)
}

/// The ImageDescription of the TIFF at `path`; `None` when it is not a
/// readable TIFF or has none. Not an input (apply checks what it would
/// replace), so not noted.
pub fn tiff_description(path: &Path) -> Option<String> {
    let bytes = gloam_io::read_bounded(
        path,
        gloam_io::MAX_IMAGE_FILE_BYTES,
        &gloam_io::ReadLog::off(),
    )
    .ok()?;
    let mut d = tiff::decoder::Decoder::new(std::io::Cursor::new(bytes)).ok()?;
    d.get_tag_ascii_string(tiff::tags::Tag::ImageDescription)
        .ok()
}

/// Writes a multi-page 32-bit float grey TIFF, one `w × h` page per slice
/// (e.g. one per spectral band), atomically.
pub fn write_tiff_f32_pages(
    path: &Path,
    w: usize,
    h: usize,
    pages: &[&[f32]],
) -> Result<(), CalibError> {
    Ok(gloam_io::tiff::write_f32_pages(path, w, h, pages, None)?)
}

/// The line of `frames.jsonl` beside `image` that records it (for a
/// page of a TIFF stack, the line whose `stored.page` is `page`); None
/// when there is no `frames.jsonl` there or it has no line for the image.
/// `reads` notes the `frames.jsonl`.
pub fn frame_record(
    image: &Path,
    page: Option<u64>,
    reads: &gloam_io::ReadLog,
) -> Result<Option<FrameLine>, CalibError> {
    let jl = gloam_io::frames::beside(image);
    let Some(name) = image.file_name().and_then(|n| n.to_str()) else {
        return Ok(None);
    };
    if !jl.exists() {
        return Ok(None);
    }
    gloam_io::frames::find(&jl, name, page, reads).map_err(|e| frames_read_error(e, ""))
}

/// A `frames.jsonl` that does not read, as calibration words it;
/// `open_note` is appended to an error opening the file.
pub fn frames_read_error(e: gloam_io::frames::FramesReadError, open_note: &str) -> CalibError {
    use gloam_io::frames::FramesReadError as E;
    match e {
        E::Open { path, source } => CalibError::file(&path, format!("{source}{open_note}")),
        E::Read { path, source } => CalibError::file(&path, source),
        E::Json { path, line, source } => CalibError::file(&path, format!("line {line}: {source}")),
        E::Bom { path, line } => CalibError::Line {
            path,
            line,
            message: "starts with a byte-order mark (U+FEFF); only the file's first line may"
                .to_string(),
        },
        E::Twice {
            path,
            line,
            name,
            page,
            first,
        } => CalibError::Line {
            path,
            line,
            message: format!(
                "records {name}{} again (first at line {first}): one frame, two records",
                page.map_or(String::new(), |p| format!(" page {p}"))
            ),
        },
    }
}

/// Checks a frame's counts against the CRC-32C its `frames.jsonl` line
/// records (`pixels_crc32c`, of the counts as little-endian `u16`, as the
/// grabber checksums them): a frame altered since its capture, or another
/// frame's file under this one's name (another gain's), is refused naming
/// the file, the line and both CRCs. `Ok(false)`: the line records no CRC,
/// so nothing could be checked.
pub fn check_frame_crc(
    frame: &Path,
    frames_jsonl: &Path,
    record: &FrameLine,
    counts: &[u16],
) -> Result<bool, CalibError> {
    let line = record.line;
    let recorded = record.pixels_crc32c().map_err(|e| CalibError::Line {
        path: frames_jsonl.to_path_buf(),
        line,
        message: e.to_string(),
    })?;
    let Some(recorded) = recorded else {
        return Ok(false);
    };
    let actual = gloam_grabber::pixels_crc32c(counts);
    if actual != recorded {
        return Err(CalibError::FrameCrc {
            frame: frame.to_path_buf(),
            frames_jsonl: frames_jsonl.to_path_buf(),
            line,
            recorded,
            actual,
        });
    }
    Ok(true)
}

/// The gain recorded for `image` in the `frames.jsonl` beside it (lines
/// of JSON objects with at least `"file"` and `"gain"`), matched by file
/// name; `reads` notes the `frames.jsonl`.
pub fn gain_from_frames_jsonl(
    image: &Path,
    page: Option<u64>,
    reads: &gloam_io::ReadLog,
) -> Result<f64, CalibError> {
    let jl = gloam_io::frames::beside(image);
    // A name that is not UTF-8 has a name, but no JSON line can hold it:
    // it was called "no file name".
    let name = image
        .file_name()
        .ok_or_else(|| CalibError::file(image, "no file name"))?
        .to_str()
        .ok_or_else(|| {
            CalibError::file(
                image,
                "its file name is not UTF-8, so no frames.jsonl line can name it; pass --gain",
            )
        })?;
    let note = format!(" (needed for the gain of {name}; pass --gain to override)");
    match gloam_io::frames::find(&jl, name, page, reads).map_err(|e| frames_read_error(e, &note))? {
        Some(l) => l
            .number("gain")
            .ok_or_else(|| CalibError::file(&jl, format!("line {}: no numeric \"gain\"", l.line))),
        None => Err(CalibError::file(
            &jl,
            format!("no line for \"{name}\" (pass --gain to override)"),
        )),
    }
}

/// Checks that a frame's `frames.jsonl` line describes the frame read: its
/// `width`/`height`, `bits` (a depth in 1..=16), and `stored` (`format` the
/// file's, `sample_shift` 0 or 16 − bits). A line that contradicts its
/// frame is refused: its gain would be another frame's too.
pub fn check_record_fits_frame(
    frame: &Path,
    frames_jsonl: &Path,
    record: &FrameLine,
    width: usize,
    height: usize,
) -> Result<(), CalibError> {
    let at = |message: String| CalibError::Line {
        path: frames_jsonl.to_path_buf(),
        line: record.line,
        message: format!("{message} ({})", frame.display()),
    };
    for (key, actual) in [("width", width), ("height", height)] {
        if let Some(v) = record.get(key)
            && v.as_u64() != Some(actual as u64)
        {
            return Err(at(format!(
                "\"{key}\" {v} contradicts the frame, {width} × {height} pixels"
            )));
        }
    }
    let bits = (record.bits().map_err(|e| at(e.to_string()))?).map(u64::from);
    let Some(stored) = record.get("stored") else {
        return Ok(());
    };
    if let Some(v) = stored.get("sample_shift") {
        let ok = v
            .as_u64()
            .filter(|&s| s == 0 || bits.is_none_or(|b| s == 16 - b) && s < 16);
        if ok.is_none() {
            return Err(at(format!(
                "\"stored.sample_shift\" {v} is not 0{}",
                bits.map_or(" or a shift below 16".to_string(), |b| format!(
                    " or 16 − bits = {}",
                    16 - b
                ))
            )));
        }
    }
    if let Some(v) = stored.get("page")
        && v.as_u64().is_none()
    {
        return Err(at(format!("\"stored.page\" {v} is not a page number")));
    }
    if let Some(v) = stored.get("format") {
        let bytes = {
            let mut head = [0u8; 16];
            // The frame's own read noted it.
            let n = gloam_io::open_bounded(
                frame,
                gloam_io::MAX_IMAGE_FILE_BYTES,
                &gloam_io::ReadLog::off(),
            )
            .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
            .unwrap_or(0);
            head[..n].to_vec()
        };
        let actual = if bytes.starts_with(PNG_SIGNATURE) {
            "png"
        } else if is_fits(&bytes) {
            "fits"
        } else if is_tiff_bytes(&bytes) {
            "tiff"
        } else {
            "?"
        };
        if v.as_str() != Some(actual) {
            return Err(at(format!(
                "\"stored.format\" {v} contradicts the frame, a {actual} file"
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A FITS file by hand: `cards` (keyword, value text), END, then
    /// `data` padded to the block.
    fn fits(cards: &[(&str, &str)], data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        for (k, v) in cards {
            out.extend_from_slice(format!("{k:<8}= {v:>20}{:50}", "").as_bytes());
        }
        out.extend_from_slice(format!("{:<80}", "END").as_bytes());
        out.resize(out.len().div_ceil(2880) * 2880, b' ');
        out.extend_from_slice(data);
        out.resize(out.len().div_ceil(2880) * 2880, 0);
        out
    }

    const HEAD: [(&str, &str); 5] = [
        ("SIMPLE", "T"),
        ("BITPIX", "16"),
        ("NAXIS", "2"),
        ("NAXIS1", "2"),
        ("NAXIS2", "1"),
    ];

    #[test]
    fn fits_counts_come_back_through_bzero_and_bitpix_8() {
        // −32768 + 32768 = 0; 32767 + 32768 = 65535.
        let data = [0x80, 0x00, 0x7f, 0xff];
        let f =
            decode_fits_counts(&fits(&[&HEAD[..], &[("BZERO", "32768")]].concat(), &data)).unwrap();
        assert_eq!(f.counts, [0, 65535]);
        // No BZERO: signed values as they are; 258 fits, a negative does not.
        let f = decode_fits_counts(&fits(&HEAD, &[0x01, 0x02, 0x00, 0x07])).unwrap();
        assert_eq!(f.counts, [258, 7]);
        let e = decode_fits_counts(&fits(&HEAD, &[0xff, 0xff, 0, 0])).unwrap_err();
        assert!(e.contains("pixel 0 (row 0, column 0) holds -1"), "{e}");
        let mut b8 = HEAD;
        b8[1] = ("BITPIX", "8");
        assert_eq!(
            decode_fits_counts(&fits(&b8, &[200, 3])).unwrap().counts,
            [200, 3]
        );
    }

    #[test]
    fn fits_that_are_not_frames_are_refused_naming_the_card() {
        let with = |k: &str, v: &str| {
            let mut c: Vec<(&str, &str)> = HEAD.to_vec();
            match c.iter_mut().find(|(key, _)| *key == k) {
                Some(card) => card.1 = v,
                None => c.push((k, v)),
            }
            decode_fits_counts(&fits(&c, &[0; 8])).unwrap_err()
        };
        assert!(with("BITPIX", "-32").contains("BITPIX = -32"));
        assert!(with("NAXIS", "3").contains("NAXIS = 3"));
        assert!(with("NAXIS1", "1000000000").contains("1000000000 × 1"));
        assert!(with("NAXIS1", "x").contains("NAXIS1 = x is not an integer"));
        assert!(with("BSCALE", "2.0").contains("BSCALE = 2"));
        assert!(with("SIMPLE", "F").contains("SIMPLE is not T"));
        // A keyword given twice (issue 46): never resolved by order.
        let twice = [&HEAD[..], &[("BZERO", "32768"), ("BZERO", "0")]].concat();
        let e = decode_fits_counts(&fits(&twice, &[0; 8])).unwrap_err();
        assert!(e.contains("card 7 repeats BZERO (first at card 6)"), "{e}");
        // Data shorter than the header says.
        let short = fits(
            &[("NAXIS1", "3000")]
                .iter()
                .fold(HEAD.to_vec(), |mut c, (k, v)| {
                    c[3] = (k, v);
                    c
                }),
            &[],
        );
        let e = decode_fits_counts(&short).unwrap_err();
        assert!(e.contains("need 6000"), "{e}");
        // No END within the bound.
        let e = decode_fits_counts(&vec![b' '; 2880 * 70]).unwrap_err();
        assert!(e.contains("no END card"), "{e}");
        // No END before binary data (round 9): the header's missing END is
        // named, not only "card 37 is not ASCII".
        let mut no_end = fits(&HEAD, &[0xff; 8]);
        let end = no_end.windows(3).position(|w| w == b"END").unwrap();
        no_end[end..end + 3].copy_from_slice(b"   ");
        let e = decode_fits_counts(&no_end).unwrap_err();
        assert!(
            e.contains("header card 37") && e.contains("no END card"),
            "{e}"
        );
    }

    #[test]
    fn gloams_tiff_descriptions_state_the_shift() {
        let d = "12-bit counts left-bit-replicated to 16 bits: count = sample >> 4";
        assert_eq!(tiff_stated_shift(d), Some(4));
        assert_eq!(tiff_stated_shift("counts as they are (no scaling)"), None);
        assert_eq!(tiff_stated_shift("count = sample >> 99"), None);
    }
}
