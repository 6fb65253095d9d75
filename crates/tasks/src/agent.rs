//! The robot's side of MURDOCH: listen, bid, win or withdraw, work, renew, charge.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::time::Duration;

use colony_proto::Vec2;
use colony_wire::{Packet, Subject};

use crate::metric::{Metrics, RobotView};
use crate::node::Node;
use crate::protocol::{Announcement, Bid, Message, Negotiation, MAX_MAGNITUDE};
use crate::protocol::{ResourceSet, Token, IDLE};
use crate::time::Time;
use colony_proto::DecodeError;

/// A robot's timings and thresholds.
#[derive(Debug, Clone, PartialEq)]
pub struct AgentConfig {
    /// How often the winner tells the announcer it is still at work.
    pub renew_interval: Duration,
    /// An announcer silent this long is presumed gone, and its task abandoned.
    pub renew_timeout: Duration,
    /// How long after an auction's deadline a bidder waits for the award
    /// before it decides the announcer is gone.
    pub award_grace: Duration,
    /// Below this charge (0 to 1), an idle robot leaves to charge.
    pub low_battery: f64,
    /// How often an idle robot looks at its battery.
    pub battery_check: Duration,
    /// Charge a robot expects to use per second of a task; it does not bid for
    /// a task that would take it below `low_battery`. 0 turns the check off.
    pub drain_per_second: f64,
    /// After finishing, how long the winner keeps answering the announcer with
    /// `done`, in case its first `done` was lost.
    pub linger: Duration,
}

impl Default for AgentConfig {
    fn default() -> Self {
        AgentConfig {
            renew_interval: Duration::from_secs(1),
            renew_timeout: Duration::from_secs(3),
            award_grace: Duration::from_millis(500),
            low_battery: 0.2,
            battery_check: Duration::from_secs(1),
            drain_per_second: 0.0,
            linger: Duration::from_secs(3),
        }
    }
}

/// Why a robot stopped a task it had started.
#[derive(Debug, Clone, PartialEq)]
pub enum StopReason {
    /// The announcer withdrew it (it presumed this robot failed, or no longer wants it).
    Cancelled(String),
    /// The announcer stopped renewing: it is gone, and the task with it.
    AnnouncerSilent,
}

/// What the robot's owner must act on.
#[derive(Debug, Clone, PartialEq)]
pub enum AgentEvent {
    /// Start executing this task; call [`Agent::finish`] when it is done.
    Start(Announcement),
    /// Stop executing the task (the robot is idle again).
    Stop {
        /// The task's number.
        task: u64,
        /// Its name.
        name: String,
        /// Why.
        reason: StopReason,
    },
    /// The battery is low: the robot has unsubscribed from everything; drive to a
    /// charger and call [`Agent::charged`] when full.
    Charge,
    /// Back from charging, listening again.
    Rejoined,
    /// A task was heard but not bid for.
    Skipped {
        /// The task's number.
        task: u64,
        /// Its name.
        name: String,
        /// Why not.
        why: String,
    },
    /// A packet that is not a valid message was ignored.
    Rejected(DecodeError),
}

/// Counts of what a robot did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AgentStats {
    /// Packets received.
    pub heard: u64,
    /// Bids made.
    pub bids: u64,
    /// Tasks won and started.
    pub started: u64,
    /// Tasks finished.
    pub finished: u64,
    /// Tasks stopped before the end (cancelled or abandoned).
    pub stopped: u64,
    /// Trips to the charger.
    pub charges: u64,
    /// Packets refused as malformed.
    pub rejected: u64,
}

/// The robot's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AgentMode {
    /// Listening for tasks (and perhaps bidding).
    Idle,
    /// Executing a task.
    Working,
    /// Unsubscribed from everything, charging.
    Charging,
}

#[derive(Debug)]
struct Pending {
    ann: Announcement,
    best: Bid,
    close_at: Time,
}

#[derive(Debug)]
struct Job {
    ann: Announcement,
    last_heard: Time,
    next_renew: Time,
    progress: f64,
}

/// Events kept for the owner before the oldest are dropped.
const MAX_EVENTS: usize = 1024;

/// One robot (or any machine with resources) in MURDOCH.
///
/// It subscribes to its resources and, while free, to [`IDLE`]. On an
/// announcement it scores itself with the task's metrics and bids on the
/// task's negotiation subject; hearing a better bid it withdraws at once (every
/// bidder knows the winner), and on the award it acknowledges and emits
/// [`AgentEvent::Start`]. While it works it renews every
/// [`AgentConfig::renew_interval`] and abandons the task if the announcer
/// falls silent. Idle with a low battery, it unsubscribes from everything and
/// emits [`AgentEvent::Charge`].
///
/// Inputs: [`Node::handle_packet`], [`Node::handle_timeout`], and the owner's
/// [`set_position`](Agent::set_position), [`set_battery`](Agent::set_battery),
/// [`set_progress`](Agent::set_progress), [`finish`](Agent::finish),
/// [`abandon`](Agent::abandon), [`charged`](Agent::charged). Outputs:
/// [`Node::poll_transmit`], [`Node::subscriptions`], [`poll_event`](Agent::poll_event).
#[derive(Debug)]
pub struct Agent {
    id: Token,
    resources: ResourceSet,
    config: AgentConfig,
    metrics: Metrics,
    position: Option<Vec2>,
    battery: f64,
    mode: AgentMode,
    pending: BTreeMap<Subject, Pending>,
    job: Option<Job>,
    lingering: BTreeMap<Subject, (u64, Time)>,
    next_check: Time,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
    events: VecDeque<AgentEvent>,
    stats: AgentStats,
}

impl Agent {
    /// A robot called `id` (used only to sign its bids) with these resources,
    /// idle, full, at no known position, with the standard metrics.
    pub fn new(id: Token, resources: ResourceSet, config: AgentConfig, now: Time) -> Agent {
        let mut agent = Agent {
            id,
            resources,
            next_check: now + config.battery_check,
            config,
            metrics: Metrics::standard(),
            position: None,
            battery: 1.0,
            mode: AgentMode::Idle,
            pending: BTreeMap::new(),
            job: None,
            lingering: BTreeMap::new(),
            subs: BTreeSet::new(),
            outbox: VecDeque::new(),
            events: VecDeque::new(),
            stats: AgentStats::default(),
        };
        agent.refresh_subs();
        agent
    }

    /// Replaces the metrics this robot knows.
    pub fn with_metrics(mut self, metrics: Metrics) -> Agent {
        self.metrics = metrics;
        self
    }

    /// The metrics, to add to them.
    pub fn metrics_mut(&mut self) -> &mut Metrics {
        &mut self.metrics
    }

    /// Who it is.
    pub fn id(&self) -> &Token {
        &self.id
    }

    /// Its resources.
    pub fn resources(&self) -> &ResourceSet {
        &self.resources
    }

    /// Idle, working or charging.
    pub fn mode(&self) -> AgentMode {
        self.mode
    }

    /// The task it is executing.
    pub fn current_task(&self) -> Option<&Announcement> {
        self.job.as_ref().map(|j| &j.ann)
    }

    /// Auctions it is bidding in and not yet beaten.
    pub fn open_bids(&self) -> usize {
        self.pending.len()
    }

    /// What it has done.
    pub fn stats(&self) -> &AgentStats {
        &self.stats
    }

    /// The battery as last told.
    pub fn battery(&self) -> f64 {
        self.battery
    }

    /// Where it is, for the `distance` metric.
    pub fn set_position(&mut self, p: Vec2) {
        self.position = Some(p);
    }

    /// Its charge, 0 to 1 (clamped; NaN counts as flat).
    pub fn set_battery(&mut self, level: f64) {
        self.battery = if level.is_nan() {
            0.0
        } else {
            level.clamp(0.0, 1.0)
        };
    }

    /// How far along the current task is, 0 to 1, for the renewals.
    pub fn set_progress(&mut self, p: f64) {
        if let Some(job) = &mut self.job {
            job.progress = if p.is_nan() { 0.0 } else { p.clamp(0.0, 1.0) };
        }
    }

    /// The next thing the owner must act on.
    pub fn poll_event(&mut self) -> Option<AgentEvent> {
        self.events.pop_front()
    }

    /// The current task is done: says so and goes back to listening (or to
    /// charge). Returns the task's number, or `None` if it had none.
    pub fn finish(&mut self, now: Time) -> Option<u64> {
        let job = self.job.take()?;
        self.send(
            &job.ann.negotiation,
            &Negotiation::Done {
                task: job.ann.id,
                bidder: self.id.clone(),
            },
        );
        self.lingering.insert(
            job.ann.negotiation.clone(),
            (job.ann.id, now + self.config.linger),
        );
        self.stats.finished += 1;
        self.become_idle(now);
        Some(job.ann.id)
    }

    /// Gives the current task up (the robot cannot go on): the announcer
    /// auctions it again at once.
    pub fn abandon(&mut self, now: Time, reason: &str) -> Option<u64> {
        let job = self.job.take()?;
        self.send(
            &job.ann.negotiation,
            &Negotiation::Abandon {
                task: job.ann.id,
                bidder: self.id.clone(),
                reason: reason.to_owned(),
            },
        );
        self.stats.stopped += 1;
        self.become_idle(now);
        Some(job.ann.id)
    }

    /// Charging is over: subscribe again and listen.
    pub fn charged(&mut self, now: Time) {
        if self.mode == AgentMode::Charging {
            self.mode = AgentMode::Idle;
            self.next_check = now + self.config.battery_check;
            self.events.push_back(AgentEvent::Rejoined);
            self.refresh_subs();
        }
    }

    fn push_event(&mut self, e: AgentEvent) {
        if self.events.len() == MAX_EVENTS {
            self.events.pop_front();
        }
        self.events.push_back(e);
    }

    fn send(&mut self, subject: &Subject, message: &Negotiation) {
        match message.encode(subject) {
            Ok(p) => self.outbox.push_back(p),
            Err(e) => tracing::warn!(agent = %self.id, error = %e, "could not write a message"),
        }
    }

    fn refresh_subs(&mut self) {
        self.subs.clear();
        if self.mode == AgentMode::Charging {
            return;
        }
        self.subs.extend(self.resources.iter().cloned());
        if self.mode == AgentMode::Idle {
            if let Ok(idle) = Subject::new(IDLE) {
                self.subs.insert(idle);
            }
        }
        self.subs.extend(self.pending.keys().cloned());
        self.subs.extend(self.lingering.keys().cloned());
        if let Some(job) = &self.job {
            self.subs.insert(job.ann.negotiation.clone());
        }
    }

    fn become_idle(&mut self, now: Time) {
        self.mode = AgentMode::Idle;
        self.check_battery(now);
        self.refresh_subs();
    }

    fn check_battery(&mut self, now: Time) {
        self.next_check = now + self.config.battery_check;
        if self.mode == AgentMode::Idle && self.battery < self.config.low_battery {
            self.decline_all();
            self.lingering.clear();
            self.mode = AgentMode::Charging;
            self.stats.charges += 1;
            self.push_event(AgentEvent::Charge);
            self.refresh_subs();
        }
    }

    fn decline_all(&mut self) {
        for (subject, p) in std::mem::take(&mut self.pending) {
            self.send(
                &subject,
                &Negotiation::Decline {
                    task: p.ann.id,
                    bidder: self.id.clone(),
                },
            );
        }
    }

    fn on_announce(&mut self, now: Time, ann: Announcement) {
        if self.mode != AgentMode::Idle
            || !ann.spec.resources.is_subset(&self.resources)
            || self.pending.contains_key(&ann.negotiation)
        {
            return;
        }
        let skip = |why: String| AgentEvent::Skipped {
            task: ann.id,
            name: ann.spec.name.clone(),
            why,
        };
        let needed = ann.spec.length_s * self.config.drain_per_second;
        if self.config.drain_per_second > 0.0 && self.battery - needed < self.config.low_battery {
            let e = skip(format!(
                "battery {:.2} would fall below {:.2} during a {} s task",
                self.battery, self.config.low_battery, ann.spec.length_s
            ));
            self.push_event(e);
            return;
        }
        let view = RobotView {
            position: self.position,
            battery: self.battery,
            resources: &self.resources,
        };
        let score = match self.metrics.score(&ann.spec, &view) {
            Ok(s) => s.clamp(-MAX_MAGNITUDE, MAX_MAGNITUDE),
            Err(e) => {
                let e = skip(e.to_string());
                self.push_event(e);
                return;
            }
        };
        let bid = Bid {
            task: ann.id,
            bidder: self.id.clone(),
            score,
        };
        self.stats.bids += 1;
        let subject = ann.negotiation.clone();
        self.send(&subject, &Negotiation::Bid(bid.clone()));
        self.pending.insert(
            subject,
            Pending {
                close_at: now + ann.deadline + self.config.award_grace,
                ann,
                best: bid,
            },
        );
        self.refresh_subs();
    }

    fn on_negotiation(&mut self, now: Time, subject: Subject, msg: Negotiation) {
        if let Some(p) = self.pending.get_mut(&subject) {
            if msg.task() != p.ann.id {
                return;
            }
            match msg {
                Negotiation::Bid(b) => {
                    if b.beats(&p.best) {
                        p.best = b;
                    }
                    if p.best.bidder != self.id {
                        // Beaten: back to listening; the winner needs nothing from us.
                        self.pending.remove(&subject);
                        self.refresh_subs();
                    }
                }
                Negotiation::Award { winner, .. } if winner == self.id => self.take(now, subject),
                Negotiation::Award { .. }
                | Negotiation::Cancel { .. }
                | Negotiation::Unachievable { .. } => {
                    self.pending.remove(&subject);
                    self.refresh_subs();
                }
                _ => {}
            }
            return;
        }
        if let Some(job) = &mut self.job {
            if job.ann.negotiation == subject && job.ann.id == msg.task() {
                match msg {
                    Negotiation::Renew { by, .. } if by == job.ann.announcer => {
                        job.last_heard = now;
                    }
                    Negotiation::Award { winner, .. } if winner == self.id => {
                        // Our ack was lost and the award repeated: acknowledge again.
                        job.last_heard = now;
                        let ack = Negotiation::Ack {
                            task: job.ann.id,
                            bidder: self.id.clone(),
                        };
                        self.send(&subject, &ack);
                    }
                    Negotiation::Cancel { reason, .. } => {
                        let job = self.job.take();
                        if let Some(job) = job {
                            self.stats.stopped += 1;
                            self.push_event(AgentEvent::Stop {
                                task: job.ann.id,
                                name: job.ann.spec.name,
                                reason: StopReason::Cancelled(reason),
                            });
                        }
                        self.become_idle(now);
                    }
                    _ => {}
                }
                return;
            }
        }
        if let Some(&(task, _)) = self.lingering.get(&subject) {
            if let Negotiation::Renew { by, .. } = &msg {
                if *by != self.id && task == msg.task() {
                    let done = Negotiation::Done {
                        task,
                        bidder: self.id.clone(),
                    };
                    self.send(&subject, &done);
                }
            }
        }
    }

    /// Won: acknowledge and start, or decline if something else came first.
    fn take(&mut self, now: Time, subject: Subject) {
        let Some(p) = self.pending.remove(&subject) else {
            return;
        };
        if self.mode != AgentMode::Idle {
            let decline = Negotiation::Decline {
                task: p.ann.id,
                bidder: self.id.clone(),
            };
            self.send(&subject, &decline);
            self.refresh_subs();
            return;
        }
        let ack = Negotiation::Ack {
            task: p.ann.id,
            bidder: self.id.clone(),
        };
        self.send(&subject, &ack);
        // One task at a time: withdraw every other bid so those auctions need not wait.
        self.decline_all();
        self.mode = AgentMode::Working;
        self.stats.started += 1;
        self.job = Some(Job {
            ann: p.ann.clone(),
            last_heard: now,
            next_renew: now + self.config.renew_interval,
            progress: 0.0,
        });
        self.push_event(AgentEvent::Start(p.ann));
        self.refresh_subs();
    }
}

impl Node for Agent {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
        self.stats.heard += 1;
        match Message::decode(packet) {
            Ok(Message::Announce(ann)) => self.on_announce(now, ann),
            Ok(Message::Negotiation { subject, message }) => {
                self.on_negotiation(now, subject, message)
            }
            Err(e) => {
                tracing::debug!(agent = %self.id, error = %e, "ignored a malformed message");
                self.stats.rejected += 1;
                self.push_event(AgentEvent::Rejected(e));
            }
        }
    }

    fn handle_timeout(&mut self, now: Time) {
        let before = (self.pending.len(), self.lingering.len());
        self.pending.retain(|_, p| p.close_at > now);
        self.lingering.retain(|_, (_, until)| *until > now);
        if let Some(job) = &mut self.job {
            if now.since(job.last_heard) >= self.config.renew_timeout {
                let reason = format!(
                    "announcer {} silent for {:.1} s",
                    job.ann.announcer,
                    now.since(job.last_heard).as_secs_f64()
                );
                if let Some(job) = self.job.take() {
                    let abandon = Negotiation::Abandon {
                        task: job.ann.id,
                        bidder: self.id.clone(),
                        reason,
                    };
                    self.send(&job.ann.negotiation, &abandon);
                    self.stats.stopped += 1;
                    self.push_event(AgentEvent::Stop {
                        task: job.ann.id,
                        name: job.ann.spec.name,
                        reason: StopReason::AnnouncerSilent,
                    });
                }
                self.become_idle(now);
            } else if now >= job.next_renew {
                job.next_renew = now + self.config.renew_interval;
                let renew = Negotiation::Renew {
                    task: job.ann.id,
                    by: self.id.clone(),
                    progress: Some(job.progress),
                };
                let subject = job.ann.negotiation.clone();
                self.send(&subject, &renew);
            }
        }
        if self.mode == AgentMode::Idle && now >= self.next_check {
            self.check_battery(now);
        }
        if before != (self.pending.len(), self.lingering.len()) {
            self.refresh_subs();
        }
    }

    fn poll_timeout(&self) -> Option<Time> {
        let pending = self.pending.values().map(|p| p.close_at);
        let lingering = self.lingering.values().map(|(_, t)| *t);
        let job = self
            .job
            .iter()
            .flat_map(|j| [j.next_renew, j.last_heard + self.config.renew_timeout]);
        let check = (self.mode == AgentMode::Idle).then_some(self.next_check);
        pending.chain(lingering).chain(job).chain(check).min()
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::receives;
    use crate::protocol::negotiation_subject;
    use crate::protocol::TaskSpec;

    fn token(s: &str) -> Token {
        Token::new(s).unwrap()
    }

    fn t(ms: u64) -> Time {
        Time::from_micros(ms * 1000)
    }

    /// `r1` at the origin, idle and full.
    fn robot(resources: &str) -> Agent {
        let mut a = Agent::new(
            token("r1"),
            resources.parse().unwrap(),
            AgentConfig::default(),
            Time::ZERO,
        );
        a.set_position(Vec2::ZERO);
        a
    }

    /// A task 5 cm from the origin, announced by `u`, scored by distance.
    fn task(id: u64, resources: &str) -> Announcement {
        Announcement {
            spec: TaskSpec::new("goto", resources.parse().unwrap())
                .length(10.0)
                .param("x", 3.0)
                .param("y", 4.0)
                .metric("distance", 1.0),
            id,
            negotiation: negotiation_subject(&token("u"), id, 1),
            deadline: Duration::from_millis(200),
            announcer: token("u"),
        }
    }

    /// Hands the packet over if the hub would: true if it did.
    fn hear(a: &mut Agent, now: Time, bytes: &[u8]) -> bool {
        let packet = Packet::parse(bytes).unwrap();
        if !receives(a.subscriptions(), packet.subjects()) {
            return false;
        }
        a.handle_packet(now, &packet);
        true
    }

    fn announce(a: &mut Agent, now: Time, ann: &Announcement) -> bool {
        hear(a, now, &ann.encode().unwrap())
    }

    fn say(a: &mut Agent, now: Time, ann: &Announcement, m: Negotiation) -> bool {
        hear(a, now, &m.encode(&ann.negotiation).unwrap())
    }

    fn bid_by(ann: &Announcement, bidder: &str, score: f64) -> Negotiation {
        Negotiation::Bid(Bid {
            task: ann.id,
            bidder: token(bidder),
            score,
        })
    }

    fn award(ann: &Announcement, winner: &str) -> Negotiation {
        Negotiation::Award {
            task: ann.id,
            winner: token(winner),
            score: 5.0,
            bids: 1,
        }
    }

    fn renew_by(ann: &Announcement, by: &str) -> Negotiation {
        Negotiation::Renew {
            task: ann.id,
            by: token(by),
            progress: None,
        }
    }

    /// What it published, with the subject each went to.
    fn sent(a: &mut Agent) -> Vec<(String, Negotiation)> {
        std::iter::from_fn(|| a.poll_transmit())
            .map(|p| match Message::decode_bytes(&p).unwrap() {
                Message::Negotiation { subject, message } => (subject.to_string(), message),
                other => panic!("an agent sent {other:?}"),
            })
            .collect()
    }

    fn messages(a: &mut Agent) -> Vec<Negotiation> {
        sent(a).into_iter().map(|(_, m)| m).collect()
    }

    fn events(a: &mut Agent) -> Vec<AgentEvent> {
        std::iter::from_fn(|| a.poll_event()).collect()
    }

    fn subs(a: &Agent) -> Vec<&str> {
        a.subscriptions().iter().map(|s| s.as_str()).collect()
    }

    /// Bids for `ann` at `at` and wins it at once; the bid, ack and Start are drained.
    fn win(a: &mut Agent, at: Time, ann: &Announcement) {
        assert!(announce(a, at, ann));
        assert!(say(a, at, ann, award(ann, "r1")));
        assert_eq!(a.mode(), AgentMode::Working);
        sent(a);
        events(a);
    }

    #[test]
    fn a_new_robot_listens_on_its_resources_and_idle() {
        let a = robot("mobile camera");
        assert_eq!(subs(&a), ["camera", "idle", "mobile"]);
        assert_eq!(a.mode(), AgentMode::Idle);
        assert_eq!(a.poll_timeout(), Some(t(1000)));
    }

    #[test]
    fn an_announcement_it_can_do_gets_a_bid_with_its_score() {
        let mut a = robot("camera mobile");
        let ann = task(7, "mobile");
        assert!(announce(&mut a, t(10), &ann));
        assert_eq!(
            sent(&mut a),
            [(
                "murdoch.u.7.1".to_string(),
                Negotiation::Bid(Bid {
                    task: 7,
                    bidder: token("r1"),
                    score: 5.0
                })
            )]
        );
        assert_eq!(a.open_bids(), 1);
        assert_eq!(a.stats().bids, 1);
        assert!(a.subscriptions().contains("murdoch.u.7.1"));
        // It waits for the award until the deadline plus the grace.
        assert_eq!(a.poll_timeout(), Some(t(10 + 200 + 500)));
    }

    #[test]
    fn an_announcement_needing_more_than_it_has_is_not_bid_for() {
        let mut a = robot("mobile");
        let ann = task(7, "camera mobile");
        assert!(
            !announce(&mut a, t(0), &ann),
            "the hub would not deliver it"
        );
        // Even handed over directly, it does not bid.
        let bytes = ann.encode().unwrap();
        a.handle_packet(t(0), &Packet::parse(&bytes).unwrap());
        assert!(sent(&mut a).is_empty());
        assert_eq!(a.open_bids(), 0);
    }

    #[test]
    fn the_same_announcement_heard_twice_gets_one_bid() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        announce(&mut a, t(0), &ann);
        announce(&mut a, t(5), &ann);
        assert_eq!(sent(&mut a).len(), 1);
        assert_eq!(a.stats().bids, 1);
    }

    #[test]
    fn a_score_beyond_the_wire_limit_is_bid_at_the_limit() {
        let mut a = robot("mobile");
        a.metrics_mut().insert("huge", |_, _| Some(1e300));
        let mut ann = task(7, "mobile");
        ann.spec = ann.spec.metric("huge", 1.0);
        announce(&mut a, t(0), &ann);
        assert!(matches!(&messages(&mut a)[..],
            [Negotiation::Bid(b)] if b.score == MAX_MAGNITUDE));
    }

    #[test]
    fn a_task_it_cannot_score_is_skipped_with_the_reason() {
        let mut a = robot("mobile");
        let mut ann = task(7, "mobile");
        ann.spec = ann.spec.metric("charisma", 1.0);
        announce(&mut a, t(0), &ann);
        assert!(sent(&mut a).is_empty());
        assert_eq!(
            events(&mut a),
            [AgentEvent::Skipped {
                task: 7,
                name: "goto".into(),
                why: "unknown metric `charisma`".into()
            }]
        );
    }

    #[test]
    fn a_task_that_would_drain_the_battery_below_the_threshold_is_skipped() {
        let mut a = Agent::new(
            token("r1"),
            "mobile".parse().unwrap(),
            AgentConfig {
                drain_per_second: 0.05,
                ..AgentConfig::default()
            },
            Time::ZERO,
        );
        a.set_battery(0.6);
        // 10 s at 0.05/s leaves 0.1, below 0.2.
        announce(&mut a, t(0), &task(7, "mobile"));
        assert!(sent(&mut a).is_empty());
        assert!(matches!(&events(&mut a)[..],
            [AgentEvent::Skipped { why, .. }] if why.contains("battery 0.60 would fall below 0.20")));
        // 10 s at 0.03/s leaves 0.3: it bids.
        let mut b = Agent::new(
            token("r1"),
            "mobile".parse().unwrap(),
            AgentConfig {
                drain_per_second: 0.03,
                ..AgentConfig::default()
            },
            Time::ZERO,
        );
        b.set_battery(0.6);
        b.set_position(Vec2::ZERO);
        announce(&mut b, t(0), &task(7, "mobile"));
        assert_eq!(b.stats().bids, 1);
    }

    #[test]
    fn a_better_bid_sends_it_back_to_listening_without_a_word() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        announce(&mut a, t(0), &ann);
        sent(&mut a);
        assert!(say(&mut a, t(3), &ann, bid_by(&ann, "r9", 4.0)));
        assert_eq!(a.open_bids(), 0);
        assert_eq!(subs(&a), ["idle", "mobile"]);
        assert!(sent(&mut a).is_empty(), "a loser need not decline");
        // The award to the better bidder no longer reaches it.
        assert!(!say(&mut a, t(200), &ann, award(&ann, "r9")));
        assert_eq!(a.mode(), AgentMode::Idle);
    }

    #[test]
    fn a_worse_bid_or_its_own_echo_leaves_it_bidding() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        announce(&mut a, t(0), &ann);
        say(&mut a, t(1), &ann, bid_by(&ann, "r1", 5.0));
        say(&mut a, t(2), &ann, bid_by(&ann, "r0", 6.0));
        assert_eq!(a.open_bids(), 1);
    }

    #[test]
    fn an_equal_bid_from_a_lower_token_beats_it_and_from_a_higher_does_not() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        announce(&mut a, t(0), &ann);
        say(&mut a, t(1), &ann, bid_by(&ann, "r2", 5.0));
        assert_eq!(a.open_bids(), 1);
        say(&mut a, t(2), &ann, bid_by(&ann, "r0", 5.0));
        assert_eq!(a.open_bids(), 0);
    }

    #[test]
    fn a_bid_for_another_task_on_the_subject_is_ignored() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        announce(&mut a, t(0), &ann);
        let other = Negotiation::Bid(Bid {
            task: 8,
            bidder: token("r0"),
            score: 0.0,
        });
        say(&mut a, t(1), &ann, other);
        assert_eq!(a.open_bids(), 1);
    }

    #[test]
    fn an_award_to_someone_else_sends_it_back_to_listening() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        announce(&mut a, t(0), &ann);
        sent(&mut a);
        say(&mut a, t(200), &ann, award(&ann, "r9"));
        assert_eq!(a.open_bids(), 0);
        assert_eq!(a.mode(), AgentMode::Idle);
        assert!(!a.subscriptions().contains("murdoch.u.7.1"));
        assert!(sent(&mut a).is_empty());
    }

    #[test]
    fn no_award_by_the_deadline_and_grace_drops_the_bid() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        announce(&mut a, t(100), &ann);
        a.handle_timeout(t(799));
        assert_eq!(a.open_bids(), 1);
        a.handle_timeout(t(800));
        assert_eq!(a.open_bids(), 0);
        assert_eq!(subs(&a), ["idle", "mobile"]);
        assert_eq!(a.mode(), AgentMode::Idle);
    }

    #[test]
    fn winning_acknowledges_starts_and_stops_listening_for_tasks() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        announce(&mut a, t(0), &ann);
        sent(&mut a);
        assert!(say(&mut a, t(200), &ann, award(&ann, "r1")));
        assert_eq!(
            messages(&mut a),
            [Negotiation::Ack {
                task: 7,
                bidder: token("r1")
            }]
        );
        assert_eq!(events(&mut a), [AgentEvent::Start(ann.clone())]);
        assert_eq!(a.mode(), AgentMode::Working);
        assert_eq!(a.current_task(), Some(&ann));
        assert_eq!(subs(&a), ["mobile", "murdoch.u.7.1"]);
        assert_eq!(a.stats().started, 1);
        // Working, it hears no announcement.
        assert!(!announce(&mut a, t(250), &task(8, "mobile")));
    }

    #[test]
    fn winning_one_auction_withdraws_its_other_bids() {
        let mut a = robot("mobile");
        let (first, second) = (task(7, "mobile"), task(8, "mobile"));
        announce(&mut a, t(0), &first);
        announce(&mut a, t(0), &second);
        sent(&mut a);
        say(&mut a, t(200), &first, award(&first, "r1"));
        assert_eq!(
            sent(&mut a),
            [
                (
                    "murdoch.u.7.1".to_string(),
                    Negotiation::Ack {
                        task: 7,
                        bidder: token("r1")
                    }
                ),
                (
                    "murdoch.u.8.1".to_string(),
                    Negotiation::Decline {
                        task: 8,
                        bidder: token("r1")
                    }
                ),
            ]
        );
        assert_eq!(a.open_bids(), 0);
        assert!(!a.subscriptions().contains("murdoch.u.8.1"));
    }

    #[test]
    fn the_winner_renews_every_interval_with_its_progress() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        win(&mut a, t(200), &ann);
        assert_eq!(a.poll_timeout(), Some(t(1200)));
        a.handle_timeout(t(700));
        assert!(sent(&mut a).is_empty(), "no renewal before it is due");
        a.set_progress(0.4);
        a.handle_timeout(t(1200));
        assert_eq!(
            messages(&mut a),
            [Negotiation::Renew {
                task: 7,
                by: token("r1"),
                progress: Some(0.4)
            }]
        );
        say(&mut a, t(1500), &ann, renew_by(&ann, "u"));
        assert_eq!(a.poll_timeout(), Some(t(2200)));
        a.handle_timeout(t(2200));
        assert_eq!(messages(&mut a).len(), 1);
        assert_eq!(a.mode(), AgentMode::Working);
    }

    #[test]
    fn progress_is_clamped_and_nan_counts_as_none_done() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        win(&mut a, t(0), &ann);
        for (set, want) in [(1.7, 1.0), (-3.0, 0.0), (f64::NAN, 0.0)] {
            a.set_progress(set);
            let now = a.poll_timeout().unwrap();
            say(&mut a, now, &ann, renew_by(&ann, "u"));
            a.handle_timeout(now);
            assert!(
                matches!(&messages(&mut a)[..],
                [Negotiation::Renew { progress: Some(p), .. }] if *p == want),
                "{set}"
            );
        }
    }

    #[test]
    fn an_announcer_gone_silent_is_abandoned_after_the_timeout() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        win(&mut a, t(0), &ann);
        a.handle_timeout(t(1000));
        a.handle_timeout(t(2000));
        assert_eq!(messages(&mut a).len(), 2, "two renewals");
        assert_eq!(a.poll_timeout(), Some(t(3000)));
        a.handle_timeout(t(3000));
        assert_eq!(
            messages(&mut a),
            [Negotiation::Abandon {
                task: 7,
                bidder: token("r1"),
                reason: "announcer u silent for 3.0 s".into()
            }]
        );
        assert_eq!(
            events(&mut a),
            [AgentEvent::Stop {
                task: 7,
                name: "goto".into(),
                reason: StopReason::AnnouncerSilent
            }]
        );
        assert_eq!(a.mode(), AgentMode::Idle);
        assert_eq!(a.current_task(), None);
        assert_eq!(subs(&a), ["idle", "mobile"]);
        assert_eq!(a.stats().stopped, 1);
    }

    #[test]
    fn the_announcers_renewals_keep_the_task_alive() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        win(&mut a, t(0), &ann);
        say(&mut a, t(2500), &ann, renew_by(&ann, "u"));
        a.handle_timeout(t(3000));
        assert_eq!(a.mode(), AgentMode::Working);
        a.handle_timeout(t(5499));
        assert_eq!(a.mode(), AgentMode::Working);
        a.handle_timeout(t(5500));
        assert_eq!(a.mode(), AgentMode::Idle);
    }

    #[test]
    fn only_the_announcers_renewals_count() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        win(&mut a, t(0), &ann);
        say(&mut a, t(2500), &ann, renew_by(&ann, "r1"));
        say(&mut a, t(2600), &ann, renew_by(&ann, "stranger"));
        a.handle_timeout(t(3000));
        assert_eq!(a.mode(), AgentMode::Idle);
    }

    #[test]
    fn a_repeated_award_is_acknowledged_again() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        win(&mut a, t(0), &ann);
        say(&mut a, t(1100), &ann, award(&ann, "r1"));
        assert_eq!(
            messages(&mut a),
            [Negotiation::Ack {
                task: 7,
                bidder: token("r1")
            }]
        );
        // And it counts as hearing from the announcer.
        a.handle_timeout(t(3000));
        assert_eq!(a.mode(), AgentMode::Working);
        assert!(events(&mut a).is_empty());
    }

    #[test]
    fn a_cancel_stops_the_task_with_the_announcers_reason() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        win(&mut a, t(0), &ann);
        let cancel = Negotiation::Cancel {
            task: 7,
            reason: "presumed failed".into(),
        };
        say(&mut a, t(500), &ann, cancel);
        assert_eq!(
            events(&mut a),
            [AgentEvent::Stop {
                task: 7,
                name: "goto".into(),
                reason: StopReason::Cancelled("presumed failed".into())
            }]
        );
        assert_eq!(a.mode(), AgentMode::Idle);
        assert!(sent(&mut a).is_empty());
        assert!(a.subscriptions().contains("idle"));
    }

    #[test]
    fn finishing_says_done_and_keeps_answering_renewals_until_the_linger_ends() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        win(&mut a, t(0), &ann);
        assert_eq!(a.finish(t(4000)), Some(7));
        let done = || Negotiation::Done {
            task: 7,
            bidder: token("r1"),
        };
        assert_eq!(messages(&mut a), [done()]);
        assert_eq!(a.mode(), AgentMode::Idle);
        assert_eq!(a.stats().finished, 1);
        // The announcer did not hear it and renews: done again.
        assert!(say(&mut a, t(5000), &ann, renew_by(&ann, "u")));
        assert_eq!(messages(&mut a), [done()]);
        // Its own renewal echoing back is not answered.
        say(&mut a, t(5100), &ann, renew_by(&ann, "r1"));
        assert!(sent(&mut a).is_empty());
        a.handle_timeout(t(7000));
        assert!(!a.subscriptions().contains("murdoch.u.7.1"));
        assert_eq!(a.finish(t(7000)), None);
    }

    #[test]
    fn abandoning_tells_the_announcer_why() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        win(&mut a, t(0), &ann);
        assert_eq!(a.abandon(t(100), "stuck"), Some(7));
        assert_eq!(
            messages(&mut a),
            [Negotiation::Abandon {
                task: 7,
                bidder: token("r1"),
                reason: "stuck".into()
            }]
        );
        assert_eq!(a.mode(), AgentMode::Idle);
        assert!(!a.subscriptions().contains("murdoch.u.7.1"));
        assert_eq!(a.abandon(t(200), "again"), None);
    }

    #[test]
    fn a_low_battery_while_idle_unsubscribes_from_everything_at_the_check() {
        let mut a = robot("camera mobile");
        let ann = task(7, "mobile");
        announce(&mut a, t(900), &ann);
        sent(&mut a);
        a.set_battery(0.1);
        a.handle_timeout(t(999));
        assert_eq!(a.mode(), AgentMode::Idle, "it looks only at the check");
        a.handle_timeout(t(1000));
        assert_eq!(a.mode(), AgentMode::Charging);
        assert!(a.subscriptions().is_empty());
        assert_eq!(events(&mut a), [AgentEvent::Charge]);
        // Its open bid is withdrawn so the auction need not wait for it.
        assert_eq!(
            messages(&mut a),
            [Negotiation::Decline {
                task: 7,
                bidder: token("r1")
            }]
        );
        assert_eq!(a.open_bids(), 0);
        assert_eq!(a.poll_timeout(), None);
        assert_eq!(a.stats().charges, 1);
    }

    #[test]
    fn a_charging_robot_ignores_even_an_announcement_handed_to_it() {
        let mut a = robot("mobile");
        a.set_battery(0.0);
        a.handle_timeout(t(1000));
        assert!(!announce(&mut a, t(1100), &task(7, "mobile")));
        let bytes = task(7, "mobile").encode().unwrap();
        a.handle_packet(t(1100), &Packet::parse(&bytes).unwrap());
        assert!(sent(&mut a).is_empty());
    }

    #[test]
    fn charged_rejoins_and_resumes_battery_checks() {
        let mut a = robot("mobile");
        a.set_battery(0.1);
        a.handle_timeout(t(1000));
        events(&mut a);
        a.charged(t(5000));
        assert_eq!(events(&mut a), [AgentEvent::Rejoined]);
        assert_eq!(a.mode(), AgentMode::Idle);
        assert_eq!(subs(&a), ["idle", "mobile"]);
        assert_eq!(a.poll_timeout(), Some(t(6000)));
        // Still low: back to the charger at the next check.
        a.handle_timeout(t(6000));
        assert_eq!(a.mode(), AgentMode::Charging);
        // charged() while not charging does nothing.
        let mut b = robot("mobile");
        b.charged(t(10));
        assert!(events(&mut b).is_empty());
    }

    #[test]
    fn a_low_battery_while_working_waits_for_the_end_of_the_task() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        win(&mut a, t(0), &ann);
        a.set_battery(0.05);
        say(&mut a, t(900), &ann, renew_by(&ann, "u"));
        a.handle_timeout(t(1000));
        assert_eq!(a.mode(), AgentMode::Working);
        assert!(matches!(&messages(&mut a)[..], [Negotiation::Renew { .. }]));
        a.finish(t(1500));
        assert_eq!(a.mode(), AgentMode::Charging);
        assert_eq!(events(&mut a), [AgentEvent::Charge]);
        // It said done before it left, but lingers no more.
        assert!(matches!(&messages(&mut a)[..], [Negotiation::Done { .. }]));
        assert!(a.subscriptions().is_empty());
    }

    #[test]
    fn battery_levels_are_clamped_and_nan_is_flat() {
        let mut a = robot("mobile");
        a.set_battery(2.0);
        assert_eq!(a.battery(), 1.0);
        a.set_battery(-1.0);
        assert_eq!(a.battery(), 0.0);
        a.set_battery(f64::NAN);
        assert_eq!(a.battery(), 0.0);
    }

    #[test]
    fn a_malformed_packet_is_reported_and_changes_nothing() {
        let mut a = robot("mobile");
        let ann = task(7, "mobile");
        announce(&mut a, t(0), &ann);
        sent(&mut a);
        assert!(hear(
            &mut a,
            t(1),
            b"@ <murdoch.u.7.1> 0\nbid task 7 bidder r0 score lots\n"
        ));
        assert_eq!(a.open_bids(), 1);
        assert_eq!(a.stats().rejected, 1);
        assert!(
            matches!(&events(&mut a)[..], [AgentEvent::Rejected(e)] if e.to_string().contains("`score`"))
        );
    }

    #[test]
    fn the_event_queue_keeps_only_the_newest() {
        let mut a = robot("mobile");
        for _ in 0..MAX_EVENTS + 5 {
            hear(&mut a, t(0), b"@ <idle> 0\nnonsense task 1\n");
        }
        assert_eq!(events(&mut a).len(), MAX_EVENTS);
        assert_eq!(a.stats().rejected, MAX_EVENTS as u64 + 5);
    }
}
