//! FITS frames: one primary HDU of unsigned 16-bit counts with a header
//! of fixed-format cards (FITS standard 4.0).

/// One FITS header value.
#[derive(Clone, Debug, PartialEq)]
pub enum FitsValue {
    Bool(bool),
    Int(i128),
    Float(f64),
    Str(String),
}

/// One 80-character header card: keyword (≤ 8 characters of A–Z, 0–9,
/// `-`, `_`), value and comment.
#[derive(Clone, Debug, PartialEq)]
pub struct FitsCard {
    pub key: &'static str,
    pub value: FitsValue,
    pub comment: &'static str,
}

impl FitsCard {
    pub fn new(key: &'static str, value: FitsValue, comment: &'static str) -> Self {
        Self {
            key,
            value,
            comment,
        }
    }

    /// The card in the fixed format of the FITS standard (4.0, §4.2):
    /// `= ` in columns 9–10, numbers and logicals right-justified to
    /// column 30, strings quoted from column 11; printable ASCII only.
    fn text(&self) -> String {
        let value = match &self.value {
            FitsValue::Bool(b) => format!("{:>20}", if *b { "T" } else { "F" }),
            FitsValue::Int(i) => format!("{i:>20}"),
            FitsValue::Float(x) => format!("{:>20}", fits_float(*x)),
            FitsValue::Str(s) => {
                // 68 characters fit between the quotes of one card; a
                // quote is written twice, never split.
                let mut clean = String::new();
                for c in s.chars() {
                    let c = if (' '..='~').contains(&c) { c } else { '?' };
                    let add = if c == '\'' {
                        "''".to_string()
                    } else {
                        c.to_string()
                    };
                    if clean.len() + add.len() > 68 {
                        break;
                    }
                    clean.push_str(&add);
                }
                format!("'{clean:<8}'")
            }
        };
        let mut card = format!("{:<8}= {value}", self.key);
        // A comment that does not fit whole is left out, not cut.
        if !self.comment.is_empty() && card.len() + 3 + self.comment.len() <= 80 {
            card.push_str(" / ");
            card.push_str(self.comment);
        }
        let mut card: String = card.chars().take(80).collect();
        while card.len() < 80 {
            card.push(' ');
        }
        card
    }
}

/// A float as FITS writes it: Rust's shortest round-trip digits with an
/// upper-case exponent and a decimal point (`2.0E1`); NaN and infinities,
/// which FITS has no literal for, are written as strings by the caller.
fn fits_float(x: f64) -> String {
    let s = format!("{x:E}");
    match s.split_once('E') {
        Some((m, e)) if !m.contains('.') => format!("{m}.0E{e}"),
        _ => s,
    }
}

/// The FITS block: headers and data are padded to multiples of it.
pub const FITS_BLOCK: usize = 2880;

/// A FITS file of one frame: a primary HDU of `width × height` unsigned
/// 16-bit counts (BITPIX 16, BZERO 32768: stored value = count − 32768,
/// big-endian), row 0 of `pixels` first, with `cards` after the mandatory
/// keywords. Non-finite floats are written as strings.
pub fn fits_frame_bytes(width: u32, height: u32, pixels: &[u16], cards: &[FitsCard]) -> Vec<u8> {
    let mandatory = [
        FitsCard::new("SIMPLE", FitsValue::Bool(true), "conforms to FITS"),
        FitsCard::new("BITPIX", FitsValue::Int(16), "16-bit integers"),
        FitsCard::new("NAXIS", FitsValue::Int(2), "an image"),
        FitsCard::new("NAXIS1", FitsValue::Int(width.into()), "columns"),
        FitsCard::new("NAXIS2", FitsValue::Int(height.into()), "rows"),
        FitsCard::new("BZERO", FitsValue::Int(32768), "unsigned 16-bit counts"),
        FitsCard::new("BSCALE", FitsValue::Int(1), ""),
    ];
    let mut out = Vec::with_capacity(FITS_BLOCK * 2 + pixels.len() * 2);
    for c in mandatory.iter().chain(cards) {
        let c = match &c.value {
            FitsValue::Float(x) if !x.is_finite() => {
                FitsCard::new(c.key, FitsValue::Str(x.to_string()), c.comment)
            }
            _ => c.clone(),
        };
        out.extend_from_slice(c.text().as_bytes());
    }
    out.extend_from_slice(format!("{:<80}", "END").as_bytes());
    pad_to_block(&mut out, b' ');
    for &p in pixels {
        // count − 32768 as a two's-complement i16 is the count with its
        // top bit flipped.
        out.extend_from_slice(&(p ^ 0x8000).to_be_bytes());
    }
    pad_to_block(&mut out, 0);
    out
}

fn pad_to_block(v: &mut Vec<u8>, fill: u8) {
    let n = v.len().div_ceil(FITS_BLOCK) * FITS_BLOCK;
    v.resize(n, fill);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_cards_follow_the_fixed_format() {
        let c = FitsCard::new("GAIN", FitsValue::Float(20.0), "tube gain");
        let t = c.text();
        assert_eq!(t.len(), 80);
        assert_eq!(&t[..10], "GAIN    = ");
        assert_eq!(&t[10..30], format!("{:>20}", "2.0E1"));
        assert_eq!(&t[30..44], " / tube gain  ");
        let s = FitsCard::new("CAMERA", FitsValue::Str("it's".into()), "").text();
        assert_eq!(s.trim_end(), "CAMERA  = 'it''s   '");
        let long = FitsCard::new("INPUT1", FitsValue::Str("'".repeat(50)), "x").text();
        assert_eq!(long.len(), 80);
        assert_eq!(long.trim_end(), format!("INPUT1  = '{}'", "''".repeat(34)));
        assert_eq!(fits_float(1.25e-5), "1.25E-5");
        assert_eq!(fits_float(0.0), "0.0E0");
        assert_eq!(
            FitsCard::new("AGC", FitsValue::Bool(false), "").text()[10..30],
            format!("{:>20}", "F")
        );
    }

    /// An independent reading of the header: 80-column cards up to END.
    fn header(bytes: &[u8]) -> Vec<(String, String)> {
        let mut out = Vec::new();
        for card in bytes.chunks(80) {
            let card = std::str::from_utf8(card).unwrap();
            if card.starts_with("END ") {
                break;
            }
            let (k, rest) = card.split_at(8);
            let v = rest.strip_prefix("= ").unwrap_or(rest);
            let v = if v.trim_start().starts_with('\'') {
                v.trim().split('\'').nth(1).unwrap().trim_end().to_string()
            } else {
                v.split(" /").next().unwrap().trim().to_string()
            };
            out.push((k.trim().to_string(), v));
        }
        out
    }

    #[test]
    fn a_fits_frame_is_blocked_and_its_counts_come_back_through_bzero() {
        let px: Vec<u16> = vec![0, 1, 4095, 32768, 65535, 7];
        let cards = [FitsCard::new("EXPTIME", FitsValue::Float(0.04), "s")];
        let b = fits_frame_bytes(3, 2, &px, &cards);
        assert_eq!(b.len() % FITS_BLOCK, 0);
        assert_eq!(b.len(), 2 * FITS_BLOCK);
        let h = header(&b);
        let get = |k: &str| h.iter().find(|(key, _)| key == k).unwrap().1.clone();
        assert_eq!(h[0], ("SIMPLE".into(), "T".into()));
        assert_eq!(
            (get("BITPIX"), get("NAXIS"), get("NAXIS1"), get("NAXIS2")),
            ("16".into(), "2".into(), "3".into(), "2".into())
        );
        assert_eq!(get("BZERO"), "32768");
        assert_eq!(get("EXPTIME").parse::<f64>().unwrap(), 0.04);
        // The data: big-endian i16 from the second block, + BZERO.
        let data = &b[FITS_BLOCK..];
        let back: Vec<u16> = data
            .chunks(2)
            .take(6)
            .map(|c| (i32::from(i16::from_be_bytes([c[0], c[1]])) + 32768) as u16)
            .collect();
        assert_eq!(back, px);
        assert!(data[12..].iter().all(|&z| z == 0));
    }
}
