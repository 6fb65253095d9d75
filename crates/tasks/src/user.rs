//! The user agent: introduces tasks on a person's behalf and, when one is
//! unachievable, introduces it again after a randomized exponential backoff
//! until it is allocated or its deadline passes.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::time::Duration;

use colony_wire::{Packet, Subject};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::announcer::{Announcer, AnnouncerEvent, AuctionConfig};
use crate::protocol::Token;
use crate::protocol::{SpecError, TaskSpec};
use colony_node::Node;
use colony_node::Time;

/// How a user agent retries.
#[derive(Debug, Clone, PartialEq)]
pub struct Backoff {
    /// The first wait after an unachievable report.
    pub initial: Duration,
    /// The longest wait before the jitter (which can stretch it by half).
    pub max: Duration,
    /// A task not allocated this long after it was introduced is given up.
    pub give_up_after: Duration,
}

impl Default for Backoff {
    fn default() -> Self {
        Backoff {
            initial: Duration::from_secs(1),
            max: Duration::from_secs(60),
            give_up_after: Duration::from_secs(600),
        }
    }
}

impl Backoff {
    /// The wait before try `tries + 1`, after `tries` unachievable reports:
    /// `initial · 2^(tries-1)`, at most `max`, times a factor drawn uniformly
    /// from [0.5, 1.5) so that user agents that failed together do not all come
    /// back together. A wait too long for a [`Duration`] is [`Duration::MAX`].
    pub fn delay(&self, tries: u32, rng: &mut impl Rng) -> Duration {
        let doubling = 2f64.powi(tries.saturating_sub(1).min(60) as i32);
        let base = (self.initial.as_secs_f64() * doubling).min(self.max.as_secs_f64());
        // With a `max` near `Duration::MAX` the jitter can carry the wait past it,
        // where `Duration::from_secs_f64` would panic.
        Duration::try_from_secs_f64(base * rng.random_range(0.5..1.5)).unwrap_or(Duration::MAX)
    }
}

/// What became of a request.
#[derive(Debug, Clone, PartialEq)]
pub enum UserEvent {
    /// A robot took the request's task (after `tries` introductions).
    Allocated {
        /// The request.
        request: u64,
        /// Who took it.
        winner: Token,
        /// How many times it was introduced.
        tries: u32,
    },
    /// The task was done.
    Completed {
        /// The request.
        request: u64,
        /// Who did it.
        winner: Token,
    },
    /// The task was unachievable; it will be introduced again after `retry_in`.
    Unachievable {
        /// The request.
        request: u64,
        /// The announcer's reason.
        reason: String,
        /// When it will be tried again.
        retry_in: Duration,
    },
    /// The deadline passed; the request is dropped.
    GaveUp {
        /// The request.
        request: u64,
        /// The last reason heard.
        reason: String,
    },
    /// Everything the announcer underneath reports, for logs.
    Auction {
        /// The request the task belongs to.
        request: u64,
        /// What happened.
        event: AnnouncerEvent,
    },
}

#[derive(Debug)]
struct Request {
    spec: TaskSpec,
    give_up_at: Time,
    tries: u32,
    task: Option<u64>,
    retry_at: Option<Time>,
    allocated: bool,
}

/// A user's persistent agent: it wraps an [`Announcer`], and turns its
/// unachievable reports into retries with randomized exponential backoff.
///
/// ```
/// use std::time::Duration;
/// use colony_tasks::{Backoff, Bus, Node, TaskSpec, Time, Token, UserAgent, UserEvent};
/// let mut user = UserAgent::new(Token::new("user").unwrap(), Default::default(),
///     Backoff::default(), 7);
/// let r = user.introduce(Time::ZERO, TaskSpec::new("fly", "wings".parse().unwrap())).unwrap();
/// let mut bus = Bus::new(Duration::from_millis(1));
/// bus.run_until(&mut [&mut user], Time::from_secs_f64(0.5));
/// let events: Vec<_> = std::iter::from_fn(|| user.poll_event()).collect();
/// assert!(events.iter().any(|e| matches!(e,
///     UserEvent::Unachievable { request, reason, .. }
///         if *request == r && reason == "no robot with {wings} is available")));
/// ```
#[derive(Debug)]
pub struct UserAgent {
    announcer: Announcer,
    backoff: Backoff,
    rng: ChaCha8Rng,
    next_request: u64,
    requests: BTreeMap<u64, Request>,
    by_task: BTreeMap<u64, u64>,
    events: VecDeque<UserEvent>,
}

impl UserAgent {
    /// A user agent announcing as `token`; `seed` fixes its backoff's jitter.
    pub fn new(token: Token, auction: AuctionConfig, backoff: Backoff, seed: u64) -> UserAgent {
        UserAgent {
            announcer: Announcer::new(token, auction),
            backoff,
            rng: ChaCha8Rng::seed_from_u64(seed),
            next_request: 1,
            requests: BTreeMap::new(),
            by_task: BTreeMap::new(),
            events: VecDeque::new(),
        }
    }

    /// The announcer underneath.
    pub fn announcer(&self) -> &Announcer {
        &self.announcer
    }

    /// Introduces a task now; returns the request's number.
    pub fn introduce(&mut self, now: Time, spec: TaskSpec) -> Result<u64, SpecError> {
        spec.validate()?;
        let request = self.next_request;
        self.next_request += 1;
        self.requests.insert(
            request,
            Request {
                spec,
                give_up_at: now + self.backoff.give_up_after,
                tries: 0,
                task: None,
                retry_at: Some(now),
                allocated: false,
            },
        );
        self.retry_due(now);
        Ok(request)
    }

    /// Requests not yet completed or given up.
    pub fn open_requests(&self) -> usize {
        self.requests.len()
    }

    /// The next thing that happened.
    pub fn poll_event(&mut self) -> Option<UserEvent> {
        self.events.pop_front()
    }

    fn retry_due(&mut self, now: Time) {
        let due: Vec<u64> = self
            .requests
            .iter()
            .filter(|(_, r)| r.retry_at.is_some_and(|t| t <= now))
            .map(|(id, _)| *id)
            .collect();
        for id in due {
            let Some(r) = self.requests.get_mut(&id) else {
                continue;
            };
            r.retry_at = None;
            r.tries += 1;
            match self.announcer.announce(now, r.spec.clone()) {
                Ok(task) => {
                    r.task = Some(task);
                    self.by_task.insert(task, id);
                }
                Err(e) => {
                    self.requests.remove(&id);
                    self.events.push_back(UserEvent::GaveUp {
                        request: id,
                        reason: e.to_string(),
                    });
                }
            }
        }
        self.pump(now);
    }

    /// Turns the announcer's events into the user's.
    fn pump(&mut self, now: Time) {
        while let Some(event) = self.announcer.poll_event() {
            let task = match &event {
                AnnouncerEvent::Announced { task, .. }
                | AnnouncerEvent::Bid { task, .. }
                | AnnouncerEvent::Awarded { task, .. }
                | AnnouncerEvent::Started { task, .. }
                | AnnouncerEvent::Completed { task, .. }
                | AnnouncerEvent::WinnerLost { task, .. }
                | AnnouncerEvent::Unachievable { task, .. }
                | AnnouncerEvent::Cancelled { task } => *task,
            };
            let Some(&request) = self.by_task.get(&task) else {
                continue;
            };
            self.events.push_back(UserEvent::Auction {
                request,
                event: event.clone(),
            });
            let Some(r) = self.requests.get_mut(&request) else {
                continue;
            };
            match event {
                AnnouncerEvent::Started { winner, .. } if !r.allocated => {
                    r.allocated = true;
                    self.events.push_back(UserEvent::Allocated {
                        request,
                        winner,
                        tries: r.tries,
                    });
                }
                AnnouncerEvent::Completed { winner, .. } => {
                    self.requests.remove(&request);
                    self.by_task.remove(&task);
                    self.events
                        .push_back(UserEvent::Completed { request, winner });
                }
                AnnouncerEvent::Unachievable { reason, .. } => {
                    self.by_task.remove(&task);
                    r.task = None;
                    let wait = self.backoff.delay(r.tries, &mut self.rng);
                    if now + wait > r.give_up_at {
                        self.requests.remove(&request);
                        self.events.push_back(UserEvent::GaveUp { request, reason });
                    } else {
                        r.retry_at = Some(now + wait);
                        self.events.push_back(UserEvent::Unachievable {
                            request,
                            reason,
                            retry_in: wait,
                        });
                    }
                }
                _ => {}
            }
        }
    }
}

impl Node for UserAgent {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        self.announcer.subscriptions()
    }

    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
        self.announcer.handle_packet(now, packet);
        self.pump(now);
    }

    fn handle_timeout(&mut self, now: Time) {
        if self.announcer.poll_timeout().is_some_and(|t| t <= now) {
            self.announcer.handle_timeout(now);
        }
        self.pump(now);
        self.retry_due(now);
    }

    fn poll_timeout(&self) -> Option<Time> {
        let retries = self.requests.values().filter_map(|r| r.retry_at);
        retries.chain(self.announcer.poll_timeout()).min()
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.announcer.poll_transmit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::announcer::TaskPhase;
    use crate::protocol::negotiation_subject;
    use crate::protocol::{Bid, Message, Negotiation};

    fn token(s: &str) -> Token {
        Token::new(s).unwrap()
    }

    fn t(ms: u64) -> Time {
        Time::from_micros(ms * 1000)
    }

    fn secs(s: f64) -> Duration {
        Duration::from_secs_f64(s)
    }

    fn backoff(initial: f64, max: f64, give_up_after: f64) -> Backoff {
        Backoff {
            initial: secs(initial),
            max: secs(max),
            give_up_after: secs(give_up_after),
        }
    }

    fn agent(b: Backoff) -> UserAgent {
        UserAgent::new(token("user"), AuctionConfig::default(), b, 11)
    }

    fn gripper() -> TaskSpec {
        TaskSpec::new("open-door", "gripper".parse().unwrap())
    }

    /// The announcements published, by task number.
    fn announced(u: &mut UserAgent) -> Vec<u64> {
        std::iter::from_fn(|| u.poll_transmit())
            .filter_map(|p| match Message::decode_bytes(&p).unwrap() {
                Message::Announce(a) => Some(a.id),
                Message::Negotiation { .. } | Message::Robot(_) => None,
            })
            .collect()
    }

    /// The user's own events, the announcer's left out.
    fn events(u: &mut UserAgent) -> Vec<UserEvent> {
        std::iter::from_fn(|| u.poll_event())
            .filter(|e| !matches!(e, UserEvent::Auction { .. }))
            .collect()
    }

    fn say(u: &mut UserAgent, now: Time, task: u64, m: Negotiation) {
        let by = crate::test_keys::speaker(&m, &token("user")).to_owned();
        let bytes = m
            .encode(&negotiation_subject(&token("user"), task, 1))
            .unwrap();
        let bytes = crate::test_keys::seal_as(&by, bytes);
        u.handle_packet(now, &Packet::parse(&bytes).unwrap());
    }

    #[test]
    fn the_wait_stays_within_half_to_one_and_a_half_of_the_doubling_base() {
        let b = backoff(1.0, 1000.0, 1e6);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for tries in 1..=8u32 {
            let base = 2f64.powi(tries as i32 - 1);
            let draws: Vec<f64> = (0..200)
                .map(|_| b.delay(tries, &mut rng).as_secs_f64())
                .collect();
            for d in &draws {
                assert!(
                    (0.5 * base..1.5 * base).contains(d),
                    "try {tries}: {d} outside [{}, {})",
                    0.5 * base,
                    1.5 * base
                );
            }
            // Jittered, and over the whole range rather than a corner of it.
            let (lo, hi) = draws
                .iter()
                .fold((f64::MAX, f64::MIN), |(lo, hi), d| (lo.min(*d), hi.max(*d)));
            assert!(
                lo < 0.7 * base && hi > 1.3 * base,
                "try {tries}: {lo}..{hi}"
            );
        }
    }

    #[test]
    fn each_try_doubles_the_wait_for_the_same_draw() {
        let b = backoff(0.25, 1000.0, 1e6);
        for tries in 1..10u32 {
            let rng = ChaCha8Rng::seed_from_u64(u64::from(tries));
            let this = b.delay(tries, &mut rng.clone());
            let next = b.delay(tries + 1, &mut rng.clone());
            let diff = next.abs_diff(this * 2);
            assert!(diff <= Duration::from_nanos(2), "{this:?} then {next:?}");
        }
    }

    #[test]
    fn the_first_two_tries_wait_from_the_initial_delay() {
        let b = backoff(2.0, 60.0, 1e6);
        let rng = ChaCha8Rng::seed_from_u64(5);
        assert_eq!(b.delay(0, &mut rng.clone()), b.delay(1, &mut rng.clone()));
        let d = b.delay(1, &mut rng.clone());
        assert!(d >= secs(1.0) && d < secs(3.0), "{d:?}");
    }

    #[test]
    fn the_base_stops_doubling_at_the_maximum() {
        let b = backoff(1.0, 10.0, 1e6);
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for tries in [5, 10, 64, u32::MAX] {
            for _ in 0..50 {
                let d = b.delay(tries, &mut rng);
                assert!(d >= secs(5.0) && d < secs(15.0), "try {tries}: {d:?}");
            }
        }
    }

    #[test]
    fn an_unbounded_maximum_saturates_instead_of_panicking() {
        let b = Backoff {
            initial: Duration::from_secs(1000),
            max: Duration::MAX,
            give_up_after: Duration::MAX,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        // Half the draws push the jittered wait past `Duration::MAX`.
        for _ in 0..64 {
            let d = b.delay(u32::MAX, &mut rng);
            assert!(d >= Duration::MAX / 2, "{d:?}");
        }
    }

    #[test]
    fn a_zero_initial_delay_retries_at_once() {
        let b = backoff(0.0, 10.0, 100.0);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        assert_eq!(b.delay(7, &mut rng), Duration::ZERO);
    }

    #[test]
    fn introducing_announces_at_once() {
        let mut u = agent(Backoff::default());
        let r = u.introduce(t(5), gripper()).unwrap();
        assert_eq!(r, 1);
        assert_eq!(announced(&mut u), [1]);
        assert_eq!(u.open_requests(), 1);
        assert_eq!(u.poll_timeout(), Some(t(205)));
        assert_eq!(u.announcer().phase(1), Some(TaskPhase::Bidding));
    }

    #[test]
    fn an_invalid_task_is_refused_and_takes_no_request_number() {
        let mut u = agent(Backoff::default());
        assert!(u.introduce(t(0), gripper().length(-1.0)).is_err());
        assert_eq!(u.open_requests(), 0);
        assert!(announced(&mut u).is_empty());
        assert_eq!(u.introduce(t(0), gripper()), Ok(1));
    }

    #[test]
    fn an_unachievable_task_is_retried_after_the_drawn_wait() {
        let mut u = agent(backoff(1.0, 60.0, 600.0));
        let r = u.introduce(t(0), gripper()).unwrap();
        announced(&mut u);
        u.handle_timeout(t(200));
        let ev = events(&mut u);
        let [UserEvent::Unachievable {
            request,
            reason,
            retry_in,
        }] = &ev[..]
        else {
            panic!("{ev:?}");
        };
        assert_eq!(*request, r);
        assert_eq!(reason, "no robot with {gripper} is available");
        assert!(
            *retry_in >= secs(0.5) && *retry_in < secs(1.5),
            "{retry_in:?}"
        );
        let retry_at = t(200) + *retry_in;
        assert_eq!(u.poll_timeout(), Some(retry_at));
        u.handle_timeout(retry_at);
        assert_eq!(announced(&mut u), [2], "introduced again as a new task");
    }

    #[test]
    fn each_further_failure_waits_about_twice_as_long() {
        let mut u = agent(backoff(1.0, 60.0, 600.0));
        u.introduce(t(0), gripper()).unwrap();
        let mut waits = Vec::new();
        while waits.len() < 5 {
            let now = u.poll_timeout().unwrap();
            u.handle_timeout(now);
            for e in events(&mut u) {
                if let UserEvent::Unachievable { retry_in, .. } = e {
                    waits.push(retry_in.as_secs_f64());
                }
            }
        }
        for (i, w) in waits.iter().enumerate() {
            let base = 2f64.powi(i as i32);
            assert!((0.5 * base..1.5 * base).contains(w), "wait {i}: {w}");
        }
    }

    #[test]
    fn it_gives_up_at_the_deadline_and_never_announces_past_it() {
        let give_up_at = t(10_000);
        let mut u = agent(backoff(1.0, 1.0, 10.0));
        let r = u.introduce(Time::ZERO, gripper()).unwrap();
        let mut last_announce = Time::ZERO;
        let mut gave_up = None;
        while let Some(now) = u.poll_timeout() {
            assert!(now <= give_up_at + secs(0.2), "still busy at {now}");
            u.handle_timeout(now);
            if !announced(&mut u).is_empty() {
                last_announce = now;
            }
            for e in events(&mut u) {
                if let UserEvent::GaveUp { request, reason } = e {
                    assert_eq!(request, r);
                    assert!(reason.contains("{gripper}"), "{reason}");
                    gave_up = Some(now);
                }
            }
        }
        let gave_up = gave_up.expect("it gave up");
        assert!(last_announce <= give_up_at, "announced at {last_announce}");
        // It gave up only because the next wait (at most 1.5 s) would pass the deadline.
        assert!(
            gave_up + secs(1.5) > give_up_at,
            "gave up early, at {gave_up}"
        );
        assert_eq!(u.open_requests(), 0);
    }

    #[test]
    fn an_allocated_task_is_reported_once_with_its_tries_then_completed() {
        let mut u = agent(backoff(1.0, 60.0, 600.0));
        let r = u.introduce(t(0), gripper()).unwrap();
        u.handle_timeout(t(200)); // unachievable
        let retry = u.poll_timeout().unwrap();
        u.handle_timeout(retry); // task 2
        events(&mut u);
        let bid = Negotiation::Bid(Bid {
            task: 2,
            bidder: token("r1"),
            score: 0.0,
        });
        say(&mut u, retry, 2, bid);
        u.handle_timeout(retry + secs(0.2));
        let ack = Negotiation::Ack {
            task: 2,
            bidder: token("r1"),
        };
        say(&mut u, retry + secs(0.3), 2, ack.clone());
        say(&mut u, retry + secs(0.4), 2, ack);
        assert_eq!(
            events(&mut u),
            [UserEvent::Allocated {
                request: r,
                winner: token("r1"),
                tries: 2
            }]
        );
        let done = Negotiation::Done {
            task: 2,
            bidder: token("r1"),
        };
        say(&mut u, retry + secs(1.0), 2, done);
        assert_eq!(
            events(&mut u),
            [UserEvent::Completed {
                request: r,
                winner: token("r1")
            }]
        );
        assert_eq!(u.open_requests(), 0);
        assert_eq!(u.poll_timeout(), None);
    }

    #[test]
    fn the_announcers_events_are_passed_on_with_the_request() {
        let mut u = agent(Backoff::default());
        let r = u.introduce(t(0), gripper()).unwrap();
        let ev: Vec<UserEvent> = std::iter::from_fn(|| u.poll_event()).collect();
        assert_eq!(
            ev,
            [UserEvent::Auction {
                request: r,
                event: AnnouncerEvent::Announced {
                    task: 1,
                    name: "open-door".into(),
                    attempt: 1
                }
            }]
        );
    }

    #[test]
    fn the_same_seed_draws_the_same_schedule() {
        let run = |seed| {
            let mut u = UserAgent::new(
                token("user"),
                AuctionConfig::default(),
                Backoff::default(),
                seed,
            );
            u.introduce(t(0), gripper()).unwrap();
            let mut waits = Vec::new();
            for _ in 0..4 {
                let now = u.poll_timeout().unwrap();
                u.handle_timeout(now);
                waits.extend(events(&mut u).into_iter().filter_map(|e| match e {
                    UserEvent::Unachievable { retry_in, .. } => Some(retry_in),
                    _ => None,
                }));
            }
            waits
        };
        assert_eq!(run(4), run(4));
        assert_ne!(run(4), run(5));
    }
}
