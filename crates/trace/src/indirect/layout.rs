//! The cache's texels: a square grid per facet side, or world-space
//! clusters when the facets outnumber the budget.

use super::*;

impl Tracer {
    /// The square texel grid of facet `f` at texel size `h` (`first` = 0).
    pub(super) fn facet_grid(&self, f: usize, h: f64) -> Grid {
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
        Grid {
            origin: v[0] + t * s0 + b * v0,
            t,
            b,
            inv_h: 1.0 / hf,
            nu,
            nv,
            first: 0,
        }
    }

    /// Grid texels of facet `f` at texel size `h` (both sides).
    pub(super) fn grid_texels(&self, f: usize, h: f64) -> u64 {
        let g = self.facet_grid(f, h);
        2 * g.nu as u64 * g.nv as u64
    }

    /// [`CACHE_DIRECT_REPEATS`] points stratified over the square cell of
    /// area `area` around texel point `p` on facet `f` (the facet grid's
    /// axes), each kept on the facet by `into_polygon`.
    pub(super) fn texel_points(
        &self,
        f: u32,
        p: DVec3,
        area: f64,
        rng: &mut rand_pcg::Pcg64Mcg,
    ) -> Vec<DVec3> {
        use rand::Rng;
        let m = (CACHE_DIRECT_REPEATS as f64).sqrt().round().max(1.0) as u32;
        let on_cell = self.cell_mapping(f, p, area);
        (0..CACHE_DIRECT_REPEATS)
            .map(|r| {
                let (i, j) = (r % m, (r / m) % m);
                let u = (i as f64 + rng.random::<f64>()) / m as f64 - 0.5;
                let w = (j as f64 + rng.random::<f64>()) / m as f64 - 0.5;
                on_cell(u, w).0
            })
            .collect()
    }

    /// The point at cell coordinates `(u, w)` ∈ [−½, ½]² of the square cell
    /// of area `area` around texel point `p` on facet `f` (the facet
    /// grid's axes), kept on the facet by `into_polygon`, and whether it
    /// lay on the facet already.
    pub(super) fn cell_mapping(
        &self,
        f: u32,
        p: DVec3,
        area: f64,
    ) -> impl Fn(f64, f64) -> (DVec3, bool) + '_ {
        let v = &self.facet_verts[f as usize];
        let nf = self.facet_normal[f as usize];
        let t = (v[1] - v[0]).normalize_or_zero();
        let t = if t == DVec3::ZERO {
            orthonormal_basis(nf).0
        } else {
            t
        };
        let b = nf.cross(t);
        let hf = area.max(0.0).sqrt();
        let centroid = v.iter().copied().sum::<DVec3>() / v.len() as f64;
        move |u, w| {
            let q = p + t * (u * hf) + b * (w * hf);
            let kept = into_polygon(q, v, nf, centroid, hf);
            // Inside, `into_polygon` moves a point by 1e-4 · hf at most.
            (kept, (kept - q).length() <= 2e-4 * hf)
        }
    }

    /// Texel `k`'s sharp direct light (`Smooth`) summed over slots at its
    /// centre `p` (facet `f`, side normal `n`; `centre` is that light as
    /// the cache took it) and at the centres of `SHARP_TEST_SIDE`²
    /// sub-cells of its cell (area `area`): the points only if their spread
    /// exceeds `SHARP_VARIATION` of their mean (`None` for a texel lit
    /// evenly, or not at all). Whether bilinear interpolation between
    /// texel centres misses that variation is told once every centre is
    /// known ([`Tracer::build_cache_split`]).
    ///
    /// A light tree's picks are random: every point of every texel draws
    /// the same random numbers (one stream, restarted), so neighbouring
    /// points pick alike and the values differ where the light does, not
    /// where the picks do. Without a tree the sharp terms draw none.
    pub(super) fn sharp_samples(
        &self,
        f: u32,
        p: DVec3,
        n: DVec3,
        area: f64,
        centre: &Light,
        c: &mut RayCounts,
    ) -> (f64, Option<SharpSamples>) {
        let mut e = centre.dark_like();
        let mut at = |q: DVec3, c: &mut RayCounts| -> f64 {
            let mut rng = stream(self.settings.seed, DOMAIN_SHARP, 0);
            e.clear();
            let smooth = Smooth::Omitted;
            self.irradiance_split(
                q,
                n,
                f,
                CACHE_DIRECT_REPEATS,
                1,
                None,
                smooth,
                &mut rng,
                c,
                &mut e,
            );
            total(&e)
        };
        let e0 = if self.light_tree.is_some() {
            at(p, c)
        } else {
            total(centre)
        };
        let on_cell = self.cell_mapping(f, p, area);
        let (mut lo, mut hi) = (e0, e0);
        let m = SHARP_TEST_SIDE;
        let mut points = Vec::with_capacity((m * m - 1) as usize);
        for r in (0..m * m).filter(|&r| r != m * m / 2) {
            let u = ((r % m) as f64 + 0.5) / m as f64 - 0.5;
            let w = ((r / m) as f64 + 0.5) / m as f64 - 0.5;
            // Only points on the facet: one pulled in from beyond an edge
            // would sit on a seam, where a shadow ray can slip through.
            let (q, on_facet) = on_cell(u, w);
            if !on_facet {
                continue;
            }
            let x = at(q, c);
            lo = lo.min(x);
            hi = hi.max(x);
            points.push((q, x));
        }
        let mean = (e0 + points.iter().map(|p| p.1).sum::<f64>()) / (1 + points.len()) as f64;
        let samples = (hi - lo > SHARP_VARIATION * mean).then_some(SharpSamples { mean, points });
        (e0, samples)
    }

    /// Texel sample points of a grid (`into_polygon` keeps them on the facet).
    pub(super) fn push_grid_texels(
        &self,
        f: usize,
        side: usize,
        g: &Grid,
        texels: &mut Vec<Texel>,
    ) {
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
                let c = g.origin + g.t * ((i as f64 + 0.5) * hf) + g.b * ((j as f64 + 0.5) * hf);
                let p = into_polygon(c, v, self.facet_normal[f], centroid, hf);
                texels.push((f as u32, p, n, hf * hf));
            }
        }
    }

    /// Where the texels go for a budget of `budget` texels: one grid per
    /// facet side (the original layout, kept bit for bit) whenever every
    /// side can have its own texel within 4 × the budget; otherwise
    /// [`Tracer::clustered_layout`]. Returns the layout, its texels and the
    /// texel size.
    pub(super) fn cache_layout(&self, budget: u32) -> (Layout, Vec<Texel>, f64) {
        let nf = self.facet_verts.len();
        // Facets that reflect diffusely get texels on each side.
        let cached: Vec<bool> = (0..nf)
            .map(|f| self.mats[self.facet_mat[f] as usize].has_diffuse)
            .collect();
        let total_area: f64 = (0..nf)
            .filter(|&f| cached[f])
            .map(|f| polygon_area(&self.facet_verts[f]))
            .sum();
        let texels_max = budget.max(1) as f64;
        let h0 = (total_area / (texels_max / 2.0)) // two sides
            .sqrt()
            .max(1e-12 * self.geom.extent.max(1e-300));
        let sides = 2 * cached.iter().filter(|&&c| c).count() as u64;
        // Per-facet grids while the sides are at most twice the budget: every
        // shipped scene (and so its results, bit for bit) stays on this path,
        // and a scene of ~10⁴ facets, which would get up to 4× the budget in
        // one-texel grids, takes the cheaper clustered layout instead.
        if sides as f64 <= PER_FACET_MAX_SIDES_PER_TEXEL * texels_max {
            // Each side gets ≥ 1 texel, so this search ends once h exceeds
            // every facet (h at least doubles a round).
            let mut h = h0;
            for _ in 0..MAX_GROW_PER_FACET {
                let count: u64 = (0..nf)
                    .filter(|&f| cached[f])
                    .map(|f| self.grid_texels(f, h))
                    .sum();
                if count as f64 <= 4.0 * texels_max || count == 0 {
                    return self.per_facet_layout(&cached, h);
                }
                h *= (count as f64 / texels_max).sqrt();
            }
        }
        self.clustered_layout(&cached, h0, budget.max(1) as u64)
    }

    /// Every cached facet side its own grid at texel size `h`.
    pub(super) fn per_facet_layout(&self, cached: &[bool], h: f64) -> (Layout, Vec<Texel>, f64) {
        let mut grids = Vec::new();
        let mut locs = vec![[NO_TEXEL; 2]; cached.len()];
        let mut count = 0u64;
        for (f, _) in cached.iter().enumerate().filter(|c| *c.1) {
            let g = self.facet_grid(f, h);
            for loc in locs[f].iter_mut() {
                *loc = grids.len() as u32;
                grids.push(Grid {
                    first: count as u32,
                    ..g.clone()
                });
                count += g.nu as u64 * g.nv as u64;
            }
        }
        let mut texels = Vec::with_capacity(count as usize);
        for (f, l) in locs.iter().enumerate() {
            for (side, &gi) in l.iter().enumerate() {
                if gi != NO_TEXEL {
                    self.push_grid_texels(f, side, &grids[gi as usize], &mut texels);
                }
            }
        }
        let clusters = 0;
        (
            Layout {
                grids,
                locs,
                clusters,
            },
            texels,
            h,
        )
    }

    /// The cluster key of facet `f`'s side `side` at texel size `h`
    /// (`coarse`: normal bin only, the last resort that always fits).
    pub(super) fn cluster_key(&self, f: usize, side: usize, h: f64, coarse: bool) -> ClusterKey {
        let n = if side == 0 {
            self.facet_normal[f]
        } else {
            -self.facet_normal[f]
        };
        let bin = normal_bin(n);
        if coarse {
            return ClusterKey {
                cell: [0; 3],
                bin,
                mat: 0,
            };
        }
        let c = centroid(&self.facet_verts[f]);
        let e = self.geom.extent;
        // NaN → 0, ±∞ saturate: never a panic.
        let cell = |x: f64| ((x + e) / h).floor() as i64;
        ClusterKey {
            cell: [cell(c.x), cell(c.y), cell(c.z)],
            bin,
            mat: self.facet_mat[f],
        }
    }

    /// Whether facet `f` gets a single texel per side at size `h` (it is
    /// no larger than a texel), so it joins a cluster.
    pub(super) fn is_small(&self, f: usize, h: f64, coarse: bool) -> bool {
        if coarse {
            return true;
        }
        let g = self.facet_grid(f, h);
        g.nu == 1 && g.nv == 1
    }

    /// Texels of the clustered layout at size `h`, counting stops above
    /// `cap` (then the true count is larger still).
    pub(super) fn clustered_count(
        &self,
        cached: &[bool],
        h: f64,
        cap: u64,
        keys: &mut KeyMap<()>,
    ) -> u64 {
        keys.clear();
        let mut grid = 0u64;
        for (f, _) in cached.iter().enumerate().filter(|c| *c.1) {
            let g = self.facet_grid(f, h);
            if g.nu == 1 && g.nv == 1 {
                for side in 0..2 {
                    keys.insert(self.cluster_key(f, side, h, false), ());
                }
            } else {
                grid += 2 * g.nu as u64 * g.nv as u64;
            }
            if grid + keys.len() as u64 > cap {
                break;
            }
        }
        grid + keys.len() as u64
    }

    /// The layout for scenes with more facets than texels: facets larger
    /// than the texel size h keep their grids; smaller ones share world-space
    /// cluster texels keyed by (voxel of size h, normal bin, material), so
    /// the cache holds at most `budget` texels whatever the facet count. h
    /// grows from `h0` (≥ 10 % a round, at most [`MAX_GROW`] rounds, at most
    /// 4 × the scene's half-diagonal, where every facet shares one voxel);
    /// should even that not fit, clusters go by normal bin alone (≤ 54).
    pub(super) fn clustered_layout(
        &self,
        cached: &[bool],
        h0: f64,
        budget: u64,
    ) -> (Layout, Vec<Texel>, f64) {
        let (h, coarse) = self.cluster_size(cached, h0, budget);
        let nf = cached.len();
        let mut grids = Vec::new();
        let mut locs = vec![[NO_TEXEL; 2]; nf];
        let mut texels: Vec<Texel> = Vec::new();
        // Large facets: grids, as in the per-facet layout.
        for f in (0..nf).filter(|&f| cached[f]) {
            if self.is_small(f, h, coarse) {
                continue;
            }
            let g = self.facet_grid(f, h);
            for (side, loc) in locs[f].iter_mut().enumerate() {
                *loc = grids.len() as u32;
                let g = Grid {
                    first: texels.len() as u32,
                    ..g.clone()
                };
                self.push_grid_texels(f, side, &g, &mut texels);
                grids.push(g);
            }
        }
        // Small facets: cluster texels in order of first appearance
        // (deterministic), with area and area-weighted centroid sums.
        let base = texels.len();
        let mut ids: KeyMap<u32> = KeyMap::default();
        let mut sums: Vec<(f64, DVec3)> = Vec::new();
        for f in (0..nf).filter(|&f| cached[f]) {
            if !self.is_small(f, h, coarse) {
                continue;
            }
            let a = polygon_area(&self.facet_verts[f]);
            let c = centroid(&self.facet_verts[f]);
            for (side, loc) in locs[f].iter_mut().enumerate() {
                let key = self.cluster_key(f, side, h, coarse);
                let id = *ids.entry(key).or_insert_with(|| {
                    sums.push((0.0, DVec3::ZERO));
                    (sums.len() - 1) as u32
                });
                *loc = CLUSTER | (base as u32 + id);
                let s = &mut sums[id as usize];
                if a.is_finite() && c.is_finite() {
                    s.0 += a;
                    s.1 += a * c;
                }
            }
        }
        drop(ids);
        let rep = self.cluster_representatives(cached, &locs, base, &sums);
        texels.reserve(sums.len());
        for (&(f, side, _, _), &(a, _)) in rep.iter().zip(&sums) {
            let f = f as usize;
            let n = if side == 0 {
                self.facet_normal[f]
            } else {
                -self.facet_normal[f]
            };
            texels.push((f as u32, centroid(&self.facet_verts[f]), n, a));
        }
        let clusters = sums.len();
        (
            Layout {
                grids,
                locs,
                clusters,
            },
            texels,
            h,
        )
    }

    /// The cluster size h that fits `budget` texels, grown from `h0`, and
    /// whether even 4 × the half-diagonal did not fit (`coarse`: clusters
    /// by normal bin alone).
    fn cluster_size(&self, cached: &[bool], h0: f64, budget: u64) -> (f64, bool) {
        let h_max = 4.0 * self.geom.extent;
        let mut h = if h0 < h_max { h0 } else { h_max };
        let mut keys: KeyMap<()> = KeyMap::default();
        let mut chosen = None;
        for _ in 0..MAX_GROW {
            let count = self.clustered_count(cached, h, 16 * budget, &mut keys);
            if count <= budget {
                chosen = Some(h);
                break;
            }
            if h >= h_max {
                break;
            }
            let grow = (count as f64 / budget as f64).sqrt().max(1.1);
            h = (h * grow).min(h_max);
        }
        drop(keys);
        match chosen {
            Some(h) => (h, false),
            None => (h_max, true),
        }
    }

    /// Each cluster's sample point: the centroid of the member facet (with
    /// area) nearest the cluster's mean centroid — a real point on a real
    /// surface, never inside an object. Per cluster: facet, side, whether
    /// degenerate, squared distance.
    fn cluster_representatives(
        &self,
        cached: &[bool],
        locs: &[[u32; 2]],
        base: usize,
        sums: &[(f64, DVec3)],
    ) -> Vec<(u32, u8, bool, f64)> {
        let nf = cached.len();
        let mut rep: Vec<(u32, u8, bool, f64)> =
            vec![(u32::MAX, 0, true, f64::INFINITY); sums.len()];
        for f in (0..nf).filter(|&f| cached[f]) {
            for (side, &l) in locs[f].iter().enumerate() {
                if l == NO_TEXEL || l & CLUSTER == 0 {
                    continue;
                }
                let id = (l & !CLUSTER) as usize - base;
                let (a, m) = sums[id];
                let mean = if a > 0.0 { m / a } else { DVec3::ZERO };
                let degenerate = polygon_area(&self.facet_verts[f]).partial_cmp(&0.0)
                    != Some(std::cmp::Ordering::Greater);
                let d = (centroid(&self.facet_verts[f]) - mean).length_squared();
                let d = if d.is_nan() { f64::INFINITY } else { d };
                let r = &mut rep[id];
                if r.0 == u32::MAX || (degenerate, d) < (r.2, r.3) {
                    *r = (f as u32, side as u8, degenerate, d);
                }
            }
        }
        rep
    }

    /// The size of a render's cache (not the pilot's), from the settings.
    pub(crate) fn render_cache_size(&self) -> CacheSize {
        CacheSize {
            texels: self.settings.cache_texels,
            rays: self.settings.cache_rays,
            tolerance: self.settings.cache_tolerance,
            max_iterations: 200,
            direct_cell_mean: false,
        }
    }
}
