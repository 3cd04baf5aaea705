//! Sampling directions uniformly in the solid angle of triangles and
//! rectangles, and uniform area sampling as the fallback.
//!
//! Every sampler is precomputed once per (receiving point, emitter) pair and
//! then maps `u ∈ [0,1)²` to a sample. Constructors return `None` when the
//! solid angle is too small (or the geometry degenerate) for the spherical
//! maps to stay accurate in f64; callers then sample the area instead, which
//! for such small solid angles has practically the same variance.

use crate::closed_form::polygon_solid_angle;
use glam::DVec3;
use std::f64::consts::PI;

/// Below this solid angle (sr) the spherical samplers decline (`None`): their
/// inverse-cosine steps resolve angles only to ~√ε ≈ 10⁻⁸ rad, which for a
/// 10⁻⁶ sr emitter (angular size ~10⁻³ rad) is a 10⁻⁵ relative placement error.
pub const MIN_SOLID_ANGLE_SR: f64 = 1e-6;

/// The spherical samplers decline (`None`) when the point's height above the
/// emitter plane is below this fraction of its distance to the farthest
/// vertex: at 10⁻¹⁰ rad elevation every direction is within rounding of the
/// plane and the spherical construction (not the answer) loses meaning.
pub const MIN_RELATIVE_HEIGHT: f64 = 1e-10;

/// Angle between unit vectors, robust near 0 and π (atan2 form).
fn angle_between(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// Unit component of `v` orthogonal to unit `w` (Gram–Schmidt); `None` if parallel.
fn orthonormal_part(v: DVec3, w: DVec3) -> Option<DVec3> {
    (v - w * v.dot(w)).try_normalize()
}

/// Solid-angle sampler for the triangle `(a, b, c)` seen from a point.
///
/// **Method**: Arvo 1995, "Stratified sampling of spherical triangles"
/// (SIGGRAPH): the first coordinate picks the sub-triangle area `u₀·Ω`
/// (locating `C'` on arc `AC`), the second picks `cos θ` uniformly along arc
/// `B C'`. Two numerical refinements over the paper's listing: the sub-area
/// is `π + α + u₀ Ω` with `Ω` from Van Oosterom–Strackee (no `α+β+γ−π`
/// cancellation), and the last step uses `sin²(θ/2) = u₁ sin²(θ'/2)` with
/// `sin(θ'/2) = |B − C'|/2`, which is exact for short arcs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphericalTriangle {
    a: DVec3,
    b: DVec3,
    /// Unit vector in the plane of `a` and `c`, perpendicular to `a`, towards `c`.
    c_perp_a: DVec3,
    alpha: f64,
    cos_c: f64,
    solid_angle: f64,
}

impl SphericalTriangle {
    /// Precompute the sampler for triangle `(a, b, c)` seen from `point`.
    ///
    /// **Degenerate cases** → `None` (caller falls back to area sampling):
    /// the point on a vertex or in (within [`MIN_RELATIVE_HEIGHT`] of) the
    /// triangle's plane, including on an edge or inside it, collinear
    /// vertices, non-finite input, or a solid angle below
    /// [`MIN_SOLID_ANGLE_SR`]. A point close to an edge (say 10⁻⁹ away, where
    /// two vertex directions are antipodal to rounding) is handled by
    /// labelling that pair (A, C), which keeps Arvo's construction
    /// conditioned; samples stay unbiased there (tested down to 10⁻⁹). Near-2π triangles (point just in front
    /// of the interior) are handled: all angles are formed with `atan2`.
    pub fn new(point: DVec3, a: DVec3, b: DVec3, c: DVec3) -> Option<Self> {
        if !(point.is_finite() && a.is_finite() && b.is_finite() && c.is_finite()) {
            return None;
        }
        let plane_n = (b - a).cross(c - a).try_normalize()?;
        let far = (a - point)
            .length()
            .max((b - point).length())
            .max((c - point).length());
        if (point - a).dot(plane_n).abs() < MIN_RELATIVE_HEIGHT * far {
            return None;
        }
        let solid_angle = polygon_solid_angle(point, &[a, b, c]);
        if solid_angle.is_nan() || solid_angle < MIN_SOLID_ANGLE_SR {
            return None;
        }
        // Relabel (keeping the cyclic order) so that the most nearly antipodal
        // vertex pair, which occurs when the point is close to an edge, is
        // (A, C): Arvo's `cos c = A·B` step and the final arc B → C' then
        // stay well conditioned, and the arc A → C is handled through its
        // plane normal, which edge differences give to full precision.
        let dirs = [a - point, b - point, c - point];
        let verts = [a, b, c];
        let unit = |v: DVec3| v.try_normalize();
        let (u0, u1, u2) = (unit(dirs[0])?, unit(dirs[1])?, unit(dirs[2])?);
        let dots = [u0.dot(u1), u1.dot(u2), u2.dot(u0)]; // pairs (0,1), (1,2), (2,0)
        let worst = (0..3)
            .min_by(|&i, &j| dots[i].total_cmp(&dots[j]))
            .unwrap_or(0);
        // Pair (i, i+1) should become (C, A): A = vertex i+1.
        let ia = (worst + 1) % 3;
        let (ib, ic) = ((ia + 1) % 3, (ia + 2) % 3);
        let (a, b, c) = (verts[ia], verts[ib], verts[ic]);
        let (ra, rb, rc) = (dirs[ia], dirs[ib], dirs[ic]);
        let ua = ra.try_normalize()?;
        let ub = rb.try_normalize()?;
        // Edge-plane normals from edge differences for precision.
        let n_ab = ra.cross(b - a).try_normalize()?;
        let _n_bc = rb.cross(c - b).try_normalize()?;
        let n_ca = rc.cross(a - c).try_normalize()?;
        // Interior angle at A: between the planes (A,B) and (A,C).
        let alpha = angle_between(n_ab, -n_ca);
        // Unit vector ⟂ A towards C in their plane: (A × C) × A with
        // A × C = −n_ca (robust even when A and C are nearly antipodal).
        let c_perp_a = (-n_ca).cross(ua).try_normalize()?;
        Some(Self {
            a: ua,
            b: ub,
            c_perp_a,
            alpha,
            cos_c: ua.dot(ub),
            solid_angle,
        })
    }

    /// Solid angle of the triangle, sr (Van Oosterom–Strackee, equal to
    /// [`polygon_solid_angle`]).
    pub fn solid_angle(&self) -> f64 {
        self.solid_angle
    }

    /// Uniformly distributed unit direction (pdf `1/Ω`) from the point into
    /// the triangle, `u ∈ [0,1)²` (Arvo 1995). Stratification in `u` carries
    /// over to the sphere (the map is area preserving and continuous).
    pub fn sample(&self, u: [f64; 2]) -> DVec3 {
        let (sin_alpha, cos_alpha) = self.alpha.sin_cos();
        // Sub-triangle area A' = u0 Ω; the spherical excess relation uses A' + π − α.
        let a_hat = u[0] * self.solid_angle;
        let (s, t) = (a_hat - self.alpha).sin_cos();
        let uu = t - cos_alpha;
        let vv = s + sin_alpha * self.cos_c;
        let num = (vv * t - uu * s) * cos_alpha - vv;
        let den = (vv * s + uu * t) * sin_alpha;
        let q = if den != 0.0 {
            (num / den).clamp(-1.0, 1.0)
        } else {
            1.0
        };
        let sin_q = (1.0 - q * q).max(0.0).sqrt();
        let c_prime = (self.a * q + self.c_perp_a * sin_q).normalize();
        // Uniform in cos θ along arc B → C'.
        let half_chord = 0.5 * (self.b - c_prime).length(); // sin(θ'/2)
        let sin_half = (u[1].max(0.0).sqrt() * half_chord).min(1.0);
        let theta = 2.0 * sin_half.asin();
        let Some(perp) = orthonormal_part(c_prime, self.b) else {
            return self.b;
        };
        let (st, ct) = theta.sin_cos();
        (self.b * ct + perp * st).normalize()
    }
}

/// Solid-angle sampler for a rectangle (corner `s`, perpendicular edges
/// `ex`, `ey`) seen from a point.
///
/// **Method**: Ureña, Fajardo & King 2013, "An area-preserving
/// parametrization for spherical rectangles" (EGSR / Computer Graphics Forum
/// 32(4)), in the rectangle's local frame with the point at the origin. The
/// edge normals use the paper's closed forms; the solid angle comes from
/// Van Oosterom–Strackee (the paper's `Σγ − 2π` cancels for small
/// rectangles) and the first coordinate maps to `k + u₀ S`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphericalRectangle {
    origin: DVec3,
    x: DVec3,
    y: DVec3,
    z: DVec3,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    z0: f64,
    b0: f64,
    b1: f64,
    k: f64,
    solid_angle: f64,
}

impl SphericalRectangle {
    /// Precompute the sampler for the rectangle `corner + [0,1]·ex + [0,1]·ey`
    /// seen from `point`.
    ///
    /// **Degenerate cases** → `None` (caller falls back to area sampling):
    /// zero-length or non-perpendicular edges (`|êx·êy| > 10⁻⁶`), the point
    /// in (within [`MIN_RELATIVE_HEIGHT`] of) the rectangle's plane, incl. on
    /// an edge, non-finite input, or a
    /// solid angle below [`MIN_SOLID_ANGLE_SR`]. Near-2π rectangles are fine.
    pub fn new(point: DVec3, corner: DVec3, ex: DVec3, ey: DVec3) -> Option<Self> {
        if !(point.is_finite() && corner.is_finite() && ex.is_finite() && ey.is_finite()) {
            return None;
        }
        let exl = ex.length();
        let eyl = ey.length();
        if exl == 0.0 || eyl == 0.0 {
            return None;
        }
        let x = ex / exl;
        let y = ey / eyl;
        if x.dot(y).abs() > 1e-6 {
            return None;
        }
        let mut z = x.cross(y).normalize();
        let d = corner - point;
        let mut z0 = d.dot(z);
        if z0 > 0.0 {
            z = -z;
            z0 = -z0;
        }
        let far = d
            .length()
            .max((d + ex + ey).length())
            .max((d + ex).length())
            .max((d + ey).length());
        if -z0 < MIN_RELATIVE_HEIGHT * far {
            return None;
        }
        let solid_angle =
            polygon_solid_angle(point, &[corner, corner + ex, corner + ex + ey, corner + ey]);
        if solid_angle.is_nan() || solid_angle < MIN_SOLID_ANGLE_SR {
            return None;
        }
        let x0 = d.dot(x);
        let y0 = d.dot(y);
        let x1 = x0 + exl;
        let y1 = y0 + eyl;
        // Edge-plane normals (paper, §3): n0 ∝ (0, z0, −y0), n1 ∝ (−z0, 0, x1) (unused),
        // n2 ∝ (0, −z0, y1), n3 ∝ (z0, 0, −x0).
        let n0 = DVec3::new(0.0, z0, -y0).normalize();
        let n2 = DVec3::new(0.0, -z0, y1).normalize();
        let n3 = DVec3::new(z0, 0.0, -x0).normalize();
        let g2 = angle_between(n2, -n3);
        let g3 = angle_between(n3, -n0);
        let k = 2.0 * PI - g2 - g3;
        Some(Self {
            origin: point,
            x,
            y,
            z,
            x0,
            x1,
            y0,
            y1,
            z0,
            b0: n0.z,
            b1: n2.z,
            k,
            solid_angle,
        })
    }

    /// Solid angle of the rectangle, sr (equal to [`polygon_solid_angle`]).
    pub fn solid_angle(&self) -> f64 {
        self.solid_angle
    }

    /// The sampled point on the rectangle, uniformly distributed in solid
    /// angle seen from the point (pdf `1/Ω` per steradian), `u ∈ [0,1)²`.
    pub fn sample(&self, u: [f64; 2]) -> DVec3 {
        let au = u[0] * self.solid_angle + self.k;
        let (sin_au, cos_au) = au.sin_cos();
        let fu = (cos_au * self.b0 - self.b1) / sin_au;
        let cu = if fu.is_finite() {
            (fu.signum() / (fu * fu + self.b0 * self.b0).sqrt()).clamp(-1.0, 1.0)
        } else {
            fu.signum()
        };
        let one_minus = (1.0 - cu * cu).max(0.0);
        let xu = if one_minus > 0.0 {
            (-(cu * self.z0) / one_minus.sqrt()).clamp(self.x0, self.x1)
        } else if cu * self.z0 < 0.0 {
            self.x1
        } else {
            self.x0
        };
        // Plain square roots, not `hypot`: these are distances within the
        // scene (no overflow or underflow to guard against), and glibc's
        // `hypot` cost 5 % of a direct-light render.
        let d2 = xu * xu + self.z0 * self.z0;
        let d = d2.sqrt();
        let h0 = self.y0 / (d2 + self.y0 * self.y0).sqrt();
        let h1 = self.y1 / (d2 + self.y1 * self.y1).sqrt();
        let hv = h0 + u[1] * (h1 - h0);
        let hv2 = hv * hv;
        let yv = if hv2 < 1.0 - 1e-14 {
            ((hv * d) / (1.0 - hv2).sqrt()).clamp(self.y0, self.y1)
        } else {
            self.y1
        };
        self.origin + self.x * xu + self.y * yv + self.z * self.z0
    }
}

/// Uniform area sampling of triangle `(a, b, c)`: returns a point on it
/// (pdf `1/area`). Square-root parametrisation (Turk 1990 / Shirley):
/// `b₀ = 1 − √u₀`, `b₁ = u₁ √u₀`. A degenerate triangle returns points on
/// its segment/point; never panics.
pub fn sample_triangle_area(a: DVec3, b: DVec3, c: DVec3, u: [f64; 2]) -> DVec3 {
    let su = u[0].max(0.0).sqrt();
    let b0 = 1.0 - su;
    let b1 = u[1] * su;
    // Written relative to `a` so distant triangles keep precision.
    a + (b - a) * b1 + (c - a) * (1.0 - b0 - b1)
}

/// Uniform area sampling of the parallelogram `corner + u₀ ex + u₁ ey`
/// (pdf `1/|ex × ey|`).
pub fn sample_parallelogram_area(corner: DVec3, ex: DVec3, ey: DVec3, u: [f64; 2]) -> DVec3 {
    corner + ex * u[0] + ey * u[1]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_sample_corners() {
        let p = DVec3::ZERO;
        let (a, b, c) = (
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
        );
        let t = SphericalTriangle::new(p, a, b, c).unwrap();
        // u1 = 0 → B for any u0; (0, 1) → A; (1, 1) → C: the three vertices
        // (whichever labelling the constructor chose).
        let vb = t.sample([0.3, 0.0]);
        assert!((t.sample([0.9, 0.0]) - vb).length() < 1e-12);
        let hits = [vb, t.sample([0.0, 1.0]), t.sample([1.0, 1.0])];
        for v in [a, b, c] {
            let v = v.normalize();
            assert!(hits.iter().any(|h| (*h - v).length() < 1e-9), "{v} not hit");
        }
    }

    #[test]
    fn rectangle_sample_corners_and_degenerate() {
        let p = DVec3::new(0.2, 0.3, 1.0);
        let r = SphericalRectangle::new(p, DVec3::ZERO, DVec3::X, DVec3::Y).unwrap();
        let q = r.sample([0.0, 0.0]);
        assert!(q.z.abs() < 1e-12 && (q.x.abs() < 1e-9 || (q.x - 1.0).abs() < 1e-9));
        assert!(
            SphericalRectangle::new(DVec3::new(0.5, 0.5, 0.0), DVec3::ZERO, DVec3::X, DVec3::Y)
                .is_none()
        );
        assert!(SphericalTriangle::new(DVec3::ZERO, DVec3::X, DVec3::X, DVec3::Y).is_none());
    }
}

/// The first two dimensions of the Sobol sequence (a (0,2)-sequence:
/// every aligned block of 2^m points is stratified in every elementary
/// interval of area 2^-m), Owen-scrambled by a hash (Burley 2020, after
/// Laine and Karras), as points in [0,1)². Used to stratify a pixel's
/// final-gather directions across all of its camera samples: consecutive
/// blocks of `2^m` indices are themselves well stratified, and so is their
/// union, so adding batches keeps the pattern.
pub fn sobol_owen_2d(index: u32, seed: u64) -> [f64; 2] {
    let x = index.reverse_bits();
    // Second dimension: direction numbers v_0 = 2^31, v_k = v_{k-1} ^ (v_{k-1} >> 1).
    let mut y = 0u32;
    let mut v = 1u32 << 31;
    let mut i = index;
    while i != 0 {
        if i & 1 == 1 {
            y ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    let s0 = (seed ^ (seed >> 32)) as u32;
    let s1 = ((seed.wrapping_mul(0x9E37_79B9_7F4A_7C15)) >> 32) as u32;
    let to_unit = |b: u32| (b as f64 + 0.5) * (1.0 / 4_294_967_296.0);
    [to_unit(owen(x, s0)), to_unit(owen(y, s1))]
}

/// A sample index shuffled by a nested uniform scramble (Burley 2020,
/// §3.3): a permutation of the indices that maps every aligned block of
/// 2^m indices onto an aligned block, so the first 2^m shuffled points are
/// still a net, while two sequences drawn with differently shuffled
/// indices are no longer paired point by point (without it, a second
/// sequence's digits repeat the first's and a pixel's estimate converges
/// to a wrong value of its own).
pub fn shuffled_index(index: u32, seed: u64) -> u32 {
    owen(index, (seed ^ (seed >> 29)) as u32)
}

/// Nested uniform (Owen) scramble of a 32-bit fixed-point coordinate by a
/// hash: bit-reverse, apply an invertible hash that only carries upward
/// (each bit depends on the bits above it in the original), reverse back.
fn owen(x: u32, seed: u32) -> u32 {
    let mut v = x.reverse_bits();
    v = v.wrapping_add(seed);
    v ^= v.wrapping_mul(0x6c50_b47c);
    v ^= v.wrapping_mul(0xb82f_1e52);
    v ^= v.wrapping_mul(0xc7af_e638);
    v ^= v.wrapping_mul(0x8d22_f6e6);
    v.reverse_bits()
}

#[cfg(test)]
mod sobol_tests {
    use super::sobol_owen_2d;

    #[test]
    fn blocks_are_stratified_in_every_elementary_interval() {
        // A (0,m,2)-net: each of the 2^m boxes of every shape 2^-a × 2^-b
        // (a + b = m) holds exactly one point of an aligned block.
        for seed in [0u64, 7, 0xDEAD_BEEF] {
            for block in 0..3u32 {
                let m = 6;
                let n = 1u32 << m;
                let pts: Vec<[f64; 2]> =
                    (0..n).map(|i| sobol_owen_2d(block * n + i, seed)).collect();
                for a in 0..=m {
                    let b = m - a;
                    let mut seen = vec![0u32; n as usize];
                    for p in &pts {
                        let i = (p[0] * (1u32 << a) as f64) as usize;
                        let j = (p[1] * (1u32 << b) as f64) as usize;
                        seen[i * (1usize << b) + j] += 1;
                    }
                    assert!(
                        seen.iter().all(|&c| c == 1),
                        "seed {seed} block {block} a {a}"
                    );
                }
            }
        }
    }

    #[test]
    fn integrates_a_smooth_function_far_better_than_random() {
        // ∫∫ sin(πx) sin(πy) = 4/π².
        let want = 4.0 / (std::f64::consts::PI * std::f64::consts::PI);
        let n = 256;
        let got: f64 = (0..n)
            .map(|i| {
                let [x, y] = sobol_owen_2d(i, 3);
                (std::f64::consts::PI * x).sin() * (std::f64::consts::PI * y).sin()
            })
            .sum::<f64>()
            / n as f64;
        // Random sampling would give ~0.3/√256 ≈ 2e-2; a scrambled net ~n^-1.5.
        assert!((got - want).abs() < 2e-3, "{got} vs {want}");
    }
}
