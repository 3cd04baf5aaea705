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
    /// Distant sources (`lights/distant.rs`).
    pub(crate) distant: Vec<crate::lights::DistantLight>,
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

impl World {
    /// Facet `f`'s unit normal: a flat facet's, or a shared one's where it
    /// is placed (ids past the flat facets, `geometry.rs`).
    #[inline]
    pub(crate) fn normal_of(&self, f: u32) -> DVec3 {
        match self.facet_normal.get(f as usize) {
            Some(n) => *n,
            None => self.geom.shared_normal(f),
        }
    }

    /// Facet `f`'s material, flat or shared.
    #[inline]
    pub(crate) fn mat_of(&self, f: u32) -> &MatSpec {
        let m = match self.facet_mat.get(f as usize) {
            Some(&m) => m,
            None => self.geom.shared_material(f),
        };
        &self.mats[m as usize]
    }

    /// The area source facet `f` is (`u32::MAX` for none: shared facets
    /// never emit).
    #[inline]
    pub(crate) fn source_of(&self, f: u32) -> u32 {
        self.facet_source
            .get(f as usize)
            .copied()
            .unwrap_or(u32::MAX)
    }
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
    scene
        .shared
        .iter()
        .flat_map(|s| s.placed_corners())
        .for_each(&mut grow);
    grow(scene.camera.position);
    scene.point_sources.iter().for_each(|p| grow(p.position));
    (0.5 * (lo + hi), 0.5 * (hi - lo).length())
}
