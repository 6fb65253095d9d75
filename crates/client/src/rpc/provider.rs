//! The serving side, sans I/O: announcing the provider, taking calls, and
//! writing their answers.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use colony_wire::{Line, Packet, ParseError, Priority, Subject, MIN_LEASE_MS};

use super::message::{AnswerHeader, CallHeader, Id, Notice, Service};
use super::{RpcError, LONGEST_LEASE};

/// A provider answers `who` at most once per third of its lease (when it
/// would announce anyway), and at least this often, so that a new caller
/// need not wait long; forged questions cannot make it a loudspeaker.
const ANSWER_WHO_AT_LEAST_EVERY: Duration = Duration::from_secs(1);

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
/// It announces itself when made, every third of its lease, and at once
/// when a caller asks who provides (at most once per third of its lease, and
/// per second); callers stop believing in it one lease after they last
/// heard from it (an announcement or an answer).
#[derive(Debug)]
pub struct Provider {
    service: Service,
    id: Id,
    inbox: Subject,
    lease: Duration,
    last_announced: Instant,
    last_answered_who: Option<Instant>,
    /// The announcement (or farewell) not yet sent: one at most, so a
    /// provider that waits for its hub does not pile them up.
    notice: Option<Vec<u8>>,
    outbox: VecDeque<Vec<u8>>,
    served: u64,
}

impl Provider {
    /// A provider of `service` with a fresh id, announcing itself at `now`.
    pub fn new(service: &str, lease: Duration, now: Instant) -> Result<Provider, RpcError> {
        Provider::with_id(service, Id::fresh(), lease, now)
    }

    /// A provider with a chosen id.
    pub fn with_id(
        service: &str,
        id: Id,
        lease: Duration,
        now: Instant,
    ) -> Result<Provider, RpcError> {
        let service = Service::new(service)?;
        let mut p = Provider {
            inbox: service.inbox(id),
            service,
            id,
            lease: lease.clamp(Duration::from_millis(MIN_LEASE_MS), LONGEST_LEASE),
            last_announced: now,
            last_answered_who: None,
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

    /// This provider's id.
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

    fn announce(&mut self, now: Instant) {
        self.last_announced = now;
        let notice = Notice::Provider {
            id: self.id,
            lease: self.lease,
        };
        self.notice = Some(notice.to_packet(&self.service));
    }

    fn who_every(&self) -> Duration {
        (self.lease / 3).min(ANSWER_WHO_AT_LEAST_EVERY)
    }

    /// Notes a packet from one of [`subjects`](Provider::subjects); a call
    /// for this provider is returned.
    pub fn handle_packet<'p>(&mut self, now: Instant, packet: &Packet<'p>) -> Option<Call<'p>> {
        if packet.subject_count() != 1 {
            return None;
        }
        if packet.has_subject(self.service.channel().as_str()) {
            let ask = Notice::read(packet) == Some(Notice::Who);
            let fresh = self
                .last_answered_who
                .is_some_and(|t| now.saturating_duration_since(t) < self.who_every());
            if ask && !fresh {
                self.last_answered_who = Some(now);
                self.announce(now);
            }
            return None;
        }
        if !packet.has_subject(self.inbox.as_str()) {
            return None;
        }
        let header = CallHeader::read(packet)?;
        Some(Call {
            packet: *packet,
            header,
        })
    }

    /// Answers a call with these lines (packet lines as written).
    pub fn answer(&mut self, ticket: &Ticket, lines: &[String]) -> Result<(), ParseError> {
        let header = AnswerHeader {
            id: ticket.id,
            from: self.id,
            refused: None,
        };
        self.outbox
            .push_back(header.to_packet(&ticket.reply_to, ticket.priority, lines)?);
        self.served += 1;
        Ok(())
    }

    /// Tells the caller this call cannot be served, and why.
    pub fn refuse(&mut self, ticket: &Ticket, why: &str) {
        let header = AnswerHeader {
            id: ticket.id,
            from: self.id,
            // Control characters would be escaped anyway; the limit keeps a
            // long error from a script within one datagram.
            refused: Some(why.chars().take(1024).collect()),
        };
        if let Ok(packet) = header.to_packet(&ticket.reply_to, ticket.priority, &[]) {
            self.outbox.push_back(packet);
        }
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

    /// Says the provider is stopping, so callers end what they sent it at once.
    pub fn leave(&mut self) {
        self.notice = Some(Notice::Leaving { id: self.id }.to_packet(&self.service));
    }

    /// The next packet to publish.
    pub fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.notice.take().or_else(|| self.outbox.pop_front())
    }
}
