//! A caller and a provider each on a [`UdpClient`]: for programs that just
//! want to call or to serve, while still able to keep their own loop.

use std::collections::VecDeque;
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_wire::Priority;

use super::{Answer, Caller, Id, Outcome, Provider, RpcError, Ticket};
use crate::UdpClient;

/// How long a blocking loop sleeps at most, so a stop flag is seen promptly.
const TICK: Duration = Duration::from_millis(100);
/// The most datagrams one poll takes in: a flood must leave time for the
/// timers (deadlines, leases, announcements).
const MOST_PER_POLL: usize = 256;

fn earliest(a: Option<Instant>, b: Option<Instant>) -> Option<Instant> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// A [`Caller`] on its own hub client. It publishes nothing until the hub
/// has leased it its subscriptions, so the answers to its first `who` reach it.
pub struct CallClient {
    client: UdpClient,
    caller: Caller,
    /// Outcomes read while a blocking call waited for its own.
    parked: VecDeque<Outcome>,
}

impl CallClient {
    /// A caller of `service` through the hub at `hub` (`host:port`).
    pub fn connect(hub: &str, service: &str) -> Result<CallClient, RpcError> {
        CallClient::with(UdpClient::connect_to(hub)?, Caller::new(service)?)
    }

    /// A caller on a client made elsewhere (with a key, or other timings).
    pub fn with(mut client: UdpClient, caller: Caller) -> Result<CallClient, RpcError> {
        for s in caller.subjects() {
            client.subscribe(s.as_str())?;
        }
        Ok(CallClient {
            client,
            caller,
            parked: VecDeque::new(),
        })
    }

    /// The hub client underneath (its descriptor, its hub state).
    pub fn client(&self) -> &UdpClient {
        &self.client
    }

    /// The protocol state: providers known, calls in flight.
    pub fn caller(&self) -> &Caller {
        &self.caller
    }

    /// Starts a call without waiting for it; its outcome comes from
    /// [`poll_outcome`](Self::poll_outcome).
    pub fn start(
        &mut self,
        priority: Priority,
        lines: &[&str],
        timeout: Duration,
    ) -> Result<Id, RpcError> {
        let id = self.caller.call(Instant::now(), priority, lines, timeout)?;
        self.flush()?;
        Ok(id)
    }

    /// Takes in what arrived and does what is due.
    pub fn poll(&mut self, now: Instant) -> io::Result<()> {
        self.client.poll(now)?;
        for _ in 0..MOST_PER_POLL {
            let Some(packet) = self.client.recv()? else {
                break;
            };
            self.caller.handle_packet(now, &packet);
        }
        self.caller.handle_timeout(now);
        self.flush()
    }

    fn flush(&mut self) -> io::Result<()> {
        // Held until the hub has leased the subscriptions: a provider
        // answers `who` in less than the hub's cookie round trip, and an
        // echo sent before the caller's inbox exists is lost.
        if self.client.session().lease().is_none() {
            return Ok(());
        }
        while let Some(packet) = self.caller.poll_transmit() {
            self.client.publish(&packet).map_err(io::Error::other)?;
        }
        Ok(())
    }

    /// When [`poll`](Self::poll) next has work, besides a datagram arriving.
    pub fn next_deadline(&self) -> Option<Instant> {
        earliest(self.client.next_deadline(), self.caller.poll_timeout())
    }

    /// The next call that ended.
    pub fn poll_outcome(&mut self) -> Option<Outcome> {
        self.parked
            .pop_front()
            .or_else(|| self.caller.poll_outcome())
    }

    /// Calls and waits for the outcome (at most `timeout`, and a little more
    /// if the hub is slow to take the socket's datagrams).
    pub fn call(
        &mut self,
        priority: Priority,
        lines: &[&str],
        timeout: Duration,
    ) -> Result<Answer, RpcError> {
        let id = self.start(priority, lines, timeout)?;
        loop {
            while let Some((done, result)) = self.caller.poll_outcome() {
                if done == id {
                    return result.map_err(RpcError::from);
                }
                self.parked.push_back((done, result));
            }
            let wake = earliest(self.next_deadline(), Some(Instant::now() + TICK));
            self.client.wait(wake)?;
            self.poll(Instant::now())?;
        }
    }
}

/// A call a [`ServeClient`] took: where its answer goes, and its lines as written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Asked {
    /// Where and how to answer.
    pub ticket: Ticket,
    /// The caller's lines (the `call` line left out).
    pub lines: Vec<String>,
}

/// A [`Provider`] on its own hub client.
///
/// It announces itself only once the hub has leased it its subscriptions:
/// a caller that heard of it before then could send a call the hub would
/// not yet deliver.
pub struct ServeClient {
    client: UdpClient,
    provider: Provider,
}

impl ServeClient {
    /// A provider of `service` through the hub at `hub`, believed by callers
    /// for `lease` after each announcement.
    pub fn connect(hub: &str, service: &str, lease: Duration) -> Result<ServeClient, RpcError> {
        let provider = Provider::new(service, lease, Instant::now())?;
        ServeClient::with(UdpClient::connect_to(hub)?, provider)
    }

    /// A provider on a client made elsewhere.
    pub fn with(mut client: UdpClient, provider: Provider) -> Result<ServeClient, RpcError> {
        for s in provider.subjects() {
            client.subscribe(s.as_str())?;
        }
        Ok(ServeClient { client, provider })
    }

    /// The hub client underneath.
    pub fn client(&self) -> &UdpClient {
        &self.client
    }

    /// The protocol state.
    pub fn provider(&self) -> &Provider {
        &self.provider
    }

    /// Takes in what arrived (a bounded batch), does what is due, and
    /// returns the calls taken, to be answered now or later with
    /// [`answer`](Self::answer) or [`refuse`](Self::refuse).
    pub fn poll_calls(&mut self, now: Instant) -> io::Result<Vec<Asked>> {
        self.client.poll(now)?;
        let mut asked = Vec::new();
        for _ in 0..MOST_PER_POLL {
            let Some(packet) = self.client.recv()? else {
                break;
            };
            if let Some(call) = self.provider.handle_packet(now, &packet) {
                asked.push(Asked {
                    ticket: call.ticket(),
                    lines: call.lines().map(|l| l.as_str().to_owned()).collect(),
                });
            }
        }
        self.provider.handle_timeout(now);
        self.flush()?;
        Ok(asked)
    }

    /// Answers a call with these lines; lines that make no valid packet
    /// refuse it instead, saying why.
    pub fn answer(&mut self, ticket: &Ticket, lines: &[String]) -> io::Result<()> {
        if let Err(e) = self.provider.answer(ticket, lines) {
            let why = format!("the provider's answer is not a valid packet: {e}");
            self.provider.refuse(ticket, &why);
        }
        self.flush()
    }

    /// Tells the caller a call cannot be served, and why.
    pub fn refuse(&mut self, ticket: &Ticket, why: &str) -> io::Result<()> {
        self.provider.refuse(ticket, why);
        self.flush()
    }

    /// Takes in what arrived and serves each call with `handler` (its
    /// answer's lines, or why it cannot be served), announcing between calls
    /// when due, so a slow handler does not make callers think it dead.
    pub fn poll(
        &mut self,
        now: Instant,
        handler: &mut impl FnMut(&Asked) -> Result<Vec<String>, String>,
    ) -> io::Result<()> {
        for asked in self.poll_calls(now)? {
            match handler(&asked) {
                Ok(lines) => self.answer(&asked.ticket, &lines)?,
                Err(why) => self.refuse(&asked.ticket, &why)?,
            }
            self.provider.handle_timeout(Instant::now());
        }
        self.flush()
    }

    fn flush(&mut self) -> io::Result<()> {
        if self.client.session().lease().is_none() {
            return Ok(());
        }
        while let Some(packet) = self.provider.poll_transmit() {
            self.client.publish(&packet).map_err(io::Error::other)?;
        }
        Ok(())
    }

    /// When [`poll`](Self::poll) next has work, besides a datagram arriving.
    pub fn next_deadline(&self) -> Option<Instant> {
        earliest(
            self.client.next_deadline(),
            Some(self.provider.poll_timeout()),
        )
    }

    /// Serves until `stop` is set, then says it is leaving.
    pub fn serve(
        &mut self,
        stop: &AtomicBool,
        mut handler: impl FnMut(&Asked) -> Result<Vec<String>, String>,
    ) -> io::Result<()> {
        while !stop.load(Ordering::Relaxed) {
            let wake = earliest(self.next_deadline(), Some(Instant::now() + TICK));
            self.client.wait(wake)?;
            self.poll(Instant::now(), &mut handler)?;
        }
        self.leave()
    }

    /// Says this provider is stopping, so callers end its calls at once.
    pub fn leave(&mut self) -> io::Result<()> {
        self.provider.leave();
        self.flush()
    }
}
