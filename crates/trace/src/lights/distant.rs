//! Distant sources (`[distant_sources.NAME]`): parallel light from
//! infinitely far away — pbrt-v4's `DistantLight`, Mitsuba's
//! `directional`. A shading point facing the source by θ gets
//! `E(λ) cos θ` unless a shadow ray toward it is blocked: one ray, no
//! random numbers, the same at every point (so not a smooth term: its
//! shadow edges are as sharp as a point source's).
//!
//! This family is the example of adding one (issue 44): this file, an arm
//! of [`super::LightSource`] and of [`super::Term`] (with the `match`es
//! the compiler lists), its place in [`super::sampler::LightSampler::
//! every`], and the scene's table, effect and light group.

use glam::DVec3;
use gloam_scene::Scene;

use super::Term;
use crate::light::Light;
use crate::spectral::Wavelengths;
use crate::tracer::{RayCounts, Tracer};

/// A distant source as the tracer uses it.
#[derive(Clone, Debug)]
pub(crate) struct DistantLight {
    /// Unit vector toward the source (against the light's travel).
    to_source: DVec3,
    /// Irradiance normal to the beam per slot, W m⁻² nm⁻¹ (lines: W m⁻²).
    irradiance: Vec<f64>,
    /// Its light group under `--layers` (`layers.rs`; None otherwise).
    pub(crate) group: Option<usize>,
    /// The term it counts under: `distant-sources`, or `sun` for the
    /// Sun's beam from the sky.
    pub(crate) term: Term,
}

impl DistantLight {
    /// Toward unit `to_source`, `irradiance` normal to the beam per slot.
    pub(crate) fn new(to_source: DVec3, irradiance: Vec<f64>, term: Term) -> Self {
        Self {
            to_source,
            irradiance,
            group: None,
            term,
        }
    }
}

/// The scene's distant sources on the render's slots.
pub(crate) fn distant_lights(scene: &Scene, wl: &Wavelengths) -> Vec<DistantLight> {
    scene
        .distant_sources
        .iter()
        .map(|d| {
            DistantLight::new(
                -d.direction,
                wl.emission(&d.irradiance_w_m2_nm),
                Term::Distant,
            )
        })
        .collect()
}

impl Tracer {
    /// A distant source's irradiance at `p` (normal `n`, on facet
    /// `ignore`): `E cos θ` when the shadow ray toward it escapes.
    pub(crate) fn distant_irradiance(
        &self,
        l: &DistantLight,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let cos = n.dot(l.to_source);
        if cos.is_nan() || cos <= 0.0 {
            return;
        }
        let light = (l.group, cos, &l.irradiance[..]);
        self.add_if_visible(p, l.to_source, f64::INFINITY, ignore, light, c, out);
    }
}
