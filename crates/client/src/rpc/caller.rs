//! The calling side, sans I/O: which providers are alive, which calls wait
//! on which, and what became of each.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use colony_wire::{Packet, Priority, Subject, MIN_LEASE_MS};

use super::message::{body_lines, reply_inbox, AnswerHeader, CallHeader, Id, Notice, Service};
use super::{CallError, RpcError, LONGEST_LEASE, LONGEST_TIMEOUT};

/// How often a caller with calls but no provider asks who provides.
const ASK_EVERY: Duration = Duration::from_millis(250);

/// A provider's answer to a call.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Answer {
    /// The call answered.
    pub id: Id,
    /// The provider that answered it.
    pub provider: Id,
    /// The answer's lines, as written (the `reply` line left out).
    pub lines: Vec<String>,
}

/// What became of a call: its answer, or why there is none.
pub type Outcome = (Id, Result<Answer, CallError>);

/// The most providers a caller keeps: forged announcements with fresh ids
/// must not grow its memory or its work per packet.
const MOST_PROVIDERS: usize = 64;

#[derive(Debug)]
struct Known {
    id: Id,
    inbox: Subject,
    lease: Duration,
    /// When it was last heard from (an announcement, or an answer).
    seen: Instant,
    /// Believed until then; never brought forward, so a forged
    /// announcement with a short lease cannot end another's calls.
    expires: Instant,
    /// It said it was leaving: no new calls go to it, and the calls it has
    /// end when its lease does (a forged `leaving` must not end them sooner).
    left: bool,
}

#[derive(Debug)]
struct Call {
    id: Id,
    priority: Priority,
    lines: Vec<String>,
    started: Instant,
    deadline: Instant,
    /// The provider it was sent to; `None` while no provider is known.
    sent_to: Option<Id>,
}

/// One caller of one service. Subscribe its client to [`subjects`](Caller::subjects),
/// hand it every packet that arrives on them and the time, publish what
/// [`poll_transmit`](Caller::poll_transmit) gives, and read outcomes from
/// [`poll_outcome`](Caller::poll_outcome).
///
/// Calls are spread over the live providers in turn. A call is sent once
/// and answered at most once: it ends with the first answer from the
/// provider it went to, at its deadline, or when that provider's lease
/// lapses (renewed by its announcements and its answers). It is never sent
/// to a second provider, since the first may have acted on it.
#[derive(Debug)]
pub struct Caller {
    service: Service,
    inbox: Subject,
    providers: Vec<Known>,
    turn: usize,
    calls: Vec<Call>,
    next_call: u64,
    outbox: VecDeque<Vec<u8>>,
    outcomes: VecDeque<Outcome>,
    last_asked: Option<Instant>,
    strays: u64,
}

impl Caller {
    /// A caller of `service` with a fresh id.
    pub fn new(service: &str) -> Result<Caller, RpcError> {
        Caller::with_id(service, Id::fresh())
    }

    /// A caller with a chosen id (tests and reproducible runs).
    pub fn with_id(service: &str, id: Id) -> Result<Caller, RpcError> {
        Ok(Caller {
            service: Service::new(service)?,
            inbox: reply_inbox(id),
            providers: Vec::new(),
            turn: 0,
            calls: Vec::new(),
            // Call ids start where another run of the same caller id would not.
            next_call: Id::fresh().0 >> 16,
            outbox: VecDeque::new(),
            outcomes: VecDeque::new(),
            last_asked: None,
            strays: 0,
        })
    }

    /// The subjects the caller's client must subscribe to: the caller's
    /// inbox (answers) and the service's channel (providers), in that order,
    /// so the inbox is asked for before any provider can be heard of.
    pub fn subjects(&self) -> [&Subject; 2] {
        [&self.inbox, self.service.channel()]
    }

    /// The service called.
    pub fn service(&self) -> &Service {
        &self.service
    }

    /// The providers new calls may go to, in the order they go to them (not
    /// those that said they are leaving).
    pub fn providers(&self) -> impl Iterator<Item = Id> + '_ {
        self.providers.iter().filter(|p| !p.left).map(|p| p.id)
    }

    /// Calls sent or waiting for a provider, not yet ended.
    pub fn in_flight(&self) -> usize {
        self.calls.len()
    }

    /// Answers that matched no call in flight (late, repeated or forged).
    pub fn strays(&self) -> u64 {
        self.strays
    }

    /// Starts a call with these lines (packet lines as written, such as
    /// `text value "hi"`), ending at `now + timeout` at the latest.
    pub fn call(
        &mut self,
        now: Instant,
        priority: Priority,
        lines: &[&str],
        timeout: Duration,
    ) -> Result<Id, RpcError> {
        let deadline = Some(timeout)
            .filter(|t| !t.is_zero() && *t <= LONGEST_TIMEOUT)
            .and_then(|t| now.checked_add(t))
            .ok_or(RpcError::BadTimeout(timeout))?;
        let lines: Vec<String> = lines.iter().map(|l| (*l).to_owned()).collect();
        let id = Id(self.next_call);
        self.next_call = self.next_call.wrapping_add(1);
        // Refused here, not at the provider, so a bad line is the caller's error at once.
        let header = CallHeader {
            id,
            reply_to: self.inbox.clone(),
        };
        // Every provider's inbox has the length of this one.
        header
            .to_packet(&self.service.inbox(Id(0)), priority, &lines)
            .map_err(|mut e| {
                // The caller's lines follow the header and the `call` line.
                e.line = e.line.saturating_sub(2).max(1);
                RpcError::BadLines(e)
            })?;
        self.calls.push(Call {
            id,
            priority,
            lines,
            started: now,
            deadline,
            sent_to: None,
        });
        self.dispatch(now);
        Ok(id)
    }

    /// Notes a packet that arrived on one of [`subjects`](Caller::subjects).
    pub fn handle_packet(&mut self, now: Instant, packet: &Packet<'_>) {
        if packet.subject_count() != 1 {
            return;
        }
        if packet.has_subject(self.service.channel().as_str()) {
            match Notice::read(packet) {
                Some(Notice::Provider { id, lease }) => self.note_provider(now, id, lease),
                Some(Notice::Leaving { id }) => {
                    if let Some(p) = self.providers.iter_mut().find(|p| p.id == id) {
                        p.left = true;
                    }
                }
                Some(Notice::Who) | None => {}
            }
        } else if packet.has_subject(self.inbox.as_str()) {
            let Some(answer) = AnswerHeader::read(packet) else {
                self.strays += 1;
                return;
            };
            // Only the provider the call went to may end it: an answer from
            // anyone else is late, repeated or forged.
            let Some(i) = self
                .calls
                .iter()
                .position(|c| c.id == answer.id && c.sent_to == Some(answer.from))
            else {
                self.strays += 1;
                return;
            };
            let call = self.calls.swap_remove(i);
            // An answer is as good a sign of life as an announcement: a
            // provider busy answering must not lapse for want of time to announce.
            if let Some(p) = self.providers.iter_mut().find(|p| p.id == answer.from) {
                p.seen = now;
                p.expires = p.expires.max(now + p.lease);
            }
            let result = match answer.refused {
                None => Ok(Answer {
                    id: call.id,
                    provider: answer.from,
                    lines: body_lines(packet),
                }),
                Some(why) => Err(CallError::Refused {
                    provider: answer.from,
                    why,
                }),
            };
            self.outcomes.push_back((call.id, result));
        }
    }

    /// Ends what is due by `now`: calls past their deadline, providers past
    /// their lease (with the calls sent to them); asks who provides while
    /// calls wait for one.
    pub fn handle_timeout(&mut self, now: Instant) {
        let lapsed: Vec<Id> = self
            .providers
            .iter()
            .filter(|p| p.expires <= now)
            .map(|p| p.id)
            .collect();
        for id in lapsed {
            self.drop_provider(id, now);
        }
        let (due, kept): (Vec<Call>, Vec<Call>) = std::mem::take(&mut self.calls)
            .into_iter()
            .partition(|c| c.deadline <= now);
        self.calls = kept;
        for call in due {
            let waited = now.saturating_duration_since(call.started);
            let error = match call.sent_to {
                Some(provider) => CallError::Timeout { provider, waited },
                None => CallError::NoProvider { waited },
            };
            self.outcomes.push_back((call.id, Err(error)));
        }
        self.ask_if_waiting(now);
    }

    /// When [`handle_timeout`](Caller::handle_timeout) next has work.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let calls = self.calls.iter().map(|c| c.deadline);
        let leases = self.providers.iter().map(|p| p.expires);
        let ask = self
            .last_asked
            .filter(|_| self.waiting())
            .map(|t| t + ASK_EVERY);
        calls.chain(leases).chain(ask).min()
    }

    /// The next packet to publish.
    pub fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }

    /// The next call that ended.
    pub fn poll_outcome(&mut self) -> Option<Outcome> {
        self.outcomes.pop_front()
    }

    fn waiting(&self) -> bool {
        self.calls.iter().any(|c| c.sent_to.is_none())
    }

    fn ask_if_waiting(&mut self, now: Instant) {
        if self.waiting() && self.last_asked.is_none_or(|t| now >= t + ASK_EVERY) {
            self.last_asked = Some(now);
            self.outbox.push_back(Notice::Who.to_packet(&self.service));
        }
    }

    /// Believes an announcement: a new provider (room permitting), or a
    /// known one's lease extended, never shortened.
    fn note_provider(&mut self, now: Instant, id: Id, lease: Duration) {
        let lease = lease.clamp(Duration::from_millis(MIN_LEASE_MS), LONGEST_LEASE);
        let until = now + lease;
        if let Some(p) = self.providers.iter_mut().find(|p| p.id == id) {
            p.lease = lease;
            p.seen = now;
            p.expires = p.expires.max(until);
            p.left = false;
        } else {
            if self.providers.len() >= MOST_PROVIDERS {
                // Room is made only by one that would lapse before this one.
                let Some(i) = (0..self.providers.len())
                    .min_by_key(|&i| self.providers[i].expires)
                    .filter(|&i| self.providers[i].expires < until)
                else {
                    return;
                };
                let gone = self.providers[i].id;
                self.drop_provider(gone, now);
            }
            self.providers.push(Known {
                id,
                inbox: self.service.inbox(id),
                lease,
                seen: now,
                expires: until,
                left: false,
            });
        }
        if self.waiting() {
            self.dispatch(now);
        }
    }

    /// Sends every waiting call to the next live provider in turn.
    fn dispatch(&mut self, now: Instant) {
        let live: Vec<(Id, Subject)> = self
            .providers
            .iter()
            .filter(|p| p.expires > now && !p.left)
            .map(|p| (p.id, p.inbox.clone()))
            .collect();
        if !live.is_empty() {
            let mut unsendable = Vec::new();
            for call in self.calls.iter_mut().filter(|c| c.sent_to.is_none()) {
                let (to, inbox) = &live[self.turn % live.len()];
                self.turn = self.turn.wrapping_add(1);
                let header = CallHeader {
                    id: call.id,
                    reply_to: self.inbox.clone(),
                };
                // Checked when the call began, with an inbox of the same length.
                match header.to_packet(inbox, call.priority, &call.lines) {
                    Ok(packet) => {
                        self.outbox.push_back(packet);
                        call.sent_to = Some(*to);
                    }
                    Err(e) => unsendable.push((call.id, e.to_string())),
                }
            }
            for (id, why) in unsendable {
                self.calls.retain(|c| c.id != id);
                self.outcomes
                    .push_back((id, Err(CallError::Unsendable(why))));
            }
        }
        self.ask_if_waiting(now);
    }

    fn drop_provider(&mut self, id: Id, now: Instant) {
        let Some(i) = self.providers.iter().position(|p| p.id == id) else {
            return;
        };
        let gone = self.providers.remove(i);
        let (lost, kept): (Vec<Call>, Vec<Call>) = std::mem::take(&mut self.calls)
            .into_iter()
            .partition(|c| c.sent_to == Some(id));
        self.calls = kept;
        for call in lost {
            let error = if gone.left {
                CallError::ProviderLeft { provider: id }
            } else {
                CallError::ProviderLapsed {
                    provider: id,
                    lease: gone.lease,
                    silent: now.saturating_duration_since(gone.seen),
                }
            };
            self.outcomes.push_back((call.id, Err(error)));
        }
    }
}
