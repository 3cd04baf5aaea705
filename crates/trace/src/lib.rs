//! gloam's spectral ray tracer.
//!
//! [`render`] turns a [`gloam_scene::Scene`] into band radiance at the
//! camera's entrance pupil (W m⁻² sr⁻¹, band × row × column);
//! [`probe_point`] reports the irradiance at any point; [`Tracer`] keeps a
//! prepared scene for repeated queries. Every approximation is a named
//! setting in [`RenderSettings`] (see [`settings`] for the table of keys and
//! defaults). `closed_form` and `sampling` hold the exact irradiance formulas
//! and the solid-angle samplers the area-source estimators are built on.
//!
//! # Radiometry
//!
//! - Scene units are converted to metres only where a distance is squared
//!   against a physical quantity: point sources, `E = I cos^m(α) cos θ / R²`
//!   with `R` in metres. Area-source factors (∫ cos cos dω, `A/R²`) are
//!   dimensionless, and so are the Moon and the sky dome (directional: no
//!   distance, no `R²`; their irradiance is W m⁻² whatever the units).
//! - A Lambertian surface reflects `L = ρ_d E / π` with `ρ_d = (1 − s) ρ`;
//!   the specular part `s ρ` is followed by recursion (`recursion` = 1:
//!   direct light only; 2: one mirror bounce; …).
//! - Spectral values are carried at a continuum grid plus every emission line
//!   and integrated into the scene's bands at the end ([`spectral`]).
//!
//! # Point sources seen directly
//!
//! A point source in the field of view with a clear line of sight to the
//! camera deposits its flux into the pixel it projects to:
//! `L_pixel += I_s cos^m(α) τ / (R² Ω_pixel)`, with `R` the camera–lamp
//! distance in metres, `α` the angle between the lamp's axis and the
//! direction to the camera, `τ` the transmission of transmissive facets in
//! between and `Ω_pixel` the exact solid angle of that pixel (from its
//! corners on the image plane). Summed over the pixel's
//! solid angle this returns exactly the irradiance `I/R²` the lamp puts on
//! the entrance pupil. (Lamps seen in mirrors are not deposited.)
//!
//! # The night sky ([`sky_light`])
//!
//! Scenes with a `[sky]` block are lit by the Moon and the sky dome from
//! [`gloam_sky::SkyModel`] (instant from `utc`, site from latitude,
//! longitude and height, `visibility_km`, `overcast`), only as far as the
//! effect plan enables `moon` / `night-sky` / `atmosphere`. Scene axes are
//! +x east, +y north, +z up (the sky crate's ENU frame).
//!
//! - **Moon, direct**: a distant directional source along its apparent
//!   direction, `E(λ) = E_n(λ) cos θ τ(λ)` with `E_n` the direct lunar
//!   irradiance normal to the beam at the ground and one shadow ray to
//!   infinity (transmissive facets attenuate). Exact; hard shadows (the
//!   0.26° disk is ignored). Off when the Moon is down or overcast.
//! - **Sky dome**: `E(λ) = ∫ L(ω, λ) V(ω) τ (n·ω) dω` by `sky_samples`
//!   cosine-weighted directions (Latin-hypercube stratified) about the
//!   normal, each adding `π L(ω) τ / N` when its shadow ray escapes;
//!   directions below the horizon see no sky (and cast no ray). `L` is the
//!   single-scattered moonlight (or the overcast deck) plus the uniform
//!   starlight/airglow background, tabulated per wavelength on a 1.5° × 2.5°
//!   elevation × azimuth grid ([`sky_light::RadianceTable`]; a uniform dome
//!   is stored exactly).
//! - **Seen directly**: a camera or specular ray that escapes upward returns
//!   the dome's radiance in its direction (not after a diffuse bounce, whose
//!   vertex already sampled the dome). Rays escaping below the horizon read
//!   0 (there is no ground beyond the scene's geometry). The Moon's disk
//!   itself is not drawn, and it is not seen in mirrors.
//! - The sky has no emission lines: it fills the continuum slots only.
//!
//! [`Tracer::sky_probe`] reports the two terms separately at a point;
//! `RenderStats::sky` ([`SkySummary`]) records what was used.
//!
//! # Forcing every effect
//!
//! `all_effects = true` runs every estimator path even where the effect
//! plan says it is not needed, so a benchmark can show what the plan saves:
//! the area-source loops run (empty without emitters); the sky paths run
//! with a dark sky when the scene has none (moon shadow rays towards the
//! Moon's geometric direction or the zenith carrying zero, dome samples of
//! a zero dome); specular recursion goes to `recursion` on every hit with
//! zero weight where a material has no specular part; next-event
//! estimation runs on every hit, with zero albedo where a material has no
//! diffuse part; every shadow ray builds its spectral transmission vector.
//! All the extra terms are exact zeros, so the image agrees with the
//! planned render within noise (the extra paths draw random numbers, so it
//! is not bit-identical where light is sampled).
//!
//! # Area sources: three estimators
//!
//! - `analytic` (default): the exact unoccluded irradiance from the closed
//!   form (Lambert's polygon formula, Arvo's double-axis moments for integer
//!   m > 0), corrected for occlusion with `area_samples` shadow rays as a
//!   control variate: `E = E_closed + (MC_occluded − MC_unoccluded)` with the
//!   same solid-angle samples, under the occlusion rule below. Sources are
//!   never dropped: a source whose closed-form share of the irradiance at the
//!   hit point is below `source_roulette_fraction` gets proportionally fewer
//!   shadow rays, `⌈area_samples · share / fraction⌉` but at least one; the
//!   correction is unbiased for any number of samples, so this only trades
//!   variance of dim sources for time. A non-integer shape exponent has no
//!   closed form here; such sources fall back to the `solid-angle` estimator
//!   (unbiased), rather than rounding m.
//!
//!   **Occlusion rule** (per source, hit point and wavelength slot):
//!   * every shadow ray clear and unattenuated → exactly `E_closed` (the
//!     correction cancels bit for bit);
//!   * every shadow ray blocked (or transmission 0 at that wavelength) →
//!     exactly 0, not `E_closed − MC_unoccluded` (which is 0 only on average);
//!   * otherwise the control variate, unbiased.
//!
//!   The second case biases penumbra where all N samples happen to miss the
//!   visible part: the bias is `−P(all blocked) · (E_closed − E[MC_unocc |
//!   all blocked])`, which vanishes when the sample weights `cos θ_r
//!   cos^m θ_e Ω` are uniform over the source (small or distant sources),
//!   and falls with N as `P(all blocked)` does (≈ (1 − v)^N for a visible
//!   solid-angle fraction v). It is deterministic in sign and size for a
//!   given geometry (not noise), and zero outside penumbra. Finally the sum
//!   of all area sources at a hit point is clamped at 0 per wavelength:
//!   irradiance cannot be negative, and an unclamped control variate can
//!   undershoot in deep penumbra (a sliver visible, `MC_unocc` above
//!   `E_closed`). Clamping the *sum* at the hit point, rather than each
//!   source or the pixel, is the least biased place that still makes every
//!   reflected radiance, hence every pixel, non-negative (negative pieces of
//!   one source are still offset by the others); its bias is
//!   `E[max(0, −X)]`, non-zero only where the estimate X could go
//!   negative. `occlusion=ratio` (`E = E_closed · MC_occ / MC_unocc`) is
//!   the alternative: exact at both extremes and behind a uniform
//!   transmitter, O(1/N) bias everywhere in penumbra.
//! - `solid-angle`: `area_samples` directions uniform in the solid angle the
//!   facet subtends (spherical rectangles, Ureña et al. 2013, for true
//!   rectangles; spherical triangles, Arvo 1995, otherwise, a quad being two
//!   triangles picked by solid angle), weight `Ω cos^m θ_e cos θ_r / N`. It
//!   falls back to uniform area sampling (weight `A cos θ_e / R²`) where the
//!   samplers decline (solid angle below 1e-6 sr, degenerate input) or the
//!   point lies within 1e-10·√A of the emitter's plane.
//! - `dirsig2001`: the published 2001 method, faithfully: M = area ×
//!   SAMPLE_AREA_DENSITY points per source (1 … MAX_SAMPLE_POINTS, drawn
//!   once per render from the seed); at each hit point the solid angle is
//!   estimated from the angles φ the sides subtend (quad:
//!   `((φ1+φ3)/2)((φ2+φ4)/2)`, triangle: `φ_min φ_max / 2`); the source is
//!   skipped below SOLID_ANGLE_THRESHOLD or when `L Ω cos θ_c cos^m α` is
//!   below IRRADIANCE_THRESHOLD; otherwise N = ⌈Ω × SOLID_ANGLE_DENSITY⌉
//!   (≤ MAX_SOURCE_SAMPLES) shadow rays go to points drawn from the M set and
//!   `E = cos^m(α) (1/N) Σ L cos²θ_j A / R_j² τ_j`, θ_j the angle at the
//!   receiver (the published cos² stands for cos θ_r cos θ_e, equal only when
//!   source and receiver are parallel).
//!
//! **Shaping, 2001 vs gloam.** The 2001 equation evaluates `cos^m(α)` once
//! per source and hit point, with α measured at the source's centre, and
//! multiplies the whole source by it. gloam's estimators shape every surface
//! element: radiance `L cos^m(θ_e)` with θ_e the emission angle of each
//! sampled point, which is what Arvo's closed form integrates. The two agree
//! when the source is small seen from the hit point (or m = 0) and differ
//! most for large sources, large m and hit points close to the source: there
//! the 2001 shaping over-weights the parts of the source seen at steeper
//! angles than its centre and under-weights the rest.

pub mod closed_form;
pub mod geometry;
pub mod indirect;
pub mod plan;
pub mod render;
pub mod sampling;
pub mod settings;
pub mod sky_light;
pub mod spectral;
pub mod tracer;

pub use glam::DVec3;
pub use render::{ProbeResult, RenderOutput, RenderStats, probe_point, render};
pub use settings::{
    Dirsig2001Settings, Estimator, Indirect, Occlusion, RenderSettings, SettingsError,
};
pub use sky_light::SkySummary;
pub use tracer::{RayCounts, SkyProbeResult, TraceError, Tracer};
