//! The calling side, sans I/O: which providers are alive, which calls wait
//! on which, and what became of each.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use colony_wire::seal::Counter;
use colony_wire::{Packet, Priority, Subject, MIN_LEASE_MS};

use super::message::{
    body_lines, proven, reply_inbox, AnswerHeader, CallHeader, Id, Notice, Said, Service,
};
use super::{CallError, RpcError, LONGEST_LEASE, LONGEST_TIMEOUT};

/// How often a caller whose calls have no proven-live provider asks who
/// provides (with a fresh nonce each time).
const ASK_EVERY: Duration = Duration::from_millis(250);
/// How long a caller waits for a provider's `accepted` (or a `who` echo)
/// before it tries the next provider, unless the call's deadline is nearer.
pub const ACK_WAIT: Duration = Duration::from_millis(250);

/// A provider's answer to a call.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Answer {
    /// The call answered.
    pub id: Id,
    /// The provider that answered it.
    pub provider: Id,
    /// The answer's lines, as written (the `reply` and `seal` lines left out).
    pub lines: Vec<String>,
}

/// What became of a call: its answer, or why there is none.
pub type Outcome = (Id, Result<Answer, CallError>);

fn clamp_lease(lease: Duration) -> Duration {
    lease.clamp(Duration::from_millis(MIN_LEASE_MS), LONGEST_LEASE)
}

/// The most providers a caller keeps: announcements under fresh keys must
/// not grow its memory or its work per packet.
const MOST_PROVIDERS: usize = 64;

#[derive(Debug)]
struct Known {
    id: Id,
    inbox: Subject,
    lease: Duration,
    /// When it was last heard from (an announcement, or an answer).
    seen: Instant,
    /// Believed until then; never brought forward.
    expires: Instant,
    /// It said it was leaving: no new calls go to it, and the calls it
    /// accepted end when its lease does.
    left: bool,
    /// The last of this caller's `who` nonces it echoed.
    echoed: Option<Id>,
    /// It accepted or answered one of this caller's calls.
    answered: bool,
    /// A call sent to it was not accepted within the ack wait: it is tried
    /// after every other provider until it accepts or answers one.
    unresponsive: bool,
    /// Seal counts of its notices, so a recorded one cannot be sent again.
    notices: Counter,
}

/// How much a caller trusts a provider to take a call: new calls go to the
/// highest, and a full table makes room by forgetting the lowest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Standing {
    Unresponsive,
    Announced,
    /// Echoed this caller's latest nonce, or accepted or answered one of its calls.
    Live,
}

impl Known {
    fn standing(&self, nonce: Option<Id>) -> Standing {
        if self.unresponsive {
            Standing::Unresponsive
        } else if self.answered || (self.echoed.is_some() && self.echoed == nonce) {
            Standing::Live
        } else {
            Standing::Announced
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    /// No provider has it now.
    Waiting,
    /// Sent to `to`, which must accept it by `ack_by` or be passed over.
    Sent { to: Id, ack_by: Instant },
    /// Taken by `by`: it goes nowhere else.
    Accepted { by: Id },
}

/// How long a call without a live provider waits for a `who` echo before
/// it is sent to a provider only announced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum EchoWait {
    NotYet,
    Until(Instant),
    Over,
}

#[derive(Debug)]
struct Call {
    id: Id,
    priority: Priority,
    lines: Vec<String>,
    started: Instant,
    deadline: Instant,
    stage: Stage,
    echo: EchoWait,
    /// The providers it was sent to: any of them may accept it, none is
    /// sent it twice.
    tried: Vec<Id>,
}

/// One caller of one service. Subscribe its client to [`subjects`](Caller::subjects),
/// hand it every packet that arrives on them and the time, publish what
/// [`poll_transmit`](Caller::poll_transmit) gives, and read outcomes from
/// [`poll_outcome`](Caller::poll_outcome).
///
/// A provider's word counts only under its own seal (its id is its key's
/// fingerprint); anything else is counted as [`forged`](Caller::forged) and
/// dropped. Calls go first to providers proven live (they echoed this
/// caller's latest `who` nonce, or took one of its calls), in turn. A
/// provider that does not say `accepted` within the ack wait is passed over
/// for the next, within the call's deadline; once one accepts, the call is
/// never sent elsewhere and ends with that provider's answer, at its
/// deadline, or when that provider's lease lapses (renewed by its
/// announcements and its answers).
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
    /// The latest `who`: its nonce and when it was asked.
    asked: Option<(Id, Instant)>,
    ack_wait: Duration,
    strays: u64,
    forged: u64,
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
            asked: None,
            ack_wait: ACK_WAIT,
            strays: 0,
            forged: 0,
        })
    }

    /// How long to wait for `accepted` (and for a `who` echo) before trying
    /// the next provider; [`ACK_WAIT`] unless set. A call never waits more
    /// than a quarter of its time left.
    pub fn set_ack_wait(&mut self, wait: Duration) {
        self.ack_wait = wait;
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

    /// The providers new calls may go to (not those that said they are leaving).
    pub fn providers(&self) -> impl Iterator<Item = Id> + '_ {
        self.providers.iter().filter(|p| !p.left).map(|p| p.id)
    }

    /// The providers proven live: they echoed this caller's latest `who`, or
    /// accepted or answered one of its calls, and did not fail one since.
    pub fn live(&self) -> impl Iterator<Item = Id> + '_ {
        let nonce = self.nonce();
        self.providers
            .iter()
            .filter(move |p| !p.left && p.standing(nonce) == Standing::Live)
            .map(|p| p.id)
    }

    /// Calls sent or waiting for a provider, not yet ended.
    pub fn in_flight(&self) -> usize {
        self.calls.len()
    }

    /// Genuine answers that matched no call in flight (late or repeated), and
    /// packets on the caller's inbox that are no answer.
    pub fn strays(&self) -> u64 {
        self.strays
    }

    /// Answers and notices dropped because no valid seal of the provider
    /// they name was on them, or a notice was sealed before one already taken
    /// (a stranger's announcement that would find no room is dropped unread).
    pub fn forged(&self) -> u64 {
        self.forged
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
            stage: Stage::Waiting,
            echo: EchoWait::NotYet,
            tried: Vec::new(),
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
            self.handle_notice(now, packet);
        } else if packet.has_subject(self.inbox.as_str()) {
            self.handle_answer(now, packet);
        }
    }

    fn handle_notice(&mut self, now: Instant, packet: &Packet<'_>) {
        let Some(notice) = Notice::read(packet) else {
            return;
        };
        // `who` is a caller's, unsealed, and this caller hears its own.
        let Some(id) = notice.speaker() else {
            return;
        };
        if let Notice::Provider { lease, nonce, .. } = notice {
            // A stranger that could not take a place is not worth a signature check:
            // a flood of announcements costs nothing once the table is full.
            let stranger = !self.providers.iter().any(|p| p.id == id);
            let standing = self.standing_of(nonce);
            if stranger
                && self.providers.len() >= MOST_PROVIDERS
                && self.victim(standing, now + clamp_lease(lease)).is_none()
            {
                return;
            }
        }
        let Some(said) = proven(packet, id) else {
            self.forged += 1;
            return;
        };
        if let Some(p) = self.providers.iter_mut().find(|p| p.id == id) {
            if !p.notices.accept(said.n) {
                self.forged += 1;
                return;
            }
        }
        match notice {
            Notice::Provider { lease, nonce, .. } => {
                let standing = self.standing_of(nonce);
                self.note_provider(now, id, lease, standing, said.n);
            }
            Notice::Leaving { .. } => {
                if let Some(p) = self.providers.iter_mut().find(|p| p.id == id) {
                    p.left = true;
                }
            }
            Notice::Who { .. } => {}
        }
    }

    fn handle_answer(&mut self, now: Instant, packet: &Packet<'_>) {
        let Some(answer) = AnswerHeader::read(packet) else {
            self.strays += 1;
            return;
        };
        let Some(said) = proven(packet, answer.from) else {
            self.forged += 1;
            return;
        };
        // Only a provider the call was sent to may take or end it, and once
        // one took it, only that one.
        let Some(i) = self.calls.iter().position(|c| {
            c.id == answer.id
                && c.tried.contains(&answer.from)
                && match c.stage {
                    Stage::Accepted { by } => by == answer.from,
                    Stage::Waiting | Stage::Sent { .. } => true,
                }
        }) else {
            self.strays += 1;
            return;
        };
        // Taking or answering a call is as good a sign of life as an
        // announcement: a provider busy answering must not lapse for want
        // of time to announce.
        if let Some(p) = self.providers.iter_mut().find(|p| p.id == answer.from) {
            p.seen = now;
            p.expires = p.expires.max(now + p.lease);
            p.answered = true;
            p.unresponsive = false;
        }
        let result = match answer.said {
            Said::Accepted => {
                let call = &mut self.calls[i];
                if call.stage == (Stage::Accepted { by: answer.from }) {
                    self.strays += 1;
                }
                call.stage = Stage::Accepted { by: answer.from };
                if self.waiting() {
                    self.dispatch(now);
                }
                return;
            }
            Said::Reply => Ok(Answer {
                id: answer.id,
                provider: answer.from,
                lines: body_lines(&said.packet),
            }),
            Said::Refused(why) => Err(CallError::Refused {
                provider: answer.from,
                why,
            }),
        };
        let call = self.calls.swap_remove(i);
        self.outcomes.push_back((call.id, result));
        // A call waiting for a provider may go to the one proven just now.
        self.dispatch(now);
    }

    /// Ends what is due by `now`: calls past their deadline, providers past
    /// their lease (with the calls they accepted); passes over providers that
    /// did not accept in time; asks who provides while calls wait for one.
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
            let error = match (call.stage, call.tried.last()) {
                (Stage::Accepted { by: provider }, _) | (_, Some(&provider)) => {
                    CallError::Timeout { provider, waited }
                }
                (_, None) => CallError::NoProvider { waited },
            };
            self.outcomes.push_back((call.id, Err(error)));
        }
        let mut silent = Vec::new();
        for call in &mut self.calls {
            if let Stage::Sent { to, ack_by } = call.stage {
                if ack_by <= now {
                    silent.push(to);
                    call.stage = Stage::Waiting;
                }
            }
        }
        for p in &mut self.providers {
            if silent.contains(&p.id) {
                p.unresponsive = true;
            }
        }
        self.dispatch(now);
    }

    /// When [`handle_timeout`](Caller::handle_timeout) next has work.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let calls = self.calls.iter().flat_map(|c| {
            let ack = match c.stage {
                Stage::Sent { ack_by, .. } => Some(ack_by),
                Stage::Waiting | Stage::Accepted { .. } => None,
            };
            let echo = match c.echo {
                EchoWait::Until(t) if c.stage == Stage::Waiting => Some(t),
                _ => None,
            };
            [Some(c.deadline), ack, echo].into_iter().flatten()
        });
        let leases = self.providers.iter().map(|p| p.expires);
        let ask = self
            .asked
            .filter(|_| self.needs_live())
            .map(|(_, at)| at + ASK_EVERY);
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

    fn nonce(&self) -> Option<Id> {
        self.asked.map(|(nonce, _)| nonce)
    }

    fn waiting(&self) -> bool {
        self.calls.iter().any(|c| c.stage == Stage::Waiting)
    }

    /// Whether a call waits, or went to a provider not proven live: then the
    /// caller keeps asking `who`, since an echo may have been lost.
    fn needs_live(&self) -> bool {
        let nonce = self.nonce();
        self.calls.iter().any(|c| match c.stage {
            Stage::Waiting => true,
            Stage::Sent { to, .. } => !self
                .providers
                .iter()
                .any(|p| p.id == to && p.standing(nonce) == Standing::Live),
            Stage::Accepted { .. } => false,
        })
    }

    /// What an announcement carrying `nonce` proves about a newcomer.
    fn standing_of(&self, nonce: Option<Id>) -> Standing {
        if nonce.is_some() && nonce == self.nonce() {
            Standing::Live
        } else {
            Standing::Announced
        }
    }

    /// Asks who provides, unless the last question is still fresh; returns
    /// when the question a waiting call relies on was asked.
    fn ask(&mut self, now: Instant) -> Instant {
        match self.asked {
            Some((_, at)) if now < at + ASK_EVERY => at,
            _ => {
                let nonce = Id::fresh();
                self.asked = Some((nonce, now));
                let who = Notice::Who { nonce: Some(nonce) };
                self.outbox.push_back(who.to_packet(&self.service));
                now
            }
        }
    }

    fn ack_wait(&self, from: Instant, deadline: Instant) -> Duration {
        self.ack_wait
            .min(deadline.saturating_duration_since(from) / 4)
    }

    /// Believes a sealed announcement: a new provider (room permitting), or
    /// a known one's lease extended, never shortened.
    fn note_provider(&mut self, now: Instant, id: Id, lease: Duration, standing: Standing, n: u64) {
        let lease = clamp_lease(lease);
        let until = now + lease;
        let nonce = self.nonce();
        let echoes = standing == Standing::Live;
        if let Some(p) = self.providers.iter_mut().find(|p| p.id == id) {
            p.lease = lease;
            p.seen = now;
            p.expires = p.expires.max(until);
            p.left = false;
            if echoes {
                p.echoed = nonce;
            }
        } else {
            if self.providers.len() >= MOST_PROVIDERS && !self.make_room(now, standing, until) {
                return;
            }
            let mut notices = Counter::default();
            notices.accept(n);
            self.providers.push(Known {
                id,
                inbox: self.service.inbox(id),
                lease,
                seen: now,
                expires: until,
                left: false,
                echoed: if echoes { nonce } else { None },
                answered: false,
                unresponsive: false,
                notices,
            });
        }
        if self.waiting() {
            self.dispatch(now);
        }
    }

    /// The provider least worth keeping, if it is worth less than a newcomer
    /// of `standing` believed `until`: a lower standing, or the same and
    /// lapsing sooner. One holding an accepted call is kept.
    fn victim(&self, standing: Standing, until: Instant) -> Option<Id> {
        let nonce = self.nonce();
        self.providers
            .iter()
            .filter(|p| {
                !self
                    .calls
                    .iter()
                    .any(|c| c.stage == Stage::Accepted { by: p.id })
            })
            .min_by_key(|p| (p.standing(nonce), p.expires))
            .filter(|p| (p.standing(nonce), p.expires) < (standing, until))
            .map(|p| p.id)
    }

    fn make_room(&mut self, now: Instant, standing: Standing, until: Instant) -> bool {
        match self.victim(standing, until) {
            Some(id) => {
                self.drop_provider(id, now);
                true
            }
            None => false,
        }
    }

    /// Sends every waiting call to the provider it should try next, and asks
    /// who provides for those that have no live one.
    fn dispatch(&mut self, now: Instant) {
        let nonce = self.nonce();
        let mut unsendable = Vec::new();
        for c in 0..self.calls.len() {
            let call = &self.calls[c];
            if call.stage != Stage::Waiting || call.tried.len() >= MOST_PROVIDERS {
                continue;
            }
            let (deadline, echo) = (call.deadline, call.echo);
            let candidates: Vec<(Standing, usize)> = self
                .providers
                .iter()
                .enumerate()
                .filter(|(_, p)| p.expires > now && !p.left && !call.tried.contains(&p.id))
                .map(|(i, p)| (p.standing(nonce), i))
                .collect();
            let Some(best) = candidates.iter().map(|(s, _)| *s).max() else {
                self.wait_for_echo(c, now, deadline, echo);
                continue;
            };
            if best != Standing::Live && !self.wait_for_echo(c, now, deadline, echo) {
                continue;
            }
            let chosen: Vec<usize> = candidates
                .iter()
                .filter(|(s, _)| *s == best)
                .map(|(_, i)| *i)
                .collect();
            let p = &self.providers[chosen[self.turn % chosen.len()]];
            self.turn = self.turn.wrapping_add(1);
            let (to, inbox) = (p.id, p.inbox.clone());
            let ack_by = now + self.ack_wait(now, deadline);
            let call = &mut self.calls[c];
            let header = CallHeader {
                id: call.id,
                reply_to: self.inbox.clone(),
            };
            // Checked when the call began, with an inbox of the same length.
            match header.to_packet(&inbox, call.priority, &call.lines) {
                Ok(packet) => {
                    self.outbox.push_back(packet);
                    call.stage = Stage::Sent { to, ack_by };
                    call.tried.push(to);
                }
                Err(e) => unsendable.push((call.id, e.to_string())),
            }
        }
        for (id, why) in unsendable {
            self.calls.retain(|c| c.id != id);
            self.outcomes
                .push_back((id, Err(CallError::Unsendable(why))));
        }
        if self.needs_live() {
            self.ask(now);
        }
    }

    /// For a call with no live provider to go to: asks who provides, and
    /// says whether the echo has had its time, so an announced provider may
    /// be tried.
    fn wait_for_echo(&mut self, c: usize, now: Instant, deadline: Instant, echo: EchoWait) -> bool {
        let until = match echo {
            EchoWait::Over => return true,
            EchoWait::Until(t) => t,
            EchoWait::NotYet => {
                let asked = self.ask(now);
                asked + self.ack_wait(asked, deadline)
            }
        };
        let over = now >= until;
        self.calls[c].echo = if over {
            EchoWait::Over
        } else {
            EchoWait::Until(until)
        };
        over
    }

    fn drop_provider(&mut self, id: Id, now: Instant) {
        let Some(i) = self.providers.iter().position(|p| p.id == id) else {
            return;
        };
        let gone = self.providers.remove(i);
        // A call it only had sent to it may still go to another.
        for call in &mut self.calls {
            if matches!(call.stage, Stage::Sent { to, .. } if to == id) {
                call.stage = Stage::Waiting;
            }
        }
        let (lost, kept): (Vec<Call>, Vec<Call>) = std::mem::take(&mut self.calls)
            .into_iter()
            .partition(|c| c.stage == Stage::Accepted { by: id });
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
