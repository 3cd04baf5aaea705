//! Facet geometry: vector area, centroid, degeneracy checks, the quad and box
//! helpers, and frustum clipping for the effect plan.

use glam::DVec3;

use crate::Camera;

/// Largest distance of a quad's vertex from its best-fit plane, as a fraction
/// of its longest edge, before it counts as non-planar.
pub const PLANARITY_TOLERANCE: f64 = 1e-5;

/// Smallest area, as a fraction of the longest edge squared, of a facet (and
/// of each corner triangle of a quad) before it counts as degenerate.
const AREA_TOLERANCE: f64 = 1e-9;

/// Smallest facet a scene may hold: its longest edge, scene units. Below
/// about 1e-77 the squared lengths the area test takes underflow, and a
/// square of 1e-90 was called "collinear"; 1e-60 keeps every product the
/// tracer forms (areas, solid angles, their squares) in range.
pub const MIN_FACET_SIZE: f64 = 1e-60;

/// The longest edge of a facet's vertices (0 for fewer than two).
pub(crate) fn longest_edge(v: &[DVec3]) -> f64 {
    let n = v.len();
    (0..n)
        .map(|i| (v[(i + 1) % n] - v[i]).length())
        .fold(0.0, f64::max)
}

/// Newell's vector Σ vᵢ × vᵢ₊₁: normal × twice the area for planar polygons.
pub(crate) fn newell(v: &[DVec3]) -> DVec3 {
    let n = v.len();
    if n < 3 {
        return DVec3::ZERO;
    }
    // Relative to the first vertex, for accuracy far from the origin.
    let o = v[0];
    let mut s = DVec3::ZERO;
    for i in 0..n {
        s += (v[i] - o).cross(v[(i + 1) % n] - o);
    }
    s
}

/// Area centroid of a triangle or fan-triangulated convex polygon.
pub(crate) fn centroid(v: &[DVec3]) -> DVec3 {
    if v.is_empty() {
        return DVec3::ZERO;
    }
    let o = v[0];
    let mut sum = DVec3::ZERO;
    let mut total = 0.0;
    for i in 1..v.len().saturating_sub(1) {
        let a = 0.5 * (v[i] - o).cross(v[i + 1] - o).length();
        sum += a * (o + v[i] + v[i + 1]) / 3.0;
        total += a;
    }
    if total > 0.0 {
        sum / total
    } else {
        v.iter().copied().sum::<DVec3>() / v.len() as f64
    }
}

/// Why vertices are not a usable facet ([`check_facet`]); the message
/// says what is wrong, the caller adds the file, line and field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FacetError {
    #[error("a facet has 3 or 4 vertices, this one has {count}")]
    VertexCount { count: usize },
    #[error("vertex {index} is not finite ({vertex})")]
    NonFinite { index: usize, vertex: DVec3 },
    #[error("zero area: all vertices coincide")]
    AllCoincide,
    #[error(
        "degenerate: the facet is {longest:e} units across, below the {MIN_FACET_SIZE:e} a facet must span (its area would underflow)"
    )]
    TooSmall { longest: f64 },
    #[error("zero-length edge: vertices {first} and {second} coincide")]
    ZeroEdge { first: usize, second: usize },
    /// Zero area, or a sliver: an area not above `threshold`
    /// ([`AREA_TOLERANCE`] × the longest edge squared).
    #[error("{}", collinear_message(*.area, *.threshold))]
    Collinear { area: f64, threshold: f64 },
    #[error(
        "vertices {}, {}, {} are collinear (the quad is really a triangle; write it as one)",
        .corner, (.corner + 1) % 4, (.corner + 2) % 4
    )]
    CollinearCorner { corner: usize },
    #[error(
        "non-planar quad: a vertex is {offset:.3e} units off the facet's plane \
         (tolerance {:.1e} × the longest edge); split it into two triangles",
        PLANARITY_TOLERANCE
    )]
    NonPlanar { offset: f64 },
    #[error(
        "non-convex quad: the corner at vertex {vertex} turns the wrong way \
         (reflex or self-intersecting); split it into two triangles"
    )]
    NonConvex { vertex: usize },
}

/// [`FacetError::Collinear`]'s message: zero area as such, a sliver with
/// the area found and the threshold it is not above.
fn collinear_message(area: f64, threshold: f64) -> String {
    if area == 0.0 {
        "zero area: the vertices are collinear".to_string()
    } else {
        format!(
            "sliver: area {area:.3e} units² is not above the threshold {threshold:.3e} units² \
             ({AREA_TOLERANCE:e} × the longest edge squared); the vertices are nearly collinear"
        )
    }
}

/// Checks that `v` is a usable facet: 3 or 4 finite vertices, non-zero area,
/// no three collinear vertices, and for quads planar (within
/// [`PLANARITY_TOLERANCE`]) and convex.
pub fn check_facet(v: &[DVec3]) -> Result<(), FacetError> {
    if !(v.len() == 3 || v.len() == 4) {
        return Err(FacetError::VertexCount { count: v.len() });
    }
    for (i, p) in v.iter().enumerate() {
        if !p.is_finite() {
            return Err(FacetError::NonFinite {
                index: i,
                vertex: *p,
            });
        }
    }
    let n = v.len();
    let longest = (0..n)
        .map(|i| (v[(i + 1) % n] - v[i]).length())
        .fold(0.0, f64::max);
    if longest == 0.0 {
        return Err(FacetError::AllCoincide);
    }
    if longest < MIN_FACET_SIZE {
        return Err(FacetError::TooSmall { longest });
    }
    for i in 0..n {
        for j in i + 1..n {
            if (v[j] - v[i]).length() <= 1e-12 * longest {
                return Err(FacetError::ZeroEdge {
                    first: i,
                    second: j,
                });
            }
        }
    }
    let nv = newell(v);
    let area = 0.5 * nv.length();
    let threshold = AREA_TOLERANCE * longest * longest;
    if area <= threshold {
        return Err(FacetError::Collinear { area, threshold });
    }
    if n == 3 {
        return Ok(());
    }
    let normal = nv / nv.length();
    // Each corner: the turn must be non-degenerate and turn the same way.
    for i in 0..4 {
        let a = v[i];
        let b = v[(i + 1) % 4];
        let c = v[(i + 2) % 4];
        let turn = (b - a).cross(c - b);
        let corner_area = 0.5 * turn.length();
        if corner_area <= AREA_TOLERANCE * longest * longest {
            return Err(FacetError::CollinearCorner { corner: i });
        }
    }
    let c = centroid(v);
    let off = v
        .iter()
        .map(|p| (*p - c).dot(normal).abs())
        .fold(0.0, f64::max);
    if off > PLANARITY_TOLERANCE * longest {
        return Err(FacetError::NonPlanar { offset: off });
    }
    for i in 0..4 {
        let a = v[i];
        let b = v[(i + 1) % 4];
        let cc = v[(i + 2) % 4];
        if (b - a).cross(cc - b).dot(normal) <= 0.0 {
            return Err(FacetError::NonConvex {
                vertex: (i + 1) % 4,
            });
        }
    }
    Ok(())
}

/// Why a `quad` has no rectangle ([`quad_vertices`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub(crate) enum QuadError {
    #[error("normal is a zero vector")]
    ZeroNormal,
    #[error("width_axis is zero or parallel to the normal")]
    BadWidthAxis,
    #[error("cannot choose a width axis")]
    NoWidthAxis,
}

/// Vertices of a `width × height` rectangle centred at `center` facing
/// `normal`, its width along `width_axis` projected into the plane;
/// counter-clockwise seen from the front. An error when the axes are degenerate.
pub(crate) fn quad_vertices(
    center: DVec3,
    width: f64,
    height: f64,
    normal: DVec3,
    width_axis: Option<DVec3>,
) -> Result<[DVec3; 4], QuadError> {
    let n = normal.try_normalize().ok_or(QuadError::ZeroNormal)?;
    let project = |a: DVec3| (a - n * a.dot(n)).try_normalize();
    let u = match width_axis {
        Some(a) => project(a).ok_or(QuadError::BadWidthAxis)?,
        // Default: x projected into the plane, or y when the normal is along x.
        None => project(DVec3::X)
            .filter(|_| n.x.abs() < 0.999_999)
            .or_else(|| project(DVec3::Y))
            .ok_or(QuadError::NoWidthAxis)?,
    };
    let v = n.cross(u);
    let (hw, hh) = (0.5 * width, 0.5 * height);
    Ok([
        center - hw * u - hh * v,
        center + hw * u - hh * v,
        center + hw * u + hh * v,
        center - hw * u + hh * v,
    ])
}

/// The six faces of an axis-aligned box, named `-x`, `+x`, `-y`, `+y`, `-z`,
/// `+z`, facing outward (or inward), each counter-clockwise from its front.
pub(crate) fn box_faces(min: DVec3, max: DVec3, inward: bool) -> Vec<(&'static str, [DVec3; 4])> {
    let c = 0.5 * (min + max);
    let s = max - min;
    let faces: [(&str, DVec3, DVec3, f64, f64, DVec3); 6] = [
        (
            "-x",
            -DVec3::X,
            DVec3::Y,
            s.y,
            s.z,
            DVec3::new(min.x, c.y, c.z),
        ),
        (
            "+x",
            DVec3::X,
            DVec3::Y,
            s.y,
            s.z,
            DVec3::new(max.x, c.y, c.z),
        ),
        (
            "-y",
            -DVec3::Y,
            DVec3::X,
            s.x,
            s.z,
            DVec3::new(c.x, min.y, c.z),
        ),
        (
            "+y",
            DVec3::Y,
            DVec3::X,
            s.x,
            s.z,
            DVec3::new(c.x, max.y, c.z),
        ),
        (
            "-z",
            -DVec3::Z,
            DVec3::X,
            s.x,
            s.y,
            DVec3::new(c.x, c.y, min.z),
        ),
        (
            "+z",
            DVec3::Z,
            DVec3::X,
            s.x,
            s.y,
            DVec3::new(c.x, c.y, max.z),
        ),
    ];
    faces
        .iter()
        .map(|&(name, out, axis, w, h, centre)| {
            let n = if inward { -out } else { out };
            // Axes are unit and perpendicular, so this cannot fail.
            let q = quad_vertices(centre, w, h, n, Some(axis)).unwrap_or([centre; 4]);
            (name, q)
        })
        .collect()
}

/// Sutherland–Hodgman clip of `polygon` against the camera frustum (the
/// plane through the eye perpendicular to the view and the four sides);
/// true when anything is left.
pub(crate) fn frustum_overlaps(camera: &Camera, polygon: &[DVec3]) -> bool {
    let (r, u, f) = camera.basis();
    let (th, tv) = camera.tan_half_fov();
    // Camera coordinates (x right, y up, z forward).
    let mut poly: Vec<DVec3> = polygon
        .iter()
        .map(|p| {
            let d = *p - camera.position;
            DVec3::new(d.dot(r), d.dot(u), d.dot(f))
        })
        .collect();
    let planes: [fn(DVec3, f64, f64) -> f64; 5] = [
        |p, _, _| p.z,
        |p, th, _| p.z * th - p.x,
        |p, th, _| p.z * th + p.x,
        |p, _, tv| p.z * tv - p.y,
        |p, _, tv| p.z * tv + p.y,
    ];
    for plane in planes {
        if poly.is_empty() {
            return false;
        }
        let mut out = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let a = poly[i];
            let b = poly[(i + 1) % poly.len()];
            let (da, db) = (plane(a, th, tv), plane(b, th, tv));
            if da >= 0.0 {
                out.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                let t = da / (da - db);
                out.push(a + t * (b - a));
            }
        }
        poly = out;
    }
    // Something strictly in front of the eye must remain.
    poly.iter().any(|p| p.z > 0.0)
}
