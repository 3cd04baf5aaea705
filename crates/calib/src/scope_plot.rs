//! A scan line drawn like an oscilloscope screen: black face, green trace,
//! a 10 × 8 division graticule, the volts and microseconds per division
//! printed below, the digitizer's sample instants as dots (optional).

use std::path::Path;

use plotters::prelude::*;
use plotters_bitmap::BitMapBackend;

use gloam_sensor::scope::ScopeLine;

use crate::error::CalibError;
use crate::plot::ensure_font;

const TRACE: [RGBColor; 3] = [
    RGBColor(80, 255, 120),
    RGBColor(255, 220, 60),
    RGBColor(90, 200, 255),
];

/// A "nice" step (1, 2 or 5 × 10^k) at least `raw`.
fn nice(raw: f64) -> f64 {
    let e = raw.log10().floor();
    let b = 10f64.powf(e);
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * b)
        .find(|&s| s >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * b)
}

/// The time axis, µs: ten round divisions from a round start that cover
/// every line's samples; (µs per division, start, end).
fn time_axis(lines: &[ScopeLine]) -> (f64, f64, f64) {
    let t0 = lines
        .iter()
        .filter_map(|l| l.time_s.first())
        .fold(f64::INFINITY, |a, &b| a.min(b))
        * 1e6;
    let t1 = lines
        .iter()
        .filter_map(|l| l.time_s.last())
        .fold(f64::NEG_INFINITY, |a, &b| a.max(b))
        * 1e6;
    let us_div = nice((t1 - t0) / 10.0);
    let x0 = (t0 / us_div).floor() * us_div;
    let x1 = x0 + 10.0 * us_div;
    (us_div, x0, x1)
}

/// Draws `lines` (volts against µs from 0H) to a PNG (900 × 600).
pub fn scope_plot(
    path: &Path,
    title: &str,
    lines: &[ScopeLine],
    show_samples: bool,
) -> Result<(), CalibError> {
    if lines.is_empty() {
        return Err(CalibError::InsufficientData("no scan line to plot".into()));
    }
    ensure_font();
    let (w, h) = (900u32, 600u32);
    let (us_div, x0, x1) = time_axis(lines);
    // 0.2 V/div from −0.2 V: the 1 V composite fills six of eight divisions.
    let (v_div, y0) = (0.2, -0.2);
    let y1 = y0 + 8.0 * v_div;
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let e = |e: &dyn std::fmt::Display| CalibError::Io(format!("scope plot: {e}"));
        root.fill(&RGBColor(8, 12, 10)).map_err(|x| e(&x))?;
        let grid = RGBColor(60, 80, 70);
        let text = ("sans-serif", 15)
            .into_font()
            .color(&RGBColor(200, 230, 210));
        let mut chart = ChartBuilder::on(&root)
            .caption(title, text.clone())
            .margin(14)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_labels(11)
            .y_labels(9)
            .x_desc(format!("time from 0H (µs), {us_div} µs/div"))
            .y_desc(format!("volts, {v_div} V/div"))
            .bold_line_style(grid)
            .light_line_style(RGBColor(25, 35, 30))
            .axis_style(grid)
            .label_style(text.clone())
            .x_label_formatter(&|v| format!("{v:.1}"))
            .y_label_formatter(&|v| format!("{v:.1}"))
            .draw()
            .map_err(|x| e(&x))?;
        for (i, l) in lines.iter().enumerate() {
            let c = TRACE[i % TRACE.len()];
            let pts: Vec<(f64, f64)> = l
                .time_s
                .iter()
                .zip(&l.volts)
                .map(|(t, v)| (t * 1e6, v.clamp(y0, y1)))
                .collect();
            chart
                .draw_series(LineSeries::new(pts, c.stroke_width(1)))
                .map_err(|x| e(&x))?
                .label(format!(
                    "row {} (field {}, line {})",
                    l.row,
                    l.field + 1,
                    l.line
                ))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c));
            if show_samples {
                chart
                    .draw_series(
                        l.samples
                            .iter()
                            .map(|&(t, v)| Circle::new((t * 1e6, v), 1, c.mix(0.6).filled())),
                    )
                    .map_err(|x| e(&x))?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(RGBColor(8, 12, 10).mix(0.9))
            .border_style(grid)
            .label_font(text)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    let png = gloam_io::png::rgb8_png(w, h, buf)
        .ok_or_else(|| CalibError::Io("scope plot buffer has the wrong size".into()))?
        .map_err(|e| CalibError::file(path, e))?;
    crate::report::write_bytes(path, &png)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps() {
        assert_eq!(nice(6.4), 10.0);
        assert_eq!(nice(1.5), 2.0);
        assert_eq!(nice(0.3), 0.5);
        assert_eq!(nice(5.0), 5.0);
    }
}
