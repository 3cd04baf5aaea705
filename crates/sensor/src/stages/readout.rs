//! The readout: [`super::ccd`] → [`super::video`] → [`super::digitizer`]
//! as one fused row pass (charge to CCD electrons with shot, dark and read
//! noise, DSNU, the analogue line and the digitizer), so a row is read
//! while it is still in cache. Only blooming, which moves charge between
//! rows, splits it in two.

use ndarray::Array2;
use rayon::prelude::*;

use super::ccd::{self, CcdPass};
use super::digitizer::Digitizer;
use super::list::InFlight;
use super::{Chain, Tube, coupling};
use crate::noise::{self, Pass};

/// The CCD's fixed patterns at one frame size.
pub(crate) struct Patterns {
    rows: usize,
    cols: usize,
    /// Chicken wire × PRNU: the fixed gain pattern at the CCD, one map so
    /// the CCD pass reads one array instead of two.
    flat_field: Option<Vec<f32>>,
    flat_field_max: f64,
    dsnu: Option<Vec<f32>>,
}

impl Patterns {
    /// `cached` if it has this size, else the patterns made afresh.
    pub(crate) fn sized(cached: Option<Self>, chain: &Chain, rows: usize, cols: usize) -> Self {
        match cached {
            Some(p) if p.rows == rows && p.cols == cols => p,
            _ => Self::new(chain, rows, cols),
        }
    }

    fn new(chain: &Chain, rows: usize, cols: usize) -> Self {
        let cfg = &chain.config;
        let seed = cfg.noise.seed;
        let chicken_wire = cfg
            .coupling
            .as_ref()
            .filter(|c| coupling::has_chicken_wire(c))
            .map(|c| {
                coupling::chicken_wire(
                    rows,
                    cols,
                    cfg.ccd.pixel_pitch_um,
                    c.chicken_wire_cell_um,
                    c.chicken_wire_depth,
                    c.chicken_wire_width_um,
                )
            });
        let prnu = ccd::prnu_pattern(&cfg.ccd, rows, cols, seed);
        let dsnu = ccd::dsnu_pattern(&cfg.ccd, rows, cols, seed);
        let flat_field = match (chicken_wire, prnu) {
            (Some(mut w), Some(p)) => {
                w.par_iter_mut()
                    .zip(p.par_iter())
                    .for_each(|(w, &p)| *w *= p);
                Some(w)
            }
            (w, p) => w.or(p),
        };
        let flat_field_max = flat_field
            .as_ref()
            .map_or(1.0, |p| p.iter().copied().fold(0f32, f32::max) as f64);
        Self {
            rows,
            cols,
            flat_field,
            flat_field_max,
            dsnu,
        }
    }
}

/// Reads the frame in flight (charge per pixel in `f.pe`) into `f.pixels`,
/// with the frame's mean DN, saturated fraction and the scope rows'
/// electrons.
pub(crate) fn read(chain: &Chain, pat: &Patterns, f: &mut InFlight) {
    let (rows, cols, g, noise) = (f.rows, f.cols, f.gain, f.noise);
    let (conversion, shot) = match &chain.tube {
        Tube::Iccd(i) => (i.ccd_e_per_mcp_e, true),
        Tube::Ebccd(_) => (1.0, false),
        Tube::Ccd => (1.0, true),
    };
    let full_well = chain.config.ccd.full_well_e;
    let ccd = CcdPass::new(
        conversion,
        shot,
        chain.dark_e_per_frame,
        full_well,
        chain.read_noise_e,
        pat.flat_field.as_deref(),
        pat.dsnu.as_deref(),
        noise,
        cols,
    );
    let digitizer = digitizer(chain, g);
    // The analogue line (video amplifier and sampling), when band-limited.
    let line = chain.line_sampler(cols);
    let scope_rows = f.scope_rows;
    let scoped = std::sync::Mutex::new(Vec::new());
    let digitize_row = |r: usize, v: &mut [f64], out: &mut [u16]| {
        ccd.add_dsnu(r, v);
        if !scope_rows.is_empty() && scope_rows.contains(&r) {
            scoped
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .push((r, v.to_vec()));
        }
        match &line {
            None => digitizer.row(v, out),
            Some(l) => {
                let mut rng =
                    (noise.enabled && l.jitter_s > 0.0).then(|| noise.stream(Pass::ClockJitter, r));
                digitizer.row_sampled(v, out, l, || rng.as_mut().map_or(0.0, noise::normal))
            }
        }
    };
    let mut pixels = Array2::<u16>::zeros((rows, cols));
    let out_rows = pixels
        .as_slice_mut()
        .unwrap_or_else(|| unreachable!("a new array is in standard layout"));

    let pe = &mut f.pe;
    let stats: Vec<(f64, usize)> =
        if !chain.config.ccd.blooming || charge_bound(chain, pat, pe, conversion) < full_well {
            // Fast path: no charge moves between pixels, so shot, dark and read
            // noise are drawn in one pass.
            out_rows
                .par_chunks_mut(cols)
                .zip(pe.par_chunks(cols))
                .enumerate()
                .map_init(Vec::new, |m, (r, (out, row))| {
                    ccd.mean_row(r, row, m);
                    ccd.noise_row(r, m);
                    digitize_row(r, m, out)
                })
                .collect()
        } else {
            pe.par_chunks_mut(cols)
                .enumerate()
                .for_each_init(Vec::new, |m, (r, row)| {
                    ccd.mean_row(r, row, m);
                    ccd.collect_row(r, row, m);
                });
            ccd::bloom(pe, rows, cols, full_well as f32);
            out_rows
                .par_chunks_mut(cols)
                .zip(pe.par_chunks(cols))
                .enumerate()
                .map_init(Vec::new, |v: &mut Vec<f64>, (r, (out, row))| {
                    ccd.read_row(r, row, v);
                    digitize_row(r, v, out)
                })
                .collect()
        };
    let mut scoped = scoped.into_inner().unwrap_or_else(|p| p.into_inner());
    scoped.sort_by_key(|l| l.0);
    let n = (rows * cols) as f64;
    f.mean_dn = stats.iter().map(|s| s.0).sum::<f64>() / n;
    f.account.saturated_fraction = stats.iter().map(|s| s.1).sum::<usize>() as f64 / n;
    f.account.saturated_by = chain.saturating_stage(g);
    f.scope_lines = scoped;
    f.pixels = pixels;
}

/// The digitizer at gain `g`: black level, scale, clip and top code.
fn digitizer(chain: &Chain, g: f64) -> Digitizer {
    Digitizer {
        black_dn: chain.black_dn(g),
        dn_per_e: chain.dn_per_ccd_electron(g),
        clip_dn: chain.clip_dn(g),
        max_code: chain.max_code,
        // "Saturated": within 3 σ of read noise (at least 1 DN) of saturation.
        saturated_dn: chain.saturated_threshold_dn(g),
    }
}

/// An upper bound on any pixel's charge, e⁻: below full well, no charge
/// moves between pixels (the blur and patterns cannot raise the maximum
/// by more than a few per cent).
fn charge_bound(chain: &Chain, pat: &Patterns, pe: &[f32], conversion: f64) -> f64 {
    let max_q = pe
        .par_chunks(1 << 14)
        .map(|c| c.iter().copied().fold(0f32, f32::max))
        .reduce(|| 0f32, f32::max) as f64;
    let bound = max_q * conversion * 1.1 * pat.flat_field_max + chain.dark_e_per_frame;
    bound + 8.0 * bound.sqrt() + 10.0
}
