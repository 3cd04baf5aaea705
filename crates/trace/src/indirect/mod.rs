//! Diffuse interreflection from a radiosity cache: light that arrives at a
//! surface after one or more diffuse bounces.
//!
//! Direct light is exact at every vertex (closed forms plus shadow rays), and
//! rooms are mostly diffuse, so the indirect part is smooth over each facet.
//! The cache stores it on a texel grid per facet side, solved once per
//! render (when the facets outnumber the texels, facets no larger than a
//! texel share world-space cluster texels instead, so the cache keeps its
//! budget whatever the facet count: `Tracer::clustered_layout`):
//!
//! 1. every texel gets its direct irradiance `E_d` with the tracer's own
//!    estimators (the same as at a camera hit);
//! 2. `cache_rays` cosine-weighted, Latin-hypercube stratified gather rays
//!    per texel record which texel they hit (through transmissive facets,
//!    times τ): a sparse, row-stochastic estimate of the gathering operator
//!    `G`, with `E_ind(x) = ∫ L_r(y(ω)) cos θ dω ≈ π/M Σ L_r(y_j)`;
//! 3. Jacobi iteration of `L_r = k_d (E_d + G L_r) / π` — iteration `k` adds
//!    exactly the `k`-th bounce — until the estimated remainder (geometric
//!    from the last two increments) is below `cache_tolerance` of the
//!    signal, then the geometric tail is added (so a ρ = 0.99 furnace needs
//!    no thousand iterations).
//!
//! At a camera (or specular) hit the indirect irradiance is then either read
//! from the cache by bilinear interpolation (`gather_rays = 0`) or gathered
//! again with `gather_rays` stratified rays reading the cached outgoing
//! radiance where they land (a *final gather*, which averages the cache's
//! discretisation away). Emitters hit by gather rays add nothing (next-event
//! estimation counted them), nor do escaping rays (the sky dome is sampled
//! at each vertex).
//!
//! Averaging does not undo a texel that misrepresents its own cell: a
//! street lamp's pool smaller than a 4 m texel, or a reflector a lamp
//! stands 5 cm from, whose centre outshines its mean 20×. So the render's
//! cache splits direct light into smooth terms (sky dome, area sources)
//! and sharp ones (point sources and the Moon), tests the sharp light at
//! 3 × 3 points of each texel against the bilinear interpolation between
//! centres, and where it strays (a *sharp* texel) a gather ray that lands
//! nearby reads only the smooth part and computes the sharp light where
//! it landed. Bright sharp texels are also aimed at (`Guide`). Area-lit
//! rooms have no sharp texels and are unchanged.
//!
//! Brute-force path tracing (`indirect = path`, `diffuse_bounces`) is kept
//! as the reference the cache is measured against (`gloam bench accuracy`).

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::light::Light;
use crate::sky_light::{cosine_hemisphere, orthonormal_basis};
use crate::tracer::{RayCounts, Smooth, Tracer, latin_hypercube, stream};

/// Facet sides per budgeted texel up to which every side gets its own grid.
const PER_FACET_MAX_SIDES_PER_TEXEL: f64 = 2.0;

/// Light-tree estimates of direct irradiance averaged per cache texel.
pub const CACHE_DIRECT_REPEATS: u32 = 4;

/// Random-stream domain of the cache's texels.
const DOMAIN_CACHE: u64 = 0xCAC4E;

/// Random-stream domain of the test for direct light that varies within a
/// texel (its own, so the cache's gather rays draw what they always drew).
const DOMAIN_SHARP: u64 = 0x5AA4E;

/// Sub-cells per side at whose centres a texel's sharp direct light (point
/// sources and the Moon: `Smooth`) is compared with its centre's.
const SHARP_TEST_SIDE: u32 = 3;

/// A sharp texel whose outgoing radiance exceeds this many times the
/// texels' area-weighted mean is also a target of guided gather rays: a
/// lamp's housing lit from 5 cm, a pool under a street lamp.
const GUIDE_CONTRAST: f64 = 10.0;

/// At most this many texels are aimed at (the brightest by power): a
/// gather weighs each against its distance.
const GUIDE_MAX_CELLS: usize = 256;

/// Guided gather rays per cosine-weighted one (default render of
/// `night-full-moon-lamps` at half size to 2 %: 39 s at ¼, 18 s at 1,
/// 15 s at 2, 14 s at 4; the town, whose every gather aims: 26, 28, 30 s
/// at ¼, 2, 4).
const GUIDED_PER_GATHER_RAY: usize = 2;

/// Departure of those values from the bilinear interpolation between texel
/// centres, relative to their mean, above which a texel's sharp light is
/// deemed to vary within it: a gather ray recomputes it where it lands.
const SHARP_VARIATION: f64 = 0.25;

/// What the cache solve did (recorded in `report.json`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct CacheSummary {
    pub texels: usize,
    /// Of these, texels shared by facets no larger than a texel (0: one
    /// grid per facet side, the layout for scenes with few facets).
    pub cluster_texels: usize,
    /// Texel size, scene units.
    pub texel_size: f64,
    pub gather_rays_per_texel: u32,
    /// Non-zero entries of the sparse gathering operator.
    pub operator_entries: usize,
    /// Jacobi iterations (= bounces solved explicitly).
    pub iterations: u32,
    /// Estimated remainder of the truncated series relative to the signal,
    /// before the geometric tail was added.
    pub remainder_estimate: f64,
    /// Ratio of the last two bounce increments (the enclosure's effective
    /// multiple-bounce albedo).
    pub bounce_ratio: f64,
    /// Share of each bounce in the cache's total reflected radiance
    /// (bounce 0 = direct), area-weighted over texels, all slots.
    pub bounce_shares: Vec<f64>,
    /// Texels whose sharp direct light (point sources and the Moon) departs
    /// from the interpolation between texel centres by more than
    /// `SHARP_VARIATION` of its mean — a lamp's pool or a
    /// shadow's edge crosses them, or a lamp stands close by: a
    /// final-gather ray that lands near one reads only the smooth part
    /// (sky dome, area sources, interreflection) and computes the sharp
    /// light at the point it hit.
    pub sharp_texels: usize,
    /// Of these, the bright ones (`GUIDE_CONTRAST` × the mean radiance)
    /// that final gathers also sample directly, weighted against their
    /// cosine-weighted rays by multiple importance sampling (balance
    /// heuristic): a small reflector a lamp lights from close by is hit by
    /// one cosine ray in hundreds, and its light would come in rare spikes.
    pub guided_texels: usize,
    pub seconds: f64,
}

/// The texel grid of one facet side.
#[derive(Clone, Debug)]
struct Grid {
    origin: DVec3,
    t: DVec3,
    b: DVec3,
    inv_h: f64,
    nu: u32,
    nv: u32,
    /// First texel index.
    first: u32,
}

impl Grid {
    fn coords(&self, p: DVec3) -> (f64, f64) {
        let d = p - self.origin;
        (d.dot(self.t) * self.inv_h, d.dot(self.b) * self.inv_h)
    }

    /// The texel containing `p`.
    fn nearest(&self, p: DVec3) -> u32 {
        let (s, v) = self.coords(p);
        let i = clamp_index(s, self.nu);
        let j = clamp_index(v, self.nv);
        self.first + j * self.nu + i
    }

    /// Bilinear weights over texel centres around `p`.
    fn bilinear(&self, p: DVec3) -> [(u32, f64); 4] {
        let (s, v) = self.coords(p);
        let (i0, fs) = split(s - 0.5, self.nu);
        let (j0, fv) = split(v - 0.5, self.nv);
        let i1 = (i0 + 1).min(self.nu - 1);
        let j1 = (j0 + 1).min(self.nv - 1);
        let idx = |i: u32, j: u32| self.first + j * self.nu + i;
        [
            (idx(i0, j0), (1.0 - fs) * (1.0 - fv)),
            (idx(i1, j0), fs * (1.0 - fv)),
            (idx(i0, j1), (1.0 - fs) * fv),
            (idx(i1, j1), fs * fv),
        ]
    }
}

fn clamp_index(x: f64, n: u32) -> u32 {
    if x.is_nan() || x < 0.0 {
        0
    } else {
        (x as u64).min(n as u64 - 1) as u32
    }
}

/// Integer cell and fraction of a coordinate, clamped to the grid.
fn split(x: f64, n: u32) -> (u32, f64) {
    if x.is_nan() || x <= 0.0 || n == 1 {
        return (0, 0.0);
    }
    let max = (n - 1) as f64;
    if x >= max {
        return (n - 1, 0.0);
    }
    let i = x.floor();
    (i as u32, x - i)
}

/// One entry of the gathering operator: texel, weight `π/M` times the number
/// of rays that landed there, and an optional spectral transmission (index
/// into `Cache::taus`).
#[derive(Clone, Copy, Debug)]
struct Entry {
    texel: u32,
    w: f64,
    tau: u32,
}

/// One texel's row of the gathering operator: its entries and the
/// spectral transmissions they index.
type OperatorRow = (Vec<Entry>, Vec<Vec<f64>>);

/// The solved bounce series over the texels ([`Tracer::bounce_series`]).
struct Series {
    radiance: Vec<f64>,
    e_ind: Vec<f64>,
    iterations: u32,
    remainder: f64,
    ratio: f64,
    bounce_norms: Vec<f64>,
}

/// The solved cache.
pub(crate) struct Cache {
    /// Where each facet side's texels are.
    layout: Layout,
    nwl: usize,
    /// Outgoing diffuse radiance `k_d (E_d + E_ind)/π` per texel × slot:
    /// the whole scene's light, then under `--layers` that of each lit
    /// group alone (`[texel][whole, lit groups…][slot]`, so a reading
    /// finds a texel's groups beside its whole).
    radiance: Vec<f64>,
    /// Indirect irradiance per texel × slot, laid out the same (groups
    /// kept only where a render reads it, `gather_rays = 0`).
    e_ind: Vec<f64>,
    /// Per texel, whether its sharp direct light varies within it
    /// (empty when none does, or the cache is never read by a final
    /// gather).
    sharp: Vec<bool>,
    /// Where some texel's does: `radiance` without the sharp direct light,
    /// laid out as `radiance` (what a final-gather ray reads around such a
    /// texel).
    smooth: Vec<f64>,
    /// Bright sharp texels that gather rays also aim at (`None`: none).
    guide: Option<Guide>,
    /// Under `--layers`, the light groups that light some texel (empty
    /// otherwise).
    lit: Vec<usize>,
    /// Values per texel in `radiance` and in `e_ind`: `nwl` times the
    /// lights they hold.
    stride: usize,
    e_stride: usize,
    pub(crate) summary: CacheSummary,
}

/// Which cached value a reading takes.
#[derive(Clone, Copy)]
pub(crate) enum Field {
    /// Outgoing radiance (a final gather reads it where its rays land).
    Radiance,
    /// Indirect irradiance (read directly, `gather_rays = 0`).
    Indirect,
    /// Outgoing radiance without the sharp direct light (read around
    /// texels where it varies).
    Smooth,
}

/// How large the cache should be.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CacheSize {
    pub texels: u32,
    pub rays: u32,
    pub tolerance: f64,
    pub max_iterations: u32,
    /// Direct irradiance as the mean over each texel's cell (stratified
    /// points) rather than at its centre: the pilot's coarse texels are
    /// larger than a street lamp's pool, which the centre point misses or
    /// spreads over the whole texel (night lamps: interreflection share
    /// 0.85 % at the centre vs 2.6 % measured; 1.7 % as a cell mean).
    pub direct_cell_mean: bool,
}

impl Cache {
    /// No texels (or no wavelengths): nothing cached, nothing to read.
    fn empty(layout: Layout, nwl: usize) -> Cache {
        Cache {
            layout,
            nwl,
            radiance: Vec::new(),
            e_ind: Vec::new(),
            sharp: Vec::new(),
            smooth: Vec::new(),
            guide: None,
            lit: Vec::new(),
            stride: nwl,
            e_stride: nwl,
            summary: CacheSummary::default(),
        }
    }

    /// Adds `scale ·` the whole scene's cached value `field` (bilinear) at
    /// `p` on `facet`'s side seen from the front or not, to `out`. With
    /// `split = Some((sums, τ))` (a reading split by group) it also adds
    /// each lit group's value times `τ(λ)` (1 for `None`) to that group's
    /// block of `sums` (`nwl` slots each), unscaled: a reading sums its
    /// rays first and scales the groups once ([`Cache::add_sums`]).
    #[allow(clippy::too_many_arguments)]
    fn add(
        &self,
        field: Field,
        facet: u32,
        front: bool,
        p: DVec3,
        scale: &[f64],
        out: &mut [f64],
        mut split: Option<(&mut [f64], Option<&[f64]>)>,
    ) {
        let Some(weights) = self.layout.weights(facet, usize::from(!front), p) else {
            return;
        };
        let n = self.nwl;
        let (values, stride) = match field {
            Field::Radiance => (&self.radiance, self.stride),
            Field::Indirect => (&self.e_ind, self.e_stride),
            Field::Smooth => (&self.smooth, self.stride),
        };
        for (k, w) in weights {
            if w == 0.0 {
                continue;
            }
            let texel = &values[k as usize * stride..(k as usize + 1) * stride];
            out.iter_mut()
                .zip(&texel[..n])
                .zip(scale)
                .for_each(|((o, v), s)| *o += w * s * v);
            match split.as_mut() {
                Some((sums, None)) => sums
                    .iter_mut()
                    .zip(&texel[n..])
                    .for_each(|(o, v)| *o += w * v),
                Some((sums, Some(t))) => {
                    for (o, v) in sums.chunks_mut(n).zip(texel[n..].chunks(n)) {
                        o.iter_mut()
                            .zip(v)
                            .zip(t.iter())
                            .for_each(|((o, v), t)| *o += w * t * v);
                    }
                }
                None => {}
            }
        }
    }

    /// Whether a reading at `p` on `facet`'s side touches a texel whose
    /// sharp direct light varies within it.
    fn reads_sharp(&self, facet: u32, front: bool, p: DVec3) -> bool {
        !self.sharp.is_empty()
            && self
                .layout
                .weights(facet, usize::from(!front), p)
                .is_some_and(|w| w.iter().any(|&(k, w)| w > 0.0 && self.sharp[k as usize]))
    }

    /// The sums a reading split by group adds into (one block of `nwl`
    /// slots per lit group), or `None` when `out` is not split or no group
    /// lights the cache.
    fn group_sums(&self, out: &Light) -> Option<Vec<f64>> {
        (out.groups() > 0 && !self.lit.is_empty()).then(|| vec![0.0; self.lit.len() * self.nwl])
    }

    /// Adds `scale ·` each lit group's `sums` to its part of `out`.
    fn add_sums(&self, sums: &[f64], scale: &[f64], out: &mut Light) {
        for (&g, s) in self.lit.iter().zip(sums.chunks(self.nwl)) {
            if let Some(part) = out.part_mut(g) {
                part.iter_mut()
                    .zip(s)
                    .zip(scale)
                    .for_each(|((o, s), k)| *o += k * s);
            }
        }
    }
}

/// Whether `p` (in the plane of the convex polygon `v`, normal `n`) lies
/// inside it, either winding.
fn inside_polygon(p: DVec3, v: &[DVec3], n: DVec3) -> bool {
    let k = v.len();
    let side = |j: usize| {
        let a = v[j];
        let b = v[(j + 1) % k];
        (b - a).cross(p - a).dot(n)
    };
    (0..k).all(|j| side(j) >= 0.0) || (0..k).all(|j| side(j) <= 0.0)
}

/// The point of the convex-or-not polygon `v` (plane normal `n`) nearest to
/// `p` (which lies in the plane), pulled a hair towards the centroid so it is
/// strictly inside.
fn into_polygon(p: DVec3, v: &[DVec3], n: DVec3, centroid: DVec3, h: f64) -> DVec3 {
    let k = v.len();
    let q = if inside_polygon(p, v, n) {
        p
    } else {
        let mut best = v[0];
        let mut best_d = f64::INFINITY;
        for j in 0..k {
            let a = v[j];
            let b = v[(j + 1) % k];
            let e = b - a;
            let l2 = e.length_squared();
            let t = if l2 > 0.0 {
                ((p - a).dot(e) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let c = a + e * t;
            let d = (c - p).length_squared();
            if d < best_d {
                best_d = d;
                best = c;
            }
        }
        best
    };
    let to_c = centroid - q;
    let l = to_c.length();
    if l > 0.0 {
        q + to_c * (1e-4 * h / l).min(1e-3)
    } else {
        q
    }
}

/// Marks a per-facet location as a cluster texel (else a grid index).
const CLUSTER: u32 = 1 << 31;
/// No texel (the facet side does not reflect diffusely).
const NO_TEXEL: u32 = u32::MAX;
/// Most rounds of the texel-size search of the clustered layout.
const MAX_GROW: u32 = 64;
/// Most rounds of the per-facet layout's texel-size search (it meets its
/// budget within ~60 whenever it is used: the size grows ≥ 2× a round).
const MAX_GROW_PER_FACET: u32 = 200;

/// Which cluster texel a small facet side falls into: voxel cell (size h,
/// anchored at the scene box), normal-direction bin of the side, material.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct ClusterKey {
    cell: [i64; 3],
    bin: u8,
    mat: u32,
}

/// A cheap multiplicative hasher for [`ClusterKey`] (SipHash costs more
/// than the rest of the layout for 10⁶ facets; the keys are not hostile).
#[derive(Default)]
struct KeyHasher(u64);

impl std::hash::Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        crate::tracer::mix64(self.0)
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    fn write_u32(&mut self, x: u32) {
        self.write_u64(x as u64);
    }
    fn write_u8(&mut self, x: u8) {
        self.write_u64(x as u64);
    }
    fn write_i64(&mut self, x: i64) {
        self.write_u64(x as u64);
    }
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
}

type KeyMap<V> = std::collections::HashMap<ClusterKey, V, std::hash::BuildHasherDefault<KeyHasher>>;

/// Normal-direction bin of a side normal: the dominant axis and its sign
/// (6 cube faces), each split 3 × 3 at ±22.5° so that axis-aligned
/// surfaces sit robustly in a face's centre bin. Opposite sides never
/// share a bin.
fn normal_bin(n: DVec3) -> u8 {
    let a = n.abs();
    let (axis, m, u, v) = if a.x >= a.y && a.x >= a.z {
        (0u8, n.x, n.y, n.z)
    } else if a.y >= a.z {
        (1, n.y, n.z, n.x)
    } else {
        (2, n.z, n.x, n.y)
    };
    let third = |x: f64| -> u8 {
        // tan 22.5°.
        let r = if m != 0.0 { x / m.abs() } else { 0.0 };
        if r < -0.414_213_56 {
            0
        } else if r > 0.414_213_56 {
            2
        } else {
            1
        }
    };
    (axis * 2 + u8::from(m < 0.0)) * 9 + third(u) * 3 + third(v)
}

/// Where every facet side's texels are.
pub(crate) struct Layout {
    grids: Vec<Grid>,
    /// Per facet, front and back: [`NO_TEXEL`], an index into `grids`, or
    /// [`CLUSTER`] | a texel index (8 bytes a facet, whatever its size).
    locs: Vec<[u32; 2]>,
    /// Cluster texels (the last ones).
    clusters: usize,
}

impl Layout {
    /// The texel holding `p` on `facet`'s side `side`.
    fn nearest(&self, facet: u32, side: usize, p: DVec3) -> Option<u32> {
        match self.locs.get(facet as usize)?[side] {
            NO_TEXEL => None,
            l if l & CLUSTER != 0 => Some(l & !CLUSTER),
            l => Some(self.grids[l as usize].nearest(p)),
        }
    }

    /// Interpolation weights at `p` (a cluster texel is one constant).
    fn weights(&self, facet: u32, side: usize, p: DVec3) -> Option<[(u32, f64); 4]> {
        match self.locs.get(facet as usize)?[side] {
            NO_TEXEL => None,
            l if l & CLUSTER != 0 => Some([(l & !CLUSTER, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)]),
            l => Some(self.grids[l as usize].bilinear(p)),
        }
    }
}

/// Per texel: facet its sample point lies on, the point, the side normal,
/// the area it stands for.
type Texel = (u32, DVec3, DVec3, f64);

/// A texel's sharp direct light, sampled over its cell where it varies
/// ([`Tracer::sharp_samples`]).
struct SharpSamples {
    /// Its sum over slots, averaged over the points and the centre.
    mean: f64,
    /// The points and the light's sum over slots at each.
    points: Vec<(DVec3, f64)>,
}

/// The texels a final gather aims at besides its cosine-weighted rays, and
/// how often ([`Tracer::final_gather`]).
struct Guide {
    cells: Vec<GuideCell>,
    /// Per texel: 1 + its index in `cells`, 0 for texels not aimed at.
    cell_of: Vec<u32>,
}

/// One texel aimed at: its facet and side, its square cell (corner and
/// edge vectors; a point drawn in the cell off the facet is a miss), the
/// cell's area and power (radiance summed over slots × area).
struct GuideCell {
    facet: u32,
    front: bool,
    corner: DVec3,
    du: DVec3,
    dv: DVec3,
    area: f64,
    power: f64,
}

impl Guide {
    /// How often a final gather at `p` (on `facet`) aims at each cell:
    /// power over squared distance (the cell's area at least), 0 for cells
    /// on `facet` or facing away from `p`. Returns the weights and their
    /// running sums (the last: the total).
    fn weights(&self, p: DVec3, facet: u32, normal: &[DVec3]) -> (Vec<f64>, Vec<f64>) {
        let w: Vec<f64> = self
            .cells
            .iter()
            .map(|cell| {
                let n = normal[cell.facet as usize];
                let n = if cell.front { n } else { -n };
                let centre = cell.corner + 0.5 * (cell.du + cell.dv);
                if cell.facet == facet || n.dot(p - centre) <= 0.0 {
                    return 0.0;
                }
                cell.power / (centre - p).length_squared().max(cell.area)
            })
            .collect();
        let cumulative = w
            .iter()
            .scan(0.0, |run, &x| {
                *run += x;
                Some(*run)
            })
            .collect();
        (w, cumulative)
    }
}

/// A light's sum over its slots (the whole).
fn total(e: &Light) -> f64 {
    e.whole.iter().sum()
}

mod gather;
mod layout;
mod solve;
#[cfg(test)]
mod tests;

fn cells_exact(len: f64, h: f64) -> u32 {
    ((len / h - 1e-9).ceil() as u64).clamp(1, 512) as u32
}

/// Vertex mean: the centroid of a triangle, inside any convex polygon.
fn centroid(v: &[DVec3]) -> DVec3 {
    v.iter().copied().sum::<DVec3>() / v.len().max(1) as f64
}

fn polygon_area(v: &[DVec3]) -> f64 {
    let mut a = DVec3::ZERO;
    for k in 1..v.len().saturating_sub(1) {
        a += (v[k] - v[0]).cross(v[k + 1] - v[0]);
    }
    0.5 * a.length()
}
