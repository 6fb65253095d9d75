//! Per-source rate limits in a fixed table: bounded memory whatever the
//! number of sources, forged or not.

use std::net::SocketAddr;
use std::time::Instant;

/// Buckets in the table. Sources share a bucket when their hashes collide,
/// so a flood from one source can slow, at worst, the few that share its bucket.
const BUCKETS: usize = 4096;

#[derive(Debug, Clone, Copy)]
struct Bucket {
    tokens: f64,
    last: Option<Instant>,
}

/// Token buckets keyed by a hash of the source address.
#[derive(Debug)]
pub(crate) struct RateTable {
    per_second: f64,
    burst: f64,
    hasher: std::collections::hash_map::RandomState,
    buckets: Vec<Bucket>,
}

impl RateTable {
    /// Each source may send `per_second` on average, and `burst` at once.
    pub(crate) fn new(per_second: f64, burst: f64) -> RateTable {
        RateTable {
            per_second,
            burst,
            // A hash keyed at random: an attacker cannot choose addresses that
            // all land in a victim's bucket.
            hasher: std::collections::hash_map::RandomState::new(),
            buckets: vec![
                Bucket {
                    tokens: burst,
                    last: None,
                };
                BUCKETS
            ],
        }
    }

    /// Takes one token for `src`; `false` when it has none left.
    pub(crate) fn take(&mut self, src: &SocketAddr, now: Instant) -> bool {
        use std::hash::BuildHasher;
        let i = (self.hasher.hash_one(src) as usize) % BUCKETS;
        let b = &mut self.buckets[i];
        if let Some(last) = b.last {
            let refill = now.saturating_duration_since(last).as_secs_f64() * self.per_second;
            b.tokens = (b.tokens + refill).min(self.burst);
        }
        b.last = Some(now);
        if b.tokens >= 1.0 {
            b.tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_source_gets_its_burst_then_its_rate() {
        let mut t = RateTable::new(10.0, 5.0);
        let a: SocketAddr = "127.0.0.1:1000".parse().unwrap();
        let t0 = Instant::now();
        assert_eq!((0..20).filter(|_| t.take(&a, t0)).count(), 5);
        assert_eq!(
            (0..20)
                .filter(|_| t.take(&a, t0 + Duration::from_millis(500)))
                .count(),
            5
        );
        let others = (1..50u16)
            .map(|p| SocketAddr::new(a.ip(), 2000 + p))
            .filter(|b| t.take(b, t0 + Duration::from_millis(500)))
            .count();
        assert!(
            others >= 45,
            "other sources keep their own buckets: {others}"
        );
    }
}
