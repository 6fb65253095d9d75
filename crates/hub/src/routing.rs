//! The sans-IO hub: routing table, subject sets, leases, minimum priority, status.

use std::collections::{HashMap, VecDeque};
use std::net::SocketAddr;
use std::time::{Duration, Instant, SystemTime};

use colony_wire::auth::{self, ReplayWindow};
use colony_wire::{
    ChannelInfo, ClientInfo, Cookie, Packet, Priority, Reply, Request, StatusReport, Subject,
    HUB_SUBJECT, MAX_PACKET,
};

use crate::access::is_bad_source;
use crate::config::HubConfig;
use crate::cookie::CookieJar;
use crate::counters::{Counters, DropReason};
use crate::rate::RateTable;

/// Senders whose replay windows the hub keeps.
const MAX_SIGNERS: usize = 4096;
/// Requests one control packet may carry: more than a client ever sends at
/// once (its subscriptions are capped well below), so that one packet's work
/// stays bounded.
const MAX_REQUESTS: usize = 1024;
/// Replies waiting to be sent, in bytes: beyond this, new ones are dropped
/// (and counted) rather than queued.
const MAX_REPLY_BYTES: usize = 8 << 20;
/// Clients that may tap at once ([`Request::Tap`]): each costs the hub one
/// more send for every packet it forwards, so a handful at most.
pub const MAX_TAPS: usize = 8;
/// Taps one host may hold, unless it is a console: one host with many ports
/// cannot keep every other monitor out.
pub const MAX_TAPS_PER_HOST: usize = 2;
/// The longest lease, signature window and status interval a hub takes:
/// anything longer is a mistake, and would overflow instants.
const LONGEST: Duration = Duration::from_secs(86_400);

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
    /// A published packet: send its first `len` bytes (the whole datagram,
    /// less any authentication line) to each of `dests`.
    Forward {
        /// How many bytes of the datagram to send.
        len: usize,
        /// Who to send them to.
        dests: &'h [SocketAddr],
    },
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
    /// Sends this client none of its own packets ([`Request::NoLocal`]).
    no_local: bool,
    /// What it says it is ([`Request::About`]).
    about: Box<str>,
    /// Gets every forwarded packet ([`Request::Tap`]).
    tap: bool,
    /// Its tap was asked for with a console's authority (it is never displaced).
    console_tap: bool,
    /// The most bytes of joined packets it takes in one datagram
    /// ([`Request::Batch`]; 0: one packet each).
    batch: usize,
}

/// How a datagram proved where it came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Proof {
    /// Nothing: its source may be forged.
    None,
    /// Signed with the hub's key.
    Key,
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
/// // A new address gets a cookie first, and a lease when it sends it back.
/// hub.handle(now, sub, b"@ <hub> 0\ncookie v 0000000000000000\nsubscribe ch vision\n");
/// let cookie = hub.poll_transmit().unwrap().payload;
/// let cookie = std::str::from_utf8(&cookie).unwrap().split_whitespace().last().unwrap().to_owned();
/// let again = format!("@ <hub> 0\ncookie v {cookie}\nsubscribe ch vision\n");
/// hub.handle(now, sub, again.as_bytes());
/// match hub.handle(now, publisher, b"@ <vision> 0\nball x 1 y 2\n") {
///     Outcome::Forward { dests, .. } => assert_eq!(dests, &[sub]),
///     other => panic!("{other:?}"),
/// }
/// ```
#[derive(Debug)]
pub struct Hub {
    config: HubConfig,
    started: Instant,
    clients: HashMap<SocketAddr, Client>,
    subscribers: HashMap<Subject, Vec<SocketAddr>>,
    /// Clients that asked to tap; one that has since lost its lease (or its
    /// tap) is skipped when routing and pruned at the next sweep.
    taps: Vec<SocketAddr>,
    min_priority: Priority,
    /// When a raised minimum priority lapses unless its console renews it.
    min_priority_until: Option<Instant>,
    counters: Counters,
    cookies: CookieJar,
    /// Proven requests, per source.
    rates: RateTable,
    /// Cookies handed to unproven sources, per source, in a table of their
    /// own: a forger cannot spend a real client's rate.
    challenges: RateTable,
    signers: HashMap<SocketAddr, ReplayWindow>,
    reply_bytes: usize,
    /// The status report last built, and when: served again until it is
    /// `status_interval` old.
    status_cache: Option<(Instant, Vec<u8>)>,
    /// Operator actions are logged at most once a second; these were not.
    quiet_logs: u64,
    last_log: Option<Instant>,
    /// At least the number of clients that asked for batches: counted up
    /// with each request, counted exactly at each sweep.
    batching: usize,
    /// Reused for every forward, so routing allocates nothing in steady state.
    dests: Vec<SocketAddr>,
    replies: VecDeque<Transmit>,
    next_sweep: Instant,
    /// The address the hub's socket is bound to; never a client.
    local: Option<SocketAddr>,
}

impl Hub {
    /// A hub with no clients, started at `now`.
    pub fn new(mut config: HubConfig, now: Instant) -> Hub {
        // Below this, a hub and its clients would do little but refresh.
        config.lease = config.lease.clamp(crate::config::MIN_LEASE, LONGEST);
        config.auth_window = config.auth_window.min(LONGEST);
        config.status_interval = config.status_interval.min(LONGEST);
        let next_sweep = now + sweep_interval(&config);
        let rates = RateTable::new(config.control_rate, config.control_burst);
        let challenges = RateTable::new(config.control_rate, config.control_burst);
        Hub {
            started: now,
            clients: HashMap::new(),
            subscribers: HashMap::new(),
            taps: Vec::new(),
            min_priority: Priority(i32::MIN),
            min_priority_until: None,
            counters: Counters::default(),
            cookies: CookieJar::new(now),
            rates,
            config,
            challenges,
            signers: HashMap::new(),
            reply_bytes: 0,
            status_cache: None,
            quiet_logs: 0,
            last_log: None,
            batching: 0,
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

    /// The most bytes a datagram of joined packets to `addr` may hold, as
    /// the client asked ([`Request::Batch`]); 0 for one packet a datagram.
    pub fn batch_bytes(&self, addr: &SocketAddr) -> usize {
        // Asked for every destination of every packet: with no client
        // batching (the common case), no lookup.
        if self.batching == 0 {
            return 0;
        }
        self.clients.get(addr).map_or(0, |c| c.batch)
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
        if is_bad_source(&src, self.local.as_ref()) {
            return self.dropped(DropReason::BadSource);
        }
        if !self.config.allow.is_empty() && !self.config.allow.iter().any(|c| c.contains(&src)) {
            return self.dropped(DropReason::NotAllowed);
        }
        let (data, proof) = match self.authenticate(src, data) {
            Ok(checked) => checked,
            Err(reason) => return self.dropped(reason),
        };
        let packet = match Packet::parse(data) {
            Ok(p) => p,
            Err(e) => {
                tracing::debug!(%src, error = %e, "malformed packet");
                return self.dropped(DropReason::Malformed);
            }
        };
        if packet.has_subject(HUB_SUBJECT) {
            return self.control(now, src, &packet, data.len(), proof);
        }
        self.lapse_min_priority(now);
        if packet.priority() < self.min_priority {
            return self.dropped(DropReason::BelowMinPriority);
        }
        self.route(&packet);
        if !self.dests.is_empty() && self.clients.get(&src).is_some_and(|c| c.no_local) {
            self.dests.retain(|d| *d != src);
        }
        let key = channel_key(&packet);
        self.counters
            .published(&key, data.len(), self.config.max_channels);
        Outcome::Forward {
            len: data.len(),
            dests: &self.dests,
        }
    }

    /// Checks a signed datagram and strips its `auth` line. Without a key,
    /// an `auth` line is stripped unchecked, so a signing client can use a
    /// hub that asks for none.
    fn authenticate<'d>(
        &mut self,
        src: SocketAddr,
        data: &'d [u8],
    ) -> Result<(&'d [u8], Proof), DropReason> {
        let Some(key) = &self.config.key else {
            return Ok((auth::strip_auth(data).unwrap_or(data), Proof::None));
        };
        if !self.config.auth_all && !auth::has_auth_label(data) {
            return Ok((data, Proof::None));
        }
        let signed = key.verify(data).map_err(|_| DropReason::BadAuth)?;
        // The wall clock of this moment, not of the hub's start: a clock set
        // by NTP after the hub started must not refuse every signature.
        let wall = auth::unix_micros(SystemTime::now());
        let window = u64::try_from(self.config.auth_window.as_micros()).unwrap_or(u64::MAX);
        if signed.n.abs_diff(wall) > window {
            return Err(DropReason::BadAuth);
        }
        if !self.signers.contains_key(&src) && self.signers.len() >= MAX_SIGNERS {
            let oldest = wall.saturating_sub(window);
            self.signers.retain(|_, w| w.highest() >= oldest);
            if self.signers.len() >= MAX_SIGNERS {
                return Err(DropReason::BadAuth);
            }
        }
        if !self.signers.entry(src).or_default().accept(signed.n) {
            return Err(DropReason::BadAuth);
        }
        Ok((signed.body, Proof::Key))
    }

    fn dropped(&mut self, reason: DropReason) -> Outcome<'static> {
        self.counters.drop(reason, 1);
        Outcome::Dropped(reason)
    }

    /// Fills `self.dests` with every client subscribed to all of the
    /// packet's subjects, and every client that taps (once each).
    fn route(&mut self, packet: &Packet<'_>) {
        self.dests.clear();
        self.route_subscribers(packet);
        let clients = &self.clients;
        for tap in &self.taps {
            // Already a destination exactly when it subscribes to every subject.
            let Some(c) = clients.get(tap).filter(|c| c.tap) else {
                continue;
            };
            if !packet.subjects().all(|s| c.subs.contains_key(s)) {
                self.dests.push(*tap);
            }
        }
    }

    fn route_subscribers(&mut self, packet: &Packet<'_>) {
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
        proof: Proof,
    ) -> Outcome<'_> {
        let requests = match Request::parse_all(packet) {
            Ok(r) if r.len() <= MAX_REQUESTS => r,
            Ok(_) => return self.dropped(DropReason::BadControl),
            Err(e) => {
                tracing::debug!(%src, error = %e, "bad control request");
                return self.dropped(DropReason::BadControl);
            }
        };
        let cookie = requests.iter().find_map(|r| match r {
            Request::Cookie(c) => Some(*c),
            _ => None,
        });
        // Only a packet that proves its source, with a cookie the hub gave
        // that address, may act: otherwise anyone could aim a stream, or a
        // status report, at an address of their choice. A signature is no
        // such proof: a signed packet seen on the wire can be sent again from
        // any address.
        let proven = cookie.is_some_and(|c| self.cookies.check(&src, now, c));
        let acts = requests.iter().any(|r| !matches!(r, Request::Cookie(_)));
        if !proven {
            if acts {
                self.challenge(now, src, cookie, len);
            }
            return Outcome::Control;
        }
        // Checked only once the source is proven, so that a forger cannot
        // spend a real client's rate.
        if !self.rates.take(&src, now) {
            return self.dropped(DropReason::RateLimited);
        }
        if let Some(client) = self.clients.get_mut(&src) {
            client.last_heard = now;
        }
        let mut subscribed = false;
        let mut room_made = false;
        let mut status_sent = false;
        for request in requests {
            match request {
                Request::Subscribe(subject) => {
                    match self.subscribe(now, src, subject, &mut room_made) {
                        Ok(()) => subscribed = true,
                        Err(reason) => self.counters.drop(reason, 1),
                    }
                }
                Request::Unsubscribe(subject) => self.unsubscribe(src, &subject),
                Request::UnsubscribeAll => self.forget(src),
                Request::MinPriority(p) => self.set_min_priority(now, src, p, proof),
                // One report per packet, however many lines ask.
                Request::Status if !status_sent => {
                    status_sent = true;
                    self.status_request(now, src);
                }
                Request::Status | Request::Cookie(_) => {}
                // Kept only by a client that holds a lease, so they cost an
                // unsubscribed source nothing; a client sends them with every
                // refresh.
                Request::NoLocal => {
                    if let Some(c) = self.clients.get_mut(&src) {
                        c.no_local = true;
                    }
                }
                Request::About(text) => {
                    if let Some(c) = self.clients.get_mut(&src) {
                        c.about = text.into_boxed_str();
                    }
                }
                Request::Tap => self.tap(src, proof),
                Request::Batch(bytes) => {
                    if let Some(c) = self.clients.get_mut(&src) {
                        c.batch = bytes;
                        self.batching += usize::from(bytes > 0);
                    }
                }
            }
        }
        if subscribed {
            let lease = Reply::lease_packet(self.config.lease.as_millis() as u64);
            self.reply(src, lease);
        }
        Outcome::Control
    }

    /// Lets a client with a lease tap, while fewer than [`MAX_TAPS`] do.
    /// Lets a client with a lease tap, while fewer than [`MAX_TAPS`] do and
    /// its host holds fewer than [`MAX_TAPS_PER_HOST`]. A console (by
    /// address or key) always may: if every place is taken, it takes the
    /// place of the oldest tap that is not a console's.
    fn tap(&mut self, src: SocketAddr, proof: Proof) {
        let Some(client) = self.clients.get(&src) else {
            return;
        };
        if client.tap {
            return;
        }
        let console = self.is_console(src, proof);
        let clients = &self.clients;
        self.taps.retain(|a| clients.get(a).is_some_and(|c| c.tap));
        let same_host = self.taps.iter().filter(|a| a.ip() == src.ip()).count();
        let full = self.taps.len() >= MAX_TAPS;
        if !console && (full || same_host >= MAX_TAPS_PER_HOST) {
            self.counters.drop(DropReason::TooManyTaps, 1);
            return;
        }
        if full {
            let clients = &self.clients;
            let Some(i) = self
                .taps
                .iter()
                .position(|a| clients.get(a).is_some_and(|c| !c.console_tap))
            else {
                self.counters.drop(DropReason::TooManyTaps, 1);
                return;
            };
            let displaced = self.taps.remove(i);
            if let Some(c) = self.clients.get_mut(&displaced) {
                c.tap = false;
            }
            self.counters.drop(DropReason::TooManyTaps, 1);
        }
        if let Some(c) = self.clients.get_mut(&src) {
            c.tap = true;
            c.console_tap = console;
            self.taps.push(src);
        }
    }

    /// Whether `src` may act as an operator: signed with the key, or a console's address.
    fn is_console(&self, src: SocketAddr, proof: Proof) -> bool {
        proof == Proof::Key || self.config.consoles.iter().any(|c| c.contains(&src))
    }

    /// Answers an unproven request with the cookie for its source: never
    /// more than it sent, so a forged source cannot make the hub an amplifier.
    fn challenge(&mut self, now: Instant, src: SocketAddr, cookie: Option<Cookie>, len: usize) {
        if cookie.is_some_and(|c| c != Cookie::NONE) {
            self.counters.drop(DropReason::BadCookie, 1);
        }
        if !self.challenges.take(&src, now) {
            self.counters.drop(DropReason::RateLimited, 1);
            return;
        }
        let reply = Reply::cookie_packet(self.cookies.issue(&src, now));
        if reply.len() <= len {
            self.reply(src, reply);
        } else {
            self.counters.drop(DropReason::Unproven, 1);
        }
    }

    /// Queues a reply, unless the queue is already as long as it may grow.
    fn reply(&mut self, dest: SocketAddr, payload: Vec<u8>) {
        if self.reply_bytes + payload.len() > MAX_REPLY_BYTES {
            self.counters.drop(DropReason::RateLimited, 1);
            return;
        }
        self.reply_bytes += payload.len();
        self.replies.push_back(Transmit { dest, payload });
    }

    /// An operator's request: from a console (by address, with a cookie) or
    /// signed with the key. A raised minimum lasts one lease unless renewed,
    /// so a console that dies hands the robots back.
    fn set_min_priority(&mut self, now: Instant, src: SocketAddr, p: Priority, proof: Proof) {
        if !self.is_console(src, proof) {
            self.counters.drop(DropReason::NotConsole, 1);
            self.log_operator(now, src, "minimum priority refused: not a console");
            return;
        }
        if p != self.min_priority {
            self.log_operator(now, src, "minimum priority set");
        }
        self.min_priority = p;
        self.min_priority_until = (p != Priority(i32::MIN)).then(|| now + self.config.lease);
    }

    /// Whether a raised minimum priority has outlived its lease by `now`.
    fn min_priority_lapsed(&self, now: Instant) -> bool {
        self.min_priority_until.is_some_and(|t| t <= now)
    }

    fn lapse_min_priority(&mut self, now: Instant) {
        if self.min_priority_lapsed(now) {
            tracing::info!(
                min_priority = self.min_priority.0,
                "minimum priority lapsed: its console did not renew it"
            );
            self.min_priority = Priority(i32::MIN);
            self.min_priority_until = None;
        }
    }

    /// Logs an operator action, at most once a second: a flood of requests
    /// must not become a flood of log lines.
    fn log_operator(&mut self, now: Instant, src: SocketAddr, what: &str) {
        if self
            .last_log
            .is_some_and(|t| now.duration_since(t) < Duration::from_secs(1))
        {
            self.quiet_logs += 1;
            return;
        }
        self.last_log = Some(now);
        let unlogged = std::mem::take(&mut self.quiet_logs);
        tracing::info!(%src, min_priority = self.min_priority.0, unlogged, "{what}");
    }

    fn subscribe(
        &mut self,
        now: Instant,
        src: SocketAddr,
        subject: Subject,
        room_made: &mut bool,
    ) -> Result<(), DropReason> {
        if !self.clients.contains_key(&src) && self.clients.len() >= self.config.max_clients {
            // A table scan at most once a packet, however many lines ask.
            if *room_made {
                return Err(DropReason::TooManyClients);
            }
            *room_made = true;
            self.make_room(now, src)?;
        }
        let max_subs = self.config.max_subscriptions;
        let client = self.clients.entry(src).or_insert_with(|| Client {
            subs: HashMap::new(),
            last_heard: now,
            no_local: false,
            about: Box::from(""),
            tap: false,
            console_tap: false,
            batch: 0,
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

    /// With the table full, a proven newcomer takes the place of a client
    /// that has not renewed anything for half a lease (a live one renews every
    /// third); failing that, of the idlest client of the address that holds
    /// the most places, if that address holds more than the newcomer's. So a
    /// restarted robot can always join, and one host with many ports cannot
    /// keep everyone else out.
    fn make_room(&mut self, now: Instant, newcomer: SocketAddr) -> Result<(), DropReason> {
        let idle_after = self.config.lease / 2;
        let idlest = self
            .clients
            .iter()
            .min_by_key(|(_, c)| c.last_heard)
            .map(|(a, c)| (*a, c.last_heard));
        if let Some((addr, heard)) = idlest {
            if now.saturating_duration_since(heard) >= idle_after {
                self.forget(addr);
                return Ok(());
            }
        }
        let mut per_host: HashMap<std::net::IpAddr, (usize, Instant, SocketAddr)> = HashMap::new();
        for (addr, c) in &self.clients {
            let e = per_host
                .entry(addr.ip())
                .or_insert((0, c.last_heard, *addr));
            e.0 += 1;
            if c.last_heard < e.1 {
                (e.1, e.2) = (c.last_heard, *addr);
            }
        }
        let mine = per_host.get(&newcomer.ip()).map_or(0, |e| e.0);
        match per_host.values().max_by_key(|e| e.0) {
            Some(&(count, _, addr)) if count > mine + 1 => {
                self.forget(addr);
                Ok(())
            }
            _ => Err(DropReason::TooManyClients),
        }
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

    fn status_request(&mut self, now: Instant, src: SocketAddr) {
        let fresh = self.status_cache.as_ref().is_some_and(|(at, _)| {
            now.saturating_duration_since(*at) < self.config.status_interval
        });
        if !fresh {
            self.status_cache = Some((now, self.status(now).to_packet()));
        }
        let payload = self
            .status_cache
            .as_ref()
            .map(|(_, p)| p.clone())
            .unwrap_or_default();
        self.reply(src, payload);
    }

    /// The hub's state as the `status` request reports it. Its cost is
    /// bounded whatever the table holds: clients are listed in address order
    /// only until one datagram is full.
    pub fn status(&self, now: Instant) -> StatusReport {
        let ms = |d: Duration| d.as_millis() as u64;
        let mut addrs: Vec<&SocketAddr> = self.clients.keys().collect();
        addrs.sort_by_cached_key(|a| a.to_string());
        let mut clients = Vec::new();
        // Half the datagram for clients, the rest for channels and drops.
        let mut budget = MAX_PACKET / 2;
        let mut truncated = false;
        for addr in addrs {
            let c = &self.clients[addr];
            // A client line costs about its subscriptions' names plus a few
            // digits each; stop before the report could not be sent anyway.
            let cost =
                48 + c.about.len() + c.subs.keys().map(|s| s.as_str().len() + 8).sum::<usize>();
            if cost > budget {
                truncated = true;
                break;
            }
            budget -= cost;
            let mut subscriptions: Vec<(String, u64)> = c
                .subs
                .iter()
                .map(|(s, exp)| (s.to_string(), ms(exp.saturating_duration_since(now))))
                .collect();
            subscriptions.sort();
            clients.push(ClientInfo {
                addr: addr.to_string(),
                idle_ms: ms(now.saturating_duration_since(c.last_heard)),
                subscriptions,
                about: c.about.to_string(),
                tap: c.tap,
                batch: c.batch,
            });
        }
        let min_priority = if self.min_priority_lapsed(now) {
            Priority(i32::MIN)
        } else {
            self.min_priority
        };
        StatusReport {
            uptime_ms: ms(now.saturating_duration_since(self.started)),
            lease_ms: ms(self.config.lease),
            min_priority,
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
            truncated,
        }
    }

    /// The next reply to send, if any.
    pub fn poll_transmit(&mut self) -> Option<Transmit> {
        let t = self.replies.pop_front()?;
        self.reply_bytes -= t.payload.len();
        Some(t)
    }

    /// When the hub next needs [`handle_timeout`](Self::handle_timeout).
    pub fn poll_timeout(&self) -> Instant {
        self.next_sweep
    }

    /// Expires leases (and a raised minimum priority) that ran out by `now`.
    pub fn handle_timeout(&mut self, now: Instant) {
        if now < self.next_sweep {
            return;
        }
        self.lapse_min_priority(now);
        self.next_sweep = now + sweep_interval(&self.config);
        let subscribers = &mut self.subscribers;
        let mut batching = 0;
        self.clients.retain(|addr, client| {
            client.subs.retain(|subject, expiry| {
                let live = *expiry > now;
                if !live {
                    remove_subscriber(subscribers, subject.as_str(), *addr);
                }
                live
            });
            let keep = !client.subs.is_empty();
            batching += usize::from(keep && client.batch > 0);
            keep
        });
        self.batching = batching;
        let clients = &self.clients;
        self.taps.retain(|a| clients.get(a).is_some_and(|c| c.tap));
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
