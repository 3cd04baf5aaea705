//! The camera's stages, one module each, in the order the light travels:
//! [`optics`] → [`photocathode`] → [`mcp`] → [`phosphor`] → [`coupling`] →
//! [`ccd`] (or [`ebccd`] → [`ccd`]) → [`agc`] → [`video`] → [`digitizer`].
//! Each holds its model, its per-row pass (where it has one) and its tests;
//! Around a bright source the intensifier adds [`halo`] (MCP-input
//! backscatter), [`mcp_depletion`] (local pore saturation) and [`abc`]
//! (the supply's brightness control), grouped in [`bright`].
//! [`Chain`] reduces a validated configuration to the numbers they need;
//! `list.rs` puts the stages in their one order (a list built once per
//! camera, which [`crate::Camera`] runs over each frame and
//! [`crate::sensor_effects`] reports), and `readout.rs` fuses the CCD,
//! video and digitizer into one row pass.
//!
//! # Stage models (and where they come from)
//!
//! * **Optics** — camera equation for a distant scene:
//!   `E = π L τ cos⁴θ / (4 N²)` (the `(1+m)²` factor of the general form
//!   `π L τ / (4 N² (1+m)²)` is dropped because m ≈ 0 for distant scenes).
//!   Photoelectrons per pixel per frame `= ∫ E_λ QE(λ) λ/(hc) dλ · A_pix · t`.
//!   MTF: diffraction of a circular pupil,
//!   `M(ν) = (2/π)(acos x − x √(1−x²))`, `x = ν λ N`; optional defocus as a
//!   geometric blur circle of diameter `d = δz / N`, `M = 2 J1(π d ν)/(π d ν)`.
//! * **Photocathode** — spectral QE from the library (S-20, S-25, Gen III
//!   GaAs, GaAsP), a CSV file or an inline table; Poisson shot noise; dark
//!   emission as equivalent background illumination (EBI, lm cm⁻²)
//!   converted with the luminous sensitivity to 2856 K light
//!   `S = q ∫QE·P_A·λ/hc dλ / (683 ∫V·P_A dλ)` (A/lm), scaled by
//!   `(G/G_ref)^ebi_gain_exponent`.
//! * **Proximity focus** — an electron leaving with transverse energy ε
//!   crosses gap L at voltage V in `t = L √(2m/(eV))`; its landing spread per
//!   axis is Gaussian with `σ = L √(2ε/V)` (ε in eV, V in volts), so
//!   `M(ν) = exp(−2π²σ²ν²)` (Csorba, *Image Tubes*, 1985, ch. 4).
//! * **MCP** — `G = G0 (V/V0)^k` (Wiza, NIM 162 (1979) 587: gain is close to
//!   a power law of plate voltage over the working range). Only a fraction η
//!   (open area / first strike) of photoelectrons start a cascade. Single
//!   electron gain is gamma distributed with shape s, so the variance of the
//!   cascade is `G²/s` and the excess noise factor, referred to the
//!   photoelectrons leaving the cathode, is `F = (1 + 1/s)/η` (Eberhardt,
//!   IEEE TNS 28 (1981) 712; Frenkel et al., Appl. Opt. 36 (1997) 5288). The
//!   sum of n cascades is sampled exactly as one `Gamma(n s, G/s)` draw.
//!   Saturation: a soft knee `Q' = Q / √(1 + (Q/Q_sat)²)` with Q_sat the
//!   charge a pixel's channels deliver at the output current limit in a frame.
//!   Channel sampling MTF `2 J1(π p ν)/(π p ν)` for pore pitch p.
//! * **Phosphor** — photons per electron `η_E (V_s − V_dead) / ⟨hν⟩`;
//!   emission spectra: P20 (ZnCdS:Ag) Gaussian 560 nm, 95 nm FWHM; P43
//!   (Gd₂O₂S:Tb) as its Tb³⁺ lines 489/545/586/622 nm (0.15/0.60/0.15/0.10 of
//!   the power); P46 (YAG:Ce) Gaussian 530 nm, 110 nm FWHM (shapes after
//!   JEDEC TEP116-C). Spread: Gaussian σ or exponential (Lorentzian MTF
//!   `1/(1+(2πaν)²)`). Persistence: a fraction `p` of a frame's light comes
//!   out in later frames, decaying geometrically: `S_n = (1−p) X_n + p S_{n−1}`.
//! * **Coupling** — fibre plate / taper: transmission, fibre MTF
//!   `2 J1(π p ν)/(π p ν)`, fixed hexagonal chicken-wire pattern of multifibre
//!   boundaries; relay lens: collected fraction `τ / (4 N² (1+m)²)` of the
//!   Lambertian screen's exitance, diffraction MTF at working f-number
//!   `N (1+m)`.
//! * **EBCCD** — gain `(V − dead layer)/w`, w = 3.65 eV per pair in Si
//!   (Janesick, *Scientific CCDs*, 2001); Fano factor 0.12; a fraction b of
//!   electrons backscatter and deposit a uniform fraction of their energy, so
//!   the mean gain is `G(1 − b/2)` and `F = ((1−b)(1 + f/G) + b/3)/(1 − b/2)²`.
//! * **CCD** — QE (at the phosphor's spectrum in an ICCD, at the scene's in
//!   a plain CCD), PRNU (multiplicative) and DSNU (additive) fixed patterns,
//!   dark current (Poisson), full well with blooming along columns, read
//!   noise, charge-diffusion MTF (Gaussian σ).
//! * **Video / digitizer** — `V = V_black + e (V_white − V_black)/e_full`,
//!   clipped at the white clip; `DN = offset + g (V − V_lo)(2^b − 1)/(V_hi − V_lo)`
//!   rounded and clipped to `0..2^b − 1`. Without video: `DN = offset + g e / (e/DN)`.
//!
//! # Where MTFs act
//!
//! Blurs that move single quanta independently (optics, the cathode gap,
//! channel sampling, and for a plain CCD its charge diffusion) act on the
//! *mean* photoelectron rate before shot noise: a randomly displaced Poisson
//! process is again Poisson. Blurs of the charge cloud one photoelectron makes
//! (MCP→screen gap, phosphor, fibre, relay, the intensified CCD's diffusion)
//! act *after* the gain noise, so that noise is spatially correlated and its
//! per-pixel variance drops by `Σ h²` of the blur kernel.

use rand_pcg::Pcg64Mcg;

use crate::noise::{self, Pass};

pub mod abc;
pub mod agc;
pub mod bright;
pub mod ccd;
mod chain;
pub mod coupling;
pub mod digitizer;
pub mod ebccd;
pub mod halo;
pub(crate) mod list;
pub mod mcp;
pub mod mcp_depletion;
pub mod mtf;
pub mod optics;
pub mod phosphor;
pub mod photocathode;
mod readout;
pub mod video;
pub mod video_bandwidth;
pub mod video_timing;

pub use chain::{Chain, GainControl, Intensifier, Tube, resolve_spectrum};
pub use ebccd::EbParams;
pub use mtf::{MtfStage, MtfTerm, bessel_j1, jinc};
pub use optics::image_irradiance_per_radiance;
pub use phosphor::{PhosphorDefaults, phosphor_defaults, phosphor_spectrum};
pub use photocathode::ELEMENTARY_CHARGE_C;

/// The sample mean and (population) variance of the values in rows
/// `0..rows`, each made by `row(r)`: the moments the stage tests compare with
/// their closed forms.
#[cfg(test)]
pub(crate) fn row_moments(rows: usize, mut row: impl FnMut(usize) -> Vec<f32>) -> (f64, f64) {
    let (mut s1, mut s2, mut n) = (0f64, 0f64, 0f64);
    for r in 0..rows {
        for q in row(r) {
            s1 += q as f64;
            s2 += (q as f64).powi(2);
            n += 1.0;
        }
    }
    let mean = s1 / n;
    (mean, s2 / n - mean * mean)
}

/// The temporal-noise settings of one frame: every pass draws row `r` from
/// its own stream `(seed, frame, pass, r)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameNoise {
    /// Temporal noise on (off: deterministic means).
    pub enabled: bool,
    pub seed: u64,
    pub frame: u64,
    /// Poisson means above this are drawn as Gaussians.
    pub gaussian_above: f64,
}

impl FrameNoise {
    /// The stream of row `row` of `pass`.
    #[inline]
    pub fn stream(&self, pass: Pass, row: usize) -> Pcg64Mcg {
        noise::stream(self.seed, self.frame, pass, row)
    }
}
