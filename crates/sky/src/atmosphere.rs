//! Clear-sky atmosphere for moonlight: extinction, direct transmission and
//! the single-scattered sky radiance.
//!
//! * Airmass: Kasten & Young (1989), Appl. Opt. 28, 4735:
//!   `m = 1 / (sin h + 0.50572 (h + 6.07995°)^−1.6364)`, h elevation in
//!   degrees (the geometric elevation is used). [`AirmassModel::PlaneParallel`]
//!   (`1/sin h`) is available and is what makes the energy budget exact to
//!   first order.
//! * Rayleigh optical depth: Bodhaine et al. (1999), J. Atmos. Ocean.
//!   Tech. 16, 1854, eq. 30 (sea level, 1013.25 hPa, 360 ppm CO₂), scaled by
//!   `P/1013.25 hPa`; P defaults to the ICAO standard atmosphere at the site
//!   height, `1013.25 (1 − 2.25577×10⁻⁵ h)^5.25588`. Rayleigh phase function
//!   with King-factor depolarisation ρ = 0.0279.
//! * Aerosol: Koschmieder, total β_ext(550 nm) = 3.912 / V (V the
//!   meteorological visibility at the site, km); the aerosol part is that
//!   minus the Rayleigh extinction coefficient at the site
//!   (`τ_R(550)·(P/1013.25)/8.43 km`), clamped at 0. Aerosol is
//!   exponentially distributed above the site with scale height H_a, so
//!   `τ_a(550) = β_a H_a`; spectral dependence by Ångström's law
//!   `τ_a(λ) = τ_a(550) (λ/550)^−α`. Single-scattering albedo ω_a, and a
//!   Henyey–Greenstein phase function with asymmetry g.
//! * Sky radiance: plane-parallel, single scattering, Rayleigh and aerosol
//!   taken as uniformly mixed in optical depth, ground albedo 0, no
//!   ozone/water absorption. Looking up along a direction with airmass m
//!   at a source with airmass m₀ (exo irradiance E₀ normal to the beam):
//!   `L = E₀/(4π) [τ_R P_R(Θ) + ω_a τ_a P_HG(Θ)] · m · e^{−τ m₀} · h(τ(m − m₀))`,
//!   `h(x) = (1 − e^{−x})/x`, which is the exact integral of the single
//!   scattering source along the line of sight. The diffuse horizontal
//!   irradiance integrates `L sin(e)` over the dome numerically: 96-point
//!   Gauss–Legendre in sin(e) times a 256-point periodic trapezoid in
//!   azimuth, in f64.
//! * Light from a source below the (geometric) horizon is not modelled
//!   (no twilight): direct and scattered moonlight are then 0.

use crate::error::{Result, SkyError, check_range};
use crate::spectral::Samples;

const DEG: f64 = std::f64::consts::PI / 180.0;
const FOUR_PI: f64 = 4.0 * std::f64::consts::PI;
/// Standard sea-level pressure, hPa.
pub const SEA_LEVEL_PRESSURE_HPA: f64 = 1013.25;
/// Rayleigh (molecular) scale height used to convert τ_R to β_R at the site, km.
pub const RAYLEIGH_SCALE_HEIGHT_KM: f64 = 8.43;
/// Koschmieder constant: visibility = 3.912 / β_ext for a 2 % contrast threshold.
pub const KOSCHMIEDER_CONSTANT: f64 = 3.912;
/// Depolarisation factor of air used in the Rayleigh phase function.
pub const RAYLEIGH_DEPOLARISATION: f64 = 0.0279;

/// Which airmass formula to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AirmassModel {
    /// Kasten & Young (1989) — the default, finite (≈ 38) at the horizon.
    #[default]
    KastenYoung,
    /// Plane-parallel `1/sin h`, infinite at the horizon (energy-consistent).
    PlaneParallel,
}

/// Kasten & Young (1989) relative optical airmass at elevation
/// `elevation_deg` (clamped to [0, 90]).
pub fn kasten_young_airmass(elevation_deg: f64) -> f64 {
    let h = elevation_deg.clamp(0.0, 90.0);
    1.0 / ((h * DEG).sin() + 0.50572 * (h + 6.07995).powf(-1.6364))
}

impl AirmassModel {
    /// Airmass at an elevation (degrees). Plane-parallel airmass is capped at
    /// 1e6 (elevation → 0).
    pub fn airmass(&self, elevation_deg: f64) -> f64 {
        match self {
            AirmassModel::KastenYoung => kasten_young_airmass(elevation_deg),
            AirmassModel::PlaneParallel => {
                let s = (elevation_deg.clamp(0.0, 90.0) * DEG).sin();
                if s > 1e-6 { 1.0 / s } else { 1e6 }
            }
        }
    }
}

/// Rayleigh optical depth of the whole atmosphere at sea level (1013.25 hPa),
/// Bodhaine et al. (1999) eq. 30, λ in nm (valid ≈ 250–4000 nm).
pub fn rayleigh_optical_depth_sea_level(wavelength_nm: f64) -> f64 {
    let l = wavelength_nm / 1000.0;
    let l2 = l * l;
    0.002_152_0 * (1.045_599_6 - 341.290_61 / l2 - 0.902_308_50 * l2)
        / (1.0 + 0.002_705_988_9 / l2 - 85.968_563 * l2)
}

/// ICAO standard-atmosphere pressure at a height, hPa.
pub fn standard_pressure_hpa(height_m: f64) -> f64 {
    let x = (1.0 - 2.255_77e-5 * height_m.clamp(-500.0, 11_000.0)).max(0.0);
    SEA_LEVEL_PRESSURE_HPA * x.powf(5.255_88)
}

/// Rayleigh phase function (normalised: ∫P dΩ = 4π) with depolarisation.
pub fn rayleigh_phase(cos_theta: f64) -> f64 {
    let rho = RAYLEIGH_DEPOLARISATION;
    let gamma = rho / (2.0 - rho);
    3.0 / (4.0 * (1.0 + 2.0 * gamma))
        * ((1.0 + 3.0 * gamma) + (1.0 - gamma) * cos_theta * cos_theta)
}

/// Henyey–Greenstein phase function (normalised: ∫P dΩ = 4π).
pub fn henyey_greenstein_phase(cos_theta: f64, g: f64) -> f64 {
    let g2 = g * g;
    (1.0 - g2) / (1.0 + g2 - 2.0 * g * cos_theta).max(1e-300).powf(1.5)
}

/// `(1 − e^{−x})/x`, 1 at x = 0, stable for any finite x.
fn one_minus_exp_over(x: f64) -> f64 {
    if x.abs() < 1e-10 {
        1.0 - 0.5 * x
    } else {
        -(-x).exp_m1() / x
    }
}

/// Optical depths of the atmosphere above the site at one wavelength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OpticalDepths {
    /// Rayleigh scattering optical depth.
    pub rayleigh: f64,
    /// Aerosol extinction optical depth.
    pub aerosol_extinction: f64,
    /// Aerosol scattering optical depth (ω_a × extinction).
    pub aerosol_scattering: f64,
}

impl OpticalDepths {
    /// Total extinction optical depth.
    pub fn total(&self) -> f64 {
        self.rayleigh + self.aerosol_extinction
    }
}

/// A clear-sky atmosphere above a site.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Atmosphere {
    /// Surface pressure at the site, hPa (scales Rayleigh).
    pub pressure_hpa: f64,
    /// Meteorological visibility at the site, km (Koschmieder).
    pub visibility_km: f64,
    /// Ångström exponent α of the aerosol (default 1.3).
    pub angstrom_exponent: f64,
    /// Aerosol scale height above the site, km (default 1.2; 0 removes the
    /// aerosol altogether).
    pub aerosol_scale_height_km: f64,
    /// Aerosol single-scattering albedo ω_a (default 0.9).
    pub aerosol_single_scattering_albedo: f64,
    /// Henyey–Greenstein asymmetry parameter g (default 0.7).
    pub aerosol_asymmetry: f64,
    /// Airmass formula (default Kasten–Young).
    pub airmass: AirmassModel,
}

impl Atmosphere {
    /// Default atmosphere for a site height and visibility (standard
    /// pressure at that height). `site_height_m` in [−500, 10000],
    /// `visibility_km` in [0.05, 1000].
    pub fn new(site_height_m: f64, visibility_km: f64) -> Result<Self> {
        check_range("site_height_m", site_height_m, -500.0, 10_000.0)?;
        let a = Self {
            pressure_hpa: standard_pressure_hpa(site_height_m),
            visibility_km,
            angstrom_exponent: 1.3,
            aerosol_scale_height_km: 1.2,
            aerosol_single_scattering_albedo: 0.9,
            aerosol_asymmetry: 0.7,
            airmass: AirmassModel::KastenYoung,
        };
        a.validate()?;
        Ok(a)
    }

    /// Check every field's range (call after changing fields directly).
    pub fn validate(&self) -> Result<()> {
        check_range("pressure_hpa", self.pressure_hpa, 0.0, 1100.0)?;
        check_range("visibility_km", self.visibility_km, 0.05, 1000.0)?;
        check_range("angstrom_exponent", self.angstrom_exponent, -1.0, 4.0)?;
        check_range(
            "aerosol_scale_height_km",
            self.aerosol_scale_height_km,
            0.0,
            20.0,
        )?;
        check_range(
            "aerosol_single_scattering_albedo",
            self.aerosol_single_scattering_albedo,
            0.0,
            1.0,
        )?;
        check_range("aerosol_asymmetry", self.aerosol_asymmetry, -0.95, 0.95)?;
        Ok(())
    }

    /// Aerosol extinction coefficient at 550 nm at the site, km⁻¹
    /// (Koschmieder total minus Rayleigh, ≥ 0).
    pub fn aerosol_extinction_550_per_km(&self) -> f64 {
        let beta_total = KOSCHMIEDER_CONSTANT / self.visibility_km;
        let beta_r = rayleigh_optical_depth_sea_level(550.0) * self.pressure_hpa
            / SEA_LEVEL_PRESSURE_HPA
            / RAYLEIGH_SCALE_HEIGHT_KM;
        (beta_total - beta_r).max(0.0)
    }

    /// Optical depths at a wavelength (nm, must be > 0).
    pub fn optical_depths(&self, wavelength_nm: f64) -> OpticalDepths {
        let w = wavelength_nm.max(1.0);
        let rayleigh = rayleigh_optical_depth_sea_level(w).max(0.0) * self.pressure_hpa
            / SEA_LEVEL_PRESSURE_HPA;
        let tau_a550 = self.aerosol_extinction_550_per_km() * self.aerosol_scale_height_km;
        let aerosol_extinction = tau_a550 * (w / 550.0).powf(-self.angstrom_exponent);
        OpticalDepths {
            rayleigh,
            aerosol_extinction,
            aerosol_scattering: aerosol_extinction * self.aerosol_single_scattering_albedo,
        }
    }

    /// Direct-beam transmittance `exp(−τ m)` at a wavelength for a source at
    /// `elevation_deg` (0 below the horizon).
    pub fn direct_transmittance(&self, wavelength_nm: f64, elevation_deg: f64) -> f64 {
        if elevation_deg.is_nan() || elevation_deg <= 0.0 {
            return 0.0;
        }
        (-self.optical_depths(wavelength_nm).total() * self.airmass.airmass(elevation_deg)).exp()
    }

    /// Prepare single-scattering sky quantities for a source (Moon) at an
    /// elevation and azimuth (degrees, azimuth north through east).
    pub fn single_scattering(
        &self,
        source_elevation_deg: f64,
        source_azimuth_deg: f64,
    ) -> Result<SingleScattering> {
        self.validate()?;
        check_range("source_elevation_deg", source_elevation_deg, -90.0, 90.0)?;
        check_range("source_azimuth_deg", source_azimuth_deg, -360.0, 720.0)?;
        Ok(SingleScattering::new(
            *self,
            source_elevation_deg,
            source_azimuth_deg,
        ))
    }
}

/// Gauss–Legendre nodes (ascending) and weights on [0, 1].
fn gauss_legendre_01(n: usize) -> (Vec<f64>, Vec<f64>) {
    crate::quadrature::legendre_roots_01_weights(n, 1e-15)
        .into_iter()
        .map(|(z, w)| (0.5 * (1.0 - z), w))
        .unzip()
}

/// Number of Gauss–Legendre nodes in sin(elevation) for dome integrals.
pub const DOME_ELEVATION_NODES: usize = 96;
/// Number of azimuth nodes for dome integrals.
pub const DOME_AZIMUTH_NODES: usize = 256;

/// Single-scattering sky for one source direction; all results are per
/// unit exo-atmospheric irradiance E₀ on a surface normal to the source.
#[derive(Clone, Debug)]
pub struct SingleScattering {
    atmosphere: Atmosphere,
    source_enu: [f64; 3],
    source_elevation_deg: f64,
    source_airmass: f64,
    mu: Vec<f64>,
    weight: Vec<f64>,
    // azimuth integrals ∫P dφ of the phase functions at each node, for
    // radiance reaching the ground (down) and leaving the top (up)
    rayleigh_down: Vec<f64>,
    hg_down: Vec<f64>,
    rayleigh_up: Vec<f64>,
    hg_up: Vec<f64>,
}

/// Where the incident moonlight goes (fractions of the horizontal
/// exo-atmospheric irradiance E₀ sin h₀), single scattering.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnergyBudget {
    /// Direct beam reaching the ground.
    pub direct: f64,
    /// Diffuse (sky) irradiance on the ground.
    pub diffuse_down: f64,
    /// Scattered flux leaving the top of the atmosphere.
    pub escaped_up: f64,
    /// Absorbed by aerosol (from the direct beam).
    pub absorbed: f64,
    /// Scattered light extinguished again before leaving (second and
    /// higher orders, not modelled by single scattering): `1 − sum`.
    pub higher_orders: f64,
}

impl SingleScattering {
    fn new(atmosphere: Atmosphere, source_elevation_deg: f64, source_azimuth_deg: f64) -> Self {
        let (mu, weight) = gauss_legendre_01(DOME_ELEVATION_NODES);
        let n_phi = DOME_AZIMUTH_NODES;
        let dphi = 2.0 * std::f64::consts::PI / n_phi as f64;
        let s = source_elevation_deg * DEG;
        let (mu0, sin0) = (s.sin(), s.cos());
        let g = atmosphere.aerosol_asymmetry;
        let mut rd = Vec::with_capacity(mu.len());
        let mut hd = Vec::with_capacity(mu.len());
        let mut ru = Vec::with_capacity(mu.len());
        let mut hu = Vec::with_capacity(mu.len());
        for &m in &mu {
            let st = (1.0 - m * m).max(0.0).sqrt();
            let (mut a, mut b, mut c, mut d) = (0.0, 0.0, 0.0, 0.0);
            for j in 0..n_phi {
                let cphi = (j as f64 * dphi).cos();
                // looking up at elevation asin(m): cos Θ = s·v
                let cd = (mu0 * m + sin0 * st * cphi).clamp(-1.0, 1.0);
                // escaping upward at elevation asin(m): cos Θ = (−s)·u
                let cu = (-mu0 * m + sin0 * st * cphi).clamp(-1.0, 1.0);
                a += rayleigh_phase(cd);
                b += henyey_greenstein_phase(cd, g);
                c += rayleigh_phase(cu);
                d += henyey_greenstein_phase(cu, g);
            }
            rd.push(a * dphi);
            hd.push(b * dphi);
            ru.push(c * dphi);
            hu.push(d * dphi);
        }
        Self {
            atmosphere,
            source_enu: crate::ephemeris::enu_from_elevation_azimuth(
                source_elevation_deg,
                source_azimuth_deg,
            ),
            source_elevation_deg,
            source_airmass: atmosphere.airmass.airmass(source_elevation_deg),
            mu,
            weight,
            rayleigh_down: rd,
            hg_down: hd,
            rayleigh_up: ru,
            hg_up: hu,
        }
    }

    /// True when the source is above the geometric horizon (otherwise all
    /// scattered and direct quantities are 0).
    pub fn source_up(&self) -> bool {
        self.source_elevation_deg > 0.0
    }

    /// Sky radiance from single-scattered source light seen looking along
    /// `view_enu` (need not be normalised; east-north-up), per unit exo
    /// irradiance E₀: L/E₀ in sr⁻¹. 0 for directions at or below the horizon.
    pub fn radiance_per_irradiance_per_sr(&self, wavelength_nm: f64, view_enu: [f64; 3]) -> f64 {
        let n = (view_enu[0].powi(2) + view_enu[1].powi(2) + view_enu[2].powi(2)).sqrt();
        if !self.source_up() || !n.is_finite() || n <= 0.0 || view_enu[2] <= 0.0 {
            return 0.0;
        }
        let v = [view_enu[0] / n, view_enu[1] / n, view_enu[2] / n];
        let cos_t =
            (v[0] * self.source_enu[0] + v[1] * self.source_enu[1] + v[2] * self.source_enu[2])
                .clamp(-1.0, 1.0);
        let elev = v[2].clamp(-1.0, 1.0).asin() / DEG;
        let tau = self.atmosphere.optical_depths(wavelength_nm);
        let m = self.atmosphere.airmass.airmass(elev);
        let phase = tau.rayleigh * rayleigh_phase(cos_t)
            + tau.aerosol_scattering
                * henyey_greenstein_phase(cos_t, self.atmosphere.aerosol_asymmetry);
        let t = tau.total();
        phase / FOUR_PI
            * m
            * (-t * self.source_airmass).exp()
            * one_minus_exp_over(t * (m - self.source_airmass))
    }

    /// Diffuse (sky) irradiance on a horizontal ground surface per unit exo
    /// irradiance E₀ (dimensionless), integrated over the dome.
    pub fn diffuse_down_per_irradiance(&self, wavelength_nm: f64) -> f64 {
        if !self.source_up() {
            return 0.0;
        }
        let tau = self.atmosphere.optical_depths(wavelength_nm);
        let t = tau.total();
        let m0 = self.source_airmass;
        let att = (-t * m0).exp();
        let mut sum = 0.0;
        for i in 0..self.mu.len() {
            let mu = self.mu[i];
            let m = self.atmosphere.airmass.airmass(mu.asin() / DEG);
            let phase =
                tau.rayleigh * self.rayleigh_down[i] + tau.aerosol_scattering * self.hg_down[i];
            sum += self.weight[i] * mu * m * att * one_minus_exp_over(t * (m - m0)) * phase;
        }
        sum / FOUR_PI
    }

    /// Scattered flux leaving the top of the atmosphere per unit E₀.
    pub fn escaped_up_per_irradiance(&self, wavelength_nm: f64) -> f64 {
        if !self.source_up() {
            return 0.0;
        }
        let tau = self.atmosphere.optical_depths(wavelength_nm);
        let t = tau.total();
        let m0 = self.source_airmass;
        let mut sum = 0.0;
        for i in 0..self.mu.len() {
            let mu = self.mu[i];
            let m = self.atmosphere.airmass.airmass(mu.asin() / DEG);
            let phase = tau.rayleigh * self.rayleigh_up[i] + tau.aerosol_scattering * self.hg_up[i];
            sum += self.weight[i] * mu * m * one_minus_exp_over(t * (m + m0)) * phase;
        }
        sum / FOUR_PI
    }

    /// Direct irradiance on a horizontal surface per unit E₀.
    pub fn direct_horizontal_per_irradiance(&self, wavelength_nm: f64) -> f64 {
        if !self.source_up() {
            return 0.0;
        }
        let t = self.atmosphere.optical_depths(wavelength_nm).total();
        (self.source_elevation_deg * DEG).sin() * (-t * self.source_airmass).exp()
    }

    /// Energy budget at one wavelength, as fractions of the incident
    /// horizontal irradiance. Errors if the source is below the horizon.
    pub fn energy_budget(&self, wavelength_nm: f64) -> Result<EnergyBudget> {
        if !self.source_up() {
            return Err(SkyError::Invalid(
                "energy budget needs the source above the horizon".to_string(),
            ));
        }
        let incident = (self.source_elevation_deg * DEG).sin();
        let tau = self.atmosphere.optical_depths(wavelength_nm);
        let t = tau.total();
        let removed = incident * (-(-t * self.source_airmass).exp_m1());
        let absorbed = removed * (tau.aerosol_extinction - tau.aerosol_scattering) / t;
        let direct = self.direct_horizontal_per_irradiance(wavelength_nm) / incident;
        let diffuse_down = self.diffuse_down_per_irradiance(wavelength_nm) / incident;
        let escaped_up = self.escaped_up_per_irradiance(wavelength_nm) / incident;
        let absorbed = absorbed / incident;
        Ok(EnergyBudget {
            direct,
            diffuse_down,
            escaped_up,
            absorbed,
            higher_orders: 1.0 - direct - diffuse_down - escaped_up - absorbed,
        })
    }

    /// Diffuse horizontal irradiance spectrum for an exo irradiance spectrum
    /// `exo_w_m2_nm` (normal to the beam), W m⁻² nm⁻¹.
    pub fn diffuse_down_spectrum(&self, exo_w_m2_nm: &[(f64, f64)]) -> Samples {
        exo_w_m2_nm
            .iter()
            .map(|&(w, e)| (w, e * self.diffuse_down_per_irradiance(w)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kasten_young_values() {
        assert!((kasten_young_airmass(90.0) - 1.0).abs() < 1e-3);
        assert!((kasten_young_airmass(30.0) - 1.9942).abs() < 0.01);
        let h = kasten_young_airmass(0.0);
        assert!(h > 37.0 && h < 39.0, "{h}");
        assert_eq!(kasten_young_airmass(-5.0), h);
    }

    #[test]
    fn bodhaine_values() {
        // Bodhaine et al. 1999 table 3: τ_R(550 nm) ≈ 0.0973 at sea level
        let t = rayleigh_optical_depth_sea_level(550.0);
        assert!((t - 0.0973).abs() < 0.001, "{t}");
        let t4 = rayleigh_optical_depth_sea_level(400.0);
        assert!((t4 - 0.3641).abs() < 0.005, "{t4}");
        assert!((standard_pressure_hpa(0.0) - 1013.25).abs() < 1e-9);
        assert!((standard_pressure_hpa(1500.0) - 845.6).abs() < 1.0);
    }

    #[test]
    fn phase_functions_normalised() {
        let n = 20_000;
        let (mut r, mut h) = (0.0, 0.0);
        for i in 0..n {
            let c = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
            r += rayleigh_phase(c) * 2.0 / n as f64;
            h += henyey_greenstein_phase(c, 0.7) * 2.0 / n as f64;
        }
        assert!((r / 2.0 - 1.0).abs() < 1e-6);
        assert!((h / 2.0 - 1.0).abs() < 1e-3, "{h}");
    }

    #[test]
    fn koschmieder_aerosol() {
        let a = Atmosphere::new(0.0, 23.0).unwrap();
        let b = a.aerosol_extinction_550_per_km();
        assert!((b - (3.912 / 23.0 - 0.0973 / 8.43)).abs() < 1e-3);
        let d = a.optical_depths(550.0);
        assert!((d.aerosol_extinction - b * 1.2).abs() < 1e-12);
        // Ångström: shorter wavelength, more aerosol depth
        assert!(a.optical_depths(400.0).aerosol_extinction > d.aerosol_extinction);
        let clean = Atmosphere::new(0.0, 500.0).unwrap();
        assert_eq!(clean.aerosol_extinction_550_per_km(), 0.0);
        assert!(Atmosphere::new(0.0, 0.0).is_err());
        assert!(Atmosphere::new(0.0, f64::NAN).is_err());
    }

    #[test]
    fn thin_rayleigh_diffuse_is_half_the_scattered() {
        // no aerosol (huge visibility), very low pressure → thin Rayleigh
        for p in [10.0, 1.0] {
            let mut a = Atmosphere::new(0.0, 1000.0).unwrap();
            a.pressure_hpa = p;
            a.aerosol_scale_height_km = 0.0;
            a.airmass = AirmassModel::PlaneParallel;
            let ss = a.single_scattering(90.0, 0.0).unwrap();
            let tau = a.optical_depths(550.0).total();
            let scattered = -(-tau).exp_m1();
            let ratio = ss.diffuse_down_per_irradiance(550.0) / scattered;
            println!("P = {p} hPa, τ = {tau:.2e}: diffuse/scattered = {ratio:.6}");
            assert!((ratio - 0.5).abs() < 0.01 * p / 10.0 + 1e-4, "{ratio}");
        }
    }

    #[test]
    fn energy_is_conserved() {
        // thin atmospheres: single scattering is exact to first order, so
        // direct + diffuse + escaped + absorbed = incident to within 1 %
        for (p, vis, elev) in [
            (50.0, 1000.0, 90.0),
            (50.0, 200.0, 60.0),
            (100.0, 300.0, 45.0),
        ] {
            let mut a = Atmosphere::new(0.0, vis).unwrap();
            a.pressure_hpa = p;
            a.aerosol_scale_height_km = 0.3;
            a.airmass = AirmassModel::PlaneParallel;
            let ss = a.single_scattering(elev, 10.0).unwrap();
            for w in [400.0, 550.0, 900.0] {
                let b = ss.energy_budget(w).unwrap();
                let sum = b.direct + b.diffuse_down + b.escaped_up + b.absorbed;
                println!("thin P={p} V={vis} h={elev} λ={w}: sum {sum:.5} {b:?}");
                assert!((sum - 1.0).abs() < 0.01, "{b:?}");
                assert!(b.absorbed > 0.0);
            }
        }
        // realistic atmospheres: the unaccounted part is second order
        for (vis, elev) in [(1000.0, 90.0), (23.0, 90.0), (23.0, 40.0), (50.0, 20.0)] {
            let mut a = Atmosphere::new(0.0, vis).unwrap();
            a.airmass = AirmassModel::PlaneParallel;
            let ss = a.single_scattering(elev, 123.0).unwrap();
            for w in [400.0, 550.0, 900.0] {
                let b = ss.energy_budget(w).unwrap();
                let tau = a.optical_depths(w).total() / (elev * DEG).sin();
                println!("V={vis} h={elev} λ={w}: {b:?} (slant τ {tau:.3})");
                assert!(b.direct > 0.0 && b.diffuse_down > 0.0 && b.escaped_up > 0.0);
                // what single scattering cannot account for is second order in τ
                assert!(b.higher_orders >= -1e-6, "{b:?}");
                assert!(
                    b.higher_orders < tau * tau * (1.0 + (1.0 / tau).ln().max(0.0)),
                    "{b:?}"
                );
            }
        }
    }

    #[test]
    fn sky_radiance_integrates_to_diffuse() {
        // brute-force dome integral of the radiance function = the fast path
        let a = Atmosphere::new(200.0, 15.0).unwrap();
        let ss = a.single_scattering(35.0, 200.0).unwrap();
        let (ne, na) = (400, 720);
        let mut e = 0.0;
        for i in 0..ne {
            let mu = (i as f64 + 0.5) / ne as f64;
            for j in 0..na {
                let phi = (j as f64 + 0.5) / na as f64 * 2.0 * std::f64::consts::PI;
                let st = (1.0 - mu * mu).sqrt();
                let v = [st * phi.sin(), st * phi.cos(), mu];
                e += ss.radiance_per_irradiance_per_sr(550.0, v) * mu;
            }
        }
        e *= (1.0 / ne as f64) * (2.0 * std::f64::consts::PI / na as f64);
        let fast = ss.diffuse_down_per_irradiance(550.0);
        assert!((e / fast - 1.0).abs() < 2e-3, "{e} vs {fast}");
        // forward scattering: brighter near the moon than opposite it
        let near = crate::ephemeris::enu_from_elevation_azimuth(40.0, 200.0);
        let far = crate::ephemeris::enu_from_elevation_azimuth(40.0, 20.0);
        assert!(
            ss.radiance_per_irradiance_per_sr(550.0, near)
                > 2.0 * ss.radiance_per_irradiance_per_sr(550.0, far)
        );
        assert_eq!(
            ss.radiance_per_irradiance_per_sr(550.0, [0.0, 1.0, -0.1]),
            0.0
        );
        assert_eq!(
            ss.radiance_per_irradiance_per_sr(550.0, [0.0, 0.0, 0.0]),
            0.0
        );
        let below = a.single_scattering(-5.0, 0.0).unwrap();
        assert_eq!(below.diffuse_down_per_irradiance(550.0), 0.0);
        assert!(below.energy_budget(550.0).is_err());
    }
}
