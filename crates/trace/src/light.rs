//! Spectral light as a path sums it: the whole, and — for light layers
//! (`gloam render --layers`, `layers.rs`) — each light group's part beside
//! it, in one pass.
//!
//! Every term a path adds comes from one emitter: a light sample, an
//! emitter or the sky seen along a ray, the cached interreflection of one
//! group's light. [`Light::add_from`] adds it to the whole exactly as a
//! render without layers does and once more to its group's part; what is
//! applied afterwards (throughput, reflectance, `1/π`) is linear and
//! applied to every part alike ([`Light::add_each`]). So the whole is
//! bit-identical to an unlayered render's, and the parts sum to it up to
//! floating-point summation order. The one non-linear step, the analytic
//! estimator's clamp of a negative penumbra sum, is taken on the whole and
//! passed on to the parts ([`Light::add_clamped`]).
//!
//! Without layers a `Light` is its `whole` and nothing else: one branch per
//! term, no other work.

/// Spectral light (one value per wavelength slot), whole and by group.
#[derive(Clone, Debug)]
pub(crate) struct Light {
    /// The light of every emitter.
    pub(crate) whole: Vec<f64>,
    /// One per light group (none without layers): that group's part, an
    /// empty vector until the group adds light — a vertex usually sees a
    /// few groups, not all.
    parts: Vec<Vec<f64>>,
}

impl Light {
    /// No light over `slots` wavelength slots, split over `groups` light
    /// groups (0: the whole only).
    pub(crate) fn dark(slots: usize, groups: usize) -> Self {
        Self {
            whole: vec![0.0; slots],
            parts: vec![Vec::new(); groups],
        }
    }

    /// No light, with `self`'s slots and groups.
    pub(crate) fn dark_like(&self) -> Self {
        Self::dark(self.whole.len(), self.parts.len())
    }

    /// Wavelength slots.
    pub(crate) fn len(&self) -> usize {
        self.whole.len()
    }

    /// Light groups it is split over (0: not split).
    pub(crate) fn groups(&self) -> usize {
        self.parts.len()
    }

    /// Back to no light, keeping the allocations.
    pub(crate) fn clear(&mut self) {
        self.whole.iter_mut().for_each(|x| *x = 0.0);
        self.parts
            .iter_mut()
            .for_each(|p| p.iter_mut().for_each(|x| *x = 0.0));
    }

    /// Group `g`'s part, `None` while the group has added nothing.
    pub(crate) fn part(&self, g: usize) -> Option<&[f64]> {
        self.parts.get(g).filter(|p| !p.is_empty()).map(|p| &p[..])
    }

    /// Group `g`'s part to add to (allocated on first use); `None` when the
    /// light is not split into that many groups.
    pub(crate) fn part_mut(&mut self, g: usize) -> Option<&mut [f64]> {
        let n = self.whole.len();
        let p = self.parts.get_mut(g)?;
        if p.is_empty() {
            p.resize(n, 0.0);
        }
        Some(&mut p[..])
    }

    /// Adds a term that comes from an emitter of `group` (`None`: a term
    /// of no group, which must be zero for the parts to sum to the whole):
    /// `add` adds it to a spectral vector, and is applied to the whole
    /// and to that group's part alike.
    pub(crate) fn add_from(&mut self, group: Option<usize>, mut add: impl FnMut(&mut [f64])) {
        add(&mut self.whole);
        if let Some(p) = group.and_then(|g| self.part_mut(g)) {
            add(p);
        }
    }

    /// `add(own, other's)` for the whole and for every group `src` holds
    /// light of: a linear map of `src` (throughput, reflectance) added to
    /// `self` part by part. Groups beyond `self`'s are dropped (a split
    /// term added to an unsplit light).
    pub(crate) fn add_each(&mut self, src: &Light, mut add: impl FnMut(&mut [f64], &[f64])) {
        add(&mut self.whole, &src.whole);
        for (g, s) in src.parts.iter().enumerate() {
            if s.is_empty() {
                continue;
            }
            if let Some(d) = self.part_mut(g) {
                add(d, s);
            }
        }
    }

    /// Adds the area sources' sum `area` at one shading point, clamped at 0
    /// per slot (the control variate can undershoot in deep penumbra; see
    /// `Tracer::analytic`). The whole is clamped as it always was; the
    /// parts follow it: where no part is negative they are added as they
    /// are (they sum to the unclamped whole, which is then ≥ 0), elsewhere
    /// each part's positive side is scaled by `max(whole, 0) / Σ positive
    /// sides` — never negative, summing to the clamped whole, and 0 in
    /// every part where the whole clamps to 0.
    pub(crate) fn add_clamped(&mut self, area: &Light) {
        self.whole
            .iter_mut()
            .zip(&area.whole)
            .for_each(|(o, a)| *o += a.max(0.0));
        let held: Vec<usize> = (0..area.parts.len())
            .filter(|&g| area.part(g).is_some())
            .collect();
        if held.is_empty() {
            return;
        }
        for &g in &held {
            self.part_mut(g);
        }
        for s in 0..area.whole.len() {
            let negative = held.iter().any(|&g| area.parts[g][s] < 0.0);
            let k = if negative {
                let positive: f64 = held.iter().map(|&g| area.parts[g][s].max(0.0)).sum();
                if positive > 0.0 {
                    area.whole[s].max(0.0) / positive
                } else {
                    0.0
                }
            } else {
                1.0
            };
            for &g in &held {
                if let Some(d) = self.parts.get_mut(g).filter(|d| !d.is_empty()) {
                    let a = area.parts[g][s];
                    d[s] += if negative { a.max(0.0) * k } else { a };
                }
            }
        }
    }

    /// `f` applied to the whole and to every part that holds light (a
    /// scaling, say).
    pub(crate) fn each_mut(&mut self, mut f: impl FnMut(&mut [f64])) {
        f(&mut self.whole);
        self.parts
            .iter_mut()
            .filter(|p| !p.is_empty())
            .for_each(|p| f(p));
    }

    /// The whole, unsplit.
    pub(crate) fn into_whole(self) -> Vec<f64> {
        self.whole
    }
}

#[cfg(test)]
mod tests {
    use super::Light;

    #[test]
    fn terms_land_in_the_whole_and_in_their_group() {
        let mut l = Light::dark(3, 2);
        l.add_from(Some(1), |o| o.iter_mut().for_each(|x| *x += 2.0));
        l.add_from(None, |o| o[0] += 0.0);
        assert_eq!(l.whole, [2.0, 2.0, 2.0]);
        assert_eq!(l.part(0), None);
        assert_eq!(l.part(1), Some(&[2.0, 2.0, 2.0][..]));
        // A linear map applies to each part alike.
        let mut m = Light::dark(3, 2);
        m.add_each(&l, |o, s| {
            o.iter_mut().zip(s).for_each(|(o, s)| *o += 0.5 * s)
        });
        assert_eq!(m.whole, [1.0; 3]);
        assert_eq!(m.part(1), Some(&[1.0; 3][..]));
        assert_eq!(m.part(0), None);
    }

    /// Parts (3, −1) sum to 2: the whole keeps 2, the parts become (2, 0);
    /// parts (1, −2) sum to −1: everything 0; parts (1, 2): unchanged.
    #[test]
    fn the_clamp_is_the_wholes_and_the_parts_follow_it() {
        let mut area = Light::dark(3, 2);
        for (g, v) in [(0, [3.0, 1.0, 1.0]), (1, [-1.0, -2.0, 2.0])] {
            area.add_from(Some(g), |o| o.iter_mut().zip(v).for_each(|(o, v)| *o += v));
        }
        let mut out = Light::dark(3, 2);
        out.add_clamped(&area);
        assert_eq!(out.whole, [2.0, 0.0, 3.0]);
        assert_eq!(out.part(0), Some(&[2.0, 0.0, 1.0][..]));
        assert_eq!(out.part(1), Some(&[0.0, 0.0, 2.0][..]));
        // One group: its part is the whole, bit for bit.
        let mut one = Light::dark(1, 1);
        one.add_from(Some(0), |o| o[0] += 0.1);
        one.add_from(Some(0), |o| o[0] += -0.3);
        let mut out = Light::dark(1, 1);
        out.add_clamped(&one);
        assert_eq!(out.part(0), Some(&out.whole[..]));
    }
}
