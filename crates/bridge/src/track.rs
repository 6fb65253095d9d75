//! Counting, per sender and key, the packets that never crossed.
//!
//! Zenoh drops samples under congestion without telling anyone. Each bridge
//! numbers what it puts, per key and Zenoh priority (Zenoh keeps order only
//! within a priority), and sends the number along (the sample's attachment:
//! the sender's run id and the number, 16 bytes); the receiving bridge
//! counts gaps as lost and drops what it has already passed on.
//!
//! Nothing authenticates a stamp: any Zenoh peer sees a sender's run id and
//! may put any (run id, number) at any rate. So a number decides only what
//! is *counted*, never whether a real packet gets through:
//!
//! - A packet is dropped only as an exact repeat: the same number with the
//!   same bytes (a keyed hash of them, which a forger cannot aim at) as one
//!   already passed on. Whatever a forger sends first under a number, the
//!   real packet with that number still passes.
//! - A stream's position (its highest number) moves only by a step of at
//!   most [`WINDOW`], which counts the numbers skipped as lost (at most
//!   `WINDOW - 1` per packet, what a real sender that lost as many shows).
//! - A number further ahead, or further behind than the window, is passed on
//!   and counted as suspect, never as lost, and does not move the position,
//!   unless the position has heard nothing for [`QUIET`]: then it is taken
//!   up afresh (a sender back after a loss longer than the window, or a site
//!   asking again for a channel it had dropped), still counting nothing lost.
//!
//! So a forger can neither silence a real stream nor add a far jump to
//! `lost`. What it can still do: add up to `WINDOW - 1` to `lost` per packet
//! it sends (as it could under a run id of its own), hide real losses by
//! filling gaps, and, by outrunning a real stream with numbers of its own,
//! make that stream's packets count as suspect (still passed on) until it
//! stops for [`QUIET`].

use std::collections::HashMap;
use std::hash::{BuildHasher, RandomState};
use std::time::{Duration, Instant};

/// The most streams tracked at once; beyond, the table starts afresh (and
/// the next packet of each stream starts its count again).
const MAX_STREAMS: usize = 16_384;
/// Numbers remembered behind a stream's position, and the longest step
/// forward counted as the stream going on (the skipped numbers as lost).
pub const WINDOW: u64 = 64;
/// A stream whose position has not moved for this long takes up a number
/// far from it as its new position.
pub const QUIET: Duration = Duration::from_millis(500);

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
    /// The same number and bytes as one passed on already: drop it.
    Duplicate,
    /// Its number is far from its stream's position, or was taken already
    /// by other bytes: a forgery, or the real packet after one. Pass it on
    /// (dropping it could silence the real stream) and count it apart.
    Suspect,
}

#[derive(Debug)]
struct Stream {
    /// The position: the highest number taken as the stream's.
    highest: u64,
    /// Bit `i`: `highest - i` has arrived.
    seen: u64,
    /// What arrived as number `n`, at `n % WINDOW`, as a keyed hash.
    prints: [u64; WINDOW as usize],
    /// The first number heard: nothing before it was ever counted lost.
    start: u64,
    /// When the position last moved.
    moved: Instant,
    /// The last suspect (number, print), so that a forgery sent again and
    /// again passes once, and so does a real packet that came after one.
    stray: Option<(u64, u64)>,
}

impl Stream {
    fn new(seq: u64, print: u64, now: Instant) -> Stream {
        let mut prints = [0; WINDOW as usize];
        prints[slot(seq)] = print;
        Stream {
            highest: seq,
            seen: 1,
            prints,
            start: seq,
            moved: now,
            stray: None,
        }
    }

    fn check(&mut self, seq: u64, print: u64, now: Instant) -> Verdict {
        if seq > self.highest && seq - self.highest <= WINDOW {
            let step = seq - self.highest;
            self.seen = if step >= 64 { 0 } else { self.seen << step };
            self.seen |= 1;
            self.prints[slot(seq)] = print;
            self.highest = seq;
            self.moved = now;
            return Verdict::New { lost: step - 1 };
        }
        if seq <= self.highest && self.highest - seq < WINDOW {
            let bit = 1u64 << (self.highest - seq);
            if self.seen & bit != 0 {
                if self.prints[slot(seq)] == print {
                    return Verdict::Duplicate;
                }
                return self.stray(seq, print);
            }
            self.seen |= bit;
            self.prints[slot(seq)] = print;
            // Before the stream's first number: never counted, so not late either.
            return if seq > self.start {
                Verdict::Late
            } else {
                Verdict::New { lost: 0 }
            };
        }
        // Far from the position. A live stream keeps its position: a
        // forger cannot move it by a jump, however often it sends one.
        if now.saturating_duration_since(self.moved) >= QUIET {
            *self = Stream::new(seq, print, now);
            return Verdict::New { lost: 0 };
        }
        self.stray(seq, print)
    }

    fn stray(&mut self, seq: u64, print: u64) -> Verdict {
        if self.stray == Some((seq, print)) {
            return Verdict::Duplicate;
        }
        self.stray = Some((seq, print));
        Verdict::Suspect
    }
}

fn slot(seq: u64) -> usize {
    (seq % WINDOW) as usize
}

/// Gaps and repeats, per (sender run, Zenoh priority, key). Keys are held
/// as keyed hashes, so a long key costs a stream no more than a short one.
#[derive(Debug, Default)]
pub struct Tracker {
    streams: HashMap<(u64, u8, u64), Stream>,
    hasher: RandomState,
}

impl Tracker {
    /// Notes a packet of `key` with these bytes, sent at Zenoh priority
    /// `priority` with `stamp`, arriving at `now`.
    pub fn check(
        &mut self,
        key: &str,
        priority: u8,
        stamp: Stamp,
        payload: &[u8],
        now: Instant,
    ) -> Verdict {
        let id = (stamp.run, priority, self.hasher.hash_one(key));
        let print = self.hasher.hash_one((stamp.seq, payload));
        if self.streams.len() >= MAX_STREAMS && !self.streams.contains_key(&id) {
            self.streams.clear();
        }
        match self.streams.entry(id) {
            std::collections::hash_map::Entry::Occupied(mut e) => {
                e.get_mut().check(stamp.seq, print, now)
            }
            std::collections::hash_map::Entry::Vacant(e) => {
                // The first packet heard sets where the stream starts: what
                // came before was put before this site asked for it.
                e.insert(Stream::new(stamp.seq, print, now));
                Verdict::New { lost: 0 }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(seq: u64) -> Stamp {
        Stamp { run: 7, seq }
    }

    /// A tracker fed at one instant: timing plays no part.
    struct Fixed(Tracker, Instant);

    impl Fixed {
        fn new() -> Fixed {
            Fixed(Tracker::default(), Instant::now())
        }
        fn check(&mut self, key: &str, priority: u8, stamp: Stamp) -> Verdict {
            let body = format!("packet {}", stamp.seq);
            self.0.check(key, priority, stamp, body.as_bytes(), self.1)
        }
    }

    #[test]
    fn gaps_count_as_lost_and_repeats_are_refused() {
        let mut t = Fixed::new();
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
        // The longest step counted as a loss, and one further.
        assert_eq!(t.check("k", 5, at(10 + WINDOW)), Verdict::New { lost: 63 });
        assert_eq!(t.check("k", 5, at(11 + 2 * WINDOW)), Verdict::Suspect);
    }

    /// The review's attack: the real stream at 20 packets a second, and one
    /// forged stamp (its run id, 2^64 - 2) sent every 50 ms. Before, 63 real
    /// packets in 64 were dropped after each forgery, and each added 2^20
    /// to `lost`.
    #[test]
    fn a_forged_number_far_ahead_neither_silences_the_stream_nor_counts_as_lost() {
        let mut t = Tracker::default();
        let start = Instant::now();
        let (mut passed, mut lost, mut suspect) = (0, 0, 0);
        for n in 1..=300u64 {
            let now = start + Duration::from_millis(50 * n);
            let real = format!("@ <radio> 0\nmsg n {n}\n");
            match t.check("k", 5, at(n), real.as_bytes(), now) {
                Verdict::New { lost: l } => {
                    passed += 1;
                    lost += l;
                }
                v => panic!("real packet {n}: {v:?}"),
            }
            let forged = Stamp {
                run: 7,
                seq: u64::MAX - 1,
            };
            match t.check("k", 5, forged, b"@ <radio> 0\nstop\n", now) {
                Verdict::Suspect => suspect += 1,
                Verdict::Duplicate => {}
                v => panic!("a forgery was taken as the stream's: {v:?}"),
            }
        }
        assert_eq!((passed, lost), (300, 0));
        assert_eq!(suspect, 1, "the same forgery again is a repeat");
        // Forged with other bytes each time: each passes, as suspect.
        let now = start + Duration::from_millis(50 * 301);
        for i in 0..10 {
            let body = format!("junk {i}");
            let forged = Stamp {
                run: 7,
                seq: 1 << 40,
            };
            let v = t.check("k", 5, forged, body.as_bytes(), now);
            assert_eq!(v, Verdict::Suspect);
        }
        let real = t.check("k", 5, at(301), b"@ <radio> 0\nmsg n 301\n", now);
        assert_eq!(real, Verdict::New { lost: 0 });
    }

    #[test]
    fn a_number_taken_first_by_a_forger_still_lets_the_real_packet_through() {
        let mut t = Tracker::default();
        let now = Instant::now();
        assert_eq!(
            t.check("k", 5, at(1), b"one", now),
            Verdict::New { lost: 0 }
        );
        // The forger sends the next numbers before the sender does.
        for n in 2..=5 {
            let v = t.check("k", 5, at(n), b"junk", now);
            assert_eq!(v, Verdict::New { lost: 0 });
        }
        for n in 2..=5 {
            let body = format!("real {n}");
            let v = t.check("k", 5, at(n), body.as_bytes(), now);
            assert_eq!(v, Verdict::Suspect, "real {n}");
            assert_eq!(
                t.check("k", 5, at(n), body.as_bytes(), now),
                Verdict::Duplicate
            );
        }
        assert_eq!(
            t.check("k", 5, at(6), b"real 6", now),
            Verdict::New { lost: 0 }
        );
    }

    #[test]
    fn a_forged_step_within_the_window_is_made_good_by_the_real_packets_it_skipped() {
        let mut t = Tracker::default();
        let now = Instant::now();
        assert_eq!(t.check("k", 5, at(1), b"1", now), Verdict::New { lost: 0 });
        let lost = match t.check("k", 5, at(1 + WINDOW), b"junk", now) {
            Verdict::New { lost } => lost,
            v => panic!("{v:?}"),
        };
        assert_eq!(lost, WINDOW - 1);
        let late = (2..1 + WINDOW)
            .filter(|n| t.check("k", 5, at(*n), n.to_string().as_bytes(), now) == Verdict::Late)
            .count() as u64;
        assert_eq!(
            late, lost,
            "every skipped number came, and was taken off lost"
        );
    }

    #[test]
    fn a_stream_quiet_for_a_while_takes_up_a_far_number_as_its_own() {
        let mut t = Tracker::default();
        let start = Instant::now();
        assert_eq!(
            t.check("k", 5, at(10), b"10", start),
            Verdict::New { lost: 0 }
        );
        // Soon after, a jump is suspect; once the stream has been quiet,
        // the same kind of jump (a loss longer than the window, or a site
        // asking again) is where the stream goes on from, nothing counted lost.
        let soon = start + QUIET / 2;
        assert_eq!(t.check("k", 5, at(1_000_000), b"a", soon), Verdict::Suspect);
        let later = start + QUIET;
        assert_eq!(
            t.check("k", 5, at(2_000_000), b"b", later),
            Verdict::New { lost: 0 }
        );
        assert_eq!(
            t.check("k", 5, at(2_000_001), b"c", later),
            Verdict::New { lost: 0 }
        );
        // And behind, after a forger outran the stream and stopped.
        let much_later = later + QUIET;
        assert_eq!(
            t.check("k", 5, at(3), b"d", much_later),
            Verdict::New { lost: 0 }
        );
        assert_eq!(
            t.check("k", 5, at(4), b"e", much_later),
            Verdict::New { lost: 0 }
        );
    }

    #[test]
    fn any_stamp_and_bytes_give_a_verdict() {
        let mut t = Tracker::default();
        let now = Instant::now();
        for seq in [0, 1, u64::MAX, u64::MAX - 1, 0, 1 << 63, 64, 0, u64::MAX] {
            let _ = t.check("k", 0, at(seq), b"", now);
            let _ = t.check("k", 0, at(seq), b"x", now + QUIET);
        }
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
