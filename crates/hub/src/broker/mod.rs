//! The sans-IO hub: the broker's whole state and the datagrams it handles.
//!
//! [`Hub::handle`] takes each datagram: it checks the source and any signature, then either
//! routes a published packet through the subscription table ([`table`]) or acts on a control
//! request ([`control`]); [`status`] builds the report a `status` request gets.

use std::collections::{HashMap, VecDeque};
use std::net::SocketAddr;
use std::time::{Duration, Instant, SystemTime};

use colony_wire::auth::{self, ReplayWindow};
use colony_wire::{Packet, Priority, Subject, HUB_SUBJECT};

use crate::access::is_bad_source;
use crate::config::HubConfig;
use crate::cookie::CookieJar;
use crate::counters::{Counters, DropReason};
use crate::rate::RateTable;

mod control;
mod status;
mod table;

use table::{remove_subscriber, Client};

/// Senders whose replay windows the hub keeps.
const MAX_SIGNERS: usize = 4096;
/// Requests one control packet may carry: more than a client ever sends at
/// once (its subscriptions are capped well below), so that one packet's work
/// stays bounded.
const MAX_REQUESTS: usize = 1024;
/// Replies waiting to be sent, in bytes: beyond this, new ones are dropped
/// (and counted) rather than queued.
const MAX_REPLY_BYTES: usize = 8 << 20;
/// Clients that may tap at once ([`Request::Tap`](colony_wire::Request::Tap)): each costs the hub one
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
    /// the client asked ([`Request::Batch`](colony_wire::Request::Batch)); 0 for one packet a datagram.
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
