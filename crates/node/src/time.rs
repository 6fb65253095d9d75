//! Time as the protocol sees it: a count of microseconds since the caller's epoch.
//!
//! The state machines never read a clock. Live, the epoch is when the runner
//! started ([`crate::Link`]); in a batch experiment it is the start of the
//! simulation, so three simulated hours take as long as the computation does.

use std::fmt;
use std::ops::{Add, Sub};
use std::time::Duration;

/// A moment, in microseconds since an epoch the caller chooses.
///
/// ```
/// use std::time::Duration;
/// use colony_node::Time;
/// let t = Time::ZERO + Duration::from_millis(1500);
/// assert_eq!(t.as_secs_f64(), 1.5);
/// assert_eq!(t - Time::from_secs_f64(1.0), Duration::from_millis(500));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Time(u64);

impl Time {
    /// The epoch.
    pub const ZERO: Time = Time(0);

    /// `us` microseconds after the epoch.
    pub const fn from_micros(us: u64) -> Time {
        Time(us)
    }

    /// `s` seconds after the epoch, to the nearest microsecond; negative and
    /// NaN count as the epoch.
    pub fn from_secs_f64(s: f64) -> Time {
        if s.is_nan() || s <= 0.0 {
            Time::ZERO
        } else {
            // Rounded, not truncated: 1.001 s is 1 000 999.999… µs in binary.
            Time((s * 1e6).round().min(u64::MAX as f64) as u64)
        }
    }

    /// Microseconds since the epoch.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// Seconds since the epoch.
    pub fn as_secs_f64(self) -> f64 {
        self.0 as f64 / 1e6
    }

    /// How long after `earlier` this is; zero if it is not later.
    pub fn since(self, earlier: Time) -> Duration {
        Duration::from_micros(self.0.saturating_sub(earlier.0))
    }
}

impl Add<Duration> for Time {
    type Output = Time;
    fn add(self, d: Duration) -> Time {
        let us = u64::try_from(d.as_micros()).unwrap_or(u64::MAX);
        Time(self.0.saturating_add(us))
    }
}

impl Sub for Time {
    type Output = Duration;
    fn sub(self, earlier: Time) -> Duration {
        self.since(earlier)
    }
}

impl fmt::Display for Time {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.3} s", self.as_secs_f64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_round_to_the_nearest_microsecond() {
        // 1.001 · 1e6 is 1 000 999.999… in binary: truncating lost a microsecond.
        assert_eq!(Time::from_secs_f64(1.001).as_micros(), 1_001_000);
        assert_eq!(Time::from_secs_f64(0.35).as_micros(), 350_000);
        assert_eq!(Time::from_secs_f64(2.6e-6).as_micros(), 3);
        assert_eq!(Time::from_secs_f64(0.4e-6).as_micros(), 0);
        for ms in 0..5_000u64 {
            let t = Time::from_secs_f64(ms as f64 / 1000.0);
            assert_eq!(t.as_micros(), ms * 1000, "{ms} ms");
        }
    }

    #[test]
    fn negative_and_nan_seconds_are_the_epoch() {
        for s in [-1.0, -0.0, f64::NAN, f64::NEG_INFINITY] {
            assert_eq!(Time::from_secs_f64(s), Time::ZERO, "{s}");
        }
    }

    #[test]
    fn seconds_beyond_the_range_saturate() {
        assert_eq!(Time::from_secs_f64(f64::INFINITY).as_micros(), u64::MAX);
        assert_eq!(Time::from_secs_f64(1e30).as_micros(), u64::MAX);
    }

    #[test]
    fn adding_a_duration_counts_whole_microseconds_and_saturates() {
        let t = Time::from_micros(10);
        assert_eq!(t + Duration::from_nanos(2_999), Time::from_micros(12));
        assert_eq!(t + Duration::ZERO, t);
        assert_eq!(
            Time::from_micros(u64::MAX - 1) + Duration::from_micros(5),
            Time::from_micros(u64::MAX)
        );
        assert_eq!(t + Duration::MAX, Time::from_micros(u64::MAX));
    }

    #[test]
    fn the_difference_is_zero_when_the_other_is_not_earlier() {
        let (a, b) = (Time::from_micros(1_000), Time::from_micros(3_500));
        assert_eq!(b - a, Duration::from_micros(2_500));
        assert_eq!(a - b, Duration::ZERO);
        assert_eq!(a.since(a), Duration::ZERO);
        assert_eq!(b.since(a), b - a);
    }

    #[test]
    fn times_order_by_their_microseconds() {
        let mut ts = [
            Time::from_micros(5),
            Time::ZERO,
            Time::from_secs_f64(0.000_003),
        ];
        ts.sort();
        assert_eq!(ts.map(Time::as_micros), [0, 3, 5]);
        assert_eq!(Time::default(), Time::ZERO);
    }

    #[test]
    fn a_time_prints_as_seconds_to_the_millisecond() {
        assert_eq!(Time::from_micros(1_234_567).to_string(), "1.235 s");
        assert_eq!(Time::ZERO.to_string(), "0.000 s");
        assert_eq!(Time::from_micros(1_234_567).as_secs_f64(), 1.234567);
    }
}
