//! The serving side, sans I/O: announcing the provider, taking calls, and
//! writing their answers, every word of it sealed by the provider's key.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use colony_wire::seal::Identity;
use colony_wire::{Line, Packet, ParseError, Priority, Subject, MIN_LEASE_MS};

use super::message::{AnswerHeader, CallHeader, Id, Notice, Said, Service};
use super::{RpcError, LONGEST_LEASE};

/// A provider answers each `who` at once while it has credit: one answer
/// costs this much, credit grows with time, and it holds at most
/// [`WHO_BURST`] answers. A new caller hears back in milliseconds, and forged
/// questions cannot make the provider a loudspeaker (10 a second at most).
const WHO_COST: Duration = Duration::from_millis(100);
/// Answers to `who` a provider can give at once after a quiet spell.
const WHO_BURST: u32 = 10;

/// A call taken by a provider, borrowing the packet it came in.
#[derive(Debug, Clone)]
pub struct Call<'p> {
    packet: Packet<'p>,
    header: CallHeader,
}

impl<'p> Call<'p> {
    /// The call's id.
    pub fn id(&self) -> Id {
        self.header.id
    }

    /// The caller's lines (the `call` line left out).
    pub fn lines(&self) -> impl Iterator<Item = Line<'p>> {
        self.packet.lines().skip(1)
    }

    /// The whole packet, `call` line included.
    pub fn packet(&self) -> &Packet<'p> {
        &self.packet
    }

    /// What the provider needs to answer later, once the packet is gone.
    pub fn ticket(&self) -> Ticket {
        Ticket {
            id: self.header.id,
            reply_to: self.header.reply_to.clone(),
            priority: self.packet.priority(),
        }
    }
}

/// Where and how to answer one call.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ticket {
    /// The call's id.
    pub id: Id,
    /// The caller's inbox.
    pub reply_to: Subject,
    /// The call's priority, which its answer keeps.
    pub priority: Priority,
}

/// One provider of one service. Subscribe its client to
/// [`subjects`](Provider::subjects), hand it every packet arriving there;
/// calls come back from [`handle_packet`](Provider::handle_packet), and
/// [`answer`](Provider::answer) or [`refuse`](Provider::refuse) each, now or
/// later. Publish what [`poll_transmit`](Provider::poll_transmit) gives.
///
/// Its id is its key's fingerprint, and everything it publishes is sealed
/// by that key, so callers can tell its word from anyone else's. It
/// announces itself when made and every third of its lease, answers each
/// `who` at once (echoing its nonce, up to 10 a second), and tells a caller
/// `accepted` as soon as it takes a call; callers stop believing in it one
/// lease after they last heard from it (an announcement or an answer).
#[derive(Debug)]
pub struct Provider {
    service: Service,
    identity: Identity,
    id: Id,
    inbox: Subject,
    lease: Duration,
    last_announced: Instant,
    /// Credit for answering `who`, at most `WHO_BURST` answers' worth.
    who_credit: Duration,
    who_credit_at: Instant,
    /// The announcement (or farewell) not yet sent: one at most, so a
    /// provider that waits for its hub does not pile them up.
    notice: Option<Vec<u8>>,
    /// Built but not yet sealed: sealing as they leave keeps the seal counts
    /// in the order the packets are sent, so callers can refuse a replay.
    outbox: VecDeque<Vec<u8>>,
    served: u64,
}

impl Provider {
    /// A provider of `service` with a key of its own, announcing itself at `now`.
    pub fn new(service: &str, lease: Duration, now: Instant) -> Result<Provider, RpcError> {
        Provider::with_identity(service, Identity::generate(), lease, now)
    }

    /// A provider with a chosen key (tests and reproducible runs: see
    /// [`Identity::from_seed`]); its id is the key's fingerprint.
    pub fn with_identity(
        service: &str,
        identity: Identity,
        lease: Duration,
        now: Instant,
    ) -> Result<Provider, RpcError> {
        let service = Service::new(service)?;
        let id = Id::from(identity.public());
        let mut p = Provider {
            inbox: service.inbox(id),
            service,
            identity,
            id,
            lease: lease.clamp(Duration::from_millis(MIN_LEASE_MS), LONGEST_LEASE),
            last_announced: now,
            who_credit: WHO_COST * WHO_BURST,
            who_credit_at: now,
            notice: None,
            outbox: VecDeque::new(),
            served: 0,
        };
        p.announce(now);
        Ok(p)
    }

    /// The subjects its client must subscribe to: the service's channel
    /// (callers asking who provides) and its own inbox (calls).
    pub fn subjects(&self) -> [&Subject; 2] {
        [self.service.channel(), &self.inbox]
    }

    /// This provider's id: its key's fingerprint.
    pub fn id(&self) -> Id {
        self.id
    }

    /// How long callers believe in it without hearing from it.
    pub fn lease(&self) -> Duration {
        self.lease
    }

    /// Calls answered or refused so far.
    pub fn served(&self) -> u64 {
        self.served
    }

    fn announcement(&self, nonce: Option<Id>) -> Vec<u8> {
        Notice::Provider {
            id: self.id,
            lease: self.lease,
            nonce,
        }
        .to_packet(&self.service)
    }

    fn announce(&mut self, now: Instant) {
        self.last_announced = now;
        self.notice = Some(self.announcement(None));
    }

    /// Spends one answer's credit if there is one.
    fn may_answer_who(&mut self, now: Instant) -> bool {
        let earned = now.saturating_duration_since(self.who_credit_at);
        self.who_credit_at = self.who_credit_at.max(now);
        self.who_credit = (self.who_credit + earned).min(WHO_COST * WHO_BURST);
        if self.who_credit < WHO_COST {
            return false;
        }
        self.who_credit -= WHO_COST;
        true
    }

    /// Notes a packet from one of [`subjects`](Provider::subjects); a call
    /// for this provider is returned, and `accepted` is on its way to the caller.
    pub fn handle_packet<'p>(&mut self, now: Instant, packet: &Packet<'p>) -> Option<Call<'p>> {
        if packet.subject_count() != 1 {
            return None;
        }
        if packet.has_subject(self.service.channel().as_str()) {
            if let Some(Notice::Who { nonce }) = Notice::read(packet) {
                if self.may_answer_who(now) {
                    let echo = self.announcement(nonce);
                    self.outbox.push_back(echo);
                }
            }
            return None;
        }
        if !packet.has_subject(self.inbox.as_str()) {
            return None;
        }
        let header = CallHeader::read(packet)?;
        let call = Call {
            packet: *packet,
            header,
        };
        // Said before the call runs: the caller must not send it elsewhere.
        self.tell(&call.ticket(), Said::Accepted, &[]).ok()?;
        Some(call)
    }

    fn tell(&mut self, ticket: &Ticket, said: Said, lines: &[String]) -> Result<(), ParseError> {
        let header = AnswerHeader {
            id: ticket.id,
            from: self.id,
            said,
        };
        let packet = header.to_packet(&ticket.reply_to, ticket.priority, lines)?;
        self.outbox.push_back(packet);
        Ok(())
    }

    /// Answers a call with these lines (packet lines as written); lines that
    /// would not make one sealed datagram are refused.
    pub fn answer(&mut self, ticket: &Ticket, lines: &[String]) -> Result<(), ParseError> {
        self.tell(ticket, Said::Reply, lines)?;
        self.served += 1;
        Ok(())
    }

    /// Tells the caller this call cannot be served, and why.
    pub fn refuse(&mut self, ticket: &Ticket, why: &str) {
        // Control characters would be escaped anyway; the limit keeps a
        // long error from a script within one datagram.
        let why = why.chars().take(1024).collect();
        let _ = self.tell(ticket, Said::Refused(why), &[]);
        self.served += 1;
    }

    /// Announces again when a third of the lease has passed.
    pub fn handle_timeout(&mut self, now: Instant) {
        if now >= self.next_announce() {
            self.announce(now);
        }
    }

    fn next_announce(&self) -> Instant {
        self.last_announced + self.lease / 3
    }

    /// When [`handle_timeout`](Provider::handle_timeout) next has work.
    pub fn poll_timeout(&self) -> Instant {
        self.next_announce()
    }

    /// Says the provider is stopping, so callers send it no new calls.
    pub fn leave(&mut self) {
        self.notice = Some(Notice::Leaving { id: self.id }.to_packet(&self.service));
    }

    /// The next packet to publish, sealed.
    pub fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        let packet = self.notice.take().or_else(|| self.outbox.pop_front())?;
        Some(self.identity.sealed(packet))
    }
}
