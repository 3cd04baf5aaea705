//! Ground illuminance from the Moon and the night sky, and the sky model a
//! ray tracer uses (moon direction, direct spectral irradiance, sky-dome
//! radiance as a function of direction).
//!
//! Clear sky: direct moonlight `E₀(λ) T(λ) sin h`, sky light from
//! [`crate::atmosphere::SingleScattering`], plus the night-sky background.
//! Overcast: no direct beam; the cloud deck is a uniform dome passing
//! `overcast_transmittance` (default 0.1) of the clear-sky direct + diffuse
//! moonlight, and the night-sky background is scaled by the same factor
//! (≈ 1e-4 lux). Twilight (Sun above −18°) is not modelled: the result
//! flags it instead.

use serde::Serialize;

use crate::atmosphere::{Atmosphere, SingleScattering};
use crate::ephemeris::{Ephemeris, Refraction, Site, ephemeris};
use crate::error::{Result, SkyError, check_range};
use crate::moonlight::{MoonlightOptions, lunar_spectral_irradiance_exo};
use crate::nightsky::{self, night_sky_radiance_w_m2_sr_nm};
use crate::spectral::{self, Samples};
use crate::time::UtcInstant;

const PI: f64 = std::f64::consts::PI;

/// Cloud cover.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Cloud {
    /// Cloudless.
    Clear,
    /// Complete overcast.
    Overcast,
}

impl std::str::FromStr for Cloud {
    type Err = SkyError;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "clear" => Ok(Cloud::Clear),
            "overcast" => Ok(Cloud::Overcast),
            other => Err(SkyError::Invalid(format!(
                "cloud must be \"clear\" or \"overcast\", got {other:?}"
            ))),
        }
    }
}

/// Weather and model settings for [`SkyModel`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyConditions {
    /// Meteorological visibility, km (Koschmieder), default 23 km.
    pub visibility_km: f64,
    /// Cloud cover.
    pub cloud: Cloud,
    /// Fraction of clear-sky light passed by an overcast deck (default 0.1).
    pub overcast_transmittance: f64,
    /// Clear moonless night-sky horizontal illuminance, lux (default 1e-3).
    pub night_sky_clear_lux: f64,
    /// Refraction for the apparent Moon/Sun elevations.
    pub refraction: Refraction,
    /// Lunar model options.
    pub moonlight: MoonlightOptions,
}

impl SkyConditions {
    /// Defaults with the given visibility and cloud.
    pub fn new(visibility_km: f64, cloud: Cloud) -> Result<Self> {
        let c = Self {
            visibility_km,
            cloud,
            overcast_transmittance: nightsky::OVERCAST_FACTOR,
            night_sky_clear_lux: nightsky::CLEAR_MOONLESS_LUX,
            refraction: Refraction::STANDARD,
            moonlight: MoonlightOptions::default(),
        };
        c.validate()?;
        Ok(c)
    }

    /// Check ranges (after editing fields directly).
    pub fn validate(&self) -> Result<()> {
        check_range("visibility_km", self.visibility_km, 0.05, 1000.0)?;
        check_range(
            "overcast_transmittance",
            self.overcast_transmittance,
            0.0,
            1.0,
        )?;
        check_range("night_sky_clear_lux", self.night_sky_clear_lux, 0.0, 1.0)?;
        if let Refraction::Atmosphere {
            pressure_hpa,
            temperature_c,
        } = self.refraction
        {
            Refraction::atmosphere(pressure_hpa, temperature_c)?;
        }
        Ok(())
    }
}

/// Horizontal illuminance on the ground, lux.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct IlluminanceLux {
    /// Direct moonlight.
    pub moon_direct: f64,
    /// Moonlight scattered by the sky (or transmitted by cloud).
    pub moon_sky: f64,
    /// Night-sky background (starlight + airglow).
    pub night_sky: f64,
    /// Sum of the three.
    pub total: f64,
}

/// Horizontal spectral irradiances on the ground, W m⁻² nm⁻¹, on the default
/// grid (300–1100 nm, 5 nm), plus the exo-atmospheric lunar irradiance
/// normal to the beam.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroundSpectra {
    /// Lunar irradiance outside the atmosphere, normal to the rays.
    pub moon_exo_normal_w_m2_nm: Samples,
    /// Direct moonlight on a horizontal surface.
    pub moon_direct_horizontal_w_m2_nm: Samples,
    /// Sky-scattered (or cloud-transmitted) moonlight on a horizontal surface.
    pub moon_sky_horizontal_w_m2_nm: Samples,
    /// Night-sky background on a horizontal surface (π L).
    pub night_sky_horizontal_w_m2_nm: Samples,
    /// Sum of the three horizontal terms.
    pub total_horizontal_w_m2_nm: Samples,
}

/// Result of [`ground_illuminance`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroundIlluminance {
    /// Ephemeris used (Moon/Sun position, phase).
    pub ephemeris: Ephemeris,
    /// Illuminance components, lux.
    pub illuminance_lux: IlluminanceLux,
    /// True when the Sun is above −18°: twilight/daylight is NOT included.
    pub twilight_not_modelled: bool,
    /// Spectral tables when requested.
    pub spectra: Option<GroundSpectra>,
}

/// Everything a renderer needs about the night sky at one instant and site.
#[derive(Clone, Debug)]
pub struct SkyModel {
    ephemeris: Ephemeris,
    conditions: SkyConditions,
    atmosphere: Atmosphere,
    scattering: SingleScattering,
    moon_exo: Samples,
    moon_direct_normal: Samples,
    moon_direct_horizontal: Samples,
    moon_diffuse_horizontal: Samples,
    night_sky_radiance: Samples,
    overcast_moon_radiance: Samples,
}

fn zip_map(a: &[(f64, f64)], f: impl Fn(f64, f64) -> f64) -> Samples {
    a.iter().map(|&(w, v)| (w, f(w, v))).collect()
}

impl SkyModel {
    /// Build the sky for an instant, site and conditions.
    pub fn new(instant: UtcInstant, site: &Site, conditions: &SkyConditions) -> Result<Self> {
        conditions.validate()?;
        let site = Site::new(site.latitude_deg, site.longitude_east_deg, site.height_m)?;
        let eph = ephemeris(instant, &site, conditions.refraction);
        let atmosphere = Atmosphere::new(site.height_m, conditions.visibility_km)?;
        let moon_el = eph.moon.elevation_geometric_deg;
        let scattering = atmosphere.single_scattering(moon_el, eph.moon.azimuth_deg)?;
        let moon_exo = lunar_spectral_irradiance_exo(
            eph.phase_angle_deg.clamp(0.0, 180.0),
            eph.moon.distance_km,
            conditions.moonlight,
        )?;
        let up = moon_el > 0.0;
        let sin_h = moon_el.to_radians().sin().max(0.0);
        let moon_direct_normal = zip_map(&moon_exo, |w, e| {
            if up {
                e * atmosphere.direct_transmittance(w, moon_el)
            } else {
                0.0
            }
        });
        let moon_direct_horizontal = zip_map(&moon_direct_normal, |_, e| e * sin_h);
        let moon_diffuse_horizontal = scattering.diffuse_down_spectrum(&moon_exo);
        let overcast = conditions.cloud == Cloud::Overcast;
        let night_lux = conditions.night_sky_clear_lux
            * if overcast {
                conditions.overcast_transmittance
            } else {
                1.0
            };
        let night_sky_radiance = night_sky_radiance_w_m2_sr_nm(night_lux)?;
        let overcast_moon_radiance: Samples = moon_direct_horizontal
            .iter()
            .zip(&moon_diffuse_horizontal)
            .map(|(&(w, d), &(_, s))| (w, conditions.overcast_transmittance * (d + s) / PI))
            .collect();
        Ok(Self {
            ephemeris: eph,
            conditions: *conditions,
            atmosphere,
            scattering,
            moon_exo,
            moon_direct_normal,
            moon_direct_horizontal,
            moon_diffuse_horizontal,
            night_sky_radiance,
            overcast_moon_radiance,
        })
    }

    /// The ephemeris (Moon and Sun positions, phase).
    pub fn ephemeris(&self) -> &Ephemeris {
        &self.ephemeris
    }

    /// The atmosphere used.
    pub fn atmosphere(&self) -> &Atmosphere {
        &self.atmosphere
    }

    /// The conditions used.
    pub fn conditions(&self) -> &SkyConditions {
        &self.conditions
    }

    /// Unit vector towards the Moon (apparent, refracted) in the local
    /// east-north-up frame.
    pub fn moon_direction_enu(&self) -> [f64; 3] {
        self.ephemeris.moon.direction_enu()
    }

    /// True when the Moon is above the geometric horizon (and so lights the
    /// scene).
    pub fn moon_up(&self) -> bool {
        self.ephemeris.moon.elevation_geometric_deg > 0.0
    }

    /// True when the Moon's direct beam reaches the ground (clear sky, Moon up).
    pub fn moon_direct_visible(&self) -> bool {
        self.moon_up() && self.conditions.cloud == Cloud::Clear
    }

    /// Exo-atmospheric lunar spectral irradiance normal to the rays, W m⁻² nm⁻¹.
    pub fn moon_exo_irradiance_w_m2_nm(&self) -> &[(f64, f64)] {
        &self.moon_exo
    }

    /// Direct lunar spectral irradiance at the ground on a surface normal to
    /// the rays, W m⁻² nm⁻¹ (0 when overcast or the Moon is down). This is
    /// what a tracer's directional light should carry.
    pub fn moon_direct_normal_w_m2_nm(&self) -> Samples {
        if self.conditions.cloud == Cloud::Overcast {
            return zip_map(&self.moon_direct_normal, |_, _| 0.0);
        }
        self.moon_direct_normal.clone()
    }

    /// Sky-dome spectral radiance seen looking along `direction_enu`
    /// (east-north-up, need not be normalised), W m⁻² sr⁻¹ nm⁻¹: the
    /// single-scattered moonlight (clear) or the cloud deck's uniform
    /// radiance (overcast), plus the uniform night-sky background. 0 at or
    /// below the horizon (ground albedo is the tracer's business).
    pub fn sky_radiance_w_m2_sr_nm(&self, direction_enu: [f64; 3], wavelength_nm: f64) -> f64 {
        let n = direction_enu.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !n.is_finite() || n == 0.0 || direction_enu[2] <= 0.0 {
            return 0.0;
        }
        let night = spectral::interpolate(&self.night_sky_radiance, wavelength_nm);
        let moon = match self.conditions.cloud {
            Cloud::Overcast => spectral::interpolate(&self.overcast_moon_radiance, wavelength_nm),
            Cloud::Clear => {
                let e0 = spectral::interpolate(&self.moon_exo, wavelength_nm);
                if e0 > 0.0 {
                    e0 * self
                        .scattering
                        .radiance_per_irradiance_per_sr(wavelength_nm, direction_enu)
                } else {
                    0.0
                }
            }
        };
        night + moon
    }

    /// [`Self::sky_radiance_w_m2_sr_nm`] on the default grid.
    pub fn sky_radiance_spectrum(&self, direction_enu: [f64; 3]) -> Samples {
        spectral::default_grid_nm()
            .into_iter()
            .map(|w| (w, self.sky_radiance_w_m2_sr_nm(direction_enu, w)))
            .collect()
    }

    /// Horizontal spectral irradiances on the ground.
    pub fn ground_spectra(&self) -> GroundSpectra {
        let overcast = self.conditions.cloud == Cloud::Overcast;
        let direct = if overcast {
            zip_map(&self.moon_direct_horizontal, |_, _| 0.0)
        } else {
            self.moon_direct_horizontal.clone()
        };
        let sky = if overcast {
            zip_map(&self.overcast_moon_radiance, |_, l| l * PI)
        } else {
            self.moon_diffuse_horizontal.clone()
        };
        let night = zip_map(&self.night_sky_radiance, |_, l| l * PI);
        let total: Samples = direct
            .iter()
            .zip(&sky)
            .zip(&night)
            .map(|((&(w, a), &(_, b)), &(_, c))| (w, a + b + c))
            .collect();
        GroundSpectra {
            moon_exo_normal_w_m2_nm: self.moon_exo.clone(),
            moon_direct_horizontal_w_m2_nm: direct,
            moon_sky_horizontal_w_m2_nm: sky,
            night_sky_horizontal_w_m2_nm: night,
            total_horizontal_w_m2_nm: total,
        }
    }

    /// Ground illuminance summary (and spectra when `with_spectra`).
    pub fn illuminance(&self, with_spectra: bool) -> Result<GroundIlluminance> {
        let s = self.ground_spectra();
        let moon_direct = spectral::illuminance_lux(&s.moon_direct_horizontal_w_m2_nm)?;
        let moon_sky = spectral::illuminance_lux(&s.moon_sky_horizontal_w_m2_nm)?;
        let night_sky = spectral::illuminance_lux(&s.night_sky_horizontal_w_m2_nm)?;
        Ok(GroundIlluminance {
            ephemeris: self.ephemeris,
            illuminance_lux: IlluminanceLux {
                moon_direct,
                moon_sky,
                night_sky,
                total: moon_direct + moon_sky + night_sky,
            },
            twilight_not_modelled: self.ephemeris.sun.elevation_deg > -18.0,
            spectra: with_spectra.then_some(s),
        })
    }
}

/// One-call API for `gloam sky`: illuminance on the ground for an instant,
/// site, visibility (km) and cloud cover; spectral tables on request.
pub fn ground_illuminance(
    instant: UtcInstant,
    site: &Site,
    visibility_km: f64,
    cloud: Cloud,
    with_spectra: bool,
) -> Result<GroundIlluminance> {
    let c = SkyConditions::new(visibility_km, cloud)?;
    SkyModel::new(instant, site, &c)?.illuminance(with_spectra)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(s: &str) -> UtcInstant {
        UtcInstant::parse_iso8601(s).unwrap()
    }

    #[test]
    fn full_moon_high_in_the_sky() {
        // Full moon 2024-12-15 09:02 UTC; at Tucson (32.2 N, 111 W) local
        // midnight ≈ 07:20 UTC on the 15th, Moon high in the south.
        let site = Site::new(32.2, -110.95, 750.0).unwrap();
        let g =
            ground_illuminance(t("2024-12-15T07:20:00Z"), &site, 40.0, Cloud::Clear, true).unwrap();
        let l = g.illuminance_lux;
        println!(
            "full moon: el {:.1}° k {:.3} α {:.2}°: direct {:.3} sky {:.4} night {:.4} total {:.3} lux",
            g.ephemeris.moon.elevation_deg,
            g.ephemeris.illuminated_fraction,
            g.ephemeris.phase_angle_deg,
            l.moon_direct,
            l.moon_sky,
            l.night_sky,
            l.total
        );
        assert!(g.ephemeris.moon.elevation_deg > 60.0);
        assert!((0.1..=0.4).contains(&l.total), "{l:?}");
        assert!(l.moon_sky > 0.005 && l.moon_sky < 0.1 * l.moon_direct + 0.05);
        assert!((l.night_sky - 1e-3).abs() < 1e-9);
        assert!(!g.twilight_not_modelled);
        let s = g.spectra.unwrap();
        assert_eq!(s.total_horizontal_w_m2_nm.len(), 161);
        let lux = spectral::illuminance_lux(&s.total_horizontal_w_m2_nm).unwrap();
        assert!((lux / l.total - 1.0).abs() < 1e-9);
    }

    #[test]
    fn full_moon_at_moderate_elevation_is_typical() {
        // scan the night of the 2024-12-15 full moon for the Moon at 40–50°
        let site = Site::new(32.2, -110.95, 750.0).unwrap();
        let start = t("2024-12-15T01:00:00Z");
        let mut checked = 0;
        for k in 0..48 {
            let when = start.plus_seconds(k as f64 * 900.0);
            let g = ground_illuminance(when, &site, 23.0, Cloud::Clear, false).unwrap();
            let el = g.ephemeris.moon.elevation_deg;
            if (40.0..=50.0).contains(&el) {
                let l = g.illuminance_lux;
                println!(
                    "moon el {el:.1}°: total {:.3} lux (direct {:.3}, sky {:.3})",
                    l.total, l.moon_direct, l.moon_sky
                );
                assert!((0.1..=0.3).contains(&l.total), "{l:?}");
                checked += 1;
            }
        }
        assert!(checked > 0);
        // JSON for the CLI
        let g = ground_illuminance(start, &site, 23.0, Cloud::Clear, true).unwrap();
        let j = serde_json::to_string(&g).unwrap();
        assert!(j.contains("\"moon_direct\"") && j.contains("2024-12-15T01:00:00.000Z"));
    }

    #[test]
    fn overcast_and_moonless() {
        let site = Site::new(32.2, -110.95, 750.0).unwrap();
        let clear = ground_illuminance(t("2024-12-15T07:20:00Z"), &site, 40.0, Cloud::Clear, false)
            .unwrap();
        let oc = ground_illuminance(
            t("2024-12-15T07:20:00Z"),
            &site,
            40.0,
            Cloud::Overcast,
            false,
        )
        .unwrap();
        assert_eq!(oc.illuminance_lux.moon_direct, 0.0);
        let ratio = oc.illuminance_lux.moon_sky
            / (clear.illuminance_lux.moon_direct + clear.illuminance_lux.moon_sky);
        assert!((ratio - 0.1).abs() < 1e-9);
        assert!((oc.illuminance_lux.night_sky - 1e-4).abs() < 1e-10);
        // new moon 2024-12-01 06:21 UTC: moon below the horizon at local midnight
        let nm = ground_illuminance(t("2024-12-01T07:20:00Z"), &site, 40.0, Cloud::Clear, false)
            .unwrap();
        assert!(nm.ephemeris.moon.elevation_deg < 0.0);
        assert_eq!(nm.illuminance_lux.moon_direct, 0.0);
        assert_eq!(nm.illuminance_lux.moon_sky, 0.0);
        assert!((nm.illuminance_lux.total - 1e-3).abs() < 1e-9);
        assert!(
            ground_illuminance(t("2024-12-01T07:20:00Z"), &site, -1.0, Cloud::Clear, false)
                .is_err()
        );
        assert!("fog".parse::<Cloud>().is_err());
        assert_eq!("Overcast".parse::<Cloud>().unwrap(), Cloud::Overcast);
    }

    #[test]
    fn tracer_api_consistent_with_illuminance() {
        let site = Site::new(48.0, 11.0, 500.0).unwrap();
        let c = SkyConditions::new(15.0, Cloud::Clear).unwrap();
        let m = SkyModel::new(t("2024-12-15T00:00:00Z"), &site, &c).unwrap();
        assert!(m.moon_up());
        let d = m.moon_direction_enu();
        assert!((d.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-12);
        // integrate the radiance function over the dome at 600 nm and compare
        // with the horizontal sky + night terms
        let (ne, na) = (300, 600);
        let mut e = 0.0;
        for i in 0..ne {
            let mu = (i as f64 + 0.5) / ne as f64;
            for j in 0..na {
                let phi = (j as f64 + 0.5) / na as f64 * 2.0 * PI;
                let st = (1.0 - mu * mu).sqrt();
                e += m.sky_radiance_w_m2_sr_nm([st * phi.sin(), st * phi.cos(), mu], 600.0) * mu;
            }
        }
        e *= (1.0 / ne as f64) * (2.0 * PI / na as f64);
        let s = m.ground_spectra();
        let want = spectral::interpolate(&s.moon_sky_horizontal_w_m2_nm, 600.0)
            + spectral::interpolate(&s.night_sky_horizontal_w_m2_nm, 600.0);
        assert!((e / want - 1.0).abs() < 3e-3, "{e} vs {want}");
        // direct normal × sin h = direct horizontal
        let dn = spectral::interpolate(&m.moon_direct_normal_w_m2_nm(), 600.0);
        let dh = spectral::interpolate(&s.moon_direct_horizontal_w_m2_nm, 600.0);
        assert!((dn * d[2] - dh).abs() / dh < 0.01);
        assert_eq!(m.sky_radiance_w_m2_sr_nm([0.0, 1.0, -0.5], 600.0), 0.0);
        assert_eq!(m.sky_radiance_w_m2_sr_nm([f64::NAN, 1.0, 0.5], 600.0), 0.0);
    }
}
