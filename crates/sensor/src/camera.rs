//! The camera: a chain with memory (AGC loop, phosphor persistence) that
//! turns radiance images into digitised frames, one capture per frame time.

use ndarray::{Array2, ArrayView2, ArrayView3, Axis};
use rayon::prelude::*;

use gloam_spectra::Spectrum;

pub use crate::stages::agc::AgcState;

use crate::config::SensorConfig;
use crate::error::{CaptureError, ConfigError};
use crate::stages::agc::AgcLoop;
use crate::stages::bright::SaturationAccount;
use crate::stages::list::{InFlight, Stages};
use crate::stages::{Chain, FrameNoise, Tube};

pub use gloam_io::frame::SensorMeta;
use gloam_io::frame::{DnLevels, FrameMeta, FrameStatus};

pub use gloam_io::frame::Frame;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    Fixed,
    Override,
    Agc,
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
    /// The AGC's gate duty factor for the next frame (autogating; 1 else).
    duty: f64,
    agc_state: AgcState,
    seq: u64,
    /// The stages in order, with what each carries between frames.
    stages: Stages,
    buf: Vec<f32>,
    tmp: Vec<f32>,
    wide: Vec<f64>,
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
            min_duty: agc
                .gate_min_s
                .map(|g| (g / chain.config.timing.exposure_s).min(1.0)),
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
            duty: 1.0,
            seq: 0,
            stages: Stages::of(&chain),
            buf: Vec::new(),
            tmp: Vec::new(),
            wide: Vec::new(),
            scope_rows: Vec::new(),
            scope_lines: Vec::new(),
            chain,
        })
    }

    /// A built-in preset or a TOML file (noted in `reads`).
    pub fn from_preset_or_file(
        name_or_path: &str,
        reads: &gloam_io::ReadLog,
    ) -> Result<Self, ConfigError> {
        Self::new(SensorConfig::load_preset_or_file(name_or_path, reads)?)
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

    /// The AGC's gate duty factor for the next frame (1 unless autogating).
    pub fn agc_duty(&self) -> f64 {
        self.duty
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
                self.duty = 1.0;
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
                    self.duty = 1.0;
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
        self.stages.reset();
        if self.mode != Mode::Override {
            self.gain = self.chain.reference_gain;
            self.duty = 1.0;
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
        let k = self.chain.etendue_m2_sr_s;
        let pe = self.convert_checked(detected_e_s_m2_sr, k)?;
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
        let pe = self.convert_checked(pe_per_pixel, 1.0)?;
        self.run(pe, rows, cols, false)
    }

    /// `img · k` as f32 into the camera's frame buffer, checking every
    /// value is finite and ≥ 0 in the same pass (row chunks in parallel;
    /// the first bad value is reported).
    fn convert_checked(&mut self, img: ArrayView2<f64>, k: f64) -> Result<Vec<f32>, CaptureError> {
        let mut pe = std::mem::take(&mut self.buf);
        let Some(sl) = img.as_slice() else {
            check_input(img, 0)?;
            pe.clear();
            pe.extend(img.iter().map(|&v| (v * k) as f32));
            return Ok(pe);
        };
        // Every element is overwritten, so no clearing first.
        pe.resize(sl.len(), 0.0);
        let ok = pe
            .par_chunks_mut(1 << 14)
            .zip(sl.par_chunks(1 << 14))
            .map(|(o, i)| {
                let mut ok = true;
                for (o, &v) in o.iter_mut().zip(i) {
                    ok &= v.is_finite() & (v >= 0.0);
                    *o = (v * k) as f32;
                }
                ok
            })
            .reduce(|| true, |a, b| a & b);
        if !ok {
            self.buf = pe;
            check_input(img, 0)?;
            unreachable!("check_input reports the bad value the scan saw");
        }
        Ok(pe)
    }

    /// Runs the stages ([`Stages`], in the order the light travels) over a
    /// frame of mean photoelectrons per pixel `pe`; then the loops that set
    /// the next frame (the ABC's cut, the AGC's gain).
    fn run(
        &mut self,
        pe: Vec<f32>,
        rows: usize,
        cols: usize,
        apply_vignette: bool,
    ) -> Result<Frame, CaptureError> {
        let chain = &self.chain;
        // The tube's ABC: MCP voltage first, then the gate.
        let (mut abc, abc_out_of_range) = self.stages.abc_setting(chain.gain_min / self.gain);
        // The AGC's gate and the tube's own cut multiply.
        abc.duty_factor *= self.duty;
        let g = self.gain * abc.gain_factor;
        let mut f = InFlight {
            pe,
            tmp: std::mem::take(&mut self.tmp),
            wide: std::mem::take(&mut self.wide),
            rows,
            cols,
            apply_vignette,
            gain: g,
            abc,
            noise: FrameNoise {
                enabled: self.noise,
                seed: self.seed,
                frame: self.seq,
                gaussian_above: chain.config.noise.gaussian_above,
            },
            ebi_pe: 0.0,
            mean_pe: 0.0,
            mean_screen_e: None,
            account: SaturationAccount {
                abc,
                abc_out_of_range,
                ..SaturationAccount::default()
            },
            scope_rows: &self.scope_rows,
            pixels: Array2::zeros((0, 0)),
            mean_dn: 0.0,
            scope_lines: Vec::new(),
        };
        for stage in self.stages.iter_mut() {
            stage.apply(chain, &mut f);
        }
        for stage in self.stages.iter_mut() {
            stage.finish(&f);
        }
        let (mean_dn, sat_frac) = (f.mean_dn, f.account.saturated_fraction);
        let agc = self.agc.as_ref().filter(|_| self.mode == Mode::Agc);
        let median_dn = agc
            .filter(|a| a.agc.metering == crate::config::Metering::Median)
            .map(|_| crate::stages::agc::median_dn(&f.pixels));
        let meta = SensorMeta {
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
            noise: self.noise,
            saturation: f.account,
            median_dn,
        };
        (self.buf, self.tmp, self.wide, self.scope_lines) = (f.pe, f.tmp, f.wide, f.scope_lines);
        self.seq += 1;
        if let Some(agc) = agc {
            let black = chain.black_dn(g);
            let metered = median_dn.unwrap_or(mean_dn);
            let s = agc.step_metered(
                self.gain,
                self.duty,
                metered - black,
                mean_dn - black,
                sat_frac,
            );
            (self.gain, self.duty, self.agc_state) = (s.gain, s.duty, s.state);
        }
        let pixels = row_major(f.pixels);
        Ok(Frame {
            meta: self.frame_meta(meta, &pixels),
            pixels,
        })
    }

    /// The meta of a frame just made with the sensor's own figures `m`:
    /// its levels and gate at its gain as the chain gives them, its start
    /// (µs, rounded) as the frame clock's, no exposure (the figures' own
    /// `exposure_s` says it).
    fn frame_meta(&self, m: SensorMeta, pixels: &[u16]) -> FrameMeta {
        let (chain, g) = (&self.chain, m.gain_in_effect);
        FrameMeta {
            seq: m.seq,
            timestamp_us: (m.time_s * 1e6).round() as u64,
            gain: g,
            agc: m.agc_enabled,
            bits: m.bits,
            width: m.width as u32,
            height: m.height as u32,
            pixels_crc32c: gloam_io::frame::pixels_crc32c(pixels),
            status: FrameStatus::Ok,
            levels: Some(DnLevels {
                black_dn: chain.black_dn(g),
                saturation_dn: chain.saturation_dn(g),
                saturated_at_dn: chain.saturated_threshold_dn(g),
                electrons_per_dn: Some(1.0 / chain.mean_dn_per_photoelectron(g)),
            }),
            exposure_us: None,
            // The duty in effect: the configured gate times the tube's and
            // the AGC's cuts.
            gate_duty: (chain.config.photocathode.as_ref())
                .map(|p| p.gate_duty * m.saturation.abc.duty_factor),
            nd_density: Some(chain.config.optics.nd_density),
            sensor: Some(m),
        }
    }
}

/// An array's counts in row order (no copy when they are laid out so).
fn row_major(a: Array2<u16>) -> Vec<u16> {
    let n = a.len();
    if a.is_standard_layout() {
        let (v, offset) = a.into_raw_vec_and_offset();
        if offset.unwrap_or(0) == 0 && v.len() == n {
            return v;
        }
        return v.into_iter().skip(offset.unwrap_or(0)).take(n).collect();
    }
    a.iter().copied().collect()
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
