//! Image files for the CLI-facing flows: digital-count images (PNG/TIFF,
//! 8 or 16 bit grey), float images (TIFF 32-bit float, or any of the
//! former), 32-bit float TIFF output, and the per-frame gain recorded in
//! `frames.jsonl` by `gloam capture`.

use std::io::BufRead;
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

/// Reads a grey image of any supported depth (u8, u16, f32 TIFF, …).
pub fn read_grey(path: &Path) -> Result<GreyImage, CalibError> {
    if is_tiff(path) {
        let bytes =
            gloam_spectra::input::read_bounded(path, gloam_spectra::input::MAX_IMAGE_FILE_BYTES)
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
    let bytes =
        gloam_spectra::input::read_bounded(path, gloam_spectra::input::MAX_IMAGE_FILE_BYTES)
            .map_err(|e| CalibError::file(path, e))?;
    if bytes.starts_with(PNG_SIGNATURE) {
        let p = decode_png_counts(&bytes).map_err(|e| CalibError::file(path, e))?;
        return Ok(GreyImage {
            width: p.width as usize,
            height: p.height as usize,
            data: p.counts.into_iter().map(f64::from).collect(),
        });
    }
    let img = image::load_from_memory(&bytes).map_err(|e| CalibError::file(path, e))?;
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
        Some([b]) if (1..=depth).contains(b) => *b,
        _ => depth,
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

/// Reads a digital-count image (integers 0..=65535).
pub fn read_counts(path: &Path) -> Result<(usize, usize, Vec<u16>), CalibError> {
    let g = read_grey(path)?;
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
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut enc =
            tiff::encoder::TiffEncoder::new(&mut buf).map_err(|e| CalibError::file(path, e))?;
        let mut image = enc
            .new_image::<tiff::encoder::colortype::Gray32Float>(w as u32, h as u32)
            .map_err(|e| CalibError::file(path, e))?;
        image
            .encoder()
            .write_tag(tiff::tags::Tag::ImageDescription, description)
            .map_err(|e| CalibError::file(path, e))?;
        image
            .write_data(data)
            .map_err(|e| CalibError::file(path, e))?;
    }
    crate::report::write_bytes(path, buf.get_ref())
}

/// The ImageDescription of the TIFF at `path`; `None` when it is not a
/// readable TIFF or has none.
pub fn tiff_description(path: &Path) -> Option<String> {
    let bytes =
        gloam_spectra::input::read_bounded(path, gloam_spectra::input::MAX_IMAGE_FILE_BYTES)
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
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut enc =
            tiff::encoder::TiffEncoder::new(&mut buf).map_err(|e| CalibError::file(path, e))?;
        for page in pages {
            enc.write_image::<tiff::encoder::colortype::Gray32Float>(w as u32, h as u32, page)
                .map_err(|e| CalibError::file(path, e))?;
        }
    }
    crate::report::write_bytes(path, buf.get_ref())
}

/// The line of `frames.jsonl` beside `image` that records it, with its
/// 1-based line number; None when there is no `frames.jsonl` there or it
/// has no line for the image.
pub fn frame_record(image: &Path) -> Result<Option<(usize, serde_json::Value)>, CalibError> {
    let jl = image
        .parent()
        .unwrap_or(Path::new("."))
        .join("frames.jsonl");
    let Some(name) = image.file_name().and_then(|n| n.to_str()) else {
        return Ok(None);
    };
    if !jl.exists() {
        return Ok(None);
    }
    find_record(&jl, name, "")
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
    line: usize,
    record: &serde_json::Value,
    counts: &[u16],
) -> Result<bool, CalibError> {
    let Some(v) = record.get("pixels_crc32c") else {
        return Ok(false);
    };
    let at = |message: String| CalibError::Line {
        path: frames_jsonl.to_path_buf(),
        line,
        message,
    };
    let recorded = v
        .as_u64()
        .and_then(|c| u32::try_from(c).ok())
        .ok_or_else(|| {
            at(format!(
                "\"pixels_crc32c\" {v} is not a CRC-32C (a whole number below 2^32)"
            ))
        })?;
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
/// name.
pub fn gain_from_frames_jsonl(image: &Path) -> Result<f64, CalibError> {
    let jl = image
        .parent()
        .unwrap_or(Path::new("."))
        .join("frames.jsonl");
    let name = image
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(|| CalibError::file(image, "no file name"))?;
    let note = format!(" (needed for the gain of {name}; pass --gain to override)");
    match find_record(&jl, name, &note)? {
        Some((i, v)) => v
            .get("gain")
            .and_then(|g| g.as_f64())
            .ok_or_else(|| CalibError::file(&jl, format!("line {i}: no numeric \"gain\""))),
        None => Err(CalibError::file(
            &jl,
            format!("no line for \"{name}\" (pass --gain to override)"),
        )),
    }
}

/// The first line of the frames file `jl` whose `"file"` is `name`, with
/// its 1-based number (blank lines skipped); `open_note` is appended to an
/// error opening the file.
fn find_record(
    jl: &Path,
    name: &str,
    open_note: &str,
) -> Result<Option<(usize, serde_json::Value)>, CalibError> {
    let f = gloam_spectra::input::open_bounded(jl, gloam_spectra::input::MAX_TEXT_FILE_BYTES)
        .map_err(|e| CalibError::file(jl, format!("{e}{open_note}")))?;
    for (i, line) in std::io::BufReader::new(f).lines().enumerate() {
        let line = line.map_err(|e| CalibError::file(jl, e))?;
        if line.trim().is_empty() {
            continue;
        }
        let v: serde_json::Value = serde_json::from_str(&line)
            .map_err(|e| CalibError::file(jl, format!("line {}: {e}", i + 1)))?;
        if v.get("file").and_then(|f| f.as_str()) == Some(name) {
            return Ok(Some((i + 1, v)));
        }
    }
    Ok(None)
}
