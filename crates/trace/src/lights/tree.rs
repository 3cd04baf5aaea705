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
//! Selection ([`LightTree::select_in`]) follows the tree's [`Split`] rule.
//! The default, *adaptive splitting* (Conty Estevez & Kulla 2018, §5),
//! walks down from the root: a node whose importance is uncertain from `p`
//! — the relative gap `1 − I_min/I_max` between the bounds below above
//! `light_split_threshold` — is *split*, both children visited, since
//! one importance stands poorly for its emitters (near `p`: a large solid
//! angle, emitters at very different distances and angles); otherwise
//! one child is chosen with probability proportional to its importance
//! and the test is made again below it. So near a lamp the selection
//! splits down to the lamp itself, far away it samples one emitter of a
//! cluster. Nodes are taken best-first by `w · I_max · uncertainty`, and
//! no split is made that could reach more than `light_tree_max_picks`
//! emitters: cost per vertex stays bounded. The older rule,
//! `light_tree_split = fixed`, splits deterministically (from `p`, `n`
//! only) into exactly `light_tree_branches` subtrees, always the
//! brightest, most spread-out one, then picks one emitter in each.
//!
//! Either way each emitter reached is returned with `1 / P`, `P` the
//! probability of the stochastic choices on its path: the caller evaluates
//! it with its usual estimator and divides by `P`. Whether a node is split
//! or sampled may depend on anything (the budget, earlier choices): a
//! split node's emitters are all visited with the same weight and a
//! sampled one's expectation is its sum, so the estimate is unbiased.

use glam::DVec3;
use rand::Rng;
use rand_pcg::Pcg64Mcg;
use std::collections::BinaryHeap;
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

/// A node's importance bounds at a shading point ([`LightTree::bounds`]).
#[derive(Clone, Copy, Debug)]
struct Bounds {
    /// Upper bound of the importance (what sampling uses).
    max: f64,
    /// Tighter bounds of the irradiance shape, for the splitting test
    /// ([`LightTree::tight`]).
    lo: f64,
    hi: f64,
    /// The bounding sphere's angular radius as a sine (1 inside).
    spread: f64,
}

impl Bounds {
    /// The importance adaptive splitting samples by: the lesser of the
    /// two upper bounds (each conservative, so 0 only where no emitter of
    /// the node can light the point).
    fn sampling(&self) -> f64 {
        if self.max > 0.0 && self.hi > 0.0 {
            self.max.min(self.hi).max(f64::MIN_POSITIVE)
        } else {
            0.0
        }
    }
}

/// A node reached by an adaptive selection, with its weight (1 / the
/// probability of the choices above it) and its importance bounds.
#[derive(Clone, Copy, Debug)]
struct Entry {
    /// Traversal order: `w · (hi − lo)` (leaves: any).
    key: f64,
    node: u32,
    w: f64,
    b: Bounds,
}

impl Entry {
    fn new(node: u32, w: f64, b: Bounds) -> Self {
        let mut e = Entry {
            key: 0.0,
            node,
            w,
            b,
        };
        // The node's irradiance is within [lo, hi]: w·(hi − lo) bounds
        // the error of standing one emitter for all.
        let k = w * (b.hi - b.lo);
        e.key = if k.is_nan() { 0.0 } else { k };
        e
    }

    /// `1 − I_min / I_max` in [0, 1] (the tight bounds).
    fn uncertainty(&self) -> f64 {
        if self.b.hi > 0.0 && self.b.hi.is_finite() {
            (1.0 - self.b.lo / self.b.hi).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == std::cmp::Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.key.total_cmp(&o.key).then(o.node.cmp(&self.node))
    }
}

/// The tree (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct LightTree {
    nodes: Vec<Node>,
    lights: Vec<LightRef>,
    /// Floor on the squared distance in importance (scene units²): keeps it
    /// finite at a point source's own position.
    d2_min: f64,
    /// How a selection splits the tree (see [`Split`]).
    rule: Split,
    /// Whether area sources are in the tree (the `analytic` estimator).
    pub(crate) has_area: bool,
}

/// How [`LightTree::select_in`] splits the tree at a shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Split {
    /// Adaptive splitting after Conty & Kulla 2018: a node whose
    /// importance is uncertain from `p` (relative uncertainty
    /// `1 − I_min/I_max` above `threshold`) is split (both children
    /// visited), else one child is sampled by importance and the test is
    /// made again below it; the most uncertain nodes (by `w · I_max ·
    /// uncertainty`) are split first, and at most `max_picks` emitters are
    /// reached per selection.
    Adaptive { threshold: f64, max_picks: usize },
    /// Before issue 44: the brightest, most spread-out subtrees split
    /// deterministically into exactly `branches` (one emitter from each).
    Fixed { branches: usize },
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
    pub(crate) fn build(mut infos: Vec<LightInfo>, extent: f64, rule: Split) -> Option<Self> {
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
            rule: match rule {
                Split::Fixed { branches } => Split::Fixed {
                    branches: branches.clamp(1, 1024),
                },
                Split::Adaptive {
                    threshold,
                    max_picks,
                } => Split::Adaptive {
                    threshold: if threshold.is_nan() {
                        0.0
                    } else {
                        threshold.clamp(0.0, 1.0)
                    },
                    max_picks: max_picks.clamp(1, 1024),
                },
            },
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
        let b = self.bounds(k, p, n);
        (b.max, b.spread)
    }

    /// Node `k`'s importance at `p` (normal `n`) as an upper bound (the
    /// most favourable distance and angles its box and cone allow: what
    /// sampling uses) and a lower bound (the least favourable: farthest
    /// point of its bounding sphere, largest angles; 0 when some emitter
    /// may be behind the receiver or outside its emission cone). Their
    /// ratio says how well one importance stands for the node's emitters
    /// seen from `p`: the splitting test.
    fn bounds(&self, k: usize, p: DVec3, n: DVec3) -> Bounds {
        let nd = &self.nodes[k];
        let pc = 0.5 * (nd.lo + nd.hi);
        let r2 = 0.25 * (nd.hi - nd.lo).length_squared();
        let v = p - pc;
        let dist2 = v.length_squared();
        let d2 = dist2.max(r2).max(self.d2_min);
        let zero = |spread| Bounds {
            max: 0.0,
            lo: 0.0,
            hi: 0.0,
            spread,
        };
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
            return zero(spread);
        }
        // Reception: the least angle between −wi (towards the node) and n.
        let theta_i = (-wi).dot(n).clamp(-1.0, 1.0).acos();
        let theta_ip = (theta_i - theta_b).max(0.0);
        if theta_ip >= FRAC_PI_2 {
            return zero(spread);
        }
        let shape = |cos: f64| {
            if nd.cone.exponent > 0.0 {
                cos.max(0.0).powf(nd.cone.exponent)
            } else {
                1.0
            }
        };
        let imp = nd.phi * shape(theta_p.cos()) * theta_ip.cos() / d2;
        // A node that passed both tests may light p: never exactly 0.
        let max = if imp.is_finite() {
            imp.max(f64::MIN_POSITIVE)
        } else {
            f64::MAX
        };
        let (lo, hi) = self.tight(nd, p, n);
        Bounds {
            max,
            lo,
            hi,
            spread,
        }
    }

    /// Tighter bounds on node `nd`'s unoccluded irradiance shape at `p`
    /// (normal `n`) for the splitting test, from its box itself rather
    /// than its bounding sphere: the nearest and farthest box points, the
    /// receiver cosine `n·(x − p)/|x − p|` and (a cone of one direction
    /// `a`) the emission cosine `a·(p − x)/|p − x|` bounded over the box's
    /// corners. `(lo, hi)`: the node's unoccluded irradiance shape lies
    /// within them (`hi` infinite when `p` is in the box). Not used for
    /// sampling (the importance above is).
    fn tight(&self, nd: &Node, p: DVec3, n: DVec3) -> (f64, f64) {
        let c = 0.5 * (nd.lo + nd.hi);
        let h = 0.5 * (nd.hi - nd.lo);
        let near2 = (p.clamp(nd.lo, nd.hi) - p).length_squared();
        let far2 = ((p - c).abs() + h).length_squared();
        if near2 <= self.d2_min {
            return (0.0, f64::INFINITY);
        }
        let (near, far) = (near2.sqrt(), far2.sqrt());
        // A linear function v·x over the box: its range, less v·p.
        let range = |v: DVec3| {
            let m = v.dot(c - p);
            let r = v.abs().dot(h);
            (m - r, m + r)
        };
        let cos_range = |(a, b): (f64, f64)| {
            let lo = if a > 0.0 { a / far } else { 0.0 };
            let hi = if b > 0.0 { (b / near).min(1.0) } else { 0.0 };
            (lo, hi)
        };
        let (ri_lo, ri_hi) = cos_range(range(n));
        let cone = &nd.cone;
        let (e_lo, e_hi) = if cone.theta_o >= PI && cone.exponent <= 0.0 {
            (1.0, 1.0)
        } else if cone.theta_o <= 1e-6 && cone.theta_e >= FRAC_PI_2 {
            let (a, b) = range(-cone.axis);
            let (lo, hi) = cos_range((a, b));
            let k = cone.exponent;
            if k > 0.0 {
                (lo.powf(k), hi.powf(k))
            } else {
                (
                    if lo > 0.0 { 1.0 } else { 0.0 },
                    if hi > 0.0 { 1.0 } else { 0.0 },
                )
            }
        } else {
            (0.0, 1.0)
        };
        (nd.phi * e_lo * ri_lo / far2, nd.phi * e_hi * ri_hi / near2)
    }

    /// The emitters chosen at `p` (normal `n`), each with `1 / P` (P the
    /// probability of the stochastic choices on its path), into `out`
    /// (cleared first): at most `branches` of them and the tree's own cap
    /// (one: a single emitter, for estimates averaged over many rays
    /// anyway). Split by the tree's [`Split`] rule; see the module docs.
    pub(crate) fn select_in(
        &self,
        p: DVec3,
        n: DVec3,
        branches: usize,
        rng: &mut Pcg64Mcg,
        out: &mut Vec<(LightRef, f64)>,
    ) {
        out.clear();
        match self.rule {
            Split::Fixed { branches: b } => self.select_fixed(p, n, branches.clamp(1, b), rng, out),
            Split::Adaptive {
                threshold,
                max_picks,
            } => self.select_adaptive(p, n, branches.clamp(1, max_picks), threshold, rng, out),
        }
    }

    /// [`Split::Adaptive`]: a best-first traversal from the root. Each
    /// entry is a node reached with weight `w` (1 / the probability of the
    /// stochastic choices above it). A leaf is emitted with `w`; an inner
    /// node is split (both children, weight `w`) when its relative
    /// uncertainty `1 − I_min/I_max` exceeds `threshold` and splitting
    /// keeps the emitters reachable within `cap`; otherwise one child is
    /// chosen with probability `I_max(c) / ΣI_max` and carries `w / P(c)`.
    /// Either way the expected sum over a node's emitters is `w` times
    /// their sum, whatever decided it: unbiased. Entries are taken in
    /// order of `w · (hi − lo)` (the tight bounds' gap), so the budget goes
    /// to the nodes whose sampling would be noisiest (those near `p`).
    fn select_adaptive(
        &self,
        p: DVec3,
        n: DVec3,
        cap: usize,
        threshold: f64,
        rng: &mut Pcg64Mcg,
        out: &mut Vec<(LightRef, f64)>,
    ) {
        let b0 = self.bounds(0, p, n);
        if b0.max <= 0.0 {
            return;
        }
        let mut heap: BinaryHeap<Entry> = BinaryHeap::with_capacity(cap + 2);
        heap.push(Entry::new(0, 1.0, b0));
        // Each pop emits a leaf, splits (one more entry) or steps one
        // level down: bounded by the emitted leaves times the depth.
        let mut guard = 0usize;
        while let Some(e) = heap.pop() {
            guard += 1;
            if guard > self.nodes.len() {
                debug_assert!(false, "light tree selection did not terminate");
                break;
            }
            let nd = &self.nodes[e.node as usize];
            if let Some(l) = nd.light {
                out.push((self.lights[l as usize], e.w));
                continue;
            }
            let [a, b] = nd.children;
            let ba = self.bounds(a as usize, p, n);
            let bb = self.bounds(b as usize, p, n);
            // Entries still to come, each reaching at most one emitter.
            let room = out.len() + heap.len() + 2 <= cap;
            if room && e.uncertainty() > threshold {
                for (c, bc) in [(a, ba), (b, bb)] {
                    if bc.max > 0.0 {
                        heap.push(Entry::new(c, e.w, bc));
                    }
                }
                continue;
            }
            let (ia, ib) = (ba.sampling(), bb.sampling());
            let sum = ia + ib;
            if !(sum > 0.0 && sum.is_finite()) {
                continue;
            }
            let pa = ia / sum;
            let u: f64 = rng.random();
            let (c, bc, pc) = if u < pa {
                (a, ba, pa)
            } else {
                (b, bb, ib / sum)
            };
            if pc > 0.0 && pc.is_finite() {
                heap.push(Entry::new(c, e.w / pc, bc));
            }
        }
    }

    /// [`Split::Fixed`]: splits deterministically (from `p`, `n` only) into
    /// `branches` subtrees, always the brightest, most spread-out one,
    /// then descends once in each.
    fn select_fixed(
        &self,
        p: DVec3,
        n: DVec3,
        branches: usize,
        rng: &mut Pcg64Mcg,
        out: &mut Vec<(LightRef, f64)>,
    ) {
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
mod tests;
