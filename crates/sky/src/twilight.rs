//! The twilight (and low-Sun) sky: spectral sky radiance and horizontal
//! ground irradiance for the Sun from +10° down to −18°, from a
//! spherical-shell atmosphere.
//!
//! Why a separate model: the moonlit sky of [`crate::atmosphere`] is
//! plane-parallel, and a plane-parallel atmosphere has no light at all once
//! the source sets. Twilight is light scattered by the upper air that still
//! sees the Sun over the curve of the Earth, so the geometry must be a
//! sphere and the Earth's shadow must be explicit.
//!
//! * Geometry: a spherical Earth of radius 6371 km (solid surface at sea
//!   level) under an atmosphere 100 km deep, refraction-free. The observer
//!   stands at the site height; the Sun is a point at infinity.
//! * Constituents, each with its own height profile above the site:
//!   Rayleigh scattering (Bodhaine et al. 1999 τ_R at the site pressure,
//!   the same as [`crate::atmosphere`]) exponential with scale height
//!   8.43 km; aerosol ([`Atmosphere`]'s Koschmieder τ_a, Ångström α, ω_a
//!   and Henyey–Greenstein g) exponential with its scale height; ozone
//!   absorption (cross-sections in `data/ozone_cross_section.csv`) in a
//!   layer whose density rises linearly from 10 km to a peak at 25 km and
//!   falls to zero at 40 km (the shape Bruneton 2017 uses for the US
//!   standard ozone layer), holding [`TwilightOptions::ozone_column_du`]
//!   (default 300 DU).
//! * Single scattering along the line of sight, exactly in geometry: the
//!   view ray is sampled from the observer to the top of the atmosphere;
//!   each sample scatters sunlight only if the straight ray from it to the
//!   Sun misses the solid Earth (the Earth's shadow), attenuated by the
//!   slant optical depth along that ray through the shell (Rayleigh +
//!   aerosol + ozone) and by the optical depth back to the observer.
//!   Slant columns are integrated numerically, split at the ray's lowest
//!   point and with nodes crowded towards it, so grazing rays that pass
//!   within a few km of the ground are resolved.
//! * Multiple scattering: successive orders of a diffuse field tabulated
//!   over height and local solar elevation in the shell, see
//!   [`MULTIPLE_SCATTERING_NOTE`].
//! * Ground: horizontal diffuse irradiance integrates the radiance over the
//!   dome (Gauss–Legendre in sin(elevation), midpoint in azimuth relative to
//!   the Sun, using the sky's mirror symmetry about the solar vertical);
//!   the direct Sun adds `E₀ T sin h` while its centre is above the
//!   geometric horizon. Ground albedo is 0 (no light reflected back up).
//! * Solar spectrum: ASTM G173-03 extraterrestrial (Gueymard 2004) at 1 AU,
//!   scaled by `(1 AU / d)²` when built from an instant.

use crate::atmosphere::{
    Atmosphere, RAYLEIGH_SCALE_HEIGHT_KM, henyey_greenstein_phase, rayleigh_phase,
};
use crate::ephemeris::{Refraction, Site, enu_from_elevation_azimuth, ephemeris};
use crate::error::{Result, check_range};
use crate::spectral::{self, Samples};
use crate::time::UtcInstant;
use crate::twilight_data::{ozone_cross_section_cm2, solar_etr_w_m2_nm};
use std::sync::{Arc, Mutex, OnceLock};

/// Mean Earth radius, km.
pub const EARTH_RADIUS_KM: f64 = 6371.0;
/// Top of the model atmosphere above sea level, km.
pub const ATMOSPHERE_TOP_KM: f64 = 100.0;
/// Lowest Sun elevation the twilight model covers, degrees (astronomical
/// twilight ends here; below it the sky is the night sky's).
pub const TWILIGHT_MIN_SUN_ELEVATION_DEG: f64 = -18.0;
/// Molecules per cm² in one Dobson unit.
pub const DOBSON_UNIT_PER_CM2: f64 = 2.6867e16;
/// Ozone layer shape: bottom, peak and top heights above sea level, km.
pub const OZONE_LAYER_KM: [f64; 3] = [10.0, 25.0, 40.0];
/// One astronomical unit, km.
const AU_KM: f64 = 149_597_870.7;
const FOUR_PI: f64 = 4.0 * std::f64::consts::PI;

/// Why the multiple-scattering term is what it is.
///
/// In deep twilight the air over the observer is in the Earth's shadow and
/// the light comes from the sunlit shell high up and towards the Sun,
/// scattered down once or more. The parcels that matter are kilometres up,
/// where the sunlit air is close and the path to it thin — not at the
/// ground, whose view of that shell crosses hundreds of kilometres of dense
/// air. So the source of the multiple scattering is computed where it
/// acts, by successive orders in the spherical shell:
///
/// * the diffuse field `J(r, μ_s) = ∫ L dΩ / 4π` of a spherically
///   symmetric atmosphere under a Sun at infinity depends only on the
///   point's height and local solar zenith cosine (Bruneton & Neyret 2008;
///   Hillaire 2020), so it is tabulated once per atmosphere (10 heights to
///   99 km × 39 local solar elevations, 1° steps from −22° to +6°), shared
///   by every Sun position;
/// * J₁ at each node is the angular quadrature (66 directions: μ crowded
///   to the horizon above it, split at the limb below it) of the single
///   scattered radiance arriving there, each ray marched through the shell
///   with the Earth's shadow exact; its second moments are kept too, so the
///   observer's second order uses the Rayleigh phase function exactly
///   (quadratic in the scattering cosine) and, with its first moments, the
///   aerosol's Henyey–Greenstein phase function through its Legendre series
///   to second order (`1 + 3g P₁ + 5g² P₂`, clamped at zero), towards the
///   observer and towards every node alike;
/// * J₂ follows from J₁ so scattered, J₃ from J₂ by isotropic scattering,
///   both along the same quadrature; the orders beyond are a geometric tail
///   `J₃ f / (1 − f)` with `f` the node's transfer probability — the share
///   of light emitted isotropically there that is scattered again before it
///   escapes or reaches the black ground (Hillaire 2020's closure, here
///   applied past the third order);
/// * the observer's multiple-scattering radiance is `∫ β_s T J dl` along
///   the line of sight, J looked up (log-bilinear) at each sample.
///
/// Checked with the Sun high against the plane-parallel single-scattering
/// budget of [`crate::atmosphere`] (the added diffuse light is 0.39–0.56 of
/// the energy single scattering leaves in the air, never more), and
/// converged in its quadrature (twice the directions, azimuths and samples
/// change the validation table's twilight term by < 2 % to −12°, < 3.2 %
/// to −15°, 5–7 % at −16° to −18°).
pub const MULTIPLE_SCATTERING_NOTE: &str = "successive orders of an isotropic diffuse field J(r, mu_s) in the spherical shell: J1 from single scattering (Rayleigh phase via second moments, aerosol via first and second), J2, J3, then a geometric tail with the local transfer probability";

/// Options of the twilight sky.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwilightOptions {
    /// Total ozone column, Dobson units (default 300; 0 removes ozone).
    pub ozone_column_du: f64,
    /// Add the multiple-scattering term (default true).
    pub multiple_scattering: bool,
}

impl Default for TwilightOptions {
    fn default() -> Self {
        Self {
            ozone_column_du: 300.0,
            multiple_scattering: true,
        }
    }
}

impl TwilightOptions {
    fn validate(&self) -> Result<()> {
        check_range("ozone_column_du", self.ozone_column_du, 0.0, 1000.0)?;
        Ok(())
    }
}

/// Per-wavelength optical constants on the model's grid.
#[derive(Clone, Debug)]
struct Spectral {
    wavelength_nm: Vec<f64>,
    /// Exo-atmospheric solar irradiance normal to the beam, W m⁻² nm⁻¹.
    solar_w_m2_nm: Vec<f64>,
    /// Vertical Rayleigh optical depth above the site.
    tau_rayleigh: Vec<f64>,
    /// Vertical aerosol extinction optical depth above the site.
    tau_aerosol: Vec<f64>,
    /// Vertical aerosol scattering optical depth above the site.
    tau_aerosol_scattering: Vec<f64>,
    /// Ozone optical depth per Dobson unit of slant column.
    tau_ozone_per_du: Vec<f64>,
}

/// Slant columns along a path: Rayleigh and aerosol in units of their
/// vertical column above the site (an "airmass"), ozone in Dobson units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Columns {
    rayleigh: f64,
    aerosol: f64,
    ozone_du: f64,
}

impl Columns {
    fn add_scaled(&mut self, other: &Columns, k: f64) {
        self.rayleigh += other.rayleigh * k;
        self.aerosol += other.aerosol * k;
        self.ozone_du += other.ozone_du * k;
    }
}

/// Gauss–Legendre nodes/weights on [0, 1] for the slant-column integrals.
const SLANT_NODES: usize = 24;
/// Samples along a line of sight.
const VIEW_SAMPLES: usize = 64;
/// Dome quadrature: nodes in sin(elevation) and in azimuth over [0°, 180°].
const DOME_MU_NODES: usize = 16;
const DOME_AZIMUTH_NODES: usize = 36;

/// The twilight sky for one Sun position, site height and atmosphere.
#[derive(Clone, Debug)]
pub struct TwilightSky {
    atmosphere: Atmosphere,
    options: TwilightOptions,
    site_height_km: f64,
    sun_elevation_deg: f64,
    sun_azimuth_deg: f64,
    sun_enu: [f64; 3],
    spectral: Spectral,
    slant_rule: Vec<(f64, f64)>,
    /// The diffuse (multiply scattered) source field `J(r, μ_s)` at 1 AU,
    /// shared between skies of one atmosphere (None when multiple
    /// scattering is off).
    diffuse: Option<Arc<DiffuseField>>,
    /// `(1 AU / d)²`: scales [`Self::diffuse`], built at 1 AU.
    solar_scale: f64,
}

impl TwilightSky {
    /// The sky for the Sun at a geometric (refraction-free) elevation and
    /// azimuth (degrees, azimuth north through east) over a site
    /// `site_height_m` above sea level, with the solar spectrum at 1 AU.
    /// Errors when the Sun is below −18° (no twilight left: use the night
    /// sky) or any input is out of range.
    pub fn new(
        sun_elevation_deg: f64,
        sun_azimuth_deg: f64,
        site_height_m: f64,
        atmosphere: Atmosphere,
        options: TwilightOptions,
    ) -> Result<Self> {
        check_range(
            "sun_elevation_deg",
            sun_elevation_deg,
            TWILIGHT_MIN_SUN_ELEVATION_DEG,
            90.0,
        )?;
        check_range("sun_azimuth_deg", sun_azimuth_deg, -360.0, 720.0)?;
        check_range("site_height_m", site_height_m, -500.0, 10_000.0)?;
        atmosphere.validate()?;
        options.validate()?;
        let spectral = Self::spectral_constants(&atmosphere, 1.0)?;
        let slant_rule = crate::quadrature::legendre_roots_01_weights(SLANT_NODES, 1e-15)
            .into_iter()
            .map(|(z, w)| (0.5 * (1.0 - z), w))
            .collect();
        let mut sky = Self {
            atmosphere,
            options,
            site_height_km: site_height_m / 1000.0,
            sun_elevation_deg,
            sun_azimuth_deg,
            sun_enu: enu_from_elevation_azimuth(sun_elevation_deg, sun_azimuth_deg),
            spectral,
            slant_rule,
            diffuse: None,
            solar_scale: 1.0,
        };
        if options.multiple_scattering {
            sky.diffuse = Some(DiffuseField::shared(&sky));
        }
        Ok(sky)
    }

    /// The sky at an instant over a site (the Sun's geometric position from
    /// the crate's ephemeris, its spectrum scaled to the Sun's distance),
    /// with the default atmosphere for the site height and `visibility_km`.
    pub fn at(
        instant: UtcInstant,
        site: &Site,
        visibility_km: f64,
        options: TwilightOptions,
    ) -> Result<Self> {
        let site = Site::new(site.latitude_deg, site.longitude_east_deg, site.height_m)?;
        let eph = ephemeris(instant, &site, Refraction::STANDARD);
        let atmosphere = Atmosphere::new(site.height_m, visibility_km)?;
        let mut sky = Self::new(
            eph.sun.elevation_geometric_deg,
            eph.sun.azimuth_deg,
            site.height_m,
            atmosphere,
            options,
        )?;
        let d_au = eph.sun.distance_km / AU_KM;
        if d_au.is_finite() && d_au > 0.9 && d_au < 1.1 {
            let k = 1.0 / (d_au * d_au);
            sky.spectral.solar_w_m2_nm.iter_mut().for_each(|e| *e *= k);
            sky.solar_scale = k;
        }
        Ok(sky)
    }

    fn spectral_constants(atmosphere: &Atmosphere, solar_scale: f64) -> Result<Spectral> {
        let grid = spectral::default_grid_nm();
        let mut s = Spectral {
            wavelength_nm: grid.clone(),
            solar_w_m2_nm: Vec::with_capacity(grid.len()),
            tau_rayleigh: Vec::with_capacity(grid.len()),
            tau_aerosol: Vec::with_capacity(grid.len()),
            tau_aerosol_scattering: Vec::with_capacity(grid.len()),
            tau_ozone_per_du: Vec::with_capacity(grid.len()),
        };
        for &w in &grid {
            let d = atmosphere.optical_depths(w);
            s.solar_w_m2_nm.push(solar_etr_w_m2_nm(w)? * solar_scale);
            s.tau_rayleigh.push(d.rayleigh);
            s.tau_aerosol.push(d.aerosol_extinction);
            s.tau_aerosol_scattering.push(d.aerosol_scattering);
            s.tau_ozone_per_du
                .push(ozone_cross_section_cm2(w)? * DOBSON_UNIT_PER_CM2);
        }
        Ok(s)
    }

    /// Geometric Sun elevation, degrees.
    pub fn sun_elevation_deg(&self) -> f64 {
        self.sun_elevation_deg
    }

    /// Sun azimuth, degrees from north through east.
    pub fn sun_azimuth_deg(&self) -> f64 {
        self.sun_azimuth_deg
    }

    /// Unit vector towards the Sun, east-north-up.
    pub fn sun_direction_enu(&self) -> [f64; 3] {
        self.sun_enu
    }

    /// The model's wavelength grid, nm (300–1100 nm every 5 nm).
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.spectral.wavelength_nm
    }

    /// Exo-atmospheric solar irradiance normal to the beam, W m⁻² nm⁻¹.
    pub fn solar_exo_w_m2_nm(&self) -> Samples {
        self.zip(&self.spectral.solar_w_m2_nm)
    }

    fn zip(&self, v: &[f64]) -> Samples {
        self.spectral
            .wavelength_nm
            .iter()
            .copied()
            .zip(v.iter().copied())
            .collect()
    }

    /// Observer position, km, Earth-centred with the axes of the site's
    /// east-north-up frame.
    fn observer_km(&self) -> [f64; 3] {
        [0.0, 0.0, EARTH_RADIUS_KM + self.site_height_km]
    }

    /// Density profiles at a point `radius_km` from the Earth's centre:
    /// Rayleigh and aerosol per km of their vertical column above the site
    /// (so a vertical path integrates to 1), ozone in DU per km.
    fn densities_per_km(&self, radius_km: f64) -> Columns {
        let z = radius_km - EARTH_RADIUS_KM;
        let dz = z - self.site_height_km;
        let h_r = RAYLEIGH_SCALE_HEIGHT_KM;
        let h_a = self.atmosphere.aerosol_scale_height_km;
        let aerosol = if h_a > 0.0 {
            (-dz / h_a).min(700.0).exp() / h_a
        } else {
            0.0
        };
        let [bottom, peak, top] = OZONE_LAYER_KM;
        let tent = if z <= bottom || z >= top {
            0.0
        } else if z < peak {
            (z - bottom) / (peak - bottom)
        } else {
            (top - z) / (top - peak)
        };
        Columns {
            rayleigh: (-dz / h_r).min(700.0).exp() / h_r,
            aerosol,
            // the tent integrates to (top − bottom)/2 km
            ozone_du: self.options.ozone_column_du * tent / (0.5 * (top - bottom)),
        }
    }

    /// Columns along `p + t d` for t from `t_dense` to `t_far`, with the
    /// nodes of `rule` crowded towards `t_dense` (where the path is lowest
    /// and the air densest): `t = t_dense + (t_far − t_dense) u²`.
    fn segment_columns(
        &self,
        p: [f64; 3],
        d: [f64; 3],
        t_dense: f64,
        t_far: f64,
        rule: &[(f64, f64)],
    ) -> Columns {
        let mut c = Columns::default();
        let span = t_far - t_dense;
        for &(u, w) in rule {
            let t = t_dense + span * u * u;
            let q = add(p, d, t);
            let n = self.densities_per_km(norm(q));
            c.add_scaled(&n, w * 2.0 * span.abs() * u);
        }
        c
    }

    /// Columns from `p` towards the Sun to the top of the atmosphere, or
    /// `None` when the solid Earth blocks the Sun (the point is in the
    /// Earth's shadow).
    fn sun_columns(&self, p: [f64; 3]) -> Option<Columns> {
        self.sun_columns_along(p, self.sun_enu, &self.slant_rule)
    }

    /// [`Self::sun_columns`] for a Sun in direction `s` (unit), with a
    /// given slant rule.
    fn sun_columns_along(&self, p: [f64; 3], s: [f64; 3], rule: &[(f64, f64)]) -> Option<Columns> {
        let top = EARTH_RADIUS_KM + ATMOSPHERE_TOP_KM;
        let b = dot(p, s);
        let pp = dot(p, p);
        // lowest point of the ray: where it is perpendicular to the radius
        let t_low = (-b).max(0.0);
        let r_low2 = pp - b * b;
        if b < 0.0 && r_low2 < EARTH_RADIUS_KM * EARTH_RADIUS_KM {
            return None;
        }
        let t_exit = -b + (b * b - (pp - top * top)).max(0.0).sqrt();
        let mut c = self.segment_columns(p, s, t_low, t_exit, rule);
        if t_low > 0.0 {
            let before = self.segment_columns(p, s, t_low, 0.0, rule);
            c.add_scaled(&before, 1.0);
        }
        Some(c)
    }

    /// Geometry of one line of sight from the observer.
    fn march(&self, view: [f64; 3]) -> Vec<PathSample> {
        self.march_from(
            self.observer_km(),
            view,
            self.sun_enu,
            VIEW_SAMPLES,
            true,
            Some(&self.slant_rule),
        )
    }

    /// Geometry of a ray from `p` along unit `d` to the top of the
    /// atmosphere or the ground, in `n` samples (crowded towards `p` when
    /// `crowd`, else even), for a Sun in direction `s`: per sample the
    /// path element (km), the local densities, the columns back to `p`,
    /// the radius and local solar cosine, and the columns to the Sun (None
    /// in the Earth's shadow, or when no slant `rule` is given).
    fn march_from(
        &self,
        p: [f64; 3],
        d: [f64; 3],
        s: [f64; 3],
        n: usize,
        crowd: bool,
        rule: Option<&[(f64, f64)]>,
    ) -> Vec<PathSample> {
        let top = EARTH_RADIUS_KM + ATMOSPHERE_TOP_KM;
        let b = dot(p, d);
        let pp = dot(p, p);
        let mut length = -b + (b * b - (pp - top * top)).max(0.0).sqrt();
        let ground = b * b - (pp - EARTH_RADIUS_KM * EARTH_RADIUS_KM);
        if b < 0.0 && ground > 0.0 {
            length = length.min((-b - ground.sqrt()).max(0.0));
        }
        let mut out = Vec::with_capacity(n);
        let mut behind = Columns::default();
        for k in 0..n {
            let u = (k as f64 + 0.5) / n as f64;
            let (t, dt) = if crowd {
                (length * u * u, 2.0 * length * u / n as f64)
            } else {
                (length * u, length / n as f64)
            };
            let q = add(p, d, t);
            let r = norm(q);
            let dens = self.densities_per_km(r);
            // column to the start: the earlier samples plus half of this one
            let mut here = behind;
            here.add_scaled(&dens, 0.5 * dt);
            behind.add_scaled(&dens, dt);
            out.push(PathSample {
                dt,
                dens,
                to_start: here,
                pos: q,
                radius_km: r,
                mu_sun: dot(q, s) / r,
                to_sun: rule.and_then(|rule| self.sun_columns_along(q, s, rule)),
            });
        }
        out
    }

    fn optical_depth(&self, i: usize, c: &Columns) -> f64 {
        let s = &self.spectral;
        s.tau_rayleigh[i] * c.rayleigh
            + s.tau_aerosol[i] * c.aerosol
            + s.tau_ozone_per_du[i] * c.ozone_du
    }

    /// Sky spectral radiance looking along `view_enu` (east-north-up, need
    /// not be normalised), W m⁻² sr⁻¹ nm⁻¹ on [`Self::wavelengths_nm`]:
    /// scattered sunlight only (add the night sky and moonlight on top).
    /// Zero at and below the horizon and for a zero or non-finite vector.
    pub fn radiance_w_m2_sr_nm(&self, view_enu: [f64; 3]) -> Samples {
        let mut out = vec![0.0; self.spectral.wavelength_nm.len()];
        self.accumulate_radiance(view_enu, 1.0, &mut out);
        self.zip(&out)
    }

    /// Adds `weight × L(view)` into `acc` (one value per grid wavelength).
    fn accumulate_radiance(&self, view_enu: [f64; 3], weight: f64, acc: &mut [f64]) {
        let n = norm(view_enu);
        if !n.is_finite() || n == 0.0 || view_enu[2] / n <= 0.0 {
            return;
        }
        let v = [view_enu[0] / n, view_enu[1] / n, view_enu[2] / n];
        let cos_theta = dot(v, self.sun_enu).clamp(-1.0, 1.0);
        let p_r = rayleigh_phase(cos_theta);
        let p_a = henyey_greenstein_phase(cos_theta, self.atmosphere.aerosol_asymmetry);
        let samples = self.march(v);
        let s = &self.spectral;
        // the diffuse source J at each sample, on the full grid
        let sources: Vec<(Vec<f64>, Vec<f64>)> = match &self.diffuse {
            Some(field) => samples
                .iter()
                .map(|p| {
                    field.source(
                        p.pos,
                        p.radius_km,
                        p.mu_sun,
                        self.sun_enu,
                        v,
                        self.solar_scale,
                    )
                })
                .collect(),
            None => Vec::new(),
        };
        for (i, a) in acc.iter_mut().enumerate() {
            let (mut l1, mut lm) = (0.0, 0.0);
            for (k, p) in samples.iter().enumerate() {
                let t_eye = (-self.optical_depth(i, &p.to_start)).exp();
                let b_r = s.tau_rayleigh[i] * p.dens.rayleigh;
                let b_a = s.tau_aerosol_scattering[i] * p.dens.aerosol;
                if let Some((j_r, j_a)) = sources.get(k) {
                    lm += p.dt * (b_r * j_r[i] + b_a * j_a[i]) * t_eye;
                }
                let Some(to_sun) = &p.to_sun else { continue };
                let t_sun = (-self.optical_depth(i, to_sun)).exp();
                l1 += p.dt * (b_r * p_r + b_a * p_a) * t_eye * t_sun;
            }
            *a += weight * (s.solar_w_m2_nm[i] * l1 / FOUR_PI + lm);
        }
    }

    /// Diffuse (sky) spectral irradiance on a horizontal surface,
    /// W m⁻² nm⁻¹: `∫ L cos θ dΩ` over the dome.
    pub fn diffuse_horizontal_w_m2_nm(&self) -> Samples {
        self.zip(&self.dome_integrals().0)
    }

    /// `(∫ L cos θ dΩ, ∫ L dΩ)` over the upper hemisphere, per grid
    /// wavelength: Gauss–Legendre in cos θ, midpoint in azimuth over one
    /// side of the solar vertical (the sky is mirror-symmetric about it).
    fn dome_integrals(&self) -> (Vec<f64>, Vec<f64>) {
        let rule = crate::quadrature::legendre_roots_01_weights(DOME_MU_NODES, 1e-15);
        let n = self.spectral.wavelength_nm.len();
        let (mut horizontal, mut scalar) = (vec![0.0; n], vec![0.0; n]);
        let mut l = vec![0.0; n];
        let dphi = std::f64::consts::PI / DOME_AZIMUTH_NODES as f64;
        let sun_az = self.sun_azimuth_deg.to_radians();
        for &(z, w) in &rule {
            let mu = 0.5 * (1.0 - z);
            let st = (1.0 - mu * mu).max(0.0).sqrt();
            for j in 0..DOME_AZIMUTH_NODES {
                let phi = sun_az + (j as f64 + 0.5) * dphi;
                l.iter_mut().for_each(|x| *x = 0.0);
                self.accumulate_radiance([st * phi.sin(), st * phi.cos(), mu], 1.0, &mut l);
                let k = 2.0 * w * dphi;
                for i in 0..n {
                    horizontal[i] += k * mu * l[i];
                    scalar[i] += k * l[i];
                }
            }
        }
        (horizontal, scalar)
    }

    /// Direct solar spectral irradiance at the ground normal to the beam,
    /// W m⁻² nm⁻¹ (0 while the Sun's centre is below the geometric horizon).
    pub fn direct_normal_w_m2_nm(&self) -> Samples {
        let cols = if self.sun_elevation_deg > 0.0 {
            self.sun_columns(self.observer_km())
        } else {
            None
        };
        let v: Vec<f64> = (0..self.spectral.wavelength_nm.len())
            .map(|i| match &cols {
                Some(c) => self.spectral.solar_w_m2_nm[i] * (-self.optical_depth(i, c)).exp(),
                None => 0.0,
            })
            .collect();
        self.zip(&v)
    }

    /// Direct solar spectral irradiance on a horizontal surface, W m⁻² nm⁻¹.
    pub fn direct_horizontal_w_m2_nm(&self) -> Samples {
        let sin_h = self.sun_elevation_deg.to_radians().sin().max(0.0);
        self.direct_normal_w_m2_nm()
            .into_iter()
            .map(|(w, e)| (w, e * sin_h))
            .collect()
    }

    /// Horizontal illuminance from the Sun, lux: `(direct, diffuse)`.
    pub fn horizontal_illuminance_lux(&self) -> Result<(f64, f64)> {
        let direct = spectral::illuminance_lux(&self.direct_horizontal_w_m2_nm())?;
        let diffuse = spectral::illuminance_lux(&self.diffuse_horizontal_w_m2_nm())?;
        Ok((direct, diffuse))
    }
}

/// Heights of the diffuse-field table above the site, km.
const FIELD_HEIGHTS_KM: [f64; 10] = [0.0, 3.0, 7.0, 12.0, 18.0, 25.0, 35.0, 50.0, 70.0, 99.0];
/// Samples along each ray of the diffuse-field quadrature.
const FIELD_SAMPLES: usize = 24;
/// Gauss–Legendre nodes of the slant columns to the Sun in the field.
const FIELD_SLANT_NODES: usize = 12;
/// Azimuth midpoints over [0°, 180°] of the field's angular quadrature.
const FIELD_AZIMUTHS: usize = 6;
/// The field is computed every this many grid wavelengths (every 20 nm)
/// and interpolated linearly between them.
const FIELD_WAVELENGTH_STRIDE: usize = 4;
/// Orders of the diffuse field computed explicitly (J₁ from single
/// scattering, J₂ from J₁, …); the rest is a geometric tail.
const FIELD_ORDERS: usize = 3;
/// Largest transfer probability the geometric tail accepts (a guard: the
/// model's air never comes near it, f ≲ 0.5 at 300 nm).
const FIELD_MAX_TRANSFER: f64 = 0.9;

/// Local solar elevations of the diffuse-field table, degrees: 1° steps
/// through twilight, where the field changes by orders of magnitude.
fn field_elevations_deg() -> Vec<f64> {
    let mut e: Vec<f64> = [-30.0, -28.0, -26.0, -24.0].to_vec();
    e.extend((-22..=6).map(f64::from));
    e.extend([10.0, 15.0, 25.0, 40.0, 60.0, 90.0]);
    e
}

/// The isotropic diffuse source of the multiple-scattering term.
///
/// In a spherically symmetric atmosphere lit by a Sun at infinity, the
/// radiance arriving at a point — and so its angle-averaged diffuse field
/// `J = ∫ L dΩ / 4π` — depends only on the point's radius and the local
/// solar zenith cosine μ_s (the parameterisation of Bruneton & Neyret
/// 2008's precomputed scattering and of Hillaire 2020's multiple-scattering
/// table). So the field is tabulated once per atmosphere on (height,
/// local solar elevation), independent of the observer's Sun, and shared.
#[derive(Debug)]
pub(crate) struct DiffuseField {
    heights_km: Vec<f64>,
    elevations_deg: Vec<f64>,
    /// Grid-wavelength indices of the field's wavelengths.
    coarse: Vec<usize>,
    n_fine: usize,
    /// Per order n (J₁, J₂, …), per node `k·n_e + j`, per field wavelength:
    /// the order's field at 1 AU, W m⁻² sr⁻¹ nm⁻¹.
    orders: Vec<Vec<Vec<f64>>>,
    /// ln of the total field (all orders with the tail), same layout.
    log_total: Vec<Vec<f64>>,
    /// Per node and field wavelength, the transfer probability f.
    transfer: Vec<Vec<f64>>,
    /// Per node and field wavelength, the second moments of J₁'s radiance
    /// over J₁ (xx, yy, zz, xz in the node's frame: z up, the Sun in the
    /// x–z plane; xy and yz vanish by the mirror symmetry), then its first
    /// moments over J₁ (x, z; y vanishes).
    moments: Vec<Vec<[f64; 6]>>,
    /// The aerosol's Henyey–Greenstein g.
    aerosol_asymmetry: f64,
}

type FieldCache = Mutex<Vec<(String, Arc<DiffuseField>)>>;

impl DiffuseField {
    /// The field for a sky's atmosphere, ozone and site height, built once
    /// per process and shared.
    fn shared(sky: &TwilightSky) -> Arc<DiffuseField> {
        static CACHE: OnceLock<FieldCache> = OnceLock::new();
        let key = format!(
            "{:?}|{}|{}",
            sky.atmosphere, sky.options.ozone_column_du, sky.site_height_km
        );
        let cache = CACHE.get_or_init(|| Mutex::new(Vec::new()));
        if let Some(f) = cache
            .lock()
            .ok()
            .and_then(|c| c.iter().find(|e| e.0 == key).map(|e| e.1.clone()))
        {
            return f;
        }
        let field = Arc::new(Self::build(sky));
        if let Ok(mut c) = cache.lock() {
            if c.len() >= 16 {
                c.remove(0);
            }
            c.push((key, field.clone()));
        }
        field
    }

    /// Quadrature directions at radius `r` (local frame: up = z, Sun in
    /// the x–z plane), weights summing to 4π over the sphere: μ crowded to
    /// the horizon above it, split at the limb below it (rays above the
    /// limb graze the air towards the horizon, those below end on the
    /// ground), azimuth over one half (the field is mirror-symmetric about
    /// the solar vertical).
    fn directions(r_km: f64) -> Vec<([f64; 3], f64)> {
        let gl = |n: usize| crate::quadrature::legendre_roots_01_weights(n, 1e-15);
        let mut mus: Vec<(f64, f64)> = gl(6)
            .into_iter()
            .map(|(z, w)| {
                let u = 0.5 * (1.0 - z);
                (u * u, 2.0 * u * w)
            })
            .collect();
        let mu_limb = -(1.0 - (EARTH_RADIUS_KM / r_km).powi(2)).max(0.0).sqrt();
        if mu_limb < 0.0 {
            for (z, w) in gl(3) {
                mus.push((mu_limb * 0.5 * (1.0 + z), -mu_limb * w));
            }
        }
        for (z, w) in gl(2) {
            let a = -1.0 - mu_limb;
            mus.push((mu_limb + a * 0.5 * (1.0 + z), -a * w));
        }
        let dphi = std::f64::consts::PI / FIELD_AZIMUTHS as f64;
        let mut out = Vec::with_capacity(mus.len() * FIELD_AZIMUTHS);
        for &(mu, w) in &mus {
            let st = (1.0 - mu * mu).max(0.0).sqrt();
            for k in 0..FIELD_AZIMUTHS {
                let phi = (k as f64 + 0.5) * dphi;
                out.push(([st * phi.cos(), st * phi.sin(), mu], 2.0 * w * dphi));
            }
        }
        out
    }

    fn build(sky: &TwilightSky) -> DiffuseField {
        let n_fine = sky.spectral.wavelength_nm.len();
        let mut coarse: Vec<usize> = (0..n_fine).step_by(FIELD_WAVELENGTH_STRIDE).collect();
        if coarse.last() != Some(&(n_fine - 1)) {
            coarse.push(n_fine - 1);
        }
        let heights_km: Vec<f64> = FIELD_HEIGHTS_KM
            .iter()
            .map(|h| (sky.site_height_km + h).min(ATMOSPHERE_TOP_KM - 1.0))
            .collect();
        let elevations_deg = field_elevations_deg();
        let rule: Vec<(f64, f64)> =
            crate::quadrature::legendre_roots_01_weights(FIELD_SLANT_NODES, 1e-15)
                .into_iter()
                .map(|(z, w)| (0.5 * (1.0 - z), w))
                .collect();
        let mut field = DiffuseField {
            heights_km,
            elevations_deg,
            coarse,
            n_fine,
            orders: Vec::new(),
            log_total: Vec::new(),
            transfer: Vec::new(),
            moments: Vec::new(),
            aerosol_asymmetry: sky.atmosphere.aerosol_asymmetry,
        };
        let nodes: Vec<(f64, f64)> = field
            .heights_km
            .iter()
            .flat_map(|&h| field.elevations_deg.iter().map(move |&e| (h, e)))
            .collect();
        let s = &sky.spectral;
        // J₁: the angle average of the single-scattered radiance at each
        // node, with its second moments (the Rayleigh phase is quadratic in
        // the scattering cosine, so J and ∫ L d dᵀ dΩ/4π give the first
        // order's Rayleigh source in any direction exactly)
        let mut j1 = Vec::with_capacity(nodes.len());
        let mut moments = Vec::with_capacity(nodes.len());
        for &node in &nodes {
            let (j, m) = Self::single_scattering(sky, &field.coarse, &rule, node);
            j1.push(j);
            moments.push(m);
        }
        field.orders.push(j1);
        // J_{n+1}: the angle average of the radiance J_n scatters towards
        // each node (isotropic scattering of the diffuse field); with it the
        // node's transfer probability f: the share of light emitted
        // isotropically there that is scattered again before it leaves the
        // atmosphere or reaches the (black) ground
        let mut transfer = vec![vec![0.0; field.coarse.len()]; nodes.len()];
        field.moments = moments;
        for order in 1..FIELD_ORDERS {
            let prev = field.orders.last().cloned().unwrap_or_default();
            let mut next = Vec::with_capacity(nodes.len());
            for (n, &(h, e)) in nodes.iter().enumerate() {
                let r = EARTH_RADIUS_KM + h;
                let p = [0.0, 0.0, r];
                let e = e.to_radians();
                let sun = [e.cos(), 0.0, e.sin()];
                let mut j = vec![0.0; field.coarse.len()];
                let mut f = vec![0.0; field.coarse.len()];
                for (d, w) in Self::directions(r) {
                    let samples = sky.march_from(p, d, sun, FIELD_SAMPLES, d[2] >= 0.0, None);
                    // J₁ scatters towards P with the phase functions (as it
                    // does towards the observer), later orders isotropically
                    let sources: Vec<(Vec<f64>, Vec<f64>)> = samples
                        .iter()
                        .map(|q| {
                            if order == 1 {
                                field.first_order_coarse(q.pos, q.radius_km, q.mu_sun, sun, d)
                            } else {
                                let j = field.coarse_at(&prev, q.radius_km, q.mu_sun);
                                (j.clone(), j)
                            }
                        })
                        .collect();
                    for (c, &i) in field.coarse.iter().enumerate() {
                        let (mut l, mut t) = (0.0, 0.0);
                        for (q, (src_r, src_a)) in samples.iter().zip(&sources) {
                            let b_r = s.tau_rayleigh[i] * q.dens.rayleigh;
                            let b_a = s.tau_aerosol_scattering[i] * q.dens.aerosol;
                            let k = q.dt * (-sky.optical_depth(i, &q.to_start)).exp();
                            l += k * (b_r * src_r[c] + b_a * src_a[c]);
                            t += k * (b_r + b_a);
                        }
                        j[c] += w * l / FOUR_PI;
                        f[c] += w * t / FOUR_PI;
                    }
                }
                transfer[n] = f;
                next.push(j);
            }
            field.orders.push(next);
        }
        field.log_total = log_total(&field.orders, &transfer);
        field.transfer = transfer;
        field
    }

    /// J₁ at one node (height km, solar elevation °): the angle average of
    /// the single-scattered radiance per coarse wavelength, with its second
    /// moments (normalised by J; isotropic where J is 0).
    fn single_scattering(
        sky: &TwilightSky,
        coarse: &[usize],
        rule: &[(f64, f64)],
        (h, e): (f64, f64),
    ) -> (Vec<f64>, Vec<[f64; 6]>) {
        let s = &sky.spectral;
        let r = EARTH_RADIUS_KM + h;
        let p = [0.0, 0.0, r];
        let e = e.to_radians();
        let sun = [e.cos(), 0.0, e.sin()];
        let mut j = vec![0.0; coarse.len()];
        let mut m = vec![[0.0; 6]; coarse.len()];
        for (d, w) in Self::directions(r) {
            let samples = sky.march_from(p, d, sun, FIELD_SAMPLES, d[2] >= 0.0, Some(rule));
            let dd = [
                d[0] * d[0],
                d[1] * d[1],
                d[2] * d[2],
                d[0] * d[2],
                d[0],
                d[2],
            ];
            let cos_theta = dot(d, sun).clamp(-1.0, 1.0);
            // sunlight (travelling along −sun) turned towards P (along
            // −d): the scattering angle's cosine is d · sun
            let p_r = rayleigh_phase(cos_theta);
            let p_a = henyey_greenstein_phase(cos_theta, sky.atmosphere.aerosol_asymmetry);
            for (c, &i) in coarse.iter().enumerate() {
                let mut l = 0.0;
                for q in &samples {
                    let Some(to_sun) = &q.to_sun else { continue };
                    let b = s.tau_rayleigh[i] * q.dens.rayleigh * p_r
                        + s.tau_aerosol_scattering[i] * q.dens.aerosol * p_a;
                    let tau = sky.optical_depth(i, &q.to_start) + sky.optical_depth(i, to_sun);
                    l += q.dt * b * (-tau).exp();
                }
                let jw = w * s.solar_w_m2_nm[i] * l / (FOUR_PI * FOUR_PI);
                j[c] += jw;
                for (mk, dk) in m[c].iter_mut().zip(dd) {
                    *mk += jw * dk;
                }
            }
        }
        for (mc, &jc) in m.iter_mut().zip(&j) {
            if jc > 0.0 {
                mc.iter_mut().for_each(|mk| *mk /= jc);
            } else {
                *mc = [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0, 0.0, 0.0, 0.0];
            }
        }
        (j, m)
    }

    /// Bilinear weights `[(node, weight)]` for a point, or None below the
    /// table's lowest local solar elevation (no field there).
    fn weights(&self, radius_km: f64, mu_sun: f64) -> Option<[(usize, f64); 4]> {
        let e = mu_sun.clamp(-1.0, 1.0).asin().to_degrees();
        let es = &self.elevations_deg;
        if e < es[0] {
            return None;
        }
        let h = radius_km - EARTH_RADIUS_KM;
        let locate = |g: &[f64], x: f64| -> (usize, f64) {
            let x = x.clamp(g[0], g[g.len() - 1]);
            let i = g.partition_point(|&v| v <= x).clamp(1, g.len() - 1) - 1;
            (i, ((x - g[i]) / (g[i + 1] - g[i])).clamp(0.0, 1.0))
        };
        let (k, fk) = locate(&self.heights_km, h);
        let (j, fj) = locate(es, e);
        let ne = es.len();
        Some([
            (k * ne + j, (1.0 - fk) * (1.0 - fj)),
            (k * ne + j + 1, (1.0 - fk) * fj),
            ((k + 1) * ne + j, fk * (1.0 - fj)),
            ((k + 1) * ne + j + 1, fk * fj),
        ])
    }

    /// One order's field at a point on the field's wavelengths
    /// (log-bilinear: the field is exponential in height and elevation).
    fn coarse_at(&self, table: &[Vec<f64>], radius_km: f64, mu_sun: f64) -> Vec<f64> {
        match self.weights(radius_km, mu_sun) {
            Some(w) => self.coarse_with(table, &w),
            None => vec![0.0; self.coarse.len()],
        }
    }

    /// [`Self::coarse_at`] at a point's bilinear weights `w`.
    fn coarse_with(&self, table: &[Vec<f64>], w: &[(usize, f64); 4]) -> Vec<f64> {
        (0..self.coarse.len())
            .map(|c| {
                let l: f64 = w
                    .iter()
                    .map(|&(n, f)| f * table[n][c].max(1e-300).ln())
                    .sum();
                l.exp()
            })
            .collect()
    }

    /// The first order J₁ at a point scattered along `view` (unit; the
    /// light leaves towards −view), per unit scattering coefficient on the
    /// field's wavelengths at 1 AU: `(Rayleigh, aerosol)`. Rayleigh through
    /// J₁'s second moments (exact: the phase function is quadratic in the
    /// cosine); aerosol through the Henyey–Greenstein Legendre series to
    /// second order, `1 + 3g P₁ + 5g² P₂` (the part the first and second
    /// moments see; clamped at zero).
    fn first_order_coarse(
        &self,
        pos: [f64; 3],
        radius_km: f64,
        mu_sun: f64,
        sun: [f64; 3],
        view: [f64; 3],
    ) -> (Vec<f64>, Vec<f64>) {
        let nc = self.coarse.len();
        let Some(w) = self.weights(radius_km, mu_sun) else {
            return (vec![0.0; nc], vec![0.0; nc]);
        };
        let j1 = self.coarse_with(&self.orders[0], &w);
        self.first_order_with(&w, &j1, pos, radius_km, sun, view)
    }

    /// [`Self::first_order_coarse`] at a point's bilinear weights `w` and
    /// first order `j1` (the source computes both once).
    fn first_order_with(
        &self,
        w: &[(usize, f64); 4],
        j1: &[f64],
        pos: [f64; 3],
        radius_km: f64,
        sun: [f64; 3],
        view: [f64; 3],
    ) -> (Vec<f64>, Vec<f64>) {
        let nc = self.coarse.len();
        let (mut out_r, mut out_a) = (vec![0.0; nc], vec![0.0; nc]);
        // the view direction in the point's frame (z up, Sun in x–z)
        let up = [pos[0] / radius_km, pos[1] / radius_km, pos[2] / radius_km];
        let sx = add(sun, up, -dot(sun, up));
        let ns = norm(sx);
        let x = if ns > 1e-12 {
            [sx[0] / ns, sx[1] / ns, sx[2] / ns]
        } else {
            [1.0, 0.0, 0.0]
        };
        let (vx, vz) = (dot(view, x), dot(view, up));
        let vy2 = (1.0 - vx * vx - vz * vz).max(0.0);
        let (a, b) = rayleigh_phase_coefficients();
        let g = self.aerosol_asymmetry;
        for c in 0..nc {
            let mut m = [0.0; 6];
            for &(n, f) in w {
                for (mk, v) in m.iter_mut().zip(self.moments[n][c]) {
                    *mk += f * v;
                }
            }
            let quad = m[0] * vx * vx + m[1] * vy2 + m[2] * vz * vz + 2.0 * m[3] * vx * vz;
            let lin = m[4] * vx + m[5] * vz;
            let hg = 1.0 + 3.0 * g * lin + 2.5 * g * g * (3.0 * quad - 1.0);
            out_r[c] = j1[c] * (a + b * quad);
            out_a[c] = j1[c] * hg.max(0.0);
        }
        (out_r, out_a)
    }

    /// The multiple-scattering source at a point seen along `view` (unit,
    /// from the observer), on the full wavelength grid, scaled by
    /// `solar_scale`: `(for Rayleigh, for aerosol)`, per unit scattering
    /// coefficient. The first order J₁ scatters with the Rayleigh phase
    /// function through its second moments (exact: the phase function is
    /// quadratic), and with the aerosol's Henyey–Greenstein phase function
    /// through its Legendre series to second order, `1 + 3g P₁ + 5g² P₂`
    /// (the part of it that the field's first and second moments see;
    /// clamped at zero); the later orders scatter isotropically.
    fn source(
        &self,
        pos: [f64; 3],
        radius_km: f64,
        mu_sun: f64,
        sun: [f64; 3],
        view: [f64; 3],
        solar_scale: f64,
    ) -> (Vec<f64>, Vec<f64>) {
        let nc = self.coarse.len();
        let (mut rayleigh, mut aerosol) = (vec![0.0; self.n_fine], vec![0.0; self.n_fine]);
        let Some(w) = self.weights(radius_km, mu_sun) else {
            return (rayleigh, aerosol);
        };
        let j1 = self.coarse_with(&self.orders[0], &w);
        let (first_r, first_a) = self.first_order_with(&w, &j1, pos, radius_km, sun, view);
        let mut cr = vec![0.0; nc];
        let mut ca = vec![0.0; nc];
        for c in 0..nc {
            let l: f64 = w.iter().map(|&(n, f)| f * self.log_total[n][c]).sum();
            let total = l.exp();
            cr[c] = solar_scale * (total + first_r[c] - j1[c]);
            ca[c] = solar_scale * (total + first_a[c] - j1[c]);
        }
        for c in 0..nc - 1 {
            let (i0, i1) = (self.coarse[c], self.coarse[c + 1]);
            for i in i0..=i1 {
                let f = (i - i0) as f64 / (i1 - i0) as f64;
                rayleigh[i] = cr[c] * (1.0 - f) + cr[c + 1] * f;
                aerosol[i] = ca[c] * (1.0 - f) + ca[c + 1] * f;
            }
        }
        (rayleigh, aerosol)
    }
}

/// ln of the total diffuse source per node and coarse wavelength: the
/// explicit orders plus a geometric tail, each further order the last one
/// times the local transfer probability f (J_N f/(1 − f), the closure of
/// Hillaire 2020 applied past order N).
fn log_total(orders: &[Vec<Vec<f64>>], transfer: &[Vec<f64>]) -> Vec<Vec<f64>> {
    (0..transfer.len())
        .map(|k| {
            (0..transfer[k].len())
                .map(|c| {
                    let t: f64 = orders.iter().map(|o| o[k][c]).sum();
                    let last = orders.last().map_or(0.0, |o| o[k][c]);
                    let f = transfer[k][c].clamp(0.0, FIELD_MAX_TRANSFER);
                    (t + last * f / (1.0 - f)).max(1e-300).ln()
                })
                .collect()
        })
        .collect()
}

/// `(A, B)` with the Rayleigh phase function `A + B cos²θ`
/// ([`rayleigh_phase`]; `A + B/3 = 1`).
fn rayleigh_phase_coefficients() -> (f64, f64) {
    let a = rayleigh_phase(0.0);
    (a, rayleigh_phase(1.0) - a)
}

/// One sample of a ray march (see [`TwilightSky::march_from`]).
#[derive(Clone, Copy, Debug)]
struct PathSample {
    dt: f64,
    dens: Columns,
    to_start: Columns,
    pos: [f64; 3],
    radius_km: f64,
    mu_sun: f64,
    to_sun: Option<Columns>,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn add(p: [f64; 3], d: [f64; 3], t: f64) -> [f64; 3] {
    [p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sky(elevation_deg: f64, options: TwilightOptions) -> TwilightSky {
        let a = Atmosphere::new(0.0, 23.0).unwrap();
        TwilightSky::new(elevation_deg, 270.0, 0.0, a, options).unwrap()
    }

    fn band(s: &[(f64, f64)], lo: f64, hi: f64) -> f64 {
        s.iter()
            .filter(|p| p.0 >= lo && p.0 <= hi)
            .map(|p| p.1)
            .sum()
    }

    #[test]
    fn bad_inputs_are_errors() {
        let a = Atmosphere::new(0.0, 23.0).unwrap();
        let o = TwilightOptions::default();
        assert!(TwilightSky::new(-18.5, 0.0, 0.0, a, o).is_err());
        assert!(TwilightSky::new(f64::NAN, 0.0, 0.0, a, o).is_err());
        assert!(TwilightSky::new(-5.0, 0.0, 20_000.0, a, o).is_err());
        let bad = TwilightOptions {
            ozone_column_du: -1.0,
            ..o
        };
        assert!(TwilightSky::new(-5.0, 0.0, 0.0, a, bad).is_err());
        let s = sky(-6.0, o);
        assert!(
            s.radiance_w_m2_sr_nm([0.0, 0.0, 0.0])
                .iter()
                .all(|p| p.1 == 0.0)
        );
        assert!(
            s.radiance_w_m2_sr_nm([1.0, 0.0, -0.1])
                .iter()
                .all(|p| p.1 == 0.0)
        );
        assert!(
            s.radiance_w_m2_sr_nm([f64::NAN, 0.0, 1.0])
                .iter()
                .all(|p| p.1 == 0.0)
        );
        assert!(s.direct_normal_w_m2_nm().iter().all(|p| p.1 == 0.0));
    }

    #[test]
    fn earth_shadow_geometry() {
        // Sun 18° down: a point 50 km straight up is in the shadow (the
        // shadow's height at the zenith is R (1/cos 18° − 1) ≈ 328 km)
        let s = sky(-18.0, TwilightOptions::default());
        let up = [0.0, 0.0, EARTH_RADIUS_KM + 50.0];
        assert!(s.sun_columns(up).is_none());
        // Sun 2° down: 50 km up is lit (shadow height ≈ 3.9 km)
        let s = sky(-2.0, TwilightOptions::default());
        let c = s.sun_columns(up).unwrap();
        assert!(c.rayleigh > 0.0 && c.rayleigh < 1.0, "{c:?}");
        // the zenith sun's vertical column from the ground is one airmass
        let s = sky(90.0, TwilightOptions::default());
        let c = s.sun_columns(s.observer_km()).unwrap();
        assert!((c.rayleigh - 1.0).abs() < 2e-3, "{c:?}");
        assert!((c.ozone_du - 300.0).abs() < 1.0, "{c:?}");
    }

    #[test]
    fn sun_up_agrees_with_the_plane_parallel_beam() {
        // with the Sun well up, curvature is negligible: the direct beam
        // matches exp(−τ m) with m = 1/sin h (ozone off for a like test)
        let o = TwilightOptions {
            ozone_column_du: 0.0,
            multiple_scattering: false,
        };
        let s = sky(60.0, o);
        let a = Atmosphere::new(0.0, 23.0).unwrap();
        for (w, e) in s.direct_normal_w_m2_nm() {
            let t = (-a.optical_depths(w).total() / 60f64.to_radians().sin()).exp();
            let e0 = solar_etr_w_m2_nm(w).unwrap();
            assert!((e / (e0 * t) - 1.0).abs() < 5e-3, "{w}: {e} vs {}", e0 * t);
        }
    }

    #[test]
    fn ozone_dims_the_deep_twilight_zenith_mostly_in_the_chappuis_band() {
        // physical law in place of published band ratios (none found in
        // time, see docs/night-sky.md): at −12° the zenith light has crossed
        // the ozone layer on a long grazing path, so removing ozone raises
        // it most where the Chappuis cross-section peaks (500–700 nm)
        let with = sky(-12.0, TwilightOptions::default());
        let without = sky(
            -12.0,
            TwilightOptions {
                ozone_column_du: 0.0,
                ..TwilightOptions::default()
            },
        );
        let zenith = [0.0, 0.0, 1.0];
        let (l1, l0) = (
            with.radiance_w_m2_sr_nm(zenith),
            without.radiance_w_m2_sr_nm(zenith),
        );
        let gain = |lo, hi| band(&l0, lo, hi) / band(&l1, lo, hi);
        let (blue, chappuis, nir) = (gain(400.0, 450.0), gain(550.0, 650.0), gain(850.0, 950.0));
        println!(
            "ozone-free / ozone at -12° zenith: 400-450 {blue:.2}, 550-650 {chappuis:.2}, 850-950 {nir:.2}"
        );
        assert!(chappuis > 2.0 * blue && chappuis > 2.0 * nir);
        // civil twilight's zenith is bluer than the sunlit zenith (the
        // Chappuis band eats the orange), and the nautical zenith, lit by
        // light scattered down from the sunlit shell, stays blue (with the
        // older "every parcel sees the observer's sky" second order it came
        // out slightly red, 0.94)
        let ratio = |e: f64| {
            let l = sky(e, TwilightOptions::default()).radiance_w_m2_sr_nm(zenith);
            band(&l, 430.0, 470.0) / band(&l, 600.0, 640.0)
        };
        let (day, civil, nautical) = (ratio(10.0), ratio(-6.0), ratio(-12.0));
        println!("zenith blue/red: +10° {day:.2}, -6° {civil:.2}, -12° {nautical:.2}");
        assert!(civil > day);
        assert!(nautical > 1.0);
    }

    #[test]
    fn multiple_scattering_with_the_sun_high_matches_the_plane_parallel_budget() {
        // Sun high, curvature negligible: the plane-parallel single-scattering
        // budget (crate::atmosphere) names the share of the incident light
        // that single scattering leaves in the air, scattered again
        // (`higher_orders`). About half of it goes down on its next
        // scattering, less what aerosol absorbs or scatters up again, more
        // where forward-scattering aerosol sends the light on downwards: the
        // model's added diffuse light must be a like share of it, and never
        // more than all of it (energy)
        let on = TwilightOptions {
            ozone_column_du: 0.0,
            multiple_scattering: true,
        };
        let off = TwilightOptions {
            multiple_scattering: false,
            ..on
        };
        for (vis, elev) in [(23.0, 60.0), (23.0, 30.0), (1000.0, 60.0)] {
            let a = Atmosphere::new(0.0, vis).unwrap();
            let with = TwilightSky::new(elev, 180.0, 0.0, a, on).unwrap();
            let without = TwilightSky::new(elev, 180.0, 0.0, a, off).unwrap();
            let (d1, d0) = (
                with.diffuse_horizontal_w_m2_nm(),
                without.diffuse_horizontal_w_m2_nm(),
            );
            let exo = with.solar_exo_w_m2_nm();
            let mut pp = a;
            pp.airmass = crate::atmosphere::AirmassModel::PlaneParallel;
            let ss = pp.single_scattering(elev, 180.0).unwrap();
            for i in [20, 50, 100] {
                let w = d0[i].0;
                let budget = ss.energy_budget(w).unwrap();
                let incident = exo[i].1 * elev.to_radians().sin();
                let single = d0[i].1 / incident;
                let added = (d1[i].1 - d0[i].1) / incident;
                let share = added / budget.higher_orders;
                println!(
                    "V {vis} km, sun {elev}°, {w} nm: single {single:.4} (plane-parallel {:.4}), \
                     added {added:.4} = {share:.3} of the higher orders {:.4}",
                    budget.diffuse_down, budget.higher_orders
                );
                assert!((single / budget.diffuse_down - 1.0).abs() < 0.03);
                assert!(share > 0.25 && share < 0.75, "{share}");
            }
        }
    }

    #[test]
    fn sunlit_energy_stays_below_the_incident() {
        let o = TwilightOptions::default();
        for elev in [60.0, 30.0, 10.0, 2.0] {
            let s = sky(elev, o);
            let (dir, dif, exo) = (
                s.direct_horizontal_w_m2_nm(),
                s.diffuse_horizontal_w_m2_nm(),
                s.solar_exo_w_m2_nm(),
            );
            for i in 0..exo.len() {
                let f = (dir[i].1 + dif[i].1) / (exo[i].1 * elev.to_radians().sin());
                assert!(f > 0.0 && f < 1.0, "sun {elev}°, {} nm: {f}", exo[i].0);
            }
        }
    }

    #[test]
    fn the_diffuse_field_fades_into_the_shadow_and_its_orders_converge() {
        let s = sky(-6.0, TwilightOptions::default());
        let f = s.diffuse.clone().unwrap();
        let c = f
            .coarse
            .iter()
            .position(|&i| (s.spectral.wavelength_nm[i] - 540.0).abs() < 1.0)
            .unwrap();
        let ne = f.elevations_deg.len();
        let node =
            |k: usize, e: f64| k * ne + f.elevations_deg.iter().position(|&x| x == e).unwrap();
        for k in 0..f.heights_km.len() {
            // the field falls as the local Sun sinks below the horizon
            let j1 = |e| f.orders[0][node(k, e)][c];
            assert!(j1(0.0) > j1(-6.0) && j1(-6.0) > j1(-12.0) && j1(-12.0) > 0.0);
            // sunlit: each order is a fraction of the one before
            let n = node(k, 40.0);
            let (a, b, d) = (f.orders[0][n][c], f.orders[1][n][c], f.orders[2][n][c]);
            assert!(b < 0.5 * a && d < 0.5 * b, "{a} {b} {d}");
            // the transfer probability is a probability, and visible light
            // is mostly not scattered again
            let t = f.transfer[n][c];
            assert!(t > 0.0 && t < 0.5, "{t}");
            // the second moments' trace is J itself
            let m = f.moments[n][c];
            assert!((m[0] + m[1] + m[2] - 1.0).abs() < 1e-9, "{m:?}");
        }
        // in the shadow, the air above the ground is lit far more by the
        // sunlit shell than the ground-level air is: the reason the old
        // "every parcel sees the observer's sky" term fell short
        let (low, high) = (
            f.orders[0][node(0, -12.0)][c],
            f.orders[0][node(5, -12.0)][c],
        );
        assert!(high > 50.0 * low, "{low} {high}");
    }
}
