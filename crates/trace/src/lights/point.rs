//! Point sources: `cos^m` about an axis or a measured luminaire's
//! (IES / EULUMDAT) table, one shadow ray each.

use glam::DVec3;
use gloam_scene::Scene;

use super::{shaping, tree_size};
use crate::light::Light;
use crate::lights::tree::{Cone, LightInfo, LightRef};
use crate::spectral::Wavelengths;
use crate::tracer::{RayCounts, Tracer};

/// A point source: `intensity · shape(ω)`, the shape `cos^m` about `dir`
/// or a measured luminaire's `I(γ, C) / I_max` (see
/// [`PointLight::shape_toward`]).
#[derive(Clone, Debug)]
pub(crate) struct PointLight {
    pub(crate) pos: DVec3,
    dir: DVec3,
    pub(crate) m: f64,
    /// A measured distribution (IES / EULUMDAT); `m` is then 0.
    luminaire: Option<gloam_scene::Luminaire>,
    pub(crate) intensity: Vec<f64>,
    /// Its light group under `--layers` (`layers.rs`; None otherwise).
    pub(crate) group: Option<usize>,
}

/// The scene's point sources, in centred coordinates.
pub(crate) fn point_lights(scene: &Scene, wl: &Wavelengths, origin: DVec3) -> Vec<PointLight> {
    scene
        .point_sources
        .iter()
        .map(|p| PointLight {
            pos: p.position - origin,
            dir: p.direction.normalize_or_zero(),
            m: p.shape_exponent.max(0.0),
            luminaire: p.luminaire.clone(),
            intensity: wl.emission(&p.intensity_w_sr_nm),
            group: None,
        })
        .collect()
}

impl PointLight {
    /// The intensity's shape toward unit direction `w` (from the lamp), in
    /// [0, 1]: `cos^m(alpha)` about `dir`, or for a measured luminaire the
    /// file's candela bilinearly interpolated in (γ, C) over its table,
    /// divided by its largest value. Every point-light evaluation (direct
    /// light, the camera's view of the lamp, the radiosity cache) goes
    /// through here, so a tabulated lamp is evaluated exactly — no
    /// sampling — wherever a `cos^m` one is.
    pub(crate) fn shape_toward(&self, w: DVec3) -> f64 {
        match &self.luminaire {
            None => shaping(self.dir.dot(w), self.m),
            Some(l) => l.relative_toward(self.dir, w),
        }
    }

    /// Shaped (counted under `shaped-point-sources`): `cos^m` with m > 0,
    /// or a measured distribution.
    pub(crate) fn is_shaped(&self) -> bool {
        self.m > 0.0 || self.luminaire.is_some()
    }

    /// Its entry in the light tree, as source `i`: where it is, its largest
    /// intensity over `mpu2` (W sr⁻¹ per scene unit²) and the cone it
    /// shines into.
    pub(super) fn tree_info(&self, i: usize, wl: &Wavelengths, mpu2: f64) -> LightInfo {
        // Shaped: cos^m about `dir`, nothing behind; isotropic (or no
        // direction): every way.
        let cone = if let Some(lum) = &self.luminaire {
            // Intensity ≤ I_max everywhere (phi below) and zero beyond the
            // table's support angle from the nadir: a cone of that
            // half-angle, no falloff assumed inside it.
            let support = lum.table.support_deg().to_radians() + 1e-9;
            if support >= std::f64::consts::PI || self.dir == DVec3::ZERO {
                Cone::ALL
            } else {
                Cone {
                    axis: self.dir,
                    theta_o: 0.0,
                    theta_e: support,
                    exponent: 0.0,
                }
            }
        } else if self.m > 0.0 && self.dir != DVec3::ZERO {
            Cone {
                axis: self.dir,
                theta_o: 0.0,
                theta_e: std::f64::consts::FRAC_PI_2,
                exponent: self.m,
            }
        } else {
            Cone::ALL
        };
        LightInfo {
            light: LightRef::Point(i as u32),
            lo: self.pos,
            hi: self.pos,
            phi: tree_size(&self.intensity, wl.total(&self.intensity)) / mpu2,
            cone,
        }
    }
}

impl Tracer {
    /// A point source's irradiance at `p` times `scale` (1, or the light
    /// tree's 1/pmf), one shadow ray.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn point_irradiance(
        &self,
        l: &PointLight,
        p: DVec3,
        n: DVec3,
        ignore: u32,
        scale: f64,
        c: &mut RayCounts,
        out: &mut Light,
    ) {
        let v = l.pos - p;
        let r = v.length();
        if r <= 0.0 {
            return;
        }
        let w = v / r;
        let cos_r = w.dot(n);
        if cos_r <= 0.0 {
            return;
        }
        let shape = l.shape_toward(-w);
        if shape == 0.0 {
            return;
        }
        let r_m = r * self.mpu;
        // scale·shape is exactly shape for scale = 1 (no light tree).
        let g = scale * shape * cos_r / (r_m * r_m);
        self.add_if_visible(p, w, r, ignore, (l.group, g, &l.intensity), c, out);
    }
}
