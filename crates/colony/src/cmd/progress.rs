//! Progress of long work (`colony sort run`, `reproduce`, `supplementary`): a bar
//! when standard error is a terminal, and otherwise a plain line at least every
//! 10 s, written by a ticker thread that stops when the work ends, so a log or a
//! CI job shows the run is alive:
//!
//! ```text
//! sort run: 1,200 of 4,000 control steps (30 %), 41 s elapsed, about 1 min 36 s left
//! ```
//!
//! The interval can be shortened (for tests) with the environment variable
//! `COLONY_PROGRESS_SECS`: seconds, a positive number.

use std::io::IsTerminal as _;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// The longest silence between two progress lines when standard error is not a terminal.
const INTERVAL: Duration = Duration::from_secs(10);

/// The environment variable that sets another interval, in seconds (for tests).
const INTERVAL_VAR: &str = "COLONY_PROGRESS_SECS";

/// Counts work done and shows it; stops showing it when dropped.
pub struct Progress {
    done: Arc<AtomicU64>,
    bar: Option<ProgressBar>,
    /// Dropping the sender wakes the ticker to end it.
    ticker: Option<(mpsc::Sender<()>, JoinHandle<()>)>,
}

impl Progress {
    /// Starts showing progress towards `total` units (control steps), each line
    /// or the bar led by `label` (`sort run`).
    pub fn start(label: &str, total: u64) -> Progress {
        let done = Arc::new(AtomicU64::new(0));
        if std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template(
                    "{prefix}: {bar:40} {percent:>3}% {human_pos}/{human_len} steps, {per_sec}, {elapsed} elapsed, eta {eta}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_prefix(label.to_string());
            // Redrawn while nothing is counted yet (a large world being built).
            bar.enable_steady_tick(Duration::from_millis(500));
            return Progress {
                done,
                bar: Some(bar),
                ticker: None,
            };
        }
        let (stop, stopped) = mpsc::channel::<()>();
        let (label, count) = (label.to_string(), Arc::clone(&done));
        let interval = interval();
        let ticker = std::thread::Builder::new()
            .name("progress".into())
            .spawn(move || {
                let start = Instant::now();
                let mut next = start + interval;
                loop {
                    let wait = next.saturating_duration_since(Instant::now());
                    match stopped.recv_timeout(wait) {
                        Err(mpsc::RecvTimeoutError::Timeout) => {}
                        // The work ended (the sender dropped).
                        _ => return,
                    }
                    let line = line(
                        &label,
                        count.load(Ordering::Relaxed),
                        total,
                        start.elapsed(),
                    );
                    eprintln!("{line}");
                    // On the schedule, not after the write: no drift past the interval.
                    next += interval;
                    let now = Instant::now();
                    if next < now {
                        next = now + interval;
                    }
                }
            });
        Progress {
            done,
            bar: None,
            // Without a thread (none could be started) the work goes on silently.
            ticker: ticker.ok().map(|t| (stop, t)),
        }
    }

    /// Counts `n` more units done.
    pub fn add(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
        if let Some(bar) = &self.bar {
            bar.inc(n);
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Some((stop, ticker)) = self.ticker.take() {
            drop(stop);
            let _ = ticker.join();
        }
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

/// The interval between lines: `COLONY_PROGRESS_SECS` if it holds a positive
/// number of seconds (at most the default), else 10 s.
fn interval() -> Duration {
    std::env::var(INTERVAL_VAR)
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0)
        .map_or(INTERVAL, |s| {
            Duration::from_secs_f64(s.max(0.001)).min(INTERVAL)
        })
}

/// One progress line: `sort run: 1,200 of 4,000 control steps (30 %), 41 s elapsed, ...`.
fn line(label: &str, done: u64, total: u64, elapsed: Duration) -> String {
    let done = done.min(total);
    let percent = if total == 0 {
        100
    } else {
        (done as u128 * 100 / total as u128) as u64
    };
    let mut text = format!(
        "{label}: {} of {} control steps ({percent} %), {} elapsed",
        grouped(done),
        grouped(total),
        duration(elapsed.as_secs())
    );
    if done > 0 && done < total {
        let left = elapsed.as_secs_f64() * (total - done) as f64 / done as f64;
        text.push_str(&format!(", about {} left", duration(left.round() as u64)));
    }
    text
}

/// A count with its thousands grouped: `1,234,567`.
pub fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// Whole seconds as `41 s`, `12 min 05 s` or `3 h 07 min`.
fn duration(secs: u64) -> String {
    match secs {
        s if s < 60 => format!("{s} s"),
        s if s < 3600 => format!("{} min {:02} s", s / 60, s % 60),
        s => format!("{} h {:02} min", s / 3600, s % 3600 / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_are_grouped_by_thousands() {
        assert_eq!(grouped(0), "0");
        assert_eq!(grouped(999), "999");
        assert_eq!(grouped(1_000), "1,000");
        assert_eq!(grouped(40_960), "40,960");
        assert_eq!(grouped(1_234_567), "1,234,567");
    }

    #[test]
    fn a_line_says_how_far_how_long_and_how_much_is_left() {
        assert_eq!(
            line("sort run", 1_200, 4_000, Duration::from_secs(41)),
            "sort run: 1,200 of 4,000 control steps (30 %), 41 s elapsed, about 1 min 36 s left"
        );
        assert_eq!(
            line("sort run", 0, 4_000, Duration::from_secs(3)),
            "sort run: 0 of 4,000 control steps (0 %), 3 s elapsed"
        );
        assert_eq!(
            line("x", 5, 5, Duration::from_secs(7_500)),
            "x: 5 of 5 control steps (100 %), 2 h 05 min elapsed"
        );
    }
}
