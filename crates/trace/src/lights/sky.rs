//! The sky as a light: the Moon's direct beam and the night-sky dome, as
//! the tracer samples them. The sky's model (radiance, tables) is
//! `sky_light.rs`; this is its use at a shading point.

use glam::DVec3;
use gloam_scene::Scene;
use rand_pcg::Pcg64Mcg;

use super::{DistantLight, Term, add_emission};
use crate::light::Light;
use crate::settings::RenderSettings;
use crate::sky_light::{
    RadianceTable, SkyLight, SkySummary, SkyTerms, cosine_hemisphere, orthonormal_basis,
};
use crate::spectral::Wavelengths;
use crate::tracer::{RayCounts, TraceError, Tracer, latin_hypercube, stream};

/// The sky as the tracer uses it: on the continuum slots only (the sky has
/// no emission lines), scene frame +x east, +y north, +z up.
#[derive(Clone)]
pub(crate) struct SkyState {
    /// Continuum slots (the first `nc` of every spectral vector).
    pub(crate) nc: usize,
    /// Unit vector to the Moon when its direct beam lights the scene.
    pub(crate) moon_dir: Option<DVec3>,
    /// Where moon shadow rays go under `all_effects` when the Moon is dark
    /// (carrying zero irradiance).
    forced_moon_dir: DVec3,
    /// Direct lunar irradiance normal to the beam, W m⁻² nm⁻¹ per slot.
    moon_en: Vec<f64>,
    /// Whether the dome is sampled (a sky term is on, or `all_effects`).
    pub(crate) dome: bool,
    pub(crate) table: RadianceTable,
    pub(crate) summary: SkySummary,
    /// The light groups of the direct beam and of the dome under
    /// `--layers` (`layers.rs`; None otherwise).
    pub(crate) moon_group: Option<usize>,
    pub(crate) sky_group: Option<usize>,
    /// The Sun's direct beam while it is up (a distant light, term `sun`).
    pub(crate) sun: Option<DistantLight>,
    /// The twilight sky's radiance (Sun at or above −18°), and its group.
    pub(crate) twilight: Option<RadianceTable>,
    pub(crate) twilight_group: Option<usize>,
}

/// A dome as [`Tracer::dome_from`] samples it: radiance table, light
/// group, continuum slots.
pub(crate) type Dome<'a> = (&'a RadianceTable, Option<usize>, usize);

impl SkyState {
    /// The night-sky dome (scattered moonlight, starlight, airglow).
    fn night_dome(&self) -> Dome<'_> {
        (&self.table, self.sky_group, self.nc)
    }

    /// The twilight sky's dome, when the Sun lights the sky.
    pub(crate) fn twilight_dome(&self) -> Option<Dome<'_>> {
        let t = self.twilight.as_ref()?;
        Some((t, self.twilight_group, self.nc))
    }
}

/// What [`Tracer::sky_probe`] reports: the two sky terms separately, in one
/// band, W m⁻².
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SkyProbeResult {
    pub band: String,
    /// Direct moonlight, `E_n cos θ · τ` (one shadow ray; exact).
    pub moon_direct_w_m2: f64,
    /// The sky dome, mean of the repetitions (each `sky_samples` rays).
    pub sky_diffuse_w_m2: f64,
    pub sky_std_error_w_m2: f64,
}

/// Builds the sky from the scene's `[sky]` block, gated by the effect plan.
pub(crate) fn build_sky(
    scene: &Scene,
    settings: &RenderSettings,
    wl: &Wavelengths,
) -> Result<Option<SkyState>, TraceError> {
    use gloam_scene::plan::names;
    let plan = gloam_scene::plan::plan(scene);
    let moon = plan.is_enabled(names::MOON);
    let night = plan.is_enabled(names::NIGHT_SKY);
    let atmosphere = plan.is_enabled(names::ATMOSPHERE);
    let sun_beam = plan.is_enabled(names::SUN);
    let twilight = plan.is_enabled(names::TWILIGHT_SKY);
    if !(moon || night || atmosphere || sun_beam || twilight || settings.all_effects) {
        return Ok(None);
    }
    let (instant, site, conditions, cfg) = sky_inputs(scene)?;
    let model =
        gloam_sky::SkyModel::new(instant, &site, &conditions).map_err(|e| bad_sky("model", e))?;
    let terms = SkyTerms {
        moon,
        night_sky: night,
    };
    let nc = wl.n_continuum;
    let light = SkyLight::new(&model, &wl.nm[..nc], terms);
    let table = RadianceTable::new(&light);
    let moon_dir = light.moon_direction();
    let eph = model.ephemeris();
    let geometric = DVec3::from_array(model.moon_direction_enu()).normalize_or_zero();
    let forced_moon_dir = if geometric.z > 0.0 {
        geometric
    } else {
        DVec3::Z
    };
    let summary = SkySummary {
        utc: cfg.map(|s| s.utc.clone()),
        latitude_deg: site.latitude_deg,
        longitude_deg: site.longitude_east_deg,
        height_m: site.height_m,
        visibility_km: conditions.visibility_km,
        overcast: conditions.cloud == gloam_sky::Cloud::Overcast,
        moon_term: moon,
        night_sky_term: night,
        moon_elevation_deg: eph.moon.elevation_deg,
        moon_azimuth_deg: eph.moon.azimuth_deg,
        moon_illuminated_fraction: eph.illuminated_fraction,
        moon_direct: moon_dir.is_some(),
        moon_direction: geometric.to_array(),
        sky_samples: settings.sky_samples,
        uniform_dome: table.is_uniform(),
        sun_elevation_deg: eph.sun.elevation_geometric_deg,
        sun_azimuth_deg: eph.sun.azimuth_deg,
        sun_direct: false,
        twilight_sky: false,
    };
    let (sun, twilight_table) = if sun_beam || twilight {
        sun_and_twilight(
            instant,
            &site,
            &conditions,
            &wl.nm[..nc],
            (sun_beam, twilight),
        )?
    } else {
        (None, None)
    };
    let summary = SkySummary {
        sun_direct: sun.is_some(),
        twilight_sky: twilight_table.is_some(),
        ..summary
    };
    Ok(Some(SkyState {
        nc,
        moon_dir,
        forced_moon_dir,
        moon_en: light.moon_normal_irradiance_w_m2_nm().to_vec(),
        dome: moon || night || settings.all_effects,
        table,
        summary,
        moon_group: None,
        sky_group: None,
        sun,
        twilight: twilight_table,
        twilight_group: None,
    }))
}

/// A `[sky]` block's error, named.
fn bad_sky(what: &str, e: gloam_sky::SkyError) -> TraceError {
    TraceError::BadInput(format!("[sky] {what}: {e}"))
}

/// The instant, site and conditions of the scene's `[sky]` block (and the
/// block), or for `all_effects` on an indoor scene a dark sky whose paths
/// are exercised.
fn sky_inputs(
    scene: &Scene,
) -> Result<
    (
        gloam_sky::UtcInstant,
        gloam_sky::Site,
        gloam_sky::SkyConditions,
        Option<&gloam_scene::SkyConfig>,
    ),
    TraceError,
> {
    Ok(match &scene.sky {
        Some(s) => {
            let instant = s.instant;
            let site = gloam_sky::Site::new(s.latitude_deg, s.longitude_deg, s.height_m)
                .map_err(|e| bad_sky("site", e))?;
            let cloud = if s.overcast {
                gloam_sky::Cloud::Overcast
            } else {
                gloam_sky::Cloud::Clear
            };
            let c = gloam_sky::SkyConditions::new(s.visibility_km, cloud)
                .map_err(|e| bad_sky("visibility_km", e))?;
            (instant, site, c, Some(s))
        }
        None => {
            // all_effects on an indoor scene: a dark sky, paths exercised.
            let instant = gloam_sky::UtcInstant::parse_iso8601("2000-01-01T00:00:00Z")
                .map_err(|e| bad_sky("utc", e))?;
            let site = gloam_sky::Site::new(0.0, 0.0, 0.0).map_err(|e| bad_sky("site", e))?;
            let c = gloam_sky::SkyConditions::new(23.0, gloam_sky::Cloud::Clear)
                .map_err(|e| bad_sky("visibility_km", e))?;
            (instant, site, c, None)
        }
    })
}

/// The Sun's beam and the twilight sky's table (`which` = (beam, dome)),
/// from the twilight model at the scene's instant.
fn sun_and_twilight(
    instant: gloam_sky::UtcInstant,
    site: &gloam_sky::Site,
    conditions: &gloam_sky::SkyConditions,
    nm: &[f64],
    which: (bool, bool),
) -> Result<(Option<DistantLight>, Option<RadianceTable>), TraceError> {
    let twilight_sky = gloam_sky::TwilightSky::at(
        instant,
        site,
        conditions.visibility_km,
        gloam_sky::TwilightOptions::default(),
    )
    .map_err(|e| bad_sky("twilight", e))?;
    let overcast = conditions.cloud == gloam_sky::Cloud::Overcast;
    Ok(sunlight(&twilight_sky, nm, overcast, which))
}

/// The Sun's light on the continuum slots `nm`: its direct beam (when
/// `beam`, the sky is clear and the model gives the beam any light) and
/// the twilight sky's radiance table (when `dome`). An overcast deck
/// passes the clear sky's direct and diffuse light as a uniform dome, as
/// `gloam sky` and the Moon's overcast do
/// ([`gloam_sky::nightsky::OVERCAST_FACTOR`]).
fn sunlight(
    sky: &gloam_sky::TwilightSky,
    nm: &[f64],
    overcast: bool,
    (beam, dome): (bool, bool),
) -> (Option<DistantLight>, Option<RadianceTable>) {
    use gloam_sky::spectral::interpolate;
    let on_grid =
        |s: &[(f64, f64)]| -> Vec<f64> { nm.iter().map(|&w| interpolate(s, w)).collect() };
    if overcast {
        let direct = sky.direct_horizontal_w_m2_nm();
        let diffuse = sky.diffuse_horizontal_w_m2_nm();
        let k = gloam_sky::nightsky::OVERCAST_FACTOR / std::f64::consts::PI;
        let radiance: Vec<f64> = on_grid(&direct)
            .iter()
            .zip(on_grid(&diffuse))
            .map(|(a, b)| k * (a + b))
            .collect();
        return (None, dome.then(|| RadianceTable::uniform(radiance)));
    }
    let normal = on_grid(&sky.direct_normal_w_m2_nm());
    let sun = (beam && normal.iter().any(|&e| e > 0.0)).then(|| {
        let d = crate::sky_light::enu_to_scene(sky.sun_direction_enu());
        DistantLight::new(d, normal, Term::Sun)
    });
    let table = dome.then(|| {
        RadianceTable::tabulate(nm.len(), |d, out| {
            let l = sky.radiance_w_m2_sr_nm(crate::sky_light::scene_to_enu(d));
            for (o, &w) in out.iter_mut().zip(nm) {
                *o = interpolate(&l, w);
            }
        })
    });
    (sun, table)
}

impl Tracer {
    /// Direct moonlight at `p` (normal `n`): `E_n(λ) cos θ τ(λ)` with one
    /// shadow ray to infinity. A directional source: no distance, so no
    /// `meters_per_unit` (W m⁻² whatever the scene units).
    pub(crate) fn moon_irradiance(
        &self,
        sky: &SkyState,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let d = match sky.moon_dir {
            Some(d) => d,
            None if self.settings.all_effects => sky.forced_moon_dir,
            None => return,
        };
        let cos = n.dot(d);
        if cos.is_nan() || cos <= 0.0 {
            return;
        }
        let moon = (sky.moon_group, cos, &sky.moon_en[..]);
        self.add_if_visible(p, d, f64::INFINITY, ignore, moon, c, out);
    }

    /// The sky dome at `p` (normal `n`): `sky_samples` cosine-weighted
    /// directions (Latin-hypercube stratified), each adding `π L(ω) τ(ω) / N`
    /// when its shadow ray escapes; directions below the horizon carry no
    /// sky and cast no ray.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn dome_irradiance(
        &self,
        sky: &SkyState,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        if sky.dome {
            self.dome_from(sky.night_dome(), p, n, ignore, rng, c, out);
        }
    }

    /// A dome of radiance `table` (light group, continuum slots) at `p`:
    /// `sky_samples` cosine-weighted directions (Latin-hypercube
    /// stratified), each adding `π L(ω) τ(ω) / N` when its shadow ray
    /// escapes; directions below the horizon carry no sky and cast no ray.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn dome_from(
        &self,
        (table, group, nc): Dome<'_>,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let nsamp = self.settings.sky_samples.max(1) as usize;
        let mut u = Vec::with_capacity(nsamp);
        latin_hypercube(nsamp, rng, &mut u);
        let (t, b) = orthonormal_basis(n);
        let w = std::f64::consts::PI / nsamp as f64;
        let mut l = vec![0.0; nc];
        for uv in u {
            let local = cosine_hemisphere(uv);
            let dir = (t * local.x + b * local.y + n * local.z).normalize_or_zero();
            if dir.z.is_nan() || dir.z <= 0.0 {
                continue;
            }
            let Some(tau) = self.shadow(p, dir, f64::INFINITY, [ignore, u32::MAX], c) else {
                continue;
            };
            table.radiance_into(dir, &mut l);
            out.add_from(group, |o| add_emission(o, w, &l, tau.as_deref()));
        }
    }

    /// The two sky terms at world-space `point` (normal `normal`) in `band`,
    /// separately: direct moonlight (exact, one shadow ray) and the dome
    /// (mean of `samples` repetitions of `sky_samples` rays, with its
    /// standard error). `None` when the render has no sky.
    pub fn sky_probe(
        &self,
        point: DVec3,
        normal: DVec3,
        band: Option<&str>,
        samples: u32,
    ) -> Result<Option<SkyProbeResult>, TraceError> {
        let b = self.band_index(band)?;
        let n = crate::render::probe::unit_normal(normal)?;
        let Some(sky) = &self.sky else {
            return Ok(None);
        };
        let p = point - self.geom.origin;
        let ignore = self.facet_at(p).unwrap_or(u32::MAX);
        let mut c = RayCounts::default();
        let mut e = Light::dark(self.wl.len(), 0);
        self.moon_irradiance(sky, p, n, ignore, &mut c, &mut e);
        let moon = self.wl.integrate(&e.whole)[b];
        let k = samples.max(1);
        let mut es = Vec::with_capacity(k as usize);
        for i in 0..k {
            let mut rng = stream(self.settings.seed, 0x5C1E_D0E5, i as u64);
            e.clear();
            self.dome_irradiance(sky, p, n, ignore, &mut rng, &mut c, &mut e);
            es.push(self.wl.integrate(&e.whole)[b]);
        }
        let mean = es.iter().sum::<f64>() / k as f64;
        let se = if k > 1 {
            let var = es.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
            (var / k as f64).sqrt()
        } else {
            0.0
        };
        Ok(Some(SkyProbeResult {
            band: self.wl.band_names[b].clone(),
            moon_direct_w_m2: moon,
            sky_diffuse_w_m2: mean,
            sky_std_error_w_m2: se,
        }))
    }

    /// What the render took from the `[sky]` block (None: no sky).
    pub fn sky_summary(&self) -> Option<&SkySummary> {
        self.sky.as_ref().map(|s| &s.summary)
    }
}
