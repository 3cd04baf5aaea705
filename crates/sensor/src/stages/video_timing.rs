//! Line timing of the two monochrome broadcast formats a CCD camera's
//! analogue output follows, and the CCD readout mapped onto their lines.
//!
//! * **RS-170** (525 lines, 60 fields/s, 2:1 interlace) with the line
//!   period of its colour revision: `H = 63.556 µs` (15 734.26 Hz, EIA
//!   RS-170A / SMPTE 170M-2004 §11: line blanking 10.9 ± 0.2 µs, front porch
//!   1.5 ± 0.1 µs, horizontal sync 4.7 ± 0.1 µs; 20 lines of vertical
//!   blanking per field leave 485 picture lines).
//! * **CCIR** (625 lines, 50 fields/s, 2:1 interlace; ITU-R BT.470-6 table
//!   1 and BT.1700: `H = 64 µs`, line blanking 12.0 ± 0.3 µs, front porch
//!   1.5 ± 0.3 µs, sync 4.7 ± 0.2 µs, 0H to end of blanking 10.5 µs; 25 lines
//!   of field blanking per field leave 575 picture lines).
//!
//! Levels (both, monochrome, no set-up pedestal): sync tip 0 V, blanking =
//! black at the video stage's `black_level_v` (0.3 V), peak white at
//! `white_level_v` (1.0 V into 75 Ω).
//!
//! The CCD's columns are clocked out uniformly over the active line, so
//! the pixel period is `T_pix = active / columns`; frame row `r` goes to
//! field `r mod 2` (odd rows in the second field, 2:1 interlace), line
//! `⌊r/2⌋` of that field's picture lines.

use serde::{Deserialize, Serialize};

use crate::error::LineError;

/// A broadcast video format.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VideoFormat {
    /// EIA RS-170 (525/60), 63.556 µs lines.
    #[serde(rename = "rs-170")]
    Rs170,
    /// CCIR / ITU-R BT.470 B/G (625/50), 64 µs lines.
    #[default]
    Ccir,
}

/// Horizontal and vertical timing of a format, seconds and lines.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LineTiming {
    pub format: VideoFormat,
    /// Line period H, s.
    pub line_s: f64,
    /// Front porch (end of active video to the sync's leading edge), s.
    pub front_porch_s: f64,
    /// Horizontal sync pulse width, s (its leading edge is the 0H datum).
    pub sync_s: f64,
    /// Sync trailing edge to the start of active video, s.
    pub back_porch_s: f64,
    /// Lines per frame.
    pub lines_per_frame: u32,
    /// Picture (active) lines per frame.
    pub active_lines: u32,
    /// Fields per second.
    pub field_rate_hz: f64,
}

impl LineTiming {
    /// The standard timing of `format` (see the module comment for sources).
    pub fn of(format: VideoFormat) -> Self {
        match format {
            VideoFormat::Rs170 => Self {
                format,
                line_s: 63.556e-6,
                front_porch_s: 1.5e-6,
                sync_s: 4.7e-6,
                // 10.9 µs blanking − front porch − sync.
                back_porch_s: 4.7e-6,
                lines_per_frame: 525,
                active_lines: 485,
                field_rate_hz: 60_000.0 / 1001.0,
            },
            VideoFormat::Ccir => Self {
                format,
                line_s: 64e-6,
                front_porch_s: 1.5e-6,
                sync_s: 4.7e-6,
                // 10.5 µs from 0H to the end of blanking, minus sync.
                back_porch_s: 5.8e-6,
                lines_per_frame: 625,
                active_lines: 575,
                field_rate_hz: 50.0,
            },
        }
    }

    /// Line blanking: front porch + sync + back porch, s.
    pub fn blanking_s(&self) -> f64 {
        self.front_porch_s + self.sync_s + self.back_porch_s
    }

    /// Active (picture) part of a line, s.
    pub fn active_s(&self) -> f64 {
        self.line_s - self.blanking_s()
    }

    /// Start of active video after the 0H datum (sync leading edge), s.
    pub fn active_start_s(&self) -> f64 {
        self.sync_s + self.back_porch_s
    }

    /// The pixel period when `columns` CCD pixels fill the active line, s.
    pub fn pixel_period_s(&self, columns: usize) -> f64 {
        self.active_s() / columns.max(1) as f64
    }

    /// Where frame row `row` of `rows` goes: `(field 0 or 1, frame line
    /// number 1..=lines_per_frame)`, the picture centred vertically. Errors
    /// when the frame has more rows than the format has picture lines.
    pub fn line_of_row(&self, row: usize, rows: usize) -> Result<(u32, u32), LineError> {
        if rows > self.active_lines as usize {
            return Err(LineError::FrameTooTall {
                rows,
                picture_lines: self.active_lines,
                format: self.format.label(),
            });
        }
        if row >= rows {
            return Err(LineError::RowOutside { row, rows });
        }
        let per_field_total = self.lines_per_frame as f64 / 2.0;
        let per_field_active = self.active_lines / 2;
        let blank = (per_field_total - f64::from(self.active_lines) / 2.0).floor() as u32;
        // Centre the frame's rows among the picture lines.
        let first = (self.active_lines as usize - rows) / 2;
        let picture_row = first + row;
        let field = (picture_row % 2) as u32;
        let in_field = (picture_row / 2) as u32;
        let line = if field == 0 {
            blank + 1 + in_field.min(per_field_active)
        } else {
            // The second field starts half-way through line 263 (525) or
            // 313 (625).
            per_field_total.ceil() as u32 + blank + 1 + in_field.min(per_field_active)
        };
        Ok((field, line))
    }
}

impl VideoFormat {
    /// `"RS-170 (525/60)"` or `"CCIR (625/50)"`.
    pub fn label(&self) -> &'static str {
        match self {
            VideoFormat::Rs170 => "RS-170 (525/60)",
            VideoFormat::Ccir => "CCIR (625/50)",
        }
    }
}

/// Voltage levels of the composite signal, V.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Levels {
    pub sync_tip_v: f64,
    /// Blanking = black (no set-up).
    pub blanking_v: f64,
}

/// The composite input of one line before the video amplifier, as
/// `(start s from 0H, duration s, volts)` segments: sync, back porch, one
/// held step per CCD pixel of `active_v`, front porch, then the next
/// line's sync (so a trace shows two leading edges one H apart).
pub fn line_segments(t: &LineTiming, levels: Levels, active_v: &[f64]) -> Vec<(f64, f64, f64)> {
    let mut s = Vec::with_capacity(active_v.len() + 5);
    s.push((0.0, t.sync_s, levels.sync_tip_v));
    s.push((t.sync_s, t.back_porch_s, levels.blanking_v));
    let tp = t.pixel_period_s(active_v.len());
    let a0 = t.active_start_s();
    for (i, &v) in active_v.iter().enumerate() {
        s.push((a0 + i as f64 * tp, tp, v));
    }
    s.push((a0 + t.active_s(), t.front_porch_s, levels.blanking_v));
    s.push((t.line_s, t.sync_s, levels.sync_tip_v));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_line_budgets_add_up() {
        let r = LineTiming::of(VideoFormat::Rs170);
        // SMPTE 170M: 10.9 µs blanking, 52.656 µs active of 63.556 µs.
        assert!((r.blanking_s() - 10.9e-6).abs() < 1e-12);
        assert!((r.active_s() - 52.656e-6).abs() < 1e-12);
        // 525 lines at 59.94 fields/s, 2 fields per frame: H = 2/(525 · 59.94).
        let h = 2.0 / (525.0 * r.field_rate_hz);
        assert!((h - r.line_s).abs() / r.line_s < 1e-4, "{h}");
        let c = LineTiming::of(VideoFormat::Ccir);
        assert!((c.blanking_s() - 12e-6).abs() < 1e-12);
        assert!((c.active_s() - 52e-6).abs() < 1e-12);
        assert!((2.0 / (625.0 * c.field_rate_hz) - c.line_s).abs() < 1e-12);
    }

    #[test]
    fn rows_interlace_into_two_fields() {
        let r = LineTiming::of(VideoFormat::Rs170);
        // A full 485-row frame: row 0 is the first picture line of field 1
        // (line 21), row 1 the first of field 2 (line 263 + 21 = 284).
        assert_eq!(r.line_of_row(0, 485).unwrap(), (0, 21));
        assert_eq!(r.line_of_row(1, 485).unwrap(), (1, 284));
        assert_eq!(r.line_of_row(2, 485).unwrap(), (0, 22));
        let e = r.line_of_row(0, 768).unwrap_err().to_string();
        assert!(e.contains("768 rows") && e.contains("485"), "{e}");
        assert!(r.line_of_row(9, 8).is_err());
    }

    #[test]
    fn segments_tile_the_line_without_gaps() {
        let t = LineTiming::of(VideoFormat::Ccir);
        let l = Levels {
            sync_tip_v: 0.0,
            blanking_v: 0.3,
        };
        let s = line_segments(&t, l, &[0.5; 100]);
        for w in s.windows(2) {
            assert!((w[0].0 + w[0].1 - w[1].0).abs() < 1e-15);
        }
        let last = s.last().unwrap();
        assert!((last.0 - t.line_s).abs() < 1e-15);
    }
}
