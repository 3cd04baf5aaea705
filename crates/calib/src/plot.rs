//! PNG plots with `plotters` (bitmap backend, no system fonts: the text is
//! drawn with DejaVu Sans Mono, shipped in `assets/` and embedded).

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};
use plotters_bitmap::BitMapBackend;

use crate::error::CalibError;

static FONT: Once = Once::new();
const FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSansMono.ttf");

pub(crate) fn ensure_font() {
    FONT.call_once(|| {
        let _ = register_font("sans-serif", FontStyle::Normal, FONT_BYTES);
    });
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mark {
    Line,
    Points,
    LinePoints,
}

/// One named series of (x, y) points.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub mark: Mark,
}

impl Series {
    pub fn new(name: &str, points: Vec<(f64, f64)>, mark: Mark) -> Self {
        Self {
            name: name.into(),
            points,
            mark,
        }
    }
}

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
];

/// How an axis maps values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    Linear,
    /// Decades equally spaced; ticks are labelled with the values
    /// themselves. Points ≤ 0 cannot be drawn and are skipped.
    Log10,
}

impl Scale {
    fn axis_at(self, v: f64) -> f64 {
        match self {
            Scale::Linear => v,
            Scale::Log10 if v > 0.0 => v.log10(),
            Scale::Log10 => f64::NAN,
        }
    }

    fn value_at(self, a: f64) -> f64 {
        match self {
            Scale::Linear => a,
            Scale::Log10 => 10f64.powf(a),
        }
    }
}

/// Draws an x–y plot to a PNG file (800×560). Non-finite points are skipped.
pub fn xy_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<(), CalibError> {
    xy_plot_scaled(
        path,
        title,
        (x_label, Scale::Linear),
        (y_label, Scale::Linear),
        series,
    )
}

/// [`xy_plot`] with a chosen scale per axis, e.g. log–log for error
/// against time. Points that an axis cannot show (non-finite, or ≤ 0 on a
/// log axis) are skipped.
pub fn xy_plot_scaled(
    path: &Path,
    title: &str,
    (x_label, x_scale): (&str, Scale),
    (y_label, y_scale): (&str, Scale),
    series: &[Series],
) -> Result<(), CalibError> {
    let series: Vec<Series> = series
        .iter()
        .map(|s| Series {
            name: s.name.clone(),
            points: s
                .points
                .iter()
                .map(|&(x, y)| (x_scale.axis_at(x), y_scale.axis_at(y)))
                .collect(),
            mark: s.mark,
        })
        .collect();
    let series = &series[..];
    ensure_font();
    let (w, h) = (800u32, 560u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().filter(finite).copied())
        .collect();
    if all.is_empty() {
        return Err(CalibError::InsufficientData(format!(
            "nothing to plot in '{title}'"
        )));
    }
    let ((x0, x1), (y0, y1)) = padded_ranges(&all);
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let e = |e: &dyn std::fmt::Display| CalibError::Io(format!("plot '{title}': {e}"));
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|x| e(&x))?;
        let fx = tick_format(x_scale.value_at(x0), x_scale.value_at(x1), x_scale);
        let fy = tick_format(y_scale.value_at(y0), y_scale.value_at(y1), y_scale);
        chart
            .configure_mesh()
            .x_label_formatter(&|v| fmt_tick(x_scale.value_at(*v), fx))
            .y_label_formatter(&|v| fmt_tick(y_scale.value_at(*v), fy))
            .x_desc(x_label)
            .y_desc(y_label)
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|x| e(&x))?;
        for (i, s) in series.iter().enumerate() {
            let c = COLORS[i % COLORS.len()];
            let pts: Vec<(f64, f64)> = s.points.iter().filter(finite).copied().collect();
            if matches!(s.mark, Mark::Line | Mark::LinePoints) {
                chart
                    .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
                    .map_err(|x| e(&x))?
                    .label(s.name.clone())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c));
            }
            if matches!(s.mark, Mark::Points | Mark::LinePoints) {
                let a = chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))
                    .map_err(|x| e(&x))?;
                if s.mark == Mark::Points {
                    a.label(s.name.clone())
                        .legend(move |(x, y)| Circle::new((x + 9, y), 3, c.filled()));
                }
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    let png = gloam_io::png::rgb8_png(w, h, buf)
        .ok_or_else(|| CalibError::Io("plot buffer has the wrong size".into()))?
        .map_err(|e| CalibError::file(path, e))?;
    crate::report::write_bytes(path, &png)
}

/// The x and y ranges of `all`, each padded by 5 % a side (and never
/// empty) so no point sits on the frame.
fn padded_ranges(all: &[(f64, f64)]) -> ((f64, f64), (f64, f64)) {
    let pad = |lo: f64, hi: f64| {
        let d = (hi - lo).abs().max(1e-12 * hi.abs().max(1.0));
        (lo - 0.05 * d, hi + 0.05 * d)
    };
    let (x0, x1) = pad(
        all.iter().map(|p| p.0).fold(f64::INFINITY, f64::min),
        all.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max),
    );
    let (y0, y1) = pad(
        all.iter().map(|p| p.1).fold(f64::INFINITY, f64::min),
        all.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max),
    );
    ((x0, x1), (y0, y1))
}

/// Scientific notation for axes spanning tiny or huge values (on a log
/// axis, also reaching down to tiny ones), else plain.
fn tick_format(lo: f64, hi: f64, scale: Scale) -> bool {
    let m = lo.abs().max(hi.abs());
    let n = lo.abs().min(hi.abs());
    (m > 0.0 && !(1e-2..1e5).contains(&m)) || (scale == Scale::Log10 && n < 1e-2)
}

fn fmt_tick(v: f64, sci: bool) -> String {
    if sci {
        format!("{v:.2e}")
    } else {
        let s = format!("{v:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" { "0".into() } else { s.to_string() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axes_map_decades_and_skip_what_they_cannot_show() {
        assert_eq!(Scale::Log10.axis_at(1000.0), 3.0);
        assert!(Scale::Log10.axis_at(0.0).is_nan() && Scale::Log10.axis_at(-1.0).is_nan());
        assert!((Scale::Log10.value_at(-2.0) - 0.01).abs() < 1e-15);
        assert_eq!(Scale::Linear.axis_at(-4.5), -4.5);
        // Ticks: decimals for ordinary ranges, scientific for tiny or huge.
        assert!(!tick_format(0.0, 100.0, Scale::Linear));
        assert!(tick_format(1e-4, 1e-1, Scale::Log10));
        assert!(tick_format(1.0, 1e7, Scale::Linear));
        assert_eq!(fmt_tick(0.25, false), "0.25");
        assert_eq!(fmt_tick(1e-3, true), "1.00e-3");

        // A log–log plot with a zero and a negative point draws the rest;
        // with nothing drawable it is a clear error.
        let dir = std::env::temp_dir().join(format!("gloam-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join("loglog.png");
        let pts = vec![
            (0.01, 1.0),
            (0.1, 0.1),
            (1.0, 0.01),
            (0.0, 1.0),
            (2.0, -1.0),
        ];
        xy_plot_scaled(
            &png,
            "log-log",
            ("time (s)", Scale::Log10),
            ("error", Scale::Log10),
            &[Series::new("power law", pts, Mark::LinePoints)],
        )
        .unwrap();
        assert!(std::fs::metadata(&png).unwrap().len() > 1000);
        let e = xy_plot_scaled(
            &png,
            "nothing",
            ("x", Scale::Log10),
            ("y", Scale::Linear),
            &[Series::new(
                "non-positive",
                vec![(0.0, 1.0), (-1.0, 2.0)],
                Mark::Points,
            )],
        )
        .unwrap_err();
        assert!(e.to_string().contains("nothing to plot"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
