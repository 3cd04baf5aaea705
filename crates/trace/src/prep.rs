//! Where preparation time and memory went: the scene's size (facets,
//! emitters, instances) and, per preparation step (BVH, light structure,
//! sky, pilot, cache), its wall time and the process's peak resident memory
//! during it — what `report.json` and `gloam plan --json` record under
//! `preparation`, and what a progress display watches.

use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

/// One preparation step.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct PrepStep {
    /// `bvh`, `light_structure`, `sky`, `pilot` or `cache`.
    pub name: String,
    pub seconds: f64,
    /// Peak resident memory of the process during the step, bytes (Linux
    /// `VmHWM`, reset at the step's start when the kernel allows it, else
    /// the peak so far); `None` where the system does not say.
    pub peak_rss_bytes: Option<u64>,
}

/// The scene's size and the preparation steps, in the order they ran.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct Preparation {
    pub facets: usize,
    /// Facets as the scene file describes them (one copy of each object).
    pub prototype_facets: usize,
    /// Placements over all objects (an object placed once counts 1).
    pub instances: usize,
    /// Triangles in the BVH (a quad is two).
    pub triangles: usize,
    /// Placed facets of shared objects: traced through one prototype
    /// each (a second BVH level), never copied.
    pub shared_facets: u64,
    /// Emitting facets.
    pub area_emitters: usize,
    pub point_sources: usize,
    pub steps: Vec<PrepStep>,
    /// Sum of the steps' wall time, seconds.
    pub seconds: f64,
    /// Peak resident memory over the whole preparation, bytes.
    pub peak_rss_bytes: Option<u64>,
}

/// What a progress display is told: a step began, or ended.
#[derive(Clone, Debug, PartialEq)]
pub enum PrepEvent<'a> {
    Begin(&'a str),
    End(&'a PrepStep),
}

/// Who watches preparation (the CLI's spinner; `None` for library use).
pub type PrepObserver = Arc<dyn Fn(PrepEvent<'_>) + Send + Sync>;

/// A step being timed (see [`Preparation::begin`]).
pub(crate) struct Running {
    name: &'static str,
    t0: Instant,
}

impl Preparation {
    /// Starts timing step `name` (resetting the peak-memory mark) and tells
    /// the observer.
    pub(crate) fn begin(name: &'static str, observer: Option<&PrepObserver>) -> Running {
        reset_peak_rss();
        tracing::debug!(step = name, "preparation step begins");
        if let Some(o) = observer {
            o(PrepEvent::Begin(name));
        }
        Running {
            name,
            t0: Instant::now(),
        }
    }

    /// Ends a step: records it and tells the observer.
    pub(crate) fn end(&mut self, r: Running, observer: Option<&PrepObserver>) {
        let step = PrepStep {
            name: r.name.to_string(),
            seconds: r.t0.elapsed().as_secs_f64(),
            peak_rss_bytes: peak_rss_bytes(),
        };
        self.seconds += step.seconds;
        self.peak_rss_bytes = match (self.peak_rss_bytes, step.peak_rss_bytes) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        tracing::debug!(
            step = r.name,
            seconds = step.seconds,
            peak_rss_bytes = step.peak_rss_bytes,
            "preparation step ends"
        );
        if let Some(o) = observer {
            o(PrepEvent::End(&step));
        }
        self.steps.push(step);
    }
}

/// The process's peak resident set (`VmHWM` in /proc/self/status), bytes.
pub fn peak_rss_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// Resets the peak-RSS mark to the current RSS (`echo 5 >
/// /proc/self/clear_refs`, Linux ≥ 4.0), so the next reading is this
/// step's peak; where that is refused the reading is the peak so far.
fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_peak_sees_an_allocation_made_during_it() {
        let Some(before) = peak_rss_bytes() else {
            return; // not Linux: nothing to read
        };
        let mut p = Preparation::default();
        let r = Preparation::begin("bvh", None);
        // 256 MiB touched page by page: resident for certain.
        let mut v = vec![0u8; 256 << 20];
        for i in (0..v.len()).step_by(4096) {
            v[i] = 1;
        }
        std::hint::black_box(&v);
        p.end(r, None);
        let peak = p.steps[0].peak_rss_bytes.unwrap_or(0);
        assert!(
            peak >= (256 << 20) && peak >= before.min(256 << 20),
            "peak {peak} B after touching 256 MiB"
        );
        assert_eq!(p.peak_rss_bytes, Some(peak));
        assert_eq!(p.steps[0].name, "bvh");
    }
}
