//! Building and solving the cache: each texel's direct light, the gather
//! operator, the Jacobi bounce series with its geometric tail.

use rand_pcg::Pcg64Mcg;

use super::*;

impl Tracer {
    /// Builds and solves the radiosity cache (see the module docs).
    pub(crate) fn build_cache(&self, size: CacheSize) -> Cache {
        self.build_cache_split(size, 0)
    }

    /// [`Tracer::build_cache`], and with `groups` > 0 (`--layers`) each
    /// light group's cache beside the whole scene's, from the same gather:
    /// the texels' direct irradiance is taken once, split by group, and
    /// the operator's rays are traced once; only the bounce series is
    /// solved again per group (its cost is the Jacobi iterations, not the
    /// rays), with the whole scene's number of bounces and tail ratio, so
    /// every group's solve is the same linear map and the groups' caches
    /// sum to the whole scene's. The whole is bit-identical to an unsplit
    /// build.
    pub(crate) fn build_cache_split(&self, size: CacheSize, groups: usize) -> Cache {
        let t0 = std::time::Instant::now();
        let nwl = self.wl.len();
        let (layout, texels, h) = self.cache_layout(size.texels);
        let n_tex = texels.len();
        let cluster_texels = layout.clusters;
        if n_tex == 0 || nwl == 0 {
            return Cache::empty(layout, nwl);
        }
        let rays = size.rays.max(1);
        let rows = self.texel_rows(&layout, &texels, size, groups);
        let operator_entries = rows.iter().map(|r| r.3.len()).sum();
        let sharp = self.sharp_flags(&rows, &texels, &layout);
        let sharp_texels = sharp.iter().filter(|&&s| s).count();
        let (direct, sharp_direct, ops) = split_rows(rows, sharp_texels > 0);
        // The whole scene's light and each lit group's, side by side: one
        // pass over the operator per bounce for all, the series cut and
        // extrapolated by the whole's increments alone.
        let lit: Vec<usize> = (0..groups)
            .filter(|&g| direct.iter().any(|d| d.part(g).is_some()))
            .collect();
        let lights = 1 + lit.len();
        let side_by_side = |d: &Light| -> Vec<f64> {
            let mut v = d.whole.clone();
            for &g in &lit {
                v.extend_from_slice(d.part(g).unwrap_or(&vec![0.0; nwl]));
            }
            v
        };
        let series = self.bounce_series(&ops, &texels, lights, |k| side_by_side(&direct[k]), size);
        let (iterations, remainder, ratio) = (series.iterations, series.remainder, series.ratio);
        let (radiance, e_ind, bounce_norms) = (series.radiance, series.e_ind, series.bounce_norms);
        let stride = lights * nwl;
        // Around texels whose direct light varies, a gather ray reads the
        // rest (k_d/π times the smooth irradiance) and adds the direct
        // light where it lands (`final_gather`).
        let (sharp, smooth) = if sharp_texels == 0 {
            (Vec::new(), Vec::new())
        } else {
            let sharp_direct: Vec<Vec<f64>> = sharp_direct.iter().map(side_by_side).collect();
            (
                sharp,
                self.smooth_radiance(&radiance, &sharp_direct, &texels, stride),
            )
        };
        let guide = self.guide(&layout, &texels, &sharp, &radiance, stride);
        let guided_texels = guide.as_ref().map_or(0, |g| g.cells.len());
        // The groups' indirect irradiance only where it is read.
        let (e_ind, e_stride) = if lights > 1 && self.settings.gather_rays > 0 {
            let whole: Vec<f64> = e_ind
                .chunks(stride)
                .flat_map(|t| &t[..nwl])
                .copied()
                .collect();
            (whole, nwl)
        } else {
            (e_ind, stride)
        };
        let bounce_shares = bounce_shares(&bounce_norms, ratio);
        Cache {
            layout,
            nwl,
            radiance,
            e_ind,
            sharp,
            smooth,
            guide,
            lit,
            stride,
            e_stride,
            summary: CacheSummary {
                texels: n_tex,
                cluster_texels,
                texel_size: h,
                gather_rays_per_texel: rays,
                operator_entries,
                iterations,
                remainder_estimate: remainder,
                bounce_ratio: ratio,
                bounce_shares,
                sharp_texels,
                guided_texels,
                seconds: t0.elapsed().as_secs_f64(),
            },
        }
    }

    /// Each texel's direct irradiance and operator row (parallel, each
    /// texel its own random stream: deterministic).
    fn texel_rows(
        &self,
        layout: &Layout,
        texels: &[Texel],
        size: CacheSize,
        groups: usize,
    ) -> Vec<TexelRow> {
        let n_tex = texels.len();
        let rays = size.rays.max(1);
        // Only a final gather reads a texel at the point a ray hit.
        let test_sharp = !size.direct_cell_mean && self.settings.gather_rays > 0;
        texels
            .par_iter()
            .enumerate()
            .map(|(k, &texel)| {
                let mut rng = stream(self.settings.seed, DOMAIN_CACHE, k as u64);
                let mut c = RayCounts::default();
                // A cluster texel (the last `layout.clusters`) stands for
                // many small facets through one of them: its points stay
                // within that facet.
                let cell = if k + layout.clusters >= n_tex {
                    polygon_area(&self.facet_verts[texel.0 as usize])
                } else {
                    texel.3
                };
                let direct = TexelDirect {
                    size,
                    groups,
                    test_sharp,
                };
                let (e, smooth, samples) = self.texel_direct(texel, cell, direct, &mut rng, &mut c);
                let (entries, taus) = self.operator_row(layout, texel, rays, &mut rng, &mut c);
                (e, smooth, samples, entries, taus)
            })
            .collect()
    }

    /// A texel's direct irradiance: sharp and smooth parts (the smooth
    /// apart only for the render's cache) and, where a final gather will
    /// read it, the sharp light over its cell.
    fn texel_direct(
        &self,
        (f, p, n, _): Texel,
        cell: f64,
        how: TexelDirect,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
    ) -> (Light, Light, (f64, Option<SharpSamples>)) {
        let mut e = Light::dark(self.wl.len(), how.groups);
        let mut smooth = e.dark_like();
        let mut samples = (0.0, None);
        // A texel's noise persists into every bounce and every pixel that
        // gathers from it. The pilot takes the direct irradiance as the
        // texel's mean (CACHE_DIRECT_REPEATS points 2 × 2 stratified over
        // the cell, kept on the facet, one light-tree selection each); the
        // render's cache, whose texels are finer, at the centre.
        if how.size.direct_cell_mean {
            let mut e1 = e.dark_like();
            for q in self.texel_points(f, p, cell, rng) {
                e1.clear();
                let picks = self.cache_picks();
                self.irradiance_with(q, n, f, 1, picks, None, rng, c, &mut e1);
                e.add_each(&e1, |a, b| a.iter_mut().zip(b).for_each(|(a, b)| *a += b));
            }
            let inv = 1.0 / CACHE_DIRECT_REPEATS as f64;
            e.each_mut(|v| v.iter_mut().for_each(|x| *x *= inv));
        } else {
            // With the light tree (one selection picks at most
            // `light_tree_branches` emitters) CACHE_DIRECT_REPEATS
            // selections are averaged; without it the closed forms are
            // exact and the count is unused. The smooth terms (`Smooth`)
            // are kept apart.
            self.irradiance_split(
                p,
                n,
                f,
                CACHE_DIRECT_REPEATS,
                self.cache_picks(),
                None,
                Smooth::Apart(&mut smooth),
                rng,
                c,
                &mut e,
            );
            if how.test_sharp {
                samples = self.sharp_samples(f, p, n, cell, &e, c);
            }
        }
        (e, smooth, samples)
    }

    /// A texel's row of the gather operator: `rays` cosine-weighted rays
    /// (Latin hypercube), each to the texel it hits, weight π/rays; rays
    /// to the same texel unattenuated are merged; attenuated ones keep
    /// their transmittance (the second vector, indexed by `Entry::tau`).
    fn operator_row(
        &self,
        layout: &Layout,
        (f, p, n, _): Texel,
        rays: u32,
        rng: &mut Pcg64Mcg,
        c: &mut RayCounts,
    ) -> (Vec<Entry>, Vec<Vec<f64>>) {
        let w_ray = std::f64::consts::PI / rays as f64;
        let mut entries: Vec<Entry> = Vec::new();
        let mut taus: Vec<Vec<f64>> = Vec::new();
        let mut u = Vec::with_capacity(rays as usize);
        latin_hypercube(rays as usize, rng, &mut u);
        let (tx, ty) = orthonormal_basis(n);
        for uv in u {
            let l = cosine_hemisphere(uv);
            let d = (tx * l.x + ty * l.y + n * l.z).normalize_or_zero();
            if let Some((g, front, y, tau)) = self.gather_hit(p, d, f, c) {
                let Some(texel) = layout.nearest(g, usize::from(!front), y) else {
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
                    texel,
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
        (merged, taus)
    }

    /// Which texels are sharp: where the sharp direct light strays from the
    /// bilinear interpolation between texel centres — what a reading would
    /// take — by more than SHARP_VARIATION of its mean: a pool or a
    /// shadow's edge inside it, or a lamp close by. A linear gradient over
    /// a fine grid is no reason.
    fn sharp_flags(&self, rows: &[TexelRow], texels: &[Texel], layout: &Layout) -> Vec<bool> {
        let centre: Vec<f64> = rows.iter().map(|r| r.2.0).collect();
        rows.iter()
            .zip(texels)
            .map(|(r, &(f, _, n, _))| {
                let Some(samples) = &r.2.1 else { return false };
                let side = usize::from(n.dot(self.normal_of(f)) < 0.0);
                let spread = samples.points.iter().map(|&(q, x)| {
                    let interpolated: f64 = layout.weights(f, side, q).map_or(0.0, |w| {
                        w.iter().map(|&(k, w)| w * centre[k as usize]).sum()
                    });
                    (x - interpolated).abs()
                });
                spread.fold(0.0, f64::max) > SHARP_VARIATION * samples.mean
            })
            .collect()
    }

    /// The cache's radiance without each texel's sharp direct light
    /// (k_d/π times `sharp_direct`, side by side like `radiance`): what a
    /// gather ray reads around sharp texels before adding the direct light
    /// where it lands (`final_gather`).
    fn smooth_radiance(
        &self,
        radiance: &[f64],
        sharp_direct: &[Vec<f64>],
        texels: &[Texel],
        stride: usize,
    ) -> Vec<f64> {
        let inv_pi = std::f64::consts::FRAC_1_PI;
        let mut smooth = radiance.to_vec();
        for (k, s) in sharp_direct.iter().enumerate() {
            let kd = &self.mats[self.facet_mat[texels[k].0 as usize] as usize].kd;
            for ((o, e), kd) in smooth[k * stride..(k + 1) * stride]
                .iter_mut()
                .zip(s)
                .zip(kd.iter().cycle())
            {
                *o -= kd * e * inv_pi;
            }
        }
        smooth
    }

    /// The texels a final gather also aims at: sharp grid texels whose
    /// outgoing radiance exceeds `GUIDE_CONTRAST` × the area-weighted mean
    /// over texels, chosen in proportion to their power (radiance × cell
    /// area). `None` when there are none.
    pub(super) fn guide(
        &self,
        layout: &Layout,
        texels: &[Texel],
        sharp: &[bool],
        radiance: &[f64],
        stride: usize,
    ) -> Option<Guide> {
        if sharp.is_empty() || stride == 0 {
            return None;
        }
        let nwl = self.wl.len();
        let level = |k: usize| radiance[k * stride..k * stride + nwl].iter().sum::<f64>();
        let (mut sum, mut area) = (0.0, 0.0);
        for (k, t) in texels.iter().enumerate() {
            sum += level(k) * t.3;
            area += t.3;
        }
        if !(sum > 0.0 && area > 0.0) {
            return None;
        }
        let mean = sum / area;
        let mut chosen: Vec<(usize, GuideCell)> = Vec::new();
        for (k, &(f, _, n, _)) in texels.iter().enumerate() {
            if !sharp[k] || level(k) <= GUIDE_CONTRAST * mean {
                continue;
            }
            let front = n.dot(self.normal_of(f)) >= 0.0;
            let side = usize::from(!front);
            let Some(&loc) = layout.locs.get(f as usize).map(|l| &l[side]) else {
                continue;
            };
            if loc == NO_TEXEL || loc & CLUSTER != 0 {
                continue;
            }
            let g = &layout.grids[loc as usize];
            let local = k as u32 - g.first;
            let (i, j) = (local % g.nu, local / g.nu);
            let h = 1.0 / g.inv_h;
            let cell = GuideCell {
                facet: f,
                front,
                corner: g.origin + g.t * (i as f64 * h) + g.b * (j as f64 * h),
                du: g.t * h,
                dv: g.b * h,
                area: h * h,
                power: level(k) * h * h,
            };
            chosen.push((k, cell));
        }
        if chosen.is_empty() {
            return None;
        }
        // The brightest GUIDE_MAX_CELLS (a gather weighs every cell), in
        // texel order.
        chosen.sort_by(|a, b| b.1.power.total_cmp(&a.1.power));
        chosen.truncate(GUIDE_MAX_CELLS);
        chosen.sort_unstable_by_key(|&(k, _)| k);
        let mut cell_of = vec![0; texels.len()];
        for (i, &(k, _)) in chosen.iter().enumerate() {
            cell_of[k] = i as u32 + 1;
        }
        let cells = chosen.into_iter().map(|(_, cell)| cell).collect();
        Some(Guide { cells, cell_of })
    }

    /// The bounce series of one light over the cache's texels, from each
    /// texel's direct irradiance `direct(k)`: Jacobi iteration of
    /// `L_r = k_d (E_d + G L_r) / π` (iteration `k` adds bounce `k`) until
    /// the estimated remainder is below `size.tolerance`, then the
    /// geometric tail. `lights` series are solved side by side (the
    /// whole scene's light, then light groups', `build_cache_split`):
    /// `direct(k)` holds each light's slots in turn, and so does the result
    /// per texel; the stopping rule, the tail ratio and the statistics
    /// are the first light's alone, so it is solved exactly as if alone
    /// and the others are the same linear map of their direct light.
    pub(super) fn bounce_series(
        &self,
        ops: &[OperatorRow],
        texels: &[Texel],
        lights: usize,
        direct: impl Fn(usize) -> Vec<f64>,
        size: CacheSize,
    ) -> Series {
        let first = self.wl.len();
        let nwl = first * lights;
        let n_tex = texels.len();
        // k_d per texel, once per light.
        let kd = |k: usize| {
            let kd = &self.mats[self.facet_mat[texels[k].0 as usize] as usize].kd;
            kd.iter().cycle().take(nwl)
        };
        let inv_pi = std::f64::consts::FRAC_1_PI;
        let mut radiance = vec![0.0; n_tex * nwl];
        for k in 0..n_tex {
            let e = direct(k);
            for (s, kd_s) in kd(k).enumerate() {
                radiance[k * nwl + s] = kd_s * e[s] * inv_pi;
            }
        }
        let weight: Vec<f64> = texels.iter().map(|t| t.3).collect();
        let norm = |v: &[f64]| -> f64 {
            v.chunks(nwl.max(1))
                .zip(&weight)
                .map(|(c, w)| w * c[..first].iter().map(|x| x.abs()).sum::<f64>())
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
            apply_operator(ops, &increment, &mut next_e, nwl);
            iterations += 1;
            for k in 0..n_tex {
                for (s, &k_s) in kd(k).enumerate() {
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
        add_tail(
            ratio,
            (&mut e_ind, &last_increment),
            (&mut radiance, &increment),
        );
        Series {
            radiance,
            e_ind,
            iterations,
            remainder,
            ratio,
            bounce_norms,
        }
    }
}

/// Adds the geometric tail ρ/(1 − ρ) × the last increment to each sum
/// (nothing unless 0 < ρ < 1).
fn add_tail(ratio: f64, e_ind: (&mut [f64], &[f64]), radiance: (&mut [f64], &[f64])) {
    if ratio > 0.0 && ratio < 1.0 {
        let tail = ratio / (1.0 - ratio);
        for (sum, last) in [e_ind, radiance] {
            sum.iter_mut().zip(last).for_each(|(s, l)| *s += tail * l);
        }
    }
}

/// `next_e` = the gather operator `ops` applied to `increment` (`nwl`
/// slots per texel; parallel over texels).
fn apply_operator(ops: &[OperatorRow], increment: &[f64], next_e: &mut [f64], nwl: usize) {
    next_e
        .par_chunks_mut(nwl)
        .zip(ops)
        .for_each(|(e, (entries, taus))| {
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
}

/// The texels' whole direct light (sharp + smooth), their sharp light
/// alone where any texel is sharp, and the operator's rows. The bounce
/// series starts from every texel's centre (a mean over a cell that a
/// wall crosses would carry light through it); a gather ray recomputes
/// the sharp light where it lands.
fn split_rows(rows: Vec<TexelRow>, any_sharp: bool) -> (Vec<Light>, Vec<Light>, Vec<OperatorRow>) {
    let mut direct = Vec::with_capacity(rows.len());
    let mut sharp_direct = Vec::new();
    let mut ops: Vec<OperatorRow> = Vec::with_capacity(rows.len());
    for (mut e, smooth, _, m, t) in rows {
        if any_sharp {
            sharp_direct.push(e.clone());
        }
        e.add_each(&smooth, |a, b| {
            a.iter_mut().zip(b).for_each(|(a, b)| *a += b)
        });
        direct.push(e);
        ops.push((m, t));
    }
    (direct, sharp_direct, ops)
}

/// A texel's direct light (sharp; smooth; its cell's sharp samples) and
/// its operator row with the row's transmittances.
type TexelRow = (
    Light,
    Light,
    (f64, Option<SharpSamples>),
    Vec<Entry>,
    Vec<Vec<f64>>,
);

/// How a cache takes its texels' direct light.
#[derive(Clone, Copy)]
struct TexelDirect {
    size: CacheSize,
    groups: usize,
    /// Whether to sample the sharp light over the cell (only a final
    /// gather reads a texel at the point a ray hit).
    test_sharp: bool,
}

/// Each bounce's share of the whole interreflection, the geometric tail
/// (ratio `ratio` after the last bounce) counted in the total.
fn bounce_shares(norms: &[f64], ratio: f64) -> Vec<f64> {
    let tail = if ratio > 0.0 && ratio < 1.0 {
        norms.last().copied().unwrap_or(0.0) * ratio / (1.0 - ratio)
    } else {
        0.0
    };
    let total: f64 = norms.iter().sum::<f64>() + tail;
    norms
        .iter()
        .map(|b| if total > 0.0 { b / total } else { 0.0 })
        .collect()
}
