//! The auctioneer: announce a task, take bids until the deadline, award,
//! watch the winner's renewals, auction again when it fails, and report a task
//! nobody can do.

mod config;
mod events;

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use colony_wire::seal::{Binding as Bidder, Identity, PublicKey};
use colony_wire::{Packet, Subject};

pub use config::AuctionConfig;
pub use events::{AnnouncerEvent, AnnouncerStats, TaskPhase};

use crate::protocol::{negotiation_subject, Token};
use crate::protocol::{
    Announcement, Bid, Message, Negotiation, Signed, SpecError, TaskSpec, MAX_DEADLINE,
};
use colony_node::Node;
use colony_node::Time;

/// A bidder as the announcer knows it ([`Binding`](colony_wire::seal::Binding)):
/// the key that sealed its first bid in the auction. Only that key speaks
/// under the bidder's token for the rest of the auction and the task.
#[derive(Debug)]
enum Phase {
    Bidding {
        close_at: Time,
        bids: BTreeMap<Token, (f64, Bidder)>,
    },
    Awarded {
        winner: Token,
        bidder: Bidder,
        ack_by: Time,
    },
    Running {
        winner: Token,
        bidder: Bidder,
        last_heard: Time,
        next_renew: Time,
    },
}

#[derive(Debug)]
struct Record {
    spec: TaskSpec,
    attempt: u32,
    negotiation: Subject,
    phase: Phase,
}

/// Bids one auction keeps; more are ignored (the best of a flood still wins
/// unless it comes after this many).
const MAX_BIDS: usize = 4096;

/// Announces tasks and runs their auctions: the side of whoever introduces a
/// task (a user agent, a cron-like alarm, or a task that needs sub-tasks).
///
/// Inputs: [`announce`](Announcer::announce), [`cancel`](Announcer::cancel),
/// [`Node::handle_packet`], [`Node::handle_timeout`]. Outputs:
/// [`Node::poll_transmit`], [`Node::subscriptions`] (the negotiation subjects of
/// its open tasks), [`poll_event`](Announcer::poll_event).
#[derive(Debug)]
pub struct Announcer {
    token: Token,
    /// The key it seals every message with.
    identity: Identity,
    config: AuctionConfig,
    next_id: u64,
    tasks: BTreeMap<u64, Record>,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
    events: VecDeque<AnnouncerEvent>,
    stats: AnnouncerStats,
}

impl Announcer {
    /// An announcer signing its tasks `token` and sealing its messages with
    /// a key of its own; tasks are numbered from 1.
    pub fn new(token: Token, config: AuctionConfig) -> Announcer {
        Announcer {
            token,
            identity: Identity::generate(),
            config,
            next_id: 1,
            tasks: BTreeMap::new(),
            subs: BTreeSet::new(),
            outbox: VecDeque::new(),
            events: VecDeque::new(),
            stats: AnnouncerStats::default(),
        }
    }

    /// Who it is.
    pub fn token(&self) -> &Token {
        &self.token
    }

    /// Seals with this key instead (a run that must repeat byte for byte).
    pub fn with_identity(mut self, identity: Identity) -> Announcer {
        self.identity = identity;
        self
    }

    /// The key that names it on the wire.
    pub fn key(&self) -> PublicKey {
        self.identity.public()
    }

    /// Its timings.
    pub fn config(&self) -> &AuctionConfig {
        &self.config
    }

    /// What it has done.
    pub fn stats(&self) -> &AnnouncerStats {
        &self.stats
    }

    /// Announces a task now; returns its number. Refuses an invalid task, and
    /// every task while [`AuctionConfig::bid_window`] is longer than a reader
    /// accepts ([`MAX_DEADLINE`]): no robot would hear it.
    pub fn announce(&mut self, now: Time, spec: TaskSpec) -> Result<u64, SpecError> {
        spec.validate()?;
        if self.config.bid_window > MAX_DEADLINE {
            return Err(SpecError::Range {
                what: "bid_window".into(),
                value: self.config.bid_window.as_secs_f64(),
                range: "at most 600 s",
            });
        }
        let id = self.next_id;
        self.next_id += 1;
        let negotiation = negotiation_subject(&self.token, id, 1);
        self.tasks.insert(
            id,
            Record {
                spec,
                attempt: 1,
                negotiation,
                phase: Phase::Bidding {
                    close_at: now,
                    bids: BTreeMap::new(),
                },
            },
        );
        self.open_auction(now, id);
        Ok(id)
    }

    /// Withdraws a task, telling its winner to stop.
    pub fn cancel(&mut self, id: u64, reason: &str) -> bool {
        let Some(record) = self.tasks.remove(&id) else {
            return false;
        };
        let cancel = Negotiation::Cancel {
            task: id,
            reason: reason.to_owned(),
        };
        self.send(&record.negotiation, &cancel);
        self.subs.remove(&record.negotiation);
        self.events
            .push_back(AnnouncerEvent::Cancelled { task: id });
        true
    }

    /// The next thing that happened.
    pub fn poll_event(&mut self) -> Option<AnnouncerEvent> {
        self.events.pop_front()
    }

    /// The open tasks' numbers.
    pub fn open_tasks(&self) -> impl Iterator<Item = u64> + '_ {
        self.tasks.keys().copied()
    }

    /// Where a task stands, while it is open.
    pub fn phase(&self, id: u64) -> Option<TaskPhase> {
        self.tasks.get(&id).map(|r| match &r.phase {
            Phase::Bidding { .. } => TaskPhase::Bidding,
            Phase::Awarded { winner, .. } => TaskPhase::Awarded(winner.clone()),
            Phase::Running { winner, .. } => TaskPhase::Running(winner.clone()),
        })
    }

    /// The robot that holds (or was awarded) an open task.
    pub fn winner(&self, id: u64) -> Option<&Token> {
        match &self.tasks.get(&id)?.phase {
            Phase::Awarded { winner, .. } | Phase::Running { winner, .. } => Some(winner),
            Phase::Bidding { .. } => None,
        }
    }

    /// The task's spec, while it is open.
    pub fn spec(&self, id: u64) -> Option<&TaskSpec> {
        self.tasks.get(&id).map(|r| &r.spec)
    }

    fn send(&mut self, subject: &Subject, message: &Negotiation) {
        match message.encode(subject) {
            Ok(p) => self.outbox.push_back(self.identity.sealed(p)),
            Err(e) => {
                tracing::warn!(announcer = %self.token, error = %e, "could not write a message")
            }
        }
    }

    fn open_auction(&mut self, now: Time, id: u64) {
        let Some(r) = self.tasks.get_mut(&id) else {
            return;
        };
        r.negotiation = negotiation_subject(&self.token, id, r.attempt);
        r.phase = Phase::Bidding {
            close_at: now + self.config.bid_window,
            bids: BTreeMap::new(),
        };
        let ann = Announcement {
            spec: r.spec.clone(),
            id,
            negotiation: r.negotiation.clone(),
            deadline: self.config.bid_window,
            announcer: self.token.clone(),
        };
        // Subscribed before the announcement leaves, so no bid can come first.
        self.subs.insert(r.negotiation.clone());
        let (name, attempt) = (r.spec.name.clone(), r.attempt);
        match ann.encode() {
            Ok(p) => self.outbox.push_back(self.identity.sealed(p)),
            Err(e) => tracing::warn!(announcer = %self.token, error = %e, "could not announce"),
        }
        self.stats.auctions += 1;
        self.events.push_back(AnnouncerEvent::Announced {
            task: id,
            name,
            attempt,
        });
    }

    /// The winner is gone: tell it to stop in case it is only out of reach,
    /// then auction the task again among the robots still capable.
    fn reauction(&mut self, now: Time, id: u64, winner: Token, reason: String) {
        let Some(r) = self.tasks.get(&id) else {
            return;
        };
        let (old, name, attempt) = (r.negotiation.clone(), r.spec.name.clone(), r.attempt);
        let cancel = Negotiation::Cancel {
            task: id,
            reason: reason.clone(),
        };
        self.send(&old, &cancel);
        self.subs.remove(&old);
        self.stats.lost += 1;
        self.events.push_back(AnnouncerEvent::WinnerLost {
            task: id,
            name,
            winner,
            reason,
        });
        if attempt >= self.config.max_attempts {
            let reason = format!("auctioned {attempt} times without being done");
            self.unachievable(id, reason);
            return;
        }
        if let Some(r) = self.tasks.get_mut(&id) {
            r.attempt += 1;
        }
        self.open_auction(now, id);
    }

    fn unachievable(&mut self, id: u64, reason: String) {
        let Some(r) = self.tasks.remove(&id) else {
            return;
        };
        let msg = Negotiation::Unachievable {
            task: id,
            name: r.spec.name.clone(),
            reason: reason.clone(),
        };
        self.send(&r.negotiation, &msg);
        self.subs.remove(&r.negotiation);
        self.stats.unachievable += 1;
        self.events.push_back(AnnouncerEvent::Unachievable {
            task: id,
            name: r.spec.name,
            reason,
        });
    }

    fn complete(&mut self, id: u64, winner: Token) {
        let Some(r) = self.tasks.remove(&id) else {
            return;
        };
        self.subs.remove(&r.negotiation);
        self.stats.completed += 1;
        self.events.push_back(AnnouncerEvent::Completed {
            task: id,
            name: r.spec.name,
            winner,
        });
    }

    fn start(&mut self, now: Time, id: u64, winner: Token, bidder: Bidder) {
        if let Some(r) = self.tasks.get_mut(&id) {
            r.phase = Phase::Running {
                winner: winner.clone(),
                bidder,
                last_heard: now,
                next_renew: now + self.config.renew_interval,
            };
            self.events
                .push_back(AnnouncerEvent::Started { task: id, winner });
        }
    }

    fn on_negotiation(
        &mut self,
        now: Time,
        subject: &Subject,
        msg: Negotiation,
        from: (PublicKey, u64),
    ) {
        let (key, n) = from;
        if key == self.identity.public() {
            return; // its own, heard back
        }
        let id = msg.task();
        let Some(r) = self.tasks.get_mut(&id) else {
            return;
        };
        if &r.negotiation != subject {
            return; // an earlier auction of the task, closed
        }
        // Who the message claims to come from, when it names a bidder.
        let claimed = match &msg {
            Negotiation::Bid(b) => Some(&b.bidder),
            Negotiation::Ack { bidder, .. }
            | Negotiation::Decline { bidder, .. }
            | Negotiation::Done { bidder, .. }
            | Negotiation::Abandon { bidder, .. } => Some(bidder),
            Negotiation::Renew { by, .. } => Some(by),
            _ => None,
        };
        // A bidder's messages count only from the key that made its first
        // bid (the winner's from the key that won), each once and in order.
        let genuine = match (&mut r.phase, claimed) {
            (_, None) => false,
            (Phase::Bidding { bids, .. }, Some(bidder)) => match bids.get_mut(bidder) {
                Some((_, known)) => known.speaks(key, n),
                None => matches!(&msg, Negotiation::Bid(b) if r.spec.admits_score(b.score)),
            },
            (
                Phase::Awarded { winner, bidder, .. } | Phase::Running { winner, bidder, .. },
                Some(claimed),
            ) => claimed == winner && bidder.speaks(key, n),
        };
        if !genuine {
            if claimed.is_some() {
                self.stats.forged += 1;
            }
            return;
        }
        match (&mut r.phase, msg) {
            (Phase::Bidding { bids, .. }, Negotiation::Bid(b))
                if (bids.len() < MAX_BIDS || bids.contains_key(&b.bidder))
                    && r.spec.admits_score(b.score) =>
            {
                self.stats.bids += 1;
                let known = bids.get(&b.bidder).map_or(Bidder::new(key, n), |(_, k)| *k);
                bids.insert(b.bidder.clone(), (b.score, known));
                self.events.push_back(AnnouncerEvent::Bid {
                    task: id,
                    bidder: b.bidder,
                    score: b.score,
                });
            }
            (Phase::Bidding { bids, .. }, Negotiation::Decline { bidder, .. }) => {
                bids.remove(&bidder);
            }
            (Phase::Awarded { bidder: known, .. }, Negotiation::Ack { bidder, .. }) => {
                let known = *known;
                self.start(now, id, bidder, known);
            }
            // The ack was lost but the winner is at work: as good as an ack.
            (Phase::Awarded { bidder: known, .. }, Negotiation::Renew { by, .. }) => {
                let known = *known;
                self.start(now, id, by, known);
            }
            (Phase::Running { last_heard, .. }, Negotiation::Renew { .. }) => {
                *last_heard = now;
            }
            (Phase::Awarded { .. } | Phase::Running { .. }, Negotiation::Done { bidder, .. }) => {
                self.complete(id, bidder)
            }
            (Phase::Awarded { .. }, Negotiation::Decline { bidder, .. }) => {
                self.reauction(now, id, bidder, "the winner declined".into());
            }
            (
                Phase::Awarded { .. } | Phase::Running { .. },
                Negotiation::Abandon { bidder, reason, .. },
            ) => {
                self.reauction(
                    now,
                    id,
                    bidder,
                    format!("the winner abandoned it: {reason}"),
                );
            }
            _ => {}
        }
    }

    fn close(&mut self, now: Time, id: u64) {
        let Some(r) = self.tasks.get_mut(&id) else {
            return;
        };
        let Phase::Bidding { bids, .. } = &mut r.phase else {
            return;
        };
        let count = bids.len() as u32;
        // The same rule every bidder applies: lowest score, then lowest token.
        let best = bids
            .iter()
            .map(|(t, (s, k))| {
                let bid = Bid {
                    task: id,
                    bidder: t.clone(),
                    score: *s,
                };
                (bid, *k)
            })
            .reduce(|a, b| if b.0.beats(&a.0) { b } else { a });
        let Some((best, bidder)) = best else {
            let reason = format!("no robot with {} is available", r.spec.resources);
            self.unachievable(id, reason);
            return;
        };
        r.phase = Phase::Awarded {
            winner: best.bidder.clone(),
            bidder,
            ack_by: now + self.config.ack_timeout,
        };
        let (subject, name) = (r.negotiation.clone(), r.spec.name.clone());
        let award = Negotiation::Award {
            task: id,
            winner: best.bidder.clone(),
            score: best.score,
            bids: count,
        };
        self.send(&subject, &award);
        self.stats.awards += 1;
        self.events.push_back(AnnouncerEvent::Awarded {
            task: id,
            name,
            winner: best.bidder,
            score: best.score,
            bids: count,
        });
    }
}

impl Node for Announcer {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
        match Message::open(packet) {
            Ok(Signed {
                message: Message::Negotiation { subject, message },
                key,
                n,
            }) => self.on_negotiation(now, &subject, message, (key, n)),
            Ok(_) => {}
            Err(e) => {
                tracing::debug!(announcer = %self.token, error = %e, "ignored a malformed message");
                self.stats.rejected += 1;
            }
        }
    }

    fn handle_timeout(&mut self, now: Time) {
        let ids: Vec<u64> = self.tasks.keys().copied().collect();
        for id in ids {
            let Some(r) = self.tasks.get_mut(&id) else {
                continue;
            };
            match &mut r.phase {
                Phase::Bidding { close_at, .. } if *close_at <= now => self.close(now, id),
                Phase::Awarded { winner, ack_by, .. } if *ack_by <= now => {
                    let (winner, wait) = (winner.clone(), self.config.ack_timeout);
                    let reason = format!("no acknowledgement within {:.1} s", wait.as_secs_f64());
                    self.reauction(now, id, winner, reason);
                }
                Phase::Running {
                    winner,
                    last_heard,
                    next_renew,
                    ..
                } => {
                    if now.since(*last_heard) >= self.config.renew_timeout {
                        let reason = format!(
                            "presumed failed: no renewal for {:.1} s",
                            now.since(*last_heard).as_secs_f64()
                        );
                        let winner = winner.clone();
                        self.reauction(now, id, winner, reason);
                    } else if *next_renew <= now {
                        *next_renew = now + self.config.renew_interval;
                        let (subject, renew) = (
                            r.negotiation.clone(),
                            Negotiation::Renew {
                                task: id,
                                by: self.token.clone(),
                                progress: None,
                            },
                        );
                        self.send(&subject, &renew);
                    }
                }
                _ => {}
            }
        }
    }

    fn poll_timeout(&self) -> Option<Time> {
        self.tasks
            .values()
            .map(|r| match &r.phase {
                Phase::Bidding { close_at, .. } => *close_at,
                Phase::Awarded { ack_by, .. } => *ack_by,
                Phase::Running {
                    last_heard,
                    next_renew,
                    ..
                } => (*next_renew).min(*last_heard + self.config.renew_timeout),
            })
            .min()
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}

#[cfg(test)]
mod tests;
