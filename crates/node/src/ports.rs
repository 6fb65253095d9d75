//! The [`Bus`](crate::Bus)'s hub side: the real sans-IO hub, and for each
//! node a synthetic address with a real client session in front of it.
//!
//! Control traffic (subscribe, unsubscribe, lease refresh and the hub's lease
//! replies) crosses here at once, with no latency: a node's subscription
//! takes effect the moment it appears in [`Node::subscriptions`], as on the
//! bus tasks' experiments were written for, while leases, limits and the
//! minimum priority are the hub's own. Refreshes are served on the hub's
//! sweep ticks ([`Ports::handle_timeout`]).
//!
//! [`Node::subscriptions`]: crate::Node::subscriptions

use std::collections::{BTreeSet, HashSet};
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::time::{Duration, Instant};

use colony_client::{ClientConfig, Session};
use colony_hub::{Cidr, Hub, HubConfig, Outcome};
use colony_wire::{Packet, Request, Subject};

use crate::time::Time;

/// Where packets from outside any node come from: [`Bus::publish`] and the
/// console's requests.
///
/// [`Bus::publish`]: crate::Bus::publish
pub(crate) const CONSOLE: SocketAddr =
    SocketAddr::V4(SocketAddrV4::new(Ipv4Addr::new(127, 0, 0, 1), 1));

/// Exchanges with the hub at one instant: a request, a cookie, the request again.
const ROUNDS: usize = 3;

/// The synthetic address of the node at place `i`: `10.a.b.c:1` with `i` in
/// the low 24 bits, so an address names its place and nothing else.
pub(crate) fn address_of(i: usize) -> SocketAddr {
    let [_, a, b, c] = u32::try_from(i & 0xff_ffff).unwrap_or(0).to_be_bytes();
    SocketAddr::V4(SocketAddrV4::new(Ipv4Addr::new(10, a, b, c), 1))
}

/// The place whose address this is, if it is a node's.
fn place_of(addr: SocketAddr) -> Option<usize> {
    match addr {
        SocketAddr::V4(v4) if v4.ip().octets()[0] == 10 && v4.port() == 1 => {
            let [_, a, b, c] = v4.ip().octets();
            Some(u32::from_be_bytes([0, a, b, c]) as usize)
        }
        _ => None,
    }
}

/// One node's place on the hub.
#[derive(Debug)]
struct Port {
    session: Session,
    /// The node's subscriptions as last handed to the session.
    applied: BTreeSet<Subject>,
    /// The session's next deadline (never later than the true one), kept so
    /// that a sweep tick need not ask every session to work it out anew.
    due: Option<Instant>,
}

impl Port {
    fn touched(&mut self) {
        self.due = self.session.poll_timeout();
    }
}

/// What the hub made of a packet handed to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Routed {
    /// Forwarded; the places it reaches (connected nodes only) are in the buffer.
    Forward,
    /// A request to the hub itself, handled.
    Control,
    /// Dropped by the hub (counted under its reason there).
    Dropped,
}

/// The hub and every node's port on it.
#[derive(Debug)]
pub(crate) struct Ports {
    hub: Hub,
    epoch: Instant,
    client: ClientConfig,
    ports: Vec<Port>,
    /// The console's own session (it needs the hub's cookie as any client does).
    console: Session,
    /// Places whose link is down: what they send, and what is sent to them, is lost.
    cut: HashSet<usize>,
}

impl Ports {
    pub(crate) fn new(mut hub: HubConfig, client: ClientConfig) -> Ports {
        // Any instant will do: the hub and the sessions only compare instants
        // and subtract them, so results do not depend on when the bus was made.
        let epoch = Instant::now();
        hub.consoles
            .push(Cidr::host(CONSOLE.ip(), Some(CONSOLE.port())));
        Ports {
            hub: Hub::new(hub, epoch),
            epoch,
            console: Session::new(client.clone(), epoch),
            client,
            ports: Vec::new(),
            cut: HashSet::new(),
        }
    }

    pub(crate) fn hub(&self) -> &Hub {
        &self.hub
    }

    /// The instant a simulated time stands for on the hub's clock.
    pub(crate) fn instant_of(&self, t: Time) -> Instant {
        self.epoch + Duration::from_micros(t.as_micros())
    }

    /// The first simulated time not before `i`: rounded up, so a timer handed
    /// back as a [`Time`] is due when that time comes.
    fn time_of(&self, i: Instant) -> Time {
        let ns = i.saturating_duration_since(self.epoch).as_nanos();
        Time::from_micros(u64::try_from(ns.div_ceil(1000)).unwrap_or(u64::MAX))
    }

    pub(crate) fn is_cut(&self, place: usize) -> bool {
        self.cut.contains(&place)
    }

    pub(crate) fn set_reachable(&mut self, place: usize, reachable: bool) {
        if reachable {
            self.cut.remove(&place);
        } else {
            self.cut.insert(place);
        }
    }

    /// Makes the places `0..n` exactly the ports: a place no node fills any
    /// more unsubscribes from everything (a node left out is gone, as a
    /// killed process is once its socket closes), and a new one starts a
    /// fresh session.
    pub(crate) fn fit(&mut self, n: usize, now: Time) {
        while self.ports.len() > n {
            let place = self.ports.len() - 1;
            self.ports[place].session.unsubscribe_all();
            self.flush(place, now);
            self.ports.pop();
        }
        while self.ports.len() < n {
            self.ports.push(Port {
                session: Session::new(self.client.clone(), self.instant_of(now)),
                applied: BTreeSet::new(),
                due: None,
            });
        }
    }

    /// Makes the subscriptions the session keeps for `place` equal to `want`,
    /// and tells the hub at once.
    pub(crate) fn sync(&mut self, place: usize, want: &BTreeSet<Subject>, now: Time) {
        let at = self.instant_of(now);
        let port = &mut self.ports[place];
        if &port.applied == want {
            return;
        }
        for gone in port.applied.difference(want) {
            port.session.unsubscribe(gone);
        }
        for new in want.difference(&port.applied) {
            port.session.subscribe(at, new.clone());
        }
        port.applied.clone_from(want);
        // A new subscription is due at once: ask now, as `UdpClient::subscribe` does.
        port.session.handle_timeout(at);
        self.flush(place, now);
    }

    /// Sends what `place`'s session wants sent to the hub, and hands the hub's
    /// replies back to the sessions they are for.
    fn flush(&mut self, place: usize, now: Time) {
        self.pump(Some(place), now);
        self.ports[place].touched();
    }

    /// Sends what a session (a place's, or the console's for `None`) wants
    /// sent, and hands the hub's replies back. A cookie from the hub has the
    /// session ask again at once: a new session's subscription takes two
    /// rounds, all at the same instant.
    fn pump(&mut self, place: Option<usize>, now: Time) {
        let at = self.instant_of(now);
        let (src, cut) = match place {
            Some(p) => (address_of(p), self.cut.contains(&p)),
            None => (CONSOLE, false),
        };
        for _ in 0..ROUNDS {
            let mut sent = false;
            loop {
                let session = match place {
                    Some(p) => &mut self.ports[p].session,
                    None => &mut self.console,
                };
                let Some(datagram) = session.poll_transmit() else {
                    break;
                };
                sent = true;
                if !cut {
                    self.hub.handle(at, src, &datagram);
                }
            }
            self.replies(now);
            if !sent {
                break;
            }
        }
    }

    fn replies(&mut self, now: Time) {
        let at = self.instant_of(now);
        while let Some(t) = self.hub.poll_transmit() {
            if t.dest == CONSOLE {
                let _ = self.console.handle_datagram(at, &t.payload);
                continue;
            }
            let Some(place) = place_of(t.dest) else {
                continue;
            };
            if self.cut.contains(&place) {
                continue;
            }
            if let Some(port) = self.ports.get_mut(place) {
                // A reply that does not parse would be the hub's bug; the session
                // has noted the hub alive either way.
                let _ = port.session.handle_datagram(at, &t.payload);
                port.touched();
            }
        }
    }

    /// When the hub next sweeps its leases: the sessions' timers are served
    /// then too (see [`handle_timeout`](Ports::handle_timeout)).
    pub(crate) fn poll_timeout(&self) -> Time {
        self.time_of(self.hub.poll_timeout())
    }

    /// Runs every session timer due by `now` (refreshes, resubscriptions),
    /// then the hub's lease sweep.
    ///
    /// Sessions are served on the hub's sweep ticks (a tenth of a lease, at
    /// most a second) rather than each at its own moment, so a node's due
    /// refreshes travel in one datagram: a long batch run carries a fraction
    /// of the control traffic, and a refresh is at most a tenth of a lease
    /// late, as a live client's is when its loop is busy. New subscriptions
    /// are not delayed ([`sync`](Ports::sync) asks at once), and a refresh,
    /// due at most a third of a lease after the last, still comes well
    /// before the lease ends.
    pub(crate) fn handle_timeout(&mut self, now: Time) {
        let at = self.instant_of(now);
        for place in 0..self.ports.len() {
            if self.ports[place].due.is_some_and(|t| t <= at) {
                self.ports[place].session.handle_timeout(at);
                self.flush(place, now);
            }
        }
        self.hub.handle_timeout(at);
    }

    /// Hands a datagram from `src` to the hub at `now`. On
    /// [`Routed::Forward`], `places` holds the connected places it reaches,
    /// in order.
    pub(crate) fn route(
        &mut self,
        now: Time,
        src: SocketAddr,
        datagram: &[u8],
        places: &mut Vec<usize>,
    ) -> Routed {
        places.clear();
        let at = self.instant_of(now);
        let routed = match self.hub.handle(at, src, datagram) {
            Outcome::Forward { dests, .. } => {
                let n = self.ports.len();
                places.extend(
                    dests
                        .iter()
                        .filter_map(|&d| place_of(d))
                        .filter(|&p| p < n && !self.cut.contains(&p)),
                );
                // The hub's order is its table's; delivery goes by place.
                places.sort_unstable();
                Routed::Forward
            }
            Outcome::Control => Routed::Control,
            Outcome::Dropped(_) => Routed::Dropped,
        };
        self.replies(now);
        routed
    }

    /// Notes that data reached `place`, so its session refreshes at the
    /// slower pace of a channel that is flowing.
    pub(crate) fn note_data(&mut self, place: usize, now: Time, packet: &Packet<'_>) {
        let at = self.instant_of(now);
        if let Some(port) = self.ports.get_mut(place) {
            // Data only moves the session's deadline later: the deadline kept
            // may now be early, which costs one call that finds nothing due.
            port.session.note_data(at, packet);
        }
    }

    /// Sends control requests from the console, as `colony hub` tools do.
    pub(crate) fn console(&mut self, now: Time, requests: &[Request]) {
        self.console.request(requests);
        self.pump(None, now);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_address_names_its_place_and_nothing_else_does() {
        for i in [0, 1, 255, 256, 70_000, 0xff_ffff] {
            assert_eq!(place_of(address_of(i)), Some(i));
        }
        assert_eq!(place_of(CONSOLE), None);
        assert_eq!(place_of("10.0.0.1:2".parse().unwrap()), None);
    }

    #[test]
    fn a_timer_read_back_as_time_is_never_early() {
        let ports = Ports::new(HubConfig::default(), ClientConfig::default());
        let odd = ports.epoch + Duration::from_nanos(3_333_333_333);
        let t = ports.time_of(odd);
        assert_eq!(t.as_micros(), 3_333_334);
        assert!(ports.instant_of(t) >= odd);
        assert_eq!(ports.time_of(ports.epoch), Time::ZERO);
    }

    #[test]
    fn a_subscription_reaches_the_hub_at_once_and_leaves_with_its_place() {
        let mut ports = Ports::new(HubConfig::default(), ClientConfig::default());
        ports.fit(2, Time::ZERO);
        let want: BTreeSet<Subject> = [Subject::new("a").unwrap()].into();
        ports.sync(1, &want, Time::ZERO);
        let mut places = Vec::new();
        let r = ports.route(Time::ZERO, CONSOLE, b"@ <a> 0\nx\n", &mut places);
        assert_eq!((r, places.as_slice()), (Routed::Forward, &[1][..]));
        assert_eq!(ports.hub().client_count(), 1);
        ports.fit(1, Time::ZERO);
        assert_eq!(ports.hub().client_count(), 0);
        ports.route(Time::ZERO, CONSOLE, b"@ <a> 0\nx\n", &mut places);
        assert!(places.is_empty());
    }
}
