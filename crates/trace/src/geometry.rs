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
//!
//! Two levels (pbrt-v4's instances). A shared object's prototype has one
//! BVH of its own, in its own frame, and a top-level BVH holds a box per
//! placement: a ray that enters a placement's box is carried into the
//! prototype's frame by that placement's inverse (an affine map keeps the
//! ray's parameter t, so distances need no rescaling) and tested there, in
//! f64 as at the first level. A placed facet has an id past the flat ones
//! (`first_id + placement × facets + facet`), so nothing is copied per
//! placement but a transform.

use glam::{DAffine3, DVec3, Vec3A};
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
    /// Shared prototypes (the second level), in the scene's order.
    shared: Vec<Prototype>,
    /// Every placement, prototype by prototype.
    placed: Vec<Placed>,
    /// The top-level BVH over the placements' boxes.
    top: Option<CwBvh>,
}

/// A shared object the tracer is given: its facets once, in the
/// prototype's frame, and each placement's map into the centred frame.
pub struct SharedInput {
    pub facets: Vec<Vec<DVec3>>,
    /// Each facet's unit normal (the scene's, so both levels agree).
    pub normals: Vec<DVec3>,
    pub placements: Vec<DAffine3>,
    pub transmissive: bool,
    /// Index of its material.
    pub material: u32,
}

/// One shared prototype: triangles and BVH in its own frame.
#[derive(Clone)]
struct Prototype {
    tris: Vec<Tri>,
    bvh: CwBvh,
    /// Each prototype facet's unit normal, in its frame.
    normals: Vec<DVec3>,
    transmissive: bool,
    material: u32,
    /// Id of placement 0's facet 0; `facets` ids per placement.
    first_id: u32,
    facets: u32,
    /// Index of its placement 0 in [`Geometry::placed`].
    first_placed: u32,
}

/// One placement of a shared prototype.
#[derive(Clone, Copy)]
struct Placed {
    /// From the centred frame into the prototype's.
    to_local: DAffine3,
    prototype: u32,
    /// Id of this placement's facet 0.
    first_id: u32,
}

impl Geometry {
    /// Builds the BVH. `facets` are polygons (3 or 4 vertices, already
    /// centred), `transmissive[facet]` says whether shadow rays pass through.
    pub fn new(origin: DVec3, extent: f64, facets: &[Vec<DVec3>], transmissive: Vec<bool>) -> Self {
        let extent = extent.max(1e-12);
        let tris = triangles(facets);
        let bvh = bvh_over(&tris, extent);
        Self {
            origin,
            extent,
            tris,
            bvh,
            transmissive,
            shared: Vec::new(),
            placed: Vec::new(),
            top: None,
        }
    }

    /// Adds the shared prototypes (the second level) and the top-level BVH
    /// over their placements; their facet ids follow the flat facets'.
    /// The scene has checked that the ids fit a `u32`
    /// (`gloam_scene::MAX_SHARED_FACETS`).
    pub fn with_shared(mut self, inputs: Vec<SharedInput>) -> Self {
        let mut next_id = self.transmissive.len() as u64;
        let mut boxes = Vec::new();
        for mut input in inputs {
            // The prototype centred in its own frame (its f32 boxes keep
            // their digits), each placement taking the shift back.
            let (lo, hi) = input
                .facets
                .iter()
                .flatten()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(*v), hi.max(*v))
                });
            let c = 0.5 * (lo + hi);
            let (lo, hi) = (lo - c, hi - c);
            input.facets.iter_mut().flatten().for_each(|v| *v -= c);
            let back = DAffine3::from_translation(c);
            let tris = triangles(&input.facets);
            let own_extent = (0.5 * (hi - lo).length()).max(1e-12);
            let Some(bvh) = bvh_over(&tris, own_extent) else {
                continue;
            };
            let facets = input.facets.len() as u32;
            let s = self.shared.len();
            self.shared.push(Prototype {
                tris,
                bvh,
                normals: input.normals,
                transmissive: input.transmissive,
                material: input.material,
                first_id: next_id as u32,
                facets,
                first_placed: self.placed.len() as u32,
            });
            for a in &input.placements {
                let a = *a * back;
                self.placed.push(Placed {
                    to_local: a.inverse(),
                    prototype: s as u32,
                    first_id: next_id as u32,
                });
                next_id += facets as u64;
                boxes.push(PrimBox(padded_box(
                    gloam_scene::box_corners((lo, hi)).map(|c| a.transform_point3(c)),
                    self.extent,
                )));
            }
        }
        self.top = (!boxes.is_empty()).then(|| build(&boxes));
        self
    }

    /// Whether the scene has shared prototypes (a second level).
    pub fn has_shared(&self) -> bool {
        !self.placed.is_empty()
    }

    /// The prototype and placement a facet id past the flat facets names,
    /// with the facet's index in the prototype.
    fn placed_facet(&self, id: u32) -> Option<(&Prototype, &Placed, usize)> {
        let s = self.shared.partition_point(|p| p.first_id <= id);
        let proto = self.shared.get(s.checked_sub(1)?)?;
        let local = (id - proto.first_id) as usize;
        let k = local / proto.facets.max(1) as usize;
        let placed = self.placed.get(proto.first_placed as usize + k)?;
        (placed.prototype as usize == s - 1).then_some((
            proto,
            placed,
            local % proto.facets as usize,
        ))
    }

    /// Unit normal of a shared facet `id` (past the flat facets) where it
    /// is placed: the prototype's, carried by the inverse transpose.
    pub fn shared_normal(&self, id: u32) -> DVec3 {
        self.placed_facet(id)
            .map_or(DVec3::Z, |(proto, placed, j)| {
                (placed.to_local.matrix3.transpose() * proto.normals[j]).normalize_or(DVec3::Z)
            })
    }

    /// Material index of a shared facet `id` (past the flat facets).
    pub fn shared_material(&self, id: u32) -> u32 {
        self.placed_facet(id)
            .map_or(0, |(proto, _, _)| proto.material)
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
        let mut best = Hit {
            t: tmax,
            facet: u32::MAX,
        };
        if let Some(bvh) = self.bvh.as_ref() {
            let mut hit = obvhs::ray::RayHit::none();
            bvh.ray_traverse(Self::f32_ray(o, d, tmax), &mut hit, |_, id| {
                let tri = &self.tris[bvh.primitive_indices[id] as usize];
                Self::closer(tri, tri.facet, (o, d), tmin, ignore, &mut best)
            });
        }
        self.intersect_shared(o, d, tmin, ignore, &mut best);
        (best.facet != u32::MAX).then_some(best)
    }

    /// One triangle's test for [`Geometry::intersect`] (`facet` its id,
    /// the ray in the triangle's frame): takes the hit into `best` when it
    /// is nearer, and returns the f32 distance the traversal may stop at.
    #[inline]
    fn closer(
        tri: &Tri,
        facet: u32,
        (o, d): (DVec3, DVec3),
        tmin: f64,
        ignore: u32,
        best: &mut Hit,
    ) -> f32 {
        if facet == ignore {
            return f32::INFINITY;
        }
        let t = Self::intersect_tri(tri, o, d);
        if t > tmin && t < best.t {
            *best = Hit { t, facet };
            (t * (1.0 + 1e-6)) as f32 + 1e-6
        } else {
            f32::INFINITY
        }
    }

    /// The second level of [`Geometry::intersect`]: the placements whose
    /// boxes the ray enters before the best hit so far, each tested in its
    /// prototype's frame.
    fn intersect_shared(&self, o: DVec3, d: DVec3, tmin: f64, ignore: u32, best: &mut Hit) {
        let Some(top) = self.top.as_ref() else {
            return;
        };
        let mut hit = obvhs::ray::RayHit::none();
        top.ray_traverse(Self::f32_ray(o, d, best.t), &mut hit, |_, id| {
            let (placed, proto, local) = self.placement_ray(top, id, o, d);
            let before = best.t;
            let mut local_hit = obvhs::ray::RayHit::none();
            let ray = Self::f32_ray(local.0, local.1, best.t);
            proto.bvh.ray_traverse(ray, &mut local_hit, |_, i| {
                let tri = &proto.tris[proto.bvh.primitive_indices[i] as usize];
                Self::closer(tri, placed.first_id + tri.facet, local, tmin, ignore, best)
            });
            if best.t < before {
                (best.t * (1.0 + 1e-6)) as f32 + 1e-6
            } else {
                f32::INFINITY
            }
        });
    }

    /// The placement the top-level BVH's primitive `id` names, its
    /// prototype, and the ray `(o, d)` carried into the prototype's frame
    /// (an affine map: the same t).
    #[inline]
    fn placement_ray(
        &self,
        top: &CwBvh,
        id: usize,
        o: DVec3,
        d: DVec3,
    ) -> (&Placed, &Prototype, (DVec3, DVec3)) {
        let placed = &self.placed[top.primitive_indices[id] as usize];
        let proto = &self.shared[placed.prototype as usize];
        let local = (
            placed.to_local.transform_point3(o),
            placed.to_local.transform_vector3(d),
        );
        (placed, proto, local)
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
        let mut through: Vec<u32> = Vec::new();
        let segment = (o, d, tmin, tmax);
        // `ray_traverse_miss` returns true when nothing was hit.
        let flat_clear = self.bvh.as_ref().is_none_or(|bvh| {
            bvh.ray_traverse_miss(Self::f32_ray(o, d, tmax), |_, id| {
                let tri = &self.tris[bvh.primitive_indices[id] as usize];
                let passes = self.transmissive[tri.facet as usize];
                Self::blocks(tri, tri.facet, passes, segment, ignore, &mut through)
            })
        });
        if !flat_clear || self.blocked_by_shared(segment, ignore, &mut through) {
            return Visibility::Blocked;
        }
        through.sort_unstable();
        Visibility::Clear(through)
    }

    /// One triangle's test for [`Geometry::visibility`] (`facet` its id,
    /// `passes` whether it is transmissive, the segment in the triangle's
    /// frame): 0 (stop: blocked) for an opaque hit on the segment, else
    /// +∞, a transmissive hit added to `through` once.
    #[inline]
    fn blocks(
        tri: &Tri,
        facet: u32,
        passes: bool,
        (o, d, tmin, tmax): (DVec3, DVec3, f64, f64),
        ignore: [u32; 2],
        through: &mut Vec<u32>,
    ) -> f32 {
        if facet == ignore[0] || facet == ignore[1] {
            return f32::INFINITY;
        }
        let t = Self::intersect_tri(tri, o, d);
        if !(t > tmin && t < tmax) {
            return f32::INFINITY;
        }
        if passes {
            if !through.contains(&facet) {
                through.push(facet);
            }
            f32::INFINITY
        } else {
            0.0
        }
    }

    /// The second level of [`Geometry::visibility`]: whether an opaque
    /// shared facet lies on the segment (transmissive ones are added to
    /// `through`, once each).
    fn blocked_by_shared(
        &self,
        (o, d, tmin, tmax): (DVec3, DVec3, f64, f64),
        ignore: [u32; 2],
        through: &mut Vec<u32>,
    ) -> bool {
        let Some(top) = self.top.as_ref() else {
            return false;
        };
        !top.ray_traverse_miss(Self::f32_ray(o, d, tmax), |_, id| {
            let (placed, proto, (lo, ld)) = self.placement_ray(top, id, o, d);
            let segment = (lo, ld, tmin, tmax);
            let clear = proto
                .bvh
                .ray_traverse_miss(Self::f32_ray(lo, ld, tmax), |_, i| {
                    let tri = &proto.tris[proto.bvh.primitive_indices[i] as usize];
                    let facet = placed.first_id + tri.facet;
                    Self::blocks(tri, facet, proto.transmissive, segment, ignore, through)
                });
            if clear { f32::INFINITY } else { 0.0 }
        })
    }
}

/// A polygon's triangles (a fan from its first vertex), each naming its
/// polygon's index.
fn triangles(facets: &[Vec<DVec3>]) -> Vec<Tri> {
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
    tris
}

/// An f32 box around `pts`, padded by 1e-5 of `extent` so that f32
/// rounding never makes it miss a ray that hits what it holds.
fn padded_box(pts: impl IntoIterator<Item = DVec3>, extent: f64) -> Aabb {
    let pad = Vec3A::splat((extent * 1e-5) as f32);
    let mut lo = Vec3A::splat(f32::INFINITY);
    let mut hi = Vec3A::splat(f32::NEG_INFINITY);
    for p in pts {
        let q = Vec3A::new(p.x as f32, p.y as f32, p.z as f32);
        lo = lo.min(q);
        hi = hi.max(q);
    }
    Aabb::new(lo - pad, hi + pad)
}

/// A BVH over `tris` (boxes padded for a frame of half-size `extent`).
fn bvh_over(tris: &[Tri], extent: f64) -> Option<CwBvh> {
    let boxes: Vec<PrimBox> = tris
        .iter()
        .map(|t| PrimBox(padded_box([t.v0, t.v0 + t.e1, t.v0 + t.e2], extent)))
        .collect();
    (!boxes.is_empty()).then(|| build(&boxes))
}

/// PLOC merges two nodes only when each is the other's best partner; among
/// equal boxes evenly spaced (placements on a line, a regular row of
/// facets) every node ties with its right-hand neighbour, one pair merges
/// per pass and the build turns quadratic (10⁵ placements on a line took
/// 151 s, issue 46). Growing each box by a deterministic share of up to
/// 10⁻⁴ of its size breaks the ties; the bounds stay conservative.
fn build(boxes: &[PrimBox]) -> CwBvh {
    let boxes: Vec<PrimBox> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let a = b.0;
            let size = (a.max - a.min).max_element().max(f32::MIN_POSITIVE);
            let share = (crate::tracer::mix64(i as u64) >> 40) as f32 / (1u64 << 24) as f32;
            let grow = Vec3A::splat(size * 1e-4 * share);
            PrimBox(Aabb::new(a.min - grow, a.max + grow))
        })
        .collect();
    obvhs::cwbvh::builder::build_cwbvh(
        &boxes,
        BvhBuildParams::medium_build(),
        &mut std::time::Duration::default(),
    )
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
    fn shared_placements_are_hit_without_any_flat_facet() {
        // One quad, placed at z = 1 and (turned, scaled ×2) at z = 3: no
        // flat facets at all (the first level has no BVH).
        let g = Geometry::new(DVec3::ZERO, 10.0, &[], Vec::new()).with_shared(vec![SharedInput {
            facets: vec![quad(0.0, 1.0)],
            normals: vec![DVec3::Z],
            placements: vec![
                DAffine3::from_translation(DVec3::new(0.0, 0.0, 1.0)),
                DAffine3::from_scale_rotation_translation(
                    DVec3::splat(2.0),
                    glam::DQuat::from_rotation_z(0.3),
                    DVec3::new(0.0, 0.0, 3.0),
                ),
            ],
            transmissive: false,
            material: 0,
        }]);
        assert!(g.has_shared());
        let o = DVec3::new(0.5, 0.5, 10.0);
        let h = g
            .intersect(o, -DVec3::Z, 0.0, f64::INFINITY, u32::MAX)
            .unwrap();
        // Ids follow the (zero) flat facets: placement 1's facet 0.
        assert_eq!(h.facet, 1);
        assert!((h.t - 7.0).abs() < 1e-12, "{}", h.t);
        assert!((g.shared_normal(h.facet) - DVec3::Z).length() < 1e-12);
        // Ignoring it, the ray goes on to placement 0 at z = 1.
        let h0 = g.intersect(o, -DVec3::Z, 0.0, f64::INFINITY, 1).unwrap();
        assert_eq!((h0.facet, (h0.t - 9.0).abs() < 1e-12), (0, true));
        assert_eq!(
            g.visibility(o, -DVec3::Z, 0.0, 8.0, [u32::MAX; 2]),
            Visibility::Blocked
        );
        assert_eq!(
            g.visibility(o, -DVec3::Z, 0.0, 6.0, [u32::MAX; 2]),
            Visibility::Clear(Vec::new())
        );
        // Beside both placements' squares: a miss.
        let beside = DVec3::new(2.5, 0.0, 10.0);
        assert!(
            g.intersect(beside, -DVec3::Z, 0.0, f64::INFINITY, u32::MAX)
                .is_none()
        );
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
