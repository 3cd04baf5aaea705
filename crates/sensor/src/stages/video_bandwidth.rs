//! The video amplifier's bandwidth and the digitizer's sampling of the
//! analogue line: a horizontal-only MTF, applied along each line in time.
//!
//! The CCD's output (after correlated double sampling) is a staircase, one
//! held step per pixel period `T`. The video amplifier is a continuous-time
//! low-pass with a stated −3 dB frequency `f_c`:
//!
//! * `butterworth-2` (default): `H(s) = ω_c² / (s² + √2 ω_c s + ω_c²)`,
//!   `|H(f)|² = 1 / (1 + (f/f_c)⁴)` — the maximally flat two-pole response
//!   video line drivers are built to;
//! * `single-pole`: `H(s) = ω_c / (s + ω_c)`, `|H(f)|² = 1/(1 + (f/f_c)²)`.
//!
//! RS-170/CCIR cameras are typically specified to 4.2–5 MHz. The filter
//! runs exactly on the staircase: over one held step the state advances by
//! `x ← Φ(τ) x + Γ(τ) u` with `Φ = e^{Aτ}`, `Γ = ∫₀^τ e^{As} ds B` (the
//! step-invariant discretisation, exact for piecewise-constant input), so
//! the digitizer's sample at phase `φ` of pixel n, `y_n = C(Φ(φ) x_n +
//! Γ(φ) u_n)`, is the analogue line at `t = (n + φ) T`. Line-locked
//! clock jitter of σ seconds moves each sample by `δ ~ N(0, σ)`, adding
//! `δ · dy/dt` (first order in δ).
//!
//! Analytic transfer (frequencies `f` in cycles/pixel, `ν = f/T` in Hz):
//! on the line (what an oscilloscope shows) the fundamental of a sine
//! pattern is scaled by `|H(ν)| · |sinc f|` (the held steps); sampled at
//! phase φ, by `|Σ_k H((f+k)/T) sinc(f+k) e^{−jπ(f+k)} e^{j2π(f+k)φ}|`
//! (Poisson summation: the aliases of the staircase's images), which is 1
//! for an unlimited amplifier, and by `exp(−2π² σ² ν²)` on average with
//! jitter.

use serde::{Deserialize, Serialize};

/// The amplifier's response shape.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FilterKind {
    /// Two-pole Butterworth (maximally flat), −3 dB at `bandwidth_hz`.
    #[default]
    #[serde(rename = "butterworth-2")]
    Butterworth2,
    /// One pole (RC), −3 dB at `bandwidth_hz`.
    SinglePole,
}

impl FilterKind {
    pub fn label(&self) -> &'static str {
        match self {
            FilterKind::Butterworth2 => "2-pole Butterworth",
            FilterKind::SinglePole => "single-pole RC",
        }
    }

    /// `H(j 2π ν)` for a −3 dB frequency `fc_hz`, as (re, im).
    pub fn response(&self, fc_hz: f64, nu_hz: f64) -> (f64, f64) {
        let x = nu_hz / fc_hz;
        match self {
            // 1 / (1 − x² + j√2 x)
            FilterKind::Butterworth2 => {
                cdiv((1.0, 0.0), (1.0 - x * x, std::f64::consts::SQRT_2 * x))
            }
            // 1 / (1 + j x)
            FilterKind::SinglePole => cdiv((1.0, 0.0), (1.0, x)),
        }
    }

    /// `|H(ν)|`.
    pub fn magnitude(&self, fc_hz: f64, nu_hz: f64) -> f64 {
        let (re, im) = self.response(fc_hz, nu_hz);
        re.hypot(im)
    }

    /// State-space `(A, B)` in time units of `unit_s` with `C = [1, 0]`.
    fn state_space(&self, fc_hz: f64, unit_s: f64) -> ([[f64; 2]; 2], [f64; 2]) {
        let w = std::f64::consts::TAU * fc_hz * unit_s;
        match self {
            FilterKind::Butterworth2 => (
                [[0.0, 1.0], [-w * w, -std::f64::consts::SQRT_2 * w]],
                [0.0, w * w],
            ),
            FilterKind::SinglePole => ([[-w, 0.0], [0.0, -1.0]], [w, 0.0]),
        }
    }
}

fn cdiv(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    let d = b.0 * b.0 + b.1 * b.1;
    ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
}

/// `sin(πx)/(πx)`.
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-9 {
        1.0
    } else {
        let p = std::f64::consts::PI * x;
        p.sin() / p
    }
}

/// The video amplifier: filter shape and −3 dB frequency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Amplifier {
    pub kind: FilterKind,
    pub bandwidth_hz: f64,
}

/// One held step of the exact discretisation: `x ← Φ x + Γ u`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    pub phi: [[f64; 2]; 2],
    pub gamma: [f64; 2],
}

impl Step {
    #[inline]
    fn apply(&self, x: [f64; 2], u: f64) -> [f64; 2] {
        [
            self.phi[0][0] * x[0] + self.phi[0][1] * x[1] + self.gamma[0] * u,
            self.phi[1][0] * x[0] + self.phi[1][1] * x[1] + self.gamma[1] * u,
        ]
    }
}

impl Amplifier {
    /// The held step of duration `tau` (in units of `unit_s`):
    /// `exp([[A, B], [0, 0]] τ) = [[Φ, Γ], [0, 1]]`.
    fn step(&self, unit_s: f64, tau: f64) -> Step {
        let (a, b) = self.kind.state_space(self.bandwidth_hz, unit_s);
        let m = [
            [a[0][0] * tau, a[0][1] * tau, b[0] * tau],
            [a[1][0] * tau, a[1][1] * tau, b[1] * tau],
            [0.0, 0.0, 0.0],
        ];
        let e = expm3(m);
        Step {
            phi: [[e[0][0], e[0][1]], [e[1][0], e[1][1]]],
            gamma: [e[0][2], e[1][2]],
        }
    }

    /// The state at rest at input `u` (DC gain 1).
    fn rest(&self, u: f64) -> [f64; 2] {
        [u, 0.0]
    }

    /// Runs the amplifier over held `(duration s, input)` segments and
    /// returns the output every `dt_s` (at `t = 0, dt, 2dt, …` from the
    /// first segment's start), starting at rest at the first input. Each
    /// segment's duration is rounded to whole `dt` (the caller picks `dt`
    /// dividing the pixel period, so picture steps are exact).
    pub fn trace(&self, segments: &[(f64, f64)], dt_s: f64) -> Vec<f64> {
        let step = self.step(dt_s, 1.0);
        let mut x = self.rest(segments.first().map_or(0.0, |s| s.1));
        let mut out = Vec::new();
        let mut t_end = 0.0f64;
        let mut n = 0usize;
        for &(dur, u) in segments {
            t_end += dur;
            let end = (t_end / dt_s).round() as usize;
            while n < end {
                out.push(x[0]);
                x = step.apply(x, u);
                n += 1;
            }
        }
        out.push(x[0]);
        out
    }
}

/// The digitizer's view of one line: the amplifier run over the pixel
/// staircase and sampled at phase `phase` of each pixel period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineSampler {
    pub amplifier: Amplifier,
    pub pixel_period_s: f64,
    /// Sampling instant within a pixel period, 0–1.
    pub phase: f64,
    /// Line-locked clock jitter, s rms (0 = none).
    pub jitter_s: f64,
    pixel: Step,
    to_sample: Step,
    a: [[f64; 2]; 2],
    b: [f64; 2],
}

impl LineSampler {
    pub fn new(amplifier: Amplifier, pixel_period_s: f64, phase: f64, jitter_s: f64) -> Self {
        let (a, b) = amplifier
            .kind
            .state_space(amplifier.bandwidth_hz, pixel_period_s);
        Self {
            amplifier,
            pixel_period_s,
            phase,
            jitter_s,
            pixel: amplifier.step(pixel_period_s, 1.0),
            to_sample: amplifier.step(pixel_period_s, phase),
            a,
            b,
        }
    }

    /// Pixel clock, Hz.
    pub fn pixel_clock_hz(&self) -> f64 {
        1.0 / self.pixel_period_s
    }

    /// Samples of the line whose held inputs are `u` (any affine unit: DN
    /// or volts), starting from rest at `rest` (the blanking level that
    /// precedes active video by several time constants). `jitter` gives
    /// one standard normal draw per sample when clock jitter is on.
    #[inline]
    pub fn sample_row(&self, rest: f64, u: &mut [f64], mut jitter: impl FnMut() -> f64) {
        let mut x = self.amplifier.rest(rest);
        let dj = self.jitter_s / self.pixel_period_s;
        let s = &self.to_sample;
        for v in u.iter_mut() {
            let ui = *v;
            let xs = s.apply(x, ui);
            let mut y = xs[0];
            if dj > 0.0 {
                // dy/dt (per pixel period) at the sample: C (A x + B u).
                let dydt = self.a[0][0] * xs[0] + self.a[0][1] * xs[1] + self.b[0] * ui;
                y += dj * jitter() * dydt;
            }
            x = self.pixel.apply(x, ui);
            *v = y;
        }
    }

    /// Fundamental of a sine pattern of `f` cycles/pixel on the line
    /// (oscilloscope): `|H(f/T)| · |sinc f|`.
    pub fn line_mtf(&self, f_cy_px: f64) -> f64 {
        line_mtf(&self.amplifier, self.pixel_period_s, f_cy_px)
    }

    /// Response at `f` cycles/pixel after sampling at this phase (with
    /// the mean jitter loss `exp(−2π² σ² ν²)`).
    pub fn sampled_mtf(&self, f_cy_px: f64) -> f64 {
        sampled_mtf(&self.amplifier, self.pixel_period_s, self.phase, f_cy_px)
            * jitter_mtf(self.jitter_s, f_cy_px / self.pixel_period_s)
    }
}

/// `|H(f/T)| · |sinc f|`: the fundamental of a held-step sine on the line.
pub fn line_mtf(amp: &Amplifier, pixel_period_s: f64, f_cy_px: f64) -> f64 {
    amp.kind
        .magnitude(amp.bandwidth_hz, f_cy_px / pixel_period_s)
        * sinc(f_cy_px).abs()
}

/// `|Σ_k H((f+k)/T) sinc(f+k) e^{−jπ(f+k)} e^{j2π(f+k)φ}|`, k = −400..400
/// (the terms fall as 1/k³ for the two-pole filter, 1/k² for one pole).
pub fn sampled_mtf(amp: &Amplifier, pixel_period_s: f64, phase: f64, f_cy_px: f64) -> f64 {
    let (mut re, mut im) = (0.0f64, 0.0f64);
    for k in -400i32..=400 {
        let nu = f_cy_px + f64::from(k);
        let (hr, hi) = amp.kind.response(amp.bandwidth_hz, nu / pixel_period_s);
        let s = sinc(nu);
        let ph = std::f64::consts::TAU * nu * (phase - 0.5);
        let (c, sn) = (ph.cos(), ph.sin());
        re += s * (hr * c - hi * sn);
        im += s * (hr * sn + hi * c);
    }
    re.hypot(im)
}

/// Mean loss of a sine of `nu_hz` sampled with Gaussian timing jitter σ:
/// `E[e^{j2πνδ}] = exp(−2π² σ² ν²)`.
pub fn jitter_mtf(jitter_s: f64, nu_hz: f64) -> f64 {
    (-2.0 * std::f64::consts::PI.powi(2) * (jitter_s * nu_hz).powi(2)).exp()
}

use super::Chain;
use super::video_timing::LineTiming;

impl Chain {
    /// The video output's line timing (None: direct digital readout).
    pub fn line_timing(&self) -> Option<LineTiming> {
        self.config.video.as_ref().map(|v| LineTiming::of(v.format))
    }

    /// The video amplifier when the video stage states a bandwidth.
    pub fn amplifier(&self) -> Option<Amplifier> {
        let v = self.config.video.as_ref()?;
        v.bandwidth_hz.map(|b| Amplifier {
            kind: v.bandwidth_filter,
            bandwidth_hz: b,
        })
    }

    /// The digitizer's line sampler for frames `columns` wide: the CCD's
    /// columns fill the active line, one sample per pixel period (a
    /// line-locked grabber). None without a band-limited video stage.
    pub fn line_sampler(&self, columns: usize) -> Option<LineSampler> {
        let amp = self.amplifier()?;
        let t = self.line_timing()?;
        let d = &self.config.digitizer;
        Some(LineSampler::new(
            amp,
            t.pixel_period_s(columns),
            d.sample_phase,
            d.clock_jitter_s,
        ))
    }

    /// Horizontal MTF of the digitised frame (`columns` wide) at `f`
    /// cycles/pixel: the stages' MTF × the sampled video line.
    pub fn mtf_horizontal(&self, f_cy_px: f64, g: f64, columns: usize) -> f64 {
        self.mtf(f_cy_px, g)
            * self
                .line_sampler(columns)
                .map_or(1.0, |l| l.sampled_mtf(f_cy_px))
    }

    /// MTF of the analogue line an oscilloscope shows (`columns` wide
    /// frames): the stages' MTF × `|H(ν)|` × the held steps' `|sinc f|`.
    /// None without a video stage.
    pub fn mtf_on_line(&self, f_cy_px: f64, g: f64, columns: usize) -> Option<f64> {
        let t = self.line_timing()?;
        let video = match self.amplifier() {
            Some(a) => line_mtf(&a, t.pixel_period_s(columns), f_cy_px),
            None => sinc(f_cy_px).abs(),
        };
        Some(self.mtf(f_cy_px, g) * video)
    }
}

/// `e^M` of a 3×3 matrix by scaling and squaring with an 18-term Taylor
/// series (‖M‖ ≤ ½ after scaling: truncation below 1e-20).
fn expm3(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let norm = m
        .iter()
        .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    let mut s = 0u32;
    while norm / f64::from(1u32 << s.min(30)) > 0.5 && s < 60 {
        s += 1;
    }
    let scale = 0.5f64.powi(s as i32);
    let a = m.map(|r| r.map(|v| v * scale));
    let mul = |x: &[[f64; 3]; 3], y: &[[f64; 3]; 3]| {
        let mut z = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                z[i][j] = (0..3).map(|k| x[i][k] * y[k][j]).sum();
            }
        }
        z
    };
    let mut term = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut sum = term;
    for k in 1..=18 {
        term = mul(&term, &a).map(|r| r.map(|v| v / f64::from(k)));
        for i in 0..3 {
            for j in 0..3 {
                sum[i][j] += term[i][j];
            }
        }
    }
    for _ in 0..s {
        sum = mul(&sum, &sum);
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    const BW: Amplifier = Amplifier {
        kind: FilterKind::Butterworth2,
        bandwidth_hz: 4.2e6,
    };

    #[test]
    fn minus_3_db_at_the_stated_frequency() {
        for kind in [FilterKind::Butterworth2, FilterKind::SinglePole] {
            let m = kind.magnitude(4.2e6, 4.2e6);
            assert!((m - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-12, "{m}");
        }
        // Butterworth: |H|² = 1/(1 + x⁴) at twice the corner: 1/17.
        let m = FilterKind::Butterworth2.magnitude(1.0, 2.0);
        assert!((m * m - 1.0 / 17.0).abs() < 1e-12);
    }

    #[test]
    fn step_response_matches_the_closed_form() {
        // Unit step into ω²/(s² + 2ζω s + ω²), ζ = 1/√2:
        // y(t) = 1 − e^{−ζωt} (cos ω_d t + ζ/√(1−ζ²) sin ω_d t), ω_d = ω√(1−ζ²).
        let dt = 5e-9;
        let y = BW.trace(&[(100e-9, 0.0), (2e-6, 1.0)], dt);
        let w = std::f64::consts::TAU * 4.2e6;
        let z = std::f64::consts::FRAC_1_SQRT_2;
        let wd = w * (1.0 - z * z).sqrt();
        for (n, &v) in y.iter().enumerate().skip(20) {
            let t = n as f64 * dt - 100e-9;
            let exact = 1.0
                - (-z * w * t).exp() * ((wd * t).cos() + z / (1.0 - z * z).sqrt() * (wd * t).sin());
            assert!((v - exact).abs() < 1e-9, "t {t}: {v} vs {exact}");
        }
        // 4.3 % overshoot of a 2-pole Butterworth: e^{−π ζ/√(1−ζ²)} = e^{−π}.
        let peak = y.iter().copied().fold(0.0, f64::max);
        assert!(
            (peak - 1.0 - (-std::f64::consts::PI).exp()).abs() < 1e-4,
            "{peak}"
        );
    }

    #[test]
    fn sampled_line_matches_the_aliasing_sum() {
        // A held sine of f cy/px through the amplifier, sampled at phase φ:
        // the fitted amplitude must equal the Poisson-sum transfer.
        let tp = 52.656e-6 / 640.0;
        for phase in [0.5, 0.9] {
            let s = LineSampler::new(BW, tp, phase, 0.0);
            for f in [0.05, 0.15, 0.25, 0.35, 0.45] {
                let n = 4096;
                let mut u: Vec<f64> = (0..n)
                    .map(|i| (std::f64::consts::TAU * f * i as f64).cos())
                    .collect();
                s.sample_row(1.0, &mut u, || 0.0);
                // Fit a cos + b sin after the start-up transient.
                let (mut cc, mut ss, mut cs, mut yc, mut ys) = (0.0, 0.0, 0.0, 0.0, 0.0);
                for (i, &y) in u.iter().enumerate().skip(200) {
                    let p = std::f64::consts::TAU * f * i as f64;
                    let (c, sn) = (p.cos(), p.sin());
                    cc += c * c;
                    ss += sn * sn;
                    cs += c * sn;
                    yc += y * c;
                    ys += y * sn;
                }
                let det = cc * ss - cs * cs;
                let a = (yc * ss - ys * cs) / det;
                let b = (ys * cc - yc * cs) / det;
                let got = a.hypot(b);
                let want = s.sampled_mtf(f);
                assert!(
                    (got - want).abs() < 2e-3,
                    "φ {phase} f {f}: {got} vs {want}"
                );
            }
        }
        // Without a band limit the held staircase is sampled back exactly.
        let wide = Amplifier {
            kind: FilterKind::Butterworth2,
            bandwidth_hz: 1e12,
        };
        assert!((sampled_mtf(&wide, tp, 0.3, 0.4) - 1.0).abs() < 2e-3);
        // Below the aliases the sampled response approaches |H| sinc × …:
        // at low frequency both are ≈ |H(ν)|.
        let f = 0.02;
        let s = LineSampler::new(BW, tp, 0.5, 0.0);
        assert!((s.sampled_mtf(f) - BW.kind.magnitude(4.2e6, f / tp)).abs() < 2e-3);
    }

    #[test]
    fn jitter_noise_grows_with_the_slope() {
        let tp = 50e-9;
        let s = LineSampler::new(BW, tp, 0.5, 2e-9);
        let mut flat = vec![1.0; 64];
        s.sample_row(1.0, &mut flat, || 1.0);
        // A flat line has no slope: jitter changes nothing.
        assert!(flat.iter().all(|v| (v - 1.0).abs() < 1e-12));
        let mut edge: Vec<f64> = (0..64).map(|i| if i < 32 { 0.0 } else { 1.0 }).collect();
        let mut still = edge.clone();
        s.sample_row(0.0, &mut edge, || 1.0);
        LineSampler::new(BW, tp, 0.5, 0.0).sample_row(0.0, &mut still, || 0.0);
        assert!((edge[32] - still[32]).abs() > 1e-3);
    }
}
