//! Counting, per sender and key, the packets that never crossed.
//!
//! Zenoh drops samples under congestion without telling anyone. Each bridge
//! numbers what it puts, per key, and sends the number along (the sample's
//! attachment: the sender's run id and the number, 16 bytes); the receiving
//! bridge counts gaps as lost and refuses numbers it has seen.

use std::collections::HashMap;

use colony_wire::auth::ReplayWindow;

/// The most streams tracked at once; beyond, the table starts afresh (and
/// the next packet of each stream starts its count again).
const MAX_STREAMS: usize = 65_536;

/// A packet's place in its stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stamp {
    /// Drawn at random when the sending bridge starts.
    pub run: u64,
    /// 1 for the first packet put on a key, then one more each.
    pub seq: u64,
}

impl Stamp {
    /// The attachment's bytes.
    pub fn to_bytes(self) -> [u8; 16] {
        let mut b = [0u8; 16];
        b[..8].copy_from_slice(&self.run.to_be_bytes());
        b[8..].copy_from_slice(&self.seq.to_be_bytes());
        b
    }

    /// Reads an attachment; `None` unless it is 16 bytes.
    pub fn from_bytes(b: &[u8]) -> Option<Stamp> {
        let b: &[u8; 16] = b.try_into().ok()?;
        Some(Stamp {
            run: u64::from_be_bytes(b[..8].try_into().ok()?),
            seq: u64::from_be_bytes(b[8..].try_into().ok()?),
        })
    }
}

/// What became of one received packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// New: pass it on. `lost` packets before it never came.
    New {
        /// Packets skipped since the last one of its stream.
        lost: u64,
    },
    /// Came after a later one of its stream (Zenoh sends higher priorities
    /// first): pass it on; it had been counted lost.
    Late,
    /// Seen already, or too old to tell: drop it.
    Duplicate,
}

#[derive(Debug, Default)]
struct Stream {
    window: ReplayWindow,
}

/// Gaps and repeats, per (sender run, key).
#[derive(Debug, Default)]
pub struct Tracker {
    streams: HashMap<(u64, String), Stream>,
}

impl Tracker {
    /// Notes a packet of `key` with `stamp`.
    pub fn check(&mut self, key: &str, stamp: Stamp) -> Verdict {
        if self.streams.len() >= MAX_STREAMS
            && !self.streams.contains_key(&(stamp.run, key.to_owned()))
        {
            self.streams.clear();
        }
        let stream = self.streams.entry((stamp.run, key.to_owned())).or_default();
        let highest = stream.window.highest();
        if !stream.window.accept(stamp.seq) {
            return Verdict::Duplicate;
        }
        if stamp.seq < highest {
            return Verdict::Late;
        }
        // The first packet of a stream heard sets where it starts: what came
        // before was put before this site asked for it.
        let lost = if highest == 0 {
            0
        } else {
            stamp.seq.saturating_sub(highest + 1)
        };
        Verdict::New { lost }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(seq: u64) -> Stamp {
        Stamp { run: 7, seq }
    }

    #[test]
    fn gaps_count_as_lost_and_repeats_are_refused() {
        let mut t = Tracker::default();
        assert_eq!(t.check("k", at(5)), Verdict::New { lost: 0 });
        assert_eq!(t.check("k", at(6)), Verdict::New { lost: 0 });
        assert_eq!(t.check("k", at(6)), Verdict::Duplicate);
        assert_eq!(t.check("k", at(10)), Verdict::New { lost: 3 });
        assert_eq!(t.check("k", at(8)), Verdict::Late);
        assert_eq!(t.check("k", at(8)), Verdict::Duplicate);
        // Another key, another run: streams of their own.
        assert_eq!(t.check("j", at(1)), Verdict::New { lost: 0 });
        assert_eq!(
            t.check("k", Stamp { run: 8, seq: 1 }),
            Verdict::New { lost: 0 }
        );
    }

    #[test]
    fn a_stamp_reads_back_and_other_lengths_are_none() {
        let s = Stamp {
            run: u64::MAX,
            seq: 3,
        };
        assert_eq!(Stamp::from_bytes(&s.to_bytes()), Some(s));
        assert_eq!(Stamp::from_bytes(&[0; 15]), None);
        assert_eq!(Stamp::from_bytes(&[0; 17]), None);
    }
}
