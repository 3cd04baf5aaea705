//! Coupling from the screen to the CCD: fibre plate or taper (transmission,
//! fibre MTF, the chicken-wire pattern of multifibre boundaries) or a relay
//! lens (collected fraction, diffraction at the working f-number).

use gloam_spectra::Spectrum;
use rayon::prelude::*;

use super::mtf::{MtfStage, MtfTerm};
use crate::config::{Coupling, CouplingKind};

/// Fraction of the Lambertian screen's light that reaches the CCD: the
/// fibre transmission, or for a relay lens `τ / (4 N² (1+m)²)`.
pub fn collected_fraction(c: &Coupling) -> f64 {
    match c.kind {
        CouplingKind::FibrePlate | CouplingKind::FibreTaper => c.transmission,
        CouplingKind::RelayLens => {
            c.lens_transmission / (4.0 * c.f_number * c.f_number * (1.0 + c.magnification).powi(2))
        }
    }
}

/// The coupling's MTF stage in CCD pixels of `pitch_ccd_mm`: the fibre
/// aperture `2 J1(π p ν)/(π p ν)`, or the relay's diffraction at working
/// f-number `N (1+m)` and the photon-weighted mean wavelength of `screen`.
pub fn mtf_stage(c: &Coupling, screen: &Spectrum, pitch_ccd_mm: f64) -> Option<MtfStage> {
    if c.kind == CouplingKind::RelayLens {
        let photons = screen.map_all(|w, x| x * w);
        let lam = photons.map_all(|w, x| x * w).integral() / photons.integral();
        let n_w = c.f_number * (1.0 + c.magnification);
        return Some(MtfStage {
            name: "relay lens diffraction",
            term: MtfTerm::Diffraction {
                cutoff_cy_px: pitch_ccd_mm / (lam * 1e-6 * n_w),
            },
            after_noise: true,
        });
    }
    (c.fibre_pitch_um > 0.0).then(|| MtfStage {
        name: "fibre optic",
        term: MtfTerm::Jinc {
            diameter_px: c.fibre_pitch_um * 1e-3 / pitch_ccd_mm,
        },
        after_noise: true,
    })
}

/// Whether the coupling draws a chicken-wire pattern.
pub fn has_chicken_wire(c: &Coupling) -> bool {
    c.chicken_wire_cell_um > 0.0 && c.chicken_wire_depth > 0.0
}

/// Transmission of a fibre bundle's hexagonal multifibre boundaries at the
/// CCD: `1 − depth · exp(−d²/2w²)` with d the distance to the nearest
/// boundary of a hexagonal tiling of cells `cell_um` across flats.
pub fn chicken_wire(
    rows: usize,
    cols: usize,
    pitch_um: f64,
    cell_um: f64,
    depth: f64,
    width_um: f64,
) -> Vec<f32> {
    let mut v = vec![0f32; rows * cols];
    v.par_chunks_mut(cols).enumerate().for_each(|(r, out)| {
        for (c, o) in out.iter_mut().enumerate() {
            let x = (c as f64 + 0.5) * pitch_um;
            let y = (r as f64 + 0.5) * pitch_um;
            *o = chicken_wire_at(x, y, cell_um, depth, width_um) as f32;
        }
    });
    v
}

/// The chicken-wire transmission at (x, y) µm on the CCD.
fn chicken_wire_at(x: f64, y: f64, cell_um: f64, depth: f64, width_um: f64) -> f64 {
    let d = cell_um;
    let h = d * 3f64.sqrt() / 2.0;
    // The tiling's (arbitrary) offset from the pixel grid.
    let (ox, oy) = (0.37 * d, 0.61 * d);
    let (x, y) = (x + ox, y + oy);
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
    1.0 - depth * (-0.5 * (dist / width_um).powi(2)).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn relay(f_number: f64, m: f64) -> Coupling {
        Coupling {
            kind: CouplingKind::RelayLens,
            magnification: m,
            transmission: 0.0,
            fibre_pitch_um: 0.0,
            chicken_wire_cell_um: 0.0,
            chicken_wire_depth: 0.0,
            chicken_wire_width_um: 0.0,
            f_number,
            lens_transmission: 0.8,
        }
    }

    #[test]
    fn relay_collects_the_lambertian_fraction() {
        // 1:1 relay at f/1: τ/(4·1·4) = τ/16 of a Lambertian screen's light
        // (the image-side camera equation with (1+m)² = 4).
        assert!((collected_fraction(&relay(1.0, 1.0)) - 0.8 / 16.0).abs() < 1e-15);
    }

    #[test]
    fn chicken_wire_dips_by_depth_on_a_boundary_and_not_inside_a_cell() {
        // Cells 100 µm across flats: a cell centre is 50 µm from its edges,
        // the midpoint between two neighbouring centres is on the boundary.
        let (d, depth, w) = (100.0, 0.05, 3.0);
        let (ox, oy) = (0.37 * d, 0.61 * d);
        let centre = chicken_wire_at(-ox, -oy, d, depth, w);
        let edge = chicken_wire_at(d / 2.0 - ox, -oy, d, depth, w);
        assert!((centre - 1.0).abs() < 1e-12, "{centre}");
        assert!((edge - (1.0 - depth)).abs() < 1e-9, "{edge}");
    }
}
