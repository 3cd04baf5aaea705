//! The light tree: a bounding-volume hierarchy over the emitters (area
//! sources and point sources), after Conty & Kulla 2018 and pbrt-v4's
//! `BVHLightSampler`, so that a camera vertex pays for a few emitters chosen
//! by importance instead of every emitter in the scene (issue 27: a night
//! town has thousands of lamps and lit windows).
//!
//! Each node bounds its emitters' positions (a box), their summed on-axis
//! intensity and their emission directions (a cone). From a receiving point
//! `p` with normal `n` the node's *importance* is a conservative upper bound
//! of the shape of its irradiance there: `Φ cos^k θ′_e cos θ′_r / d²`, the
//! two cosines taken at the most favourable angles the box and the cone
//! allow, k the least falloff exponent of the node's emitters.
//! It is zero only where no emitter of the node can light `p` (behind every
//! emitter, or below the receiver's horizon), so a light that contributes
//! always has a non-zero probability.
//!
//! Selection ([`LightTree::select`]) *splits* the tree deterministically
//! (from `p`, `n` only) into at most `branches` subtrees, always splitting
//! the brightest, most spread-out subtree (where importance is a poor guide
//! to the irradiance), then picks one emitter in each subtree by descending
//! with probability proportional to the children's importance. Each pick is
//! returned with `1 / pmf`: the caller evaluates that emitter with its usual
//! estimator and divides by the probability, which is unbiased. Cost per
//! vertex: `branches` descents of depth `O(log N)`.

use glam::DVec3;
use rand::Rng;
use rand_pcg::Pcg64Mcg;
use std::f64::consts::{FRAC_PI_2, PI};

/// Which emitter a leaf holds (index into the tracer's `area` or `points`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LightRef {
    Area(u32),
    Point(u32),
}

/// A cone of emission directions: every emitter in the node emits only
/// within `theta_e` of some direction within `theta_o` of `axis`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cone {
    pub(crate) axis: DVec3,
    pub(crate) theta_o: f64,
    pub(crate) theta_e: f64,
    /// Least falloff exponent of the node's emitters about their own axis
    /// (`cos^k` of the emission angle: k = m + 1 for an area source, m for
    /// a point source): `cos^k` with the least k bounds them all.
    pub(crate) exponent: f64,
}

impl Cone {
    /// Every direction (isotropic point sources, or a degenerate axis).
    pub(crate) const ALL: Cone = Cone {
        axis: DVec3::Z,
        theta_o: PI,
        theta_e: FRAC_PI_2,
        exponent: 0.0,
    };

    /// The smallest cone (of this construction) holding both (Conty & Kulla
    /// 2018, Algorithm 1). Padded by 1e-9 rad so rounding never excludes a
    /// direction.
    fn union(a: Cone, b: Cone) -> Cone {
        let (a, b) = if b.theta_o > a.theta_o {
            (b, a)
        } else {
            (a, b)
        };
        let theta_e = a.theta_e.max(b.theta_e);
        let exponent = a.exponent.min(b.exponent);
        let theta_d = a.axis.dot(b.axis).clamp(-1.0, 1.0).acos();
        if (theta_d + b.theta_o).min(PI) <= a.theta_o {
            return Cone {
                theta_e,
                exponent,
                ..a
            };
        }
        let theta_o = 0.5 * (a.theta_o + theta_d + b.theta_o) + 1e-9;
        if theta_o >= PI {
            return Cone {
                axis: a.axis,
                theta_o: PI,
                theta_e,
                exponent,
            };
        }
        // Rotate a's axis towards b's by theta_r.
        let theta_r = theta_o - a.theta_o;
        let perp = b.axis - a.axis * a.axis.dot(b.axis);
        let Some(perp) = perp.try_normalize() else {
            return Cone {
                axis: a.axis,
                theta_o: PI,
                theta_e,
                exponent,
            };
        };
        let axis = (a.axis * theta_r.cos() + perp * theta_r.sin()).normalize();
        Cone {
            axis,
            theta_o,
            theta_e,
            exponent,
        }
    }

    /// pbrt-v4's orientation measure `M_Ω` for the split cost: the solid
    /// angle a cone's emission can reach, weighted by the cosine.
    fn measure(&self) -> f64 {
        let (o, e) = (self.theta_o, self.theta_e);
        let w = (o + e).min(PI);
        2.0 * PI * (1.0 - o.cos())
            + FRAC_PI_2 * (2.0 * w * o.sin() - (o - 2.0 * w).cos() - 2.0 * o * o.sin() + o.cos())
    }
}

/// What the tree needs to know about one emitter.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightInfo {
    pub(crate) light: LightRef,
    /// Box around the emitter (centred scene coordinates).
    pub(crate) lo: DVec3,
    pub(crate) hi: DVec3,
    /// On-axis intensity, summed over bands, in units that make
    /// `phi / d²` (d in scene units) comparable across kinds: `L·A` for an
    /// area source, `I / mpu²` for a point source.
    pub(crate) phi: f64,
    pub(crate) cone: Cone,
}

#[derive(Clone, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    phi: f64,
    cone: Cone,
    /// Leaf: `Some(index into lights)`; interior: `None` with `children`.
    light: Option<u32>,
    children: [u32; 2],
}

/// The tree (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct LightTree {
    nodes: Vec<Node>,
    lights: Vec<LightRef>,
    /// Floor on the squared distance in importance (scene units²): keeps it
    /// finite at a point source's own position.
    d2_min: f64,
    /// Most subtrees a selection splits into (each yields one emitter).
    branches: usize,
    /// Whether area sources are in the tree (the `analytic` estimator).
    pub(crate) has_area: bool,
}

/// Buckets per axis in the split search (pbrt-v4 uses 12).
const BUCKETS: usize = 12;

fn surface_area(lo: DVec3, hi: DVec3) -> f64 {
    let d = (hi - lo).max(DVec3::ZERO);
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

impl LightTree {
    /// Builds the tree over `infos` (emitters with `phi <= 0` or non-finite
    /// emit nothing and are left out). `None` when nothing emits.
    /// `extent` is the scene's half-diagonal.
    pub(crate) fn build(mut infos: Vec<LightInfo>, extent: f64, branches: u32) -> Option<Self> {
        infos.retain(|l| l.phi.is_finite() && l.phi > 0.0);
        if infos.is_empty() || infos.len() >= u32::MAX as usize / 2 {
            return None;
        }
        let has_area = infos.iter().any(|l| matches!(l.light, LightRef::Area(_)));
        let n = infos.len();
        let mut nodes: Vec<Node> = Vec::with_capacity(2 * n - 1);
        nodes.push(Self::node_of(&infos));
        // (node, start, end) ranges still to split; explicit stack, so
        // unbalanced splits cannot overflow the call stack.
        let mut todo: Vec<(usize, usize, usize)> = vec![(0, 0, n)];
        // Every pop either makes a leaf or adds two nodes: ≤ 2n pops.
        let mut guard = 0usize;
        while let Some((node, start, end)) = todo.pop() {
            guard += 1;
            assert!(guard <= 2 * n, "light tree build did not terminate");
            if end - start == 1 {
                nodes[node].light = Some(start as u32);
                continue;
            }
            let mid = Self::split(&mut infos[start..end]) + start;
            let left = nodes.len();
            nodes.push(Self::node_of(&infos[start..mid]));
            nodes.push(Self::node_of(&infos[mid..end]));
            nodes[node].children = [left as u32, left as u32 + 1];
            todo.push((left, start, mid));
            todo.push((left + 1, mid, end));
        }
        let d = (1e-9 * extent).max(1e-150);
        Some(Self {
            nodes,
            lights: infos.iter().map(|l| l.light).collect(),
            d2_min: d * d,
            branches: branches.clamp(1, 1024) as usize,
            has_area,
        })
    }

    fn node_of(infos: &[LightInfo]) -> Node {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        let mut phi = 0.0;
        let mut cone: Option<Cone> = None;
        for l in infos {
            lo = lo.min(l.lo);
            hi = hi.max(l.hi);
            phi += l.phi;
            cone = Some(cone.map_or(l.cone, |c| Cone::union(c, l.cone)));
        }
        Node {
            lo,
            hi,
            phi,
            cone: cone.unwrap_or(Cone::ALL),
            light: None,
            children: [0, 0],
        }
    }

    /// Reorders `infos` (≥ 2) and returns where the second child starts
    /// (1 ..= len−1): the bucket boundary of least surface-area-orientation
    /// cost (pbrt-v4's SAOH), else the median along the longest axis.
    fn split(infos: &mut [LightInfo]) -> usize {
        let n = infos.len();
        let centre = |l: &LightInfo| 0.5 * (l.lo + l.hi);
        let (mut clo, mut chi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for l in infos.iter() {
            clo = clo.min(centre(l));
            chi = chi.max(centre(l));
            lo = lo.min(l.lo);
            hi = hi.max(l.hi);
        }
        let diag = hi - lo;
        let cdiag = chi - clo;
        let max_d = diag.max_element();
        let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, last bucket of the left)
        for axis in 0..3 {
            if cdiag[axis].is_nan() || cdiag[axis] <= 0.0 {
                continue;
            }
            let bucket = |l: &LightInfo| {
                let t = (centre(l)[axis] - clo[axis]) / cdiag[axis];
                ((t * BUCKETS as f64) as usize).min(BUCKETS - 1)
            };
            let mut bk: Vec<Option<Node>> = vec![None; BUCKETS];
            for l in infos.iter() {
                let b = bucket(l);
                let one = Self::node_of(std::slice::from_ref(l));
                bk[b] = Some(match bk[b].take() {
                    None => one,
                    Some(m) => Self::merge(&m, &one),
                });
            }
            let kr = if diag[axis] > 0.0 {
                max_d / diag[axis]
            } else {
                1.0
            };
            let cost = |m: &Node| m.phi * m.cone.measure() * kr * surface_area(m.lo, m.hi);
            // Suffix unions, then sweep the prefix.
            let mut suffix: Vec<Option<Node>> = vec![None; BUCKETS + 1];
            for b in (0..BUCKETS).rev() {
                suffix[b] = match (&bk[b], &suffix[b + 1]) {
                    (Some(x), Some(y)) => Some(Self::merge(x, y)),
                    (Some(x), None) => Some(x.clone()),
                    (None, y) => y.clone(),
                };
            }
            let mut prefix: Option<Node> = None;
            for b in 0..BUCKETS - 1 {
                if let Some(x) = &bk[b] {
                    prefix = Some(match prefix {
                        None => x.clone(),
                        Some(p) => Self::merge(&p, x),
                    });
                }
                if let (Some(l), Some(r)) = (&prefix, &suffix[b + 1]) {
                    let c = cost(l) + cost(r);
                    if c.is_finite() && best.is_none_or(|(bc, _, _)| c < bc) {
                        best = Some((c, axis, b));
                    }
                }
            }
        }
        if let Some((_, axis, b)) = best {
            let key = |l: &LightInfo| {
                let t = (centre(l)[axis] - clo[axis]) / cdiag[axis];
                ((t * BUCKETS as f64) as usize).min(BUCKETS - 1)
            };
            infos.sort_by_key(|l| key(l) > b);
            let mid = infos.iter().filter(|l| key(l) <= b).count();
            if mid > 0 && mid < n {
                return mid;
            }
        }
        // Median along the longest centroid axis (all centroids equal: any
        // halving will do).
        let axis = if cdiag.x >= cdiag.y && cdiag.x >= cdiag.z {
            0
        } else if cdiag.y >= cdiag.z {
            1
        } else {
            2
        };
        infos.sort_by(|a, b| centre(a)[axis].total_cmp(&centre(b)[axis]));
        n / 2
    }

    fn merge(a: &Node, b: &Node) -> Node {
        Node {
            lo: a.lo.min(b.lo),
            hi: a.hi.max(b.hi),
            phi: a.phi + b.phi,
            cone: Cone::union(a.cone, b.cone),
            light: None,
            children: [0, 0],
        }
    }

    /// Importance of node `k` at `p` (normal `n`), and how spread out the
    /// node looks from there (its bounding sphere's angular radius as a
    /// sine, 1 when `p` is inside it).
    fn importance(&self, k: usize, p: DVec3, n: DVec3) -> (f64, f64) {
        let nd = &self.nodes[k];
        let pc = 0.5 * (nd.lo + nd.hi);
        let r2 = 0.25 * (nd.hi - nd.lo).length_squared();
        let v = p - pc;
        let dist2 = v.length_squared();
        let d2 = dist2.max(r2).max(self.d2_min);
        // Angular radius of the bounding sphere; everything when inside.
        let (theta_b, spread) = if dist2 <= r2 * (1.0 + 1e-9) || dist2 <= 0.0 {
            (PI, 1.0)
        } else {
            let s = (r2 / dist2).sqrt();
            // Padded so rounding never cuts off a contributing emitter.
            (s.asin() + 1e-9, s)
        };
        let wi = v / dist2.sqrt();
        let wi = if wi.is_finite() { wi } else { n };
        // Emission: the least angle between wi and the cone, less θ_b.
        let theta_w = nd.cone.axis.dot(wi).clamp(-1.0, 1.0).acos();
        let theta_p = (theta_w - nd.cone.theta_o - theta_b).max(0.0);
        if theta_p >= nd.cone.theta_e {
            return (0.0, spread);
        }
        // Reception: the least angle between −wi (towards the node) and n.
        let theta_i = (-wi).dot(n).clamp(-1.0, 1.0).acos();
        let theta_ip = (theta_i - theta_b).max(0.0);
        if theta_ip >= FRAC_PI_2 {
            return (0.0, spread);
        }
        let cos_e = theta_p.cos().max(0.0);
        let shape = if nd.cone.exponent > 0.0 {
            cos_e.powf(nd.cone.exponent)
        } else {
            1.0
        };
        let imp = nd.phi * shape * theta_ip.cos() / d2;
        // A node that passed both tests may light p: never exactly 0.
        let imp = if imp.is_finite() {
            imp.max(f64::MIN_POSITIVE)
        } else {
            f64::MAX
        };
        (imp, spread)
    }

    /// The emitters chosen at `p` (normal `n`), each with `1 / pmf`, into
    /// `out` (cleared first), splitting into at most `branches` subtrees
    /// and the tree's own branch count (one: a single emitter, for
    /// estimates averaged over many rays anyway). See the module docs.
    pub(crate) fn select_in(
        &self,
        p: DVec3,
        n: DVec3,
        branches: usize,
        rng: &mut Pcg64Mcg,
        out: &mut Vec<(LightRef, f64)>,
    ) {
        out.clear();
        let branches = branches.clamp(1, self.branches);
        let (i0, s0) = self.importance(0, p, n);
        if i0 <= 0.0 {
            return;
        }
        // (node, importance × spread): split deterministically.
        let mut frontier: Vec<(usize, f64)> = Vec::with_capacity(branches + 1);
        frontier.push((0, i0 * s0));
        let mut steps = 0usize;
        while frontier.len() < branches && steps < self.nodes.len() {
            steps += 1;
            let best = frontier
                .iter()
                .enumerate()
                .filter(|(_, (k, s))| self.nodes[*k].light.is_none() && *s > 0.0)
                .max_by(|a, b| a.1.1.total_cmp(&b.1.1))
                .map(|(j, _)| j);
            let Some(j) = best else { break };
            let (k, _) = frontier.swap_remove(j);
            for c in self.nodes[k].children {
                let (ic, sc) = self.importance(c as usize, p, n);
                if ic > 0.0 {
                    frontier.push((c as usize, ic * sc));
                }
            }
        }
        for &(k, _) in &frontier {
            let u: f64 = rng.random();
            if let Some((l, pmf)) = self.descend(k, u, p, n) {
                out.push((l, 1.0 / pmf));
            }
        }
    }

    /// One emitter under node `k`, chosen with probability proportional to
    /// importance at every level (one uniform `u`, rescaled per level), and
    /// its probability (> 0). `None` when nothing under `k` can light `p`.
    fn descend(&self, mut k: usize, mut u: f64, p: DVec3, n: DVec3) -> Option<(LightRef, f64)> {
        let mut pmf = 1.0f64;
        for _ in 0..self.nodes.len() {
            let nd = &self.nodes[k];
            if let Some(l) = nd.light {
                return (pmf > 0.0 && pmf.is_finite()).then_some((self.lights[l as usize], pmf));
            }
            let [a, b] = nd.children;
            let (ia, _) = self.importance(a as usize, p, n);
            let (ib, _) = self.importance(b as usize, p, n);
            let sum = ia + ib;
            if !(sum > 0.0 && sum.is_finite()) {
                return None;
            }
            let pa = ia / sum;
            if u < pa {
                pmf *= pa;
                u /= pa;
                k = a as usize;
            } else {
                let pb = ib / sum;
                if pb.is_nan() || pb <= 0.0 {
                    return None;
                }
                pmf *= pb;
                u = (u - pa) / pb;
                k = b as usize;
            }
            u = u.clamp(0.0, 1.0 - f64::EPSILON);
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn point(i: u32, pos: DVec3, phi: f64, cone: Cone) -> LightInfo {
        LightInfo {
            light: LightRef::Point(i),
            lo: pos,
            hi: pos,
            phi,
            cone,
        }
    }

    #[test]
    fn cone_union_holds_both() {
        let down = Cone {
            axis: DVec3::NEG_Z,
            theta_o: 0.0,
            theta_e: FRAC_PI_2,
            exponent: 1.0,
        };
        let side = Cone {
            axis: DVec3::X,
            theta_o: 0.1,
            theta_e: FRAC_PI_2,
            exponent: 2.0,
        };
        let u = Cone::union(down, side);
        for c in [down, side] {
            let d = u.axis.dot(c.axis).clamp(-1.0, 1.0).acos();
            assert!(d + c.theta_o <= u.theta_o + 1e-12, "{u:?} {c:?}");
        }
        let up = Cone {
            axis: DVec3::Z,
            ..down
        };
        assert_eq!(Cone::union(down, up).theta_o, PI);
    }

    /// Over all draws, each light's selection probability sums with the
    /// others to the number of branches, and its 1/pmf matches how often
    /// it is drawn.
    #[test]
    fn pmf_matches_frequency() {
        let infos: Vec<LightInfo> = (0..40)
            .map(|i| {
                let pos = DVec3::new((i % 8) as f64, (i / 8) as f64, 3.0);
                point(i, pos, 1.0 + (i % 3) as f64, Cone::ALL)
            })
            .collect();
        let t = LightTree::build(infos, 10.0, 2).unwrap();
        let p = DVec3::new(2.0, 1.0, 0.0);
        let mut rng = Pcg64Mcg::seed_from_u64(1);
        let mut out = Vec::new();
        let mut count = [0u32; 40];
        let mut inv = [0.0; 40];
        let draws = 200_000;
        for _ in 0..draws {
            t.select_in(p, DVec3::Z, usize::MAX, &mut rng, &mut out);
            assert!(out.len() <= 2);
            for &(l, w) in &out {
                let LightRef::Point(i) = l else { panic!() };
                count[i as usize] += 1;
                inv[i as usize] = w;
            }
        }
        for i in 0..40 {
            let f = count[i] as f64 / draws as f64;
            let expect = 1.0 / inv[i];
            let se = (expect / draws as f64).sqrt();
            assert!(
                (f - expect).abs() < 5.0 * se + 1e-9,
                "light {i}: {f} vs {expect}"
            );
        }
    }
    // ---- The tree inside the tracer (scenes built in code) ----

    use crate::settings::{Indirect, RenderSettings};
    use crate::tracer::{RayCounts, Tracer};

    /// A ground plane (ρ 0.5, z = 0) under `quads` small emitting quads
    /// facing down on a ceiling grid (z = 4; m = 0, 1 and, every seventh,
    /// the non-integer 1.5) and `lamps` shaped point lamps (z = 3; cos²,
    /// cos⁴ tilted, every fifth isotropic), spacing 1 m, with opaque
    /// blockers at z = 1 casting shadows.
    pub(crate) fn many_lights_scene(quads: usize, lamps: usize) -> String {
        use std::fmt::Write;
        let side = |k: usize| (k as f64).sqrt().ceil().max(1.0) as usize;
        let span = side(quads.max(lamps)) as f64;
        let mut t = format!(
            r#"units = "m"
[camera]
position = [0, {cy}, 30]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 60
width = 16
height = 12
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.ground]
reflectance = 0.5
[materials.block]
reflectance = 0.2
[materials.e0]
reflectance = 0.0
emission = {{ value = 1.0, shape_exponent = 0 }}
[materials.e1]
reflectance = 0.0
emission = {{ value = 2.0, shape_exponent = 1 }}
[materials.e2]
reflectance = 0.0
emission = {{ value = 0.5, shape_exponent = 1.5 }}
[objects.ground]
material = "ground"
quad = {{ center = [0, 0, 0], size = [{g}, {g}], normal = [0, 0, 1] }}
"#,
            cy = -0.5 * span,
            g = 2.0 * span + 10.0,
        );
        let at = |i: usize, k: usize| {
            let n = side(k);
            let (x, y) = ((i % n) as f64, (i / n) as f64);
            (x - 0.5 * (n as f64 - 1.0), y - 0.5 * (n as f64 - 1.0))
        };
        for i in 0..quads {
            let (x, y) = at(i, quads);
            let m = if i % 7 == 6 { 2 } else { i % 2 };
            writeln!(
                t,
                "[objects.q{i}]\nmaterial = \"e{m}\"\nquad = {{ center = [{x}, {y}, 4], size = [0.3, 0.2], normal = [0, 0, -1], width_axis = [1, 0, 0] }}"
            )
            .unwrap();
        }
        for i in 0..lamps {
            let (x, y) = at(i, lamps);
            let (dx, m) = match i % 5 {
                4 => (0.0, 0.0),
                k if k % 2 == 0 => (0.0, 2.0),
                _ => (0.5, 4.0),
            };
            let v = 0.01 * (1 + i % 3) as f64;
            writeln!(
                t,
                "[point_sources.l{i}]\nposition = [{x}, {y}, 3]\ndirection = [{dx}, 0, -1]\nshape_exponent = {m}\nvalue = {v}"
            )
            .unwrap();
        }
        for i in 0..(quads.max(lamps) / 50).clamp(1, 40) {
            let (x, y) = at(i * 37 % quads.max(lamps).max(1), quads.max(lamps));
            writeln!(
                t,
                "[objects.b{i}]\nmaterial = \"block\"\nbox = {{ min = [{}, {}, 1], max = [{}, {}, 1.2] }}",
                x - 0.6,
                y - 0.6,
                x + 0.4,
                y + 0.3
            )
            .unwrap();
        }
        t
    }

    fn tracer(text: &str, min_lights: u32) -> Tracer {
        let scene = gloam_scene::parse_str(text, std::path::Path::new("many.toml"))
            .unwrap_or_else(|e| panic!("{e}"));
        let s = RenderSettings {
            indirect: Indirect::Off,
            tolerance: 0.0,
            light_tree_min_lights: min_lights,
            ..Default::default()
        };
        Tracer::new(&scene, &s).unwrap()
    }

    /// The tree's estimate, averaged over many draws, matches the
    /// exhaustive sum (the path below the threshold) within a few standard
    /// errors, at points in the open, near the edge and in a blocker's
    /// penumbra; and its noise is small enough for that to mean something.
    #[test]
    fn tree_is_unbiased() {
        let text = many_lights_scene(500, 500);
        let tree = tracer(&text, 64);
        let full = tracer(&text, u32::MAX);
        assert!(tree.light_tree.is_some() && full.light_tree.is_none());
        for p in [
            DVec3::new(0.3, 0.2, 0.0),
            DVec3::new(-10.5, 9.0, 0.0),
            DVec3::new(3.7, -6.1, 0.0),
            DVec3::new(-1.4, -11.3, 0.0),
        ] {
            let a = tree.probe_point(p, DVec3::Z, None, 6000).unwrap();
            let b = full.probe_point(p, DVec3::Z, None, 300).unwrap();
            let se = (a.std_error_w_m2.powi(2) + b.std_error_w_m2.powi(2)).sqrt();
            let d = a.irradiance_w_m2 - b.irradiance_w_m2;
            eprintln!(
                "{p}: tree {:.6e} ± {:.1e}, exhaustive {:.6e} ± {:.1e}",
                a.irradiance_w_m2, a.std_error_w_m2, b.irradiance_w_m2, b.std_error_w_m2
            );
            assert!(
                d.abs() < 4.0 * se,
                "{p}: tree {} ± {}, exhaustive {} ± {}",
                a.irradiance_w_m2,
                a.std_error_w_m2,
                b.irradiance_w_m2,
                b.std_error_w_m2
            );
            assert!(a.std_error_w_m2 < 0.01 * b.irradiance_w_m2, "{p}: {a:?}");
        }
    }

    /// With the `solid-angle` estimator the area sources keep their loop
    /// and the tree holds the point sources only; a dropped term is left
    /// out of the tree's sum. Both still agree with the exhaustive path.
    #[test]
    fn other_estimators_and_drop_with_the_tree() {
        let text = many_lights_scene(150, 150);
        let scene = gloam_scene::parse_str(&text, std::path::Path::new("many.toml")).unwrap();
        let p = DVec3::new(0.3, 0.2, 0.0);
        let run = |min: u32, est: &str, drop: &str| {
            let mut s = RenderSettings {
                indirect: Indirect::Off,
                tolerance: 0.0,
                light_tree_min_lights: min,
                ..Default::default()
            };
            s.set("estimator", est).unwrap();
            s.set("drop", drop).unwrap();
            let t = Tracer::new(&scene, &s).unwrap();
            let has_area = t.light_tree.as_ref().map(|t| t.has_area);
            (has_area, t.probe_point(p, DVec3::Z, None, 3000).unwrap())
        };
        let (h, a) = run(64, "solid-angle", "none");
        assert_eq!(h, Some(false));
        let (_, b) = run(u32::MAX, "solid-angle", "none");
        let se = (a.std_error_w_m2.powi(2) + b.std_error_w_m2.powi(2)).sqrt();
        assert!(
            (a.irradiance_w_m2 - b.irradiance_w_m2).abs() < 4.0 * se,
            "{a:?} {b:?}"
        );
        // Dropping the shaped lamps: what is left matches the exhaustive
        // path's same drop.
        let drop = "shaped-point-sources";
        let (h, a) = run(64, "analytic", drop);
        assert_eq!(h, Some(true));
        let (_, b) = run(u32::MAX, "analytic", drop);
        let (_, all) = run(u32::MAX, "analytic", "none");
        let se = (a.std_error_w_m2.powi(2) + b.std_error_w_m2.powi(2)).sqrt();
        assert!(
            (a.irradiance_w_m2 - b.irradiance_w_m2).abs() < 4.0 * se,
            "{a:?} {b:?}"
        );
        assert!(
            b.irradiance_w_m2 < 0.95 * all.irradiance_w_m2,
            "{b:?} {all:?}"
        );
    }

    /// Shadow rays per vertex for 10 … 10 000 lights grow no faster than
    /// c·log N (the exhaustive path: linearly).
    #[test]
    fn cost_grows_logarithmically() {
        for (quads, lamps) in [(true, false), (false, true)] {
            let mut per_vertex = Vec::new();
            for n in [10usize, 100, 1000, 10_000] {
                let t = tracer(
                    &many_lights_scene(if quads { n } else { 0 }, if lamps { n } else { 0 }),
                    0,
                );
                assert!(t.light_tree.is_some());
                let mut c = RayCounts::default();
                let mut e = crate::light::Light::dark(t.wl.len(), 0);
                let mut rng = crate::tracer::stream(0, 27, n as u64);
                let k = 400;
                let half = 0.5 * (n as f64).sqrt();
                for i in 0..k {
                    let u = (i as f64 + 0.5) / k as f64;
                    let p = DVec3::new(half * (2.0 * u - 1.0), half * (1.0 - 2.0 * u * u), 0.0)
                        - t.geom.origin;
                    let f = t.facet_at(p).unwrap_or(u32::MAX);
                    t.irradiance(p, DVec3::Z, f, &mut rng, &mut c, &mut e);
                }
                per_vertex.push((n, c.shadow as f64 / k as f64));
            }
            eprintln!("shadow rays per vertex (quads {quads}): {per_vertex:?}");
            let c10 = per_vertex[0].1 / (10f64).ln();
            for &(n, r) in &per_vertex {
                assert!(r > 0.0, "{per_vertex:?}");
                assert!(r <= c10 * (n as f64).ln() + 1e-9, "{per_vertex:?}");
            }
            // And the budget itself: ≤ branches × area_samples.
            let d = RenderSettings::default();
            let budget = (d.light_tree_branches * d.area_samples) as f64;
            assert!(
                per_vertex.iter().all(|&(_, r)| r <= budget),
                "{per_vertex:?}"
            );
        }
    }

    /// At or below `light_tree_min_lights` emitters there is no tree and
    /// the render is bit-identical to the exhaustive path; above it the
    /// tree is in use.
    #[test]
    fn below_threshold_is_the_exhaustive_path() {
        let render = |text: &str, min: u32| {
            let t = tracer(text, min);
            (
                t.light_tree.is_some(),
                t.render(&|_, _| {}).unwrap().radiance,
            )
        };
        let text = many_lights_scene(32, 32);
        let (tree, a) = render(&text, 64);
        let (_, b) = render(&text, u32::MAX);
        assert!(!tree);
        assert_eq!(
            a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        let (tree, _) = render(&text, 63);
        assert!(tree);
    }
}
