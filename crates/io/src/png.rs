//! PNG encoders: 16-bit grey frames whose counts come back exactly, and
//! the 8-bit grey and RGB images people look at (previews, contact
//! sheets, plots).

use std::path::PathBuf;

use crate::EncodeError;

/// `v` (a `bits`-bit count) scaled to 16 bits by left-bit replication:
/// the count's bits repeated down to the last bit, so 0 stays 0, the top
/// code becomes 65 535, and `result >> (16 − bits)` is `v` again.
pub fn replicate_to_16(v: u16, bits: u8) -> u16 {
    let bits = u32::from(bits.clamp(1, 16));
    let v = u32::from(v) & ((1 << bits) - 1);
    let mut out = 0u32;
    let mut filled = 0u32;
    // At most 16 rounds (bits ≥ 1).
    while filled < 16 {
        let shift = 16i32 - (filled + bits) as i32;
        out |= if shift >= 0 {
            v << shift
        } else {
            v >> (-shift)
        };
        filled += bits;
    }
    out as u16
}

/// A 16-bit grey PNG of a frame's counts, and the shift that recovers
/// them. With `bits` < 16 and every count below 2^bits, the samples are
/// left-bit-replicated to 16 bits with `sBIT` = bits (shift 16 − bits);
/// otherwise (16-bit cameras, or a device that sent counts beyond its
/// declared depth) the counts are stored as they are, without `sBIT`
/// (shift 0), so nothing is ever lost.
pub fn png_frame_bytes(
    width: u32,
    height: u32,
    bits: u8,
    pixels: &[u16],
) -> Result<(Vec<u8>, u8), EncodeError> {
    let (samples, shift) = scaled_to_16(bits, pixels);
    let fits_bits = shift != 0;
    let be: Vec<u8> = samples.iter().flat_map(|s| s.to_be_bytes()).collect();
    let mut bytes = Vec::with_capacity(be.len() / 2 + 1024);
    let enc_err = |e: png::EncodingError| EncodeError {
        path: PathBuf::from("frame PNG"),
        source: Box::new(e),
    };
    {
        let mut enc = png::Encoder::new(&mut bytes, width, height);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Sixteen);
        let note = if fits_bits {
            format!(
                "{bits}-bit counts left-bit-replicated to 16 bits (sBIT {bits}): count = sample >> {shift}"
            )
        } else {
            "counts as they are (no scaling)".to_string()
        };
        enc.add_text_chunk("Comment".into(), note)
            .map_err(enc_err)?;
        enc.add_text_chunk(
            "Software".into(),
            format!("gloam {}", env!("CARGO_PKG_VERSION")),
        )
        .map_err(enc_err)?;
        let mut w = enc.write_header().map_err(enc_err)?;
        if fits_bits {
            // sBIT must precede IDAT: declared right after the header.
            w.write_chunk(png::chunk::sBIT, &[bits]).map_err(enc_err)?;
        }
        w.write_image_data(&be).map_err(enc_err)?;
        w.finish().map_err(enc_err)?;
    }
    Ok((bytes, shift))
}

/// The 16-bit samples PNG and TIFF frames store for `bits`-bit counts,
/// and the shift that recovers the counts: left-bit-replicated
/// ([`replicate_to_16`], shift 16 − bits) when `bits` < 16 and every count
/// is below 2^bits; otherwise the counts as they are (shift 0), so a
/// device that sent counts beyond its declared depth loses nothing.
pub fn scaled_to_16(bits: u8, pixels: &[u16]) -> (std::borrow::Cow<'_, [u16]>, u8) {
    if (1..16).contains(&bits) && pixels.iter().all(|&p| p >> bits == 0) {
        let s = pixels.iter().map(|&p| replicate_to_16(p, bits)).collect();
        (std::borrow::Cow::Owned(s), 16 - bits)
    } else {
        (std::borrow::Cow::Borrowed(pixels), 0)
    }
}

/// An 8-bit grey PNG of `width × height` row-major `pixels`; `None` when
/// the buffer is not that size.
pub fn grey8_png(
    width: u32,
    height: u32,
    pixels: Vec<u8>,
) -> Option<Result<Vec<u8>, image::ImageError>> {
    Some(encode_png(image::GrayImage::from_raw(
        width, height, pixels,
    )?))
}

/// An 8-bit RGB PNG of `width × height` row-major RGB `pixels`; `None`
/// when the buffer is not that size.
pub fn rgb8_png(
    width: u32,
    height: u32,
    pixels: Vec<u8>,
) -> Option<Result<Vec<u8>, image::ImageError>> {
    Some(encode_png(image::RgbImage::from_raw(
        width, height, pixels,
    )?))
}

/// The PNG file bytes of an image.
fn encode_png(img: impl Into<image::DynamicImage>) -> Result<Vec<u8>, image::ImageError> {
    let mut bytes = Vec::new();
    img.into()
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map(|()| bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replication_repeats_the_bits_and_shifts_back_exactly() {
        // Closed forms: 8 bits → v·257; 12 bits → v·16 + v>>8; 16 → v.
        for v in 0..=255u16 {
            assert_eq!(replicate_to_16(v, 8), v * 257);
        }
        for v in 0..4096u16 {
            let r = replicate_to_16(v, 12);
            assert_eq!(r, (v << 4) | (v >> 8));
            assert_eq!(r >> 4, v);
        }
        assert_eq!(replicate_to_16(0x2AB, 10), (0x2AB << 6) | (0x2AB >> 4));
        assert_eq!(replicate_to_16(1, 1), 0xFFFF);
        assert_eq!(replicate_to_16(5, 3), 0b1011_0110_1101_1011);
        assert_eq!(replicate_to_16(54_321, 16), 54_321);
        // The top code is white, zero black.
        for bits in 1..=16u8 {
            let top = ((1u32 << bits) - 1) as u16;
            assert_eq!(replicate_to_16(top, bits), u16::MAX);
            assert_eq!(replicate_to_16(0, bits), 0);
        }
    }
}
