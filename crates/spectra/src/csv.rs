//! Reading spectra from two-column CSV files.
//!
//! Format: `wavelength_nm,value` per line; blank lines and lines starting
//! with `#` are ignored; one header line (any non-numeric first row) is
//! allowed; separators may be commas, semicolons, tabs or spaces.

use std::path::Path;

use crate::error::CsvError;
use crate::spectrum::Spectrum;

/// Reads a spectrum from a CSV file (see the module docs for the format).
pub fn read_csv(path: &Path) -> Result<Spectrum, CsvError> {
    let text = std::fs::read_to_string(path).map_err(|source| CsvError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_csv(&text, path)
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
    let mut seen_data_or_header = false;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split([',', ';', '\t', ' '])
            .map(str::trim)
            .filter(|f| !f.is_empty())
            .collect();
        // `str::parse` accepts `NaN`/`inf`, so those are reported as non-finite
        // values below rather than mistaken for a header.
        let parsed: Vec<Option<f64>> = fields.iter().map(|f| f.parse().ok()).collect();
        let numeric = parsed.iter().all(Option::is_some);
        if !numeric {
            if !seen_data_or_header {
                // A header row such as `wavelength_nm,value`.
                seen_data_or_header = true;
                continue;
            }
            return Err(err(
                line_no,
                format!("expected two numbers 'wavelength_nm,value', found '{line}'"),
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
        if !w.is_finite() || w <= 0.0 {
            return Err(err(
                line_no,
                format!("wavelength {w} nm is not a finite positive number"),
            ));
        }
        if !v.is_finite() {
            return Err(err(line_no, format!("value {v} at {w} nm is not finite")));
        }
        if v < 0.0 {
            return Err(err(line_no, format!("value {v} at {w} nm is negative")));
        }
        if let Some(&prev) = wavelengths.last() {
            if w == prev {
                return Err(err(
                    line_no,
                    format!(
                        "duplicate wavelength {w} nm (also on line {})",
                        rows[rows.len() - 1]
                    ),
                ));
            }
            if w < prev {
                return Err(err(
                    line_no,
                    format!(
                        "wavelength {w} nm is below the previous {prev} nm on line {}: wavelengths must increase",
                        rows[rows.len() - 1]
                    ),
                ));
            }
        }
        wavelengths.push(w);
        values.push(v);
        rows.push(line_no);
    }
    if wavelengths.is_empty() {
        return Err(CsvError::Empty {
            path: path.to_path_buf(),
        });
    }
    Spectrum::new(wavelengths, values).map_err(|e| err(0, e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn parse(text: &str) -> Result<Spectrum, CsvError> {
        parse_csv(text, &PathBuf::from("lamp.csv"))
    }

    fn message(text: &str) -> String {
        parse(text).unwrap_err().to_string()
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
    fn missing_file_names_path() {
        let e = read_csv(Path::new("/nonexistent/x.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("/nonexistent/x.csv: cannot read"), "{e}");
    }
}
