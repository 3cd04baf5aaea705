//! Night-sky lighting for the tracer: the Moon as a distant directional
//! source with shadows, and the sky dome's diffuse irradiance with occlusion,
//! both on the renderer's wavelength grid and built on
//! [`gloam_sky::SkyModel`].
//!
//! # Frames
//!
//! gloam_sky works in the local **east-north-up** (ENU) frame of the site.
//! Outdoor scenes use the same axes: **scene +x = east, +y = north,
//! +z = up** (a scene's `[sky]` block fixes where and when; its geometry is
//! laid out in this frame). [`enu_to_scene`] and [`scene_to_enu`] are
//! therefore identities, kept as the one place to change should scenes ever
//! carry a heading. Scene units do not matter here: only directions are
//! exchanged.
//!
//! # What is computed
//!
//! * **Moon, direct** ([`SkyLight::moon_irradiance_w_m2_nm`]): the Moon is
//!   a point at infinity in the direction of its apparent (refracted)
//!   position. At a surface point with unit normal `n` the spectral
//!   irradiance is `E(λ) = E_n(λ) max(0, n·d)` when the shadow ray towards
//!   `d` is unoccluded, where `E_n(λ)` is the direct lunar irradiance at the
//!   ground normal to the beam (exo-atmospheric lunar irradiance × direct
//!   transmittance along the Moon's slant path). The lunar disk's 0.26°
//!   semi-diameter is ignored, so shadows are hard (the penumbra of a 10 m
//!   tall pole is ≈ 5 cm wide). Zero when the Moon is down, the sky is
//!   overcast, or the moon term is switched off.
//! * **Sky dome, diffuse** ([`SkyLight::sky_irradiance_w_m2_nm`]):
//!   `E(λ) = ∫_{n·ω>0} L(ω, λ) V(ω) (n·ω) dω`, with `L` the dome radiance
//!   from [`gloam_sky::SkyModel::sky_radiance_w_m2_sr_nm`] (single-scattered
//!   moonlight, or the overcast deck, plus the uniform starlight/airglow
//!   background) and `V` the caller's visibility. It is estimated by
//!   cosine-weighted hemisphere sampling about `n`: with `p(ω) = (n·ω)/π`
//!   every sample contributes `π L(ω) V(ω)`, so an unoccluded uniform dome
//!   seen by a horizontal surface is exact with any number of samples
//!   (`E = π L`) and the estimator's variance comes only from the sky's
//!   anisotropy and from occlusion. Directions at or below the horizon carry
//!   no sky radiance (light reflected by the ground is the tracer's
//!   recursion, not the sky's) and cost no shadow ray.
//!
//! The [`SkyTerms`] flags mirror the scene's `[sky]` block: `moon = false`
//! removes both the direct Moon and the moonlight scattered by the sky (or
//! passed by the cloud deck); `night_sky = false` removes the starlight and
//! airglow background.
//!
//! # Use
//!
//! Build one [`SkyLight`] per render (it pre-interpolates the spectra onto
//! the render grid), then per hit point call the two estimators with a
//! shadow-ray closure. `occluded(dir)` receives the unit direction from the
//! hit point towards the light, in scene coordinates; the caller offsets the
//! ray origin and casts to infinity.
//!
//! ```ignore
//! let sky = gloam_sky::SkyModel::new(instant, &site, &conditions)?;
//! let light = SkyLight::new(&sky, &band_wavelengths_nm, SkyTerms { moon: true, night_sky: true });
//! let e_moon = light.moon_irradiance_w_m2_nm(n, |d| bvh.occluded(p + eps * n, d));
//! let e_sky = light.sky_irradiance_w_m2_nm(n, 16, || [rng.random(), rng.random()],
//!                                           |d| bvh.occluded(p + eps * n, d));
//! ```

use glam::DVec3;
use gloam_sky::SkyModel;
use gloam_sky::spectral::interpolate;

const PI: f64 = std::f64::consts::PI;

/// An east-north-up vector in scene coordinates (scene +x = east,
/// +y = north, +z = up): the identity.
pub fn enu_to_scene(v: [f64; 3]) -> DVec3 {
    DVec3::new(v[0], v[1], v[2])
}

/// A scene direction as east-north-up (the inverse of [`enu_to_scene`]).
pub fn scene_to_enu(v: DVec3) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// Which sky terms a render includes (the scene's `[sky]` `moon` and
/// `night_sky` flags).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SkyTerms {
    /// Direct moonlight and moonlight scattered by the sky / passed by cloud.
    pub moon: bool,
    /// The starlight + airglow background.
    pub night_sky: bool,
}

impl Default for SkyTerms {
    fn default() -> Self {
        Self {
            moon: true,
            night_sky: true,
        }
    }
}

/// A Monte Carlo estimate per wavelength: the mean and its standard error
/// (the sample standard deviation / √n), both W m⁻² nm⁻¹.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyIrradiance {
    /// Estimated irradiance on the render grid, W m⁻² nm⁻¹.
    pub value_w_m2_nm: Vec<f64>,
    /// Standard error of each value; `f64::INFINITY` with fewer than two
    /// samples, 0 where every sample agreed (e.g. an unoccluded uniform dome
    /// on a horizontal surface).
    pub std_error_w_m2_nm: Vec<f64>,
    /// Samples drawn.
    pub n_samples: usize,
    /// Samples above the horizon for which `occluded` was called.
    pub n_shadow_rays: usize,
}

/// The Moon and sky dome of one [`SkyModel`], on a render's wavelength grid.
#[derive(Clone, Debug)]
pub struct SkyLight {
    model: SkyModel,
    terms: SkyTerms,
    wavelengths_nm: Vec<f64>,
    /// Unit direction to the Moon (scene frame) when its direct beam lights
    /// the scene.
    moon_direction: Option<DVec3>,
    /// Direct lunar irradiance normal to the beam at the ground.
    moon_normal_w_m2_nm: Vec<f64>,
    /// Uniform night-sky background radiance (0 when switched off).
    night_radiance_w_m2_sr_nm: Vec<f64>,
    /// Night-sky radiance as the model includes it in `sky_radiance`
    /// (subtracted to isolate the moonlit part).
    model_night_radiance_w_m2_sr_nm: Vec<f64>,
    any_moon_sky: bool,
}

impl SkyLight {
    /// Pre-interpolates the model's spectra onto `wavelengths_nm` (any
    /// order; values outside 300–1100 nm are 0).
    pub fn new(model: &SkyModel, wavelengths_nm: &[f64], terms: SkyTerms) -> Self {
        let direct = model.moon_direct_normal_w_m2_nm();
        let moon_direction = (terms.moon && model.moon_direct_visible())
            .then(|| enu_to_scene(model.moon_direction_enu()).normalize_or_zero())
            .filter(|d| d.z > 0.0);
        let moon_normal_w_m2_nm = wavelengths_nm
            .iter()
            .map(|&w| {
                if moon_direction.is_some() {
                    interpolate(&direct, w).max(0.0)
                } else {
                    0.0
                }
            })
            .collect();
        // The model's night-sky radiance is uniform: its horizontal
        // irradiance over π.
        let night = model.ground_spectra().night_sky_horizontal_w_m2_nm;
        let model_night: Vec<f64> = wavelengths_nm
            .iter()
            .map(|&w| interpolate(&night, w) / PI)
            .collect();
        let night_radiance_w_m2_sr_nm = model_night
            .iter()
            .map(|&l| if terms.night_sky { l } else { 0.0 })
            .collect();
        Self {
            model: model.clone(),
            terms,
            wavelengths_nm: wavelengths_nm.to_vec(),
            moon_direction,
            moon_normal_w_m2_nm,
            night_radiance_w_m2_sr_nm,
            model_night_radiance_w_m2_sr_nm: model_night,
            any_moon_sky: terms.moon && model.moon_up(),
        }
    }

    /// The render's wavelength grid, nm.
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// The terms included.
    pub fn terms(&self) -> SkyTerms {
        self.terms
    }

    /// The underlying sky model.
    pub fn model(&self) -> &SkyModel {
        &self.model
    }

    /// Unit vector towards the Moon in scene coordinates when its direct
    /// beam lights the scene (Moon up, clear sky, moon term on); `None`
    /// otherwise, in which case no shadow rays towards it are needed.
    pub fn moon_direction(&self) -> Option<DVec3> {
        self.moon_direction
    }

    /// Direct lunar spectral irradiance on a surface normal to the beam at
    /// the ground, W m⁻² nm⁻¹ (all zero when [`Self::moon_direction`] is
    /// `None`).
    pub fn moon_normal_irradiance_w_m2_nm(&self) -> &[f64] {
        &self.moon_normal_w_m2_nm
    }

    /// Direct moonlight on a surface with unit normal `normal` (scene
    /// frame): `E_n(λ) max(0, n·d)`, or zero when `occluded(d)` is true.
    /// `occluded` is called at most once, and only when the Moon lights the
    /// front of the surface.
    pub fn moon_irradiance_w_m2_nm(
        &self,
        normal: DVec3,
        occluded: impl FnOnce(DVec3) -> bool,
    ) -> Vec<f64> {
        let mut out = vec![0.0; self.wavelengths_nm.len()];
        self.moon_irradiance_into(normal, occluded, &mut out);
        out
    }

    /// [`Self::moon_irradiance_w_m2_nm`] into `out` (overwritten; its length
    /// must equal the grid's). Returns the cosine factor used (0 when dark).
    pub fn moon_irradiance_into(
        &self,
        normal: DVec3,
        occluded: impl FnOnce(DVec3) -> bool,
        out: &mut [f64],
    ) -> f64 {
        assert_eq!(out.len(), self.wavelengths_nm.len(), "output length");
        out.fill(0.0);
        let Some(d) = self.moon_direction else {
            return 0.0;
        };
        let n = normal.normalize_or_zero();
        let cos = n.dot(d);
        if cos.is_nan() || cos <= 0.0 || occluded(d) {
            return 0.0;
        }
        for (o, &e) in out.iter_mut().zip(&self.moon_normal_w_m2_nm) {
            *o = e * cos;
        }
        cos
    }

    /// Sky-dome spectral radiance looking along `direction` (scene frame,
    /// need not be normalised), W m⁻² sr⁻¹ nm⁻¹, with the [`SkyTerms`]
    /// applied; 0 at or below the horizon.
    pub fn sky_radiance_w_m2_sr_nm(&self, direction: DVec3) -> Vec<f64> {
        let mut out = vec![0.0; self.wavelengths_nm.len()];
        self.sky_radiance_into(direction, &mut out);
        out
    }

    /// [`Self::sky_radiance_w_m2_sr_nm`] into `out` (overwritten).
    pub fn sky_radiance_into(&self, direction: DVec3, out: &mut [f64]) {
        assert_eq!(out.len(), self.wavelengths_nm.len(), "output length");
        let dir = direction.normalize_or_zero();
        if dir.z <= 0.0 {
            out.fill(0.0);
            return;
        }
        let enu = scene_to_enu(dir);
        for (i, o) in out.iter_mut().enumerate() {
            let mut l = self.night_radiance_w_m2_sr_nm[i];
            if self.any_moon_sky {
                let w = self.wavelengths_nm[i];
                let total = self.model.sky_radiance_w_m2_sr_nm(enu, w);
                l += (total - self.model_night_radiance_w_m2_sr_nm[i]).max(0.0);
            }
            *o = l;
        }
    }

    /// Diffuse sky irradiance on a surface with unit normal `normal` (scene
    /// frame), with occlusion, by `n_samples` cosine-weighted directions
    /// about the normal. `next_u` supplies the two uniform variates in
    /// [0, 1) of each sample (from the caller's seeded RNG, possibly
    /// stratified); `occluded(dir)` is the shadow-ray test, called only for
    /// sample directions above the horizon. Deterministic for a given
    /// sequence of variates.
    pub fn sky_irradiance_w_m2_nm(
        &self,
        normal: DVec3,
        n_samples: usize,
        mut next_u: impl FnMut() -> [f64; 2],
        mut occluded: impl FnMut(DVec3) -> bool,
    ) -> SkyIrradiance {
        let nw = self.wavelengths_nm.len();
        // Welford's running mean and sum of squared deviations per
        // wavelength (exact zero variance for identical samples).
        let mut mean = vec![0.0f64; nw];
        let mut m2 = vec![0.0f64; nw];
        let mut l = vec![0.0f64; nw];
        let mut shadow_rays = 0usize;
        let n = normal.normalize_or_zero();
        let basis = (n != DVec3::ZERO && n.is_finite()).then(|| orthonormal_basis(n));
        for k in 1..=n_samples {
            let mut lit = false;
            if let Some((t, b)) = basis {
                let local = cosine_hemisphere(next_u());
                let dir = (t * local.x + b * local.y + n * local.z).normalize_or_zero();
                // below the horizon there is no sky radiance (and no ray)
                if dir.z > 0.0 {
                    shadow_rays += 1;
                    if !occluded(dir) {
                        self.sky_radiance_into(dir, &mut l);
                        lit = true;
                    }
                }
            }
            let kf = k as f64;
            for i in 0..nw {
                let x = if lit { PI * l[i] } else { 0.0 };
                let delta = x - mean[i];
                mean[i] += delta / kf;
                m2[i] += delta * (x - mean[i]);
            }
        }
        let nf = n_samples as f64;
        let err: Vec<f64> = m2
            .iter()
            .map(|&m| {
                if n_samples > 1 {
                    (m.max(0.0) / (nf - 1.0) / nf).sqrt()
                } else {
                    f64::INFINITY
                }
            })
            .collect();
        let value = mean;
        SkyIrradiance {
            value_w_m2_nm: value,
            std_error_w_m2_nm: err,
            n_samples,
            n_shadow_rays: shadow_rays,
        }
    }

    /// The uniform night-sky background's closed form for an unoccluded
    /// surface of tilt `β` from horizontal: `π L (1 + cos β)/2` (the dome
    /// above the horizon that the surface sees). Exact for the background
    /// alone; a reference for tests and for quick estimates.
    pub fn night_sky_irradiance_unoccluded_w_m2_nm(&self, normal: DVec3) -> Vec<f64> {
        let n = normal.normalize_or_zero();
        let view = (1.0 + n.z.clamp(-1.0, 1.0)) / 2.0;
        let view = if n == DVec3::ZERO { 0.0 } else { view };
        self.night_radiance_w_m2_sr_nm
            .iter()
            .map(|&l| PI * l * view)
            .collect()
    }
}

/// The sky dome's radiance tabulated for the renderer: per wavelength on an
/// elevation × azimuth grid (cell centres, [`RadianceTable::ELEVATION_STEP_DEG`]
/// by [`RadianceTable::AZIMUTH_STEP_DEG`]), bilinear in between, nearest
/// row outside the first and last elevation rows. A uniform dome (no
/// moonlit sky: new moon, moon term off) is stored as one value per
/// wavelength and returned exactly. Evaluating the single-scattering model
/// per sample and wavelength would cost ~100× more than the lookup; the
/// table's interpolation error is below 0.2 % of the dome's horizontal
/// irradiance (the test `moonlit_table_integrates_like_the_model`).
#[derive(Clone, Debug)]
pub struct RadianceTable {
    nw: usize,
    n_el: usize,
    n_az: usize,
    /// `[(i_el · n_az + i_az) · nw + k]`, or `nw` values when uniform.
    values: Vec<f64>,
    uniform: bool,
}

impl RadianceTable {
    /// Elevation step, degrees.
    pub const ELEVATION_STEP_DEG: f64 = 1.5;
    /// Azimuth step, degrees.
    pub const AZIMUTH_STEP_DEG: f64 = 2.5;

    /// Tabulates `light`'s [`SkyLight::sky_radiance_into`].
    pub fn new(light: &SkyLight) -> Self {
        let nw = light.wavelengths_nm.len();
        if !light.any_moon_sky {
            return Self::uniform(light.night_radiance_w_m2_sr_nm.clone());
        }
        Self::tabulate(nw, |d, out| light.sky_radiance_into(d, out))
    }

    /// Tabulates `radiance(dir, out)` (scene frame, `nw` values) at the
    /// cells' centres, rows in parallel (the twilight sky takes ~0.3 ms a
    /// direction).
    pub(crate) fn tabulate(nw: usize, radiance: impl Fn(DVec3, &mut [f64]) + Sync) -> Self {
        use rayon::prelude::*;
        let n_el = (90.0 / Self::ELEVATION_STEP_DEG).round() as usize;
        let n_az = (360.0 / Self::AZIMUTH_STEP_DEG).round() as usize;
        let mut values = vec![0.0; n_el * n_az * nw];
        values
            .par_chunks_mut((n_az * nw).max(1))
            .enumerate()
            .for_each(|(i, row)| {
                let el = ((i as f64 + 0.5) * Self::ELEVATION_STEP_DEG).to_radians();
                for (j, cell) in row.chunks_mut(nw.max(1)).enumerate() {
                    let az = ((j as f64 + 0.5) * Self::AZIMUTH_STEP_DEG).to_radians();
                    let d = DVec3::new(el.cos() * az.sin(), el.cos() * az.cos(), el.sin());
                    radiance(d, cell);
                }
            });
        Self {
            nw,
            n_el,
            n_az,
            values,
            uniform: false,
        }
    }

    /// A dome of one radiance in every direction above the horizon.
    pub(crate) fn uniform(values: Vec<f64>) -> Self {
        Self {
            nw: values.len(),
            n_el: 1,
            n_az: 1,
            values,
            uniform: true,
        }
    }

    /// True when the dome is uniform (one radiance for every direction).
    pub fn is_uniform(&self) -> bool {
        self.uniform
    }

    /// Radiance looking along unit `dir` (scene frame) into `out`
    /// (overwritten, one value per wavelength); 0 at or below the horizon.
    pub fn radiance_into(&self, dir: DVec3, out: &mut [f64]) {
        let out = &mut out[..self.nw];
        if dir.z.is_nan() || dir.z <= 0.0 {
            out.fill(0.0);
            return;
        }
        if self.uniform {
            out.copy_from_slice(&self.values);
            return;
        }
        let el = dir.z.clamp(-1.0, 1.0).asin().to_degrees();
        let az = dir.x.atan2(dir.y).to_degrees().rem_euclid(360.0);
        let fe = (el / Self::ELEVATION_STEP_DEG - 0.5).clamp(0.0, (self.n_el - 1) as f64);
        let i0 = (fe.floor() as usize).min(self.n_el - 1);
        let i1 = (i0 + 1).min(self.n_el - 1);
        let te = fe - i0 as f64;
        let fa = (az / Self::AZIMUTH_STEP_DEG - 0.5).rem_euclid(self.n_az as f64);
        let j0 = (fa.floor() as usize) % self.n_az;
        let j1 = (j0 + 1) % self.n_az;
        let ta = fa - fa.floor();
        let w = [
            (1.0 - te) * (1.0 - ta),
            (1.0 - te) * ta,
            te * (1.0 - ta),
            te * ta,
        ];
        let nw = self.nw;
        let rows = [
            (i0 * self.n_az + j0) * nw,
            (i0 * self.n_az + j1) * nw,
            (i1 * self.n_az + j0) * nw,
            (i1 * self.n_az + j1) * nw,
        ];
        for (k, o) in out.iter_mut().enumerate() {
            *o = w[0] * self.values[rows[0] + k]
                + w[1] * self.values[rows[1] + k]
                + w[2] * self.values[rows[2] + k]
                + w[3] * self.values[rows[3] + k];
        }
    }
}

/// What a render took from the `[sky]` block (in [`crate::RenderStats`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SkySummary {
    /// The instant, ISO 8601 UTC (`None` when the scene has no `[sky]`
    /// block and only `all_effects` made the sky paths run, dark).
    pub utc: Option<String>,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub height_m: f64,
    pub visibility_km: f64,
    pub overcast: bool,
    /// The terms included (from the effect plan's `moon` / `night-sky`).
    pub moon_term: bool,
    pub night_sky_term: bool,
    /// Apparent Moon elevation and azimuth (north through east), degrees.
    pub moon_elevation_deg: f64,
    pub moon_azimuth_deg: f64,
    pub moon_illuminated_fraction: f64,
    /// True when the direct Moon lights the scene (up, clear, term on).
    pub moon_direct: bool,
    /// Unit vector to the Moon in scene coordinates (+x east, +y north, +z up).
    pub moon_direction: [f64; 3],
    /// Cosine-weighted dome samples per hit point.
    pub sky_samples: u32,
    /// Whether the dome is uniform (no moonlit sky).
    pub uniform_dome: bool,
    /// The Sun's geometric elevation and azimuth, degrees.
    pub sun_elevation_deg: f64,
    pub sun_azimuth_deg: f64,
    /// Whether the Sun's direct beam lights the scene (up, clear, term on).
    pub sun_direct: bool,
    /// Whether the twilight sky (sunlight scattered by the sky, Sun at or
    /// above −18°) lights the scene.
    pub twilight_sky: bool,
}

/// Cosine-weighted direction on the +z hemisphere from two variates in
/// [0, 1) (Malley's method: uniform on the disk, projected up). Non-finite
/// variates are replaced by 0.5; others are clamped to [0, 1].
pub fn cosine_hemisphere(u: [f64; 2]) -> DVec3 {
    let f = |x: f64| {
        if x.is_finite() {
            x.clamp(0.0, 1.0)
        } else {
            0.5
        }
    };
    let (u1, u2) = (f(u[0]), f(u[1]));
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt())
}

/// Tangent and bitangent completing a right-handed frame with the unit
/// vector `n` (Duff et al. 2017, "Building an orthonormal basis, revisited").
pub fn orthonormal_basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // parallel per-wavelength arrays
mod tests {
    use super::*;
    use gloam_sky::{Cloud, Site, SkyConditions, UtcInstant};

    /// RIT, Rochester NY, the site of the sims/night-* scenes.
    fn model(utc: &str, cloud: Cloud) -> SkyModel {
        let site = Site::new(43.0844, -77.6749, 170.0).unwrap();
        let c = SkyConditions::new(23.0, cloud).unwrap();
        SkyModel::new(UtcInstant::parse_iso8601(utc).unwrap(), &site, &c).unwrap()
    }
    const FULL: &str = "2025-10-07T05:00:00Z";
    const HALF: &str = "2025-10-13T08:30:00Z";
    const NEW: &str = "2025-10-22T04:00:00Z";

    fn grid() -> Vec<f64> {
        vec![405.0, 450.0, 557.7, 600.0, 632.5, 700.0, 850.0, 1000.0]
    }

    /// splitmix64 → [0, 1): a dependency-free, seeded variate stream.
    fn variates(seed: u64) -> impl FnMut() -> [f64; 2] {
        let mut s = seed;
        let mut next = move || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        move || [next(), next()]
    }

    fn tilted(beta_deg: f64, azimuth_deg: f64) -> DVec3 {
        let (sb, cb) = beta_deg.to_radians().sin_cos();
        let (sa, ca) = azimuth_deg.to_radians().sin_cos();
        DVec3::new(sb * sa, sb * ca, cb)
    }

    #[test]
    fn frames_are_enu() {
        let v = [0.3, -0.4, 0.5];
        assert_eq!(scene_to_enu(enu_to_scene(v)), v);
        let m = model(FULL, Cloud::Clear);
        let l = SkyLight::new(&m, &grid(), SkyTerms::default());
        let d = l.moon_direction().unwrap();
        let e = m.moon_direction_enu();
        assert!((d - DVec3::from_array(e)).length() < 1e-12);
        // the full moon of the scenario is due south, 54° up
        assert!(d.y < -0.5 && d.x.abs() < 0.05 && (d.z - 54.37f64.to_radians().sin()).abs() < 1e-3);
    }

    #[test]
    fn uniform_dome_on_a_horizontal_surface_is_exactly_pi_l() {
        // new moon: the Moon is 60° below the horizon, so the dome is the
        // uniform night-sky background alone
        let m = model(NEW, Cloud::Clear);
        let l = SkyLight::new(&m, &grid(), SkyTerms::default());
        assert!(l.moon_direction().is_none());
        let want = l.night_sky_irradiance_unoccluded_w_m2_nm(DVec3::Z);
        let got = l.sky_irradiance_w_m2_nm(DVec3::Z, 64, variates(1), |_| false);
        for i in 0..grid().len() {
            let rad = l.sky_radiance_w_m2_sr_nm(DVec3::new(0.2, 0.3, 0.9))[i];
            assert!((want[i] - PI * rad).abs() <= 1e-15 * want[i].max(1e-300));
            assert!(
                (got.value_w_m2_nm[i] - want[i]).abs() <= 1e-12 * want[i],
                "{} vs {}",
                got.value_w_m2_nm[i],
                want[i]
            );
            assert!(got.std_error_w_m2_nm[i] <= 1e-12 * want[i]);
            assert!(want[i] > 0.0);
        }
        assert_eq!(got.n_shadow_rays, 64);
        // and it is the model's own horizontal night-sky term
        let s = m.ground_spectra();
        let e600 = interpolate(&s.night_sky_horizontal_w_m2_nm, 600.0);
        assert!((want[3] / e600 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn tilted_and_half_occluded_uniform_dome() {
        let m = model(NEW, Cloud::Clear);
        let l = SkyLight::new(&m, &grid(), SkyTerms::default());
        let n = 40_000;
        for beta in [30.0, 60.0, 90.0, 120.0] {
            let nrm = tilted(beta, 200.0);
            let want = l.night_sky_irradiance_unoccluded_w_m2_nm(nrm);
            let got = l.sky_irradiance_w_m2_nm(nrm, n, variates(beta as u64), |_| false);
            let expect = PI * (1.0 + beta.to_radians().cos()) / 2.0;
            assert!(
                (want[3] / (PI * l.sky_radiance_w_m2_sr_nm(DVec3::Z)[3]) - expect / PI).abs()
                    < 1e-12
            );
            for i in 0..grid().len() {
                let (v, e) = (got.value_w_m2_nm[i], got.std_error_w_m2_nm[i]);
                assert!(e > 0.0 && e < 0.02 * want[i], "β {beta}: σ {e}");
                assert!(
                    (v - want[i]).abs() < 4.0 * e,
                    "β {beta}: {v} vs {} ± {e}",
                    want[i]
                );
            }
        }
        // horizontal, with everything east of the point blocked: half the dome
        let want = l.night_sky_irradiance_unoccluded_w_m2_nm(DVec3::Z);
        let got = l.sky_irradiance_w_m2_nm(DVec3::Z, n, variates(7), |d| d.x > 0.0);
        for i in 0..grid().len() {
            let (v, e) = (got.value_w_m2_nm[i], got.std_error_w_m2_nm[i]);
            assert!(
                (v - 0.5 * want[i]).abs() < 4.0 * e,
                "{v} vs {} ± {e}",
                0.5 * want[i]
            );
        }
        // fully enclosed: nothing
        let got = l.sky_irradiance_w_m2_nm(DVec3::Z, 100, variates(8), |_| true);
        assert!(got.value_w_m2_nm.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn moonlit_sky_integrates_to_the_models_diffuse_irradiance() {
        for utc in [FULL, HALF] {
            let m = model(utc, Cloud::Clear);
            let l = SkyLight::new(&m, &grid(), SkyTerms::default());
            let got = l.sky_irradiance_w_m2_nm(DVec3::Z, 100_000, variates(11), |_| false);
            let s = m.ground_spectra();
            for (i, &w) in grid().iter().enumerate() {
                let want = interpolate(&s.moon_sky_horizontal_w_m2_nm, w)
                    + interpolate(&s.night_sky_horizontal_w_m2_nm, w);
                let (v, e) = (got.value_w_m2_nm[i], got.std_error_w_m2_nm[i]);
                // the model's own dome quadrature differs by < 0.3 %
                assert!(
                    (v - want).abs() < 4.0 * e + 3e-3 * want,
                    "{utc} {w} nm: {v} vs {want} ± {e}"
                );
            }
        }
        // moon term off: only the uniform background remains
        let m = model(FULL, Cloud::Clear);
        let l = SkyLight::new(
            &m,
            &grid(),
            SkyTerms {
                moon: false,
                night_sky: true,
            },
        );
        assert!(l.moon_direction().is_none());
        let a = l.sky_radiance_w_m2_sr_nm(DVec3::new(0.0, -1.0, 1.0));
        let b = l.sky_radiance_w_m2_sr_nm(DVec3::new(1.0, 1.0, 0.2));
        assert_eq!(a, b);
        // night sky off and moon off: a black sky
        let l = SkyLight::new(
            &m,
            &grid(),
            SkyTerms {
                moon: false,
                night_sky: false,
            },
        );
        assert!(
            l.sky_radiance_w_m2_sr_nm(DVec3::Z)
                .iter()
                .all(|&v| v == 0.0)
        );
    }

    #[test]
    fn moon_direct_is_normal_irradiance_times_cosine() {
        let m = model(FULL, Cloud::Clear);
        let l = SkyLight::new(&m, &grid(), SkyTerms::default());
        let d = l.moon_direction().unwrap();
        let en = l.moon_normal_irradiance_w_m2_nm().to_vec();
        let direct = m.moon_direct_normal_w_m2_nm();
        for (i, &w) in grid().iter().enumerate() {
            assert!((en[i] - interpolate(&direct, w)).abs() <= 1e-15 * en[i]);
            assert!(en[i] > 0.0);
        }
        for nrm in [
            DVec3::Z,
            d,
            tilted(45.0, 180.0),
            tilted(90.0, 180.0),
            tilted(80.0, 90.0),
        ] {
            let cos = nrm.dot(d);
            let mut calls = 0;
            let e = l.moon_irradiance_w_m2_nm(nrm, |_| {
                calls += 1;
                false
            });
            assert_eq!(calls, usize::from(cos > 0.0));
            for i in 0..en.len() {
                assert!((e[i] - en[i] * cos.max(0.0)).abs() <= 1e-14 * en[i]);
            }
        }
        // facing away: no shadow ray, no light
        let e = l.moon_irradiance_w_m2_nm(-d, |_| panic!("no shadow ray needed"));
        assert!(e.iter().all(|&v| v == 0.0));
        // in shadow; the shadow ray points at the Moon
        let e = l.moon_irradiance_w_m2_nm(DVec3::Z, |dir| {
            assert!((dir - d).length() < 1e-12);
            true
        });
        assert!(e.iter().all(|&v| v == 0.0));
        // horizontal direct = the model's horizontal direct term (E_n sin h)
        let e = l.moon_irradiance_w_m2_nm(DVec3::Z, |_| false);
        let s = m.ground_spectra();
        let h = interpolate(&s.moon_direct_horizontal_w_m2_nm, 600.0);
        assert!((e[3] / h - 1.0).abs() < 0.01, "{} vs {h}", e[3]);
        // unnormalised normals are fine; zero or NaN normals give zero
        let e2 = l.moon_irradiance_w_m2_nm(DVec3::Z * 3.0, |_| false);
        assert_eq!(e, e2);
        assert!(
            l.moon_irradiance_w_m2_nm(DVec3::ZERO, |_| false)
                .iter()
                .all(|&v| v == 0.0)
        );
        assert!(
            l.moon_irradiance_w_m2_nm(DVec3::NAN, |_| false)
                .iter()
                .all(|&v| v == 0.0)
        );
    }

    #[test]
    fn no_direct_moon_when_down_overcast_or_off() {
        let down = SkyLight::new(&model(NEW, Cloud::Clear), &grid(), SkyTerms::default());
        let oc = SkyLight::new(&model(FULL, Cloud::Overcast), &grid(), SkyTerms::default());
        let off = SkyLight::new(
            &model(FULL, Cloud::Clear),
            &grid(),
            SkyTerms {
                moon: false,
                night_sky: true,
            },
        );
        for l in [&down, &oc, &off] {
            assert!(l.moon_direction().is_none());
            let e = l.moon_irradiance_w_m2_nm(DVec3::Z, |_| panic!("no shadow ray"));
            assert!(e.iter().all(|&v| v == 0.0));
        }
        // overcast: a uniform deck, so the horizontal estimate is exact
        let m = model(FULL, Cloud::Overcast);
        let got = oc.sky_irradiance_w_m2_nm(DVec3::Z, 16, variates(3), |_| false);
        let s = m.ground_spectra();
        let want = interpolate(&s.total_horizontal_w_m2_nm, 600.0);
        assert!((got.value_w_m2_nm[3] / want - 1.0).abs() < 1e-9);
        assert!(got.std_error_w_m2_nm[3] <= 1e-9 * want);
    }

    #[test]
    fn degenerate_inputs_give_finite_answers() {
        let l = SkyLight::new(&model(FULL, Cloud::Clear), &grid(), SkyTerms::default());
        let none = l.sky_irradiance_w_m2_nm(DVec3::Z, 0, variates(1), |_| false);
        assert!(none.value_w_m2_nm.iter().all(|&v| v == 0.0));
        assert!(none.std_error_w_m2_nm.iter().all(|&e| e == f64::INFINITY));
        let one = l.sky_irradiance_w_m2_nm(DVec3::Z, 1, variates(1), |_| false);
        assert!(one.value_w_m2_nm.iter().all(|v| v.is_finite()));
        // garbage variates are sanitised
        let bad = l.sky_irradiance_w_m2_nm(DVec3::Z, 8, || [f64::NAN, 7.0], |_| false);
        assert!(bad.value_w_m2_nm.iter().all(|v| v.is_finite() && *v >= 0.0));
        // a zero normal sees nothing
        let z = l.sky_irradiance_w_m2_nm(DVec3::ZERO, 8, variates(1), |_| false);
        assert!(z.value_w_m2_nm.iter().all(|&v| v == 0.0));
        assert_eq!(z.n_shadow_rays, 0);
        // a surface facing straight down sees no sky and casts no rays
        let down = l.sky_irradiance_w_m2_nm(-DVec3::Z, 100, variates(2), |_| panic!("no ray"));
        assert!(down.value_w_m2_nm.iter().all(|&v| v == 0.0));
        // wavelengths outside the model's 300–1100 nm grid are dark
        let l2 = SkyLight::new(
            &model(FULL, Cloud::Clear),
            &[250.0, 1200.0],
            SkyTerms::default(),
        );
        assert!(
            l2.moon_irradiance_w_m2_nm(DVec3::Z, |_| false)
                .iter()
                .all(|&v| v == 0.0)
        );
        assert!(
            l2.sky_radiance_w_m2_sr_nm(DVec3::Z)
                .iter()
                .all(|&v| v == 0.0)
        );
        // same variates, same answer
        let a = l.sky_irradiance_w_m2_nm(tilted(50.0, 10.0), 200, variates(5), |d| d.y > 0.5);
        let b = l.sky_irradiance_w_m2_nm(tilted(50.0, 10.0), 200, variates(5), |d| d.y > 0.5);
        assert_eq!(a, b);
    }

    #[test]
    fn moonlit_table_integrates_like_the_model() {
        for utc in [FULL, HALF, NEW] {
            let m = model(utc, Cloud::Clear);
            let l = SkyLight::new(&m, &grid(), SkyTerms::default());
            let t = RadianceTable::new(&l);
            assert_eq!(t.is_uniform(), utc == NEW);
            // Midpoint rule in (sin el, az) over the dome: ∫ L cos dω.
            let (ne, na) = (200, 400);
            let mut e = vec![0.0; grid().len()];
            let mut lt = vec![0.0; grid().len()];
            for i in 0..ne {
                let mu = (i as f64 + 0.5) / ne as f64;
                for j in 0..na {
                    let az = 2.0 * PI * (j as f64 + 0.5) / na as f64;
                    let c = (1.0 - mu * mu).sqrt();
                    t.radiance_into(DVec3::new(c * az.sin(), c * az.cos(), mu), &mut lt);
                    for k in 0..e.len() {
                        e[k] += lt[k] * mu * 2.0 * PI / (ne * na) as f64;
                    }
                }
            }
            let s = m.ground_spectra();
            for (k, &w) in grid().iter().enumerate() {
                let want = interpolate(&s.moon_sky_horizontal_w_m2_nm, w)
                    + interpolate(&s.night_sky_horizontal_w_m2_nm, w);
                assert!(
                    (e[k] / want - 1.0).abs() < 3e-3,
                    "{utc} {w}: {} vs {want}",
                    e[k]
                );
            }
            // below the horizon: dark
            t.radiance_into(DVec3::new(0.0, 1.0, -0.01), &mut lt);
            assert!(lt.iter().all(|&v| v == 0.0));
        }
    }

    #[test]
    fn sampling_helpers() {
        for k in 0..200 {
            let u = [(k as f64 + 0.5) / 200.0, ((k * 37) % 200) as f64 / 200.0];
            let v = cosine_hemisphere(u);
            assert!((v.length() - 1.0).abs() < 1e-12 && v.z >= 0.0);
        }
        for n in [
            DVec3::Z,
            -DVec3::Z,
            DVec3::X,
            tilted(33.0, 271.0),
            tilted(179.9, 5.0),
        ] {
            let (t, b) = orthonormal_basis(n);
            assert!(t.dot(n).abs() < 1e-12 && b.dot(n).abs() < 1e-12 && t.dot(b).abs() < 1e-12);
            assert!((t.cross(b) - n).length() < 1e-12);
        }
    }
}
