//! An oscilloscope on the camera's video output: one frame row as the
//! composite line (sync, blanking, the CCD's held pixel levels through the
//! video amplifier) against time, plus where the digitizer samples it.

use serde::Serialize;

use crate::camera::Camera;
use crate::error::ScopeError;
use crate::stages::video_timing::{Levels, LineTiming, line_segments};

/// Trace points per pixel period.
pub const POINTS_PER_PIXEL: usize = 8;

/// One scan line as a scope shows it.
#[derive(Clone, Debug, Serialize)]
pub struct ScopeLine {
    /// Frame row.
    pub row: usize,
    /// Field (0 or 1) and frame line number (1-based) it is sent on.
    pub field: u32,
    pub line: u32,
    pub timing: LineTiming,
    /// Time from the sync's leading edge (0H), s: from the front porch
    /// before it to the end of the next line's sync.
    pub time_s: Vec<f64>,
    pub volts: Vec<f64>,
    /// `(time s, volts)` where the digitizer samples the active line.
    pub samples: Vec<(f64, f64)>,
}

/// The video's held level per pixel for CCD electrons `e`:
/// `V_black + e (V_white − V_black)/e_full`, clipped at the white clip.
fn held_volts(cam: &Camera, electrons: &[f64]) -> Option<Vec<f64>> {
    let v = cam.config().video.as_ref()?;
    let k = (v.white_level_v - v.black_level_v) / v.full_scale_e;
    let clip = v.white_clip_v.unwrap_or(v.white_level_v);
    Some(
        electrons
            .iter()
            .map(|&e| (v.black_level_v + e * k).min(clip))
            .collect(),
    )
}

/// The lines of the rows asked for with [`Camera::set_scope_rows`], from
/// the last capture (`rows × columns` frames). Errors name what is missing:
/// no video stage, no capture, or a frame taller than the format's picture.
pub fn scope_lines(cam: &Camera, rows: usize) -> Result<Vec<ScopeLine>, ScopeError> {
    let chain = cam.chain();
    let video = cam
        .config()
        .video
        .as_ref()
        .ok_or_else(|| ScopeError::NoVideo {
            sensor: cam.config().name.clone(),
        })?;
    let timing = LineTiming::of(video.format);
    let held = cam.scope_electrons();
    if held.is_empty() {
        return Err(ScopeError::NoLineKept);
    }
    let levels = Levels {
        sync_tip_v: 0.0,
        blanking_v: video.black_level_v,
    };
    let mut out = Vec::new();
    for (row, e) in held {
        let (field, line) = timing.line_of_row(*row, rows)?;
        let v = held_volts(cam, e).unwrap_or_default();
        let cols = v.len();
        let tp = timing.pixel_period_s(cols);
        let dt = tp / POINTS_PER_PIXEL as f64;
        // The previous line's front porch first, so the 0H edge passes
        // through the amplifier like every other edge.
        let fp = timing.front_porch_s;
        let mut held_segs = vec![(fp, levels.blanking_v)];
        held_segs.extend(
            line_segments(&timing, levels, &v)
                .into_iter()
                .map(|(_, d, u)| (d, u)),
        );
        let volts = match chain.amplifier() {
            Some(a) => a.trace(&held_segs, dt),
            None => {
                let mut y = Vec::new();
                let mut t_end = 0.0;
                for &(d, u) in &held_segs {
                    t_end += d;
                    let end = (t_end / dt).round() as usize;
                    y.resize(end, u);
                }
                let last = y.last().copied().unwrap_or(0.0);
                y.push(last);
                y
            }
        };
        let time_s: Vec<f64> = (0..volts.len()).map(|i| i as f64 * dt - fp).collect();
        // Active video starts on the grid point its held steps were put on.
        let a0 = ((fp + timing.active_start_s()) / dt).round() * dt - fp;
        let phase = cam.config().digitizer.sample_phase;
        let samples = (0..cols)
            .map(|n| {
                let t = a0 + (n as f64 + phase) * tp;
                let i = (t + fp) / dt;
                let j = (i.floor() as usize).min(volts.len().saturating_sub(2));
                let w = i - j as f64;
                (t, volts[j] * (1.0 - w) + volts[j + 1] * w)
            })
            .collect();
        out.push(ScopeLine {
            row: *row,
            field,
            line,
            timing,
            time_s,
            volts,
            samples,
        });
    }
    Ok(out)
}

/// The least-squares fundamental `a + b cos(2πνt) + c sin(2πνt)` over the
/// active part of a line: `(mean V, amplitude V)`. A lab scope's V_max and
/// V_min of a sine pattern are `mean ± amplitude` of this fit (raw peaks
/// would add the held steps' ripple).
pub fn fundamental(line: &ScopeLine, nu_hz: f64) -> Option<(f64, f64)> {
    let t = &line.timing;
    let (lo, hi) = (t.active_start_s(), t.active_start_s() + t.active_s());
    let mut ata = [[0.0f64; 3]; 3];
    let mut aty = [0.0f64; 3];
    for (&ts, &v) in line.time_s.iter().zip(&line.volts) {
        if ts < lo || ts >= hi {
            continue;
        }
        let p = std::f64::consts::TAU * nu_hz * ts;
        let b = [1.0, p.cos(), p.sin()];
        for i in 0..3 {
            aty[i] += b[i] * v;
            for j in 0..3 {
                ata[i][j] += b[i] * b[j];
            }
        }
    }
    let x = solve3(ata, aty)?;
    Some((x[0], x[1].hypot(x[2])))
}

/// Solves the 3×3 system `a·x = b` (the normal equations of a DC + cos +
/// sin least-squares fit) by Gauss–Jordan with partial pivoting; `None`
/// when a pivot is below 1e-10 of the largest entry (singular). Shared
/// with `gloam-calib`'s sine-target MTF fit.
pub fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    for col in 0..3 {
        let piv = (col..3).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() <= 1e-10 * scale {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        let p = a[col];
        for r in 0..3 {
            if r != col {
                let k = a[r][col] / p[col];
                for (x, q) in a[r].iter_mut().zip(p) {
                    *x -= k * q;
                }
                b[r] -= k * b[col];
            }
        }
    }
    Some([b[0] / a[0][0], b[1] / a[1][1], b[2] / a[2][2]])
}

/// CSV of lines: `row,field,line,time_us,volts`.
pub fn to_csv(lines: &[ScopeLine]) -> String {
    let mut s = String::from("row,field,line,time_us,volts\n");
    for l in lines {
        for (t, v) in l.time_s.iter().zip(&l.volts) {
            s.push_str(&format!(
                "{},{},{},{:.5},{:.5}\n",
                l.row,
                l.field,
                l.line,
                t * 1e6,
                v
            ));
        }
    }
    s
}

/// What a scope's cursors read off a line: sync tip, blanking, the active
/// video's range, and the sync width and line period at half sync height.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct LineReadout {
    pub sync_tip_v: f64,
    pub blanking_v: f64,
    pub active_min_v: f64,
    pub active_max_v: f64,
    pub sync_width_s: f64,
    pub line_period_s: f64,
}

/// Reads [`LineReadout`] off a trace (levels are medians away from edges).
pub fn read_line(l: &ScopeLine) -> Option<LineReadout> {
    let t = &l.timing;
    let median = |lo: f64, hi: f64| {
        let mut v: Vec<f64> = l
            .time_s
            .iter()
            .zip(&l.volts)
            .filter(|(ts, _)| **ts >= lo && **ts < hi)
            .map(|(_, v)| *v)
            .collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied()
    };
    let sync = median(0.5e-6, t.sync_s - 0.5e-6)?;
    let blank = median(t.sync_s + 1.0e-6, t.active_start_s() - 0.5e-6)?;
    let half = 0.5 * (sync + blank);
    // Falling crossings of the half level: the leading edges.
    let mut edges = Vec::new();
    let mut rising = None;
    for i in 1..l.volts.len() {
        let (a, b) = (l.volts[i - 1], l.volts[i]);
        let at = |a: f64, b: f64| {
            l.time_s[i - 1] + (half - a) / (b - a) * (l.time_s[i] - l.time_s[i - 1])
        };
        if a > half && b <= half {
            edges.push(at(a, b));
        }
        if a < half && b >= half && rising.is_none() && !edges.is_empty() {
            rising = Some(at(a, b));
        }
    }
    let first_fall = *edges.first()?;
    let next_fall = *edges.iter().find(|&&e| e > t.line_s * 0.5)?;
    let (a0, a1) = (t.active_start_s(), t.active_start_s() + t.active_s());
    let act: Vec<f64> = l
        .time_s
        .iter()
        .zip(&l.volts)
        .filter(|(ts, _)| **ts >= a0 && **ts < a1)
        .map(|(_, v)| *v)
        .collect();
    Some(LineReadout {
        sync_tip_v: sync,
        blanking_v: blank,
        active_min_v: act.iter().copied().fold(f64::INFINITY, f64::min),
        active_max_v: act.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        sync_width_s: rising? - first_fall,
        line_period_s: next_fall - first_fall,
    })
}
