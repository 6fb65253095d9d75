//! The robot's side of MURDOCH: listen, bid, win or withdraw, work, renew, charge.

mod bidding;
mod config;
mod events;

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use colony_proto::Vec2;
use colony_wire::seal::{Binding, Identity, PublicKey};
use colony_wire::{Packet, Subject};

pub use config::AgentConfig;
pub use events::{AgentEvent, AgentMode, AgentStats, StopReason};

use crate::metric::Metrics;
use crate::protocol::{Announcement, Bid, Message, Negotiation, RobotReport, Signed};
use crate::protocol::{ResourceSet, Token, IDLE};
use colony_node::Node;
use colony_node::Time;

#[derive(Debug)]
struct Pending {
    ann: Announcement,
    /// The key that sealed the announcement: only it speaks for the announcer.
    announcer: Binding,
    best: Bid,
    close_at: Time,
}

#[derive(Debug)]
struct Job {
    ann: Announcement,
    announcer: Binding,
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
    /// The key it seals every message with.
    identity: Identity,
    resources: ResourceSet,
    config: AgentConfig,
    metrics: Metrics,
    position: Option<Vec2>,
    heading: Option<f64>,
    battery: f64,
    mode: AgentMode,
    pending: BTreeMap<Subject, Pending>,
    job: Option<Job>,
    lingering: BTreeMap<Subject, (u64, Time, Binding)>,
    next_check: Time,
    /// When the next periodic report is due (`None`: the robot never reports).
    next_report: Option<Time>,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
    events: VecDeque<AgentEvent>,
    stats: AgentStats,
}

impl Agent {
    /// A robot called `id` (used only to sign its bids) with these resources,
    /// idle, full, at no known position, with the standard metrics, sealing
    /// its messages with a key of its own.
    pub fn new(id: Token, resources: ResourceSet, config: AgentConfig, now: Time) -> Agent {
        let mut agent = Agent {
            id,
            identity: Identity::generate(),
            resources,
            next_check: now + config.battery_check,
            next_report: config.report_interval.map(|_| now),
            config,
            metrics: Metrics::standard(),
            position: None,
            heading: None,
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

    /// Seals with this key instead (a run that must repeat byte for byte).
    pub fn with_identity(mut self, identity: Identity) -> Agent {
        self.identity = identity;
        self
    }

    /// The key that names it on the wire.
    pub fn key(&self) -> PublicKey {
        self.identity.public()
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

    /// Which way it faces, rad, for metrics that look (a NaN or infinite heading is unknown).
    pub fn set_heading(&mut self, theta: f64) {
        self.heading = theta.is_finite().then(|| colony_proto::wrap_angle(theta));
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
            (job.ann.id, now + self.config.linger, job.announcer),
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
            self.report(now);
        }
    }

    /// The robot's resources change (it picked something up, a sensor
    /// failed, a part was repaired). Its subscriptions follow at once, so it
    /// hears no announcement it can no longer serve; bids on tasks it can no
    /// longer do are declined, and a task it holds that needs a lost resource
    /// is given up (the announcer auctions it again). Returns that task's id.
    pub fn set_resources(&mut self, now: Time, resources: ResourceSet) -> Option<u64> {
        self.resources = resources;
        let unfit: Vec<Subject> = self
            .pending
            .iter()
            .filter(|(_, p)| !p.ann.spec.resources.is_subset(&self.resources))
            .map(|(s, _)| s.clone())
            .collect();
        for subject in unfit {
            if let Some(p) = self.pending.remove(&subject) {
                let decline = Negotiation::Decline {
                    task: p.ann.id,
                    bidder: self.id.clone(),
                };
                self.send(&subject, &decline);
            }
        }
        let lost = self.job.as_ref().and_then(|job| {
            job.ann
                .spec
                .resources
                .iter()
                .find(|r| !self.resources.contains(r.as_str()))
                .map(|r| (job.ann.id, job.ann.spec.name.clone(), r.to_string()))
        });
        let given_up = match lost {
            Some((task, name, resource)) => {
                self.abandon(now, &format!("lost resource {resource}"));
                self.push_event(AgentEvent::Stop {
                    task,
                    name,
                    reason: StopReason::LostResource(resource),
                });
                Some(task)
            }
            None => None,
        };
        self.refresh_subs();
        self.report(now);
        given_up
    }

    fn push_event(&mut self, e: AgentEvent) {
        if self.events.len() == MAX_EVENTS {
            self.events.pop_front();
        }
        self.events.push_back(e);
    }

    fn send(&mut self, subject: &Subject, message: &Negotiation) {
        match message.encode(subject) {
            Ok(p) => self.outbox.push_back(self.identity.sealed(p)),
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
        if !self.check_battery(now) {
            self.report(now);
        }
        self.refresh_subs();
    }

    /// Leaves to charge if idle and low; whether it did.
    fn check_battery(&mut self, now: Time) -> bool {
        self.next_check = now + self.config.battery_check;
        if self.mode == AgentMode::Idle && self.battery < self.config.low_battery {
            self.decline_all();
            self.lingering.clear();
            self.mode = AgentMode::Charging;
            self.stats.charges += 1;
            self.push_event(AgentEvent::Charge);
            self.refresh_subs();
            self.report(now);
            return true;
        }
        false
    }

    /// Says what the robot is doing on [`ROBOTS`](crate::protocol::ROBOTS),
    /// and puts the next periodic report an interval away.
    pub(super) fn report(&mut self, now: Time) {
        let Some(every) = self.config.report_interval else {
            return;
        };
        self.next_report = Some(now + every);
        let report = RobotReport {
            name: self.id.clone(),
            mode: self.mode,
            battery: self.battery,
            resources: self.resources.clone(),
            task: self
                .job
                .as_ref()
                .map(|j| (j.ann.id, j.ann.spec.name.clone())),
        };
        match report.encode() {
            Ok(p) => self.outbox.push_back(self.identity.sealed(p)),
            Err(e) => tracing::warn!(agent = %self.id, error = %e, "could not write a report"),
        }
    }

    fn on_negotiation(
        &mut self,
        now: Time,
        subject: Subject,
        msg: Negotiation,
        from: (PublicKey, u64),
    ) {
        let (key, n) = from;
        let own = self.identity.public();
        if key == own {
            return; // its own, heard back
        }
        if let Some(p) = self.pending.get_mut(&subject) {
            if msg.task() != p.ann.id {
                return;
            }
            match msg {
                Negotiation::Bid(b) => {
                    // A bid in this robot's name from another key, or with a
                    // score no robot can reach, is a forgery.
                    if b.bidder == self.id || !p.ann.spec.admits_score(b.score) {
                        self.stats.forged += 1;
                        return;
                    }
                    if b.beats(&p.best) {
                        p.best = b;
                    }
                    if p.best.bidder != self.id {
                        // Beaten: back to listening; the winner needs nothing from us.
                        self.pending.remove(&subject);
                        self.refresh_subs();
                    }
                }
                Negotiation::Award { .. }
                | Negotiation::Cancel { .. }
                | Negotiation::Unachievable { .. }
                    if !p.announcer.speaks(key, n) =>
                {
                    self.stats.forged += 1;
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
                let announcer = matches!(
                    &msg,
                    Negotiation::Renew { .. }
                        | Negotiation::Award { .. }
                        | Negotiation::Cancel { .. }
                );
                if announcer && !job.announcer.speaks(key, n) {
                    self.stats.forged += 1;
                    return;
                }
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
        if let Some((task, _, announcer)) = self.lingering.get_mut(&subject) {
            let task = *task;
            if let Negotiation::Renew { by, .. } = &msg {
                // Only the announcer's own renewal is answered: anyone else's
                // would make this robot speak as often as it is told to.
                if *by != self.id && task == msg.task() && announcer.speaks(key, n) {
                    let done = Negotiation::Done {
                        task,
                        bidder: self.id.clone(),
                    };
                    self.send(&subject, &done);
                }
            }
        }
    }
}

impl Node for Agent {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
        self.stats.heard += 1;
        match Message::open(packet) {
            Ok(Signed {
                message: Message::Announce(ann),
                key,
                n,
            }) => self.on_announce(now, ann, Binding::new(key, n)),
            Ok(Signed {
                message: Message::Robot(_),
                ..
            }) => {}
            Ok(Signed {
                message: Message::Negotiation { subject, message },
                key,
                n,
            }) => self.on_negotiation(now, subject, message, (key, n)),
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
        self.lingering.retain(|_, (_, until, _)| *until > now);
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
        if self.next_report.is_some_and(|t| now >= t) {
            self.report(now);
        }
        if before != (self.pending.len(), self.lingering.len()) {
            self.refresh_subs();
        }
    }

    fn poll_timeout(&self) -> Option<Time> {
        let pending = self.pending.values().map(|p| p.close_at);
        let lingering = self.lingering.values().map(|(_, t, _)| *t);
        let job = self
            .job
            .iter()
            .flat_map(|j| [j.next_renew, j.last_heard + self.config.renew_timeout]);
        let check = (self.mode == AgentMode::Idle).then_some(self.next_check);
        pending
            .chain(lingering)
            .chain(job)
            .chain(check)
            .chain(self.next_report)
            .min()
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}

#[cfg(test)]
mod tests;
