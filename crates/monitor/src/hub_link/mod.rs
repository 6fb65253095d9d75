//! The monitor's link to its hub: what it hears, what it sends, and when each page is due a new
//! snapshot.
//!
//! The link is two hub clients, each with its own job:
//!
//! - the *data* client taps the hub (every forwarded packet, so the task board hears each
//!   negotiation subject from its first bid), and subscribes to `vision`, `debug`, `metrics`,
//!   `radio`, the game's `game.state`, `game.map`, `game.event` and `game.lobby`, and every
//!   channel the hub's status report names (up to [`EXTRA_CHANNELS`] more), so the hub view can
//!   show each one's last packet;
//! - the *control* client holds a lease on [`LEASE_CHANNEL`] (the hub answers `status` only to a
//!   client with a lease), asks for status every second, sends minimum-priority requests, and
//!   publishes the operator's packets.
//!
//! [`HubLink`] is the link with no socket, no channel and no clock, in the shape of the hub's
//! own sans-IO `Hub` (colony-hub's `broker`): time and what arrived go in
//! ([`handle_packet`](HubLink::handle_packet), [`handle_status`](HubLink::handle_status), a
//! page's command ([`prepare`](HubLink::prepare), then [`apply`](HubLink::apply)),
//! [`page_closed`](HubLink::page_closed), [`handle_timeout`](HubLink::handle_timeout)); what
//! to send and what the pages are due come out ([`poll_transmit`](HubLink::poll_transmit),
//! [`poll_output`](HubLink::poll_output)), with the next deadline
//! ([`poll_timeout`](HubLink::poll_timeout)). It owns the views it feeds ([`MonitorState`],
//! [`GameView`], [`TaskBoard`]) and every timer: when each snapshot is due, when to ask for
//! status, when held robots are commanded again, and the Foxglove arena scene's share of the
//! thread. [`thread`] runs it on a thread of its own with the two clients, so nothing in the
//! web server ever blocks on a socket.
//!
//! **Why not colony-node's runtime.** A `colony_node::Node` is one hub client that publishes,
//! with one subscription set, and its `Link` reads with `UdpClient::recv`, which passes over
//! the hub's replies. This link does not fit that without more than a small extension:
//!
//! - it is two clients, and must stay two: the hub's status shows both (the game view's listeners
//!   are read as clients other than these two, [`Listeners::from_status`]), only the control
//!   client signs as a console, and status replies on the data socket would queue behind a
//!   10,000-robot frame's 80 datagrams;
//! - it lives on the hub's replies (status reports) and sends control requests (status, minimum
//!   priority), which are not in `Node`'s vocabulary of packets in and packets out;
//! - a page's command is answered with what became of its publish (a packet too large once
//!   signed, a socket that failed), where `Node::poll_transmit` is fire and forget;
//! - `Link` holds a new client's packets up to 500 ms for the hub's first cookie, and
//!   `colony_node::run` looks at its owner every 50 ms: the operator's packets would wait, and
//!   the pages' requests, which this thread takes every 10 ms, would wait five times longer.
//!
//! So the link keeps its own thin loop ([`thread::LinkThread::run`]).
//!
//! **Time** is `std::time::Instant`, as the hub and the client session count it:
//! every view the link drives and Foxglove's [`SceneBudget`] take one, so `colony_node::Time`
//! here would be turned back into an `Instant` at every call.

use std::collections::{BTreeSet, VecDeque};
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_foxglove::{self as foxglove, SceneBudget};
use colony_wire::{Packet, Request, StatusReport, HUB_SUBJECT};

use crate::game::{Chats, GameFrame, GameView, Listeners, GAME_CHANNELS};
use crate::state::{Command, CommandError, MonitorState, PageId, CORE_CHANNELS};
use crate::tasks::TaskBoard;

mod thread;

pub use thread::LinkThread;

/// The channel the control client leases, so the hub will answer `status`.
pub const LEASE_CHANNEL: &str = "colony-monitor";
/// Channels subscribed to beyond the core ones, at most (a hub allows 256 per client).
pub const EXTRA_CHANNELS: usize = 64;
/// Subjects the data client holds, at most.
const MAX_SUBSCRIBED: usize = CORE_CHANNELS.len() + GAME_CHANNELS.len() + EXTRA_CHANNELS;
/// The world snapshot is sent at most this often...
const WORLD_EVERY: Duration = Duration::from_millis(33);
/// ...and at least this often, so staleness shows even when nothing arrives.
const WORLD_AT_LEAST: Duration = Duration::from_millis(250);
const STATUS_EVERY: Duration = Duration::from_secs(1);
/// While the override waits on a status report (to learn the hub's minimum priority), it is
/// asked for this often.
const STATUS_WANTED_EVERY: Duration = Duration::from_millis(200);
const HUB_VIEW_EVERY: Duration = Duration::from_secs(1);
/// The game view is sent at most this often (the game's state comes 5
/// times a game second, faster when the game runs fast)...
const GAME_EVERY: Duration = Duration::from_millis(50);
/// ...and at least this often, so the page sees the game go stale.
const GAME_AT_LEAST: Duration = Duration::from_millis(500);
/// The Foxglove terrain scene is built at most this often (a map can make a large one).
const TERRAIN_EVERY: Duration = Duration::from_secs(1);
/// The task board is sent at most this often...
const TASKS_EVERY: Duration = Duration::from_millis(100);
/// ...and at least this often, so robots that fall silent show.
const TASKS_AT_LEAST: Duration = Duration::from_secs(1);
/// Held robots are commanded on every new frame, and at least this often.
const OVERRIDE_EVERY: Duration = Duration::from_millis(80);

/// A world snapshot for the pages: its JSON, and the newest whole frame's robots and pucks as
/// the binary message the page draws them from ([`crate::state::bodies`]).
#[derive(Debug, Clone)]
pub struct WorldSnapshot {
    /// `{"t":"world",...}`.
    pub json: Arc<str>,
    /// The bodies of whole frame number `frame` (shared, not copied, by every page).
    pub bodies: axum::body::Bytes,
    /// Which whole frame `bodies` holds (0: none yet).
    pub frame: u64,
}

/// What the link wants done on the hub, in the order it wants it.
#[derive(Debug, Clone, PartialEq)]
pub enum Transmit {
    /// Subscribe the data client to this subject (one the hub view shows); if the client
    /// cannot, tell [`HubLink::subscribe_failed`].
    Subscribe(String),
    /// Ask the hub for its status report, on the control client.
    AskStatus,
    /// Send these requests (the override's minimum priority) on the control client.
    Request(Vec<Request>),
    /// Publish this packet on the control client: held robots' commands.
    Publish(Vec<u8>),
}

/// What the web side is due: a page's new snapshot, or a Foxglove scene to build.
#[derive(Debug, Clone)]
pub enum Output {
    /// The system monitor's world.
    World(WorldSnapshot),
    /// The system monitor's hub view, `{"t":"hub",...}`.
    Hub(Arc<str>),
    /// The game, before it is cut for each page.
    Game(Arc<GameFrame>),
    /// Each team's chat.
    Chat(Arc<Chats>),
    /// The game's map, `{"t":"map",...}`.
    Map(Arc<str>),
    /// The task board, `{"t":"tasks",...}`.
    Tasks(Arc<str>),
    /// Build this scene now ([`HubLink::scene`]) and hand it to the Foxglove viewers.
    Scene(Scene),
}

/// A Foxglove scene the link draws from its views.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scene {
    /// The sorting arena; report its build with [`HubLink::arena_built`].
    Arena,
    /// The game's battlefield.
    Battlefield,
    /// The game map's terrain.
    Terrain,
}

/// Which scenes some Foxglove viewer subscribes to: only those are built.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Watched {
    /// The arena's scene.
    pub arena: bool,
    /// The battlefield's and its terrain's.
    pub battlefield: bool,
}

/// Every page's snapshot as it stands: what the web side's channels start with.
#[derive(Debug, Clone)]
pub struct Snapshots {
    /// See [`Output::World`].
    pub world: WorldSnapshot,
    /// See [`Output::Hub`].
    pub hub: Arc<str>,
    /// See [`Output::Game`].
    pub game: Arc<GameFrame>,
    /// See [`Output::Chat`].
    pub chat: Arc<Chats>,
    /// See [`Output::Map`].
    pub map: Arc<str>,
    /// See [`Output::Tasks`].
    pub tasks: Arc<str>,
}

/// A snapshot sent when what it shows changes, at most every `every`, and every `at_least`
/// whether or not it changed.
#[derive(Debug)]
struct Cadence {
    every: Duration,
    at_least: Duration,
    last: Instant,
    /// The version of what it shows, as last sent.
    version: u64,
}

impl Cadence {
    fn new(every: Duration, at_least: Duration, start: Instant) -> Cadence {
        Cadence {
            every,
            at_least,
            last: start,
            version: 0,
        }
    }

    fn due(&self, now: Instant, version: u64) -> bool {
        let since = now.saturating_duration_since(self.last);
        (version != self.version && since >= self.every) || since >= self.at_least
    }

    fn next(&self, version: u64) -> Instant {
        let wait = if version != self.version {
            self.every
        } else {
            self.at_least
        };
        self.last + wait
    }

    fn sent(&mut self, now: Instant, version: u64) {
        self.last = now;
        self.version = version;
    }
}

/// The monitor's hub link without sockets or clocks: see the [module](self).
pub struct HubLink {
    state: MonitorState,
    game: GameView,
    tasks: TaskBoard,
    /// The link's own two clients' addresses: the game's listeners are other clients.
    ours: Vec<SocketAddr>,
    /// What the data client subscribed to: the hub view and the Foxglove feed keep to these.
    subscribed: BTreeSet<String>,
    watched: Watched,
    /// The latest time an input brought: when something made due by an input is due.
    now: Instant,
    transmits: VecDeque<Transmit>,
    outputs: VecDeque<Output>,
    next_status: Instant,
    /// When status was last asked for (`None`: not yet).
    last_status_ask: Option<Instant>,
    /// A status report came since the last [`HubLink::handle_timeout`].
    new_status: bool,
    next_override: Instant,
    /// The world frame the held robots were last commanded on.
    override_version: u64,
    world: Cadence,
    /// The bodies last sent, shared again while the frame is the same.
    bodies: axum::body::Bytes,
    scene_budget: SceneBudget,
    /// The world frame whose arena scene [`Output::Scene`] asked for.
    arena_frame: u64,
    game_sent: Cadence,
    chat_version: u64,
    map_version: u64,
    /// The map changed since the Foxglove terrain was last built; built only for a viewer.
    terrain_dirty: bool,
    last_terrain: Option<Instant>,
    tasks_sent: Cadence,
    next_hub_view: Instant,
}

impl HubLink {
    /// A link made at `now`, when the wall clock read `wall_ms` (Unix milliseconds); `ours`
    /// are its two clients' addresses.
    pub fn new(now: Instant, wall_ms: u64, ours: Vec<SocketAddr>) -> HubLink {
        let state = MonitorState::new(now, wall_ms);
        let bodies = state.world_bodies().into();
        HubLink {
            state,
            game: GameView::new(now, wall_ms),
            tasks: TaskBoard::new(now),
            ours,
            subscribed: BTreeSet::new(),
            watched: Watched::default(),
            now,
            transmits: VecDeque::new(),
            outputs: VecDeque::new(),
            next_status: now,
            last_status_ask: None,
            new_status: false,
            next_override: now,
            override_version: 0,
            world: Cadence::new(WORLD_EVERY, WORLD_AT_LEAST, now),
            bodies,
            scene_budget: SceneBudget::default(),
            arena_frame: 0,
            game_sent: Cadence::new(GAME_EVERY, GAME_AT_LEAST, now),
            chat_version: 0,
            map_version: 0,
            terrain_dirty: false,
            last_terrain: None,
            tasks_sent: Cadence::new(TASKS_EVERY, TASKS_AT_LEAST, now),
            next_hub_view: now,
        }
    }

    /// Every page's snapshot at `now`, whether or not it is due.
    pub fn snapshots(&self, now: Instant) -> Snapshots {
        Snapshots {
            world: WorldSnapshot {
                json: Arc::from(self.state.world_json(now)),
                bodies: self.bodies.clone(),
                frame: 0,
            },
            hub: Arc::from(self.state.hub_json(now)),
            game: Arc::new(self.game.frame(now)),
            chat: Arc::new(self.game.chats()),
            map: Arc::from(self.game.map_json()),
            tasks: Arc::from(self.tasks.json(now)),
        }
    }

    /// The link starts at `now`: its timers count from here, and it subscribes to the core
    /// and game channels. Status is asked for at the first timeout, and the hub view sent.
    pub fn start(&mut self, now: Instant) {
        self.now = now;
        self.next_status = now;
        self.last_status_ask = None;
        self.next_override = now;
        self.world = Cadence::new(WORLD_EVERY, WORLD_AT_LEAST, now);
        self.game_sent = Cadence::new(GAME_EVERY, GAME_AT_LEAST, now);
        self.tasks_sent = Cadence::new(TASKS_EVERY, TASKS_AT_LEAST, now);
        self.next_hub_view = now;
        for c in CORE_CHANNELS.into_iter().chain(GAME_CHANNELS) {
            self.subscribe(c);
        }
    }

    fn advance(&mut self, now: Instant) {
        self.now = self.now.max(now);
    }

    fn subscribe(&mut self, subject: &str) {
        if self.subscribed.contains(subject) || self.subscribed.len() >= MAX_SUBSCRIBED {
            return;
        }
        self.subscribed.insert(subject.to_owned());
        self.transmits
            .push_back(Transmit::Subscribe(subject.to_owned()));
    }

    /// The data client could not subscribe to `subject`: the hub view does not count on it,
    /// and the next status report that names it tries again.
    pub fn subscribe_failed(&mut self, subject: &str) {
        self.subscribed.remove(subject);
    }

    /// Which scenes Foxglove viewers want now.
    pub fn set_watched(&mut self, watched: Watched) {
        self.watched = watched;
    }

    /// A packet the data client received at `now`. True when the hub view shows it (every
    /// subject one the link subscribed to): the Foxglove feed then gets it too. The tap brings
    /// every subject anyone publishes on; the hub view keeps to the channels it chose, so a
    /// forger's new subjects cannot crowd it. The game and the task board see every packet.
    pub fn handle_packet(&mut self, now: Instant, packet: &Packet<'_>) -> bool {
        self.advance(now);
        let shown = packet.subjects().all(|s| self.subscribed.contains(s));
        if shown {
            self.state.on_packet(now, packet);
        }
        self.game.on_packet(now, packet);
        self.tasks.on_packet(now, packet);
        shown
    }

    /// The status reports one read of the control client brought at `now`: the hub view's
    /// rates, the game's listeners, the override's minimum priority; then a subscription to
    /// every channel the newest names, and the hub view is due.
    pub fn handle_status(&mut self, now: Instant, reports: impl IntoIterator<Item = StatusReport>) {
        self.advance(now);
        let mut any = false;
        for report in reports {
            self.game
                .set_listeners(Listeners::from_status(&report, &self.ours));
            self.state.on_status(now, report);
            any = true;
        }
        if any {
            self.new_status = true;
            for subject in self.state.channels_seen() {
                self.subscribe(&subject);
            }
        }
    }

    /// The packet a page's command publishes on the control client, if it has one (a forged
    /// packet, a game order), before [`apply`](Self::apply); the subjects it is published on
    /// are subscribed to first ([`poll_transmit`](Self::poll_transmit)), so the hub view shows
    /// it when it comes back. An error answers the page.
    pub fn prepare(&mut self, command: &Command) -> Result<Option<Vec<u8>>, CommandError> {
        match command {
            Command::Publish(bytes) => {
                let packet = Packet::parse(bytes).map_err(CommandError::Packet)?;
                for s in packet.subjects().filter(|s| *s != HUB_SUBJECT) {
                    self.subscribe(s);
                }
                Ok(Some(bytes.clone()))
            }
            Command::Game(order) => order.packet().map(Some).map_err(CommandError::Write),
            _ => Ok(None),
        }
    }

    /// Carries out page `page`'s command at `now`, its packet (if any) published; the
    /// answer is for the page.
    pub fn apply(
        &mut self,
        now: Instant,
        page: PageId,
        command: Command,
    ) -> Result<String, CommandError> {
        self.advance(now);
        self.state.apply(now, page, command)
    }

    /// Page `page` went away: what it held is let go. Returns how many robots.
    pub fn page_closed(&mut self, page: PageId) -> usize {
        let n = self.state.page_closed(page);
        if n > 0 {
            tracing::info!(
                page = page.0,
                robots = n,
                "a page went away: its robots are released"
            );
        }
        n
    }

    /// Does everything due by `now`: the override's requests, asking for status, commanding
    /// held robots, and each snapshot and scene whose time has come. Nothing that is not due
    /// is done, so a runtime may call this after every round of input.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.advance(now);
        self.state.poll(now);
        let requests = self.state.take_requests();
        if !requests.is_empty() {
            self.transmits.push_back(Transmit::Request(requests));
        }
        self.ask_status(now);
        self.command_held(now);
        self.send_world(now);
        self.ask_arena_scene(now);
        self.send_game(now);
        self.send_tasks(now);
        self.send_map_and_terrain(now);
        if now >= self.next_hub_view || self.new_status {
            self.next_hub_view = now + HUB_VIEW_EVERY;
            self.outputs
                .push_back(Output::Hub(Arc::from(self.state.hub_json(now))));
        }
        self.new_status = false;
    }

    fn status_wanted_at(&self) -> Option<Instant> {
        self.state.wants_status().then(|| {
            self.last_status_ask
                .map_or(self.now, |t| t + STATUS_WANTED_EVERY)
        })
    }

    fn ask_status(&mut self, now: Instant) {
        if now >= self.next_status || self.status_wanted_at().is_some_and(|t| now >= t) {
            self.transmits.push_back(Transmit::AskStatus);
            self.last_status_ask = Some(now);
            self.next_status = now + STATUS_EVERY;
        }
    }

    fn command_held(&mut self, now: Instant) {
        let frame = self.state.frame_version();
        if !self.state.held().is_empty()
            && (frame != self.override_version || now >= self.next_override)
        {
            self.override_version = frame;
            self.next_override = now + OVERRIDE_EVERY;
            for p in self.state.override_packets(now) {
                self.transmits.push_back(Transmit::Publish(p));
            }
        }
    }

    fn send_world(&mut self, now: Instant) {
        let frame = self.state.frame_version();
        if !self.world.due(now, frame) {
            return;
        }
        if frame != self.world.version {
            self.bodies = self.state.world_bodies().into();
        }
        self.world.sent(now, frame);
        self.outputs.push_back(Output::World(WorldSnapshot {
            json: Arc::from(self.state.world_json(now)),
            bodies: self.bodies.clone(),
            frame,
        }));
    }

    fn ask_arena_scene(&mut self, now: Instant) {
        let frame = self.state.frame_version();
        if self.watched.arena && self.scene_budget.due(frame, now) {
            self.arena_frame = frame;
            self.outputs.push_back(Output::Scene(Scene::Arena));
        }
    }

    fn send_game(&mut self, now: Instant) {
        let version = self.game.version();
        if self.game_sent.due(now, version) {
            if version != self.game_sent.version
                && self.watched.battlefield
                && self.game.state().is_some()
            {
                self.outputs.push_back(Output::Scene(Scene::Battlefield));
            }
            self.game_sent.sent(now, version);
            self.outputs
                .push_back(Output::Game(Arc::new(self.game.frame(now))));
        }
        if self.game.chat_version() != self.chat_version {
            self.chat_version = self.game.chat_version();
            self.outputs
                .push_back(Output::Chat(Arc::new(self.game.chats())));
        }
    }

    fn send_tasks(&mut self, now: Instant) {
        let version = self.tasks.version();
        if self.tasks_sent.due(now, version) {
            self.tasks_sent.sent(now, version);
            self.outputs
                .push_back(Output::Tasks(Arc::from(self.tasks.json(now))));
        }
    }

    /// The map only when it changes: it can be large, and every tab gets the newest on
    /// connecting anyway. Its terrain scene at most every [`TERRAIN_EVERY`].
    fn send_map_and_terrain(&mut self, now: Instant) {
        if self.game.map_version() != self.map_version {
            self.map_version = self.game.map_version();
            self.terrain_dirty = true;
            self.outputs
                .push_back(Output::Map(Arc::from(self.game.map_json())));
        }
        if self.terrain_dirty
            && self.watched.battlefield
            && self
                .last_terrain
                .is_none_or(|t| now.saturating_duration_since(t) >= TERRAIN_EVERY)
        {
            self.terrain_dirty = false;
            self.last_terrain = Some(now);
            if self.game.map().is_some() {
                self.outputs.push_back(Output::Scene(Scene::Terrain));
            }
        }
    }

    /// The next thing to do on the hub, if any.
    pub fn poll_transmit(&mut self) -> Option<Transmit> {
        self.transmits.pop_front()
    }

    /// The next thing the web side is due, if any.
    pub fn poll_output(&mut self) -> Option<Output> {
        self.outputs.pop_front()
    }

    /// When [`handle_timeout`](Self::handle_timeout) next has something to do (a time already
    /// past when an input made something due). The arena's Foxglove scene is not counted: its
    /// budget ([`SceneBudget`]) keeps its time to itself, and the runtime looks again within
    /// its tick anyway.
    pub fn poll_timeout(&self) -> Instant {
        let now = self.now;
        let held = (!self.state.held().is_empty()).then(|| {
            if self.state.frame_version() != self.override_version {
                now
            } else {
                self.next_override
            }
        });
        let changed = self.game.chat_version() != self.chat_version
            || self.game.map_version() != self.map_version
            || self.new_status;
        let terrain = (self.terrain_dirty && self.watched.battlefield)
            .then(|| self.last_terrain.map_or(now, |t| t + TERRAIN_EVERY));
        [
            Some(self.next_status),
            self.status_wanted_at(),
            held,
            Some(self.world.next(self.state.frame_version())),
            Some(self.game_sent.next(self.game.version())),
            Some(self.tasks_sent.next(self.tasks.version())),
            changed.then_some(now),
            terrain,
            self.state.next_deadline(),
        ]
        .into_iter()
        .flatten()
        .fold(self.next_hub_view, Instant::min)
    }

    /// The scene [`Output::Scene`] asked for, stamped `wall_ns` (the wall clock, ns since the
    /// Unix epoch); `None` when there is nothing to draw.
    pub fn scene(&self, scene: Scene, wall_ns: u64) -> Option<Vec<u8>> {
        match scene {
            Scene::Arena => {
                let world = self.state.world();
                let caches = world.caches().iter().map(|((r, k), p)| (*r, k.0, p.x, p.y));
                Some(foxglove::scene::arena_scene(
                    world.frame(),
                    world.arena(),
                    world.sizes(),
                    caches,
                    wall_ns,
                ))
            }
            Scene::Battlefield => self
                .game
                .state()
                .map(|s| foxglove::scene::battlefield_scene(s, wall_ns)),
            Scene::Terrain => self
                .game
                .map()
                .map(|m| foxglove::scene::terrain_scene(m, wall_ns)),
        }
    }

    /// The arena's scene was built from `started`, taking `took` of the thread; the next waits
    /// for its share ([`SceneBudget`]). Returns how many world frames were passed over.
    pub fn arena_built(&mut self, started: Instant, took: Duration) -> u64 {
        self.scene_budget.built(self.arena_frame, started, took)
    }

    /// The link stops: the requests that let every held robot go and put the hub's minimum
    /// priority back, each to be sent on its own.
    pub fn shutdown(&mut self) -> Vec<Request> {
        self.state.shutdown()
    }
}

#[cfg(test)]
mod tests;
