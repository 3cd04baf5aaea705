//! The camera: a chain with memory (AGC loop, phosphor persistence) that
//! turns radiance images into digitised frames, one capture per frame time.

use ndarray::{Array2, ArrayView2, ArrayView3, Axis};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use gloam_spectra::Spectrum;

pub use crate::stages::agc::AgcState;

use crate::config::SensorConfig;
use crate::error::{CaptureError, ConfigError};
use crate::kernel::Kernel;
use crate::stages::abc::AbcSetting;
use crate::stages::agc::AgcLoop;
use crate::stages::bright::{BrightStages, SaturationAccount};
use crate::stages::ccd::{self, CcdPass};
use crate::stages::digitizer::Digitizer;
use crate::stages::ebccd::EbPass;
use crate::stages::mcp::{McpPass, RowScratch};
use crate::stages::{Chain, FrameNoise, Tube, coupling, optics, phosphor};

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
    /// Which stage saturated, MCP compression and the tube's brightness
    /// control ([`crate::stages::bright`]).
    #[serde(default)]
    pub saturation: SaturationAccount,
}

/// One digitised frame: `height × width` digital counts, with the
/// settings in effect — what the camera model's digitizer hands on (a
/// frame grabber wraps it in its own `Frame`).
#[derive(Clone, Debug, PartialEq)]
pub struct DigitizedFrame {
    pub pixels: Array2<u16>,
    pub meta: FrameMeta,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    Fixed,
    Override,
    Agc,
}

/// The fixed patterns of one frame size.
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
    agc: Option<AgcLoop>,
    gain: f64,
    agc_state: AgcState,
    seq: u64,
    lag: Option<Vec<f32>>,
    /// The intensifier's bright-source stages (ICCD).
    bright: Option<BrightStages>,
    /// The ABC's throughput cut carried to the next frame (≤ 1).
    abc_cut: f64,
    /// MCP pore reservoirs (fraction full) while a depletion is recovering.
    reservoir: Option<Vec<f32>>,
    patterns: Option<Patterns>,
    kernels: Option<Kernels>,
    buf: Vec<f32>,
    tmp: Vec<f32>,
    /// Rows whose analogue line the next captures keep (`gloam scope`).
    scope_rows: Vec<usize>,
    /// `(row, CCD electrons per pixel)` of those rows in the last capture.
    scope_lines: Vec<(usize, Vec<f64>)>,
}

impl Camera {
    /// Builds the camera (validating the configuration).
    pub fn new(config: SensorConfig) -> Result<Self, ConfigError> {
        let chain = Chain::new(&config)?;
        let agc = config.agc.clone().map(|agc| AgcLoop {
            agc,
            hardware_min_gain: chain.gain_min,
            hardware_max_gain: chain.gain_max,
            frame_period_s: 1.0 / chain.config.timing.frame_rate_hz,
        });
        let mode = if agc.as_ref().is_some_and(|a| a.agc.enabled) {
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
            bright: BrightStages::of(&chain),
            abc_cut: 1.0,
            reservoir: None,
            patterns: None,
            kernels: None,
            buf: Vec::new(),
            tmp: Vec::new(),
            scope_rows: Vec::new(),
            scope_lines: Vec::new(),
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

    /// Keeps, from the next capture on, the CCD output of these frame rows
    /// (the analogue line's held levels before the video amplifier) for
    /// [`crate::scope`]. An empty list stops it.
    pub fn set_scope_rows(&mut self, rows: Vec<usize>) {
        self.scope_rows = rows;
        self.scope_lines.clear();
    }

    /// `(row, CCD electrons per pixel, read noise and DSNU included)` of the
    /// rows asked for by [`Camera::set_scope_rows`], from the last capture.
    pub fn scope_electrons(&self) -> &[(usize, Vec<f64>)] {
        &self.scope_lines
    }

    /// Forgets history: frame counter, AGC gain, phosphor persistence.
    pub fn reset(&mut self) {
        self.seq = 0;
        self.lag = None;
        self.abc_cut = 1.0;
        self.reservoir = None;
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
    ) -> Result<DigitizedFrame, CaptureError> {
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
    ) -> Result<DigitizedFrame, CaptureError> {
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
    ) -> Result<DigitizedFrame, CaptureError> {
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
    ) -> Result<DigitizedFrame, CaptureError> {
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

    /// Runs the stages over a frame of mean photoelectrons per pixel `pe`,
    /// each pass row by row: optics (fall-off, pre-noise blur) → gain stage
    /// (MCP and phosphor, or electron bombardment) → post-noise blur → CCD →
    /// video and digitizer; then the AGC loop.
    fn run(
        &mut self,
        mut pe: Vec<f32>,
        rows: usize,
        cols: usize,
        apply_vignette: bool,
    ) -> Result<DigitizedFrame, CaptureError> {
        let chain = &self.chain;
        // The tube's ABC: MCP voltage first, then the gate.
        let abc = self.bright.as_ref().and_then(|b| b.abc);
        let (abc_setting, abc_out_of_range) = match abc {
            Some(a) if self.abc_cut < 1.0 => a.split(self.abc_cut, chain.gain_min / self.gain),
            _ => (AbcSetting::OPEN, false),
        };
        let g = self.gain * abc_setting.gain_factor;
        // Fixed patterns per frame size; blur kernels per gain (only the
        // EBCCD's depend on it).
        let pat = match self.patterns.take() {
            Some(p) if p.rows == rows && p.cols == cols => p,
            _ => Patterns::new(chain, rows, cols),
        };
        let gain_dependent = matches!(chain.tube, Tube::Ebccd(_));
        let kernels = match self.kernels.take() {
            Some(k) if !gain_dependent || k.gain == g => k,
            _ => Kernels::new(chain, g),
        };
        let noise = FrameNoise {
            enabled: self.noise,
            seed: self.seed,
            frame: self.seq,
            gaussian_above: chain.config.noise.gaussian_above,
        };

        // Optics: cos⁴θ, then the blurs that move single quanta.
        if apply_vignette && let Some(v) = &pat.vignette {
            optics::apply_falloff(&mut pe, v);
        }
        if let Some(k) = &kernels.pre_noise {
            k.apply(&mut pe, &mut self.tmp, rows, cols);
        }

        // Bright source in view? (One pass: the input's mean and maximum.)
        let n_px = (rows * cols) as f64;
        let mut account = SaturationAccount {
            abc: abc_setting,
            abc_out_of_range,
            ..SaturationAccount::default()
        };
        let mut mean_pe = 0.0;
        if let Some(b) = &self.bright {
            let (sum, max) = pe
                .par_chunks(1 << 14)
                .map(|c| {
                    c.iter()
                        .fold((0f64, 0f32), |(s, m), &v| (s + v as f64, m.max(v)))
                })
                .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)));
            mean_pe = sum / n_px;
            account.input_max_over_mean = if mean_pe > 0.0 {
                max as f64 / mean_pe
            } else {
                0.0
            };
            account.bright_source_in_view = b.in_view(mean_pe, max as f64);
        }
        let in_view = account.bright_source_in_view;
        if abc_setting.duty_factor < 1.0 {
            let d = abc_setting.duty_factor as f32;
            pe.par_iter_mut().for_each(|p| *p *= d);
        }
        if in_view && let Some(h) = self.bright.as_ref().and_then(|b| b.halo.as_ref()) {
            h.apply(&mut pe, rows, cols);
            account.halo_fraction = h.fraction;
        }

        // Gain stage: photoelectrons → charge.
        let ebi = chain.ebi_pe(g) * abc_setting.duty_factor;
        let mut next_abc_cut = self.abc_cut;
        match &chain.tube {
            Tube::Iccd(i) => {
                // Pore depletion while a bright source is in view or its
                // deficit is recovering; it replaces the static knee.
                let depletion = self
                    .bright
                    .as_ref()
                    .and_then(|b| b.depletion)
                    .filter(|_| in_view || self.reservoir.is_some());
                let plate = match depletion {
                    Some(_) => std::borrow::Cow::Owned(i.mcp.without_knee()),
                    None => std::borrow::Cow::Borrowed(&i.mcp),
                };
                let mcp = McpPass::new(&plate, g, ebi, noise);
                pe.par_chunks_mut(cols)
                    .enumerate()
                    .for_each_init(RowScratch::default, |s, (r, row)| mcp.row(r, row, s));
                // Mean screen charge per pixel: exact in expectation from
                // the input while the plate is linear, summed otherwise.
                let mut mean_q = i.mcp.open_area * (mean_pe * abc_setting.duty_factor + ebi) * g;
                if let Some(d) = depletion {
                    let state = match self.reservoir.take() {
                        Some(s) if s.len() == pe.len() => s,
                        _ => vec![1f32; pe.len()],
                    };
                    let mut state = state;
                    let compressed: usize = pe
                        .par_chunks_mut(cols)
                        .zip(state.par_chunks_mut(cols))
                        .map(|(row, s)| d.row(row, s))
                        .sum();
                    account.mcp_compressed_fraction = compressed as f64 / n_px;
                    mean_q = pe.par_iter().map(|&v| v as f64).sum::<f64>() / n_px;
                    let recovered = !in_view && state.par_iter().all(|&s| s > 0.999);
                    self.reservoir = (!recovered).then_some(state);
                }
                if let Some(a) = abc {
                    next_abc_cut = a.step(self.abc_cut, mean_q);
                }
                phosphor::persist(&mut self.lag, &mut pe, i.lag_fraction);
            }
            Tube::Ebccd(e) => {
                let eb = EbPass {
                    eb: e,
                    gain: g,
                    ebi_pe: ebi,
                    noise,
                };
                pe.par_chunks_mut(cols)
                    .enumerate()
                    .for_each(|(r, row)| eb.row(r, row));
            }
            Tube::Ccd => {}
        }
        if let Some(k) = &kernels.post_noise {
            k.apply(&mut pe, &mut self.tmp, rows, cols);
        }

        // CCD: conversion, chicken wire, PRNU, shot and dark noise; then read
        // noise, DSNU, video and digitizer.
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
        let black = chain.black_dn(g);
        let digitizer = Digitizer {
            black_dn: black,
            dn_per_e: chain.dn_per_ccd_electron(g),
            clip_dn: chain.clip_dn(g),
            max_code: chain.max_code,
            // "Saturated": within 3 σ of read noise (at least 1 DN) of saturation.
            saturated_dn: chain.saturated_threshold_dn(g),
        };
        // The analogue line (video amplifier and sampling), when band-limited.
        let line = chain.line_sampler(cols);
        let scope_rows = &self.scope_rows;
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
                    let mut rng = (noise.enabled && l.jitter_s > 0.0)
                        .then(|| noise.stream(crate::noise::Pass::ClockJitter, r));
                    digitizer
                        .row_sampled(v, out, l, || rng.as_mut().map_or(0.0, crate::noise::normal))
                }
            }
        };
        let mut pixels = Array2::<u16>::zeros((rows, cols));
        let out_rows = pixels
            .as_slice_mut()
            .unwrap_or_else(|| unreachable!("a new array is in standard layout"));

        // Can any pixel reach full well? (Upper bound: the blur and
        // patterns cannot raise the maximum by more than a few per cent.)
        let max_q = pe.par_iter().copied().reduce(|| 0f32, f32::max) as f64;
        let bound = max_q * conversion * 1.1 * pat.flat_field_max + chain.dark_e_per_frame;
        let bound = bound + 8.0 * bound.sqrt() + 10.0;
        let stats: Vec<(f64, usize)> = if !chain.config.ccd.blooming || bound < full_well {
            // Fast path: no charge moves between pixels, so shot, dark and
            // read noise are drawn in one pass.
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
            ccd::bloom(&mut pe, rows, cols, full_well as f32);
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
        self.scope_lines = scoped;
        self.buf = pe;
        self.patterns = Some(pat);
        self.kernels = Some(kernels);
        let n = (rows * cols) as f64;
        let mean_dn = stats.iter().map(|s| s.0).sum::<f64>() / n;
        let sat_frac = stats.iter().map(|s| s.1).sum::<usize>() as f64 / n;
        account.saturated_fraction = sat_frac;
        account.saturated_by = chain.saturating_stage(g);
        self.abc_cut = next_abc_cut;

        let meta = FrameMeta {
            seq: self.seq,
            time_s: self.seq as f64 / chain.config.timing.frame_rate_hz,
            exposure_s: chain.config.timing.exposure_s,
            gain_in_effect: g,
            mcp_voltage_v: match chain.tube {
                Tube::Iccd(_) => chain.gain_control.voltage_for(g),
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
            noise: noise.enabled,
            saturation: account,
        };
        self.seq += 1;
        if self.mode == Mode::Agc
            && let Some(agc) = &self.agc
        {
            (self.gain, self.agc_state) = agc.step(self.gain, mean_dn - black, sat_frac);
        }
        Ok(DigitizedFrame { pixels, meta })
    }
}

/// The pre- and post-noise blur kernels at one gain.
struct Kernels {
    gain: f64,
    pre_noise: Option<Kernel>,
    post_noise: Option<Kernel>,
}

impl Kernels {
    fn new(chain: &Chain, g: f64) -> Self {
        let stages = chain.stages_at(g);
        let pre: Vec<_> = stages.iter().filter(|s| !s.after_noise).collect();
        let post: Vec<_> = stages.iter().filter(|s| s.after_noise).collect();
        Self {
            gain: g,
            pre_noise: Kernel::from_mtf(|f| pre.iter().map(|s| s.term.at(f)).product()),
            post_noise: Kernel::from_mtf(|f| post.iter().map(|s| s.term.at(f)).product()),
        }
    }
}

impl Patterns {
    fn new(chain: &Chain, rows: usize, cols: usize) -> Self {
        let cfg = &chain.config;
        let seed = cfg.noise.seed;
        let vignette = cfg.optics.vignetting.then(|| {
            optics::cos4_falloff(
                rows,
                cols,
                chain.pitch_cathode_mm,
                cfg.optics.focal_length_mm,
            )
        });
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
            vignette,
            flat_field,
            flat_field_max,
            dsnu,
        }
    }
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
