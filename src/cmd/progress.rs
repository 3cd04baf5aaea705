//! Progress on a terminal only: a bar over tiles or tasks, and a spinner
//! for preparation steps (BVH, light structure, sky, pilot, cache) that run
//! longer than a second; quick steps and non-terminal stderr stay silent.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use gloam_trace::{PrepEvent, PrepObserver};

/// A step runs this long before its spinner shows.
const SHOW_AFTER: Duration = Duration::from_secs(1);

/// A bar of `len` steps drawn with `template` and `chars` (None off a
/// terminal).
pub fn bar(template: &str, chars: &str, len: u64) -> Option<indicatif::ProgressBar> {
    std::io::stderr().is_terminal().then(|| {
        let style = indicatif::ProgressStyle::with_template(template)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar());
        indicatif::ProgressBar::new(len).with_style(style.progress_chars(chars))
    })
}

/// A bar of `len` steps drawn with `template` on a terminal, hidden
/// elsewhere.
pub fn bar_or_hidden(template: &str, len: u64) -> indicatif::ProgressBar {
    bar(template, "█░", len).unwrap_or_else(indicatif::ProgressBar::hidden)
}

/// The observer to hand to `Tracer::prepare_observed` (None off a terminal).
pub fn prep_spinner() -> Option<PrepObserver> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    // The running step's "done" flag and bar.
    let current: Mutex<Option<(Arc<AtomicBool>, indicatif::ProgressBar)>> = Mutex::new(None);
    Some(Arc::new(move |e: PrepEvent<'_>| {
        let Ok(mut cur) = current.lock() else { return };
        match e {
            PrepEvent::Begin(name) => {
                let done = Arc::new(AtomicBool::new(false));
                let bar = indicatif::ProgressBar::hidden();
                bar.set_style(
                    indicatif::ProgressStyle::with_template("{spinner} preparing: {msg} {elapsed}")
                        .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
                );
                bar.set_message(name.to_string());
                let (d, b) = (done.clone(), bar.clone());
                // Bounded wait: SHOW_AFTER in 50 ms steps, then show.
                std::thread::spawn(move || {
                    for _ in 0..SHOW_AFTER.as_millis() / 50 {
                        if d.load(Ordering::Relaxed) {
                            return;
                        }
                        std::thread::sleep(Duration::from_millis(50));
                    }
                    if !d.load(Ordering::Relaxed) {
                        b.set_draw_target(indicatif::ProgressDrawTarget::stderr());
                        b.enable_steady_tick(Duration::from_millis(120));
                    }
                });
                *cur = Some((done, bar));
            }
            PrepEvent::End(step) => {
                if let Some((done, bar)) = cur.take() {
                    done.store(true, Ordering::Relaxed);
                    if step.seconds >= SHOW_AFTER.as_secs_f64() {
                        bar.finish_with_message(format!(
                            "{} ({:.1} s{})",
                            step.name,
                            step.seconds,
                            step.peak_rss_bytes
                                .map(|b| format!(", peak {:.0} MiB", b as f64 / 1048576.0))
                                .unwrap_or_default()
                        ));
                    } else {
                        bar.finish_and_clear();
                    }
                }
            }
        }
    }))
}

/// A tile progress bar on a terminal (nothing elsewhere): what a render's
/// `progress(done, total)` callback drives.
pub struct TileBar(Option<indicatif::ProgressBar>);

impl TileBar {
    pub fn new() -> Self {
        let template = "{spinner} rendering [{bar:40}] {pos}/{len} tiles {elapsed}/{eta}";
        TileBar(bar(template, "=> ", 0))
    }

    /// The render's progress callback.
    pub fn progress(&self, done: u64, total: u64) {
        if let Some(b) = &self.0 {
            b.set_length(total);
            b.set_position(done);
        }
    }

    pub fn finish(&self) {
        if let Some(b) = &self.0 {
            b.finish_and_clear();
        }
    }
}

/// A request's events on a terminal: a spinner for the preparation, a bar
/// over the tiles, notes on stderr.
#[derive(Default)]
pub struct Terminal {
    bar: std::sync::OnceLock<TileBar>,
}

impl gloam_pipeline::Events for Terminal {
    fn preparation(&self) -> Option<PrepObserver> {
        prep_spinner()
    }
    fn tiles(&self, done: u64, total: u64) {
        self.bar.get_or_init(TileBar::new).progress(done, total);
    }
    fn traced(&self) {
        if let Some(b) = self.bar.get() {
            b.finish();
        }
    }
    fn note(&self, line: &str) {
        eprintln!("{line}");
    }
}
