//! EULUMDAT (`.ldt`): one field per line, intensities in cd/klm of the
//! lamp flux. Line numbers below are the format's (1-based).

use super::{
    Format, MAX_ANGLES, MAX_VALUES, Photometry, PhotometryError, Symmetry, check_angles,
    check_candela, check_count,
};

/// Most lamp sets (line 26) a file may declare.
const MAX_LAMP_SETS: usize = 1000;

struct Lines<'a> {
    lines: Vec<&'a str>,
    path: &'a str,
}

impl Lines<'_> {
    fn err(&self, line: usize, field: &str, msg: impl Into<String>) -> PhotometryError {
        PhotometryError::Parse {
            path: self.path.to_string(),
            line,
            field: field.to_string(),
            msg: msg.into(),
        }
    }

    fn text(&self, line: usize, field: &str) -> Result<&str, PhotometryError> {
        self.lines
            .get(line - 1)
            .map(|s| s.trim())
            .ok_or_else(|| self.err(line, field, "the file ends before this line (truncated?)"))
    }

    /// A number on `line` (decimal point or comma).
    fn number(&self, line: usize, field: &str) -> Result<f64, PhotometryError> {
        let s = self.text(line, field)?;
        match s.replace(',', ".").parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(v) => Err(self.err(line, field, format!("{v} is not a finite number"))),
            Err(_) => Err(self.err(line, field, format!("'{s}' is not a number"))),
        }
    }

    fn list(&self, first: usize, n: usize, field: &str) -> Result<Vec<f64>, PhotometryError> {
        (first..first + n).map(|l| self.number(l, field)).collect()
    }
}

pub(super) fn parse(text: &str, path: &str) -> Result<Photometry, PhotometryError> {
    let lines: Vec<&str> = text.trim_start_matches('\u{feff}').lines().collect();
    let f = Lines { lines, path };
    let Header {
        isym_v,
        mc,
        ng,
        lorl,
        conv,
        n,
        lamp_flux,
    } = header(&f)?;
    let c_first = 27 + 6 * n + 10;
    let g_first = c_first + mc;
    let (symmetry, stored, c_from) = stored_planes(&f, isym_v, mc)?;
    let values = stored.checked_mul(ng).filter(|&v| v <= MAX_VALUES);
    let Some(values) = values else {
        return Err(f.err(
            6,
            "Ng (number of intensities per C-plane)",
            format!("{stored} planes × {ng} intensities is more than the limit of {MAX_VALUES}"),
        ));
    };
    let i_first = g_first + ng;
    if i_first - 1 + values > f.lines.len() {
        return Err(f.err(
            f.lines.len(),
            "luminous intensity distribution",
            format!(
                "{mc} C-angles, {ng} γ-angles and {values} intensities are promised on lines {c_first}–{}, but the file has {} lines (truncated?)",
                i_first - 1 + values,
                f.lines.len()
            ),
        ));
    }
    let c_all = f.list(c_first, mc, "C-plane angles")?;
    check_angles(&c_all, 0.0, 360.0).map_err(|(i, m)| f.err(c_first + i, "C-plane angles", m))?;
    let gamma = f.list(g_first, ng, "γ angles")?;
    check_angles(&gamma, 0.0, 180.0).map_err(|(i, m)| f.err(g_first + i, "γ angles", m))?;
    // The stored planes' angles: for Isym 3 they run from C270 through
    // C0 (= 360) to C90, i.e. 90 → 270 after the mirror C ↦ 180 − C; the
    // data are reordered to 90 → 270 so the table's angles increase.
    let mut horizontal: Vec<f64> = (0..stored).map(|k| c_all[(c_from + k) % mc]).collect();
    let mut candela = Vec::with_capacity(values);
    let klm = conv * lamp_flux / 1000.0;
    for l in i_first..i_first + values {
        candela.push(f.number(l, "luminous intensity (cd/klm)")? * klm);
    }
    // Lines past the table (other than blank ones) are the mark of a wrong
    // count: refuse them rather than read a shifted table.
    let end = i_first - 1 + values;
    if let Some(k) = f.lines[end..]
        .iter()
        .position(|l| !l.trim().trim_matches('\u{1a}').is_empty())
    {
        let extra = f.lines[end + k..]
            .iter()
            .filter(|l| !l.trim().trim_matches('\u{1a}').is_empty())
            .count();
        return Err(f.err(
            end + k + 1,
            "luminous intensity distribution",
            format!(
                "{extra} non-empty lines after the intensity table, which ends at line {end}: the counts (Isym line 3, Mc line 4, Ng line 6) say {stored} planes × {ng} intensities"
            ),
        ));
    }
    if symmetry == Symmetry::BilateralC90 {
        (horizontal, candela) = mirror_c90(&horizontal, &candela, ng);
    }
    if symmetry == Symmetry::Full && horizontal[0] == 0.0 && horizontal[stored - 1] < 360.0 {
        // Close the circle as IES files do: C360 = C0.
        horizontal.push(360.0);
        candela.extend_from_within(0..ng);
    }
    if symmetry != Symmetry::Rotational {
        check_angles(&horizontal, 0.0, 360.0)
            .map_err(|(_, m)| f.err(c_first, "C-plane angles", format!("stored planes: {m}")))?;
    }
    // The stored order (before any reordering) gives the line.
    let raw_line = |i: usize| {
        if symmetry == Symmetry::BilateralC90 {
            let (k, v) = (i / ng, i % ng);
            i_first + (stored - 1 - k) * ng + v
        } else {
            i_first + i
        }
    };
    let max_candela = check_candela(&candela)
        .map_err(|(i, m)| f.err(raw_line(i), "luminous intensity (cd/klm)", m))?;
    check_stored_range(&f, c_first, isym_v, symmetry, &horizontal)?;
    if symmetry == Symmetry::Rotational {
        horizontal.truncate(1);
        horizontal[0] = 0.0;
    }
    Ok(Photometry {
        format: Format::Eulumdat,
        vertical_deg: gamma,
        horizontal_deg: horizontal,
        symmetry,
        candela,
        max_candela,
        header_lumens: Some(lamp_flux * lorl / 100.0),
        tilt: None,
    })
}

/// The header fields the distribution depends on.
struct Header {
    isym_v: f64,
    mc: usize,
    ng: usize,
    lorl: f64,
    conv: f64,
    n: usize,
    lamp_flux: f64,
}

/// Reads and checks the header: symmetry, plane and angle counts, light
/// output ratio, conversion factor, lamp sets and the first set's flux.
fn header(f: &Lines) -> Result<Header, PhotometryError> {
    let isym_v = f.number(3, "Isym (symmetry indicator)")?;
    let mc = check_count(f.number(4, "Mc (number of C-planes)")?, MAX_ANGLES)
        .map_err(|m| f.err(4, "Mc (number of C-planes)", m.to_string()))?;
    let ng = check_count(
        f.number(6, "Ng (number of intensities per C-plane)")?,
        MAX_ANGLES,
    )
    .map_err(|m| f.err(6, "Ng (number of intensities per C-plane)", m.to_string()))?;
    let lorl = f.number(23, "LORL (light output ratio)")?;
    let conv = f.number(24, "conversion factor for luminous intensities")?;
    let n = check_count(f.number(26, "n (number of lamp sets)")?, MAX_LAMP_SETS)
        .map_err(|m| f.err(26, "n (number of lamp sets)", m.to_string()))?;
    if !(0.0..=100.0).contains(&lorl) {
        return Err(f.err(
            23,
            "LORL (light output ratio)",
            format!("{lorl} % must be in 0..=100"),
        ));
    }
    if conv <= 0.0 {
        return Err(f.err(
            24,
            "conversion factor for luminous intensities",
            format!("{conv} must be > 0"),
        ));
    }
    // Lamp sets: n lines each of count, type, flux, colour, CRI, watts.
    let flux_line = 27 + 2 * n;
    let lamp_flux = f
        .number(flux_line, "total luminous flux of lamps (set 1)")?
        .abs();
    if lamp_flux <= 0.0 {
        return Err(f.err(
            flux_line,
            "total luminous flux of lamps (set 1)",
            "must be non-zero: EULUMDAT intensities are per 1000 lm of it",
        ));
    }
    Ok(Header {
        isym_v,
        mc,
        ng,
        lorl,
        conv,
        n,
        lamp_flux,
    })
}

/// The symmetry Isym declares, how many C-planes are stored for it and the
/// index of the first (Isym 3 starts at C270); Mc must split evenly.
fn stored_planes(
    f: &Lines,
    isym_v: f64,
    mc: usize,
) -> Result<(Symmetry, usize, usize), PhotometryError> {
    let (symmetry, stored, c_from) = match isym_v {
        0.0 => (Symmetry::Full, mc, 0),
        1.0 => (Symmetry::Rotational, 1, 0),
        2.0 => (Symmetry::BilateralC0, mc / 2 + 1, 0),
        3.0 => (Symmetry::BilateralC90, mc / 2 + 1, 3 * mc / 4),
        4.0 => (Symmetry::Quadrant, mc / 4 + 1, 0),
        _ => {
            return Err(f.err(
                3,
                "Isym (symmetry indicator)",
                format!("{isym_v} must be 0, 1, 2, 3 or 4"),
            ));
        }
    };
    if (2.0..=4.0).contains(&isym_v) && mc % if isym_v == 4.0 { 4 } else { 2 } != 0 {
        return Err(f.err(
            4,
            "Mc (number of C-planes)",
            format!("{mc} C-planes cannot be split by symmetry Isym = {isym_v}"),
        ));
    }
    Ok((symmetry, stored, c_from))
}

/// Isym 3's planes reordered to increasing angles: plane k (angle C_k in
/// 270..360 ∪ 0..90) equals, by the mirror, the plane at 180 − C_k (in
/// 90..270); listing those in increasing order is the stored order
/// reversed. 180 − 90 = 90 and 180 − 270 = −90 ≡ 270: the ends are exact.
fn mirror_c90(horizontal: &[f64], candela: &[f64], ng: usize) -> (Vec<f64>, Vec<f64>) {
    let mirrored = horizontal
        .iter()
        .rev()
        .map(|c| (180.0 - c).rem_euclid(360.0))
        .collect();
    let mut out = Vec::with_capacity(candela.len());
    for k in (0..horizontal.len()).rev() {
        out.extend_from_slice(&candela[k * ng..(k + 1) * ng]);
    }
    (mirrored, out)
}

/// A partial symmetry's stored planes span the range it mirrors from.
fn check_stored_range(
    f: &Lines,
    c_first: usize,
    isym_v: f64,
    symmetry: Symmetry,
    horizontal: &[f64],
) -> Result<(), PhotometryError> {
    let expect_end = match symmetry {
        Symmetry::Quadrant => Some((0.0, 90.0)),
        Symmetry::BilateralC0 => Some((0.0, 180.0)),
        Symmetry::BilateralC90 => Some((90.0, 270.0)),
        _ => None,
    };
    if let Some((a, b)) = expect_end
        && (horizontal[0] != a || horizontal[horizontal.len() - 1] != b)
    {
        return Err(f.err(
            c_first,
            "C-plane angles",
            format!(
                "symmetry Isym = {isym_v} needs stored planes from C{a} to C{b}, found {}–{}",
                horizontal[0],
                horizontal[horizontal.len() - 1]
            ),
        ));
    }
    Ok(())
}
