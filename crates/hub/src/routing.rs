//! The sans-IO hub: routing table, subject sets, leases, minimum priority, status.

use std::collections::{HashMap, VecDeque};
use std::net::SocketAddr;
use std::time::{Duration, Instant};

use colony_wire::{
    ChannelInfo, ClientInfo, Packet, Priority, Reply, Request, StatusReport, Subject, HUB_SUBJECT,
};

use crate::config::HubConfig;
use crate::counters::{Counters, DropReason};

/// A datagram the hub wants sent: a reply to a control request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Transmit {
    /// Where it goes.
    pub dest: SocketAddr,
    /// The datagram.
    pub payload: Vec<u8>,
}

/// What became of a datagram handed to [`Hub::handle`].
#[derive(Debug, PartialEq, Eq)]
pub enum Outcome<'h> {
    /// A published packet: send the same bytes, unchanged, to each of these.
    Forward(&'h [SocketAddr]),
    /// A control request, handled; any reply waits in [`Hub::poll_transmit`].
    Control,
    /// Dropped, and counted under this reason.
    Dropped(DropReason),
}

impl Outcome<'_> {
    /// Whether the hub accepted the datagram (a traffic log records these).
    pub fn accepted(&self) -> bool {
        !matches!(self, Outcome::Dropped(_))
    }
}

#[derive(Debug)]
struct Client {
    /// Each subscription and when its lease runs out.
    subs: HashMap<Subject, Instant>,
    last_heard: Instant,
    last_status: Option<Instant>,
}

/// The broker's whole state. Feed it datagrams and time; it never does I/O.
///
/// ```
/// use std::time::Instant;
/// use colony_hub::{Hub, HubConfig, Outcome};
/// let mut hub = Hub::new(HubConfig::default(), Instant::now());
/// let now = Instant::now();
/// let sub = "127.0.0.1:5001".parse().unwrap();
/// let publisher = "127.0.0.1:5002".parse().unwrap();
/// hub.handle(now, sub, b"@ <hub> 0\nsubscribe ch vision\n");
/// match hub.handle(now, publisher, b"@ <vision> 0\nball x 1 y 2\n") {
///     Outcome::Forward(dests) => assert_eq!(dests, &[sub]),
///     other => panic!("{other:?}"),
/// }
/// ```
#[derive(Debug)]
pub struct Hub {
    config: HubConfig,
    started: Instant,
    clients: HashMap<SocketAddr, Client>,
    subscribers: HashMap<Subject, Vec<SocketAddr>>,
    min_priority: Priority,
    counters: Counters,
    /// Reused for every forward, so routing allocates nothing in steady state.
    dests: Vec<SocketAddr>,
    replies: VecDeque<Transmit>,
    next_sweep: Instant,
    /// The address the hub's socket is bound to; never a client.
    local: Option<SocketAddr>,
}

impl Hub {
    /// A hub with no clients, started at `now`.
    pub fn new(config: HubConfig, now: Instant) -> Hub {
        let next_sweep = now + sweep_interval(&config);
        Hub {
            config,
            started: now,
            clients: HashMap::new(),
            subscribers: HashMap::new(),
            min_priority: Priority(i32::MIN),
            counters: Counters::default(),
            dests: Vec::new(),
            replies: VecDeque::new(),
            next_sweep,
            local: None,
        }
    }

    /// Tells the hub the address its socket listens on, so that it never
    /// takes that address (or its port on any local address) for a client.
    pub fn set_local_addr(&mut self, addr: SocketAddr) {
        self.local = Some(addr);
    }

    /// The limits it was made with.
    pub fn config(&self) -> &HubConfig {
        &self.config
    }

    /// The minimum priority a published packet needs to be repeated.
    pub fn min_priority(&self) -> Priority {
        self.min_priority
    }

    /// How many clients hold at least one lease.
    pub fn client_count(&self) -> usize {
        self.clients.len()
    }

    /// How many datagrams were dropped for this reason.
    pub fn drops(&self, reason: DropReason) -> u64 {
        self.counters.drops(reason)
    }

    /// Counts drops the runtime saw (a subscriber's socket buffer was full).
    pub fn record_drops(&mut self, reason: DropReason, n: u64) {
        self.counters.drop(reason, n);
    }

    /// Handles one datagram from `src` that arrived at `now`.
    pub fn handle(&mut self, now: Instant, src: SocketAddr, data: &[u8]) -> Outcome<'_> {
        let packet = match Packet::parse(data) {
            Ok(p) => p,
            Err(e) => {
                tracing::debug!(%src, error = %e, "malformed packet");
                return self.dropped(DropReason::Malformed);
            }
        };
        if let Some(client) = self.clients.get_mut(&src) {
            client.last_heard = now;
        }
        if packet.has_subject(HUB_SUBJECT) {
            return self.control(now, src, &packet, data.len());
        }
        if packet.priority() < self.min_priority {
            return self.dropped(DropReason::BelowMinPriority);
        }
        self.route(&packet);
        let key = channel_key(&packet);
        self.counters
            .published(&key, data.len(), self.config.max_channels);
        Outcome::Forward(&self.dests)
    }

    fn dropped(&mut self, reason: DropReason) -> Outcome<'static> {
        self.counters.drop(reason, 1);
        Outcome::Dropped(reason)
    }

    /// Fills `self.dests` with every client subscribed to all of the packet's subjects.
    fn route(&mut self, packet: &Packet<'_>) {
        self.dests.clear();
        // Start from the subject with the fewest subscribers; check the others per client.
        let mut rarest: Option<&Vec<SocketAddr>> = None;
        for s in packet.subjects() {
            match self.subscribers.get(s) {
                None => return,
                Some(list) if rarest.is_none_or(|r| list.len() < r.len()) => rarest = Some(list),
                Some(_) => {}
            }
        }
        let Some(candidates) = rarest else { return };
        if packet.subject_count() == 1 {
            self.dests.extend_from_slice(candidates);
            return;
        }
        for addr in candidates {
            let Some(client) = self.clients.get(addr) else {
                continue;
            };
            if packet.subjects().all(|s| client.subs.contains_key(s)) {
                self.dests.push(*addr);
            }
        }
    }

    fn control(
        &mut self,
        now: Instant,
        src: SocketAddr,
        packet: &Packet<'_>,
        len: usize,
    ) -> Outcome<'_> {
        let requests = match Request::parse_all(packet) {
            Ok(r) => r,
            Err(e) => {
                tracing::debug!(%src, error = %e, "bad control request");
                return self.dropped(DropReason::BadControl);
            }
        };
        let had_lease = self.clients.contains_key(&src);
        let mut subscribed = false;
        for request in requests {
            match request {
                Request::Subscribe(subject) => match self.subscribe(now, src, subject) {
                    Ok(()) => subscribed = true,
                    Err(reason) => self.counters.drop(reason, 1),
                },
                Request::Unsubscribe(subject) => self.unsubscribe(src, &subject),
                Request::UnsubscribeAll => self.forget(src),
                Request::MinPriority(p) => {
                    tracing::info!(%src, min_priority = p.0, "minimum priority set");
                    self.min_priority = p;
                }
                Request::Status => self.status_request(now, src, had_lease),
            }
        }
        if subscribed {
            let lease = Reply::lease_packet(self.config.lease.as_millis() as u64);
            // Never answer an address that held no lease with more than it sent:
            // a forged source must not turn the hub into an amplifier.
            if had_lease || lease.len() <= len {
                self.replies.push_back(Transmit {
                    dest: src,
                    payload: lease,
                });
            }
        }
        Outcome::Control
    }

    fn subscribe(
        &mut self,
        now: Instant,
        src: SocketAddr,
        subject: Subject,
    ) -> Result<(), DropReason> {
        if !self.clients.contains_key(&src) && self.clients.len() >= self.config.max_clients {
            return Err(DropReason::TooManyClients);
        }
        let max_subs = self.config.max_subscriptions;
        let client = self.clients.entry(src).or_insert_with(|| Client {
            subs: HashMap::new(),
            last_heard: now,
            last_status: None,
        });
        let expiry = now + self.config.lease;
        if let Some(e) = client.subs.get_mut(&subject) {
            *e = expiry;
            return Ok(());
        }
        if client.subs.len() >= max_subs {
            if client.subs.is_empty() {
                self.clients.remove(&src);
            }
            return Err(DropReason::TooManySubscriptions);
        }
        client.subs.insert(subject.clone(), expiry);
        self.subscribers.entry(subject).or_default().push(src);
        Ok(())
    }

    fn unsubscribe(&mut self, src: SocketAddr, subject: &Subject) {
        let Some(client) = self.clients.get_mut(&src) else {
            return;
        };
        if client.subs.remove(subject).is_some() {
            remove_subscriber(&mut self.subscribers, subject.as_str(), src);
        }
        if client.subs.is_empty() {
            self.clients.remove(&src);
        }
    }

    fn forget(&mut self, src: SocketAddr) {
        if let Some(client) = self.clients.remove(&src) {
            for subject in client.subs.keys() {
                remove_subscriber(&mut self.subscribers, subject.as_str(), src);
            }
        }
    }

    fn status_request(&mut self, now: Instant, src: SocketAddr, had_lease: bool) {
        if !had_lease {
            self.counters.drop(DropReason::NoLease, 1);
            return;
        }
        let interval = self.config.status_interval;
        let Some(client) = self.clients.get_mut(&src) else {
            // The same packet unsubscribed it before asking.
            self.counters.drop(DropReason::NoLease, 1);
            return;
        };
        if client
            .last_status
            .is_some_and(|t| now.duration_since(t) < interval)
        {
            self.counters.drop(DropReason::StatusRateLimited, 1);
            return;
        }
        client.last_status = Some(now);
        let payload = self.status(now).to_packet();
        self.replies.push_back(Transmit { dest: src, payload });
    }

    /// The hub's state as the `status` request reports it.
    pub fn status(&self, now: Instant) -> StatusReport {
        let ms = |d: Duration| d.as_millis() as u64;
        let mut clients: Vec<ClientInfo> = self
            .clients
            .iter()
            .map(|(addr, c)| {
                let mut subscriptions: Vec<(String, u64)> = c
                    .subs
                    .iter()
                    .map(|(s, exp)| (s.to_string(), ms(exp.saturating_duration_since(now))))
                    .collect();
                subscriptions.sort();
                ClientInfo {
                    addr: addr.to_string(),
                    idle_ms: ms(now.saturating_duration_since(c.last_heard)),
                    subscriptions,
                }
            })
            .collect();
        clients.sort_by(|a, b| a.addr.cmp(&b.addr));
        StatusReport {
            uptime_ms: ms(now.saturating_duration_since(self.started)),
            lease_ms: ms(self.config.lease),
            min_priority: self.min_priority,
            client_count: self.clients.len() as u64,
            clients,
            channels: self
                .counters
                .channels()
                .into_iter()
                .map(|(subjects, packets, bytes)| ChannelInfo {
                    subjects,
                    packets,
                    bytes,
                })
                .collect(),
            drops: DropReason::ALL
                .iter()
                .map(|&r| (r.name().to_owned(), self.counters.drops(r)))
                .filter(|&(_, n)| n > 0)
                .collect(),
            truncated: false,
        }
    }

    /// The next reply to send, if any.
    pub fn poll_transmit(&mut self) -> Option<Transmit> {
        self.replies.pop_front()
    }

    /// When the hub next needs [`handle_timeout`](Self::handle_timeout).
    pub fn poll_timeout(&self) -> Instant {
        self.next_sweep
    }

    /// Expires leases that ran out by `now`.
    pub fn handle_timeout(&mut self, now: Instant) {
        if now < self.next_sweep {
            return;
        }
        self.next_sweep = now + sweep_interval(&self.config);
        let subscribers = &mut self.subscribers;
        self.clients.retain(|addr, client| {
            client.subs.retain(|subject, expiry| {
                let live = *expiry > now;
                if !live {
                    remove_subscriber(subscribers, subject.as_str(), *addr);
                }
                live
            });
            !client.subs.is_empty()
        });
    }
}

/// Leases are checked this often: a tenth of a lease, at most a second, so a
/// lease ends at most 10 % late.
fn sweep_interval(config: &HubConfig) -> Duration {
    (config.lease / 10).clamp(Duration::from_millis(1), Duration::from_secs(1))
}

fn remove_subscriber(
    subscribers: &mut HashMap<Subject, Vec<SocketAddr>>,
    subject: &str,
    addr: SocketAddr,
) {
    if let Some(list) = subscribers.get_mut(subject) {
        if let Some(i) = list.iter().position(|a| *a == addr) {
            list.swap_remove(i);
        }
        if list.is_empty() {
            subscribers.remove(subject);
        }
    }
}

/// The counter key for a packet's channel: its subject, or its subjects joined by blanks.
fn channel_key<'p>(packet: &Packet<'p>) -> std::borrow::Cow<'p, str> {
    let mut subjects = packet.subjects();
    let first = subjects.next().unwrap_or_default();
    if packet.subject_count() == 1 {
        return std::borrow::Cow::Borrowed(first);
    }
    let mut key = first.to_owned();
    for s in subjects {
        key.push(' ');
        key.push_str(s);
    }
    std::borrow::Cow::Owned(key)
}
