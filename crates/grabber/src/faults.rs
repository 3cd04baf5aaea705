//! Fault injection for links: drop, corrupt, truncate, delay wire units.
//!
//! Used by the in-memory transport (tests) and by the device emulator
//! (`gloam device --fault-*`). Deterministic for a given seed.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// Probabilities are per wire unit (one COBS frame / one USB transfer).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FaultConfig {
    /// Drop the whole unit.
    pub drop: f64,
    /// Flip one random bit of the unit.
    pub corrupt: f64,
    /// Cut the unit at a random length.
    pub truncate: f64,
    /// Hold the unit back by `delay` (the link stalls, order is kept).
    pub delay_p: f64,
    pub delay: Duration,
    /// Seed of the fault generator.
    pub seed: u64,
}

impl FaultConfig {
    /// No faults.
    pub fn none() -> Self {
        Self::default()
    }

    /// True when no fault can fire.
    pub fn is_clean(&self) -> bool {
        self.drop <= 0.0 && self.corrupt <= 0.0 && self.truncate <= 0.0 && self.delay_p <= 0.0
    }
}

/// Counts of injected faults, shared between the injector and observers.
#[derive(Debug, Default)]
pub struct FaultStats {
    pub units: AtomicU64,
    pub dropped: AtomicU64,
    pub corrupted: AtomicU64,
    pub truncated: AtomicU64,
    pub delayed: AtomicU64,
    pub resets: AtomicU64,
    pub disconnects: AtomicU64,
}

impl FaultStats {
    /// Snapshot as plain numbers.
    pub fn snapshot(&self) -> FaultCounts {
        FaultCounts {
            units: self.units.load(Ordering::Relaxed),
            dropped: self.dropped.load(Ordering::Relaxed),
            corrupted: self.corrupted.load(Ordering::Relaxed),
            truncated: self.truncated.load(Ordering::Relaxed),
            delayed: self.delayed.load(Ordering::Relaxed),
            resets: self.resets.load(Ordering::Relaxed),
            disconnects: self.disconnects.load(Ordering::Relaxed),
        }
    }
}

/// Plain snapshot of [`FaultStats`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct FaultCounts {
    pub units: u64,
    pub dropped: u64,
    pub corrupted: u64,
    pub truncated: u64,
    pub delayed: u64,
    pub resets: u64,
    pub disconnects: u64,
}

impl FaultCounts {
    /// Faults that damage data (everything but delays).
    pub fn damaging(&self) -> u64 {
        self.dropped + self.corrupted + self.truncated + self.resets + self.disconnects
    }
}

/// What to do with one unit.
#[derive(Debug, PartialEq, Eq)]
pub enum Verdict {
    Drop,
    /// Deliver (possibly modified), after an optional delay.
    Deliver(Option<Duration>),
}

/// Small deterministic generator (Vigna's SplitMix64, the same stream as
/// `gloam_sensor::noise::splitmix64` stepped by the golden-ratio
/// increment): same stream on every platform. Written out here so the
/// grabber does not depend on the sensor model for eight lines.
#[derive(Clone, Debug)]
pub struct SplitMix(u64);

impl SplitMix {
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x5851_F42D_4C95_7F2D)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in 0..n (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }
}

/// Applies a [`FaultConfig`] to wire units.
#[derive(Debug)]
pub struct FaultInjector {
    config: FaultConfig,
    rng: SplitMix,
    stats: Arc<FaultStats>,
}

impl FaultInjector {
    pub fn new(config: FaultConfig) -> Self {
        let rng = SplitMix::new(config.seed);
        Self {
            config,
            rng,
            stats: Arc::new(FaultStats::default()),
        }
    }

    /// An injector counting into existing `stats`.
    pub fn with_stats(config: FaultConfig, stats: Arc<FaultStats>) -> Self {
        let rng = SplitMix::new(config.seed);
        Self { config, rng, stats }
    }

    /// Shared counters.
    pub fn stats(&self) -> Arc<FaultStats> {
        self.stats.clone()
    }

    /// Decide the fate of `unit`, modifying it in place for corruption and
    /// truncation.
    pub fn apply(&mut self, unit: &mut Vec<u8>) -> Verdict {
        self.stats.units.fetch_add(1, Ordering::Relaxed);
        if self.config.is_clean() || unit.is_empty() {
            return Verdict::Deliver(None);
        }
        let c = &self.config;
        if self.rng.unit() < c.drop {
            self.stats.dropped.fetch_add(1, Ordering::Relaxed);
            return Verdict::Drop;
        }
        if self.rng.unit() < c.corrupt {
            let i = self.rng.below(unit.len());
            let bit = self.rng.below(8);
            unit[i] ^= 1 << bit;
            self.stats.corrupted.fetch_add(1, Ordering::Relaxed);
        }
        if self.rng.unit() < c.truncate {
            let n = self.rng.below(unit.len());
            unit.truncate(n);
            self.stats.truncated.fetch_add(1, Ordering::Relaxed);
        }
        if self.rng.unit() < c.delay_p && !c.delay.is_zero() {
            self.stats.delayed.fetch_add(1, Ordering::Relaxed);
            return Verdict::Deliver(Some(c.delay));
        }
        Verdict::Deliver(None)
    }
}

#[cfg(test)]
mod tests {
    /// The generator's first outputs from state 0 are splitmix64.c's
    /// published sequence (seeded with x = 0), so fault streams are the
    /// reference generator's.
    #[test]
    fn splitmix_matches_the_reference_sequence() {
        let mut g = super::SplitMix(0);
        assert_eq!(g.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(g.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(g.next_u64(), 0x06C4_5D18_8009_454F);
    }
}
