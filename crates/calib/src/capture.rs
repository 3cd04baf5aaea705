//! Grabbing frames robustly and reducing them to statistics.

use std::path::Path;

use gloam_grabber::{Frame, FrameGrabber, GrabError, Stimulus};

use crate::error::CalibError;

/// How many damaged or lost frames in a row are tolerated before giving up.
pub const MAX_CONSECUTIVE_BAD_FRAMES: usize = 20;

/// The next good frame: damaged and lost frames are skipped (they are never
/// good data) up to [`MAX_CONSECUTIVE_BAD_FRAMES`] in a row.
pub fn grab_good(grabber: &mut dyn FrameGrabber) -> Result<Frame, CalibError> {
    let mut bad = 0;
    loop {
        match grabber.grab() {
            Ok(f) => {
                let n = f.meta.width as usize * f.meta.height as usize;
                if f.pixels.len() != n || n == 0 {
                    return Err(CalibError::Invalid(format!(
                        "frame {} holds {} pixels but its metadata says {}×{}",
                        f.meta.seq,
                        f.pixels.len(),
                        f.meta.width,
                        f.meta.height
                    )));
                }
                return Ok(f);
            }
            Err(e) if e.is_frame_loss() => {
                bad += 1;
                if bad >= MAX_CONSECUTIVE_BAD_FRAMES {
                    return Err(CalibError::Grab(e));
                }
            }
            Err(e) => return Err(e.into()),
        }
    }
}

/// Frames a long capture lost, by kind, for its summary line: damaged
/// frames, frames lost (counted by sequence gaps), stream interruptions and
/// how many of those lost an unknown number of frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameLosses {
    pub damaged: u64,
    pub lost: u64,
    pub interruptions: u64,
    pub unknown: u64,
}

impl FrameLosses {
    /// Counts `e` when it is a frame loss ([`GrabError::is_frame_loss`]);
    /// `false` for any other error, which a capture should not ride out.
    pub fn count(&mut self, e: &GrabError) -> bool {
        if !e.is_frame_loss() {
            return false;
        }
        match e {
            GrabError::FrameDamaged { .. } => self.damaged += 1,
            GrabError::FramesLost { count, .. } => self.lost += count,
            GrabError::Interrupted { frames_lost, .. } => {
                self.interruptions += 1;
                match frames_lost {
                    Some(n) => self.lost += n,
                    None => self.unknown += 1,
                }
            }
            _ => {}
        }
        true
    }

    /// The capture's closing line: `captured N frame(s) into OUT; D
    /// damaged, L lost`, then the frames with exposure warnings and the
    /// interruptions when there were any.
    pub fn summary(&self, captured: usize, out: &Path, frames_with_warnings: u64) -> String {
        let mut s = format!(
            "captured {captured} frame(s) into {}; {} damaged, {} lost",
            out.display(),
            self.damaged,
            self.lost
        );
        if frames_with_warnings > 0 {
            s.push_str(&format!(
                "; {frames_with_warnings} frame(s) with exposure warnings (see frames.jsonl)"
            ));
        }
        if self.interruptions > 0 {
            s.push_str(&format!(
                ", {} interruption(s) ({} with an unknown number of lost frames)",
                self.interruptions, self.unknown
            ));
        }
        s
    }
}

/// Most bytes of pixels one stack of frames may hold at once.
pub const MAX_STACK_BYTES: u64 = 4 << 30;

/// `n` good frames of the same size; refused once the first frame's size
/// shows the stack would pass [`MAX_STACK_BYTES`].
pub fn grab_frames(grabber: &mut dyn FrameGrabber, n: usize) -> Result<Vec<Frame>, CalibError> {
    let mut out: Vec<Frame> = Vec::new();
    for _ in 0..n {
        let f = grab_good(grabber)?;
        if out.is_empty() {
            let bytes = (n as u64).saturating_mul(2 * f.pixels.len() as u64);
            if bytes > MAX_STACK_BYTES {
                return Err(CalibError::Invalid(format!(
                    "{n} frames of {}×{} at one setting would hold {:.1} GiB at once (at most {} GiB): take fewer frames",
                    f.meta.width,
                    f.meta.height,
                    bytes as f64 / (1u64 << 30) as f64,
                    MAX_STACK_BYTES >> 30
                )));
            }
            out.reserve_exact(n);
        }
        if let Some(first) = out.first()
            && (first.meta.width, first.meta.height) != (f.meta.width, f.meta.height)
        {
            return Err(CalibError::Invalid(format!(
                "frame size changed mid-capture from {}×{} to {}×{}",
                first.meta.width, first.meta.height, f.meta.width, f.meta.height
            )));
        }
        out.push(f);
    }
    Ok(out)
}

/// Statistics of a stack of frames taken at one setting.
#[derive(Clone, Debug, PartialEq)]
pub struct StackStats {
    /// Mean over pixels and frames, DN.
    pub mean_dn: f64,
    /// Temporal standard deviation: sqrt of the pixel-averaged variance
    /// across frames (unbiased), DN. Zero with a single frame.
    pub temporal_std_dn: f64,
    /// Fraction of pixel samples at the digitizer's maximum.
    pub clipped_fraction: f64,
    /// Largest code the digitizer can output.
    pub max_dn: f64,
    /// Per-pixel temporal mean (row-major).
    pub mean_image: Vec<f64>,
    pub width: usize,
    pub height: usize,
    /// Gain in effect per frame, as reported.
    pub gains: Vec<f64>,
}

/// Reduces a non-empty stack of equally sized frames.
pub fn stack_stats(frames: &[Frame]) -> Result<StackStats, CalibError> {
    let first = frames
        .first()
        .ok_or_else(|| CalibError::InsufficientData("no frames captured".into()))?;
    let n = first.pixels.len();
    let k = frames.len() as f64;
    let max_dn = ((1u64 << first.meta.bits.min(16)) - 1) as f64;
    let mut sum = vec![0.0f64; n];
    let mut sum2 = vec![0.0f64; n];
    let mut clipped = 0usize;
    for f in frames {
        for (i, &p) in f.pixels.iter().enumerate() {
            let v = p as f64;
            sum[i] += v;
            sum2[i] += v * v;
            if v >= max_dn {
                clipped += 1;
            }
        }
    }
    let mean_image: Vec<f64> = sum.iter().map(|s| s / k).collect();
    let mean_dn = mean_image.iter().sum::<f64>() / n as f64;
    let temporal_var = if frames.len() > 1 {
        sum.iter()
            .zip(&sum2)
            .map(|(s, s2)| ((s2 - s * s / k) / (k - 1.0)).max(0.0))
            .sum::<f64>()
            / n as f64
    } else {
        0.0
    };
    Ok(StackStats {
        mean_dn,
        temporal_std_dn: temporal_var.sqrt(),
        clipped_fraction: clipped as f64 / (n as f64 * k),
        max_dn,
        mean_image,
        width: first.meta.width as usize,
        height: first.meta.height as usize,
        gains: frames.iter().map(|f| f.meta.gain).collect(),
    })
}

/// Mean of one frame's pixels, DN.
pub fn frame_mean(f: &Frame) -> f64 {
    f.pixels.iter().map(|&p| p as f64).sum::<f64>() / f.pixels.len().max(1) as f64
}

/// Finds the uniform band radiance (W m⁻² sr⁻¹, relative spectrum
/// `spectrum`) that puts the camera's mean output at `fraction` of its
/// full scale above dark, at the current gain: decades upward from 1e-12
/// until the signal is clearly above dark, then a linear scale-up and one
/// refinement. Only for grabbers that render stimuli (returns an error on
/// hardware, where the operator sets the source).
pub fn auto_range(
    grabber: &mut dyn FrameGrabber,
    spectrum: &str,
    fraction: f64,
) -> Result<f64, CalibError> {
    if !grabber.present(&Stimulus::Dark)? {
        return Err(CalibError::Invalid(
            "auto-ranging needs a grabber that renders stimuli (simulated camera or emulator)"
                .into(),
        ));
    }
    let dark = stack_stats(&grab_frames(grabber, 2)?)?;
    let full = dark.max_dn - dark.mean_dn;
    let signal = |g: &mut dyn FrameGrabber, l: f64| -> Result<(f64, f64), CalibError> {
        g.present(&Stimulus::Uniform {
            radiance_w_m2_sr: l,
            spectrum: spectrum.to_string(),
        })?;
        let s = stack_stats(&grab_frames(g, 2)?)?;
        Ok((s.mean_dn - dark.mean_dn, s.clipped_fraction))
    };
    let mut l = 1e-12;
    for _ in 0..30 {
        let (s, clip) = signal(grabber, l)?;
        if clip > 0.01 {
            // Overshot in one decade: back off and refine linearly below.
            l /= 10.0;
            continue;
        }
        if s > 0.02 * full {
            let mut est = l * fraction * full / s;
            for _ in 0..3 {
                let (s2, clip2) = signal(grabber, est)?;
                if clip2 > 0.01 || s2 <= 0.0 {
                    est *= 0.7;
                    continue;
                }
                est *= fraction * full / s2;
            }
            return Ok(est);
        }
        l *= 10.0;
    }
    Err(CalibError::InsufficientData(
        "auto-ranging found no radiance between 1e-12 and 1e18 W m⁻² sr⁻¹ that the camera responds to"
            .into(),
    ))
}

/// Turns AGC off; a camera without AGC (`Unsupported`) already is.
pub fn agc_off(grabber: &mut dyn FrameGrabber) -> Result<(), CalibError> {
    match grabber.set_agc(false) {
        Ok(_) | Err(GrabError::Unsupported(_)) => Ok(()),
        Err(e) => Err(e.into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn losses_count_by_kind_and_summarise() {
        let mut l = FrameLosses::default();
        assert!(l.count(&GrabError::FrameDamaged {
            seq: 4,
            reason: "crc".into()
        }));
        assert!(l.count(&GrabError::FramesLost {
            count: 3,
            next_seq: 9
        }));
        assert!(!l.count(&GrabError::Unsupported("agc".into())));
        assert_eq!(
            l,
            FrameLosses {
                damaged: 1,
                lost: 3,
                interruptions: 0,
                unknown: 0
            }
        );
        assert_eq!(
            l.summary(7, Path::new("o"), 0),
            "captured 7 frame(s) into o; 1 damaged, 3 lost"
        );
        assert_eq!(
            l.summary(7, Path::new("o"), 2),
            "captured 7 frame(s) into o; 1 damaged, 3 lost; 2 frame(s) with exposure warnings (see frames.jsonl)"
        );
    }
}
