//! A traced scene as the simulated camera sees it. Rendered by the caller
//! (`gloam-pipeline` traces it): this crate does not trace.

use std::sync::Arc;

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
    /// A scene that changes: detected-radiance layers (as `Detected`, one
    /// per light group — radiance is linear in each group's emission) mixed
    /// per frame with the weights of its exposure window. Frame `k` starts
    /// at `k / frame_rate_hz` s of the view's clock (restarted with each
    /// acquisition); its window is the camera's exposure, at most one
    /// frame period.
    Layers {
        e_s_m2_sr: Vec<Array2<f64>>,
        frame_rate_hz: f64,
        weights: LayerWeights,
    },
}

/// Each layer's weight over an exposure window `[t0, t1]`, s from the
/// view's start: the caller's (a sequence file's) time course, so this
/// crate need not know what a light group is.
#[derive(Clone)]
pub struct LayerWeights(pub Arc<dyn Fn(f64, f64) -> Vec<f64> + Send + Sync>);

impl std::fmt::Debug for LayerWeights {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("LayerWeights(..)")
    }
}

/// `Σ_i w_i · layer_i` into `out` (the layers' shape), in layer order in
/// f64; a zero weight skips its layer. The caller checks the counts and
/// shapes agree ([`SceneView::validate`]).
///
/// Row blocks in parallel when every array is contiguous (a live device
/// mixes at frame rate); each pixel's sum is the same either way.
/// Each layer `f` (0…1) of the way from render `a` to render `b` of a
/// moving sky, pixel by pixel ([`gloam_spectra::geometric_between`]), into
/// `out` (resized to match `a`).
pub fn layers_between(a: &[Array2<f64>], b: &[Array2<f64>], f: f64, out: &mut Vec<Array2<f64>>) {
    out.resize_with(a.len(), || Array2::zeros((0, 0)));
    for ((o, la), lb) in out.iter_mut().zip(a).zip(b) {
        if o.dim() != la.dim() {
            *o = Array2::zeros(la.dim());
        }
        ndarray::Zip::from(o)
            .and(la)
            .and(lb)
            .for_each(|o, &x, &y| *o = gloam_spectra::geometric_between(x, y, f));
    }
}

pub fn mix_layers(layers: &[Array2<f64>], weights: &[f64], out: &mut Array2<f64>) {
    use rayon::prelude::*;
    let used: Vec<(&Array2<f64>, f64)> = layers
        .iter()
        .zip(weights.iter().copied())
        .filter(|&(_, w)| w != 0.0)
        .collect();
    let slices: Option<Vec<(&[f64], f64)>> = used
        .iter()
        .map(|&(l, w)| l.as_slice().map(|s| (s, w)))
        .collect();
    if let (Some(slices), Some(o)) = (slices, out.as_slice_mut())
        && slices.iter().all(|(s, _)| s.len() == o.len())
    {
        const BLOCK: usize = 1 << 14;
        o.par_chunks_mut(BLOCK).enumerate().for_each(|(i, o)| {
            o.fill(0.0);
            for &(l, w) in &slices {
                for (o, &l) in o.iter_mut().zip(&l[i * BLOCK..]) {
                    *o += w * l;
                }
            }
        });
        return;
    }
    out.fill(0.0);
    for (layer, w) in used {
        ndarray::Zip::from(&mut *out)
            .and(layer)
            .for_each(|o, &l| *o += w * l);
    }
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
            SceneImage::Layers {
                e_s_m2_sr,
                frame_rate_hz,
                ..
            } => {
                if !(frame_rate_hz.is_finite() && *frame_rate_hz > 0.0) {
                    return bad(format!("frame rate {frame_rate_hz} Hz is not positive"));
                }
                let (r, c) = e_s_m2_sr.first().map_or((0, 0), Array2::dim);
                if let Some(i) = e_s_m2_sr.iter().position(|l| l.dim() != (r, c)) {
                    let (ri, ci) = e_s_m2_sr[i].dim();
                    return bad(format!(
                        "layer {i} is {ci}×{ri}, layer 0 {c}×{r}: layers must share one size"
                    ));
                }
                (e_s_m2_sr.len(), r, c)
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
            SceneImage::Layers { e_s_m2_sr, .. } => {
                e_s_m2_sr.iter().enumerate().find_map(|(i, l)| {
                    l.indexed_iter()
                        .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
                        .map(|((r, c), v)| {
                            format!("detected radiance {v} at layer {i}, row {r}, column {c}")
                        })
                })
            }
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
            SceneImage::Layers { e_s_m2_sr, .. } => e_s_m2_sr.first().map_or((0, 0), Array2::dim),
        };
        (cols as u32, rows as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::ShapeBuilder;

    /// The mix is the weighted sum, checked pixel by pixel against the sum
    /// written out by hand.
    #[test]
    fn layers_mix_to_their_weighted_sum() {
        let moon = Array2::from_shape_fn((2, 3), |(r, c)| (1 + r * 3 + c) as f64);
        let lamp = Array2::from_shape_vec((2, 3), vec![10.0, 0.0, 20.0, 0.0, 40.0, 0.5]).unwrap();
        let mut out = Array2::from_elem((2, 3), 7.0);
        mix_layers(&[moon, lamp], &[0.5, 2.0], &mut out);
        // 0.5·[1 2 3; 4 5 6] + 2·[10 0 20; 0 40 0.5]
        let by_hand = [[20.5, 1.0, 41.5], [2.0, 82.5, 4.0]];
        for ((r, c), v) in out.indexed_iter() {
            assert_eq!(*v, by_hand[r][c], "row {r}, column {c}");
        }
        // The lamp off: the moon alone, whatever `out` held.
        let moon = Array2::from_elem((2, 3), 3.0);
        mix_layers(
            &[moon, Array2::from_elem((2, 3), 9.0)],
            &[1.0, 0.0],
            &mut out,
        );
        assert!(out.iter().all(|&v| v == 3.0));
    }

    /// Large frames mix in parallel row blocks, non-contiguous layers one
    /// pixel at a time: both give each pixel's weighted sum in layer order,
    /// to the bit (checked against that sum written per pixel).
    #[test]
    fn parallel_and_strided_mixes_are_the_per_pixel_sum() {
        let (rows, cols) = (150, 301); // several 2¹⁴-pixel blocks and a remainder
        let a = Array2::from_shape_fn((rows, cols), |(r, c)| {
            ((r * 7 + c * 13) % 101) as f64 * 0.37
        });
        let b = Array2::from_shape_fn((rows, cols), |(r, c)| ((r + 3 * c) % 17) as f64 / 3.0);
        let w = [0.3, 1.7];
        let mut out = Array2::zeros((rows, cols));
        mix_layers(&[a.clone(), b.clone()], &w, &mut out);
        // Column-major copies: no contiguous row-major slice.
        let fortran = |x: &Array2<f64>| {
            let mut f = Array2::zeros((rows, cols).f());
            f.assign(x);
            f
        };
        let (af, bf) = (fortran(&a), fortran(&b));
        assert!(af.as_slice().is_none());
        let mut out_f = Array2::zeros((rows, cols));
        mix_layers(&[af, bf], &w, &mut out_f);
        for ((r, c), &v) in out.indexed_iter() {
            let want = (0.0 + w[0] * a[[r, c]]) + w[1] * b[[r, c]];
            assert_eq!(v.to_bits(), want.to_bits(), "row {r}, column {c}");
            assert_eq!(
                out_f[[r, c]].to_bits(),
                want.to_bits(),
                "row {r}, column {c}"
            );
        }
    }

    #[test]
    fn layers_of_different_sizes_are_refused() {
        let view = SceneView {
            label: "street".into(),
            image: SceneImage::Layers {
                e_s_m2_sr: vec![Array2::zeros((2, 3)), Array2::zeros((3, 2))],
                frame_rate_hz: 25.0,
                weights: LayerWeights(Arc::new(|_, _| vec![1.0, 1.0])),
            },
        };
        let e = view.validate().unwrap_err().to_string();
        assert!(e.contains("layer 1 is 2×3, layer 0 3×2"), "{e}");
    }
}
