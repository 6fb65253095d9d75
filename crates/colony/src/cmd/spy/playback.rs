//! Playing a traffic log, with no file and no clock of its own: which records are due when,
//! and where the log's clock stands, paused, resumed and moved.
//!
//! Two clocks meet here, both as a [`Duration`]: the wall's (since an origin of the caller's
//! choosing) and the log's (since its first record). Playing, the log's clock runs at `speed`
//! times the wall's from where it was last set; paused, it stands, so the paused time counts
//! nowhere (the spy's rates are over the log's clock). A seek sets it: the records up to the
//! target are taken at once (the caller draws nothing meanwhile), then it runs on from there.
//! A log is read forward only, so a seek back starts it again from its first record and
//! fast-forwards: the caller opens it again. Either way the work is bounded as playing is, by
//! the records taken per call.

use std::fmt::Display;
use std::time::Duration;

use colony_hub::log::Record;
use colony_wire::{Packet, HUB_SUBJECT};

use super::model::{Action, Feed, LogState, Seek, Spy};

/// How far Left and Right move a log's clock.
pub const SEEK_STEP: Duration = Duration::from_secs(10);
/// Later than any log plays: a tiny speed stretches a log past what a `Duration` holds.
const FAR: Duration = Duration::from_secs(100 * 365 * 24 * 3600);

/// A log's clock against the wall's.
#[derive(Debug, Clone)]
pub struct Clock {
    speed: f64,
    /// The wall's time when the log's clock stood at `log0`, when it was last set.
    wall0: Duration,
    log0: Duration,
    paused: bool,
    /// Every record up to `log0` is being taken at once.
    seeking: bool,
    /// The log's last record, once it was read to its end: the clock stops there.
    end: Option<Duration>,
}

impl Clock {
    /// A clock at the log's start, running `speed` times the wall's from the wall's zero.
    pub fn new(speed: f64) -> Clock {
        Clock {
            speed,
            wall0: Duration::ZERO,
            log0: Duration::ZERO,
            paused: false,
            seeking: false,
            end: None,
        }
    }

    /// The log's time at `wall`.
    pub fn now(&self, wall: Duration) -> Duration {
        let t = if self.paused || self.seeking {
            self.log0
        } else {
            self.log0.saturating_add(scaled(
                wall.saturating_sub(self.wall0).as_secs_f64() * self.speed,
            ))
        };
        self.end.map_or(t, |end| t.min(end))
    }

    pub fn paused(&self) -> bool {
        self.paused
    }

    /// The target of the seek under way, if one is.
    pub fn seeking(&self) -> Option<Duration> {
        self.seeking.then_some(self.log0)
    }

    /// Stops the clock where it is at `wall`, or lets it run on from there.
    pub fn set_paused(&mut self, paused: bool, wall: Duration) {
        if paused == self.paused {
            return;
        }
        if paused {
            self.log0 = self.now(wall);
        } else {
            self.wall0 = wall;
        }
        self.paused = paused;
    }

    /// When, on the wall's clock, the record logged at `since` is due (playing, not paused).
    fn due(&self, since: Duration) -> Duration {
        let ahead = since.saturating_sub(self.log0).as_secs_f64() / self.speed;
        self.wall0.saturating_add(scaled(ahead))
    }

    /// Sets the clock by `seek` at `wall`, from where it stands (or from the target of a seek
    /// under way), no further than the log's end once known; `taken`: how far into the log
    /// the records taken go (the spy's clock). Whether the log must be read again from its
    /// start: the target is before what was taken.
    pub fn seek(&mut self, seek: Seek, wall: Duration, taken: Duration) -> bool {
        let at = self.now(wall);
        let to = match seek {
            Seek::Forward => at.saturating_add(SEEK_STEP),
            Seek::Back => at.saturating_sub(SEEK_STEP),
            Seek::Start => Duration::ZERO,
        };
        let to = self.end.map_or(to, |end| to.min(end));
        let restart = to < taken;
        if restart {
            self.end = None;
        }
        self.log0 = to;
        self.wall0 = wall;
        // Read up to the target, unless the log was read to its end already.
        self.seeking = self.end.is_none();
        restart
    }

    /// The seek is done: the clock runs on from its target from `wall` on.
    fn reached(&mut self, wall: Duration) {
        self.seeking = false;
        self.wall0 = wall;
    }

    /// The log was read to its end, or as far as it could be, its last record at `last`.
    fn ended(&mut self, last: Duration) {
        self.end = Some(last);
        self.seeking = false;
    }
}

/// `secs` seconds as a duration, or one too far for any log when there is none.
fn scaled(secs: f64) -> Duration {
    Duration::try_from_secs_f64(secs).unwrap_or(FAR)
}

/// What [`Player::play`] left.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Played {
    /// Call again at this wall time (at once if it has passed), or after a key.
    Wait(Option<Duration>),
    /// The records ran out: the log is played to its end (the caller says with what damage).
    Ended,
}

/// A log being played into a spy: its clock and the next record, read but not yet due.
#[derive(Debug, Clone)]
pub struct Player {
    pub clock: Clock,
    pending: Option<(Duration, Record)>,
    /// The first record's time, in microseconds: the log's clock counts from it.
    first: Option<u64>,
}

impl Player {
    pub fn new(speed: f64) -> Player {
        Player {
            clock: Clock::new(speed),
            pending: None,
            first: None,
        }
    }

    /// Whether a seek is under way (the caller draws nothing until it is done).
    pub fn seeking(&self) -> bool {
        self.clock.seeking().is_some()
    }

    /// Takes into `spy` the records of `records` due at `wall` (every one up to a seek's
    /// target), at most `budget` of them, and sets the spy's clock to the log's.
    pub fn play<E: Display>(
        &mut self,
        spy: &mut Spy,
        records: &mut impl Iterator<Item = Result<Record, E>>,
        wall: Duration,
        budget: usize,
    ) -> Played {
        self.clock.set_paused(spy.paused(), wall);
        if !playing(spy) {
            return Played::Wait(None);
        }
        let mut taken = 0;
        let next = loop {
            if taken >= budget {
                break Some(wall);
            }
            if self.pending.is_none() {
                match records.next() {
                    Some(Ok(r)) => {
                        let t0 = *self.first.get_or_insert(r.time_us);
                        let since = Duration::from_micros(r.time_us.saturating_sub(t0));
                        self.pending = Some((since, r));
                    }
                    Some(Err(e)) => {
                        self.fail(spy, e.to_string());
                        return Played::Wait(None);
                    }
                    None => {
                        self.finish(spy);
                        return Played::Ended;
                    }
                }
            }
            let Some((since, _)) = &self.pending else {
                break None;
            };
            if let Some(target) = self.clock.seeking() {
                if *since > target {
                    self.clock.reached(wall);
                    spy.set_now(target);
                    spy.set_seeking(None);
                    continue;
                }
            } else if self.clock.paused() {
                break None;
            } else {
                let due = self.clock.due(*since);
                if due > wall {
                    break Some(due);
                }
            }
            let (since, record) = self.pending.take().expect("a pending record");
            take_record(spy, since, &record);
            taken += 1;
        };
        // The log's clock runs at its pace, never past the next record.
        if !self.seeking() {
            let mut now = self.clock.now(wall);
            if let Some((since, _)) = &self.pending {
                now = now.min(*since);
            }
            spy.set_now(now);
        }
        Played::Wait(next)
    }

    /// Acts on what a key asked, at `wall`: the clock pauses as the spy does, and a seek sets
    /// it. Whether the log must be read again from its start (the spy forgot what it took;
    /// the caller opens the log again and plays that).
    pub fn on_action(&mut self, spy: &mut Spy, action: Action, wall: Duration) -> bool {
        self.clock.set_paused(spy.paused(), wall);
        let Action::Seek(seek) = action else {
            return false;
        };
        let restart = self.clock.seek(seek, wall, spy.now());
        if restart {
            self.pending = None;
            self.first = None;
            spy.restart();
            set_log_state(spy, LogState::Playing);
        }
        spy.set_seeking(self.clock.seeking());
        restart
    }

    /// The log cannot be read (further): the spy says why, and the clock stops.
    pub fn fail(&mut self, spy: &mut Spy, why: String) {
        set_log_state(spy, LogState::Failed(why));
        self.finish(spy);
    }

    fn finish(&mut self, spy: &mut Spy) {
        self.pending = None;
        self.clock.ended(spy.now());
        spy.set_seeking(None);
    }
}

fn playing(spy: &Spy) -> bool {
    matches!(
        spy.feed,
        Feed::Log {
            state: LogState::Playing,
            ..
        }
    )
}

pub fn set_log_state(spy: &mut Spy, new: LogState) {
    if let Feed::Log { state, .. } = &mut spy.feed {
        *state = new;
    }
}

/// A logged datagram, as a tap would have received it: control requests belonged to their
/// senders and never reached a tap, so they are left out, as a replay leaves them out.
fn take_record(spy: &mut Spy, since: Duration, record: &Record) {
    match Packet::parse(&record.payload) {
        Ok(p) if p.has_subject(HUB_SUBJECT) => spy.set_now(since),
        Ok(p) => spy.on_packet(since, &p),
        Err(_) => spy.on_datagram(since, &record.payload),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::spy::model::Key;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    /// A log of `seconds` with a packet on `a` every 10 ms, from a first record at an
    /// arbitrary epoch time.
    fn log(seconds: u64) -> Vec<Record> {
        (0..seconds * 100)
            .map(|i| Record {
                time_us: 1_700_000_000_000_000 + i * 10_000,
                source: "127.0.0.1:5".into(),
                payload: format!("@ <a> 0\nv n {i}\n").into_bytes(),
            })
            .collect()
    }

    type Records = std::vec::IntoIter<Result<Record, String>>;

    fn records(seconds: u64) -> Records {
        log(seconds)
            .into_iter()
            .map(Ok)
            .collect::<Vec<_>>()
            .into_iter()
    }

    fn spy(speed: f64) -> Spy {
        Spy::new(
            Feed::Log {
                file: "t.clog".into(),
                speed,
                state: LogState::Playing,
            },
            Duration::from_secs(1),
        )
    }

    /// Plays from wall time `from` to `to` in steps of 20 ms, as the loop would.
    fn play(p: &mut Player, s: &mut Spy, r: &mut Records, from: u64, to: u64) -> Played {
        let mut last = Played::Wait(None);
        let mut t = from;
        while t <= to {
            last = p.play(s, r, ms(t), 20_000);
            t += 20;
        }
        last
    }

    fn key(p: &mut Player, s: &mut Spy, r: &mut Records, k: Key, wall: u64, seconds: u64) {
        let action = s.on_key(k);
        if p.on_action(s, action, ms(wall)) {
            *r = records(seconds);
        }
    }

    fn rate(s: &Spy) -> f64 {
        s.channel("a").unwrap().rates(s.now()).unwrap().0
    }

    #[test]
    fn paused_time_counts_nowhere_and_playing_goes_on_from_where_it_stopped() {
        for speed in [1.0, 2.0] {
            let (mut p, mut s, mut r) = (Player::new(speed), spy(speed), records(60));
            play(&mut p, &mut s, &mut r, 0, 5000);
            let at = s.now();
            assert!((at.as_secs_f64() - 5.0 * speed).abs() < 0.05, "{at:?}");
            key(&mut p, &mut s, &mut r, Key::Pause, 5000, 60);
            assert!(s.paused() && p.clock.paused());
            let seen = s.seen();
            // A long pause: nothing taken, the clock stands, the rates stay.
            play(&mut p, &mut s, &mut r, 5000, 105_000);
            assert_eq!(s.now(), at);
            assert_eq!(s.seen(), seen);
            assert!((rate(&s) - 100.0).abs() < 5.0, "{}", rate(&s));
            key(&mut p, &mut s, &mut r, Key::Pause, 105_000, 60);
            assert!(!s.paused());
            play(&mut p, &mut s, &mut r, 105_000, 107_000);
            // Two more seconds of the wall, as if the pause had never been.
            let now = s.now().as_secs_f64();
            assert!((now - 7.0 * speed).abs() < 0.05, "{now}");
            assert!((rate(&s) - 100.0).abs() < 5.0, "{}", rate(&s));
            assert_eq!(s.seen() as f64, (now * 100.0).floor() + 1.0);
        }
    }

    #[test]
    fn seeks_go_10_s_either_way_back_to_the_start_and_no_further_than_the_end() {
        let (mut p, mut s, mut r) = (Player::new(1.0), spy(1.0), records(30));
        play(&mut p, &mut s, &mut r, 0, 5000);
        assert_eq!(s.now(), ms(5000));
        // On: every record up to 15 s is taken at once, with no time passing.
        key(&mut p, &mut s, &mut r, Key::Right, 5000, 30);
        assert_eq!(s.seeking(), Some(ms(15_000)));
        assert!(p.seeking());
        assert_eq!(
            p.play(&mut s, &mut r, ms(5000), 20_000),
            Played::Wait(Some(ms(5010)))
        );
        assert!(!p.seeking() && s.seeking().is_none());
        assert_eq!(s.now(), ms(15_000));
        assert_eq!(s.seen(), 1501);
        assert!((rate(&s) - 100.0).abs() < 5.0, "{}", rate(&s));
        // It plays on from there.
        play(&mut p, &mut s, &mut r, 5000, 6000);
        assert_eq!(s.now(), ms(16_000));
        // Back: the log starts again, and what was before 6 s is taken again, at once.
        key(&mut p, &mut s, &mut r, Key::Left, 6000, 30);
        assert_eq!(s.seen(), 0);
        assert_eq!(s.seeking(), Some(ms(6000)));
        play(&mut p, &mut s, &mut r, 6000, 6000);
        assert_eq!((s.now(), s.seen()), (ms(6000), 601));
        assert!((rate(&s) - 100.0).abs() < 5.0, "{}", rate(&s));
        // Twice on at once is 20 s on.
        key(&mut p, &mut s, &mut r, Key::Right, 6000, 30);
        key(&mut p, &mut s, &mut r, Key::Right, 6000, 30);
        assert_eq!(s.seeking(), Some(ms(26_000)));
        play(&mut p, &mut s, &mut r, 6000, 6000);
        assert_eq!(s.now(), ms(26_000));
        // Past the end: it stops at the last record.
        key(&mut p, &mut s, &mut r, Key::Right, 6000, 30);
        assert_eq!(play(&mut p, &mut s, &mut r, 6000, 6000), Played::Ended);
        set_log_state(&mut s, LogState::Ended(None));
        assert_eq!((s.now(), s.seen()), (ms(29_990), 3000));
        key(&mut p, &mut s, &mut r, Key::Right, 7000, 30);
        assert!(!p.seeking());
        play(&mut p, &mut s, &mut r, 7000, 9000);
        assert_eq!(s.now(), ms(29_990));
        // Back from the end: 10 s before the last record, playing again.
        key(&mut p, &mut s, &mut r, Key::Left, 9000, 30);
        play(&mut p, &mut s, &mut r, 9000, 9000);
        assert_eq!(s.now(), ms(19_990));
        assert!(matches!(
            s.feed,
            Feed::Log {
                state: LogState::Playing,
                ..
            }
        ));
        // Home: from the start, at its pace.
        key(&mut p, &mut s, &mut r, Key::Home, 9000, 30);
        play(&mut p, &mut s, &mut r, 9000, 10_000);
        assert_eq!((s.now(), s.seen()), (ms(1000), 101));
        // Back at the start stays at the start.
        key(&mut p, &mut s, &mut r, Key::Home, 10_000, 30);
        key(&mut p, &mut s, &mut r, Key::Left, 10_000, 30);
        play(&mut p, &mut s, &mut r, 10_000, 10_000);
        assert_eq!((s.now(), s.seen()), (ms(0), 1));
    }

    #[test]
    fn a_seek_while_paused_stays_paused_and_a_long_one_is_taken_a_budget_at_a_time() {
        let (mut p, mut s, mut r) = (Player::new(1.0), spy(1.0), records(60));
        play(&mut p, &mut s, &mut r, 0, 2000);
        key(&mut p, &mut s, &mut r, Key::Pause, 2000, 60);
        key(&mut p, &mut s, &mut r, Key::Right, 3000, 60);
        key(&mut p, &mut s, &mut r, Key::Right, 3000, 60);
        key(&mut p, &mut s, &mut r, Key::Right, 3000, 60);
        // 3000 records to take, 500 a call: each call asks to be called again at once.
        for _ in 0..6 {
            assert_eq!(
                p.play(&mut s, &mut r, ms(3000), 500),
                Played::Wait(Some(ms(3000)))
            );
            assert!(p.seeking());
        }
        p.play(&mut s, &mut r, ms(3000), 500);
        assert!(!p.seeking());
        assert_eq!((s.now(), s.seen()), (ms(32_000), 3201));
        play(&mut p, &mut s, &mut r, 3000, 9000);
        assert_eq!((s.now(), s.seen()), (ms(32_000), 3201));
        assert!(s.paused());
        key(&mut p, &mut s, &mut r, Key::Pause, 9000, 60);
        play(&mut p, &mut s, &mut r, 9000, 10_000);
        assert_eq!(s.now(), ms(33_000));
    }

    #[test]
    fn a_log_that_fails_stops_its_clock_and_a_seek_back_tries_it_again() {
        let (mut p, mut s) = (Player::new(1.0), spy(1.0));
        let mut r = log(1)
            .into_iter()
            .map(Ok)
            .chain([Err("record at byte 99 is corrupt".to_string())])
            .collect::<Vec<_>>()
            .into_iter();
        play(&mut p, &mut s, &mut r, 0, 3000);
        assert!(matches!(
            &s.feed,
            Feed::Log { state: LogState::Failed(why), .. } if why.contains("corrupt")
        ));
        assert_eq!(s.now(), ms(990));
        key(&mut p, &mut s, &mut r, Key::Right, 3000, 1);
        assert!(!p.seeking(), "no seek waits on a log that cannot be read");
        key(&mut p, &mut s, &mut r, Key::Home, 3000, 1);
        play(&mut p, &mut s, &mut r, 3000, 3500);
        assert_eq!(s.now(), ms(500));
    }
}
