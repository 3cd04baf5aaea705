//! Phosphor screen: photons per electron, emission spectra, light spread in
//! the screen and persistence from frame to frame.

use gloam_spectra::{EmissionLine, Spectrum};
use rayon::prelude::*;

use super::mtf::{MtfStage, MtfTerm};
use crate::config::{Phosphor, PhosphorType, SpreadShape};

/// hc in eV nm.
const HC_EV_NM: f64 = 1_239.841_984;

/// Defaults of a phosphor type.
#[derive(Clone, Copy, Debug)]
pub struct PhosphorDefaults {
    pub energy_efficiency: f64,
    pub dead_voltage_v: f64,
    pub lag_fraction: f64,
}

/// Energy efficiencies are typical forward-emission values for aluminised
/// screens in image tubes (P20 ≈ 0.10, P43 ≈ 0.08, P46 ≈ 0.03; ZnS-type
/// phosphors are the most efficient, YAG:Ce trades efficiency for speed).
/// Dead voltage 2 kV is typical for the aluminium film. Lag fractions are
/// *assumed* afterglow carried into the next 40 ms frame: P20's hyperbolic
/// tail ≈ 1 %, P43 ≈ 0.2 % (1 ms to 10 %), P46 (≈ 0.3 µs) none.
pub fn phosphor_defaults(p: PhosphorType) -> PhosphorDefaults {
    match p {
        PhosphorType::P20 => PhosphorDefaults {
            energy_efficiency: 0.10,
            dead_voltage_v: 2000.0,
            lag_fraction: 0.01,
        },
        PhosphorType::P43 => PhosphorDefaults {
            energy_efficiency: 0.08,
            dead_voltage_v: 2000.0,
            lag_fraction: 0.002,
        },
        PhosphorType::P46 => PhosphorDefaults {
            energy_efficiency: 0.03,
            dead_voltage_v: 2000.0,
            lag_fraction: 0.0,
        },
    }
}

/// Relative spectral power of a phosphor's emission (integral 1).
pub fn phosphor_spectrum(p: PhosphorType) -> Spectrum {
    let gaussian = |peak: f64, fwhm: f64| {
        let sigma = fwhm / 2.354_820_045;
        let grid: Vec<f64> = (0..=120).map(|i| 350.0 + 4.0 * i as f64).collect();
        let v = grid
            .iter()
            .map(|&w| (-0.5 * ((w - peak) / sigma).powi(2)).exp())
            .collect();
        Spectrum::new(grid, v).expect("static grid")
    };
    let s = match p {
        PhosphorType::P20 => gaussian(560.0, 95.0),
        PhosphorType::P46 => gaussian(530.0, 110.0),
        PhosphorType::P43 => Spectrum::from_lines(
            [(489.0, 0.15), (545.0, 0.60), (586.0, 0.15), (622.0, 0.10)]
                .iter()
                .map(|&(w, v)| EmissionLine {
                    wavelength_nm: w,
                    value: v,
                })
                .collect(),
        )
        .expect("static lines"),
    };
    let total = s.integral();
    s.scaled(1.0 / total).expect("positive")
}

/// A configured screen, reduced to what the chain needs.
#[derive(Clone, Debug)]
pub struct Screen {
    /// Relative spectral power of the emission (integral 1).
    pub spectrum: Spectrum,
    /// Photons per electron `η_E (V_s − V_dead) / ⟨hν⟩`.
    pub photons_per_e: f64,
    /// Fraction p of a frame's light emitted in later frames.
    pub lag_fraction: f64,
}

impl Screen {
    pub fn new(ph: &Phosphor) -> Self {
        let d = phosphor_defaults(ph.phosphor);
        let spectrum = phosphor_spectrum(ph.phosphor);
        // Mean photon energy of the emission, eV: power / photon count.
        let photons_per_w = spectrum.map_all(|w, x| x * w / HC_EV_NM).integral();
        let mean_photon_ev = 1.0 / photons_per_w;
        let eff = ph.energy_efficiency.unwrap_or(d.energy_efficiency);
        let dead = ph.dead_voltage_v.unwrap_or(d.dead_voltage_v);
        Self {
            photons_per_e: eff * (ph.screen_voltage_v - dead) / mean_photon_ev,
            lag_fraction: ph.lag_fraction.unwrap_or(d.lag_fraction),
            spectrum,
        }
    }

    /// The spread of light in the screen: Gaussian σ, or an exponential
    /// line spread of decay length a (Lorentzian MTF `1/(1+(2πaν)²)`).
    pub fn spread_mtf(ph: &Phosphor, pitch_cathode_mm: f64) -> Option<MtfStage> {
        (ph.spread_um > 0.0).then(|| {
            let a_px = ph.spread_um * 1e-3 / pitch_cathode_mm;
            MtfStage {
                name: "phosphor spread",
                term: match ph.spread_shape {
                    SpreadShape::Gaussian => MtfTerm::Gaussian { sigma_px: a_px },
                    SpreadShape::Exponential => MtfTerm::Lorentzian { length_px: a_px },
                },
                after_noise: true,
            }
        })
    }
}

/// Persistence: `S_n = (1−p) X_n + p S_{n−1}`, in place on the frame `x`,
/// with the screen state `state` carried between frames (the first frame,
/// or a change of size, starts the screen at that frame's light).
pub fn persist(state: &mut Option<Vec<f32>>, x: &mut [f32], p: f64) {
    if p <= 0.0 {
        return;
    }
    match state {
        Some(s) if s.len() == x.len() => {
            s.par_iter_mut().zip(x.par_iter_mut()).for_each(|(s, x)| {
                *s = (1.0 - p as f32) * *x + p as f32 * *s;
                *x = *s;
            });
        }
        _ => *state = Some(x.to_vec()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn p43_mean_photon_energy_from_its_lines() {
        // Power-weighted lines 489/545/586/622 nm (0.15/0.60/0.15/0.10): the
        // photon count per watt is Σ wᵢ λᵢ / hc, so ⟨hν⟩ = hc / Σ wᵢ λᵢ.
        let ph = Phosphor {
            phosphor: PhosphorType::P43,
            screen_voltage_v: 6000.0,
            dead_voltage_v: None,
            energy_efficiency: None,
            gap_mm: 0.4,
            exit_energy_ev: 0.5,
            spread_um: 3.0,
            spread_shape: SpreadShape::Gaussian,
            lag_fraction: None,
        };
        let mean_nm: f64 = 0.15 * 489.0 + 0.60 * 545.0 + 0.15 * 586.0 + 0.10 * 622.0;
        let want = 0.08 * (6000.0 - 2000.0) / (HC_EV_NM / mean_nm);
        let s = Screen::new(&ph);
        assert!(
            (s.photons_per_e / want - 1.0).abs() < 1e-9,
            "{}",
            s.photons_per_e
        );
        assert_eq!(s.lag_fraction, 0.002);
    }

    #[test]
    fn spectra_have_unit_integral_and_the_stated_peak() {
        for p in [PhosphorType::P20, PhosphorType::P43, PhosphorType::P46] {
            assert!((phosphor_spectrum(p).integral() - 1.0).abs() < 1e-9);
        }
        // P20 Gaussian at 560 nm: its value there beats 540 and 580 nm.
        let s = phosphor_spectrum(PhosphorType::P20);
        assert!(s.eval(560.0) > s.eval(540.0) && s.eval(560.0) > s.eval(580.0));
    }

    #[test]
    fn persistence_impulse_response_is_geometric() {
        // A unit flash then darkness: (1−p), then (1−p)p, (1−p)p², …
        let p = 0.25;
        let mut state = Some(vec![0f32]);
        let mut out = Vec::new();
        for x in [1f32, 0.0, 0.0, 0.0] {
            let mut f = vec![x];
            persist(&mut state, &mut f, p);
            out.push(f[0] as f64);
        }
        for (n, &o) in out.iter().enumerate() {
            let want = (1.0 - p) * p.powi(n as i32);
            assert!((o - want).abs() < 1e-7, "frame {n}: {o} vs {want}");
        }
    }
}
