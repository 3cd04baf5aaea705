//! Coincident facets where shared placements are involved: a facet of one
//! placement on exactly the vertices of a facet of another placement (the
//! same object turned onto its own symmetry, two boxes side by side, two
//! shared objects) or of an expanded object. Expanded facets are checked by
//! one sort of all their vertex sets (`build::first_coincident_pair`); a
//! shared object keeps its placed facets unmade, so they are checked only
//! where two placed boxes meet: a sweep over x finds the overlapping
//! boxes, and only the prototype facets inside the overlap are placed and
//! keyed — cost grows with the overlap, not with the placed facets.

use std::collections::BTreeSet;
use std::hash::{Hash, Hasher};

use glam::{DAffine3, DVec3};

use crate::Facet;
use crate::instance::{SharedInstances, bounds, box_corners};

/// Most placed facets keyed where boxes overlap (16 bytes each).
const MAX_KEYS: usize = 10_000_000;
/// Most box tests (placement boxes against boxes, prototype facets
/// against an overlap).
const MAX_TESTS: u64 = 500_000_000;

/// One side of a coincident pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Who {
    /// `Scene::facets[i]`.
    Facet(usize),
    /// Facet `facet` of `shared[shared]`'s prototype under its placement
    /// `placement`.
    Placed {
        shared: usize,
        placement: usize,
        facet: usize,
    },
}

/// A box with room for rounding: a vertex placed by the affine map may
/// land an ulp outside the box of the placed prototype corners.
fn padded(lo: DVec3, hi: DVec3) -> (DVec3, DVec3) {
    let pad = (lo.abs().max(hi.abs()) * 1e-9) + DVec3::splat(1e-300);
    (lo - pad, hi + pad)
}

fn overlap(a: &(DVec3, DVec3), b: &(DVec3, DVec3)) -> bool {
    a.0.cmple(b.1).all() && b.0.cmple(a.1).all()
}

fn ordered(x: f64) -> i64 {
    let b = x.to_bits() as i64;
    b ^ (((b >> 63) as u64) >> 1) as i64
}

/// The vertex set of a facet as sorted bit patterns (-0.0 as 0.0).
fn vertex_key(vs: impl Iterator<Item = DVec3>) -> ([[u64; 3]; 4], usize) {
    let mut k = [[u64::MAX; 3]; 4];
    let mut n = 0;
    for (slot, v) in k.iter_mut().zip(vs) {
        *slot = [v.x, v.y, v.z].map(|c| (c + 0.0).to_bits());
        n += 1;
    }
    k[..n].sort_unstable();
    (k, n)
}

struct Ctx<'a> {
    facets: &'a [Facet],
    shared: &'a [SharedInstances],
}

impl Ctx<'_> {
    fn key(&self, w: Who) -> ([[u64; 3]; 4], usize) {
        match w {
            Who::Facet(i) => vertex_key(self.facets[i].vertices.iter().copied()),
            Who::Placed {
                shared,
                placement,
                facet,
            } => {
                let sh = &self.shared[shared];
                let a = sh.placements[placement];
                vertex_key(
                    sh.prototype[facet]
                        .vertices
                        .iter()
                        .map(|&v| a.transform_point3(v)),
                )
            }
        }
    }
}

/// The first two facets on exactly the same vertices of which at least one
/// is a shared placement's, if any (`Err`: the overlap is too large to
/// check, with the reason).
pub(crate) fn first_coincident_shared(
    facets: &[Facet],
    shared: &[SharedInstances],
) -> Result<Option<(Who, Who)>, String> {
    if shared.iter().all(|s| s.placements.is_empty()) {
        return Ok(None);
    }
    let units = units(facets, shared);
    let mut keyer = Keyer::new(facets, shared);
    sweep(&units, &mut keyer)?;
    Ok(keyer.first_pair())
}

/// An axis-aligned box, (min, max).
type Aabb = (DVec3, DVec3);

/// What the sweep over x meets: a shared placement or an expanded facet.
#[derive(Clone, Copy)]
enum Unit {
    Placement(usize, usize),
    Facet(usize),
}

/// Units: every shared placement (its placed box) and every expanded
/// facet (its box) that meets some placement's box, sorted by min x.
fn units(facets: &[Facet], shared: &[SharedInstances]) -> Vec<(Aabb, Unit)> {
    let mut units: Vec<(Aabb, Unit)> = Vec::new();
    for (s, sh) in shared.iter().enumerate() {
        let corners = box_corners(sh.prototype_bounds());
        for (p, a) in sh.placements.iter().enumerate() {
            let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            for c in corners {
                let v = a.transform_point3(c);
                lo = lo.min(v);
                hi = hi.max(v);
            }
            units.push((padded(lo, hi), Unit::Placement(s, p)));
        }
    }
    // Only expanded facets that meet some placement's box matter.
    let (mut all_lo, mut all_hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for (b, _) in &units {
        all_lo = all_lo.min(b.0);
        all_hi = all_hi.max(b.1);
    }
    for (i, f) in facets.iter().enumerate() {
        let (lo, hi) = bounds(std::slice::from_ref(f));
        let b = padded(lo, hi);
        if overlap(&b, &(all_lo, all_hi)) {
            units.push((b, Unit::Facet(i)));
        }
    }
    units.sort_unstable_by(|a, b| a.0.0.x.total_cmp(&b.0.0.x));
    units
}

/// Each prototype's facet boxes in six orders (by min and by max on each
/// axis): a query takes the shortest run that can meet it (the facets at
/// the bottom, for a ground under the placement), not every facet.
fn facet_orders(proto_boxes: &[Vec<Aabb>]) -> Vec<[Vec<u32>; 6]> {
    proto_boxes
        .iter()
        .map(|b| {
            std::array::from_fn(|k| {
                let (axis, by_max) = (k % 3, k >= 3);
                let at = |i: u32| {
                    let (lo, hi) = b[i as usize];
                    if by_max { hi[axis] } else { lo[axis] }
                };
                let mut v: Vec<u32> = (0..b.len() as u32).collect();
                v.sort_unstable_by(|&i, &j| at(i).total_cmp(&at(j)));
                v
            })
        })
        .collect()
}

fn too_many(what: &str) -> String {
    format!(
        "{what}: shared placements overlap too much to rule out coincident facets (at most {MAX_KEYS} placed facets inside overlaps, {MAX_TESTS} box tests); move the placements apart or use instancing = \"expand\""
    )
}

/// Keys of equal hash in a fixed order: expanded facets first.
fn rank(w: &Who) -> (u8, usize, usize, usize) {
    match *w {
        Who::Facet(i) => (0, i, 0, 0),
        Who::Placed {
            shared,
            placement,
            facet,
        } => (1, shared, placement, facet),
    }
}

/// The keyed facets inside overlaps, and the budgets (keys, box tests)
/// that bound the work.
struct Keyer<'a> {
    cx: Ctx<'a>,
    /// Each shared object's prototype facet boxes, in its own frame.
    proto_boxes: Vec<Vec<Aabb>>,
    orders: Vec<[Vec<u32>; 6]>,
    /// Placements whose every prototype facet is keyed already (a pile of
    /// placements on one spot keys each once).
    all_keyed: Vec<Vec<bool>>,
    facet_keyed: Vec<bool>,
    keys: Vec<(u64, Who)>,
    tests: u64,
}

impl<'a> Keyer<'a> {
    fn new(facets: &'a [Facet], shared: &'a [SharedInstances]) -> Self {
        let proto_boxes: Vec<Vec<Aabb>> = shared
            .iter()
            .map(|s| {
                s.prototype
                    .iter()
                    .map(|f| bounds(std::slice::from_ref(f)))
                    .collect()
            })
            .collect();
        Keyer {
            cx: Ctx { facets, shared },
            orders: facet_orders(&proto_boxes),
            proto_boxes,
            all_keyed: shared
                .iter()
                .map(|s| vec![false; s.placements.len()])
                .collect(),
            facet_keyed: vec![false; facets.len()],
            keys: Vec::new(),
            tests: 0,
        }
    }

    /// Keys one facet. A facet keyed for two overlaps is one key:
    /// duplicates are dropped whenever the budget is reached.
    fn push(&mut self, w: Who) -> Result<(), String> {
        self.keys.push((hash(&self.cx.key(w)), w));
        if self.keys.len() > MAX_KEYS {
            self.keys.sort_unstable_by_key(|(h, w)| (*h, rank(w)));
            self.keys.dedup();
            if self.keys.len() > MAX_KEYS / 2 {
                return Err(too_many("placed facets"));
            }
        }
        Ok(())
    }

    /// Keys expanded facet `i`, once.
    fn add_facet(&mut self, i: usize) -> Result<(), String> {
        if !std::mem::replace(&mut self.facet_keyed[i], true) {
            self.push(Who::Facet(i))?;
        }
        Ok(())
    }

    fn check_tests(&self) -> Result<(), String> {
        if self.tests > MAX_TESTS {
            return Err(too_many("box tests"));
        }
        Ok(())
    }

    /// Keys the prototype facets of placement (s, p) whose box meets
    /// `other` (mapped into the prototype's frame).
    fn add(&mut self, s: usize, p: usize, other: &Aabb) -> Result<(), String> {
        self.tests += 1;
        if self.all_keyed[s][p] {
            return Ok(());
        }
        let inv: DAffine3 = self.cx.shared[s].placements[p].inverse();
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for c in box_corners(*other) {
            let v = inv.transform_point3(c);
            lo = lo.min(v);
            hi = hi.max(v);
        }
        let q = padded(lo, hi);
        let (k, run) = self.candidate_run(s, &q);
        self.tests += run.len() as u64;
        self.check_tests()?;
        let mut n = 0;
        for r in run {
            let j = self.orders[s][k][r] as usize;
            if overlap(&self.proto_boxes[s][j], &q) {
                n += 1;
                self.push(Who::Placed {
                    shared: s,
                    placement: p,
                    facet: j,
                })?;
            }
        }
        self.all_keyed[s][p] = n == self.proto_boxes[s].len();
        Ok(())
    }

    /// The shortest candidate run of prototype `s`'s facets for box `q`:
    /// boxes with min ≤ q.max (a prefix of the min order) or max ≥ q.min
    /// (a suffix of the max order). The order's index and the run in it.
    fn candidate_run(&self, s: usize, q: &Aabb) -> (usize, std::ops::Range<usize>) {
        let boxes = &self.proto_boxes[s];
        (0..6)
            .map(|k| {
                let (axis, by_max) = (k % 3, k >= 3);
                let ord = &self.orders[s][k];
                if by_max {
                    let from = ord.partition_point(|&i| boxes[i as usize].1[axis] < q.0[axis]);
                    (k, from..ord.len())
                } else {
                    let to = ord.partition_point(|&i| boxes[i as usize].0[axis] <= q.1[axis]);
                    (k, 0..to)
                }
            })
            .min_by_key(|(_, r)| r.len())
            .unwrap_or((0, 0..0))
    }

    /// The first two keyed facets on exactly the same vertices.
    fn first_pair(mut self) -> Option<(Who, Who)> {
        self.keys.sort_unstable_by_key(|(h, w)| (*h, rank(w)));
        self.keys.dedup();
        for run in self.keys.chunk_by(|a, b| a.0 == b.0) {
            for (i, a) in run.iter().enumerate() {
                let ka = self.cx.key(a.1);
                if let Some(b) = run[i + 1..].iter().find(|b| self.cx.key(b.1) == ka) {
                    return Some((a.1, b.1));
                }
            }
        }
        None
    }
}

/// Sweep over x: each arriving unit meets the boxes still open (max x ≥
/// its min x); where a placement's box meets another's or a facet's, the
/// facets inside the overlap are keyed.
fn sweep(units: &[(Aabb, Unit)], keyer: &mut Keyer) -> Result<(), String> {
    let mut open_placements: BTreeSet<(i64, usize)> = BTreeSet::new();
    // Open facets: pruned when a placement arrives, and whenever the list
    // has doubled since (amortised O(1) a facet).
    let mut open_facets: Vec<(f64, usize)> = Vec::new();
    let mut pruned_len = 0usize;
    for (u, (bx, unit)) in units.iter().enumerate() {
        let at = ordered(bx.0.x);
        open_placements = open_placements.split_off(&(at, 0));
        match *unit {
            Unit::Placement(s, p) => {
                open_facets.retain(|&(hi, _)| hi >= bx.0.x);
                pruned_len = open_facets.len();
                let open = open_placements.iter().map(|&(_, v)| v);
                for v in open.chain(open_facets.iter().map(|&(_, v)| v)) {
                    let (ob, other) = &units[v];
                    keyer.tests += 1;
                    if !overlap(bx, ob) {
                        continue;
                    }
                    keyer.add(s, p, ob)?;
                    match *other {
                        Unit::Placement(s2, p2) => keyer.add(s2, p2, bx)?,
                        Unit::Facet(i) => keyer.add_facet(i)?,
                    }
                }
                keyer.check_tests()?;
                open_placements.insert((ordered(bx.1.x), u));
            }
            Unit::Facet(i) => {
                for &(_, v) in open_placements.iter() {
                    let (ob, other) = &units[v];
                    keyer.tests += 1;
                    if !overlap(bx, ob) {
                        continue;
                    }
                    if let Unit::Placement(s, p) = *other {
                        keyer.add(s, p, bx)?;
                        keyer.add_facet(i)?;
                    }
                }
                keyer.check_tests()?;
                open_facets.push((bx.1.x, u));
                if open_facets.len() > 2 * pruned_len + 1024 {
                    open_facets.retain(|&(hi, _)| hi >= bx.0.x);
                    pruned_len = open_facets.len();
                }
            }
        }
    }
    Ok(())
}

fn hash(k: &([[u64; 3]; 4], usize)) -> u64 {
    let mut h = std::hash::DefaultHasher::new();
    k.hash(&mut h);
    h.finish()
}
