//! The client's side of the protocol, with no socket and no clock.

use std::time::{Duration, Instant, SystemTime};

use colony_wire::auth::{Key, Signer};
use colony_wire::{Cookie, Packet, Reply, Request, Subject, MAX_PACKET};

/// Requests sent this recently are sent again when the hub answers with a
/// cookie instead: they were sent before the hub knew this address (or
/// before it restarted), and it did not act on them.
const RESEND_WITHIN: Duration = Duration::from_secs(2);
/// A second cookie this soon after the last is not taken: replies forged from
/// the hub's address, alternating two cookies, could otherwise keep a client
/// resending everything it holds.
const COOKIE_EVERY: Duration = Duration::from_millis(250);
/// The longest lease a client believes.
const LONGEST_LEASE: Duration = Duration::from_secs(86_400);

/// How often a client talks to the hub to keep its subscriptions.
#[derive(Debug, Clone)]
pub struct ClientConfig {
    /// A subscription is refreshed this often while data flows; well inside
    /// the hub's default 10 s lease, so two lost refreshes in a row are harmless.
    pub refresh: Duration,
    /// A channel silent this long is subscribed again at once: after a hub
    /// restart, data flows again within about this time.
    pub resubscribe_after: Duration,
    /// With no datagram from the hub for this long, [`HubState::Unreachable`].
    /// The hub's default lease: by then a live hub has answered.
    pub unreachable_after: Duration,
}

impl Default for ClientConfig {
    fn default() -> Self {
        ClientConfig {
            refresh: Duration::from_secs(3),
            resubscribe_after: Duration::from_secs(1),
            unreachable_after: Duration::from_secs(10),
        }
    }
}

/// Whether the hub seems to be there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HubState {
    /// Nothing heard yet, and it is too early to say.
    Unknown,
    /// Heard from within [`ClientConfig::unreachable_after`].
    Alive,
    /// Silent for `silent_for` while the client was asking it for data.
    Unreachable {
        /// How long nothing was heard.
        silent_for: Duration,
    },
}

#[derive(Debug)]
struct Subscription {
    subject: Subject,
    added: Instant,
    last_data: Option<Instant>,
    last_request: Option<Instant>,
}

impl Subscription {
    /// When this subscription next needs a subscribe request: at once when
    /// new; then every `refresh` while data flows, or every
    /// `resubscribe_after` while the channel is silent.
    fn due(&self, config: &ClientConfig, refresh: Duration) -> Instant {
        let Some(asked) = self.last_request else {
            return self.added;
        };
        let heard = self.last_data.map_or(asked, |d| d.max(asked));
        (asked + refresh).min(heard + config.resubscribe_after)
    }
}

/// The protocol state of one client: subscriptions, their refresh timers and
/// the hub's liveness. Feed it time and received datagrams; take the
/// datagrams it wants sent from [`poll_transmit`](Session::poll_transmit).
#[derive(Debug)]
pub struct Session {
    config: ClientConfig,
    subs: Vec<Subscription>,
    outbox: Vec<Vec<u8>>,
    started: Instant,
    last_from_hub: Option<Instant>,
    lease: Option<Duration>,
    /// The hub's proof that it reaches us; sent with every request.
    cookie: Cookie,
    signer: Option<Signer>,
    /// The latest time any call gave.
    clock: Instant,
    /// One-off requests lately sent, to send again with a fresh cookie.
    recent: Vec<(Instant, Vec<Request>)>,
    /// When the session last asked the hub anything, and last took a cookie.
    last_asked: Option<Instant>,
    last_cookie: Option<Instant>,
    /// Sent with every subscription refresh ([`Session::set_standing`]).
    standing: Vec<Request>,
}

/// What a datagram from the hub was.
#[derive(Debug)]
pub enum Incoming<'a> {
    /// A packet published on a subscribed channel.
    Packet(Packet<'a>),
    /// The hub's own answer (a lease, a status report); already noted by the session.
    Reply(Reply),
}

impl Session {
    /// A session with no subscriptions, started at `now`.
    pub fn new(config: ClientConfig, now: Instant) -> Session {
        Session {
            config,
            subs: Vec::new(),
            outbox: Vec::new(),
            started: now,
            last_from_hub: None,
            lease: None,
            cookie: Cookie::NONE,
            signer: None,
            clock: now,
            recent: Vec::new(),
            last_asked: None,
            last_cookie: None,
            standing: Vec::new(),
        }
    }

    /// Signs every datagram this session sends with `key`, as a hub started
    /// with `--key` asks of a console (and of everyone, with `--auth-all`).
    pub fn set_key(&mut self, key: Key) {
        self.signer = Some(Signer::new(key));
    }

    /// Signs a datagram the application publishes, when the session has a
    /// key; leaves it as it is otherwise.
    pub fn sign(&mut self, datagram: &mut Vec<u8>) {
        if let Some(signer) = &mut self.signer {
            signer.sign(datagram, SystemTime::now());
        }
    }

    /// Whether this session signs what it sends.
    pub fn signs(&self) -> bool {
        self.signer.is_some()
    }

    /// The cookie the hub gave this address, once it has.
    pub fn cookie(&self) -> Option<Cookie> {
        (self.cookie != Cookie::NONE).then_some(self.cookie)
    }

    /// A control packet with this session's cookie in front.
    fn control(&self, requests: &[Request]) -> Vec<u8> {
        let mut all = Vec::with_capacity(requests.len() + 1);
        all.push(Request::Cookie(self.cookie));
        all.extend_from_slice(requests);
        Request::to_packet(&all)
    }

    fn tick(&mut self, now: Instant) {
        self.clock = self.clock.max(now);
    }

    /// Sends a one-off request now, and keeps it a while in case the hub
    /// answers with a cookie instead.
    fn send_once(&mut self, requests: Vec<Request>) {
        self.outbox.push(self.control(&requests));
        let clock = self.clock;
        self.last_asked = Some(clock);
        self.recent
            .retain(|(at, _)| clock.saturating_duration_since(*at) < RESEND_WITHIN);
        self.recent.push((clock, requests));
    }

    /// The timings it was made with.
    pub fn config(&self) -> &ClientConfig {
        &self.config
    }

    /// Subscribes to `subject`; the request goes out with the next transmit.
    pub fn subscribe(&mut self, now: Instant, subject: Subject) {
        self.tick(now);
        if !self.subs.iter().any(|s| s.subject == subject) {
            self.subs.push(Subscription {
                subject,
                added: now,
                last_data: None,
                last_request: None,
            });
        }
    }

    /// Drops a subscription; the request goes out with the next transmit.
    pub fn unsubscribe(&mut self, subject: &Subject) {
        if let Some(i) = self.subs.iter().position(|s| &s.subject == subject) {
            self.subs.remove(i);
            self.send_once(vec![Request::Unsubscribe(subject.clone())]);
        }
    }

    /// Drops every subscription; the request goes out with the next transmit.
    pub fn unsubscribe_all(&mut self) {
        self.subs.clear();
        self.send_once(vec![Request::UnsubscribeAll]);
    }

    /// Queues any control request (status, minimum priority, ...).
    pub fn request(&mut self, requests: &[Request]) {
        self.send_once(requests.to_vec());
    }

    /// Requests that describe this client rather than ask for anything
    /// ([`Request::NoLocal`], [`Request::About`]): the hub keeps them only
    /// while the client holds a lease, so they go with every subscription
    /// refresh, and a restarted hub learns them again with the
    /// subscriptions. A change is sent at once.
    pub fn set_standing(&mut self, requests: Vec<Request>) {
        if requests == self.standing {
            return;
        }
        self.standing = requests;
        if !self.subs.is_empty() && !self.standing.is_empty() {
            self.send_once(self.standing.clone());
        }
    }

    /// The subjects this session keeps subscribed.
    pub fn subscriptions(&self) -> impl Iterator<Item = &Subject> {
        self.subs.iter().map(|s| &s.subject)
    }

    /// The hub's lease time, once it has told us.
    pub fn lease(&self) -> Option<Duration> {
        self.lease
    }

    /// Notes a datagram from the hub: a reply is returned as such, a packet
    /// as itself. A packet that does not parse is an error for the caller to report.
    pub fn handle_datagram<'a>(
        &mut self,
        now: Instant,
        data: &'a [u8],
    ) -> Result<Incoming<'a>, colony_wire::ParseError> {
        self.tick(now);
        self.last_from_hub = Some(now);
        let packet = Packet::parse(data)?;
        if let Some(Ok(reply)) = Reply::parse(&packet) {
            match reply {
                // A forged `lease ms 0` must not set the client spinning.
                Reply::Lease { ms } => {
                    let shortest = Duration::from_millis(colony_wire::MIN_LEASE_MS);
                    self.lease = Some(Duration::from_millis(ms).clamp(shortest, LONGEST_LEASE));
                }
                Reply::Cookie(cookie) => self.take_cookie(now, cookie),
                Reply::Status(_) => {}
            }
            return Ok(Incoming::Reply(reply));
        }
        self.note_data(now, &packet);
        Ok(Incoming::Packet(packet))
    }

    /// The hub did not know us (a new session, or a restarted hub): ask again,
    /// now with its cookie, for everything it may not have acted on.
    fn take_cookie(&mut self, now: Instant, cookie: Cookie) {
        if cookie == self.cookie || cookie == Cookie::NONE {
            // The same cookie again means the hub refused it for a reason of
            // its own; asking again at once could only loop.
            return;
        }
        // Taken only in answer to something asked, and not twice in quick
        // succession: what is resent for a cookie is a burst.
        let asked = self
            .last_asked
            .is_some_and(|t| now.saturating_duration_since(t) < RESEND_WITHIN);
        let too_soon = self
            .last_cookie
            .is_some_and(|t| now.saturating_duration_since(t) < COOKIE_EVERY);
        if !asked || too_soon {
            return;
        }
        self.cookie = cookie;
        self.last_cookie = Some(now);
        // One-off requests first: an unsubscribe followed by a subscribe to
        // the same channel must end subscribed.
        let recent = std::mem::take(&mut self.recent);
        for (at, requests) in recent {
            if now.saturating_duration_since(at) < RESEND_WITHIN {
                self.send_once(requests);
            }
        }
        for s in &mut self.subs {
            s.last_request = None;
        }
        self.handle_timeout(now);
    }

    /// Notes that data arrived for the packet's subjects, and that the hub is alive.
    pub fn note_data(&mut self, now: Instant, packet: &Packet<'_>) {
        self.last_from_hub = Some(now);
        for s in &mut self.subs {
            if packet.has_subject(s.subject.as_str()) {
                s.last_data = Some(now);
            }
        }
    }

    /// How often subscriptions are refreshed: as configured, but at least
    /// three times per lease once the hub has said how long its leases last.
    pub fn refresh_interval(&self) -> Duration {
        match self.lease {
            Some(lease) => self.config.refresh.min(lease / 3),
            None => self.config.refresh,
        }
    }

    /// When the session next needs [`handle_timeout`](Session::handle_timeout).
    pub fn poll_timeout(&self) -> Option<Instant> {
        let refresh = self.refresh_interval();
        self.subs.iter().map(|s| s.due(&self.config, refresh)).min()
    }

    /// Queues a subscribe request for every subscription that is due by `now`.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.tick(now);
        let (config, refresh) = (&self.config, self.refresh_interval());
        let due: Vec<Subject> = self
            .subs
            .iter_mut()
            .filter(|s| s.due(config, refresh) <= now)
            .map(|s| {
                s.last_request = Some(now);
                s.subject.clone()
            })
            .collect();
        if !due.is_empty() {
            self.last_asked = Some(now);
        }
        // One control packet carries many subscriptions; split only to fit a datagram.
        let per_packet = (MAX_PACKET - 1024) / (16 + colony_wire::MAX_SUBJECT_LEN);
        for chunk in due.chunks(per_packet) {
            let mut requests: Vec<Request> =
                chunk.iter().cloned().map(Request::Subscribe).collect();
            requests.extend_from_slice(&self.standing);
            self.outbox.push(self.control(&requests));
        }
    }

    /// The next datagram to send to the hub.
    pub fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        if self.outbox.is_empty() {
            return None;
        }
        let mut datagram = self.outbox.remove(0);
        self.sign(&mut datagram);
        Some(datagram)
    }

    /// Whether the hub has been heard from recently.
    pub fn hub_state(&self, now: Instant) -> HubState {
        let since = self.last_from_hub.unwrap_or(self.started);
        let silent_for = now.saturating_duration_since(since);
        match self.last_from_hub {
            _ if silent_for >= self.config.unreachable_after && !self.subs.is_empty() => {
                HubState::Unreachable { silent_for }
            }
            Some(_) => HubState::Alive,
            None => HubState::Unknown,
        }
    }
}
