//! Reading a traffic log in time: each record with its time since the first,
//! and publishing a log again with its original timing (`colony log` and
//! `colony replay`).

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_wire::{Packet, HUB_SUBJECT};

use crate::log::{LogError, LogReader, Record, TornTail};

/// Whether `packet` is on one of `channels` (any subject of its header
/// counts); every packet is when `channels` is empty.
pub fn on_channels(packet: &Packet<'_>, channels: &[String]) -> bool {
    channels.is_empty() || packet.subjects().any(|s| channels.iter().any(|c| c == s))
}

/// What a pass over a log found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pass {
    /// Records handed to the caller.
    pub records: u64,
    /// The torn record the log ends in, if a crash cut its last write short
    /// (everything before it was read; it is no loss of a whole record).
    pub torn: Option<TornTail>,
}

/// Calls `each` with every whole record of the log at `path` and its time
/// since the log's first record, until `each` returns false.
pub fn for_each_timed<E: From<LogError>>(
    path: impl AsRef<Path>,
    each: impl FnMut(Duration, &Record) -> Result<bool, E>,
) -> Result<Pass, E> {
    let mut reader = LogReader::open(path)?;
    let records = for_each_timed_in(reader.by_ref().map(|r| r.map_err(E::from)), each)?;
    Ok(Pass {
        records,
        torn: reader.torn_tail().cloned(),
    })
}

/// [`for_each_timed`] over records from any reader (a `.clog` [`LogReader`],
/// colony-mcap's reader): calls `each` with every record and its time since
/// the first, until `each` returns false. Returns how many it handed over.
pub fn for_each_timed_in<E>(
    records: impl Iterator<Item = Result<Record, E>>,
    mut each: impl FnMut(Duration, &Record) -> Result<bool, E>,
) -> Result<u64, E> {
    let mut first: Option<u64> = None;
    let mut count = 0;
    for record in records {
        let record = record?;
        let t0 = *first.get_or_insert(record.time_us);
        count += 1;
        if !each(
            Duration::from_micros(record.time_us.saturating_sub(t0)),
            &record,
        )? {
            break;
        }
    }
    Ok(count)
}

/// When each packet of a replay is due: the first at once, every later one
/// as long after it as in the log, divided by the speed.
#[derive(Debug, Clone)]
pub struct Pacer {
    start: Instant,
    speed: f64,
    first: Option<Duration>,
}

impl Pacer {
    /// A replay starting at `start`, `speed` times faster than the log (2: twice as fast).
    ///
    /// # Panics
    ///
    /// If `speed` is not a positive, finite number.
    pub fn new(start: Instant, speed: f64) -> Pacer {
        assert!(speed.is_finite() && speed > 0.0, "speed {speed}");
        Pacer {
            start,
            speed,
            first: None,
        }
    }

    /// Makes the packet logged `since` after the log's first record due at
    /// `at`, and every later one as long after it as in the log (over the
    /// speed): the time before it is skipped.
    pub fn restart(&mut self, since: Duration, at: Instant) {
        self.start = at;
        self.first = Some(since);
    }

    /// When the packet logged `since` after the log's first record is due.
    pub fn due(&mut self, since: Duration) -> Instant {
        let offset = since.saturating_sub(*self.first.get_or_insert(since));
        // A tiny speed stretches the log past what an Instant can hold: such a packet
        // is due so far ahead that a century will do.
        Duration::try_from_secs_f64(offset.as_secs_f64() / self.speed)
            .ok()
            .and_then(|d| self.start.checked_add(d))
            .unwrap_or_else(|| self.start + FAR)
    }
}

/// Later than any replay will run.
const FAR: Duration = Duration::from_secs(100 * 365 * 24 * 3600);

/// What to publish again, and how fast.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// How many times faster than real time (2 is twice as fast).
    pub speed: f64,
    /// Only packets on these channels (all when empty).
    pub channels: Vec<String>,
    /// The longest wait for a packet (at the replay's speed): a log may hold a
    /// silence of hours, or a forged record time a century ahead, and a longer
    /// gap is skipped, the next packet published at once.
    pub max_gap: Duration,
}

/// A gap in a log longer than [`ReplayOptions::max_gap`], skipped.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedGap {
    /// When the packet after the gap was logged, since the log's first record.
    pub at: Duration,
    /// How long the log was silent before it (on the channels replayed), in the log's time.
    pub gap: Duration,
}

/// How long a wait sleeps before it looks at the stop flag again: short
/// enough that Ctrl-C seems to act at once.
const STOP_CHECK: Duration = Duration::from_millis(50);

/// Sleeps until `due`, or until `stop` is set; whether `due` came first.
fn wait_until(due: Instant, stop: &AtomicBool) -> bool {
    loop {
        if stop.load(Ordering::Relaxed) {
            return false;
        }
        let now = Instant::now();
        if now >= due {
            return true;
        }
        std::thread::sleep((due - now).min(STOP_CHECK));
    }
}

/// What a replay did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Replayed {
    /// Packets published.
    pub sent: u64,
    /// Records read, published or not.
    pub records: u64,
    /// The log's torn tail, if it has one.
    pub torn: Option<TornTail>,
}

/// Publishes the log at `path` again through `publish`, each packet when its
/// time comes (sleeping in between), until the log ends or `stop` is set;
/// `skipped` hears of each gap longer than [`ReplayOptions::max_gap`].
/// Control requests belonged to their senders and are left out, as are
/// records that are not packets.
pub fn replay<E: From<LogError>>(
    path: impl AsRef<Path>,
    options: &ReplayOptions,
    stop: &AtomicBool,
    publish: impl FnMut(&[u8]) -> Result<(), E>,
    skipped: impl FnMut(&SkippedGap),
) -> Result<Replayed, E> {
    let mut reader = LogReader::open(path)?;
    let (sent, records) = replay_records(
        reader.by_ref().map(|r| r.map_err(E::from)),
        options,
        stop,
        publish,
        skipped,
    )?;
    Ok(Replayed {
        sent,
        records,
        torn: reader.torn_tail().cloned(),
    })
}

/// [`replay`] over records from any reader (a `.clog` [`LogReader`],
/// colony-mcap's reader). Returns the packets published and the records read.
pub fn replay_records<E>(
    records: impl Iterator<Item = Result<Record, E>>,
    options: &ReplayOptions,
    stop: &AtomicBool,
    mut publish: impl FnMut(&[u8]) -> Result<(), E>,
    mut skipped: impl FnMut(&SkippedGap),
) -> Result<(u64, u64), E> {
    let mut pacer = Pacer::new(Instant::now(), options.speed);
    let mut last: Option<Duration> = None;
    let mut sent = 0;
    let records = for_each_timed_in(records, |since, record| {
        if stop.load(Ordering::Relaxed) {
            return Ok(false);
        }
        let Ok(packet) = Packet::parse(&record.payload) else {
            return Ok(true);
        };
        if packet.has_subject(HUB_SUBJECT) || !on_channels(&packet, &options.channels) {
            return Ok(true);
        }
        let mut due = pacer.due(since);
        let now = Instant::now();
        if due.saturating_duration_since(now) > options.max_gap {
            skipped(&SkippedGap {
                at: since,
                gap: since.saturating_sub(last.unwrap_or(since)),
            });
            pacer.restart(since, now);
            due = now;
        }
        if !wait_until(due, stop) {
            return Ok(false);
        }
        publish(&record.payload)?;
        last = Some(since);
        sent += 1;
        Ok(true)
    })?;
    Ok((sent, records))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tiny_speed_puts_later_packets_far_ahead_without_overflowing() {
        let start = Instant::now();
        let mut p = Pacer::new(start, 1e-310);
        assert_eq!(p.due(Duration::from_secs(5)), start);
        assert_eq!(p.due(Duration::from_secs(6)), start + FAR);
    }

    #[test]
    fn the_first_packet_is_due_at_once_and_the_rest_at_their_spacing_over_the_speed() {
        let start = Instant::now();
        let mut p = Pacer::new(start, 2.0);
        assert_eq!(p.due(Duration::from_secs(5)), start);
        assert_eq!(
            p.due(Duration::from_secs(7)),
            start + Duration::from_secs(1)
        );
        assert_eq!(
            p.due(Duration::from_secs(11)),
            start + Duration::from_secs(3)
        );
    }

    #[test]
    fn channels_filter_by_any_subject() {
        let p = Packet::parse(b"@ <a> <b> 0\nx y 1\n").unwrap();
        assert!(on_channels(&p, &[]));
        assert!(on_channels(&p, &["b".to_string()]));
        assert!(!on_channels(&p, &["c".to_string()]));
    }

    #[test]
    fn a_replay_publishes_the_logged_traffic_but_not_control_requests() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.log");
        let (mut w, _) = crate::log::LogWriter::open(&path).unwrap();
        let src = "127.0.0.1:5".parse().unwrap();
        let t0 = std::time::UNIX_EPOCH + Duration::from_secs(100);
        w.append(t0, src, b"@ <a> 0\nx y 1\n").unwrap();
        w.append(t0, src, b"@ <hub> 0\nstatus\n").unwrap();
        w.append(t0 + Duration::from_millis(10), src, b"@ <b> 0\nx y 2\n")
            .unwrap();
        w.flush().unwrap();
        let mut got = Vec::new();
        let stop = AtomicBool::new(false);
        let options = ReplayOptions {
            speed: 100.0,
            channels: Vec::new(),
            max_gap: Duration::from_secs(10),
        };
        let r = replay(
            &path,
            &options,
            &stop,
            |p| {
                got.push(p.to_vec());
                Ok::<(), LogError>(())
            },
            |g| panic!("no gap to skip: {g:?}"),
        )
        .unwrap();
        assert_eq!(r.sent, 2);
        assert_eq!(got[1], b"@ <b> 0\nx y 2\n");
    }

    fn record(at: Duration, payload: &[u8]) -> Result<Record, LogError> {
        Ok(Record {
            time_us: at.as_micros() as u64,
            source: "127.0.0.1:5".to_string(),
            payload: payload.to_vec(),
        })
    }

    #[test]
    fn a_gap_longer_than_the_bound_is_skipped_and_said() {
        let century = Duration::from_secs(100 * 365 * 24 * 3600);
        let records = vec![
            record(Duration::ZERO, b"@ <a> 0\nx y 1\n"),
            record(century, b"@ <a> 0\nx y 2\n"),
            record(century + Duration::from_millis(20), b"@ <a> 0\nx y 3\n"),
        ];
        let options = ReplayOptions {
            speed: 1.0,
            channels: Vec::new(),
            max_gap: Duration::from_secs(1),
        };
        let mut gaps = Vec::new();
        let mut sent = Vec::new();
        let (n, _) = replay_records(
            records.into_iter(),
            &options,
            &AtomicBool::new(false),
            |p| {
                sent.push(p.to_vec());
                Ok(())
            },
            |g| gaps.push(g.clone()),
        )
        .unwrap();
        assert_eq!(n, 3);
        assert_eq!(sent.len(), 3);
        assert_eq!(
            gaps,
            [SkippedGap {
                at: century,
                gap: century
            }]
        );
    }

    #[test]
    fn a_wait_ends_when_the_stop_flag_is_set() {
        let stop = std::sync::Arc::new(AtomicBool::new(false));
        let s = stop.clone();
        let setter = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(100));
            s.store(true, Ordering::Relaxed);
        });
        // An hour's wait: the test would hang, not fail, if the flag went unseen.
        assert!(!wait_until(
            Instant::now() + Duration::from_secs(3600),
            &stop
        ));
        setter.join().unwrap();
        assert!(wait_until(Instant::now(), &AtomicBool::new(false)));
    }
}
