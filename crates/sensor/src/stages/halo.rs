//! Halo: photoelectrons that bounce off the MCP's input face and land again
//! on the plate, a disc of radius ≈ twice the cathode–MCP gap around every
//! bright point.
//!
//! # Model and sources
//!
//! A photoelectron that strikes the plate between channels (the closed
//! area, `1 − η` of the face) is backscattered with probability `b`,
//! keeping most of its energy `e V_gap`. In the uniform retarding field of
//! the gap it flies a parabola and lands at `R = 2 L sin 2θ` from where it
//! struck (L the gap, θ the angle from the normal): at most `2 L`, at 45°,
//! independent of the gap voltage (Csorba, *Image Tubes*, 1985, ch. 4;
//! the "halo diameter ≈ 4 × gap" rule of proximity-focused tubes). Such
//! electrons then start a cascade with the same probability η as any
//! other, so per detected photoelectron `(1 − η) b` more land in the halo,
//! and the halo's share of the output is `f = (1 − η) b / (1 + (1 − η) b)`.
//! `b` = 0.25 (assumed) lies between the low-keV backscatter coefficients
//! of silicon (≈ 0.17) and lead (≈ 0.45) for the lead-silicate glass and
//! its ion-barrier film; with η = 0.65 this gives f ≈ 8 % for the Gen III
//! preset.
//!
//! The landing points are spread uniformly over the disc of radius `2 L`
//! (the and the tube makers' description of the halo; the exact
//! distribution peaks towards the rim, which a uniform disc slightly
//! under-weights). Backscatter moves single electrons, so the halo acts
//! on the mean photoelectron rate before shot noise, like the other
//! pre-noise blurs; `(1 − f)` stays in place and `f` goes into the disc,
//! so a uniform field is unchanged and light is conserved. Beyond the
//! frame edge the cathode is taken to continue the edge pixels.

use rayon::prelude::*;

use crate::config::HaloConfig;

/// The halo at one camera's geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct Halo {
    /// Share f of the output in the halo.
    pub fraction: f64,
    /// Disc radius, cathode pixels.
    pub radius_px: f64,
}

/// Landing distance of an electron backscattered with its full energy at
/// `angle_rad` from the normal across a uniform-field gap of `gap_mm`:
/// `R = 2 L sin 2θ` (mm).
pub fn backscatter_range_mm(gap_mm: f64, angle_rad: f64) -> f64 {
    2.0 * gap_mm * (2.0 * angle_rad).sin()
}

/// The halo's share of the output for open area η and backscatter
/// coefficient b: `(1 − η) b / (1 + (1 − η) b)`.
pub fn halo_fraction(open_area: f64, backscatter: f64) -> f64 {
    let extra = (1.0 - open_area).max(0.0) * backscatter;
    extra / (1.0 + extra)
}

impl Halo {
    /// The halo of a cathode–MCP gap of `gap_mm` behind pixels
    /// `pitch_cathode_mm` wide; None when switched off or empty.
    pub fn new(c: &HaloConfig, open_area: f64, gap_mm: f64, pitch_cathode_mm: f64) -> Option<Self> {
        let fraction = halo_fraction(open_area, c.backscatter_coefficient);
        let radius_px = 2.0 * gap_mm / pitch_cathode_mm;
        (c.enabled && fraction > 0.0 && radius_px >= 1.0).then_some(Self {
            fraction,
            radius_px,
        })
    }

    /// Applies the halo in place to the `rows × cols` frame `pe`: each
    /// pixel keeps `1 − f` and receives `f` times the mean over the disc
    /// around it. Row prefix sums make the disc mean `O(rows · cols ·
    /// (2R + 1))`; for a disc wider than 16 pixels it is taken on a grid
    /// binned by `b = ⌊R/8⌋` and interpolated back (bilinear), which blurs
    /// the halo's rim by about `b` pixels and costs ~`1/b³` as much.
    pub fn apply(&self, pe: &mut [f32], rows: usize, cols: usize) {
        self.apply_with(pe, rows, cols, &mut Vec::new());
    }

    /// [`Halo::apply`] with `prefix` as scratch for the row prefix sums,
    /// kept by the caller from frame to frame (no allocation per frame).
    pub fn apply_with(&self, pe: &mut [f32], rows: usize, cols: usize, prefix: &mut Vec<f64>) {
        let b = ((self.radius_px / 8.0).floor() as usize).max(1);
        let (keep, f) = (1.0 - self.fraction, self.fraction);
        if b == 1 {
            // The disc mean of each row is taken from the prefix sums only,
            // so the row can be overwritten as soon as it is known.
            let disc = Disc::new(pe, rows, cols, chords(self.radius_px), prefix);
            pe.par_chunks_mut(cols)
                .enumerate()
                .for_each_init(Vec::new, |mean, (r, out)| {
                    disc.row_mean(r, mean);
                    for (o, &m) in out.iter_mut().zip(mean.iter()) {
                        *o = (keep * *o as f64 + f * m) as f32;
                    }
                });
            return;
        }
        // Bin b × b (edge blocks average the pixels they have).
        let (rb, cb) = (rows.div_ceil(b), cols.div_ceil(b));
        let mut binned = vec![0f32; rb * cb];
        binned.par_chunks_mut(cb).enumerate().for_each(|(br, out)| {
            let r0 = br * b;
            let r1 = (r0 + b).min(rows);
            for (bc, o) in out.iter_mut().enumerate() {
                let c0 = bc * b;
                let c1 = (c0 + b).min(cols);
                let mut sum = 0f64;
                for r in r0..r1 {
                    sum += pe[r * cols + c0..r * cols + c1]
                        .iter()
                        .map(|&v| v as f64)
                        .sum::<f64>();
                }
                *o = (sum / ((r1 - r0) * (c1 - c0)) as f64) as f32;
            }
        });
        let disc = Disc::new(&binned, rb, cb, chords(self.radius_px / b as f64), prefix);
        let mut mean = vec![0f64; rb * cb];
        mean.par_chunks_mut(cb)
            .enumerate()
            .for_each_init(Vec::new, |m, (r, out)| {
                disc.row_mean(r, m);
                out.copy_from_slice(m);
            });
        // Bilinear back to full resolution at the pixel centres.
        let at = |x: usize, n: usize| {
            let t = ((x as f64 + 0.5) / b as f64 - 0.5).clamp(0.0, (n - 1) as f64);
            let i = (t.floor() as usize).min(n.saturating_sub(2));
            (i, (i + 1).min(n - 1), t - i as f64)
        };
        let col_w: Vec<_> = (0..cols).map(|c| at(c, cb)).collect();
        pe.par_chunks_mut(cols).enumerate().for_each(|(r, out)| {
            let (r0, r1, wr) = at(r, rb);
            let (m0, m1) = (&mean[r0 * cb..(r0 + 1) * cb], &mean[r1 * cb..(r1 + 1) * cb]);
            for (o, &(c0, c1, wc)) in out.iter_mut().zip(&col_w) {
                let top = m0[c0] * (1.0 - wc) + m0[c1] * wc;
                let bot = m1[c0] * (1.0 - wc) + m1[c1] * wc;
                let m = top * (1.0 - wr) + bot * wr;
                *o = (keep * *o as f64 + f * m) as f32;
            }
        });
    }
}

/// Half-widths of a disc's rows, `dy = −R…R`: the lattice points with
/// `dx² + dy² ≤ R²`.
fn chords(r: f64) -> Vec<usize> {
    let n = r.floor() as i64;
    (-n..=n)
        .map(|dy| ((r * r - (dy * dy) as f64).max(0.0).sqrt()).floor() as usize)
        .collect()
}

/// The mean of an image over the disc of `chords` around every pixel,
/// edge pixels repeated beyond the frame, from its rows' prefix sums.
struct Disc<'a> {
    /// Prefix sums of each row with its edge pixels repeated `pad` times.
    prefix: &'a [f64],
    rows: usize,
    cols: usize,
    width: usize,
    chords: Vec<usize>,
    count: f64,
}

impl<'a> Disc<'a> {
    fn new(
        img: &[f32],
        rows: usize,
        cols: usize,
        chords: Vec<usize>,
        prefix: &'a mut Vec<f64>,
    ) -> Self {
        let pad = chords.len() / 2;
        let width = cols + 2 * pad + 1;
        // Every element is written below.
        prefix.resize(rows * width, 0.0);
        prefix
            .par_chunks_mut(width)
            .zip(img.par_chunks(cols))
            .for_each(|(p, row)| {
                let mut acc = 0f64;
                p[0] = 0.0;
                let padded = std::iter::repeat_n(&row[0], pad)
                    .chain(row)
                    .chain(std::iter::repeat_n(&row[cols - 1], pad));
                for (o, &v) in p[1..].iter_mut().zip(padded) {
                    acc += v as f64;
                    *o = acc;
                }
            });
        let count = chords.iter().map(|&w| (2 * w + 1) as f64).sum();
        Self {
            prefix,
            rows,
            cols,
            width,
            chords,
            count,
        }
    }

    /// Row `r`'s disc means into `out`: chord by chord across the row (so
    /// the loop runs over contiguous columns and vectorises), each pixel's
    /// sum taken over the chords in the same order as pixel by pixel.
    fn row_mean(&self, r: usize, out: &mut Vec<f64>) {
        let (n, cols) = (self.chords.len() / 2, self.cols);
        let pad = n;
        out.clear();
        out.resize(cols, 0.0);
        for (j, &w) in self.chords.iter().enumerate() {
            let rr = (r as i64 + j as i64 - n as i64).clamp(0, self.rows as i64 - 1) as usize;
            let p = &self.prefix[rr * self.width..(rr + 1) * self.width];
            // Columns c − w … c + w, shifted by the padding.
            accumulate_chord(out, &p[pad + w + 1..], &p[pad - w..]);
        }
        for o in out.iter_mut() {
            *o /= self.count;
        }
    }
}

/// `out[c] += hi[c] − lo[c]`: compiled for AVX2 as well as the baseline
/// (no fused multiply-add, so the same bits either way).
#[multiversion::multiversion(targets("x86_64+avx2"))]
fn accumulate_chord(out: &mut [f64], hi: &[f64], lo: &[f64]) {
    for ((o, &h), &l) in out.iter_mut().zip(hi).zip(lo) {
        *o += h - l;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn halo(r: f64, f: f64) -> Halo {
        Halo {
            fraction: f,
            radius_px: r,
        }
    }

    /// The landing range against a step-by-step integration of the
    /// electron's flight back across the retarding field.
    #[test]
    fn range_is_twice_the_gap_at_45_degrees_by_integrating_the_flight() {
        let (gap_m, volts): (f64, f64) = (0.2e-3, 600.0);
        let (q_over_m, field): (f64, f64) = (1.758_820_01e11, volts / gap_m);
        for deg in [15.0f64, 30.0, 45.0, 60.0] {
            let th = deg.to_radians();
            // Leaves the plate with energy e V (it was accelerated across the gap).
            let v = (2.0 * q_over_m * volts).sqrt();
            let (mut x, mut z, vx, mut vz) = (0.0, 0.0, v * th.sin(), v * th.cos());
            let dt = 1e-15;
            loop {
                // Velocity Verlet under a constant deceleration back to the plate.
                let a = -q_over_m * field;
                z += vz * dt + 0.5 * a * dt * dt;
                vz += a * dt;
                x += vx * dt;
                if z < 0.0 {
                    break;
                }
            }
            let want = backscatter_range_mm(0.2, th);
            assert!(
                (x * 1e3 - want).abs() < 1e-3 * want,
                "{deg}°: {} vs {want}",
                x * 1e3
            );
        }
        assert!((backscatter_range_mm(0.2, std::f64::consts::FRAC_PI_4) - 0.4).abs() < 1e-15);
    }

    #[test]
    fn gen3_share_from_open_area_and_backscatter() {
        // 0.35 × 0.25 = 0.0875 extra electrons per detected one.
        let f = halo_fraction(0.65, 0.25);
        assert!((f - 0.0875 / 1.0875).abs() < 1e-15);
        // 6.45 µm CCD pixels through a 0.611 taper: 10.56 µm at the cathode,
        // so the 0.2 mm gap gives a disc of 0.4 mm = 37.9 pixels.
        let pitch = 6.45e-3 / 0.611;
        let h = Halo::new(&HaloConfig::default(), 0.65, 0.2, pitch).unwrap();
        assert!((h.radius_px - 0.4 / pitch).abs() < 1e-12);
        assert!((h.fraction - f).abs() < 1e-15);
    }

    #[test]
    fn a_point_spreads_f_uniformly_over_the_disc_and_light_is_conserved() {
        let (rows, cols, r) = (41, 41, 6.5);
        let h = halo(r, 0.1);
        let mut img = vec![0f32; rows * cols];
        img[20 * cols + 20] = 1000.0;
        h.apply(&mut img, rows, cols);
        let n_disc = (-6i64..=6)
            .flat_map(|dy| (-6i64..=6).map(move |dx| (dx, dy)))
            .filter(|(dx, dy)| ((dx * dx + dy * dy) as f64) <= r * r)
            .count() as f64;
        let total: f64 = img.iter().map(|&v| v as f64).sum();
        assert!((total - 1000.0).abs() < 1e-3, "{total}");
        let centre = img[20 * cols + 20] as f64;
        assert!((centre - (900.0 + 100.0 / n_disc)).abs() < 1e-3, "{centre}");
        // Inside the disc (5, 3): 34 ≤ 42.25; outside (5, 5): 50 > 42.25.
        let at = |dy: i64, dx: i64| img[((20 + dy) as usize) * cols + (20 + dx) as usize] as f64;
        assert!((at(3, 5) - 100.0 / n_disc).abs() < 1e-4);
        assert_eq!(at(5, 5), 0.0);
        assert_eq!(at(0, 7), 0.0);
    }

    #[test]
    fn the_binned_disc_conserves_light_and_ends_near_its_radius() {
        // R = 38 px: binned by 4. A point's halo: total f within 1 %, flat
        // over the disc, nothing beyond R + 2b.
        let (rows, cols, r) = (200, 200, 38.0);
        let h = halo(r, 0.1);
        let mut img = vec![0f32; rows * cols];
        img[100 * cols + 100] = 1e6;
        h.apply(&mut img, rows, cols);
        let total: f64 = img.iter().map(|&v| v as f64).sum();
        assert!((total / 1e6 - 1.0).abs() < 0.01, "{total}");
        let per_px = 0.1e6 / (std::f64::consts::PI * r * r);
        let v = img[(100 + 20) * cols + 100] as f64;
        assert!((v / per_px - 1.0).abs() < 0.1, "{v} vs {per_px}");
        assert_eq!(img[(100 + 47) * cols + 100], 0.0);
    }

    #[test]
    fn a_uniform_field_is_unchanged() {
        let (rows, cols) = (20, 30);
        for r in [8.0, 20.0] {
            let mut img = vec![7.25f32; rows * cols];
            halo(r, 0.08).apply(&mut img, rows, cols);
            assert!(img.iter().all(|&v| (v - 7.25).abs() < 1e-5));
        }
    }
}
