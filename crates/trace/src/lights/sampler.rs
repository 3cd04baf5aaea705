//! Which lights a shading point evaluates, and with what weight: the
//! [`LightSampler`] (pbrt's `LightSampler`, in gloam's two kinds).
//!
//! Every shading point evaluates the lights no tree picks — the point
//! sources of a scene without a light tree, the Moon, the sky dome, and
//! the area sources unless the tree picks them — each with weight 1
//! ([`LightSampler::every`]). When a scene has more emitters than
//! `light_tree_min_lights`, the light tree picks among its area and point
//! sources, each pick weighted by its 1/pmf ([`LightSampler::pick`]).

use glam::DVec3;
use rand_pcg::Pcg64Mcg;

use super::{AreaSet, AreaSource, LightSource};
use crate::lights::tree::{LightRef, LightTree};
use crate::tracer::Tracer;

/// The lights of one prepared scene, as a shading point meets them.
pub(crate) struct LightSampler<'a> {
    tracer: &'a Tracer,
    tree: Option<&'a LightTree>,
}

impl<'a> LightSampler<'a> {
    pub(crate) fn new(tracer: &'a Tracer) -> Self {
        Self {
            tracer,
            tree: tracer.light_tree.as_ref(),
        }
    }

    /// The light tree, when the scene has one: then [`LightSampler::pick`]
    /// adds its picks to [`LightSampler::every`]'s lights.
    pub(crate) fn tree(&self) -> Option<&'a LightTree> {
        self.tree
    }

    /// The lights every shading point evaluates, each with weight 1, in
    /// the order their random numbers are drawn: the point sources (none
    /// with a tree: it picks them), the Moon and the sky dome (with a
    /// sky), the distant sources, the area sources (unless the tree picks
    /// them).
    pub(crate) fn every(&self) -> impl Iterator<Item = (LightSource<'a>, f64)> + use<'a> {
        let t = self.tracer;
        let points: &'a [super::PointLight] = if self.tree.is_some() { &[] } else { &t.points };
        let sky = t.sky.as_ref();
        let area_in_tree = self.tree.is_some_and(|tree| tree.has_area);
        let area_empty = t.area.is_empty() && !t.settings.all_effects;
        (points.iter().map(LightSource::Point))
            .chain(sky.map(LightSource::Moon))
            .chain(sky.map(LightSource::Dome))
            .chain(t.distant.iter().map(LightSource::Distant))
            .chain(sky.and_then(|s| s.sun.as_ref()).map(LightSource::Distant))
            .chain(
                sky.and_then(super::SkyState::twilight_dome)
                    .map(LightSource::Twilight),
            )
            .chain((!area_in_tree && !area_empty).then_some(LightSource::Area(AreaSet::Every)))
            .map(|l| (l, 1.0))
    }

    /// One selection of the light tree at `p` (normal `n`, at most
    /// `branches` picks): each picked point source with its 1/pmf, in pick
    /// order, then the picked area sources as one set (weight 1: each pick
    /// carries its own 1/pmf, and the `analytic` estimator shares their
    /// closed-form total and clamps their sum). Draws the tree's random
    /// numbers; empty without a tree.
    pub(crate) fn pick(
        &self,
        p: DVec3,
        n: DVec3,
        branches: usize,
        rng: &mut Pcg64Mcg,
    ) -> Vec<(LightSource<'a>, f64)> {
        let Some(tree) = self.tree else {
            return Vec::new();
        };
        let t = self.tracer;
        let mut picks = Vec::new();
        tree.select_in(p, n, branches, rng, &mut picks);
        let mut out = Vec::with_capacity(picks.len() + 1);
        let mut area: Vec<(&'a AreaSource, f64)> = Vec::new();
        for (l, w) in picks {
            match l {
                LightRef::Area(i) => area.push((&t.area[i as usize], w)),
                LightRef::Point(i) => out.push((LightSource::Point(&t.points[i as usize]), w)),
            }
        }
        if !area.is_empty() {
            out.push((LightSource::Area(AreaSet::Picked(area)), 1.0));
        }
        out
    }
}
