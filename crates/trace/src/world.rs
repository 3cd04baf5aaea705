//! The scene as the tracer sees it: the [`World`] — geometry, materials at
//! the carried wavelengths, lights, camera — built once by preparation
//! (`tracer.rs`) and shared, immutable, by every tracer made from it.

use glam::DVec3;
use gloam_scene::Scene;

use crate::geometry::Geometry;
use crate::lights::{AreaSource, PointLight, SkyState};
use crate::spectral::Wavelengths;

/// Per-material spectral factors at the carried wavelengths.
#[derive(Clone, Debug)]
pub(crate) struct MatSpec {
    /// Lambertian albedo (1 − s)ρ.
    pub(crate) kd: Vec<f64>,
    /// Specular reflectance sρ (empty when none).
    pub(crate) ks: Vec<f64>,
    /// Straight-through transmission.
    pub(crate) trans: Option<Vec<f64>>,
    pub(crate) has_diffuse: bool,
}

/// The scene as the tracer sees it — geometry, materials, lights, camera,
/// the carried wavelengths — built once by preparation and shared,
/// immutable, by every tracer made from it (pbrt-v4's scene, apart from
/// the integrator's settings and plan).
#[derive(Clone)]
pub struct World {
    pub(crate) wl: Wavelengths,
    pub(crate) geom: Geometry,
    pub(crate) mpu: f64,
    pub(crate) facet_mat: Vec<u32>,
    pub(crate) facet_normal: Vec<DVec3>,
    pub(crate) facet_verts: Vec<Vec<DVec3>>,
    pub(crate) facet_source: Vec<u32>,
    pub(crate) mats: Vec<MatSpec>,
    pub(crate) area: Vec<AreaSource>,
    pub(crate) points: Vec<PointLight>,
    /// Camera in centred coordinates.
    pub(crate) camera: gloam_scene::Camera,
    pub(crate) ones: Vec<f64>,
    /// The Moon and the sky dome, when the effect plan (or `all_effects`)
    /// calls for them.
    pub(crate) sky: Option<SkyState>,
    /// The light tree over the emitters, when there are more than
    /// `light_tree_min_lights` (else every emitter is evaluated, as always).
    pub(crate) light_tree: Option<crate::lights::tree::LightTree>,
    /// The light groups its emitters are split by (`--layers`,
    /// `layers.rs`), when a layered render asked for them.
    pub(crate) layers: Option<crate::layers::LayerMap>,
    /// Which pixels each emitter's face covers: the faces seen directly
    /// are computed apart from the camera samples (`direct_view.rs`).
    pub(crate) view: crate::direct_view::Footprints,
}

impl MatSpec {
    /// Material `m`'s factors at the wavelengths of `wl`.
    pub(crate) fn of(m: &gloam_scene::Material, wl: &Wavelengths) -> Self {
        let rho = wl.factor(&m.reflectance);
        let s = m.specular_fraction.clamp(0.0, 1.0);
        let kd: Vec<f64> = rho.iter().map(|r| (1.0 - s) * r).collect();
        let ks: Vec<f64> = if s > 0.0 {
            rho.iter().map(|r| s * r).collect()
        } else {
            Vec::new()
        };
        MatSpec {
            has_diffuse: kd.iter().any(|&k| k > 0.0),
            kd,
            ks: if ks.iter().any(|&k| k > 0.0) {
                ks
            } else {
                Vec::new()
            },
            trans: m
                .transmission
                .as_ref()
                .filter(|_| m.is_transmissive())
                .map(|t| wl.factor(t)),
        }
    }
}

/// The centre of the box around the scene's facets, camera and lamps (the
/// tracer's origin, so coordinates keep their digits) and the box's
/// half-diagonal.
pub(crate) fn centre_of(scene: &Scene) -> (DVec3, f64) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut grow = |p: DVec3| {
        lo = lo.min(p);
        hi = hi.max(p);
    };
    for f in &scene.facets {
        f.vertices.iter().for_each(|&v| grow(v));
    }
    grow(scene.camera.position);
    scene.point_sources.iter().for_each(|p| grow(p.position));
    (0.5 * (lo + hi), 0.5 * (hi - lo).length())
}
