//! Frame files: how a capture's counts are stored so that a person can
//! look at them in any viewer and a program reads the exact counts back.
//!
//! - **PNG** (default, `frame-NNNNNN.png`): 16-bit grey, the counts scaled
//!   to the full 16 bits by left-bit replication and an `sBIT` chunk
//!   declaring the camera's significant bits, as the PNG specification
//!   (§12.4) asks; a viewer shows the image at its true brightness and a
//!   reader recovers the counts as `sample >> (16 − bits)`
//!   ([`gloam_calib::io::decode_png_counts`]).
//! - **FITS** (`frame-NNNNNN.fits`): one primary HDU per frame, BITPIX 16
//!   with BZERO 32768 (unsigned counts, as they are), and a header with
//!   the frame's settings ([`gloam_io::fits::fits_frame_bytes`]).
//! - **TIFF** (`frames.tiff`): one 16-bit page per frame, the counts
//!   scaled to 16 bits by left-bit replication as in the PNGs (viewers
//!   ignore `MaxSampleValue`, so 12-bit counts as they are showed near
//!   black), the scale stated in each page's `ImageDescription` and in
//!   `frames.jsonl`'s `stored.sample_shift`.
//!
//! Beside them every capture writes `frames-preview.png`, an 8-bit
//! contact sheet of up to 16 frames picked evenly ([`ContactSheet`]).

use crate::output::OutputError;

pub use gloam_io::frames::{FrameFormat, TIFF_STACK, UnknownFrameFormat};

/// The contact sheet of a capture.
pub const PREVIEW: &str = "frames-preview.png";

pub use gloam_io::frames::FrameStorage;

/// The longest side of one frame in the contact sheet, pixels (larger
/// frames are box-averaged down by a whole factor).
pub const SHEET_TILE_PX: u32 = 512;

/// Space between tiles, pixels, and its grey (neither black nor white,
/// so empty and saturated frames both stand apart from it).
const SHEET_GAP_PX: u32 = 4;
const SHEET_GAP_GREY: u8 = 96;

/// One frame, scaled to 8 bits and shrunk for the sheet.
struct Tile {
    index: u64,
    width: u32,
    height: u32,
    grey: Vec<u8>,
}

/// `frames-preview.png`: up to `max_tiles` frames picked evenly from the
/// capture, each scaled linearly from its black level (0) to its clip
/// (255), in a grid. Frames arrive one at a time and their number is not
/// known in advance (a capture may stop early), so it keeps every
/// `stride`-th frame and doubles the stride whenever more than twice
/// `max_tiles` are kept: at most 2·`max_tiles` small tiles in memory.
pub struct ContactSheet {
    max_tiles: usize,
    stride: u64,
    kept: Vec<Tile>,
}

impl ContactSheet {
    pub fn new(max_tiles: usize) -> Self {
        Self {
            max_tiles: max_tiles.max(1),
            stride: 1,
            kept: Vec::new(),
        }
    }

    /// Offers frame `index` (counts `pixels`, black level and clip in DN).
    pub fn add(
        &mut self,
        index: u64,
        width: u32,
        height: u32,
        pixels: &[u16],
        black_dn: f64,
        clip_dn: f64,
    ) {
        if index % self.stride != 0 || pixels.len() != width as usize * height as usize {
            return;
        }
        self.kept
            .push(tile(index, width, height, pixels, black_dn, clip_dn));
        if self.kept.len() > 2 * self.max_tiles {
            self.stride *= 2;
            let s = self.stride;
            self.kept.retain(|t| t.index % s == 0);
        }
    }

    /// The indices of the frames the sheet shows, in order.
    pub fn shown(&self) -> Vec<u64> {
        self.picked().iter().map(|t| t.index).collect()
    }

    fn picked(&self) -> Vec<&Tile> {
        let n = self.kept.len();
        if n <= self.max_tiles {
            return self.kept.iter().collect();
        }
        // Evenly over the kept frames, first and last included; distinct
        // because n − 1 ≥ max_tiles − 1.
        let m = self.max_tiles;
        (0..m)
            .map(|k| {
                &self.kept[if m == 1 {
                    0
                } else {
                    (k * (n - 1) + (m - 1) / 2) / (m - 1)
                }]
            })
            .collect()
    }

    /// The sheet as an 8-bit grey PNG; None before any frame.
    pub fn png(&self) -> Result<Option<Vec<u8>>, OutputError> {
        let tiles = self.picked();
        if tiles.is_empty() {
            return Ok(None);
        }
        let cw = tiles.iter().map(|t| t.width).max().unwrap_or(1);
        let ch = tiles.iter().map(|t| t.height).max().unwrap_or(1);
        let cols = (tiles.len() as f64).sqrt().ceil() as u32;
        let rows = (tiles.len() as u32).div_ceil(cols);
        let (w, h) = (
            cols * cw + (cols - 1) * SHEET_GAP_PX,
            rows * ch + (rows - 1) * SHEET_GAP_PX,
        );
        let mut sheet = vec![SHEET_GAP_GREY; w as usize * h as usize];
        for (k, t) in tiles.iter().enumerate() {
            let (c, r) = (k as u32 % cols, k as u32 / cols);
            let (x0, y0) = (c * (cw + SHEET_GAP_PX), r * (ch + SHEET_GAP_PX));
            for y in 0..t.height {
                let src = &t.grey[(y * t.width) as usize..][..t.width as usize];
                let at = ((y0 + y) * w + x0) as usize;
                sheet[at..at + t.width as usize].copy_from_slice(src);
            }
        }
        let bytes = gloam_io::png::grey8_png(w, h, sheet)
            .ok_or(OutputError::PreviewSize)?
            .map_err(OutputError::Png)?;
        Ok(Some(bytes))
    }
}

/// 8-bit grey of a frame for people to look at: counts scaled from
/// `black_dn` (0) to `clip_dn` (255) — or over the 16-bit range when the
/// levels are unknown — box-averaged over `f × f` pixels. Returns the
/// reduced width, height and pixels.
pub(crate) fn scaled_grey(
    width: u32,
    height: u32,
    pixels: &[u16],
    black_dn: f64,
    clip_dn: f64,
    f: u32,
) -> (u32, u32, Vec<u8>) {
    let f = f.max(1);
    let (tw, th) = (width.div_ceil(f), height.div_ceil(f));
    let (black, span) = match clip_dn > black_dn {
        true => (black_dn, clip_dn - black_dn),
        false => (0.0, f64::from(u16::MAX)),
    };
    let mut grey = Vec::with_capacity(tw as usize * th as usize);
    for ty in 0..th {
        for tx in 0..tw {
            let (mut sum, mut n) = (0.0, 0u32);
            for y in ty * f..((ty + 1) * f).min(height) {
                for x in tx * f..((tx + 1) * f).min(width) {
                    sum += f64::from(pixels[(y * width + x) as usize]);
                    n += 1;
                }
            }
            let v = sum / f64::from(n.max(1));
            grey.push((255.0 * ((v - black) / span).clamp(0.0, 1.0)).round() as u8);
        }
    }
    (tw, th, grey)
}

/// A frame scaled from `black_dn` (0) to `clip_dn` (255) and box-averaged
/// down to at most [`SHEET_TILE_PX`] on its longest side.
fn tile(index: u64, width: u32, height: u32, pixels: &[u16], black_dn: f64, clip_dn: f64) -> Tile {
    let f = width.max(height).div_ceil(SHEET_TILE_PX).max(1);
    let (tw, th, grey) = scaled_grey(width, height, pixels, black_dn, clip_dn, f);
    Tile {
        index,
        width: tw,
        height: th,
        grey,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gloam_io::fits::*;
    use gloam_io::png::*;
    use gloam_io::tiff::*;

    fn counts_of(bits: u8, n: usize) -> Vec<u16> {
        // Every code's neighbourhood: 0, the top code and a spread between.
        let top = ((1u32 << bits) - 1) as u64;
        (0..n as u64)
            .map(|i| ((i * 2_654_435_761) % (top + 1)) as u16)
            .chain([0, top as u16])
            .collect()
    }

    #[test]
    fn png_frames_round_trip_exactly_at_8_12_and_16_bits() {
        for bits in [8u8, 12, 16] {
            let px = counts_of(bits, 7 * 5 - 2);
            let (bytes, shift) = png_frame_bytes(7, 5, bits, &px).unwrap();
            assert_eq!(shift, if bits == 16 { 0 } else { 16 - bits });
            // Read back by gloam's own reader: the exact counts and bits.
            let back = gloam_calib::io::decode_png_counts(&bytes).unwrap();
            assert_eq!((back.width, back.height, back.bits), (7, 5, bits));
            assert_eq!(back.counts, px, "{bits} bits");
            // An ordinary decoder (ignoring sBIT) sees the full 16-bit
            // range: the top code is white.
            let img = image::load_from_memory(&bytes).unwrap().into_luma16();
            let top = ((1u32 << bits) - 1) as u16;
            let i = px.iter().position(|&p| p == top).unwrap();
            assert_eq!(img.as_raw()[i], u16::MAX);
        }
    }

    /// TIFF pages hold the counts scaled as the PNGs do (the top code
    /// white in any viewer), the scale in the page's description; 16-bit
    /// counts and counts beyond the declared depth as they are.
    #[test]
    fn tiff_pages_scale_counts_to_16_bits_and_say_so() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(TIFF_STACK);
        let px12 = counts_of(12, 4);
        let px8 = counts_of(8, 4);
        let beyond = [0u16, 5000, 4095, 1, 2, 3];
        {
            let mut t = TiffStack::create(&path).unwrap();
            assert_eq!(t.append(3, 2, 12, &px12).unwrap(), (0, 4));
            assert_eq!(t.append(3, 2, 8, &px8).unwrap(), (1, 8));
            assert_eq!(t.append(3, 2, 12, &beyond).unwrap(), (2, 0));
        }
        let bytes = std::fs::read(&path).unwrap();
        let mut d = tiff::decoder::Decoder::new(std::io::Cursor::new(bytes)).unwrap();
        let page = |d: &mut tiff::decoder::Decoder<_>| {
            let desc = d
                .get_tag_ascii_string(tiff::tags::Tag::ImageDescription)
                .unwrap();
            let max = d.get_tag_u32(tiff::tags::Tag::MaxSampleValue).unwrap();
            match d.read_image().unwrap() {
                tiff::decoder::DecodingResult::U16(v) => (desc, max, v),
                other => panic!("not 16-bit: {other:?}"),
            }
        };
        let (desc, max, v) = page(&mut d);
        assert_eq!(
            desc,
            "12-bit counts left-bit-replicated to 16 bits: count = sample >> 4"
        );
        assert_eq!(max, 65_535);
        // v·16 + v/256: 4095 → 65 535.
        let want: Vec<u16> = px12.iter().map(|&c| c * 16 + c / 256).collect();
        assert_eq!(v, want);
        assert_eq!(v[px12.iter().position(|&c| c == 4095).unwrap()], u16::MAX);
        d.next_image().unwrap();
        let (desc, _, v) = page(&mut d);
        assert!(desc.contains("sample >> 8"), "{desc}");
        assert_eq!(v, px8.iter().map(|&c| c * 257).collect::<Vec<_>>());
        d.next_image().unwrap();
        let (desc, _, v) = page(&mut d);
        assert_eq!(desc, "counts as they are (no scaling)");
        assert_eq!(v, beyond);
        assert!(!d.more_images());
    }

    #[test]
    fn counts_beyond_the_declared_bits_are_stored_unscaled() {
        let px = [0u16, 4095, 5000];
        let (bytes, shift) = png_frame_bytes(3, 1, 12, &px).unwrap();
        assert_eq!(shift, 0);
        let back = gloam_calib::io::decode_png_counts(&bytes).unwrap();
        assert_eq!((back.bits, back.counts), (16, px.to_vec()));
    }

    /// gloam's readers (`calibrate apply`, `agc --sequence`) take back
    /// what every writer stored: FITS through BZERO, each TIFF page by its
    /// shift, the exact counts at 8, 12 and 16 bits.
    #[test]
    fn the_readers_return_the_counts_of_every_format_written() {
        use gloam_calib::io::{StoredAt, TiffPages, decode_fits_counts, read_frame_counts};
        let card = [FitsCard::new("TUBEGAIN", FitsValue::Float(20.0), "")];
        let edge: Vec<u16> = vec![0, 1, 4095, 32767, 32768, 65535];
        let f = decode_fits_counts(&fits_frame_bytes(3, 2, &edge, &card)).unwrap();
        assert_eq!((f.width, f.height, &f.counts), (3, 2, &edge));
        assert!(f.cards.contains(&("TUBEGAIN".into(), "2.0E1".into())));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(TIFF_STACK);
        let stacks = [
            (12u8, counts_of(12, 10)),
            (8, counts_of(8, 10)),
            (16, counts_of(16, 10)),
        ];
        let mut shifts = Vec::new();
        {
            let mut t = TiffStack::create(&path).unwrap();
            for (bits, px) in &stacks {
                shifts.push(t.append(4, 3, *bits, px).unwrap().1);
            }
        }
        assert_eq!(shifts, [4, 8, 0]);
        let mut pages = TiffPages::open(&path, &gloam_io::ReadLog::off()).unwrap();
        // Out of order: the reader goes back to an earlier page.
        for k in [1usize, 2, 0, 2] {
            // By the shift frames.jsonl records, and by the one the page's
            // description states.
            for shift in [Some(shifts[k]), None] {
                let at = StoredAt {
                    page: Some(k as u64),
                    sample_shift: shift,
                };
                assert_eq!(
                    pages.counts(&at).unwrap(),
                    (4, 3, stacks[k].1.clone()),
                    "page {k}"
                );
            }
        }
        // A stack must be given its page.
        let e = read_frame_counts(&path, &StoredAt::default(), &gloam_io::ReadLog::off())
            .unwrap_err()
            .to_string();
        assert!(e.contains("holds 3 pages"), "{e}");
        let e = pages
            .counts(&StoredAt {
                page: Some(3),
                sample_shift: None,
            })
            .unwrap_err()
            .to_string();
        assert!(e.contains("no page 3: the TIFF holds 3 page(s)"), "{e}");
    }

    #[test]
    fn the_sheet_picks_frames_evenly_and_scales_black_to_clip() {
        let mut s = ContactSheet::new(4);
        for i in 0..100u64 {
            s.add(i, 2, 1, &[100, 1100], 100.0, 1100.0);
        }
        let shown = s.shown();
        assert_eq!(shown.len(), 4);
        assert_eq!(shown[0], 0);
        assert!(shown.windows(2).all(|w| w[1] > w[0]));
        assert!(shown[3] >= 64, "{shown:?}");
        let png = s.png().unwrap().unwrap();
        let img = image::load_from_memory(&png).unwrap().into_luma8();
        assert_eq!(img.dimensions(), (2 * 2 + SHEET_GAP_PX, 2 + SHEET_GAP_PX));
        // Black level → 0, clip → 255.
        assert_eq!(
            (img.get_pixel(0, 0).0[0], img.get_pixel(1, 0).0[0]),
            (0, 255)
        );
        assert_eq!(img.get_pixel(2, 0).0[0], SHEET_GAP_GREY);
        // Few frames: all of them.
        let mut few = ContactSheet::new(16);
        for i in 0..3 {
            few.add(i, 1, 1, &[5], 0.0, 10.0);
        }
        assert_eq!(few.shown(), vec![0, 1, 2]);
    }

    #[test]
    fn large_frames_shrink_to_the_tile_size() {
        let t = tile(0, 1030, 10, &vec![50u16; 10_300], 0.0, 100.0);
        assert_eq!((t.width, t.height), (344, 4));
        assert!(t.grey.iter().all(|&g| g == 128));
    }
}
