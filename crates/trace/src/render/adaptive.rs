//! Sampling the image: a first round over every pixel of the region, tile
//! by tile, then — with a target error — rounds of more samples where a
//! pixel's stated error is still above the target (adaptive stopping).
//! What comes out is the pixels' estimates; `film.rs` develops them.

use std::sync::atomic::AtomicBool;

use super::*;

/// Most adaptive rounds after the first: a bound on the loop (the caps
/// and the target end it long before, in practice).
const MAX_ROUNDS: u32 = 64;

/// The rows a render covers, checked against the image.
pub(super) struct Region {
    pub(super) rows: std::ops::Range<u32>,
    pub(super) w: u32,
    pub(super) h: u32,
    /// A tile (not the whole image): no cache-bias statement, no target.
    pub(super) partial: bool,
}

impl Region {
    pub(super) fn row0(&self) -> u32 {
        self.rows.start
    }

    pub(super) fn pixels(&self) -> usize {
        self.w as usize * self.h as usize
    }
}

/// A stop request, polled by every tile and round; once seen it stays.
pub(super) struct Halt<'a> {
    stopped: AtomicBool,
    stop: &'a (dyn Fn() -> bool + Sync),
}

impl<'a> Halt<'a> {
    pub(super) fn new(stop: &'a (dyn Fn() -> bool + Sync)) -> Self {
        Self {
            stopped: AtomicBool::new(false),
            stop,
        }
    }

    /// Whether to stop now (asks the caller's `stop`).
    pub(super) fn now(&self) -> bool {
        if self.stopped.load(Ordering::Relaxed) || (self.stop)() {
            self.stopped.store(true, Ordering::Relaxed);
            return true;
        }
        false
    }

    /// Whether a stop was seen.
    pub(super) fn stopped(&self) -> bool {
        self.stopped.load(Ordering::Relaxed)
    }
}

/// A per-pixel bound on the render's standard error in one band, set from
/// the first round's estimate: a camera's own temporal noise at each pixel
/// for `--target-error camera` (gloam-pipeline's `camera_goal.rs`), so
/// each pixel is rendered only as well as the camera can see.
pub trait PixelGoal: Sync {
    /// The band the bounds are for.
    fn band(&self) -> usize;
    /// Per pixel of the image (row-major), the largest standard error of
    /// [`PixelGoal::band`] the render may keep, from that band's image
    /// so far (asked after each round); or why no bound can be set.
    fn bounds(&self, first_round: ndarray::ArrayView2<f64>) -> Result<Vec<f64>, String>;
    /// In a layered render (light groups, `layers.rs`): the bounds on the
    /// whole image's standard error from the whole image of the band and
    /// each group's image of it (in the groups' order) — a sequence mixes
    /// the groups with other weights in each frame. By default the
    /// whole's [`PixelGoal::bounds`].
    fn bounds_layered(
        &self,
        whole: ndarray::ArrayView2<f64>,
        groups: &[ndarray::ArrayView2<f64>],
    ) -> Result<Vec<f64>, String> {
        let _ = groups;
        self.bounds(whole)
    }
}

/// The pixels' estimates, in row-major order over the region, with the
/// emitters each pixel sees directly (computed apart), rays and rounds.
pub(super) struct Samples {
    /// Whether each batch was split into two replicates (adaptive renders:
    /// their error is measured from the replicates' difference).
    pub(super) replicated: bool,
    pub(super) ests: Vec<PixelEstimate>,
    pub(super) views: Vec<Option<ViewTerm>>,
    pub(super) rays: RayCounts,
    pub(super) rounds: u32,
}

impl Tracer {
    /// The most samples a pixel takes: `max_spp`, or `spp` if more.
    pub(super) fn spp_cap(&self) -> u32 {
        self.settings.max_spp.max(self.settings.spp.max(1))
    }

    /// The rows `rows` as a region to render, or why not.
    pub(super) fn region(
        &self,
        rows: std::ops::Range<u32>,
        goal: bool,
    ) -> Result<Region, TraceError> {
        let (w, full_h) = (self.camera.width, self.camera.height);
        if rows.start >= rows.end || rows.end > full_h {
            return Err(TraceError::BadInput(format!(
                "rows {}..{} are not a non-empty part of the image's 0..{full_h}",
                rows.start, rows.end
            )));
        }
        let partial = rows.start != 0 || rows.end != full_h;
        if partial && (self.settings.target_error.is_some() || goal) {
            return Err(TraceError::BadInput(
                "target_error needs the whole image (its dark-pixel floor is relative to the image mean); render a tile at a fixed spp".into(),
            ));
        }
        let h = rows.end - rows.start;
        Ok(Region {
            rows,
            w,
            h,
            partial,
        })
    }

    /// Every pixel of `region` sampled: `spp` each, then adaptive rounds
    /// to the per-pixel `goal`, or to the image's target error when one is
    /// set. Runs in the caller's thread pool.
    pub(super) fn sample_image(
        &self,
        region: &Region,
        groups: usize,
        goal: Option<&dyn PixelGoal>,
        progress: &(dyn Fn(u64, u64) + Sync),
        halt: &Halt,
    ) -> Result<Samples, TraceError> {
        let replicated = goal.is_some() || self.settings.target_error.is_some();
        let mut samples = self.first_round(region, groups, replicated, progress, halt);
        if let Some(goal) = goal {
            self.goal_rounds(&mut samples, region, goal, progress, halt)?;
        } else if let Some(target) = self.settings.target_error {
            self.adaptive_rounds(&mut samples, region, target, progress, halt);
        }
        Ok(samples)
    }

    /// Round 0: every pixel, one batch of spp, tile by tile.
    fn first_round(
        &self,
        region: &Region,
        groups: usize,
        replicated: bool,
        progress: &(dyn Fn(u64, u64) + Sync),
        halt: &Halt,
    ) -> Samples {
        let (w, row0) = (region.w, region.row0());
        let (nb, nwl) = (self.wl.band_names.len(), self.wl.len());
        let spp = self.settings.spp.max(1) as usize;
        // Adaptive renders sample in two replicates, so their error
        // estimate is measured rather than assumed (see `stratification`).
        let tiles: Vec<(u32, u32)> = (0..region.h.div_ceil(TILE))
            .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, row0 + ty * TILE)))
            .collect();
        let total = tiles.len() as u64;
        let done = AtomicU64::new(0);
        type Pixel = (usize, PixelEstimate, Option<ViewTerm>);
        let res: Vec<(Vec<Pixel>, RayCounts)> = tiles
            .par_iter()
            .map(|&(x0, y0)| {
                if halt.now() {
                    return (Vec::new(), RayCounts::default());
                }
                let x1 = (x0 + TILE).min(w);
                let y1 = (y0 + TILE).min(region.rows.end);
                let mut c = RayCounts::default();
                let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
                for row in y0..y1 {
                    if row > y0 && halt.now() {
                        break;
                    }
                    for col in x0..x1 {
                        let mut e = PixelEstimate::new(nwl, nb, groups);
                        // Emitters seen directly: computed apart, and
                        // whether the pixel sees one decided by them,
                        // not by its samples (`direct_view.rs`).
                        let view = self.view_term(col, row, &mut c);
                        e.sees_emitter = view
                            .as_ref()
                            .is_some_and(|v| v.bands.iter().any(|&x| x > 0.0));
                        self.pixel_batch(col, row, 0, spp, replicated, &mut e, &mut c);
                        out.push(((row - row0) as usize * w as usize + col as usize, e, view));
                    }
                }
                let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(n, total);
                (out, c)
            })
            .collect();
        let npix = region.pixels();
        let mut rays = RayCounts::default();
        let mut ests: Vec<Option<PixelEstimate>> = vec![None; npix];
        let mut views: Vec<Option<ViewTerm>> = (0..npix).map(|_| None).collect();
        for (tile, c) in res {
            rays.add(&c);
            for (i, e, v) in tile {
                ests[i] = Some(e);
                views[i] = v;
            }
        }
        let ests = ests
            .into_iter()
            .map(|e| e.unwrap_or_else(|| PixelEstimate::new(nwl, nb, groups)))
            .collect();
        Samples {
            replicated,
            ests,
            views,
            rays,
            rounds: 1,
        }
    }

    /// Rounds of more samples where the stated relative error is above
    /// `target`, each pixel up to its cap, until none is or [`MAX_ROUNDS`].
    fn adaptive_rounds(
        &self,
        s: &mut Samples,
        region: &Region,
        target: f64,
        progress: &(dyn Fn(u64, u64) + Sync),
        halt: &Halt,
    ) {
        let w = region.w as usize;
        let nb = self.wl.band_names.len();
        let floor = band_floor(&s.ests, &s.views, nb);
        let cap = self.spp_cap();
        let decay = variance_decay(self.settings.pixel_strata);
        while s.rounds <= MAX_ROUNDS && !halt.now() {
            let (factor, _) = stratification(&s.ests, &floor);
            let stated = stated_std_errors(&s.ests, w, &factor, &floor, true);
            let rel: Vec<f64> = s
                .ests
                .par_iter()
                .enumerate()
                .map(|(i, e)| stated_rel_error(e, &stated[i * nb..(i + 1) * nb], &floor))
                .collect();
            let work = allocate(&s.ests, &rel, target, cap, decay);
            if work.is_empty() {
                break;
            }
            self.run_round(s, region, &work, progress);
        }
    }

    /// One round: `(pixel, samples to add)` for each pixel in `work`, as
    /// batch number `s.rounds` (each batch its own random streams).
    fn run_round(
        &self,
        s: &mut Samples,
        region: &Region,
        work: &[(usize, u32)],
        progress: &(dyn Fn(u64, u64) + Sync),
    ) {
        let (w, row0) = (region.w as usize, region.row0());
        let total = work.len() as u64;
        let done = AtomicU64::new(0);
        let batch = s.rounds;
        let ests = &s.ests;
        let updated: Vec<(usize, PixelEstimate, RayCounts)> = work
            .par_iter()
            .map(|&(i, add)| {
                let mut c = RayCounts::default();
                let mut e = ests[i].clone();
                let (col, row) = ((i % w) as u32, row0 + (i / w) as u32);
                self.pixel_batch(col, row, batch, add as usize, true, &mut e, &mut c);
                let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                if n % 1024 == 0 || n == total {
                    progress(n, total);
                }
                (i, e, c)
            })
            .collect();
        for (i, e, c) in updated {
            s.ests[i] = e;
            s.rays.add(&c);
        }
        s.rounds += 1;
    }

    /// The goal's per-pixel bounds from the image of its band so far (the
    /// emitters seen directly included, as in the image), checked.
    fn goal_bounds(
        &self,
        s: &Samples,
        region: &Region,
        goal: &dyn PixelGoal,
    ) -> Result<Vec<f64>, TraceError> {
        let band = goal.band();
        if band >= self.wl.band_names.len() {
            return Err(TraceError::BadInput(format!(
                "the per-pixel error goal is for band {band}; the render has {}",
                self.wl.band_names.len()
            )));
        }
        let image: Vec<f64> = s
            .ests
            .iter()
            .zip(&s.views)
            .map(|(e, v)| e.mean(band) + v.as_ref().map_or(0.0, |v| v.bands[band]))
            .collect();
        let shape = (region.h as usize, region.w as usize);
        let shaped = |v: &[f64]| {
            ndarray::Array2::from_shape_vec(shape, v.to_vec())
                .map_err(|e| TraceError::BadInput(format!("per-pixel error goal: {e}")))
        };
        let whole = shaped(&image)?;
        let groups = s.ests.first().map_or(0, |e| e.groups);
        let bounds = if groups == 0 {
            goal.bounds(whole.view())
        } else {
            // Each group's image as `develop_layer` develops it: its part
            // of the samples and of the emitters seen directly.
            let layers = (0..groups)
                .map(|g| {
                    let img: Vec<f64> = (s.ests.iter().zip(&s.views))
                        .map(|(e, v)| {
                            let view = v.as_ref().and_then(|t| t.light.part(g));
                            e.layer(g, band).0 + view.map_or(0.0, |p| self.wl.integrate(p)[band])
                        })
                        .collect();
                    shaped(&img)
                })
                .collect::<Result<Vec<_>, _>>()?;
            let views: Vec<_> = layers.iter().map(|l| l.view()).collect();
            goal.bounds_layered(whole.view(), &views)
        }
        .map_err(TraceError::BadInput)?;
        if bounds.len() != image.len() {
            return Err(TraceError::BadInput(format!(
                "the per-pixel error goal gave {} bounds for {} pixels",
                bounds.len(),
                image.len()
            )));
        }
        Ok(bounds)
    }

    /// Rounds of more samples for the pixels whose stated standard error in
    /// the goal's band is above their bound — the bounds set again each
    /// round from the estimate so far, so a first round that overshot a
    /// pixel does not leave it with a loose bound: each grows to
    /// `n (σ/τ)²` (at most 4× per round, at least the first round's spp
    /// up to [`MIN_ADAPTIVE_SPP`], never past its cap), until every pixel
    /// is within its bound or capped. Pixels that see an emitter's face are
    /// held to their bound too (unlike under a target error, whose metric
    /// leaves them out): the camera sees their error.
    fn goal_rounds(
        &self,
        s: &mut Samples,
        region: &Region,
        goal: &dyn PixelGoal,
        progress: &(dyn Fn(u64, u64) + Sync),
        halt: &Halt,
    ) -> Result<(), TraceError> {
        let band = goal.band();
        let nb = self.wl.band_names.len();
        let floor = band_floor(&s.ests, &s.views, nb);
        let cap = self.spp_cap();
        // A bound loose against the pixel's error needs no more than the
        // first round (`spp`, at least one sample per replicate): a camera
        // whose frame is mostly its own noise asks little of the render.
        let min = self.settings.spp.clamp(2, MIN_ADAPTIVE_SPP).min(cap);
        while s.rounds <= MAX_ROUNDS && !halt.now() {
            let bounds = self.goal_bounds(s, region, goal)?;
            let (factor, _) = stratification(&s.ests, &floor);
            let stated = stated_std_errors(&s.ests, region.w as usize, &factor, &floor, true);
            let work: Vec<(usize, u32)> = s
                .ests
                .iter()
                .enumerate()
                .filter_map(|(i, e)| {
                    let (sigma, tau) = (stated[i * nb + band], bounds[i]);
                    let n = e.n.max(1) as f64;
                    let want = if sigma <= tau || tau.is_nan() {
                        0.0
                    } else if tau > 0.0 {
                        n * (sigma / tau).powi(2)
                    } else {
                        f64::INFINITY
                    };
                    let cap = pixel_cap(e, cap);
                    let goal = want.ceil().min(4.0 * n).max(min as f64).min(cap as f64);
                    let add = even_add(e.n, goal as u32, cap);
                    (add > 0).then_some((i, add))
                })
                .collect();
            if work.is_empty() {
                break;
            }
            self.run_round(s, region, &work, progress);
        }
        Ok(())
    }
}
