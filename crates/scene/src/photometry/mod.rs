//! Measured luminaires: IES LM-63 (1991/1995/2002) and EULUMDAT (`.ldt`)
//! photometric files read into one [`Photometry`] table — candela over
//! (vertical angle γ from nadir, C-plane angle) — evaluated by bilinear
//! interpolation in those two angles.
//!
//! Both formats are photometric (candela, or cd/klm × lamp flux): the scene
//! supplies the spectral shape and scales it so its luminous intensity
//! (683 lm/W · ∫V(λ)S(λ)dλ) equals the file's candela value in each
//! direction. Files are read through `gloam_io` (bounded,
//! regular files only); every count is checked against the numbers the file
//! actually holds before anything is allocated, and every refusal names
//! file, line and field.

mod ies;
mod ldt;

use std::path::Path;

/// Largest photometric file read, bytes (real files are < 1 MiB).
pub const MAX_PHOTOMETRY_FILE_BYTES: u64 = 16 << 20;
/// Most vertical or horizontal angles one file may list.
pub const MAX_ANGLES: usize = 100_000;
/// Most candela values one file may hold.
pub const MAX_VALUES: usize = 4_000_000;
/// Largest candela value (after every multiplier) accepted.
pub const MAX_CANDELA: f64 = 1e15;

/// Why a photometric file could not be read; `Display` is
/// `file:line: field: message`.
#[derive(Debug, thiserror::Error)]
pub enum PhotometryError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}:{line}: {field}: {msg}")]
    Parse {
        path: String,
        line: usize,
        field: String,
        msg: String,
    },
}

/// How the stored C-planes cover the full circle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Symmetry {
    /// One plane: the same in every C-plane.
    Rotational,
    /// C0–C90 stored; mirrored about the C0–C180 and C90–C270 planes.
    Quadrant,
    /// C0–C180 stored; mirrored about the C0–C180 plane.
    BilateralC0,
    /// C90–C270 stored; mirrored about the C90–C270 plane.
    BilateralC90,
    /// The full circle stored (the last plane may stop short of 360°; the
    /// gap to 360° = 0° is interpolated).
    Full,
}

/// Which format a file was read as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Ies,
    Eulumdat,
}

/// TILT=INCLUDE: the multiplier on the whole distribution as a function of
/// the luminaire's tilt from its photometered orientation.
#[derive(Clone, Debug, PartialEq)]
pub struct TiltTable {
    /// Lamp-to-luminaire geometry (1: vertical lamp, 2/3: horizontal lamp;
    /// gloam applies the table against the nadir's tilt from straight down
    /// for every geometry).
    pub geometry: u32,
    pub angles_deg: Vec<f64>,
    pub factors: Vec<f64>,
}

impl TiltTable {
    /// The multiplier at `tilt_deg`, linear between entries and held at
    /// the end values outside them.
    pub fn factor(&self, tilt_deg: f64) -> f64 {
        interp_clamped(&self.angles_deg, &self.factors, tilt_deg)
    }

    /// The multiplier for a luminaire whose nadir is unit `nadir`: at its
    /// tilt from straight down (−z), as gloam applies every geometry.
    pub fn factor_for_nadir(&self, nadir: glam::DVec3) -> f64 {
        self.factor(
            nadir
                .dot(glam::DVec3::NEG_Z)
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees(),
        )
    }
}

/// A measured intensity distribution, type C photometry: γ = 0° is the
/// luminaire's nadir, C-plane angles run counter-clockwise seen from above
/// (C90 = C0 turned 90° about the upward axis).
#[derive(Clone, Debug, PartialEq)]
pub struct Photometry {
    pub format: Format,
    /// Vertical angles γ, degrees, strictly increasing within [0, 180].
    pub vertical_deg: Vec<f64>,
    /// Stored C-plane angles, degrees, strictly increasing.
    pub horizontal_deg: Vec<f64>,
    pub symmetry: Symmetry,
    /// Candela, every multiplier applied: plane `h`, vertical angle `v` at
    /// `h * vertical_deg.len() + v`.
    pub candela: Vec<f64>,
    /// The largest value in `candela`.
    pub max_candela: f64,
    /// The flux the header states, lm: the rated lamp flux for an IES file
    /// (lamps × lumens per lamp; `None` for absolute photometry, −1), the
    /// luminaire flux (lamp flux × light output ratio) for EULUMDAT.
    pub header_lumens: Option<f64>,
    pub tilt: Option<TiltTable>,
}

impl Photometry {
    /// Reads an IES or EULUMDAT file, by its extension (`.ies` / `.ldt`,
    /// any case), noting it in `reads`.
    pub fn read(path: &Path, reads: &gloam_io::ReadLog) -> Result<Self, PhotometryError> {
        let name = path.display().to_string();
        let text =
            gloam_io::read_text(path, MAX_PHOTOMETRY_FILE_BYTES, reads).map_err(|source| {
                PhotometryError::Io {
                    path: name.clone(),
                    source,
                }
            })?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("ldt") => Self::parse_ldt(&text, &name),
            Some("ies") => Self::parse_ies(&text, &name),
            _ => Err(PhotometryError::Parse {
                path: name,
                line: 0,
                field: "file".into(),
                msg: "unknown photometric format: the name must end in .ies (IES LM-63) or .ldt (EULUMDAT)".into(),
            }),
        }
    }

    /// Parses IES LM-63 text; `path` names it in errors.
    pub fn parse_ies(text: &str, path: &str) -> Result<Self, PhotometryError> {
        ies::parse(text, path)
    }

    /// Parses EULUMDAT text; `path` names it in errors.
    pub fn parse_ldt(text: &str, path: &str) -> Result<Self, PhotometryError> {
        ldt::parse(text, path)
    }

    /// Candela toward vertical angle `gamma_deg` (from nadir) in C-plane
    /// `c_deg`: bilinear in (γ, C) between the table's nodes, the stored
    /// planes folded by the symmetry; zero outside the vertical range.
    pub fn candela_at(&self, gamma_deg: f64, c_deg: f64) -> f64 {
        let nv = self.vertical_deg.len();
        let Some((v0, tv)) = bracket(&self.vertical_deg, gamma_deg) else {
            return 0.0;
        };
        let at = |h: usize| {
            let row = &self.candela[h * nv..(h + 1) * nv];
            if tv == 0.0 {
                row[v0]
            } else {
                row[v0] + tv * (row[v0 + 1] - row[v0])
            }
        };
        let hs = &self.horizontal_deg;
        if self.symmetry == Symmetry::Rotational || hs.len() == 1 {
            return at(0);
        }
        let c = fold(self.symmetry, c_deg.rem_euclid(360.0));
        let last = hs.len() - 1;
        if self.symmetry == Symmetry::Full && !(c >= hs[0] && c <= hs[last]) {
            // The wrap from the last plane to the first + 360°.
            let (a, b) = (hs[last], hs[0] + 360.0);
            let c = if c < hs[0] { c + 360.0 } else { c };
            let t = if b > a { (c - a) / (b - a) } else { 0.0 };
            let (x, y) = (at(last), at(0));
            return x + t.clamp(0.0, 1.0) * (y - x);
        }
        match bracket(hs, c.clamp(hs[0], hs[last])) {
            Some((h0, th)) if th > 0.0 => {
                let (x, y) = (at(h0), at(h0 + 1));
                x + th * (y - x)
            }
            Some((h0, _)) => at(h0),
            None => 0.0,
        }
    }

    /// The largest vertical angle, degrees, toward which the interpolated
    /// distribution may be non-zero: beyond it every plane is zero (the
    /// light tree's emission cone).
    pub fn support_deg(&self) -> f64 {
        let nv = self.vertical_deg.len();
        let lit = |v: usize| (0..self.horizontal_deg.len()).any(|h| self.candela[h * nv + v] > 0.0);
        match (0..nv).rev().find(|&v| lit(v)) {
            Some(v) if v + 1 < nv => self.vertical_deg[v + 1],
            Some(v) => self.vertical_deg[v],
            None => 0.0,
        }
    }

    /// Total luminous flux, lm: ∮ I dΩ of the interpolated distribution,
    /// integrated exactly in γ (I is linear in γ between nodes, so each
    /// interval's ∫ I sin γ dγ has a closed form) and by the trapezoid rule
    /// in C (exact, as I is linear in C between planes).
    pub fn flux_lm(&self) -> f64 {
        let nv = self.vertical_deg.len();
        let g: Vec<f64> = self.vertical_deg.iter().map(|d| d.to_radians()).collect();
        let plane = |h: usize| -> f64 {
            let row = &self.candela[h * nv..(h + 1) * nv];
            (0..nv.saturating_sub(1))
                .map(|i| linear_sin_integral(g[i], g[i + 1], row[i], row[i + 1]))
                .sum()
        };
        let hs = &self.horizontal_deg;
        if self.symmetry == Symmetry::Rotational || hs.len() == 1 {
            return 2.0 * std::f64::consts::PI * plane(0);
        }
        let f: Vec<f64> = (0..hs.len()).map(plane).collect();
        let mut sum = 0.0;
        for i in 0..hs.len() - 1 {
            sum += 0.5 * (f[i] + f[i + 1]) * (hs[i + 1] - hs[i]).to_radians();
        }
        let covered = (hs[hs.len() - 1] - hs[0]).to_radians();
        let full = 2.0 * std::f64::consts::PI;
        match self.symmetry {
            Symmetry::Full => {
                let gap = full - covered;
                sum + 0.5 * (f[hs.len() - 1] + f[0]) * gap.max(0.0)
            }
            // The stored part is a quarter or half of the circle.
            _ => sum * full / covered,
        }
    }
}

/// ∫ (a + (b−a)(γ−g0)/(g1−g0)) sin γ dγ over [g0, g1], exactly.
fn linear_sin_integral(g0: f64, g1: f64, a: f64, b: f64) -> f64 {
    let d = g1 - g0;
    if d <= 0.0 {
        return 0.0;
    }
    // ∫ sin = cos g0 − cos g1; ∫ (γ−g0) sin γ = −d cos g1 + sin g1 − sin g0.
    let i0 = g0.cos() - g1.cos();
    let i1 = -d * g1.cos() + g1.sin() - g0.sin();
    a * i0 + (b - a) * i1 / d
}

/// Maps a C angle in [0, 360) into the stored range of `sym`.
fn fold(sym: Symmetry, c: f64) -> f64 {
    match sym {
        Symmetry::Rotational | Symmetry::Full => c,
        Symmetry::Quadrant => {
            let c = if c > 180.0 { 360.0 - c } else { c };
            if c > 90.0 { 180.0 - c } else { c }
        }
        Symmetry::BilateralC0 => {
            if c > 180.0 {
                360.0 - c
            } else {
                c
            }
        }
        Symmetry::BilateralC90 => {
            if c < 90.0 {
                180.0 - c
            } else if c > 270.0 {
                540.0 - c
            } else {
                c
            }
        }
    }
}

/// The node `i` and fraction `t` with `xs[i] + t (xs[i+1] − xs[i]) = x`
/// (`t` = 0 at the last node); `None` outside `[xs[0], xs[last]]`.
fn bracket(xs: &[f64], x: f64) -> Option<(usize, f64)> {
    let last = xs.len().checked_sub(1)?;
    if !(x >= xs[0] && x <= xs[last]) {
        return None;
    }
    if last == 0 || x == xs[last] {
        return Some((last, 0.0));
    }
    let i = xs
        .partition_point(|&a| a <= x)
        .saturating_sub(1)
        .min(last - 1);
    let t = (x - xs[i]) / (xs[i + 1] - xs[i]);
    Some((i, t.clamp(0.0, 1.0)))
}

fn interp_clamped(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    match (xs.first(), xs.last()) {
        (Some(&a), _) if x <= a => ys[0],
        (_, Some(&b)) if x >= b => ys[ys.len() - 1],
        (None, _) => 1.0,
        _ => match bracket(xs, x) {
            Some((i, t)) if t > 0.0 => ys[i] + t * (ys[i + 1] - ys[i]),
            Some((i, _)) => ys[i],
            None => 1.0,
        },
    }
}

/// Whitespace- (and comma-) separated numbers with their line numbers, for
/// the IES body; a lazy walk, so a claimed count is checked against what is
/// left before anything is allocated.
pub(crate) struct Tokens<'a> {
    text: &'a str,
    pos: usize,
    line: usize,
    path: &'a str,
}

impl<'a> Tokens<'a> {
    pub(crate) fn new(text: &'a str, pos: usize, line: usize, path: &'a str) -> Self {
        Self {
            text,
            pos,
            line,
            path,
        }
    }

    pub(crate) fn line(&self) -> usize {
        self.line
    }

    pub(crate) fn err(&self, line: usize, field: &str, msg: impl Into<String>) -> PhotometryError {
        PhotometryError::Parse {
            path: self.path.to_string(),
            line,
            field: field.to_string(),
            msg: msg.into(),
        }
    }

    fn next_raw(&mut self) -> Option<(usize, &'a str)> {
        let b = self.text.as_bytes();
        while self.pos < b.len() {
            let c = b[self.pos];
            if c == b'\n' {
                self.line += 1;
            } else if !(c.is_ascii_whitespace() || c == b',') {
                break;
            }
            self.pos += 1;
        }
        if self.pos >= b.len() {
            return None;
        }
        let start = self.pos;
        while self.pos < b.len() && !(b[self.pos].is_ascii_whitespace() || b[self.pos] == b',') {
            self.pos += 1;
        }
        Some((self.line, &self.text[start..self.pos]))
    }

    /// The next number, finite, or an error naming `field`.
    pub(crate) fn number(&mut self, field: &str) -> Result<f64, PhotometryError> {
        let line = self.line;
        let Some((l, s)) = self.next_raw() else {
            return Err(self.err(line, field, "the file ends here (truncated?)"));
        };
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(v) => Err(self.err(l, field, format!("{v} is not a finite number"))),
            Err(_) => Err(self.err(l, field, format!("'{s}' is not a number"))),
        }
    }

    /// A count: a whole number in 1..=max.
    pub(crate) fn count(&mut self, field: &str, max: usize) -> Result<usize, PhotometryError> {
        let line = self.line;
        let v = self.number(field)?;
        check_count(v, max).map_err(|m| self.err(line.max(self.line), field, m.to_string()))
    }

    /// The tokens left in the text: how many and the line of the first
    /// (`None` when only separators remain). A DOS end-of-file mark
    /// (Ctrl-Z) is not a token. Bounded by the text's length.
    pub(crate) fn leftover(&mut self) -> Option<(usize, usize)> {
        let mut first = None;
        let mut n = 0usize;
        while let Some((l, s)) = self.next_raw() {
            if s.bytes().all(|b| b == 0x1a) {
                continue;
            }
            first.get_or_insert(l);
            n += 1;
        }
        first.map(|l| (l, n))
    }

    /// How many more tokens the text holds (a bound for claimed counts).
    pub(crate) fn remaining_at_most(&self) -> usize {
        // Each token needs at least one character and one separator.
        (self.text.len() - self.pos).div_ceil(2)
    }
}

/// A count in a photometric file that cannot size a table.
#[derive(Debug, thiserror::Error)]
pub(crate) enum BadCount {
    #[error("{0} must be a whole number ≥ 1")]
    NotWhole(f64),
    #[error("{0} is more than the limit of {1}")]
    OverLimit(f64, usize),
}

pub(crate) fn check_count(v: f64, max: usize) -> Result<usize, BadCount> {
    if v.fract() != 0.0 || v < 1.0 {
        return Err(BadCount::NotWhole(v));
    }
    if v > max as f64 {
        return Err(BadCount::OverLimit(v, max));
    }
    Ok(v as usize)
}

/// Checks a list of angles: each within `lo..=hi`, strictly increasing;
/// the error carries the offending entry's index.
pub(crate) fn check_angles(angles: &[f64], lo: f64, hi: f64) -> Result<(), (usize, String)> {
    for (i, &a) in angles.iter().enumerate() {
        if !(lo..=hi).contains(&a) {
            let msg = format!("angle {a}° (entry {}) is outside {lo}°..{hi}°", i + 1);
            return Err((i, msg));
        }
        if i > 0 && a <= angles[i - 1] {
            let msg = format!(
                "angles must increase: {a}° (entry {}) follows {}°",
                i + 1,
                angles[i - 1]
            );
            return Err((i, msg));
        }
    }
    Ok(())
}

/// Checks candela values (finite, ≥ 0, ≤ [`MAX_CANDELA`]) and returns the
/// largest, which must be > 0.
pub(crate) fn check_candela(values: &[f64]) -> Result<f64, (usize, String)> {
    let mut max = 0.0f64;
    for (i, &v) in values.iter().enumerate() {
        if !(v.is_finite() && (0.0..=MAX_CANDELA).contains(&v)) {
            let msg = format!(
                "candela value {} (entry {}) must be finite, ≥ 0 and ≤ {MAX_CANDELA:e} after the multipliers",
                crate::build::num(v),
                i + 1
            );
            return Err((i, msg));
        }
        max = max.max(v);
    }
    if max <= 0.0 {
        let msg = "every candela value is zero: the luminaire emits nothing".into();
        return Err((0, msg));
    }
    Ok(max)
}

#[cfg(test)]
mod tests;
