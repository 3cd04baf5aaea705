//! Figures of a stack of frames: the numbers a sweep's results table holds.

use crate::run::Figures;

/// `mean_dn` over every pixel of every frame; `temporal_noise_dn`, the
/// RMS over pixels of each pixel's standard deviation across frames
/// (needs two frames or more, else NaN); `signal_dn` = mean − black when
/// the black level is known; `snr` = signal (or mean) / temporal noise.
/// The temporal noise is used, not the spread over pixels, because a
/// scene's own contrast would swamp the spatial one.
pub fn frame_figures(frames: &[&[u16]], black_dn: Option<f64>) -> Figures {
    let mut f = Figures::new();
    let n = frames.len();
    let npix = frames.first().map_or(0, |p| p.len());
    if n == 0 || npix == 0 || frames.iter().any(|p| p.len() != npix) {
        f.insert("mean_dn".into(), f64::NAN);
        return f;
    }
    let mut sum = 0.0f64;
    let mut var_sum = 0.0f64;
    for i in 0..npix {
        let m = frames.iter().map(|p| p[i] as f64).sum::<f64>() / n as f64;
        sum += m;
        if n >= 2 {
            let v = frames
                .iter()
                .map(|p| (p[i] as f64 - m).powi(2))
                .sum::<f64>()
                / (n - 1) as f64;
            var_sum += v;
        }
    }
    let mean = sum / npix as f64;
    let noise = if n >= 2 {
        (var_sum / npix as f64).sqrt()
    } else {
        f64::NAN
    };
    let signal = black_dn.map_or(mean, |b| mean - b);
    f.insert("mean_dn".into(), mean);
    f.insert("temporal_noise_dn".into(), noise);
    if let Some(b) = black_dn {
        f.insert("black_dn".into(), b);
        f.insert("signal_dn".into(), signal);
    }
    f.insert(
        "snr".into(),
        if noise > 0.0 {
            signal / noise
        } else {
            f64::NAN
        },
    );
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_of_known_frames() {
        // Two frames, two pixels: means 11 and 20, per-pixel variances 2 and 0.
        let a = [10u16, 20];
        let b = [12u16, 20];
        let f = frame_figures(&[&a, &b], Some(5.0));
        assert_eq!(f["mean_dn"], 15.5);
        assert_eq!(f["temporal_noise_dn"], 1.0);
        assert_eq!(f["signal_dn"], 10.5);
        assert_eq!(f["snr"], 10.5);
        let one = frame_figures(&[&a], None);
        assert!(one["temporal_noise_dn"].is_nan() && one["snr"].is_nan());
    }
}
