//! Ray casting: a compressed wide BVH (obvhs CWBVH) over every facet.
//!
//! Precision strategy. All positions are stored relative to a scene-centred
//! origin (the centre of the bounding box of facets, camera and point
//! sources), so a scene placed 1e5 units from the world origin loses nothing.
//! The BVH itself is f32 (that is what obvhs traverses), built over boxes
//! padded by a small multiple of the scene extent so that f32 rounding can
//! never make a box miss a ray that hits its triangle. The ray–triangle test
//! that decides hits, distances and hit points runs in f64 on the f64
//! (centred) vertices, so shading maths never sees f32 rounding.
//!
//! Self-intersection: facets are planar, so a ray leaving a facet can never
//! hit that facet again; continuation and shadow rays ignore the facet they
//! start on (and, for area-source samples, the facet they end on). On top of
//! that, rays start `eps` along their direction, with `eps` proportional to
//! the magnitude of the coordinates involved ([`Geometry::epsilon`]), which
//! handles neighbouring facets meeting at an edge.

use glam::{DVec3, Vec3A};
use obvhs::{Boundable, BvhBuildParams, aabb::Aabb, cwbvh::CwBvh, ray::Ray};

/// One triangle in centred f64 coordinates (quads are two of these).
#[derive(Clone, Copy, Debug)]
struct Tri {
    v0: DVec3,
    e1: DVec3,
    e2: DVec3,
    facet: u32,
}

/// A padded f32 box handed to the BVH builder.
struct PrimBox(Aabb);

impl Boundable for PrimBox {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

/// A closest hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the (unit) ray direction, scene units.
    pub t: f64,
    /// Index into the scene's facets.
    pub facet: u32,
}

/// What lies between two points for a shadow ray.
#[derive(Clone, Debug, PartialEq)]
pub enum Visibility {
    /// An opaque facet is in the way.
    Blocked,
    /// Nothing opaque: the listed transmissive facets (each once) attenuate.
    Clear(Vec<u32>),
}

/// The BVH and the triangles it indexes.
#[derive(Clone)]
pub struct Geometry {
    /// World position (scene units) of the centred frame's origin.
    pub origin: DVec3,
    /// Half the diagonal of the centred bounding box, scene units (≥ 1e-12).
    pub extent: f64,
    tris: Vec<Tri>,
    bvh: Option<CwBvh>,
    transmissive: Vec<bool>,
}

impl Geometry {
    /// Builds the BVH. `facets` are polygons (3 or 4 vertices, already
    /// centred), `transmissive[facet]` says whether shadow rays pass through.
    pub fn new(origin: DVec3, extent: f64, facets: &[Vec<DVec3>], transmissive: Vec<bool>) -> Self {
        let mut tris = Vec::with_capacity(facets.len() * 2);
        for (i, v) in facets.iter().enumerate() {
            for k in 1..v.len().saturating_sub(1) {
                tris.push(Tri {
                    v0: v[0],
                    e1: v[k] - v[0],
                    e2: v[k + 1] - v[0],
                    facet: i as u32,
                });
            }
        }
        let extent = extent.max(1e-12);
        let pad = (extent * 1e-5) as f32;
        let boxes: Vec<PrimBox> = tris
            .iter()
            .map(|t| {
                let pts = [t.v0, t.v0 + t.e1, t.v0 + t.e2];
                let mut lo = Vec3A::splat(f32::INFINITY);
                let mut hi = Vec3A::splat(f32::NEG_INFINITY);
                for p in pts {
                    let q = Vec3A::new(p.x as f32, p.y as f32, p.z as f32);
                    lo = lo.min(q);
                    hi = hi.max(q);
                }
                PrimBox(Aabb::new(lo - Vec3A::splat(pad), hi + Vec3A::splat(pad)))
            })
            .collect();
        let bvh = (!boxes.is_empty()).then(|| {
            obvhs::cwbvh::builder::build_cwbvh(
                &boxes,
                BvhBuildParams::medium_build(),
                &mut std::time::Duration::default(),
            )
        });
        Self {
            origin,
            extent,
            tris,
            bvh,
            transmissive,
        }
    }

    /// Number of triangles in the BVH.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Ray-start offset for a ray leaving `p` (centred coordinates): a few
    /// thousand ulps of the coordinates (f64 rounding of the hit point and
    /// of the hit test), plus 1e-12 of the scene's extent — not a fixed
    /// fraction of the absolute position, which once swallowed a 0.1 mm gap
    /// beside an emitter 1e5 m from the origin. The facet a ray leaves is
    /// ignored anyway; the offset only guards its neighbours.
    pub fn epsilon(&self, p: DVec3) -> f64 {
        1e-12 * (self.extent + p.abs().max_element()) + 1e-300
    }

    fn f32_ray(o: DVec3, d: DVec3, tmax: f64) -> Ray {
        let tmax = if tmax.is_finite() {
            (tmax * (1.0 + 1e-5)) as f32 + 1e-6
        } else {
            f32::INFINITY
        };
        // `+ 0.0` turns -0.0 (e.g. from `-DVec3::Z`, or an underflow in the
        // f32 conversion) into +0.0: obvhs picks a zero component's inverse
        // sign from the sign bit but its slab order from `< 0.0`, and the
        // two disagree for -0.0, which makes the ray miss every box.
        Ray::new(
            Vec3A::new(o.x as f32, o.y as f32, o.z as f32),
            Vec3A::new(d.x as f32 + 0.0, d.y as f32 + 0.0, d.z as f32 + 0.0),
            0.0,
            tmax,
        )
    }

    /// f64 Möller–Trumbore, two-sided, edges inclusive. Returns t or +∞.
    #[inline]
    fn intersect_tri(tri: &Tri, o: DVec3, d: DVec3) -> f64 {
        let p = d.cross(tri.e2);
        let det = tri.e1.dot(p);
        if det == 0.0 || !det.is_finite() {
            return f64::INFINITY;
        }
        let inv = 1.0 / det;
        let s = o - tri.v0;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return f64::INFINITY;
        }
        let q = s.cross(tri.e1);
        let v = d.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return f64::INFINITY;
        }
        tri.e2.dot(q) * inv
    }

    /// Closest hit along the unit direction `d` from `o` (centred
    /// coordinates) with `tmin < t < tmax`, ignoring facet `ignore`.
    pub fn intersect(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64, ignore: u32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let mut best_t = tmax;
        let mut best_facet = u32::MAX;
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(Self::f32_ray(o, d, tmax), &mut hit, |_, id| {
            let tri = &self.tris[bvh.primitive_indices[id] as usize];
            if tri.facet == ignore {
                return f32::INFINITY;
            }
            let t = Self::intersect_tri(tri, o, d);
            if t > tmin && t < best_t {
                best_t = t;
                best_facet = tri.facet;
                (t * (1.0 + 1e-6)) as f32 + 1e-6
            } else {
                f32::INFINITY
            }
        });
        (best_facet != u32::MAX).then_some(Hit {
            t: best_t,
            facet: best_facet,
        })
    }

    /// Shadow query from `o` along unit `d` over `tmin < t < tmax`, ignoring
    /// facets `ignore`. Exits on the first opaque hit; transmissive facets
    /// are collected (once each) so the caller can attenuate.
    pub fn visibility(
        &self,
        o: DVec3,
        d: DVec3,
        tmin: f64,
        tmax: f64,
        ignore: [u32; 2],
    ) -> Visibility {
        let Some(bvh) = self.bvh.as_ref() else {
            return Visibility::Clear(Vec::new());
        };
        let mut through: Vec<u32> = Vec::new();
        // `ray_traverse_miss` returns true when nothing was hit.
        let miss = bvh.ray_traverse_miss(Self::f32_ray(o, d, tmax), |_, id| {
            let tri = &self.tris[bvh.primitive_indices[id] as usize];
            if tri.facet == ignore[0] || tri.facet == ignore[1] {
                return f32::INFINITY;
            }
            let t = Self::intersect_tri(tri, o, d);
            if !(t > tmin && t < tmax) {
                return f32::INFINITY;
            }
            if self.transmissive[tri.facet as usize] {
                if !through.contains(&tri.facet) {
                    through.push(tri.facet);
                }
                f32::INFINITY
            } else {
                0.0
            }
        });
        if miss {
            through.sort_unstable();
            Visibility::Clear(through)
        } else {
            Visibility::Blocked
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(z: f64, half: f64) -> Vec<DVec3> {
        vec![
            DVec3::new(-half, -half, z),
            DVec3::new(half, -half, z),
            DVec3::new(half, half, z),
            DVec3::new(-half, half, z),
        ]
    }

    #[test]
    fn closest_hit_and_shadow() {
        let g = Geometry::new(
            DVec3::ZERO,
            2.0,
            &[quad(0.0, 1.0), quad(1.0, 1.0), quad(0.5, 0.2)],
            vec![false, false, true],
        );
        let h = g
            .intersect(
                DVec3::new(0.1, 0.1, 2.0),
                -DVec3::Z,
                0.0,
                f64::INFINITY,
                u32::MAX,
            )
            .unwrap();
        assert_eq!(h.facet, 1);
        assert!((h.t - 1.0).abs() < 1e-12);
        // From the floor up to z = 0.9: only the transmissive facet in
        // between, counted once where the ray crosses the shared diagonal of
        // its two triangles ((0, 0) and (0.1, 0.1)) as inside one of them.
        for (x, y) in [(0.0, 0.0), (0.1, 0.1), (0.15, -0.05)] {
            let v = g.visibility(DVec3::new(x, y, 0.0), DVec3::Z, 1e-9, 0.9, [0, u32::MAX]);
            assert_eq!(v, Visibility::Clear(vec![2]), "({x}, {y})");
        }
        let v = g.visibility(
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::Z,
            1e-9,
            2.0,
            [0, u32::MAX],
        );
        assert_eq!(v, Visibility::Blocked);
    }

    #[test]
    fn axis_aligned_rays_with_negative_zero_components_hit() {
        // glam's `-DVec3::Z` is (-0.0, -0.0, -1.0): obvhs takes the sign of
        // the inverse from the zero's sign bit but the slab order from
        // `< 0.0`, so such rays missed every box before the +0.0 fix.
        for n in 1..6 {
            let facets: Vec<Vec<DVec3>> = (0..n).map(|i| quad(i as f64, 1.0)).collect();
            let g = Geometry::new(DVec3::ZERO, 10.0, &facets, vec![false; n]);
            for o in [DVec3::new(0.1, 0.1, 20.0), DVec3::new(0.0, 0.0, 20.0)] {
                let h = g.intersect(o, -DVec3::Z, 0.0, f64::INFINITY, u32::MAX);
                assert_eq!(h.map(|h| h.facet), Some(n as u32 - 1));
                let v = g.visibility(o, -DVec3::Z, 0.0, 100.0, [u32::MAX; 2]);
                assert_eq!(v, Visibility::Blocked);
                let h = g.intersect(-o, DVec3::Z, 0.0, f64::INFINITY, u32::MAX);
                assert_eq!(h.map(|h| h.facet), Some(0));
            }
        }
    }

    #[test]
    fn single_triangle_scene() {
        let g = Geometry::new(
            DVec3::ZERO,
            1.0,
            &[vec![DVec3::ZERO, DVec3::X, DVec3::Y]],
            vec![false],
        );
        assert!(
            g.intersect(
                DVec3::new(0.2, 0.2, 1.0),
                -DVec3::Z,
                0.0,
                f64::INFINITY,
                u32::MAX
            )
            .is_some()
        );
        assert!(
            g.intersect(
                DVec3::new(0.8, 0.8, 1.0),
                -DVec3::Z,
                0.0,
                f64::INFINITY,
                u32::MAX
            )
            .is_none()
        );
    }
}
