//! The chain as an ordered list of stages. [`Stages::of`] builds it once
//! per camera from its [`Chain`]; a capture runs each [`Stage`] in turn
//! over the frame in flight ([`InFlight`]), and [`crate::sensor_effects`]
//! reports the same list, entry by entry — so the order the stages run in
//! and the order the effect plan lists them in is one order, written here
//! once.
//!
//! Each stage's pass goes over the whole frame, row by row in parallel, as
//! the camera always did: a stage that needs the whole frame (a blur, the
//! halo, blooming) sees it, and the CCD → video → digitizer pass stays
//! fused per row ([`super::readout`]). A stage that does not apply to a
//! camera (the MCP of a plain CCD, a disabled halo) stays in the list as
//! `None`, so the plan can say why it is off; it costs nothing at capture.
//! A stage that carries state from frame to frame (phosphor persistence,
//! pore reservoirs, the ABC's cut, the blur and pattern caches) owns it.

use std::borrow::Cow;

use ndarray::Array2;
use rayon::prelude::*;

use super::abc::{Abc, AbcSetting};
use super::bright::{BrightStages, SaturationAccount, source_in_view};
use super::ebccd::{EbParams, EbPass};
use super::halo::Halo;
use super::mcp::{Mcp, McpPass, RowScratch};
use super::mcp_depletion::Depletion;
use super::readout::{self, Patterns};
use super::{Chain, FrameNoise, MtfStage, Tube, optics, phosphor};
use crate::kernel::Kernel;

/// One capture on its way through the stages.
pub(crate) struct InFlight<'a> {
    /// Mean photoelectrons per pixel, row-major; charge after the gain stage.
    pub pe: Vec<f32>,
    /// Scratch of the frame's size for the blurs.
    pub tmp: Vec<f32>,
    /// Scratch for the halo's prefix sums.
    pub wide: Vec<f64>,
    pub rows: usize,
    pub cols: usize,
    /// Apply the cos⁴θ fall-off (not to photoelectrons given at the cathode).
    pub apply_vignette: bool,
    /// Tube gain in effect (after the ABC's cut).
    pub gain: f64,
    /// The ABC's setting for this frame.
    pub abc: AbcSetting,
    pub noise: FrameNoise,
    /// Dark-emission photoelectrons per pixel this frame.
    pub ebi_pe: f64,
    /// Mean input photoelectrons per pixel (measured with a bright-source switch).
    pub mean_pe: f64,
    /// Mean MCP output electrons per pixel, for the ABC (ICCD).
    pub mean_screen_e: Option<f64>,
    pub account: SaturationAccount,
    /// Frame rows whose CCD electrons are kept for the scope.
    pub scope_rows: &'a [usize],
    // The readout's results.
    pub pixels: Array2<u16>,
    pub mean_dn: f64,
    pub scope_lines: Vec<(usize, Vec<f64>)>,
}

/// One stage of the chain, with the state it carries between frames.
pub(crate) enum Stage {
    /// Optics: cos⁴θ fall-off (the camera equation is in the input
    /// conversion); its map cached per frame size.
    Optics {
        vignetting: bool,
        falloff: Option<(usize, usize, Vec<f32>)>,
    },
    /// The MTF stages before (`after_noise` false) or after the gain noise
    /// as one separable kernel, cached per gain (only the EBCCD's depends on
    /// it).
    Blur {
        after_noise: bool,
        kernel: Option<(f64, Option<Kernel>)>,
    },
    /// The detecting surface: its dark emission (EBI) for this frame (shot
    /// noise is drawn in the gain or CCD pass).
    Photocathode,
    /// The bright-source switch (ICCD): input mean and maximum, and whether
    /// a bright source is in view (threshold: max over mean).
    BrightSwitch(Option<f64>),
    /// The ABC: the photocathode gate's duty cut (its MCP-voltage cut is in
    /// the frame's gain); `cut` is carried to the next frame.
    Abc { abc: Option<Abc>, cut: f64 },
    /// MCP-input backscatter, while a bright source is in view.
    Halo(Option<Halo>),
    /// The MCP cascade and pore depletion.
    Mcp(Option<McpStage>),
    /// Phosphor persistence (ICCD): lag fraction and the screen's state.
    Phosphor {
        lag_fraction: Option<f64>,
        screen: Option<Vec<f32>>,
    },
    /// Fibre or relay coupling: its fraction is in the CCD's conversion,
    /// its chicken wire in the readout's flat field.
    Coupling,
    /// Electron bombardment (EBCCD).
    Bombardment(Option<EbParams>),
    /// CCD, video and digitizer, fused per row; fixed patterns per size.
    Readout(Option<Patterns>),
    /// The AGC: acts between frames ([`crate::Camera`] steps it, as it
    /// owns the gain and the override).
    Agc,
}

/// The MCP plate, its pore depletion and the pores' charge reservoirs
/// (fraction full) while a depletion is recovering.
pub(crate) struct McpStage {
    plate: Mcp,
    depletion: Option<Depletion>,
    reservoir: Option<Vec<f32>>,
}

/// A camera's stages in the order the light travels.
pub(crate) struct Stages(Vec<Stage>);

impl Stages {
    /// The list for `chain`.
    pub(crate) fn of(chain: &Chain) -> Self {
        let bright = BrightStages::of(chain);
        let b = bright.as_ref();
        let intensifier = chain.intensifier();
        Self(vec![
            Stage::Optics {
                vignetting: chain.config.optics.vignetting,
                falloff: None,
            },
            Stage::Blur {
                after_noise: false,
                kernel: None,
            },
            Stage::Photocathode,
            Stage::BrightSwitch(b.map(|b| b.on_above_max_over_mean)),
            Stage::Abc {
                abc: b.and_then(|b| b.abc),
                cut: 1.0,
            },
            Stage::Halo(b.and_then(|b| b.halo.clone())),
            Stage::Mcp(intensifier.map(|i| McpStage {
                plate: i.mcp.clone(),
                depletion: b.and_then(|b| b.depletion),
                reservoir: None,
            })),
            Stage::Phosphor {
                lag_fraction: intensifier.map(|i| i.lag_fraction),
                screen: None,
            },
            Stage::Coupling,
            Stage::Bombardment(match &chain.tube {
                Tube::Ebccd(e) => Some(*e),
                _ => None,
            }),
            Stage::Blur {
                after_noise: true,
                kernel: None,
            },
            Stage::Readout(None),
            Stage::Agc,
        ])
    }

    pub(crate) fn iter(&self) -> impl Iterator<Item = &Stage> {
        self.0.iter()
    }

    pub(crate) fn iter_mut(&mut self) -> impl Iterator<Item = &mut Stage> {
        self.0.iter_mut()
    }

    /// The ABC's setting for the next frame (gain first, down to
    /// `gain_floor` = minimum over set gain, then the gate) and whether it
    /// has run out of range; open without an ABC or below its limit.
    pub(crate) fn abc_setting(&self, gain_floor: f64) -> (AbcSetting, bool) {
        self.iter()
            .find_map(|s| match s {
                Stage::Abc { abc: Some(a), cut } if *cut < 1.0 => Some(a.split(*cut, gain_floor)),
                _ => None,
            })
            .unwrap_or((AbcSetting::OPEN, false))
    }

    /// Forgets what carries between frames (persistence, reservoirs, the
    /// ABC's cut).
    pub(crate) fn reset(&mut self) {
        for s in self.iter_mut() {
            match s {
                Stage::Abc { cut, .. } => *cut = 1.0,
                Stage::Mcp(Some(m)) => m.reservoir = None,
                Stage::Phosphor { screen, .. } => *screen = None,
                _ => {}
            }
        }
    }
}

/// The MTF stages in effect at gain `g` before or after the gain noise.
pub(crate) fn blur_terms(chain: &Chain, g: f64, after_noise: bool) -> Vec<MtfStage> {
    let mut s = chain.stages_at(g);
    s.retain(|s| s.after_noise == after_noise);
    s
}

/// Their product as one kernel (None: identity).
pub(crate) fn blur_kernel(terms: &[MtfStage]) -> Option<Kernel> {
    Kernel::from_mtf(|f| terms.iter().map(|s| s.term.at(f)).product())
}

impl Stage {
    /// Runs the stage over the frame in flight.
    pub(crate) fn apply(&mut self, chain: &Chain, f: &mut InFlight) {
        let (rows, cols) = (f.rows, f.cols);
        match self {
            Stage::Optics {
                vignetting: true,
                falloff,
            } if f.apply_vignette => {
                let map = match falloff.take() {
                    Some(m) if m.0 == rows && m.1 == cols => m,
                    _ => (
                        rows,
                        cols,
                        optics::cos4_falloff(
                            rows,
                            cols,
                            chain.pitch_cathode_mm,
                            chain.config.optics.focal_length_mm,
                        ),
                    ),
                };
                optics::apply_falloff(&mut f.pe, &map.2);
                *falloff = Some(map);
            }
            Stage::Optics { .. } => {}
            Stage::Blur {
                after_noise,
                kernel,
            } => {
                let gain_dependent = matches!(chain.tube, Tube::Ebccd(_));
                let k = match kernel.take() {
                    Some(k) if !gain_dependent || k.0 == f.gain => k,
                    _ => (
                        f.gain,
                        blur_kernel(&blur_terms(chain, f.gain, *after_noise)),
                    ),
                };
                if let Some(k) = &k.1 {
                    k.apply(&mut f.pe, &mut f.tmp, rows, cols);
                }
                *kernel = Some(k);
            }
            Stage::Photocathode => f.ebi_pe = chain.ebi_pe(f.gain) * f.abc.duty_factor,
            Stage::BrightSwitch(Some(on_above)) => {
                // One pass: the input's mean and maximum.
                let (sum, max) =
                    f.pe.par_chunks(1 << 14)
                        .map(|c| {
                            c.iter()
                                .fold((0f64, 0f32), |(s, m), &v| (s + v as f64, m.max(v)))
                        })
                        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)));
                let mean = sum / (rows * cols) as f64;
                f.mean_pe = mean;
                f.account.input_max_over_mean = if mean > 0.0 { max as f64 / mean } else { 0.0 };
                f.account.bright_source_in_view = source_in_view(*on_above, mean, max as f64);
            }
            Stage::BrightSwitch(None) => {}
            Stage::Abc { .. } => {
                if f.abc.duty_factor < 1.0 {
                    let d = f.abc.duty_factor as f32;
                    f.pe.par_iter_mut().for_each(|p| *p *= d);
                }
            }
            Stage::Halo(Some(h)) if f.account.bright_source_in_view => {
                h.apply_with(&mut f.pe, rows, cols, &mut f.wide);
                f.account.halo_fraction = h.fraction;
            }
            Stage::Halo(_) => {}
            Stage::Mcp(Some(m)) => m.apply(f),
            Stage::Mcp(None) => {}
            Stage::Phosphor {
                lag_fraction: Some(p),
                screen,
            } => phosphor::persist(screen, &mut f.pe, *p),
            Stage::Phosphor { .. } => {}
            Stage::Coupling | Stage::Agc => {}
            Stage::Bombardment(Some(e)) => {
                let eb = EbPass {
                    eb: e,
                    gain: f.gain,
                    ebi_pe: f.ebi_pe,
                    noise: f.noise,
                };
                f.pe.par_chunks_mut(cols)
                    .enumerate()
                    .for_each(|(r, row)| eb.row(r, row));
            }
            Stage::Bombardment(None) => {}
            Stage::Readout(patterns) => {
                let pat = Patterns::sized(patterns.take(), chain, rows, cols);
                readout::read(chain, &pat, f);
                *patterns = Some(pat);
            }
        }
    }

    /// After the frame: the stages whose next setting depends on it.
    pub(crate) fn finish(&mut self, f: &InFlight) {
        if let Stage::Abc { abc: Some(a), cut } = self
            && let Some(q) = f.mean_screen_e
        {
            *cut = a.step(*cut, q);
        }
    }
}

impl McpStage {
    /// The pore depletion, when enabled.
    pub(crate) fn depletion(&self) -> Option<&Depletion> {
        self.depletion.as_ref()
    }

    fn apply(&mut self, f: &mut InFlight) {
        let (n_px, cols) = ((f.rows * f.cols) as f64, f.cols);
        let in_view = f.account.bright_source_in_view;
        // Pore depletion while a bright source is in view or its deficit is
        // recovering; it replaces the static knee.
        let depletion = self
            .depletion
            .filter(|_| in_view || self.reservoir.is_some());
        let plate = match depletion {
            Some(_) => Cow::Owned(self.plate.without_knee()),
            None => Cow::Borrowed(&self.plate),
        };
        let mcp = McpPass::new(&plate, f.gain, f.ebi_pe, f.noise);
        f.pe.par_chunks_mut(cols)
            .enumerate()
            .for_each_init(RowScratch::default, |s, (r, row)| mcp.row(r, row, s));
        // Mean screen charge per pixel: exact in expectation from the input
        // while the plate is linear, summed otherwise.
        let mut mean_q = self.plate.open_area * (f.mean_pe * f.abc.duty_factor + f.ebi_pe) * f.gain;
        if let Some(d) = depletion {
            let mut state = match self.reservoir.take() {
                Some(s) if s.len() == f.pe.len() => s,
                _ => vec![1f32; f.pe.len()],
            };
            let compressed: usize =
                f.pe.par_chunks_mut(cols)
                    .zip(state.par_chunks_mut(cols))
                    .map(|(row, s)| d.row(row, s))
                    .sum();
            f.account.mcp_compressed_fraction = compressed as f64 / n_px;
            mean_q = f.pe.par_iter().map(|&v| v as f64).sum::<f64>() / n_px;
            let recovered = !in_view
                && state
                    .par_chunks(1 << 14)
                    .all(|c| c.iter().all(|&s| s > 0.999));
            self.reservoir = (!recovered).then_some(state);
        }
        f.mean_screen_e = Some(mean_q);
    }
}
