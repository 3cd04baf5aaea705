//! The pilot: a coarse grid of camera rays (with windows around lamps)
//! and a pilot radiosity cache, giving each term's share of the signal.

use rand_pcg::Pcg64Mcg as Rng;

use super::*;
use crate::indirect::Cache;
use crate::render::Deposit;

impl Tracer {
    /// Band sums of the traced radiance (direct light, specular bounces,
    /// transmission; no interreflection) over the pilot grid's pixels whose
    /// first hit is a facet that does not emit. Each pixel has its own fixed random
    /// stream, so two calls with different settings differ by the effect,
    /// not by noise.
    pub(super) fn pilot_traced(&self) -> Vec<f64> {
        let cam = &self.camera;
        let cols = PILOT_COLS.min(cam.width).max(1);
        let rows = PILOT_ROWS.min(cam.height).max(1);
        let mut c = RayCounts::default();
        let mut sum = vec![0.0; self.wl.len()];
        let mut acc = crate::light::Light::dark(self.wl.len(), 0);
        let seen_points = self.point_source_pixels();
        for j in 0..rows {
            for i in 0..cols {
                let x = (i as f64 + 0.5) * cam.width as f64 / cols as f64;
                let y = (j as f64 + 0.5) * cam.height as f64 / rows as f64;
                let d = cam.pixel_direction(x, y);
                // The interreflection pilot's pixel set: pixels that see a
                // facet that is not an emitter (not the sky, not a panel).
                match self.gather_hit(cam.position, d, u32::MAX, &mut c) {
                    None => continue,
                    Some((f, front, _, _)) if front && self.source_of(f) != u32::MAX => {
                        continue;
                    }
                    Some(_) if self.emitter_beside(x, y, &seen_points, &mut c) => continue,
                    Some(_) => {}
                }
                let mut rng = stream(self.settings.seed, 0x0009_1108, (j * cols + i) as u64);
                acc.clear();
                self.trace(
                    cam.position,
                    d,
                    u32::MAX,
                    &self.ones,
                    PathState::camera(self.settings.diffuse_bounces, false),
                    None,
                    None,
                    &mut rng,
                    &mut c,
                    &mut acc,
                );
                sum.iter_mut().zip(&acc.whole).for_each(|(s, a)| *s += a);
            }
        }
        self.wl.integrate(&sum)
    }

    /// Whether the image pixel around `(x, y)` or one of its eight
    /// neighbours shows an emitter (either side) at any of its four corners
    /// or 2 × 2 interior points (the test points of
    /// `gloam_bench::truth::no_emitter_mask`: an emitter's edge
    /// can poke into a pixel between them, and then shows in a neighbour).
    /// 52 primary rays per pilot pixel.
    /// `seen_points`: the pixels that show a point source
    /// ([`Tracer::point_source_pixels`]), emitters too.
    pub(super) fn emitter_beside(
        &self,
        x: f64,
        y: f64,
        seen_points: &[(u32, u32)],
        c: &mut RayCounts,
    ) -> bool {
        let cam = &self.camera;
        let (x0, y0) = (x.floor() - 1.0, y.floor() - 1.0);
        if seen_points.iter().any(|&(pc, pr)| {
            (pc as f64 - x.floor()).abs() <= 1.0 && (pr as f64 - y.floor()).abs() <= 1.0
        }) {
            return true;
        }
        // Corners: a 4 × 4 lattice; interior points: a 6 × 6 one.
        let corners = (0..16).map(|k| ((k % 4) as f64, (k / 4) as f64));
        let inner = (0..36).map(|k| (0.25 + 0.5 * (k % 6) as f64, 0.25 + 0.5 * (k / 6) as f64));
        corners.chain(inner).any(|(dx, dy)| {
            let (px, py) = (x0 + dx, y0 + dy);
            if px < 0.0 || py < 0.0 || px > cam.width as f64 || py > cam.height as f64 {
                return false;
            }
            let d = cam.pixel_direction(px, py);
            matches!(self.gather_hit(cam.position, d, u32::MAX, c),
                Some((f, _, _, _)) if self.source_of(f) != u32::MAX)
        })
    }

    /// The pilot: a coarse cache and a coarse grid of camera rays. Without
    /// `interreflection` (the user set `indirect = off`) no cache is built
    /// and nothing gathered: the shares are the direct light's.
    pub(super) fn pilot(&self, interreflection: bool) -> Pilot {
        let t0 = std::time::Instant::now();
        let cache = interreflection.then(|| {
            self.build_cache(CacheSize {
                texels: PILOT_TEXELS,
                rays: PILOT_RAYS,
                tolerance: 1e-3,
                max_iterations: 200,
                direct_cell_mean: true,
            })
        });
        let cam = &self.camera;
        let cols = PILOT_COLS.min(cam.width).max(1);
        let rows = PILOT_ROWS.min(cam.height).max(1);
        let samples = self.pilot_samples(cols, rows);
        let mut c = RayCounts::default();
        // Point sources seen directly: their pixels are emitter pixels, and
        // their deposits are direct view's share below.
        let deposits = self.point_deposits(&mut c);
        let mut walk = PilotWalk {
            rng: stream(self.settings.seed, 0x0009_1107, 0),
            split_rng: stream(self.settings.seed, 0x0009_110A, 0),
            c,
            seen_points: deposits.iter().map(|d| (d.0, d.1)).collect(),
            beside: std::collections::HashMap::new(),
        };
        let mut tally = Tally::new(self.wl.len());
        for &sample in &samples {
            self.pilot_sample(sample, cache.as_ref(), &mut walk, &mut tally);
        }
        // Weights are in pixels: the grid's samples stand for the pixels
        // outside the windows, a window's sub-samples for their pixel.
        let total_weight: f64 = samples.iter().map(|s| s.2).sum();
        let parts = self.part_shares(&tally, &deposits, total_weight);
        let (ind, tot) = if tally.plain_pixels > 0 {
            (&tally.ind, &tally.tot)
        } else {
            (&tally.ind_all, &tally.tot_all)
        };
        let bi = self.wl.integrate(ind);
        let bt = self.wl.integrate(tot);
        let share_by_band = bi
            .iter()
            .zip(&bt)
            .map(|(i, t)| if *t > 0.0 { i / t } else { 0.0 })
            .collect();
        Pilot {
            share_by_band,
            ratio: cache.as_ref().map_or(0.0, |c| c.summary.bounce_ratio),
            seconds: t0.elapsed().as_secs_f64(),
            parts,
        }
    }

    /// One pilot sample `(x, y, weight, on_grid)`: its hit's direct light
    /// by term, one bounce of each term (grid pixels, with a cache), and
    /// its indirect light by a final gather on the pilot `cache`, added to
    /// `t`.
    fn pilot_sample(
        &self,
        (x, y, w, on_grid): (f64, f64, f64, bool),
        cache: Option<&Cache>,
        walk: &mut PilotWalk,
        t: &mut Tally,
    ) {
        let cam = &self.camera;
        let nwl = self.wl.len();
        let inv_pi = std::f64::consts::FRAC_1_PI;
        let d = cam.pixel_direction(x, y);
        let Some((f, front, p, tau)) = self.gather_hit(cam.position, d, u32::MAX, &mut walk.c)
        else {
            return;
        };
        let tau = tau.unwrap_or_else(|| self.ones.clone());
        let ng = self.normal_of(f);
        let ns = if front { ng } else { -ng };
        let mat = self.mat_of(f);
        let mut e_d = vec![0.0; nwl];
        let src = self.source_of(f);
        let emitter = src != u32::MAX && front;
        // Pixels beside an emitter show some of it in their footprint: left
        // out of the share's pixel set, as from the set `--target-error`
        // governs. Per pixel, not per point (a window pixel has up to 4096).
        let beside = !emitter
            && *walk
                .beside
                .entry((x.floor() as i64, y.floor() as i64))
                .or_insert_with(|| self.emitter_beside(x, y, &walk.seen_points, &mut walk.c));
        let plain = !emitter && !beside;
        let mut pix_parts: Vec<Vec<f64>> = vec![vec![0.0; nwl]; Term::COUNT];
        if mat.has_diffuse {
            let parts = self.irradiance_parts(p, ns, f, &mut walk.rng, &mut walk.c);
            let reflect: Vec<f64> = (0..nwl).map(|s| mat.kd[s] * inv_pi * tau[s]).collect();
            t.add_parts(&parts, &reflect, (w, plain), &mut e_d, &mut pix_parts);
        }
        if cache.is_some() && mat.has_diffuse && on_grid && plain {
            self.bounce_split(
                p,
                ns,
                f,
                &mat.kd,
                &tau,
                &mut walk.split_rng,
                &mut walk.c,
                &mut t.bounce_parts,
            );
        }
        // Indirect irradiance by a final gather on the pilot cache (reading
        // the coarse cache directly misjudges small lit patches such as the
        // pools under street lamps). A window pixel's points share its
        // PILOT_GATHER rays (at least PILOT_GATHER_MIN each): a grazing
        // road pixel of 64 × 2 points would otherwise cost 128 grid pixels'
        // gathers.
        let gather = if on_grid {
            PILOT_GATHER
        } else {
            ((PILOT_GATHER as f64 * w).round() as usize).clamp(PILOT_GATHER_MIN, PILOT_GATHER)
        };
        let mut e_i = crate::light::Light::dark(nwl, 0);
        if let Some(cache) = cache.filter(|_| mat.has_diffuse) {
            let (rng, c) = (&mut walk.rng, &mut walk.c);
            self.final_gather(cache, p, ns, f, gather, None, &self.ones, rng, c, &mut e_i);
        }
        let e_i = e_i.into_whole();
        let mut pix_ind = vec![0.0; nwl];
        let mut pix_tot = vec![0.0; nwl];
        for s in 0..nwl {
            let k = mat.kd[s] * inv_pi * tau[s];
            pix_ind[s] = k * e_i[s];
            pix_tot[s] = k * (e_d[s] + e_i[s]);
            if emitter {
                let a = &self.area[src as usize];
                let le = tau[s] * a.radiance_toward(s, -d);
                pix_tot[s] += le;
                t.emitted_all[s] += w * le;
            }
        }
        t.add_sample((w, on_grid, plain), &pix_ind, &pix_tot);
        // The per-pixel percentiles stay the grid's (a uniform sample of
        // the pixels).
        if on_grid && plain {
            t.plain_pixels += 1;
            let parts = pix_parts.iter().map(|v| self.wl.integrate(v)).collect();
            t.per_pixel.push((parts, self.wl.integrate(&pix_tot)));
        }
    }

    /// Each light term's share of the signal, emitters seen directly's,
    /// the terms' 90th percentiles over the pixels, from the pilot's sums.
    fn part_shares(&self, t: &Tally, deposits: &[Deposit], total_weight: f64) -> PartShares {
        let nwl = self.wl.len();
        let max_share = |num: &[f64], den: &[f64]| -> f64 {
            let (n, d) = (self.wl.integrate(num), self.wl.integrate(den));
            n.iter()
                .zip(&d)
                .map(|(a, b)| if *b > 0.0 { a / b } else { 0.0 })
                .fold(0.0, f64::max)
        };
        let plain = t.plain_pixels > 0;
        // Leaving a source out takes away its direct light and the
        // interreflection it feeds. Over the plain pixels the
        // interreflection is split among the terms as one bounce of each
        // splits (`bounce_split`); without them, or without a bounce, as
        // the direct light does. (Its share of the whole signal, direct
        // only, put the office's panels at 53 % when dropping them takes
        // 100 %; the direct light's split put the night town's Moon at
        // 0.66× of the measured share: it lights the walls the streets
        // see, the lamps mostly the streets.)
        let direct_sum = |all: bool| -> Vec<f64> {
            (0..nwl)
                .map(|s| {
                    t.part_sums
                        .iter()
                        .map(|p| if all { p.1[s] } else { p.0[s] })
                        .sum()
                })
                .collect()
        };
        let (direct_plain, direct_all) = (direct_sum(false), direct_sum(true));
        let bounce_total: Vec<f64> = (0..nwl)
            .map(|s| t.bounce_parts.iter().map(|b| b[s]).sum())
            .collect();
        let part = |k: usize| {
            if plain {
                // Per slot: (d_k + I·b_k/B) / (D + I), with the direct
                // split standing in for b_k/B where no bounce was seen.
                let (num, den): (Vec<f64>, Vec<f64>) = (0..nwl)
                    .map(|s| {
                        let d = direct_plain[s];
                        let frac = if bounce_total[s] > 0.0 {
                            t.bounce_parts[k][s] / bounce_total[s]
                        } else if d > 0.0 {
                            t.part_sums[k].0[s] / d
                        } else {
                            0.0
                        };
                        (t.part_sums[k].0[s] + t.ind[s] * frac, d + t.ind[s])
                    })
                    .unzip();
                max_share(&num, &den)
            } else {
                max_share(&t.part_sums[k].1, &direct_all)
            }
        };
        let p90 = |k: usize| term_p90(&t.per_pixel, k);
        PartShares {
            terms: TermShares::from_fn(part),
            direct_view: self.direct_view_share(t, deposits, total_weight),
            pixel_p90: TermShares::from_fn(p90),
            signal_seen: {
                let tot = self.wl.integrate(if plain { &t.tot } else { &t.tot_all });
                tot.iter().any(|&x| x > 0.0)
            },
            ..Default::default()
        }
    }

    /// Emitters seen directly: emitting facets seen (sampled on the pilot
    /// grid) plus point sources seen (deposited in one pixel each: their
    /// share of the image mean is deposit / pixel count), largest over
    /// bands.
    fn direct_view_share(&self, t: &Tally, deposits: &[Deposit], total_weight: f64) -> f64 {
        let npilot = total_weight.max(1e-300);
        let npix = self.camera.width as f64 * self.camera.height as f64;
        let mut dep = vec![0.0; self.wl.band_names.len()];
        for (_, _, v, _) in deposits {
            dep.iter_mut().zip(v).for_each(|(a, b)| *a += b / npix);
        }
        let (em, tot) = (
            self.wl.integrate(&t.emitted_all),
            self.wl.integrate(&t.all_w),
        );
        (0..dep.len())
            .map(|b| {
                let seen = em[b] / npilot + dep[b];
                let all = tot[b] / npilot + dep[b];
                if all > 0.0 { seen / all } else { 0.0 }
            })
            .fold(0.0, f64::max)
    }
}

/// The pilot's random streams, ray counts and per-pixel memo of which
/// pixels lie beside an emitter.
struct PilotWalk {
    rng: Rng,
    split_rng: Rng,
    c: RayCounts,
    /// Pixels showing a point source ([`Tracer::point_deposits`]).
    seen_points: Vec<(u32, u32)>,
    beside: std::collections::HashMap<(i64, i64), bool>,
}

/// The pilot's sums over its samples, spectral, weighted in pixels.
/// "Plain" samples see no emitter and lie beside none.
struct Tally {
    /// Indirect and total radiance over the plain samples.
    ind: Vec<f64>,
    tot: Vec<f64>,
    /// Indirect and total radiance over every grid sample, unweighted.
    ind_all: Vec<f64>,
    tot_all: Vec<f64>,
    /// Plain grid samples, and each one's (band integrals of each term,
    /// band totals) for the percentiles.
    plain_pixels: u32,
    per_pixel: Vec<(Vec<Vec<f64>>, Vec<f64>)>,
    /// Per term: (sum over plain samples, sum over all samples).
    part_sums: Vec<(Vec<f64>, Vec<f64>)>,
    /// Emitted radiance seen, over all samples.
    emitted_all: Vec<f64>,
    /// One bounce of each term's light, seen from the plain grid samples:
    /// how the interreflection splits among the terms.
    bounce_parts: Vec<Vec<f64>>,
    /// The weighted total over all samples (windows included).
    all_w: Vec<f64>,
}

impl Tally {
    /// Adds a sample's direct light by term (`parts`, irradiance; the
    /// radiance is `reflect` × it) to the terms' sums, and to its own
    /// direct irradiance `e_d` and radiance by term `pix_parts`.
    fn add_parts(
        &mut self,
        parts: &[Vec<f64>],
        reflect: &[f64],
        (w, plain): (f64, bool),
        e_d: &mut [f64],
        pix_parts: &mut [Vec<f64>],
    ) {
        for (k, part) in parts.iter().enumerate() {
            for (s, &r) in reflect.iter().enumerate() {
                let l = r * part[s];
                e_d[s] += part[s];
                pix_parts[k][s] = l;
                self.part_sums[k].1[s] += w * l;
                if plain {
                    self.part_sums[k].0[s] += w * l;
                }
            }
        }
    }

    /// Adds a sample's indirect and total radiance. Interreflection's share
    /// over the plain pixels is weighted like the light terms' (windows at
    /// their pixels' weight): `street-switch-on`'s pool and the pole it
    /// lights hold 3 % of the mean in interreflection, which the grid
    /// never sees.
    fn add_sample(&mut self, (w, on_grid, plain): (f64, bool, bool), ind: &[f64], tot: &[f64]) {
        for s in 0..tot.len() {
            if on_grid {
                self.ind_all[s] += ind[s];
                self.tot_all[s] += tot[s];
            }
            self.all_w[s] += w * tot[s];
            if plain {
                self.ind[s] += w * ind[s];
                self.tot[s] += w * tot[s];
            }
        }
    }

    fn new(nwl: usize) -> Self {
        Self {
            ind: vec![0.0; nwl],
            tot: vec![0.0; nwl],
            ind_all: vec![0.0; nwl],
            tot_all: vec![0.0; nwl],
            plain_pixels: 0,
            per_pixel: Vec::new(),
            part_sums: vec![(vec![0.0; nwl], vec![0.0; nwl]); Term::COUNT],
            emitted_all: vec![0.0; nwl],
            bounce_parts: vec![vec![0.0; nwl]; Term::COUNT],
            all_w: vec![0.0; nwl],
        }
    }
}

impl Tracer {
    /// One bounce of each light term's light towards a camera hit `p`
    /// (normal `n`, facet `f`, reflectance `kd`, transmittance `tau` to
    /// the camera), added to `out[term]`: BOUNCE_SPLIT_RAYS
    /// cosine-weighted rays, each hit's direct light by term
    /// ([`Tracer::irradiance_parts`]) reflected by its Lambertian part.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn bounce_split(
        &self,
        p: DVec3,
        n: DVec3,
        f: u32,
        kd: &[f64],
        tau: &[f64],
        rng: &mut rand_pcg::Pcg64Mcg,
        c: &mut RayCounts,
        out: &mut [Vec<f64>],
    ) {
        use rand::Rng;
        let (tx, ty) = crate::sky_light::orthonormal_basis(n);
        let inv = 1.0 / BOUNCE_SPLIT_RAYS as f64;
        for _ in 0..BOUNCE_SPLIT_RAYS {
            let l = crate::sky_light::cosine_hemisphere([rng.random(), rng.random()]);
            let d = (tx * l.x + ty * l.y + n * l.z).normalize_or_zero();
            let Some((g, front, y, tau_g)) = self.gather_hit(p, d, f, c) else {
                continue;
            };
            let mat = self.mat_of(g);
            if !mat.has_diffuse || (front && self.source_of(g) != u32::MAX) {
                continue;
            }
            let ng = self.normal_of(g);
            let ny = if front { ng } else { -ng };
            let parts = self.irradiance_parts(y, ny, g, rng, c);
            // Cosine-weighted: E ≈ π · mean L, L = k_d E_hit / π.
            for (k, part) in parts.iter().enumerate() {
                for s in 0..out[k].len() {
                    let t = tau_g.as_ref().map_or(1.0, |t| t[s]);
                    out[k][s] += inv
                        * kd[s]
                        * tau[s]
                        * t
                        * mat.kd[s]
                        * std::f64::consts::FRAC_1_PI
                        * part[s];
                }
            }
        }
    }

    /// The pilot's sample points `(x, y, weight in pixels, on the grid)`:
    /// the uniform grid, plus a window of pixels around each point source's
    /// image, each pixel sub-sampled [`WINDOW_SUB`]² times. A luminaire's
    /// housing sits centimetres from its source and shines ~10⁴× brighter
    /// than the street it lights, in a few pixels the grid hits once or
    /// never (on `street-switch-on` at quarter resolution two such pixels
    /// held 90 % of the lamps' share of the mean): a stratum of its own
    /// finds them at a known weight. The grid's samples inside a window
    /// are left out, the rest stand for the pixels outside every window.
    pub(super) fn pilot_samples(&self, cols: u32, rows: u32) -> Vec<(f64, f64, f64, bool)> {
        let mut c = RayCounts::default();
        let cam = &self.camera;
        let (w, h) = (cam.width as usize, cam.height as usize);
        let mut window = vec![false; w * h];
        // Per window pixel: the sources whose window holds it.
        let mut holders: Vec<Vec<DVec3>> = vec![Vec::new(); w * h];
        let mut budget = (cols * rows) as usize;
        let (_, _, fwd) = cam.basis();
        // The angle one pixel spans at the image's centre.
        let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
        let pixel_rad = cam
            .pixel_direction(cx, cy)
            .angle_between(cam.pixel_direction(cx + 1.0, cy))
            .max(1e-12);
        for l in &self.points {
            let Some((px, py)) = cam.project(l.pos) else {
                continue;
            };
            let dist = (l.pos - cam.position).dot(fwd);
            if dist <= 0.0 {
                continue;
            }
            let r = self.window_radius_px(l, dist, pixel_rad, &mut c);
            let (c0, r0) = (px.floor() as i64, py.floor() as i64);
            for yy in (r0 - r).max(0)..=(r0 + r).min(h as i64 - 1) {
                for xx in (c0 - r).max(0)..=(c0 + r).min(w as i64 - 1) {
                    let k = yy as usize * w + xx as usize;
                    if !window[k] && budget > 0 {
                        window[k] = true;
                        budget -= 1;
                    }
                    if window[k] && holders[k].len() < WINDOW_MAX_HOLDERS {
                        holders[k].push(l.pos);
                    }
                }
            }
        }
        // Each window pixel: at least WINDOW_SUB² points, more along a
        // side whose footprint is long against the height of its sources
        // above the surface it shows (a point source's pool varies on that
        // scale): at most WINDOW_SUB_MAX² points, and refined only while
        // WINDOW_POINTS_MAX are not spent (every window pixel keeps its
        // WINDOW_SUB²). The pool 205 m down `street-switch-on`'s road is a sliver of
        // one pixel row at grazing view, 380 m of road per pixel: 2 × 2
        // points put its lamps at 3.7 % of the mean where 82 % was
        // measured.
        let mut win = Vec::new();
        let mut windowed = 0.0;
        let mut points_left = WINDOW_POINTS_MAX;
        for (k, _) in window.iter().enumerate().filter(|(_, b)| **b) {
            let (xx, yy) = ((k % w) as f64, (k / w) as f64);
            let (nx, ny) = self.window_sub(xx, yy, &holders[k], points_left, &mut c);
            points_left = points_left.saturating_sub(nx * ny);
            let n = (nx * ny) as f64;
            for s in 0..nx * ny {
                let dx = ((s % nx) as f64 + 0.5) / nx as f64;
                let dy = ((s / nx) as f64 + 0.5) / ny as f64;
                win.push((xx + dx, yy + dy, 1.0 / n, false));
            }
            windowed += 1.0;
        }
        let mut grid = Vec::new();
        for j in 0..rows {
            for i in 0..cols {
                let x = (i as f64 + 0.5) * cam.width as f64 / cols as f64;
                let y = (j as f64 + 0.5) * cam.height as f64 / rows as f64;
                let k = (y as usize).min(h.saturating_sub(1)) * w
                    + (x as usize).min(w.saturating_sub(1));
                grid.push((x, y, !window.get(k).copied().unwrap_or(false)));
            }
        }
        // The grid first: it draws the random numbers it drew before.
        // Grid points inside a window keep their place (the
        // interreflection share is the whole grid's) at weight 0.
        let outside = grid.iter().filter(|g| g.2).count();
        let gw = ((w * h) as f64 - windowed) / outside.max(1) as f64;
        let mut out: Vec<_> = grid
            .into_iter()
            .map(|(x, y, out)| (x, y, if out { gw } else { 0.0 }, true))
            .collect();
        out.extend(win);
        out
    }

    /// The half-width in pixels of a point source's pilot window, seen
    /// `dist` ahead of the camera with `pixel_rad` a pixel: the pool a
    /// source lights brightest lies about as far from it as the surface in
    /// its brightest direction (of the 26 of a 3 × 3 × 3 lattice) — a road
    /// lamp's pool 205 m away is a couple of pixels under its image, not
    /// at it — and at least [`WINDOW_RADIUS_M`].
    fn window_radius_px(
        &self,
        l: &crate::lights::PointLight,
        dist: f64,
        pixel_rad: f64,
        c: &mut RayCounts,
    ) -> i64 {
        let mut best = (0.0, 0.0);
        for k in 0..27 {
            let v = DVec3::new(
                (k % 3) as f64 - 1.0,
                ((k / 3) % 3) as f64 - 1.0,
                (k / 9) as f64 - 1.0,
            );
            if k == 13 {
                continue;
            }
            let w = v.normalize();
            let shape = l.shape_toward(w);
            if shape > best.0
                && let Some((_, _, p, _)) = self.gather_hit(l.pos, w, u32::MAX, c)
            {
                best = (shape, (p - l.pos).length());
            }
        }
        let reach = f64::max(best.1, WINDOW_RADIUS_M);
        ((reach / dist).atan() / pixel_rad)
            .ceil()
            .clamp(1.0, WINDOW_MAX_PX as f64) as i64
    }
}

/// Pilot windows around point sources: the least radius (scene metres at
/// the source; a luminaire's housing), the most pixels either side, the
/// least and most sub-samples per pixel side, the points past which no
/// window pixel is refined, and the most sources a pixel's refinement
/// looks at.
const WINDOW_RADIUS_M: f64 = 0.5;
const WINDOW_MAX_PX: u32 = 8;
const WINDOW_SUB: usize = 2;
const WINDOW_SUB_MAX: usize = 64;
const WINDOW_POINTS_MAX: usize = 1 << 16;
const WINDOW_MAX_HOLDERS: usize = 8;

/// Rays per plain grid pixel that split the pilot's interreflection by
/// light term.
const BOUNCE_SPLIT_RAYS: usize = 4;

impl Tracer {
    /// Sub-samples `(across, down)` for window pixel `(x, y)` (its
    /// top-left corner): per side, the footprint's length (between the
    /// surface points its corners show; unbounded when one corner shows
    /// a surface and its neighbour none) over half the least height of
    /// `sources` above those surfaces' planes, between WINDOW_SUB and
    /// WINDOW_SUB_MAX, within `left` points.
    pub(super) fn window_sub(
        &self,
        x: f64,
        y: f64,
        sources: &[DVec3],
        left: usize,
        c: &mut RayCounts,
    ) -> (usize, usize) {
        let cam = &self.camera;
        let base = (WINDOW_SUB, WINDOW_SUB);
        if left < WINDOW_SUB * WINDOW_SUB * 4 {
            return base;
        }
        let corner = |dx: f64, dy: f64, c: &mut RayCounts| {
            let d = cam.pixel_direction(x + dx, y + dy);
            self.gather_hit(cam.position, d, u32::MAX, c)
                .map(|(f, _, p, _)| (p, self.normal_of(f)))
        };
        let q = [
            corner(0.0, 0.0, c),
            corner(1.0, 0.0, c),
            corner(0.0, 1.0, c),
            corner(1.0, 1.0, c),
        ];
        let mut height = f64::INFINITY;
        for (p, n) in q.iter().flatten() {
            for s in sources {
                height = height.min(n.dot(*s - *p).abs());
            }
        }
        if !height.is_finite() {
            return base;
        }
        let scale = 0.5 * height.max(1e-9);
        let steps = |a: &Option<(DVec3, DVec3)>, b: &Option<(DVec3, DVec3)>| -> usize {
            let len = match (a, b) {
                (Some((p, _)), Some((q, _))) => (*p - *q).length(),
                (None, None) => 0.0,
                _ => f64::INFINITY,
            };
            (len / scale)
                .ceil()
                .clamp(WINDOW_SUB as f64, WINDOW_SUB_MAX as f64) as usize
        };
        // The thin-facet scan (WINDOW_SUB_MAX rays) only where the
        // footprint has not already asked for the most.
        let finer = |n: usize, across: bool, c: &mut RayCounts| {
            if n < WINDOW_SUB_MAX {
                n.max(self.thin_run_sub(x, y, across, c))
            } else {
                n
            }
        };
        let across = finer(steps(&q[0], &q[1]).max(steps(&q[2], &q[3])), true, c);
        let down = finer(steps(&q[0], &q[2]).max(steps(&q[1], &q[3])), false, c);
        // Within what is left: shrink the longer side first.
        let (mut nx, mut ny) = (across, down);
        while nx * ny > left && (nx > WINDOW_SUB || ny > WINDOW_SUB) {
            if nx >= ny {
                nx = (nx / 2).max(WINDOW_SUB)
            } else {
                ny = (ny / 2).max(WINDOW_SUB)
            }
        }
        (nx, ny)
    }

    /// Sub-samples along one side of window pixel `(x, y)` that give its
    /// thinnest facet two of them: WINDOW_SUB_MAX rays along the pixel's
    /// middle row (`across`) or column find the shortest run of one
    /// facet. A thing thinner than the footprint's scale — the lamp's pole
    /// on `street-switch-on` at quarter size, 0.08 pixel wide and lit only
    /// by the pool at its foot — fell between the sub-samples, and the
    /// pilot put interreflection at 0.01 % of the signal where renders
    /// measure a few per cent.
    fn thin_run_sub(&self, x: f64, y: f64, across: bool, c: &mut RayCounts) -> usize {
        let cam = &self.camera;
        let n = WINDOW_SUB_MAX;
        let mut shortest = n;
        let (mut run, mut last) = (0usize, None);
        for k in 0..=n {
            let id = (k < n).then(|| {
                let t = (k as f64 + 0.5) / n as f64;
                let (dx, dy) = if across { (t, 0.5) } else { (0.5, t) };
                let d = cam.pixel_direction(x + dx, y + dy);
                self.gather_hit(cam.position, d, u32::MAX, c).map(|h| h.0)
            });
            if k > 0 && id != last {
                // Only runs of a facet count: the sky has no thickness.
                if let Some(Some(_)) = last {
                    shortest = shortest.min(run);
                }
                run = 0;
            }
            run += 1;
            last = id;
        }
        (2 * n)
            .div_ceil(shortest.max(1))
            .clamp(WINDOW_SUB, WINDOW_SUB_MAX)
    }
}

/// The 90th percentile over pixels of term `k`'s share of the pixel,
/// `part / max(pixel, 5 % of the mean pixel)` (largest over bands).
pub(super) fn term_p90(pixels: &[(Vec<Vec<f64>>, Vec<f64>)], k: usize) -> f64 {
    let Some(first) = pixels.first() else {
        return 0.0;
    };
    (0..first.1.len())
        .map(|b| {
            let mean = pixels.iter().map(|p| p.1[b]).sum::<f64>() / pixels.len() as f64;
            let floor = (0.05 * mean).max(1e-300);
            let mut v: Vec<f64> = pixels
                .iter()
                .map(|p| p.0[k][b] / p.1[b].max(floor))
                .collect();
            let i = ((v.len() - 1) as f64 * 0.9).round() as usize;
            *v.select_nth_unstable_by(i, f64::total_cmp).1
        })
        .fold(0.0, f64::max)
}
