//! The user agent: introduces tasks on a person's behalf and, when one is
//! unachievable, introduces it again after a randomized exponential backoff
//! until it is allocated or its deadline passes.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::time::Duration;

use colony_wire::{Packet, Subject};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::announcer::{Announcer, AnnouncerEvent, AuctionConfig};
use crate::node::Node;
use crate::protocol::{SpecError, TaskSpec};
use crate::resource::Token;
use crate::time::Time;

/// How a user agent retries.
#[derive(Debug, Clone, PartialEq)]
pub struct Backoff {
    /// The first wait after an unachievable report.
    pub initial: Duration,
    /// The longest wait.
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
    /// back together.
    pub fn delay(&self, tries: u32, rng: &mut impl Rng) -> Duration {
        let doubling = 2f64.powi(tries.saturating_sub(1).min(60) as i32);
        let base = (self.initial.as_secs_f64() * doubling).min(self.max.as_secs_f64());
        Duration::from_secs_f64(base * rng.random_range(0.5..1.5))
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
