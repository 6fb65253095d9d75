//! A channel's rate: its packets (and bytes) per second, as counts over a span of time divided by
//! that span. Two measurements, because a watcher asks two questions:
//!
//! - what the hub published: [`rates_between`] two of its status reports, whose cumulative
//!   packet counts grew by so much over so long (the monitor's hub view);
//! - what this client received: a [`RateWindow`] counts packets as they arrive, over a sliding
//!   window (`colony spy`, which taps every channel).
//!
//! They differ where packets are lost on the way or the client hears only some channels, which
//! is why neither stands in for the other.

use std::collections::BTreeMap;
use std::time::Duration;

use colony_wire::StatusReport;

/// Slots a window is cut into: the window slides in steps of 1/32 of its length.
pub const SLOTS: usize = 32;

/// Packets and bytes counted over a sliding window of fixed length: the window is cut into
/// [`SLOTS`] slots, and the rate is what the slots wholly inside the window hold, over the time
/// they cover. Memory is the same whatever the traffic: a few hundred bytes.
#[derive(Debug, Clone)]
pub struct RateWindow {
    slot: Duration,
    /// Counts per slot; the slot for time `t` is `t / slot` modulo the length (one more than
    /// [`SLOTS`]: the slot being filled is not yet part of the window).
    counts: [(u64, u64); SLOTS + 1],
    /// The absolute number of the newest slot written or cleared.
    newest: u64,
    /// The slot of the first packet: until a whole window has passed since, the rate is over
    /// the slots since then.
    first: Option<u64>,
}

impl RateWindow {
    /// A window of `window` (at least [`SLOTS`] microseconds).
    pub fn new(window: Duration) -> RateWindow {
        let slot = (window / SLOTS as u32).max(Duration::from_micros(1));
        RateWindow {
            slot,
            counts: [(0, 0); SLOTS + 1],
            newest: 0,
            first: None,
        }
    }

    fn slot_of(&self, at: Duration) -> u64 {
        u64::try_from(at.as_nanos() / self.slot.as_nanos()).unwrap_or(u64::MAX)
    }

    /// Moves the newest slot up to `n`, clearing the slots passed over (time never runs back:
    /// an earlier `n` changes nothing).
    fn advance(&mut self, n: u64) {
        if n <= self.newest {
            return;
        }
        let len = self.counts.len() as u64;
        if n - self.newest >= len {
            self.counts = [(0, 0); SLOTS + 1];
        } else {
            for k in self.newest + 1..=n {
                self.counts[(k % len) as usize] = (0, 0);
            }
        }
        self.newest = n;
    }

    /// Counts one packet of `bytes` received at `at` (time since any fixed origin, the same
    /// for every call).
    pub fn record(&mut self, at: Duration, bytes: usize) {
        let n = self.slot_of(at);
        self.advance(n);
        self.first.get_or_insert(n);
        // A packet stamped earlier than the newest slot (a log out of order) counts in the newest.
        let len = self.counts.len() as u64;
        let c = &mut self.counts[(n.max(self.newest) % len) as usize];
        c.0 = c.0.saturating_add(1);
        c.1 = c.1.saturating_add(bytes as u64);
    }

    /// Packets and bytes per second at `now`: the count of the whole slots of the window that
    /// ends where the current slot begins, over the window. `None` until a whole window has
    /// passed since the first packet: a count over part of the window is no rate over it (a
    /// burst of three packets would read as a hundred a second).
    pub fn rates(&self, now: Duration) -> Option<(f64, f64)> {
        let current = self.slot_of(now);
        let first = self.first?;
        if current.saturating_sub(first) < SLOTS as u64 {
            return None;
        }
        let whole = SLOTS as u64;
        let len = self.counts.len() as u64;
        let (mut packets, mut bytes) = (0u64, 0u64);
        for k in current - whole..current {
            // Slots after the newest were never written, and those a lap before it are gone.
            if k > self.newest || self.newest - k >= len {
                continue;
            }
            let (p, b) = self.counts[(k % len) as usize];
            packets = packets.saturating_add(p);
            bytes = bytes.saturating_add(b);
        }
        let span = self.slot.as_secs_f64() * whole as f64;
        Some((packets as f64 / span, bytes as f64 / span))
    }
}

/// Each channel's packets per second between two status reports of one hub, in the order
/// `report` lists them: the growth of its count over the growth of the hub's uptime. `None`
/// for a channel the previous report did not list or whose count went down, and for every
/// channel when there is no previous report or the uptime did not grow (the hub restarted).
pub fn rates_between(previous: Option<&StatusReport>, report: &StatusReport) -> Vec<Option<f64>> {
    let dt_ms = match previous {
        Some(prev) if report.uptime_ms > prev.uptime_ms => {
            Some((report.uptime_ms - prev.uptime_ms) as f64)
        }
        _ => None,
    };
    let before: BTreeMap<&str, u64> = previous
        .iter()
        .flat_map(|r| r.channels.iter())
        .map(|c| (c.subjects.as_str(), c.packets))
        .collect();
    report
        .channels
        .iter()
        .map(|c| match (dt_ms, before.get(c.subjects.as_str())) {
            (Some(dt), Some(&before)) if c.packets >= before => {
                Some((c.packets - before) as f64 * 1000.0 / dt)
            }
            _ => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use colony_wire::ChannelInfo;

    use super::*;

    fn report(uptime_ms: u64, channels: &[(&str, u64)]) -> StatusReport {
        StatusReport {
            uptime_ms,
            channels: channels
                .iter()
                .map(|&(subjects, packets)| ChannelInfo {
                    subjects: subjects.into(),
                    packets,
                    bytes: 0,
                })
                .collect(),
            ..StatusReport::default()
        }
    }

    #[test]
    fn a_rate_between_reports_is_the_count_grown_over_the_time_passed() {
        let first = report(1000, &[("a", 10), ("b", 5)]);
        let second = report(3000, &[("a", 30), ("b", 4), ("c", 1)]);
        assert_eq!(rates_between(None, &first), [None, None]);
        assert_eq!(
            rates_between(Some(&first), &second),
            [Some(10.0), None, None]
        );
        // A hub that restarted counts from nothing again: no rate across it.
        assert_eq!(
            rates_between(Some(&second), &report(500, &[("a", 1)])),
            [None]
        );
    }

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn a_steady_stream_reads_at_its_rate_once_the_window_is_full() {
        let mut w = RateWindow::new(Duration::from_secs(1));
        // 20 packets a second of 100 bytes, for 3 s.
        for i in 0..60 {
            w.record(ms(i * 50), 100);
        }
        let (p, b) = w.rates(ms(3000)).unwrap();
        assert!((p - 20.0).abs() < 1.0, "{p}");
        assert!((b - 2000.0).abs() < 100.0, "{b}");
    }

    #[test]
    fn a_slow_periodic_channel_reads_within_one_packet_of_its_rate_over_a_long_window() {
        // One packet every 2.5 s, a 30 s window: 12 packets, give or take one at the edges.
        let mut w = RateWindow::new(Duration::from_secs(30));
        for i in 0..40 {
            w.record(ms(i * 2500), 30);
        }
        for now in [95_000, 97_300, 99_900] {
            let (p, _) = w.rates(ms(now)).unwrap();
            assert!((p - 0.4).abs() <= 1.0 / 30.0 + 1e-9, "at {now}: {p}");
        }
    }

    #[test]
    fn a_channel_that_falls_silent_reads_zero_after_a_window() {
        let mut w = RateWindow::new(Duration::from_secs(1));
        for i in 0..20 {
            w.record(ms(i * 50), 10);
        }
        assert!(w.rates(ms(1000)).unwrap().0 > 15.0);
        assert_eq!(w.rates(ms(2100)), Some((0.0, 0.0)));
        // Long after, too (the slots are cleared, not left from a lap before).
        assert_eq!(w.rates(ms(1_000_000)), Some((0.0, 0.0)));
    }

    #[test]
    fn a_new_channel_has_no_rate_until_a_whole_window_has_passed() {
        let mut w = RateWindow::new(Duration::from_secs(32));
        assert_eq!(w.rates(ms(5000)), None);
        for i in 0..40 {
            w.record(ms(10_000 + i * 100), 1);
        }
        assert_eq!(w.rates(ms(14_000)), None);
        for i in 40..320 {
            w.record(ms(10_000 + i * 100), 1);
        }
        assert_eq!(w.rates(ms(41_999)), None);
        // 32 s of 10 a second by now: the window holds 320 of them.
        let (p, _) = w.rates(ms(42_000)).unwrap();
        assert!((p - 10.0).abs() < 0.5, "{p}");
    }

    #[test]
    fn time_running_back_counts_in_the_newest_slot_and_nothing_overflows() {
        let mut w = RateWindow::new(Duration::from_secs(1));
        w.record(ms(5000), usize::MAX);
        w.record(ms(10), 1);
        w.record(Duration::MAX, 1);
        let _ = w.rates(Duration::MAX);
        let mut tiny = RateWindow::new(Duration::ZERO);
        tiny.record(ms(1), 1);
        assert!(tiny.rates(ms(2)).is_some());
    }
}
