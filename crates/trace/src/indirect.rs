//! Diffuse interreflection from a radiosity cache: light that arrives at a
//! surface after one or more diffuse bounces.
//!
//! Direct light is exact at every vertex (closed forms plus shadow rays), and
//! rooms are mostly diffuse, so the indirect part is smooth over each facet.
//! The cache stores it on a texel grid per facet side, solved once per
//! render:
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
//! Brute-force path tracing (`indirect = path`, `diffuse_bounces`) is kept
//! as the reference the cache is measured against (`gloam bench accuracy`).

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::sky_light::{cosine_hemisphere, orthonormal_basis};
use crate::tracer::{RayCounts, Tracer, latin_hypercube, stream};

/// Random-stream domain of the cache's texels.
const DOMAIN_CACHE: u64 = 0xCAC4E;

/// What the cache solve did (recorded in `report.json`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct CacheSummary {
    pub texels: usize,
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

/// The solved cache.
pub(crate) struct Cache {
    /// Per facet: front (index 0) and back (index 1) grids.
    grids: Vec<[Option<Grid>; 2]>,
    nwl: usize,
    /// Outgoing diffuse radiance `k_d (E_d + E_ind)/π` per texel × slot.
    radiance: Vec<f64>,
    /// Indirect irradiance per texel × slot.
    e_ind: Vec<f64>,
    pub(crate) summary: CacheSummary,
}

/// How large the cache should be.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CacheSize {
    pub texels: u32,
    pub rays: u32,
    pub tolerance: f64,
    pub max_iterations: u32,
}

impl Cache {
    /// Bilinear cached value (`radiance` or `e_ind`) at `p` on `facet`'s side
    /// `side`, times `scale`, added to `out`. False when there is no grid.
    fn add_bilinear(
        &self,
        field: &[f64],
        facet: u32,
        side: usize,
        p: DVec3,
        scale: &[f64],
        out: &mut [f64],
    ) -> bool {
        let Some(g) = &self.grids[facet as usize][side] else {
            return false;
        };
        let n = self.nwl;
        for (k, w) in g.bilinear(p) {
            if w == 0.0 {
                continue;
            }
            let v = &field[k as usize * n..(k as usize + 1) * n];
            out.iter_mut()
                .zip(v)
                .zip(scale)
                .for_each(|((o, v), s)| *o += w * s * v);
        }
        true
    }

    /// Adds `scale ·` the cached outgoing radiance at `p` on `facet` (side
    /// seen from direction `d`) to `out`.
    pub(crate) fn add_radiance(
        &self,
        facet: u32,
        front: bool,
        p: DVec3,
        scale: &[f64],
        out: &mut [f64],
    ) {
        self.add_bilinear(&self.radiance, facet, usize::from(!front), p, scale, out);
    }

    /// Adds `scale ·` the cached indirect irradiance at `p` to `out`.
    pub(crate) fn add_indirect_irradiance(
        &self,
        facet: u32,
        front: bool,
        p: DVec3,
        scale: &[f64],
        out: &mut [f64],
    ) {
        self.add_bilinear(&self.e_ind, facet, usize::from(!front), p, scale, out);
    }
}

/// The point of the convex-or-not polygon `v` (plane normal `n`) nearest to
/// `p` (which lies in the plane), pulled a hair towards the centroid so it is
/// strictly inside.
fn into_polygon(p: DVec3, v: &[DVec3], n: DVec3, centroid: DVec3, h: f64) -> DVec3 {
    let k = v.len();
    let inside = (0..k).all(|j| {
        let a = v[j];
        let b = v[(j + 1) % k];
        (b - a).cross(p - a).dot(n) >= 0.0
    }) || (0..k).all(|j| {
        let a = v[j];
        let b = v[(j + 1) % k];
        (b - a).cross(p - a).dot(n) <= 0.0
    });
    let q = if inside {
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

impl Tracer {
    /// Builds and solves the radiosity cache (see the module docs).
    pub(crate) fn build_cache(&self, size: CacheSize) -> Cache {
        let t0 = std::time::Instant::now();
        let nf = self.facet_verts.len();
        let nwl = self.wl.len();
        // Facets that reflect diffusely get a grid on each side.
        let cached: Vec<bool> = (0..nf)
            .map(|f| self.mats[self.facet_mat[f] as usize].has_diffuse)
            .collect();
        let area: Vec<f64> = (0..nf)
            .map(|f| polygon_area(&self.facet_verts[f]))
            .collect();
        let total_area: f64 = (0..nf).filter(|&f| cached[f]).map(|f| area[f]).sum();
        let budget = size.texels.max(1) as f64 / 2.0; // two sides
        let mut h = (total_area / budget)
            .sqrt()
            .max(1e-12 * self.geom.extent.max(1e-300));
        let mut grids: Vec<[Option<Grid>; 2]>;
        let mut count;
        loop {
            grids = vec![[None, None]; nf];
            count = 0u64;
            for f in 0..nf {
                if !cached[f] {
                    continue;
                }
                let v = &self.facet_verts[f];
                let n = self.facet_normal[f];
                let t = (v[1] - v[0]).normalize_or_zero();
                let t = if t == DVec3::ZERO {
                    orthonormal_basis(n).0
                } else {
                    t
                };
                let b = n.cross(t);
                let (mut s0, mut s1, mut v0, mut v1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
                for &x in v {
                    let d = x - v[0];
                    s0 = s0.min(d.dot(t));
                    s1 = s1.max(d.dot(t));
                    v0 = v0.min(d.dot(b));
                    v1 = v1.max(d.dot(b));
                }
                let cells = |len: f64| ((len / h).ceil() as u64).clamp(1, 512) as u32;
                let (nu, nv) = (cells(s1 - s0), cells(v1 - v0));
                let hu = (s1 - s0) / nu as f64;
                let hv = (v1 - v0) / nv as f64;
                // Square cells: one size per facet side (the larger).
                let hf = hu.max(hv).max(f64::MIN_POSITIVE);
                let (nu, nv) = (cells_exact(s1 - s0, hf), cells_exact(v1 - v0, hf));
                let origin = v[0] + t * s0 + b * v0;
                for g in grids[f].iter_mut() {
                    *g = Some(Grid {
                        origin,
                        t,
                        b,
                        inv_h: 1.0 / hf,
                        nu,
                        nv,
                        first: count as u32,
                    });
                    count += nu as u64 * nv as u64;
                }
            }
            if count as f64 <= 4.0 * size.texels.max(1) as f64 || count == 0 {
                break;
            }
            h *= (count as f64 / size.texels.max(1) as f64).sqrt();
        }
        let n_tex = count as usize;
        if n_tex == 0 || nwl == 0 {
            return Cache {
                grids,
                nwl,
                radiance: Vec::new(),
                e_ind: Vec::new(),
                summary: CacheSummary::default(),
            };
        }
        // Texel sample points and their side normals.
        let mut texels: Vec<(u32, DVec3, DVec3, f64)> = Vec::with_capacity(n_tex);
        for (f, sides) in grids.iter().enumerate() {
            for (side, g) in sides.iter().enumerate() {
                let Some(g) = g else { continue };
                let n = if side == 0 {
                    self.facet_normal[f]
                } else {
                    -self.facet_normal[f]
                };
                let v = &self.facet_verts[f];
                let centroid = v.iter().copied().sum::<DVec3>() / v.len() as f64;
                let hf = 1.0 / g.inv_h;
                for j in 0..g.nv {
                    for i in 0..g.nu {
                        let c = g.origin
                            + g.t * ((i as f64 + 0.5) * hf)
                            + g.b * ((j as f64 + 0.5) * hf);
                        let p = into_polygon(c, v, self.facet_normal[f], centroid, hf);
                        texels.push((f as u32, p, n, hf * hf));
                    }
                }
            }
        }
        let rays = size.rays.max(1);
        let w_ray = std::f64::consts::PI / rays as f64;
        // Direct irradiance and the operator's rows, per texel (parallel,
        // each texel its own random stream: deterministic).
        type Row = (Vec<f64>, Vec<Entry>, Vec<Vec<f64>>);
        let rows: Vec<Row> = texels
            .par_iter()
            .enumerate()
            .map(|(k, &(f, p, n, _))| {
                let mut rng = stream(self.settings.seed, DOMAIN_CACHE, k as u64);
                let mut c = RayCounts::default();
                let mut e = vec![0.0; nwl];
                self.irradiance(p, n, f, &mut rng, &mut c, &mut e);
                let mut entries: Vec<Entry> = Vec::new();
                let mut taus: Vec<Vec<f64>> = Vec::new();
                let mut u = Vec::with_capacity(rays as usize);
                latin_hypercube(rays as usize, &mut rng, &mut u);
                let (tx, ty) = orthonormal_basis(n);
                for uv in u {
                    let l = cosine_hemisphere(uv);
                    let d = (tx * l.x + ty * l.y + n * l.z).normalize_or_zero();
                    if let Some((g, front, y, tau)) = self.gather_hit(p, d, f, &mut c) {
                        let Some(grid) = &grids[g as usize][usize::from(!front)] else {
                            continue;
                        };
                        let ti = match tau {
                            None => u32::MAX,
                            Some(t) => {
                                taus.push(t);
                                (taus.len() - 1) as u32
                            }
                        };
                        entries.push(Entry {
                            texel: grid.nearest(y),
                            w: w_ray,
                            tau: ti,
                        });
                    }
                }
                // Merge rays that landed on the same texel (unattenuated).
                entries.sort_by_key(|e| (e.tau != u32::MAX, e.texel));
                let mut merged: Vec<Entry> = Vec::with_capacity(entries.len());
                for e in entries {
                    match merged.last_mut() {
                        Some(m) if m.texel == e.texel && m.tau == u32::MAX && e.tau == u32::MAX => {
                            m.w += e.w
                        }
                        _ => merged.push(e),
                    }
                }
                (e, merged, taus)
            })
            .collect();
        let operator_entries = rows.iter().map(|r| r.1.len()).sum();
        // k_d per texel.
        let kd = |k: usize| &self.mats[self.facet_mat[texels[k].0 as usize] as usize].kd;
        let inv_pi = std::f64::consts::FRAC_1_PI;
        let mut radiance = vec![0.0; n_tex * nwl];
        for k in 0..n_tex {
            let kdk = kd(k);
            for s in 0..nwl {
                radiance[k * nwl + s] = kdk[s] * rows[k].0[s] * inv_pi;
            }
        }
        let weight: Vec<f64> = texels.iter().map(|t| t.3).collect();
        let norm = |v: &[f64]| -> f64 {
            v.chunks(nwl.max(1))
                .zip(&weight)
                .map(|(c, w)| w * c.iter().map(|x| x.abs()).sum::<f64>())
                .sum()
        };
        let direct_norm = norm(&radiance);
        let mut bounce_norms = vec![direct_norm];
        let mut e_ind = vec![0.0; n_tex * nwl];
        let mut prev_delta = f64::NAN;
        let mut ratio = 0.0;
        let mut remainder = 0.0;
        let mut iterations = 0;
        let mut last_increment = vec![0.0; n_tex * nwl];
        let mut increment = radiance.clone(); // bounce 0
        let mut next_e = vec![0.0; n_tex * nwl];
        let mut delta_l = vec![0.0; n_tex * nwl];
        while iterations < size.max_iterations && direct_norm > 0.0 {
            // Next bounce: G applied to the last increment.
            next_e
                .par_chunks_mut(nwl)
                .zip(&rows)
                .for_each(|(e, (_, entries, taus))| {
                    e.iter_mut().for_each(|x| *x = 0.0);
                    for en in entries {
                        let t = en.texel as usize;
                        let src = &increment[t * nwl..(t + 1) * nwl];
                        if en.tau == u32::MAX {
                            e.iter_mut().zip(src).for_each(|(o, l)| *o += en.w * l);
                        } else {
                            e.iter_mut()
                                .zip(src)
                                .zip(&taus[en.tau as usize])
                                .for_each(|((o, l), t)| *o += en.w * l * t);
                        }
                    }
                });
            iterations += 1;
            for k in 0..n_tex {
                let kdk = kd(k);
                for (s, &k_s) in kdk.iter().enumerate().take(nwl) {
                    let i = k * nwl + s;
                    e_ind[i] += next_e[i];
                    delta_l[i] = k_s * next_e[i] * inv_pi;
                    radiance[i] += delta_l[i];
                }
            }
            std::mem::swap(&mut last_increment, &mut next_e);
            std::mem::swap(&mut increment, &mut delta_l);
            let delta = norm(&increment);
            bounce_norms.push(delta);
            let prev_ratio = ratio;
            if prev_delta.is_finite() && prev_delta > 0.0 {
                ratio = (delta / prev_delta).min(0.999_999);
            }
            prev_delta = delta;
            let total = norm(&radiance);
            remainder = if ratio > 0.0 {
                delta * ratio / (1.0 - ratio) / total
            } else {
                delta / total
            };
            // Stop when the remainder is small, or when the bounce ratio
            // has settled so well that the geometric tail is known to the
            // tolerance (a ρ = 0.99 furnace: a few iterations, not 1000).
            let tail_uncertainty = if ratio > 0.0 && ratio < 1.0 {
                remainder * (ratio - prev_ratio).abs() / (1.0 - ratio)
            } else {
                f64::INFINITY
            };
            if delta == 0.0
                || (iterations >= 2 && remainder < size.tolerance)
                || (iterations >= 6 && tail_uncertainty < size.tolerance)
            {
                break;
            }
        }
        // The geometric tail of the series beyond the last bounce solved.
        if ratio > 0.0 && ratio < 1.0 {
            let tail = ratio / (1.0 - ratio);
            for i in 0..n_tex * nwl {
                e_ind[i] += tail * last_increment[i];
                radiance[i] += tail * increment[i];
            }
        }
        let total: f64 = bounce_norms.iter().sum::<f64>()
            + if ratio > 0.0 && ratio < 1.0 {
                bounce_norms.last().copied().unwrap_or(0.0) * ratio / (1.0 - ratio)
            } else {
                0.0
            };
        let bounce_shares = bounce_norms
            .iter()
            .map(|b| if total > 0.0 { b / total } else { 0.0 })
            .collect();
        Cache {
            grids,
            nwl,
            radiance,
            e_ind,
            summary: CacheSummary {
                texels: n_tex,
                texel_size: h,
                gather_rays_per_texel: rays,
                operator_entries,
                iterations,
                remainder_estimate: remainder,
                bounce_ratio: ratio,
                bounce_shares,
                seconds: t0.elapsed().as_secs_f64(),
            },
        }
    }

    /// Follows a gather ray from `p` (on facet `from`) to the first opaque
    /// surface: `(facet, front side hit, point, transmission)`. Transmissive
    /// facets in between multiply τ; a transmissive facet that also
    /// reflects diffusely ends the ray there (its cached radiance counts).
    pub(crate) fn gather_hit(
        &self,
        p: DVec3,
        d: DVec3,
        from: u32,
        c: &mut RayCounts,
    ) -> Option<(u32, bool, DVec3, Option<Vec<f64>>)> {
        let mut o = p;
        let mut ignore = from;
        let mut tau: Option<Vec<f64>> = None;
        for _ in 0..64 {
            c.secondary += 1;
            let eps = self.geom.epsilon(o);
            let hit = self.geom.intersect(o, d, eps, f64::INFINITY, ignore)?;
            let f = hit.facet;
            let y = o + d * hit.t;
            let front = d.dot(self.facet_normal[f as usize]) < 0.0;
            let mat = &self.mats[self.facet_mat[f as usize] as usize];
            match &mat.trans {
                Some(tr) if !mat.has_diffuse => {
                    let t = tau.get_or_insert_with(|| vec![1.0; tr.len()]);
                    t.iter_mut().zip(tr).for_each(|(a, b)| *a *= b);
                    if t.iter().all(|&x| x == 0.0) {
                        return None;
                    }
                    o = y;
                    ignore = f;
                }
                _ => return Some((f, front, y, tau)),
            }
        }
        None
    }

    /// Indirect irradiance at a camera/specular hit `p` on `facet` (side
    /// normal `ns`), times `scale` (throughput × k_d / π), added to `acc`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn cached_indirect(
        &self,
        cache: &Cache,
        p: DVec3,
        ns: DVec3,
        facet: u32,
        front: bool,
        scale: &[f64],
        points: Option<&[[f64; 2]]>,
        rng: &mut rand_pcg::Pcg64Mcg,
        c: &mut RayCounts,
        acc: &mut [f64],
    ) {
        let k = self.settings.gather_rays as usize;
        if k == 0 {
            cache.add_indirect_irradiance(facet, front, p, scale, acc);
            return;
        }
        self.final_gather(cache, p, ns, facet, k, points, scale, rng, c, acc);
    }

    /// A final gather: `k` cosine-weighted rays from `p` (on `facet`, side
    /// normal `ns`) along `points` (or a fresh Latin hypercube), each adding
    /// `π/k · scale · τ ·` the cached outgoing radiance where it lands, so
    /// `acc` gains `scale ·` the indirect irradiance.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn final_gather(
        &self,
        cache: &Cache,
        p: DVec3,
        ns: DVec3,
        facet: u32,
        k: usize,
        points: Option<&[[f64; 2]]>,
        scale: &[f64],
        rng: &mut rand_pcg::Pcg64Mcg,
        c: &mut RayCounts,
        acc: &mut [f64],
    ) {
        let mut u = Vec::with_capacity(k);
        match points {
            Some(pts) if pts.len() == k => u.extend_from_slice(pts),
            _ => latin_hypercube(k, rng, &mut u),
        }
        let (tx, ty) = orthonormal_basis(ns);
        // E = π/K Σ L(y_j).
        let w = std::f64::consts::PI / k as f64;
        let mut s = scale.to_vec();
        for uv in u {
            let l = cosine_hemisphere(uv);
            let d = (tx * l.x + ty * l.y + ns * l.z).normalize_or_zero();
            if let Some((g, gfront, y, tau)) = self.gather_hit(p, d, facet, c) {
                match tau {
                    None => {
                        s.iter_mut().zip(scale).for_each(|(a, b)| *a = w * b);
                    }
                    Some(t) => {
                        s.iter_mut()
                            .zip(scale)
                            .zip(&t)
                            .for_each(|((a, b), t)| *a = w * b * t);
                    }
                }
                cache.add_radiance(g, gfront, y, &s, acc);
            }
        }
    }
}

fn cells_exact(len: f64, h: f64) -> u32 {
    ((len / h - 1e-9).ceil() as u64).clamp(1, 512) as u32
}

fn polygon_area(v: &[DVec3]) -> f64 {
    let mut a = DVec3::ZERO;
    for k in 1..v.len().saturating_sub(1) {
        a += (v[k] - v[0]).cross(v[k + 1] - v[0]);
    }
    0.5 * a.length()
}
