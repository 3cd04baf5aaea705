//! Reading the cache at a hit: bilinear, or a final gather of stratified
//! rays reading the cached radiance where they land.

use super::*;

impl Tracer {
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
            let front = d.dot(self.normal_of(f)) < 0.0;
            let mat = self.mat_of(f);
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
        acc: &mut Light,
    ) {
        let k = self.settings.gather_rays as usize;
        if k == 0 {
            let mut sums = cache.group_sums(acc);
            let split = sums.as_deref_mut().map(|s| (s, None));
            cache.add(
                Field::Indirect,
                facet,
                front,
                p,
                scale,
                &mut acc.whole,
                split,
            );
            if let Some(sums) = sums {
                cache.add_sums(&sums, scale, acc);
            }
            return;
        }
        self.final_gather(cache, p, ns, facet, k, points, scale, rng, c, acc);
    }

    /// A final gather: `k` cosine-weighted rays from `p` (on `facet`, side
    /// normal `ns`) along `points` (or a fresh Latin hypercube), each adding
    /// `π/k · scale · τ ·` the cached outgoing radiance where it lands, so
    /// `acc` gains `scale ·` the indirect irradiance.
    ///
    /// Where the cache has bright sharp texels ([`Guide`]),
    /// `GUIDED_PER_GATHER_RAY · k` more rays aim at points drawn on them,
    /// and every ray is weighted by the balance heuristic: a ray of direction ω that lands at `y` adds
    /// `L(y) cos θ / (k cos θ/π + k_g p_g(ω))`, `p_g` the guided rays'
    /// solid-angle density there (0 off the guided texels, where the
    /// weight is the plain `π/k`).
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
        acc: &mut Light,
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
        // The groups' parts: Σ_j τ_j L_g(y_j), scaled once at the end.
        let mut sums = cache.group_sums(acc);
        // Guided rays where some bright cell faces p: cell i is aimed at
        // with probability aim[i] / aim_sum.
        let (guide, aim, cumulative) = match cache.guide.as_ref() {
            Some(g) => {
                let (aim, cumulative) = g.weights(p, facet, &self.facet_normal);
                let sum = cumulative.last().copied().unwrap_or(0.0);
                (Some(g).filter(|_| sum > 0.0), aim, cumulative)
            }
            None => (None, Vec::new(), Vec::new()),
        };
        let aim_sum = cumulative.last().copied().unwrap_or(0.0);
        let kg = guide.map_or(0, |_| GUIDED_PER_GATHER_RAY * k);
        // The balance-heuristic weight of a ray (direction d, cosine
        // cos_p at p) landing at y on texel side (g, front), relative to w.
        let weight = |g: u32, front: bool, y: DVec3, d: DVec3, cos_p: f64| -> Option<f64> {
            let guide = guide?;
            let texel = cache.layout.nearest(g, usize::from(!front), y)?;
            let i = guide.cell_of[texel as usize].checked_sub(1)? as usize;
            let density = aim[i] / aim_sum / guide.cells[i].area;
            if density <= 0.0 {
                return None;
            }
            let n = self.normal_of(g);
            let cos_y = (if front { n } else { -n }).dot(-d);
            if cos_y <= 0.0 {
                return None;
            }
            let pdf_g = density * (y - p).length_squared() / cos_y;
            let pdf_c = cos_p * std::f64::consts::FRAC_1_PI;
            Some(cos_p / (k as f64 * pdf_c + kg as f64 * pdf_g) / w)
        };
        for uv in u {
            let l = cosine_hemisphere(uv);
            let d = (tx * l.x + ty * l.y + ns * l.z).normalize_or_zero();
            if let Some((g, gfront, y, tau)) = self.gather_hit(p, d, facet, c) {
                let ratio = weight(g, gfront, y, d, l.z);
                let hit = (g, gfront, y);
                let sums = sums.as_deref_mut();
                self.gather_read(cache, hit, tau, w, ratio, scale, &mut s, sums, rng, c, acc);
            }
        }
        if let Some(guide) = guide {
            for _ in 0..kg {
                let Some(h) = self.guided_ray(guide, &cumulative, aim_sum, p, ns, facet, rng, c)
                else {
                    continue;
                };
                let Some(ratio) = weight(h.facet, h.front, h.y, h.d, h.cos_p) else {
                    continue;
                };
                let sums = sums.as_deref_mut();
                let hit = (h.facet, h.front, h.y);
                let ratio = Some(ratio);
                self.gather_read(
                    cache, hit, h.tau, w, ratio, scale, &mut s, sums, rng, c, acc,
                );
            }
        }
        if let Some(sums) = sums {
            let ws: Vec<f64> = scale.iter().map(|k| w * k).collect();
            cache.add_sums(&sums, &ws, acc);
        }
    }

    /// One guided gather ray: a point drawn on a bright cell (the cell by
    /// inversion of the running sums `cumulative` of the aim weights; a
    /// cell of weight 0 adds nothing to them and is never picked), kept
    /// only where the first surface seen from `p` along it is that side of
    /// that facet (transmissive ones between pass τ).
    #[allow(clippy::too_many_arguments)]
    fn guided_ray(
        &self,
        guide: &Guide,
        cumulative: &[f64],
        aim_sum: f64,
        p: DVec3,
        ns: DVec3,
        facet: u32,
        rng: &mut rand_pcg::Pcg64Mcg,
        c: &mut RayCounts,
    ) -> Option<GuidedHit> {
        use rand::Rng;
        let x = rng.random::<f64>() * aim_sum;
        let i = cumulative.partition_point(|&run| run <= x);
        let cell = &guide.cells[i.min(guide.cells.len() - 1)];
        let y = cell.corner + cell.du * rng.random::<f64>() + cell.dv * rng.random::<f64>();
        let f = cell.facet as usize;
        if cell.facet == facet || !inside_polygon(y, &self.facet_verts[f], self.facet_normal[f]) {
            return None;
        }
        let d = (y - p).try_normalize()?;
        let cos_p = d.dot(ns);
        if cos_p <= 0.0 {
            return None;
        }
        let (g, gfront, _, tau) = self.gather_hit(p, d, facet, c)?;
        if g != cell.facet || gfront != cell.front {
            return None;
        }
        Some(GuidedHit {
            facet: g,
            front: gfront,
            y,
            d,
            cos_p,
            tau,
        })
    }

    /// Adds one gather ray's reading to `acc`: `w · ratio · scale · τ ·`
    /// the outgoing radiance at `y` on facet `g`'s side (`ratio` 1 for
    /// `None`) — the cached radiance, or around a sharp texel the cached
    /// smooth part plus k_d/π × the sharp light computed at `y`. Group parts
    /// go to `sums` (times τ · ratio, scaled by `w · scale` at the end).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn gather_read(
        &self,
        cache: &Cache,
        (g, gfront, y): (u32, bool, DVec3),
        tau: Option<Vec<f64>>,
        w: f64,
        ratio: Option<f64>,
        scale: &[f64],
        s: &mut [f64],
        sums: Option<&mut [f64]>,
        rng: &mut rand_pcg::Pcg64Mcg,
        c: &mut RayCounts,
        acc: &mut Light,
    ) {
        let wr = ratio.map_or(w, |r| w * r);
        match &tau {
            None => {
                s.iter_mut().zip(scale).for_each(|(a, b)| *a = wr * b);
            }
            Some(t) => {
                s.iter_mut()
                    .zip(scale)
                    .zip(t)
                    .for_each(|((a, b), t)| *a = wr * b * t);
            }
        }
        // Group parts: τ · ratio per slot, built only for a split reading.
        let split_tau: Option<Vec<f64>> = match (&sums, ratio) {
            (Some(_), Some(r)) => Some(match &tau {
                None => vec![r; scale.len()],
                Some(t) => t.iter().map(|t| t * r).collect(),
            }),
            _ => None,
        };
        let split = sums.map(|s| (s, split_tau.as_deref().or(tau.as_deref())));
        if !cache.reads_sharp(g, gfront, y) {
            cache.add(Field::Radiance, g, gfront, y, s, &mut acc.whole, split);
            return;
        }
        // The texel's direct light varies within it: its smooth part from
        // the cache, the rest where the ray landed.
        cache.add(Field::Smooth, g, gfront, y, s, &mut acc.whole, split);
        let n = self.normal_of(g);
        let ny = if gfront { n } else { -n };
        let mut e = acc.dark_like();
        let smooth = Smooth::Omitted;
        self.irradiance_split(y, ny, g, 1, 1, None, smooth, rng, c, &mut e);
        let kd = &self.mat_of(g).kd;
        acc.add_each(&e, |o, e| {
            for (((o, e), s), kd) in o.iter_mut().zip(e).zip(s.iter()).zip(kd) {
                *o += s * kd * e * std::f64::consts::FRAC_1_PI;
            }
        });
    }
}

/// Where a guided gather ray landed: facet and side, the point, the
/// direction from the shading point, cos θ there and the τ passed on the way.
struct GuidedHit {
    facet: u32,
    front: bool,
    y: DVec3,
    d: DVec3,
    cos_p: f64,
    tau: Option<Vec<f64>>,
}
