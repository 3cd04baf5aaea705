//! A traced scene as the simulated camera sees it. Rendered by the caller
//! (`gloam-pipeline` traces it): this crate does not trace.

use ndarray::{Array2, Array3};

use gloam_grabber::GrabError;
use gloam_spectra::Spectrum;

/// A rendered scene as the camera sees it.
#[derive(Clone, Debug)]
pub struct SceneView {
    /// What was rendered (for descriptions), e.g. the scene path.
    pub label: String,
    pub image: SceneImage,
}

/// The radiance of a [`SceneView`].
#[derive(Clone, Debug)]
pub enum SceneImage {
    /// Per-band radiance, W m⁻² sr⁻¹, band × row × column, with each band's
    /// spectral shape (any scale): the camera integrates its QE over each
    /// shape ([`gloam_sensor::Camera::capture`]).
    Bands {
        radiance_w_m2_sr: Array3<f64>,
        band_shapes: Vec<Spectrum>,
    },
    /// Detected-electron radiance `∫ L QE λ/hc dλ` for this camera's
    /// detector, e⁻ s⁻¹ m⁻² sr⁻¹, row × column: exact for any spectrum
    /// ([`gloam_sensor::Camera::capture_detected`]).
    Detected { e_s_m2_sr: Array2<f64> },
}

impl SceneView {
    /// Checks the shapes agree and every value is finite and ≥ 0 (the first
    /// bad value is named).
    pub fn validate(&self) -> Result<(), GrabError> {
        let bad = |what: String| {
            Err(GrabError::InvalidSetting(format!(
                "scene '{}': {what}",
                self.label
            )))
        };
        let (bands, rows, cols) = match &self.image {
            SceneImage::Bands {
                radiance_w_m2_sr,
                band_shapes,
            } => {
                let (b, r, c) = radiance_w_m2_sr.dim();
                if b != band_shapes.len() {
                    return bad(format!(
                        "{b} radiance bands but {} band spectra",
                        band_shapes.len()
                    ));
                }
                (b, r, c)
            }
            SceneImage::Detected { e_s_m2_sr } => {
                let (r, c) = e_s_m2_sr.dim();
                (1, r, c)
            }
        };
        if bands == 0 || rows == 0 || cols == 0 {
            return bad(format!(
                "empty radiance image ({bands} bands, {cols}×{rows})"
            ));
        }
        if rows > 4096 || cols > 4096 {
            return bad(format!("{cols}×{rows} is larger than 4096×4096"));
        }
        let first_bad = match &self.image {
            SceneImage::Bands {
                radiance_w_m2_sr, ..
            } => radiance_w_m2_sr
                .indexed_iter()
                .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
                .map(|((b, r, c), v)| format!("radiance {v} at band {b}, row {r}, column {c}")),
            SceneImage::Detected { e_s_m2_sr } => e_s_m2_sr
                .indexed_iter()
                .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
                .map(|((r, c), v)| format!("detected radiance {v} at row {r}, column {c}")),
        };
        match first_bad {
            Some(what) => bad(format!("{what} is not finite and ≥ 0")),
            None => Ok(()),
        }
    }

    /// (width, height) in pixels.
    pub fn size(&self) -> (u32, u32) {
        let (rows, cols) = match &self.image {
            SceneImage::Bands {
                radiance_w_m2_sr, ..
            } => {
                let (_, r, c) = radiance_w_m2_sr.dim();
                (r, c)
            }
            SceneImage::Detected { e_s_m2_sr } => e_s_m2_sr.dim(),
        };
        (cols as u32, rows as u32)
    }
}
