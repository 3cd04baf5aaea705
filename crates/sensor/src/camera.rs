//! The camera: a chain with memory (AGC loop, phosphor persistence) that
//! turns radiance images into digitised frames, one capture per frame time.

use ndarray::{Array2, ArrayView2, ArrayView3, Axis};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use gloam_spectra::Spectrum;

use crate::config::{Agc, SensorConfig, SensorKind};
use crate::error::{CaptureError, ConfigError};
use crate::kernel::Kernel;
use crate::noise::{self, Pass};
use crate::stages::Chain;

/// What the gain loop is doing for a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AgcState {
    /// No AGC: the configured fixed gain.
    Off,
    /// A manual override fixes the gain.
    Override,
    /// Servoing toward the set-point.
    Tracking,
    /// Wants more gain than its upper limit allows.
    AtMaxGain,
    /// Wants less gain than its lower limit allows.
    AtMinGain,
    /// Bright-source protection is cutting the gain.
    Protecting,
}

/// Metadata of one frame: the settings actually in effect when it was taken.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameMeta {
    /// Frame number since the camera was created or reset.
    pub seq: u64,
    /// Start of the frame, s since the stream started (seq / frame rate).
    pub time_s: f64,
    pub exposure_s: f64,
    /// Tube gain (MCP gain, EB gain or analogue gain) for this frame.
    pub gain_in_effect: f64,
    /// MCP plate voltage for this frame (ICCD).
    pub mcp_voltage_v: Option<f64>,
    /// Control voltage (MCP or EBCCD accelerating voltage).
    pub control_voltage_v: Option<f64>,
    /// True when AGC (not a fixed or override gain) set this frame's gain.
    pub agc_enabled: bool,
    pub agc_state: AgcState,
    pub bits: u8,
    pub width: usize,
    pub height: usize,
    /// Mean DN of the frame.
    pub mean_dn: f64,
    /// Fraction of pixels at saturation (within 3 σ of read noise, at least
    /// 1 DN, of [`crate::Chain::saturation_dn`]).
    pub saturated_fraction: f64,
    /// Temporal noise on.
    pub noise: bool,
}

/// One digitised frame: `height × width` digital counts.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub pixels: Array2<u16>,
    pub meta: FrameMeta,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    Fixed,
    Override,
    Agc,
}

struct Patterns {
    rows: usize,
    cols: usize,
    vignette: Option<Vec<f32>>,
    /// Chicken wire × PRNU: the fixed gain pattern at the CCD, one map so
    /// the CCD pass reads one array instead of two.
    flat_field: Option<Vec<f32>>,
    flat_field_max: f64,
    dsnu: Option<Vec<f32>>,
}

/// A camera: configuration, derived chain, and the state that carries from
/// frame to frame.
pub struct Camera {
    chain: Chain,
    noise: bool,
    seed: u64,
    mode: Mode,
    agc: Option<Agc>,
    gain: f64,
    agc_state: AgcState,
    seq: u64,
    lag: Option<Vec<f32>>,
    patterns: Option<Patterns>,
    kernels: Option<(f64, Option<Kernel>, Option<Kernel>)>,
    buf: Vec<f32>,
    tmp: Vec<f32>,
}

impl Camera {
    /// Builds the camera (validating the configuration).
    pub fn new(config: SensorConfig) -> Result<Self, ConfigError> {
        let chain = Chain::new(&config)?;
        let agc = config.agc.clone();
        let mode = if agc.as_ref().is_some_and(|a| a.enabled) {
            Mode::Agc
        } else {
            Mode::Fixed
        };
        let gain = chain.reference_gain;
        Ok(Self {
            noise: config.noise.enabled,
            seed: config.noise.seed,
            agc_state: if mode == Mode::Agc {
                AgcState::Tracking
            } else {
                AgcState::Off
            },
            mode,
            agc,
            gain,
            seq: 0,
            lag: None,
            patterns: None,
            kernels: None,
            buf: Vec::new(),
            tmp: Vec::new(),
            chain,
        })
    }

    /// A built-in preset or a TOML file.
    pub fn from_preset_or_file(name_or_path: &str) -> Result<Self, ConfigError> {
        Self::new(SensorConfig::load_preset_or_file(name_or_path)?)
    }

    /// The derived chain with the analytic transfer.
    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    pub fn config(&self) -> &SensorConfig {
        &self.chain.config
    }

    /// The gain that the next frame will use.
    pub fn gain(&self) -> f64 {
        self.gain
    }

    pub fn agc_state(&self) -> AgcState {
        self.agc_state
    }

    /// Frames captured since creation or reset.
    pub fn frames_captured(&self) -> u64 {
        self.seq
    }

    /// Fixes the gain (override: output linear in flux), or with `None`
    /// returns to AGC if the configuration has one, else to the configured gain.
    pub fn set_override_gain(&mut self, gain: Option<f64>) -> Result<(), CaptureError> {
        match gain {
            Some(g) => {
                if !(g.is_finite() && g >= self.chain.gain_min * (1.0 - 1e-9))
                    || g > self.chain.gain_max * (1.0 + 1e-9)
                {
                    return Err(CaptureError::GainOutOfRange {
                        gain: g,
                        min: self.chain.gain_min,
                        max: self.chain.gain_max,
                        camera: self.chain.config.name.clone(),
                    });
                }
                self.gain = g.clamp(self.chain.gain_min, self.chain.gain_max);
                self.mode = Mode::Override;
                self.agc_state = AgcState::Override;
            }
            None => {
                if self.agc.is_some() {
                    self.mode = Mode::Agc;
                    self.agc_state = AgcState::Tracking;
                } else {
                    self.mode = Mode::Fixed;
                    self.gain = self.chain.reference_gain;
                    self.agc_state = AgcState::Off;
                }
            }
        }
        Ok(())
    }

    /// Switches AGC on (from the current gain) or off (holding the current gain).
    pub fn set_agc(&mut self, on: bool) {
        if on && self.agc.is_some() {
            self.mode = Mode::Agc;
            self.agc_state = AgcState::Tracking;
        } else if !on {
            self.mode = Mode::Override;
            self.agc_state = AgcState::Override;
        }
    }

    /// Temporal noise on or off (fixed patterns stay).
    pub fn set_noise(&mut self, on: bool) {
        self.noise = on;
    }

    /// Forgets history: frame counter, AGC gain, phosphor persistence.
    pub fn reset(&mut self) {
        self.seq = 0;
        self.lag = None;
        if self.mode != Mode::Override {
            self.gain = self.chain.reference_gain;
        }
    }

    /// Captures a frame from per-band radiance (band × row × col, W m⁻² sr⁻¹
    /// in each band) and each band's spectral shape (any scale: normalised
    /// to unit integral here), so the detector's QE is integrated per band.
    pub fn capture(
        &mut self,
        radiance_w_m2_sr: ArrayView3<f64>,
        band_shapes: &[Spectrum],
    ) -> Result<Frame, CaptureError> {
        let (bands, rows, cols) = radiance_w_m2_sr.dim();
        if bands != band_shapes.len() {
            return Err(CaptureError::BandMismatch {
                bands,
                spectra: band_shapes.len(),
            });
        }
        if rows == 0 || cols == 0 {
            return Err(CaptureError::EmptyImage { rows, cols });
        }
        let k: Vec<f64> = band_shapes
            .iter()
            .enumerate()
            .map(|(b, s)| {
                self.chain
                    .pe_per_radiance(s)
                    .ok_or(CaptureError::EmptyBand { band: b })
            })
            .collect::<Result<_, _>>()?;
        // Check the input (first bad value reported).
        for (b, plane) in radiance_w_m2_sr.axis_iter(Axis(0)).enumerate() {
            check_input(plane, b)?;
        }
        let mut pe = std::mem::take(&mut self.buf);
        pe.resize(rows * cols, 0.0);
        pe.par_chunks_mut(cols).enumerate().for_each(|(r, out)| {
            out.fill(0.0);
            for (b, &kb) in k.iter().enumerate() {
                let row = radiance_w_m2_sr.slice(ndarray::s![b, r, ..]);
                for (o, &l) in out.iter_mut().zip(row.iter()) {
                    *o += (l * kb) as f32;
                }
            }
        });
        self.run(pe, rows, cols, true)
    }

    /// Captures from detected-electron radiance: per pixel `∫ L QE λ/hc dλ`
    /// (e⁻ s⁻¹ m⁻² sr⁻¹ at the entrance pupil), e.g. a render band whose
    /// response is [`Chain::detected_response_e_per_j`]. Unlike
    /// [`Camera::capture`], nothing is assumed about the spectrum inside a
    /// band, so the photoelectron rate is exact for any source.
    pub fn capture_detected(
        &mut self,
        detected_e_s_m2_sr: ArrayView2<f64>,
    ) -> Result<Frame, CaptureError> {
        let (rows, cols) = detected_e_s_m2_sr.dim();
        if rows == 0 || cols == 0 {
            return Err(CaptureError::EmptyImage { rows, cols });
        }
        check_input(detected_e_s_m2_sr, 0)?;
        let k = self.chain.etendue_m2_sr_s;
        let mut pe = std::mem::take(&mut self.buf);
        pe.clear();
        pe.extend(detected_e_s_m2_sr.iter().map(|&v| (v * k) as f32));
        self.run(pe, rows, cols, true)
    }

    /// Captures a monochrome radiance image (W m⁻² sr⁻¹) of one spectral shape.
    pub fn capture_mono(
        &mut self,
        radiance_w_m2_sr: ArrayView2<f64>,
        shape: &Spectrum,
    ) -> Result<Frame, CaptureError> {
        let view = radiance_w_m2_sr.insert_axis(Axis(0));
        self.capture(view, std::slice::from_ref(shape))
    }

    /// Captures from the mean photoelectrons per pixel per frame at the
    /// detecting surface (photocathode, or the CCD for a plain CCD): no
    /// vignetting is applied, the pre-noise blur (optics, cathode gap) is.
    /// For tests and calibration.
    pub fn capture_photoelectrons(
        &mut self,
        pe_per_pixel: ArrayView2<f64>,
    ) -> Result<Frame, CaptureError> {
        let (rows, cols) = pe_per_pixel.dim();
        if rows == 0 || cols == 0 {
            return Err(CaptureError::EmptyImage { rows, cols });
        }
        let mut pe = std::mem::take(&mut self.buf);
        match pe_per_pixel.as_slice() {
            Some(sl) => {
                // Convert and check in one pass (every element is
                // overwritten, so no clearing first).
                pe.resize(sl.len(), 0.0);
                let ok = pe
                    .par_chunks_mut(1 << 14)
                    .zip(sl.par_chunks(1 << 14))
                    .map(|(o, i)| {
                        let mut ok = true;
                        for (o, &v) in o.iter_mut().zip(i) {
                            ok &= v.is_finite() & (v >= 0.0);
                            *o = v as f32;
                        }
                        ok
                    })
                    .reduce(|| true, |a, b| a & b);
                if !ok {
                    self.buf = pe;
                    check_input(pe_per_pixel, 0)?;
                    unreachable!("check_input reports the bad value the scan saw");
                }
            }
            None => {
                check_input(pe_per_pixel, 0)?;
                pe.clear();
                pe.extend(pe_per_pixel.iter().map(|&v| v as f32));
            }
        }
        self.run(pe, rows, cols, false)
    }

    fn ensure_patterns(&mut self, rows: usize, cols: usize) {
        if self
            .patterns
            .as_ref()
            .is_some_and(|p| p.rows == rows && p.cols == cols)
        {
            return;
        }
        let cfg = &self.chain.config;
        let seed = cfg.noise.seed;
        let vignette = cfg.optics.vignetting.then(|| {
            let f = cfg.optics.focal_length_mm;
            let p = self.chain.pitch_cathode_mm;
            let (cy, cx) = ((rows as f64 - 1.0) / 2.0, (cols as f64 - 1.0) / 2.0);
            let mut v = vec![0f32; rows * cols];
            v.par_chunks_mut(cols).enumerate().for_each(|(r, out)| {
                for (c, o) in out.iter_mut().enumerate() {
                    let rr = ((r as f64 - cy).powi(2) + (c as f64 - cx).powi(2)).sqrt() * p;
                    let t2 = (rr / f).powi(2);
                    *o = (1.0 / (1.0 + t2).powi(2)) as f32;
                }
            });
            v
        });
        let chicken_wire = cfg.coupling.as_ref().and_then(|c| {
            (c.chicken_wire_cell_um > 0.0 && c.chicken_wire_depth > 0.0).then(|| {
                chicken_wire(
                    rows,
                    cols,
                    cfg.ccd.pixel_pitch_um,
                    c.chicken_wire_cell_um,
                    c.chicken_wire_depth,
                    c.chicken_wire_width_um,
                )
            })
        });
        let gauss_pattern = |pass: Pass, f: &(dyn Fn(f64) -> f32 + Sync)| {
            let mut v = vec![0f32; rows * cols];
            v.par_chunks_mut(cols).enumerate().for_each(|(r, out)| {
                let mut rng = noise::pattern_rng(seed, pass, r);
                for o in out.iter_mut() {
                    *o = f(noise::normal(&mut rng));
                }
            });
            v
        };
        let prnu_amp = cfg.ccd.prnu;
        let prnu = (prnu_amp > 0.0)
            .then(|| gauss_pattern(Pass::Prnu, &|z| (1.0 + prnu_amp * z).max(0.0) as f32));
        let dsnu_amp = cfg.ccd.dsnu_e;
        let dsnu = (dsnu_amp > 0.0).then(|| gauss_pattern(Pass::Dsnu, &|z| (dsnu_amp * z) as f32));
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
        self.patterns = Some(Patterns {
            rows,
            cols,
            vignette,
            flat_field,
            flat_field_max,
            dsnu,
        });
    }

    fn ensure_kernels(&mut self, g: f64) {
        let gain_dependent = self.chain.kind == SensorKind::Ebccd;
        if let Some((kg, _, _)) = &self.kernels
            && (!gain_dependent || *kg == g)
        {
            return;
        }
        let stages = self.chain.stages_at(g);
        let pre: Vec<_> = stages.iter().filter(|s| !s.after_noise).collect();
        let post: Vec<_> = stages.iter().filter(|s| s.after_noise).collect();
        let kp = Kernel::from_mtf(|f| pre.iter().map(|s| s.term.at(f)).product());
        let kq = Kernel::from_mtf(|f| post.iter().map(|s| s.term.at(f)).product());
        self.kernels = Some((g, kp, kq));
    }

    fn run(
        &mut self,
        mut pe: Vec<f32>,
        rows: usize,
        cols: usize,
        apply_vignette: bool,
    ) -> Result<Frame, CaptureError> {
        let g = self.gain;
        self.ensure_patterns(rows, cols);
        self.ensure_kernels(g);
        let chain = &self.chain;
        let pat = self.patterns.as_ref().expect("patterns");
        let (_, kpre, kpost) = self.kernels.as_ref().expect("kernels");
        let noise_on = self.noise;
        let seed = self.seed;
        let frame = self.seq;
        let ga = chain.config.noise.gaussian_above;

        if apply_vignette && let Some(v) = &pat.vignette {
            pe.par_iter_mut()
                .zip(v.par_iter())
                .for_each(|(p, &w)| *p *= w);
        }
        if let Some(k) = kpre {
            k.apply(&mut pe, &mut self.tmp, rows, cols);
        }

        // Gain stage: photoelectrons → charge.
        let ebi = chain.ebi_pe(g);
        match chain.kind {
            SensorKind::Iccd => {
                let eta = chain.open_area;
                let gamma = noise::GammaSums::new(chain.gain_shape);
                pe.par_chunks_mut(cols).enumerate().for_each_init(
                    RowScratch::default,
                    |RowScratch {
                         lams,
                         counts,
                         hits,
                         exps,
                     },
                     (r, row)| {
                        let lam = |p: f32| eta * (p.max(0.0) as f64 + ebi);
                        if !noise_on {
                            for p in row.iter_mut() {
                                *p = chain.mcp_compress(lam(*p) * g) as f32;
                            }
                            return;
                        }
                        // Counts for the whole row first, then a gain draw for
                        // each pixel with events, listed without a
                        // data-dependent branch: tight loops that predict well.
                        let mut rng = noise::stream(seed, frame, Pass::Photoelectrons, r);
                        let mut events = noise::PoissonRow::new(&mut rng, ga);
                        lams.clear();
                        lams.extend(row.iter().map(|&p| lam(p)));
                        events.draw_row(&mut rng, lams, counts, exps);
                        hits.clear();
                        hits.resize(cols, 0);
                        let mut k = 0;
                        for (c, &n) in counts.iter().enumerate() {
                            hits[k] = c as u32;
                            k += (n > 0.0) as usize;
                        }
                        row.fill(0.0);
                        for &c in &hits[..k] {
                            let q = gamma.sample(&mut rng, counts[c as usize], g);
                            row[c as usize] = chain.mcp_compress(q) as f32;
                        }
                    },
                );
                let p = chain.lag_fraction;
                if p > 0.0 {
                    match &mut self.lag {
                        Some(s) if s.len() == pe.len() => {
                            s.par_iter_mut().zip(pe.par_iter_mut()).for_each(|(s, x)| {
                                *s = (1.0 - p as f32) * *x + p as f32 * *s;
                                *x = *s;
                            });
                        }
                        _ => self.lag = Some(pe.clone()),
                    }
                }
            }
            SensorKind::Ebccd => {
                let e = chain.eb.expect("ebccd");
                pe.par_chunks_mut(cols).enumerate().for_each(|(r, row)| {
                    let mut rng = noise::stream(seed, frame, Pass::Photoelectrons, r);
                    let mut events = noise::PoissonRow::new(&mut rng, ga);
                    for p in row.iter_mut() {
                        let lam = (*p).max(0.0) as f64 + ebi;
                        *p = if noise_on {
                            let n = events.draw(&mut rng, lam);
                            noise::eb_charge(&mut rng, n, g, e.backscatter, e.fano)
                        } else {
                            lam * g * (1.0 - 0.5 * e.backscatter)
                        } as f32;
                    }
                });
            }
            SensorKind::Ccd => {}
        }
        if let Some(k) = kpost {
            k.apply(&mut pe, &mut self.tmp, rows, cols);
        }
        // CCD: conversion, chicken wire, PRNU, shot and dark noise; then read
        // noise, DSNU, video and digitizer.
        let conv = match chain.kind {
            SensorKind::Iccd => chain.ccd_e_per_mcp_e,
            _ => 1.0,
        };
        let shot_at_ccd = chain.kind != SensorKind::Ebccd;
        let dark = chain.dark_e_per_frame;
        let flat_field = pat.flat_field.as_deref();
        let full_well = chain.config.ccd.full_well_e;
        let read = chain.read_noise_e;
        let dn_per_e = chain.dn_per_ccd_electron(g);
        let black = chain.black_dn(g);
        let clip = chain.clip_dn(g);
        let max_code = chain.max_code;
        // "Saturated": within 3 σ of read noise (at least 1 DN) of saturation.
        let sat_dn = chain.saturated_threshold_dn(g);
        let dsnu = pat.dsnu.as_deref();
        // Mean CCD electrons of row `r` into `m` (whole-row passes vectorise).
        let mean_row = |r: usize, row: &[f32], m: &mut Vec<f64>| {
            m.clear();
            m.extend(row.iter().map(|&p| p.max(0.0) as f64 * conv));
            if let Some(ff) = flat_field {
                for (x, &f) in m.iter_mut().zip(&ff[r * cols..(r + 1) * cols]) {
                    *x *= f as f64;
                }
            }
        };
        // DSNU, video and digitizer for row `r` of electrons `v`: its DN sum
        // and saturated count.
        let digitize_row = |r: usize, v: &mut [f64], out: &mut [u16]| -> (f64, usize) {
            if let Some(d) = dsnu {
                for (x, &d) in v.iter_mut().zip(&d[r * cols..(r + 1) * cols]) {
                    *x += d as f64;
                }
            }
            let mut sum = 0f64;
            let mut nsat = 0usize;
            for (o, &x) in out.iter_mut().zip(v.iter()) {
                let dn = (black + x * dn_per_e).min(clip).clamp(0.0, max_code);
                let dn = (dn + 0.5) as i32 as f64;
                *o = dn as u16;
                sum += dn;
                nsat += (dn >= sat_dn) as usize;
            }
            (sum, nsat)
        };
        let mut pixels = Array2::<u16>::zeros((rows, cols));
        let out_rows = pixels.as_slice_mut().expect("standard layout");

        // Can any pixel reach full well? (Upper bound: the blur and
        // patterns cannot raise the maximum by more than a few per cent.)
        let max_q = pe.par_iter().copied().reduce(|| 0f32, f32::max) as f64;
        let bound = max_q * conv * 1.1 * pat.flat_field_max + dark;
        let bound = bound + 8.0 * bound.sqrt() + 10.0;
        let blooming = chain.config.ccd.blooming;
        let fw = full_well;
        // Shot noise is drawn as a Gaussian for ga < t < t_gauss, where
        // t + 8√t stays below full well.
        let t_gauss = ((16.0 + fw).sqrt() - 4.0).powi(2);
        let read_var = read * read;
        let stats: Vec<(f64, usize)> = if !blooming || bound < full_well {
            // Fast path: no charge moves between pixels, so shot, dark and
            // read noise are drawn in one pass (one Gaussian N(m, m + σ_read²)
            // where the shot noise is Gaussian and full well is out of reach).
            out_rows
                .par_chunks_mut(cols)
                .zip(pe.par_chunks(cols))
                .enumerate()
                .map_init(Vec::new, |m, (r, (out, row))| {
                    mean_row(r, row, m);
                    let mut rng = noise::stream(seed, frame, Pass::Ccd, r);
                    let mut events = noise::PoissonRow::new(&mut rng, ga);
                    for x in m.iter_mut() {
                        *x = if !noise_on {
                            (*x + dark).min(fw)
                        } else if shot_at_ccd {
                            let t = *x + dark;
                            if t > ga && t < t_gauss {
                                t + (t + read_var).sqrt() * noise::normal(&mut rng)
                            } else {
                                events.draw(&mut rng, t).min(fw) + read * noise::normal(&mut rng)
                            }
                        } else {
                            (*x + events.draw(&mut rng, dark)).min(fw)
                                + read * noise::normal(&mut rng)
                        };
                    }
                    digitize_row(r, m, out)
                })
                .collect()
        } else {
            pe.par_chunks_mut(cols)
                .enumerate()
                .for_each_init(Vec::new, |m, (r, row)| {
                    mean_row(r, row, m);
                    let mut rng = noise::stream(seed, frame, Pass::Ccd, r);
                    let mut events = noise::PoissonRow::new(&mut rng, ga);
                    for (p, &m) in row.iter_mut().zip(m.iter()) {
                        let e = if !noise_on {
                            m + dark
                        } else if shot_at_ccd {
                            events.draw(&mut rng, m + dark)
                        } else {
                            m + events.draw(&mut rng, dark)
                        };
                        *p = e as f32;
                    }
                });
            bloom(&mut pe, rows, cols, full_well as f32);
            out_rows
                .par_chunks_mut(cols)
                .zip(pe.par_chunks(cols))
                .enumerate()
                .map_init(Vec::new, |v: &mut Vec<f64>, (r, (out, row))| {
                    let mut rng = noise::stream(seed, frame, Pass::Read, r);
                    v.clear();
                    v.extend(row.iter().map(|&e| e as f64));
                    if noise_on && read > 0.0 {
                        for x in v.iter_mut() {
                            *x += read * noise::normal(&mut rng);
                        }
                    }
                    digitize_row(r, v, out)
                })
                .collect()
        };
        self.buf = pe;
        let n = (rows * cols) as f64;
        let mean_dn = stats.iter().map(|s| s.0).sum::<f64>() / n;
        let sat_frac = stats.iter().map(|s| s.1).sum::<usize>() as f64 / n;

        let meta = FrameMeta {
            seq: self.seq,
            time_s: self.seq as f64 / chain.config.timing.frame_rate_hz,
            exposure_s: chain.config.timing.exposure_s,
            gain_in_effect: g,
            mcp_voltage_v: match chain.kind {
                SensorKind::Iccd => chain.gain_control.voltage_for(g),
                _ => None,
            },
            control_voltage_v: chain.gain_control.voltage_for(g),
            agc_enabled: self.mode == Mode::Agc,
            agc_state: self.agc_state,
            bits: chain.config.digitizer.bits,
            width: cols,
            height: rows,
            mean_dn,
            saturated_fraction: sat_frac,
            noise: noise_on,
        };
        self.seq += 1;
        if self.mode == Mode::Agc {
            self.agc_update(mean_dn - black, sat_frac);
        }
        Ok(Frame { pixels, meta })
    }

    /// One step of the AGC loop after a frame whose mean signal above black
    /// was `signal_dn`:
    /// `ln g ← ln g + (1 − e^{−Δt/τ}) (ln set-point − ln signal)`, clamped to
    /// the limits; bright-source protection multiplies g by `protect_factor`
    /// instead when the mean or the saturated fraction passes its threshold.
    /// In the linear range the log-gain error decays as `e^{−t/τ}`.
    fn agc_update(&mut self, signal_dn: f64, sat_frac: f64) {
        let Some(a) = &self.agc else { return };
        let lo = a
            .min_gain
            .unwrap_or(self.chain.gain_min)
            .max(self.chain.gain_min);
        let hi = a
            .max_gain
            .unwrap_or(self.chain.gain_max)
            .min(self.chain.gain_max);
        let protect = a.protect_mean_dn.is_some_and(|t| signal_dn > t)
            || (sat_frac > a.protect_saturated_fraction && a.protect_saturated_fraction > 0.0);
        let mut state = AgcState::Tracking;
        let want = if protect {
            state = AgcState::Protecting;
            self.gain * a.protect_factor
        } else {
            let dt = 1.0 / self.chain.config.timing.frame_rate_hz;
            let alpha = 1.0 - (-dt / a.time_constant_s).exp();
            let measured = signal_dn.max(1e-3);
            (self.gain.ln() + alpha * (a.set_point_dn.ln() - measured.ln())).exp()
        };
        let g = want.clamp(lo, hi);
        if !protect {
            if want > hi {
                state = AgcState::AtMaxGain;
            } else if want < lo {
                state = AgcState::AtMinGain;
            }
        }
        self.gain = g;
        self.agc_state = state;
    }
}

/// Per-thread buffers of the MCP pass, reused from row to row.
#[derive(Default)]
struct RowScratch {
    /// Mean events per pixel.
    lams: Vec<f64>,
    /// Event counts.
    counts: Vec<f64>,
    /// Columns with at least one event.
    hits: Vec<u32>,
    /// e^{-λ} for the Poisson inversion.
    exps: Vec<f64>,
}

/// The first value that is not finite and ≥ 0, as an error.
fn check_input(img: ArrayView2<f64>, band: usize) -> Result<(), CaptureError> {
    // Fast, vectorisable scan; the location is looked up only on failure.
    let ok = match img.as_slice() {
        Some(sl) => sl.par_chunks(1 << 14).all(|ch| {
            ch.iter()
                .fold(true, |a, v| a & (v.is_finite() & (*v >= 0.0)))
        }),
        None => img.iter().all(|v| v.is_finite() && *v >= 0.0),
    };
    if ok {
        return Ok(());
    }
    let ((row, col), &value) = img
        .indexed_iter()
        .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        .expect("a bad value exists");
    Err(CaptureError::BadRadiance {
        band,
        row,
        col,
        value,
    })
}

/// Spills charge above `fw` along each column: half up, half down, filling
/// neighbours until it is absorbed (charge off the ends is lost to the drain).
fn bloom(img: &mut [f32], rows: usize, cols: usize, fw: f32) {
    for c in 0..cols {
        if !(0..rows).any(|r| img[r * cols + c] > fw) {
            continue;
        }
        let mut down = vec![0f32; rows];
        for r in 0..rows {
            let v = &mut img[r * cols + c];
            if *v > fw {
                let ex = *v - fw;
                *v = fw;
                down[r] = 0.5 * ex;
                // the other half goes up
                let mut carry = 0.5 * ex;
                let mut rr = r;
                while carry > 0.0 && rr > 0 {
                    rr -= 1;
                    let w = &mut img[rr * cols + c];
                    let room = (fw - *w).max(0.0);
                    let take = room.min(carry);
                    *w += take;
                    carry -= take;
                }
            }
        }
        let mut carry = 0f32;
        for (r, d) in down.iter().enumerate() {
            let v = &mut img[r * cols + c];
            if carry > 0.0 {
                let room = (fw - *v).max(0.0);
                let take = room.min(carry);
                *v += take;
                carry -= take;
            }
            carry += d;
        }
    }
}

/// Transmission of a fibre bundle's hexagonal multifibre boundaries, at the CCD.
fn chicken_wire(
    rows: usize,
    cols: usize,
    pitch_um: f64,
    cell_um: f64,
    depth: f64,
    width_um: f64,
) -> Vec<f32> {
    let d = cell_um;
    let h = d * 3f64.sqrt() / 2.0;
    let (ox, oy) = (0.37 * d, 0.61 * d);
    let mut v = vec![0f32; rows * cols];
    v.par_chunks_mut(cols).enumerate().for_each(|(r, out)| {
        for (c, o) in out.iter_mut().enumerate() {
            let x = (c as f64 + 0.5) * pitch_um + ox;
            let y = (r as f64 + 0.5) * pitch_um + oy;
            let j0 = (y / h).floor();
            let mut best = (f64::INFINITY, 0.0, 0.0);
            for j in [j0, j0 + 1.0] {
                let i0 = ((x - j * d / 2.0) / d).floor();
                for i in [i0, i0 + 1.0] {
                    let cx = i * d + j * d / 2.0;
                    let cy = j * h;
                    let d2 = (x - cx).powi(2) + (y - cy).powi(2);
                    if d2 < best.0 {
                        best = (d2, cx, cy);
                    }
                }
            }
            let (d1, cx, cy) = best;
            let mut dist = f64::INFINITY;
            for (dx, dy) in [
                (d, 0.0),
                (-d, 0.0),
                (d / 2.0, h),
                (-d / 2.0, h),
                (d / 2.0, -h),
                (-d / 2.0, -h),
            ] {
                let d2 = (x - cx - dx).powi(2) + (y - cy - dy).powi(2);
                dist = dist.min((d2 - d1) / (2.0 * d));
            }
            *o = (1.0 - depth * (-0.5 * (dist / width_um).powi(2)).exp()) as f32;
        }
    });
    v
}
