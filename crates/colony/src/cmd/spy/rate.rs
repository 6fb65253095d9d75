//! A channel's rate and bandwidth over a sliding window.
//!
//! The hub reports cumulative packet counts; a rate is the count over a span of time divided by
//! that span, which is how the monitor reads two status reports a second apart. The spy counts
//! the packets it receives the same way, over the last `window`: the window is cut into
//! [`SLOTS`] slots, and the rate is what the slots wholly inside the window hold, over the time
//! they cover. Memory is the same whatever the traffic: a few hundred bytes per channel.

use std::time::Duration;

/// Slots a window is cut into: the window slides in steps of 1/32 of its length.
pub const SLOTS: usize = 32;

/// Packets and bytes counted over a sliding window of fixed length.
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

#[cfg(test)]
mod tests {
    use super::*;

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
