//! Packets the hub published that never reached the spy, told from the hub's status reports.
//!
//! A report counts every packet the hub accepted, by channel; a tap receives every one of them.
//! The growth of the hub's total since a baseline report, less the growth of the spy's count
//! over the same reports, is what the spy missed (a full socket buffer, a datagram lost). A
//! report is built when it is asked for, but served again from the hub's cache for up to
//! 100 ms: its counts can be older than its arrival, and what came meanwhile would look missed.
//! So only reports fresh from the hub are believed: those whose arrival, less the hub's uptime
//! in them, is within a few milliseconds of the least seen (the freshest). That least value
//! creeps up by 100 ppm of the time passed, so a hub on another machine whose clock runs a
//! little slow is still believed, and a fresher report retakes the baseline only in the first
//! seconds (after that, a hub whose clock runs a little fast would retake it again and again).

use std::time::Duration;

use colony_wire::StatusReport;

/// A status report whose hub clock is this much behind the freshest one seen was served from
/// the hub's cache: its counts are older than its arrival.
const FRESH_WITHIN: f64 = 0.005;
/// How fast the freshest offset is let creep up: two clocks' rates differ by less.
const DRIFT: f64 = 1e-4;
/// A fresher report retakes the baseline only this long after it was taken.
const SETTLE: f64 = 10.0;

/// Packets the hub counted as published that the spy never received, from the status reports:
/// the growth of the hub's total since a baseline, less the growth of the spy's.
#[derive(Debug, Clone, Default)]
pub struct Missed {
    /// The smallest (arrival time − hub uptime) seen, the freshest report's, and when (in
    /// seconds of the spy's clock) it was last brought up to date.
    min_offset: Option<(f64, f64)>,
    last_uptime: u64,
    /// The hub's total and the spy's at the baseline report, and when it came.
    baseline: Option<(u64, u64, f64)>,
    missed: u64,
}

impl Missed {
    /// Takes in a status report that arrived at `now`, when the spy had seen `seen` packets
    /// (`tapping`: and the hub lets it tap, so it should have seen them all).
    pub fn on_status(&mut self, now: Duration, report: &StatusReport, seen: u64, tapping: bool) {
        if report.uptime_ms < self.last_uptime {
            // The hub restarted: its counts began again.
            *self = Missed::default();
        }
        self.last_uptime = report.uptime_ms;
        let t = now.as_secs_f64();
        let offset = t - report.uptime_ms as f64 / 1000.0;
        let floor = self.min_offset.map(|(m, at)| m + DRIFT * (t - at).max(0.0));
        let settling = self.baseline.is_none_or(|(.., at)| t - at < SETTLE);
        if floor.is_some_and(|f| offset < f - FRESH_WITHIN) && settling {
            // A fresher report than the baseline's: the baseline's counts were older than its
            // arrival (what came meanwhile looked missed), so the count starts again from it.
            self.baseline = None;
            self.missed = 0;
        }
        let floor = floor.map_or(offset, |f| f.min(offset));
        self.min_offset = Some((floor, t));
        let fresh = offset - floor <= FRESH_WITHIN;
        if !fresh || report.truncated || !tapping {
            return;
        }
        let hub: u64 = report.channels.iter().map(|c| c.packets).sum();
        match self.baseline {
            None => self.baseline = Some((hub, seen, t)),
            Some((h0, s0, _)) => {
                self.missed = hub
                    .saturating_sub(h0)
                    .saturating_sub(seen.saturating_sub(s0));
            }
        }
    }

    /// Packets missed since the baseline.
    pub fn count(&self) -> u64 {
        self.missed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_wire::ChannelInfo;

    fn report(uptime_ms: u64, packets: u64) -> StatusReport {
        StatusReport {
            uptime_ms,
            channels: vec![ChannelInfo {
                subjects: "a".into(),
                packets,
                bytes: 0,
            }],
            ..StatusReport::default()
        }
    }

    #[test]
    fn a_hub_whose_clock_runs_slow_or_fast_is_still_believed() {
        for ppm in [-50.0, 50.0] {
            let mut m = Missed::default();
            // The spy sees every packet but one in a thousand, over an hour of reports.
            for i in 0..3600u64 {
                let t = i as f64;
                let uptime = (t * (1.0 + ppm * 1e-6) * 1000.0) as u64;
                m.on_status(
                    Duration::from_secs(i),
                    &report(uptime, i * 1000),
                    i * 999,
                    true,
                );
            }
            assert!(
                (3500..=3600).contains(&m.count()),
                "{ppm} ppm: {}",
                m.count()
            );
        }
    }
}
