//! Counting, per sender and key, the packets that never crossed.
//!
//! Zenoh drops samples under congestion without telling anyone. Each bridge
//! numbers what it puts, per key and Zenoh priority (Zenoh keeps order only
//! within a priority), and sends the number along (the sample's attachment:
//! the sender's run id and the number, 16 bytes); the receiving bridge
//! counts gaps as lost and refuses numbers it has seen.

use std::collections::HashMap;
use std::hash::{BuildHasher, RandomState};

use colony_wire::auth::ReplayWindow;

/// The most streams tracked at once; beyond, the table starts afresh (and
/// the next packet of each stream starts its count again).
const MAX_STREAMS: usize = 65_536;
/// This many refusals in a row restart a stream's window: a forged number
/// far ahead must not silence the real stream behind it.
const RESYNC_AFTER: u32 = 64;
/// The largest gap counted as lost at once; a larger jump is a restart or a
/// forgery, and counts as this.
const MAX_GAP: u64 = 1 << 20;

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
    /// The first number heard: nothing before it was ever counted lost.
    start: u64,
    refused: u32,
}

/// Gaps and repeats, per (sender run, Zenoh priority, key). Keys are held
/// as keyed hashes, so a long key costs a stream no more than a short one.
#[derive(Debug, Default)]
pub struct Tracker {
    streams: HashMap<(u64, u8, u64), Stream>,
    hasher: RandomState,
}

impl Tracker {
    /// Notes a packet of `key`, sent at Zenoh priority `priority`, with `stamp`.
    pub fn check(&mut self, key: &str, priority: u8, stamp: Stamp) -> Verdict {
        let id = (stamp.run, priority, self.hasher.hash_one(key));
        if self.streams.len() >= MAX_STREAMS && !self.streams.contains_key(&id) {
            self.streams.clear();
        }
        let stream = self.streams.entry(id).or_default();
        let highest = stream.window.highest();
        if !stream.window.accept(stamp.seq) {
            stream.refused += 1;
            if stream.refused < RESYNC_AFTER {
                return Verdict::Duplicate;
            }
            *stream = Stream::default();
            stream.window.accept(stamp.seq);
            stream.start = stamp.seq;
            return Verdict::New { lost: 0 };
        }
        stream.refused = 0;
        // The first packet of a stream heard sets where it starts: what came
        // before was put before this site asked for it.
        if highest == 0 {
            stream.start = stamp.seq;
            return Verdict::New { lost: 0 };
        }
        if stamp.seq < highest {
            return if stamp.seq > stream.start {
                Verdict::Late
            } else {
                Verdict::New { lost: 0 }
            };
        }
        Verdict::New {
            lost: (stamp.seq - highest - 1).min(MAX_GAP),
        }
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
        assert_eq!(t.check("k", 5, at(5)), Verdict::New { lost: 0 });
        assert_eq!(t.check("k", 5, at(6)), Verdict::New { lost: 0 });
        assert_eq!(t.check("k", 5, at(6)), Verdict::Duplicate);
        assert_eq!(t.check("k", 5, at(10)), Verdict::New { lost: 3 });
        assert_eq!(t.check("k", 5, at(8)), Verdict::Late);
        assert_eq!(t.check("k", 5, at(8)), Verdict::Duplicate);
        // Before the stream's first number: never counted, so not late either.
        assert_eq!(t.check("k", 5, at(4)), Verdict::New { lost: 0 });
        // Another key, run or priority: streams of their own.
        assert_eq!(t.check("j", 5, at(1)), Verdict::New { lost: 0 });
        assert_eq!(t.check("k", 1, at(1)), Verdict::New { lost: 0 });
        let other_run = Stamp { run: 8, seq: 1 };
        assert_eq!(t.check("k", 5, other_run), Verdict::New { lost: 0 });
    }

    #[test]
    fn a_forged_number_far_ahead_silences_a_stream_only_briefly() {
        let mut t = Tracker::default();
        assert_eq!(t.check("k", 5, at(1)), Verdict::New { lost: 0 });
        assert_eq!(
            t.check("k", 5, at(u64::MAX - 1)),
            Verdict::New { lost: MAX_GAP }
        );
        let refused = (2..200)
            .take_while(|&n| t.check("k", 5, at(n)) == Verdict::Duplicate)
            .count();
        assert_eq!(refused as u32, RESYNC_AFTER - 1);
        assert_eq!(t.check("k", 5, at(66)), Verdict::New { lost: 0 });
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
