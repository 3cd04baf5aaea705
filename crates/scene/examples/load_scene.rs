//! Loads scene files and prints, for each, how long loading took (wall
//! and CPU time, so that a busy machine does not hide the cost), its
//! instancing counts, and memory: the process's peak and what the loaded
//! scene keeps (Linux), e.g.
//! `cargo run --release -p gloam-scene --example load_scene -- scene.toml`.

use std::time::Instant;

/// (VmRSS, VmHWM) in bytes.
fn rss() -> (u64, u64) {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let kb = |key: &str| -> u64 {
        s.lines()
            .find(|l| l.starts_with(key))
            .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
            .unwrap_or(0)
            * 1024
    };
    (kb("VmRSS:"), kb("VmHWM:"))
}

/// User + system CPU seconds of this process.
fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the command name (which may hold spaces) in parentheses.
    let rest = s.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<f64> = rest
        .split_whitespace()
        .map(|x| x.parse().unwrap_or(0.0))
        .collect();
    // utime and stime are fields 14 and 15, i.e. 12 and 13 after ')'.
    (f.get(11).unwrap_or(&0.0) + f.get(12).unwrap_or(&0.0)) / 100.0
}

fn main() {
    for arg in std::env::args().skip(1) {
        let (rss0, _) = rss();
        let (t, c) = (Instant::now(), cpu_seconds());
        match gloam_scene::load(std::path::Path::new(&arg), &gloam_io::ReadLog::off()) {
            Ok(scene) => {
                let (wall, cpu) = (t.elapsed().as_secs_f64(), cpu_seconds() - c);
                let (rss1, peak) = rss();
                let n = scene.facets.len().max(1) as f64;
                println!("{arg}: {}", scene.counts());
                println!(
                    "  loaded in {wall:.3} s wall, {cpu:.2} s CPU ({:.0} ns CPU per facet); \
                     scene keeps {:.0} bytes per facet; process peak {:.1} MB",
                    cpu * 1e9 / n,
                    rss1.saturating_sub(rss0) as f64 / n,
                    peak as f64 / 1e6,
                );
            }
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        }
    }
}
