//! Reading spectra from CSV files: a sampled continuum plus optional
//! emission lines.
//!
//! Format:
//!
//! * Continuum rows: `wavelength_nm,value` (value per nm, e.g.
//!   W sr⁻¹ nm⁻¹), wavelengths strictly increasing; the continuum is linear
//!   between rows and zero outside them.
//! * Line rows: `line,wavelength_nm,value`, an emission line whose whole
//!   power sits at `wavelength_nm`; `value` is its integrated value, in the
//!   continuum's units × nm (W sr⁻¹ for a continuum in W sr⁻¹ nm⁻¹). Line
//!   rows may stand anywhere in the file, in any order; each wavelength may
//!   carry one line. A file may hold only line rows.
//! * Blank lines and lines starting with `#` are ignored; one header line
//!   (any non-numeric row before the first continuum row, e.g.
//!   `wavelength_nm,value`) is allowed; separators may be commas,
//!   semicolons, tabs or spaces.
//!
//! A row is a line row when its first field is `line` (any case) and some
//! later field is a number, or when it starts with `line` after the header
//! or the first continuum row; a first row such as `line,value` stays a
//! header, so every file without line rows reads as it always did.

use std::path::Path;

use crate::error::{CsvError, LineRowError};
use crate::spectrum::{EmissionLine, Spectrum};

/// Reads a spectrum from a CSV file (see the module docs for the format),
/// noting it in `reads`.
pub fn read_csv(path: &Path, reads: &gloam_io::ReadLog) -> Result<Spectrum, CsvError> {
    let text =
        gloam_io::read_text(path, gloam_io::MAX_TEXT_FILE_BYTES, reads).map_err(|source| {
            CsvError::Io {
                path: path.to_path_buf(),
                source,
            }
        })?;
    parse_csv(&text, path)
}

/// Longest wavelength a spectrum row may give, nm (1 mm).
pub const MAX_WAVELENGTH_NM: f64 = 1e6;

/// The rows of a gloam CSV file (spectra, placements): `(1-based line
/// number, trimmed line, fields)`, skipping blank lines and `#` comments;
/// fields are separated by commas, semicolons, tabs or spaces.
pub fn data_rows(text: &str) -> impl Iterator<Item = (usize, &str, Vec<&str>)> {
    // A UTF-8 byte-order mark (spreadsheets write one) is not part of the
    // first field: with it, a header row read as a rejected data row.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.lines().enumerate().filter_map(|(i, raw)| {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            return None;
        }
        let fields = line
            .split([',', ';', '\t', ' '])
            .map(str::trim)
            .filter(|f| !f.is_empty())
            .collect();
        Some((i + 1, line, fields))
    })
}

/// Parses CSV text; `path` only labels errors.
pub fn parse_csv(text: &str, path: &Path) -> Result<Spectrum, CsvError> {
    let err = |line: usize, message: String| CsvError::Parse {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut wavelengths: Vec<f64> = Vec::new();
    let mut values: Vec<f64> = Vec::new();
    let mut rows: Vec<usize> = Vec::new();
    let mut lines: Vec<EmissionLine> = Vec::new();
    let mut line_rows: Vec<usize> = Vec::new();
    let mut seen_data_or_header = false;
    for (line_no, line, fields) in data_rows(text) {
        if is_line_row(&fields, seen_data_or_header) {
            let l = parse_line_row(&fields).map_err(|e| err(line_no, e.to_string()))?;
            if let Some(k) = lines
                .iter()
                .position(|e| e.wavelength_nm == l.wavelength_nm)
            {
                return Err(err(
                    line_no,
                    format!(
                        "duplicate emission line at {} nm (also on line {}); give each line once, with the summed value",
                        l.wavelength_nm, line_rows[k]
                    ),
                ));
            }
            lines.push(l);
            line_rows.push(line_no);
            continue;
        }
        // `str::parse` accepts `NaN`/`inf`, so those are reported as non-finite
        // values below rather than mistaken for a header.
        let parsed: Vec<Option<f64>> = fields.iter().map(|f| f.parse().ok()).collect();
        let numeric = parsed.iter().all(Option::is_some);
        if !numeric {
            if !seen_data_or_header && fields.iter().all(|f| looks_like_name(f)) {
                // A header row such as `wavelength_nm,value`.
                seen_data_or_header = true;
                continue;
            }
            return Err(err(
                line_no,
                if seen_data_or_header {
                    format!(
                        "expected two numbers 'wavelength_nm,value', found '{}'",
                        gloam_io::shown(line)
                    )
                } else {
                    format!(
                        "expected two numbers 'wavelength_nm,value', found '{}' (a header row must name its columns, e.g. 'wavelength_nm,value'; this looks like a mistyped data row)",
                        gloam_io::shown(line)
                    )
                },
            ));
        }
        seen_data_or_header = true;
        if fields.len() != 2 {
            return Err(err(
                line_no,
                format!(
                    "expected 2 columns (wavelength_nm, value), found {}",
                    fields.len()
                ),
            ));
        }
        let (w, v) = (parsed[0].unwrap_or(f64::NAN), parsed[1].unwrap_or(f64::NAN));
        let prev = wavelengths.last().map(|&p| (p, rows[rows.len() - 1]));
        check_point(w, v, prev).map_err(|m| err(line_no, m))?;
        wavelengths.push(w);
        values.push(v);
        rows.push(line_no);
    }
    if wavelengths.is_empty() && lines.is_empty() {
        return Err(CsvError::Empty {
            path: path.to_path_buf(),
        });
    }
    if wavelengths.len() == 1 {
        // One row spans no range: as a constant it would silently cover
        // every wavelength, as a point it would integrate to nothing.
        return Err(err(
            rows[0],
            format!(
                "the only continuum row ({} nm): a spectrum needs at least two rows (or only `line` rows)",
                wavelengths[0]
            ),
        ));
    }
    // Every row was checked above, so these cannot fail; an error would
    // still be reported, never a panic.
    Spectrum::new(wavelengths, values)
        .and_then(|s| s.with_lines(lines))
        .map_err(|e| err(0, e.to_string()))
}

/// One continuum row's wavelength and value: a wavelength in range,
/// above the previous row's (`prev`: its wavelength and line), and a
/// finite value ≥ 0.
fn check_point(w: f64, v: f64, prev: Option<(f64, usize)>) -> Result<(), String> {
    if !w.is_finite() || w <= 0.0 || w > MAX_WAVELENGTH_NM {
        return Err(if w.abs() < 1e7 || !w.is_finite() {
            format!(
                "wavelength {w} nm is not a finite positive number up to {MAX_WAVELENGTH_NM:e} nm (1 mm)"
            )
        } else {
            format!(
                "wavelength {w:e} nm is not a finite positive number up to {MAX_WAVELENGTH_NM:e} nm (1 mm)"
            )
        });
    }
    if !v.is_finite() {
        return Err(format!("value {v} at {w} nm is not finite"));
    }
    if v < 0.0 {
        return Err(format!("value {v} at {w} nm is negative"));
    }
    if let Some((prev, prev_row)) = prev {
        if w == prev {
            return Err(format!(
                "duplicate wavelength {w} nm (also on line {})",
                prev_row
            ));
        }
        if w < prev {
            return Err(format!(
                "wavelength {w} nm is below the previous {prev} nm on line {}: wavelengths must increase",
                prev_row
            ));
        }
    }
    Ok(())
}

/// A header field is clearly a name, never a mistyped number: no digit at
/// all (`wavelength_nm`, `value`, `λ`), or at least two letters and a
/// letter first (`CIE1931`). `O.9`, `0.5x` and `1e` are not.
fn looks_like_name(f: &str) -> bool {
    let f = f.trim_matches('"');
    if !f.chars().any(|c| c.is_ascii_digit()) {
        return !f.is_empty();
    }
    f.chars().next().is_some_and(char::is_alphabetic)
        && f.chars().filter(|c| c.is_alphabetic()).count() >= 2
}

/// True for a `line,wavelength_nm,value` row (see the module docs): the
/// first field is `line`, and either a header or a continuum row came
/// before it or one of its other fields is a number (so that a first row
/// such as `line,value` remains a header).
fn is_line_row(fields: &[&str], seen_data_or_header: bool) -> bool {
    fields
        .first()
        .is_some_and(|f| f.eq_ignore_ascii_case("line"))
        && (seen_data_or_header || fields[1..].iter().any(|f| f.parse::<f64>().is_ok()))
}

/// Parses and checks the fields of a line row; the error names the field.
fn parse_line_row(fields: &[&str]) -> Result<EmissionLine, LineRowError> {
    if fields.len() != 3 {
        return Err(LineRowError::Columns {
            found: fields.len(),
        });
    }
    let number = |field: &'static str, f: &str| {
        f.parse::<f64>().map_err(|_| LineRowError::NotANumber {
            field,
            text: f.to_string(),
        })
    };
    let w = number("wavelength_nm", fields[1])?;
    let v = number("value", fields[2])?;
    if !w.is_finite() || w <= 0.0 {
        return Err(LineRowError::BadWavelength { wavelength_nm: w });
    }
    if !v.is_finite() {
        return Err(LineRowError::NonFiniteValue {
            value: v,
            wavelength_nm: w,
        });
    }
    if v < 0.0 {
        return Err(LineRowError::NegativeValue {
            value: v,
            wavelength_nm: w,
        });
    }
    Ok(EmissionLine {
        wavelength_nm: w,
        value: v,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use std::path::PathBuf;

    fn parse(text: &str) -> Result<Spectrum, CsvError> {
        parse_csv(text, &PathBuf::from("lamp.csv"))
    }

    fn message(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    /// A spreadsheet's byte-order mark is not part of the first field.
    #[test]
    fn a_byte_order_mark_is_not_data() {
        let rows: Vec<_> = data_rows("\u{feff}x,y,z\n1,2,3\n").collect();
        assert_eq!(rows[0].2, vec!["x", "y", "z"]);
        assert_eq!(rows[1], (2, "1,2,3", vec!["1", "2", "3"]));
    }

    #[test]
    fn reads_header_comments_and_blank_lines() {
        let s = parse("# a lamp\nwavelength_nm,value\n\n400,1\n500, 2\n# mid comment\n600\t3\n")
            .unwrap();
        assert_eq!(s.wavelengths_nm(), &[400.0, 500.0, 600.0]);
        assert_eq!(s.values(), &[1.0, 2.0, 3.0]);
    }

    #[test]
    fn headerless_file_reads() {
        let s = parse("400,1\n500,2\n").unwrap();
        assert_eq!(s.values(), &[1.0, 2.0]);
    }

    #[test]
    fn every_error_names_file_and_line() {
        assert_eq!(
            message("400,1\n400,2\n"),
            "lamp.csv:2: duplicate wavelength 400 nm (also on line 1)"
        );
        assert!(
            message("wl,v\n500,1\n400,2\n").starts_with("lamp.csv:3: wavelength 400 nm is below")
        );
        assert_eq!(
            message("400,1\n500,NaN\n"),
            "lamp.csv:2: value NaN at 500 nm is not finite"
        );
        assert_eq!(
            message("400,1\n500,-0.5\n"),
            "lamp.csv:2: value -0.5 at 500 nm is negative"
        );
        assert_eq!(
            message("400,1\n500,inf\n"),
            "lamp.csv:2: value inf at 500 nm is not finite"
        );
        assert!(message("400,1\n500,abc\n").starts_with("lamp.csv:2: expected two numbers"));
        assert!(message("400,1,3\n").starts_with("lamp.csv:1: expected 2 columns"));
        assert!(message("-5,1\n").starts_with("lamp.csv:1: wavelength -5 nm"));
    }

    #[test]
    fn empty_files_are_rejected() {
        assert_eq!(
            message(""),
            "lamp.csv: no data rows (the file is empty or holds only comments and a header)"
        );
        assert!(matches!(
            parse("# only\nwavelength,value\n"),
            Err(CsvError::Empty { .. })
        ));
    }

    #[test]
    fn line_rows_add_emission_lines_anywhere_in_the_file() {
        let s = parse(
            "# a lamp with two lines\nline,546.07,0.12\nwavelength_nm,value\n400,1\nLINE;435.83;0.05\n500,2\n600\t3\nline 404.66 0\n",
        )
        .unwrap();
        assert_eq!(s.wavelengths_nm(), &[400.0, 500.0, 600.0]);
        assert_eq!(s.values(), &[1.0, 2.0, 3.0]);
        let lines: Vec<(f64, f64)> = s
            .lines()
            .iter()
            .map(|l| (l.wavelength_nm, l.value))
            .collect();
        assert_eq!(lines, [(404.66, 0.0), (435.83, 0.05), (546.07, 0.12)]);
    }

    #[test]
    fn a_file_of_lines_only_is_a_line_spectrum() {
        let s = parse("line,588.995,2\nline,589.592,1\n").unwrap();
        assert!(s.wavelengths_nm().is_empty());
        assert_eq!(s.integral(), 3.0);
        assert_eq!(s.integrate_band(589.0, 590.0), 1.0);
    }

    #[test]
    fn headers_starting_with_line_still_read_as_headers() {
        // Before line rows existed these were headers; they still are.
        for header in ["line,value", "Line name;intensity", "line"] {
            let s = parse(&format!("{header}\n400,1\n500,2\n")).unwrap();
            assert_eq!(s.values(), &[1.0, 2.0], "{header}");
            assert!(s.lines().is_empty(), "{header}");
        }
    }

    #[test]
    fn line_row_errors_name_file_line_and_field() {
        assert_eq!(
            message("400,1\nline,546.07,0.1\nline,546.07,0.2\n"),
            "lamp.csv:3: duplicate emission line at 546.07 nm (also on line 2); give each line once, with the summed value"
        );
        assert_eq!(
            message("400,1\nline,546.07\n"),
            "lamp.csv:2: an emission line row is 'line,wavelength_nm,value', found 2 columns"
        );
        assert_eq!(
            message("400,1\nline,546.07,0.1,7\n"),
            "lamp.csv:2: an emission line row is 'line,wavelength_nm,value', found 4 columns"
        );
        assert_eq!(
            message("line,546.07,abc\n"),
            "lamp.csv:1: emission line value 'abc' is not a number"
        );
        assert_eq!(
            message("400,1\nline,green,0.1\n"),
            "lamp.csv:2: emission line wavelength_nm 'green' is not a number"
        );
        assert_eq!(
            message("line,0,0.1\n"),
            "lamp.csv:1: emission line wavelength_nm 0 is not a finite positive number"
        );
        assert_eq!(
            message("line,-546,0.1\n"),
            "lamp.csv:1: emission line wavelength_nm -546 is not a finite positive number"
        );
        assert_eq!(
            message("line,inf,0.1\n"),
            "lamp.csv:1: emission line wavelength_nm inf is not a finite positive number"
        );
        assert_eq!(
            message("400,1\nline,546.07,NaN\n"),
            "lamp.csv:2: emission line value NaN at 546.07 nm is not finite"
        );
        assert_eq!(
            message("400,1\nline,546.07,-0.1\n"),
            "lamp.csv:2: emission line value -0.1 at 546.07 nm is negative"
        );
        // Lines do not take part in the continuum's ordering.
        assert!(parse("500,1\nline,450,1\n600,1\n").is_ok());
    }

    #[test]
    fn user_lamp_line_integrates_exactly_on_a_coarse_grid() {
        // A user lamp: a continuum on a 100 nm grid (W sr⁻¹ nm⁻¹) and two
        // lines (W sr⁻¹). Closed form over a band: the continuum's trapezoid
        // area inside the band (exact, it is linear) plus the lines in it.
        let s =
            parse("400,0.01\n500,0.03\n600,0.02\n700,0.01\nline,546.07,0.12\nline,577.0,0.05\n")
                .unwrap();
        // 540–560 nm lies inside the 500–600 segment: c(λ) = 0.03 − 1e-4 (λ − 500).
        let c = |w: f64| 0.03 - 1e-4 * (w - 500.0);
        let continuum = 0.5 * 20.0 * (c(540.0) + c(560.0));
        assert_relative_eq!(
            s.integrate_band(540.0, 560.0),
            continuum + 0.12,
            max_relative = 1e-14
        );
        // 400–700 nm: the whole continuum (2 + 2.5 + 1.5 = 6 W sr⁻¹) plus both lines.
        let whole = 100.0 * (0.02 + 0.025 + 0.015);
        assert_relative_eq!(
            s.integrate_band(400.0, 700.0),
            whole + 0.17,
            max_relative = 1e-14
        );
        // Against a flat 0.5 filter on 550–600 nm: only the 577 nm line is in.
        let filter = Spectrum::constant(550.0, 600.0, 0.5).unwrap();
        let cont = 0.5 * 50.0 * (c(550.0) + c(600.0)) * 0.5;
        assert_relative_eq!(
            s.integrate_weighted(&filter),
            cont + 0.5 * 0.05,
            max_relative = 1e-14
        );
    }

    #[test]
    fn missing_file_names_path() {
        let e = read_csv(Path::new("/nonexistent/x.csv"), &gloam_io::ReadLog::off())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("/nonexistent/x.csv: cannot read"), "{e}");
    }
}
