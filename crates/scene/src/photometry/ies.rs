//! IES LM-63 (1986/1991/1995/2002): keyword lines, `TILT=`, then numbers.
//! Type C photometry only (types A and B are goniometer conventions for
//! floodlights and automotive lamps, refused by name).

use super::{
    Format, MAX_ANGLES, MAX_VALUES, Photometry, PhotometryError, Symmetry, TiltTable, Tokens,
    check_angles, check_candela,
};

pub(super) fn parse(text: &str, path: &str) -> Result<Photometry, PhotometryError> {
    let err = |line: usize, field: &str, msg: String| parse_err(path, line, field, msg);
    let (pos, tl, tilt) = tilt_line(text, path)?;
    let mut tok = Tokens::new(text, pos, tl + 1, path);
    let tilt = tilt_data(&mut tok, path, tl, &tilt)?;
    let Header {
        lamps,
        lumens,
        multiplier,
        nv,
        nh,
        pt_line,
        ballast,
        ballast_lamp,
    } = header(&mut tok, path)?;
    let values = nv.checked_mul(nh).filter(|&n| n <= MAX_VALUES);
    let Some(values) = values else {
        return Err(err(
            pt_line,
            "number of horizontal angles",
            format!("{nv} × {nh} candela values is more than the limit of {MAX_VALUES}"),
        ));
    };
    if nv + nh + values > tok.remaining_at_most() {
        return Err(err(
            tok.line(),
            "candela values",
            format!(
                "the header promises {nv} vertical + {nh} horizontal angles and {values} values, more numbers than the rest of the file holds (truncated?)"
            ),
        ));
    }
    let (vertical, vl) = read_list(&mut tok, nv, "vertical angles")?;
    check_angles(&vertical, 0.0, 180.0).map_err(|(i, m)| err(vl[i], "vertical angles", m))?;
    let (horizontal, hl) = read_list(&mut tok, nh, "horizontal angles")?;
    check_angles(&horizontal, 0.0, 360.0).map_err(|(i, m)| err(hl[i], "horizontal angles", m))?;
    let symmetry =
        symmetry_of(&horizontal).map_err(|m| err(hl[0], "horizontal angles", m.to_string()))?;
    let (mut candela, cl) = read_list(&mut tok, values, "candela values")?;
    // Numbers past the table are the mark of a wrong angle count (a file
    // whose count is one short reads shifted, not short): refuse them.
    if let Some((line, n)) = tok.leftover() {
        return Err(err(
            line,
            "candela values",
            format!(
                "{n} numbers after the candela table: the angle counts (line {pt_line}) say {nv} × {nh} values"
            ),
        ));
    }
    let k = multiplier * ballast * ballast_lamp;
    candela.iter_mut().for_each(|c| *c *= k);
    let max_candela = check_candela(&candela).map_err(|(i, m)| err(cl[i], "candela values", m))?;
    Ok(Photometry {
        format: Format::Ies,
        vertical_deg: vertical,
        horizontal_deg: horizontal,
        symmetry,
        candela,
        max_candela,
        header_lumens: (lumens > 0.0).then_some(lamps * lumens),
        tilt,
    })
}

/// A parse error at `line` of the file, naming the field.
fn parse_err(path: &str, line: usize, field: &str, msg: String) -> PhotometryError {
    PhotometryError::Parse {
        path: path.to_string(),
        line,
        field: field.to_string(),
        msg,
    }
}

/// Keyword lines up to `TILT=`; the numbers follow that line. The byte
/// offset after it, its line and its value.
fn tilt_line(text: &str, path: &str) -> Result<(usize, usize, String), PhotometryError> {
    let mut pos = 0usize;
    let mut line = 0usize;
    let mut tilt_line = None;
    for l in text.split_inclusive('\n') {
        line += 1;
        pos += l.len();
        let t = l.trim_start_matches('\u{feff}').trim();
        if let Some(rest) = t.strip_prefix("TILT=").or_else(|| t.strip_prefix("TILT =")) {
            tilt_line = Some((line, rest.trim().to_string()));
            break;
        }
    }
    let Some((tl, tilt)) = tilt_line else {
        return Err(parse_err(
            path,
            line,
            "TILT",
            "no `TILT=` line: not an IES LM-63 file (or truncated before its data)".into(),
        ));
    };
    Ok((pos, tl, tilt))
}

/// The tilt table, when `TILT=INCLUDE` puts it in this file.
fn tilt_data(
    tok: &mut Tokens,
    path: &str,
    tl: usize,
    tilt: &str,
) -> Result<Option<TiltTable>, PhotometryError> {
    Ok(match tilt {
        "NONE" => None,
        "INCLUDE" => Some(tilt_table(tok)?),
        other => {
            return Err(parse_err(
                path,
                tl,
                "TILT",
                format!(
                    "TILT={other}: a tilt table in a separate file is not supported; copy it into this file as TILT=INCLUDE"
                ),
            ));
        }
    })
}

/// The header numbers the distribution depends on, and the line of the
/// photometric type (where a size limit is reported).
struct Header {
    lamps: f64,
    lumens: f64,
    multiplier: f64,
    nv: usize,
    nh: usize,
    pt_line: usize,
    ballast: f64,
    ballast_lamp: f64,
}

/// Reads and checks the header line after the tilt data: type C only,
/// lamps and lumens (or −1, absolute), and positive factors.
fn header(tok: &mut Tokens, path: &str) -> Result<Header, PhotometryError> {
    let err = |line: usize, field: &str, msg: String| parse_err(path, line, field, msg);
    let lamps = tok.number("number of lamps")?;
    let lumens_line = tok.line();
    let lumens = tok.number("lumens per lamp")?;
    let mult_line = tok.line();
    let multiplier = tok.number("candela multiplier")?;
    let nv = tok.count("number of vertical angles", MAX_ANGLES)?;
    let nh = tok.count("number of horizontal angles", MAX_ANGLES)?;
    let pt_line = tok.line();
    let ptype = tok.number("photometric type")?;
    for f in ["units type", "width", "length", "height"] {
        tok.number(f)?;
    }
    let bf_line = tok.line();
    let ballast = tok.number("ballast factor")?;
    // 1995: the ballast-lamp photometric factor; 2002: "future use" (1).
    let blf_line = tok.line();
    let ballast_lamp = tok.number("ballast-lamp photometric factor")?;
    tok.number("input watts")?;
    if ptype != 1.0 {
        let what = match ptype {
            2.0 => "type B",
            3.0 => "type A",
            _ => "unknown",
        };
        return Err(err(
            pt_line,
            "photometric type",
            format!("{ptype} ({what} photometry): only type C (1) is supported"),
        ));
    }
    if !(lamps.is_finite() && lamps > 0.0) {
        return Err(err(
            lumens_line,
            "number of lamps",
            format!("{lamps} must be > 0"),
        ));
    }
    if !(lumens == -1.0 || lumens > 0.0) {
        return Err(err(
            lumens_line,
            "lumens per lamp",
            format!("{lumens} must be > 0, or −1 for absolute photometry"),
        ));
    }
    for (v, l, f) in [
        (multiplier, mult_line, "candela multiplier"),
        (ballast, bf_line, "ballast factor"),
        (ballast_lamp, blf_line, "ballast-lamp photometric factor"),
    ] {
        if v <= 0.0 {
            return Err(err(l, f, format!("{} must be > 0", crate::build::num(v))));
        }
        if v < MIN_FACTOR {
            return Err(err(
                l,
                f,
                format!(
                    "{} is below {MIN_FACTOR:e}: the lamp would emit nothing visible (a mistyped exponent?)",
                    crate::build::num(v)
                ),
            ));
        }
    }
    Ok(Header {
        lamps,
        lumens,
        multiplier,
        nv,
        nh,
        pt_line,
        ballast,
        ballast_lamp,
    })
}

/// `n` numbers and the line each was on.
fn read_list(
    tok: &mut Tokens,
    n: usize,
    field: &str,
) -> Result<(Vec<f64>, Vec<usize>), PhotometryError> {
    let mut out = Vec::with_capacity(n);
    let mut lines = Vec::with_capacity(n);
    for _ in 0..n {
        out.push(tok.number(field)?);
        lines.push(tok.line());
    }
    Ok((out, lines))
}

/// Smallest candela multiplier, ballast factor and ballast-lamp factor
/// accepted: real files use about 0.001–1000 (a relative file's multiplier
/// is its lamp lumens / 1000); below 1e-12 a lamp of even 1e12 cd emits
/// less than 1 cd, so the value is a typo (1e-320 renders black).
pub const MIN_FACTOR: f64 = 1e-12;

/// Largest TILT=INCLUDE multiplying factor accepted.
pub const MAX_TILT_FACTOR: f64 = 10.0;

fn tilt_table(tok: &mut Tokens) -> Result<TiltTable, PhotometryError> {
    let gl = tok.line();
    let geometry = tok.number("lamp-to-luminaire geometry")?;
    if ![1.0, 2.0, 3.0].contains(&geometry) {
        return Err(tok.err(
            gl,
            "lamp-to-luminaire geometry",
            format!("{geometry} must be 1, 2 or 3"),
        ));
    }
    let n = tok.count("number of tilt angles", MAX_ANGLES)?;
    if 2 * n > tok.remaining_at_most() {
        return Err(tok.err(
            tok.line(),
            "tilt angles",
            format!("{n} tilt angles promised, more than the file holds (truncated?)"),
        ));
    }
    let (angles, al) = read_list(tok, n, "tilt angles")?;
    check_angles(&angles, 0.0, 180.0).map_err(|(i, m)| tok.err(al[i], "tilt angles", m))?;
    let (factors, fl) = read_list(tok, n, "tilt multiplying factors")?;
    // A tilt factor scales the lamp's rated output for its burning
    // position (LM-63: typically 0.5–1.2); past MAX_TILT_FACTOR it is not
    // a tilt, and 1e300 would carry the emission past every limit.
    if let Some(i) = factors
        .iter()
        .position(|f| !(0.0..=MAX_TILT_FACTOR).contains(f))
    {
        return Err(tok.err(
            fl[i],
            "tilt multiplying factors",
            format!("{:e} must be in 0..={MAX_TILT_FACTOR}", factors[i]),
        ));
    }
    Ok(TiltTable {
        geometry: geometry as u32,
        angles_deg: angles,
        factors,
    })
}

/// Type C horizontal angles that name none of LM-63's symmetries.
#[derive(Debug, thiserror::Error)]
#[error(
    "{first}° to {last}°: type C horizontal angles must be 0 alone (rotational symmetry), or run 0–90, 0–180, 90–270 or 0–360"
)]
struct UnknownSymmetry {
    first: f64,
    last: f64,
}

/// The symmetry LM-63-2002 assigns to a type C horizontal angle list.
fn symmetry_of(h: &[f64]) -> Result<Symmetry, UnknownSymmetry> {
    let (first, last) = (h[0], h[h.len() - 1]);
    match (h.len(), first, last) {
        (1, 0.0, _) => Ok(Symmetry::Rotational),
        (_, 0.0, 90.0) => Ok(Symmetry::Quadrant),
        (_, 0.0, 180.0) => Ok(Symmetry::BilateralC0),
        (_, 90.0, 270.0) => Ok(Symmetry::BilateralC90),
        (_, 0.0, 360.0) => Ok(Symmetry::Full),
        _ => Err(UnknownSymmetry { first, last }),
    }
}
