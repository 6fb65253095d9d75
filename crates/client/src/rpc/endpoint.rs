//! A caller and a provider each on a [`UdpClient`]: for programs that just
//! want to call or to serve, while still able to keep their own loop.

use std::collections::VecDeque;
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_wire::Priority;

use super::{Answer, Call, Caller, Id, Outcome, Provider, RpcError};
use crate::UdpClient;

/// How long a blocking loop sleeps at most, so a stop flag is seen promptly.
const TICK: Duration = Duration::from_millis(100);

fn earliest(a: Option<Instant>, b: Option<Instant>) -> Option<Instant> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// A [`Caller`] on its own hub client.
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
        while let Some(packet) = self.client.recv()? {
            self.caller.handle_packet(now, &packet);
        }
        self.caller.handle_timeout(now);
        self.flush()
    }

    fn flush(&mut self) -> io::Result<()> {
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

    /// Takes in what arrived, serving each call with `handler` (its answer's
    /// lines, or why it cannot be served), and does what is due.
    pub fn poll(
        &mut self,
        now: Instant,
        handler: &mut impl FnMut(&Call<'_>) -> Result<Vec<String>, String>,
    ) -> io::Result<()> {
        self.client.poll(now)?;
        while let Some(packet) = self.client.recv()? {
            let Some(call) = self.provider.handle_packet(now, &packet) else {
                continue;
            };
            let ticket = call.ticket();
            match handler(&call) {
                Ok(lines) => {
                    if let Err(e) = self.provider.answer(&ticket, &lines) {
                        let why = format!("the provider's answer is not a valid packet: {e}");
                        self.provider.refuse(&ticket, &why);
                    }
                }
                Err(why) => self.provider.refuse(&ticket, &why),
            }
        }
        self.provider.handle_timeout(now);
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
        mut handler: impl FnMut(&Call<'_>) -> Result<Vec<String>, String>,
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
