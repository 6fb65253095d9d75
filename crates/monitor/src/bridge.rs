//! The hub side: a thread of its own that owns two hub clients and the
//! [`MonitorState`], so nothing in the web server ever blocks on a socket.
//!
//! - The *data* client taps the hub (every forwarded packet, so the task
//!   board hears each negotiation subject from its first bid), and
//!   subscribes to `vision`, `debug`, `metrics`, `radio`,
//!   the game's `game.state`, `game.map` and `game.event`, and every channel
//!   the hub's status report names (up to [`EXTRA_CHANNELS`] more), so the
//!   hub view can show each one's last packet.
//! - The *control* client holds a lease on [`LEASE_CHANNEL`] (the hub answers
//!   `status` only to a client with a lease), asks for status every second,
//!   sends minimum-priority requests, and publishes the operator's packets.
//!
//! The web side reads snapshots from `watch` channels (the latest value
//! only: a slow browser never builds a queue) and sends requests over a
//! bounded channel, each with a one-shot for its answer and the page it came
//! from. When a page's WebSocket closes, its id comes over a channel of its
//! own (one message per connection, never refused for a full queue), and
//! what that page held is released.

use std::collections::BTreeSet;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use colony_client::UdpClient;
use colony_wire::{Packet, Reply, Request, HUB_SUBJECT};
use tokio::sync::watch;

use crate::foxglove::{self, Feed};
use crate::game::{Chats, GameFrame, GameView, Listeners, GAME_CHANNELS};
use crate::state::{Command, CommandError, MonitorState, PageId, CORE_CHANNELS};
use crate::tasks::TaskBoard;

use crate::request::Envelope;

/// The channel the control client leases, so the hub will answer `status`.
pub const LEASE_CHANNEL: &str = "colony-monitor";
/// Channels subscribed to beyond the core ones, at most (a hub allows 256 per client).
pub const EXTRA_CHANNELS: usize = 64;
/// The world snapshot is sent at most this often...
const WORLD_EVERY: Duration = Duration::from_millis(33);
/// ...and at least this often, so staleness shows even when nothing arrives.
const WORLD_AT_LEAST: Duration = Duration::from_millis(250);
const STATUS_EVERY: Duration = Duration::from_secs(1);
const HUB_VIEW_EVERY: Duration = Duration::from_secs(1);
/// The game view is sent at most this often (the game's state comes 5
/// times a game second, faster when the game runs fast)...
const GAME_EVERY: Duration = Duration::from_millis(50);
/// The Foxglove terrain scene is built at most this often (a map can make a large one).
const TERRAIN_EVERY: Duration = Duration::from_secs(1);
/// ...and at least this often, so the page sees the game go stale.
const GAME_AT_LEAST: Duration = Duration::from_millis(500);
/// The task board is sent at most this often...
const TASKS_EVERY: Duration = Duration::from_millis(100);
/// ...and at least this often, so robots that fall silent show.
const TASKS_AT_LEAST: Duration = Duration::from_secs(1);
/// Held robots are commanded on every new frame, and at least this often.
const OVERRIDE_EVERY: Duration = Duration::from_millis(80);
/// The longest the loop sleeps, so browser requests are taken promptly.
const TICK: Duration = Duration::from_millis(10);

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

/// The data client's receive buffer asked for: a 10,000-robot frame is some 80 datagrams of
/// 60 kB arriving at once, and the default buffer (about 208 KiB) would drop all but a few.
const DATA_BUFFER: usize = 32 << 20;

/// The bridge's two clients and its state, ready to run on a thread.
pub struct Bridge {
    data: UdpClient,
    control: UdpClient,
    state: MonitorState,
    game: GameView,
    tasks: TaskBoard,
    subscribed: BTreeSet<String>,
    world_tx: watch::Sender<WorldSnapshot>,
    hub_tx: watch::Sender<Arc<str>>,
    game_tx: watch::Sender<Arc<GameFrame>>,
    chat_tx: watch::Sender<Arc<Chats>>,
    map_tx: watch::Sender<Arc<str>>,
    tasks_tx: watch::Sender<Arc<str>>,
    /// Every packet and the scenes, for Foxglove viewers.
    feed: Feed,
}

/// The web side's ends of the bridge.
pub struct Handles {
    pub world: watch::Receiver<WorldSnapshot>,
    pub hub: watch::Receiver<Arc<str>>,
    /// The game, cut for each page by the page's session (what a team's player may see).
    pub game: watch::Receiver<Arc<GameFrame>>,
    /// Each team's chat, as JSON for the pages playing it.
    pub chat: watch::Receiver<Arc<Chats>>,
    pub map: watch::Receiver<Arc<str>>,
    pub tasks: watch::Receiver<Arc<str>>,
}

impl Bridge {
    /// Makes both clients for the hub at `hub` (nothing is sent yet); the
    /// control client signs with `key`, if given, to act as a console.
    pub fn connect(
        hub: SocketAddr,
        key: Option<colony_wire::auth::Key>,
        feed: Feed,
    ) -> Result<(Bridge, Handles), colony_client::ClientError> {
        let mut data = UdpClient::connect(hub)?;
        enlarge_receive_buffer(&data, DATA_BUFFER);
        // Kept with every refresh; a hub that refuses it counts `too_many_taps`.
        data.set_standing(vec![Request::Tap])?;
        let mut control = UdpClient::connect(hub)?;
        if let Some(key) = key {
            control.set_key(key);
        }
        let now = Instant::now();
        let wall = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64);
        let state = MonitorState::new(now, wall);
        let game = GameView::new(now, wall);
        let (world_tx, world) = watch::channel(WorldSnapshot {
            json: Arc::from(state.world_json(now)),
            bodies: state.world_bodies().into(),
            frame: 0,
        });
        let (hub_tx, hub) = watch::channel(Arc::from(state.hub_json(now)));
        let (game_tx, game_rx) = watch::channel(Arc::new(game.frame(now)));
        let (map_tx, map) = watch::channel(Arc::from(game.map_json()));
        let (chat_tx, chat) = watch::channel(Arc::new(game.chats()));
        let tasks = TaskBoard::new(now);
        let (tasks_tx, tasks_rx) = watch::channel(Arc::from(tasks.json(now)));
        Ok((
            Bridge {
                data,
                control,
                state,
                game,
                tasks,
                subscribed: BTreeSet::new(),
                world_tx,
                hub_tx,
                game_tx,
                map_tx,
                chat_tx,
                tasks_tx,
                feed,
            },
            Handles {
                world,
                hub,
                game: game_rx,
                chat,
                map,
                tasks: tasks_rx,
            },
        ))
    }

    fn subscribe(&mut self, subject: &str) {
        if self.subscribed.contains(subject)
            || self.subscribed.len() >= CORE_CHANNELS.len() + GAME_CHANNELS.len() + EXTRA_CHANNELS
        {
            return;
        }
        match self.data.subscribe(subject) {
            Ok(()) => {
                self.subscribed.insert(subject.to_owned());
            }
            Err(e) => tracing::debug!(subject, error = %e, "cannot subscribe"),
        }
    }

    /// Runs until `stop`, then lets every held robot go, restores the hub's
    /// minimum priority if it raised it, and drops its subscriptions.
    pub fn run(
        mut self,
        requests: Receiver<Envelope>,
        closed: Receiver<PageId>,
        stop: Arc<AtomicBool>,
    ) {
        for c in CORE_CHANNELS.into_iter().chain(GAME_CHANNELS) {
            self.subscribe(c);
        }
        if let Err(e) = self.control.subscribe(LEASE_CHANNEL) {
            tracing::warn!(error = %e, "cannot take the monitor's lease");
        }
        let start = Instant::now();
        let mut next_status = start;
        let mut last_status_ask = start - STATUS_EVERY;
        let mut next_override = start;
        let mut override_version = 0;
        let mut last_world = start;
        let mut world_version = 0;
        let mut scene_budget = foxglove::SceneBudget::default();
        let mut next_hub_view = start;
        let mut last_game = start;
        let mut game_version = 0;
        let mut chat_version = 0;
        let mut map_version = 0;
        // The map changed since the Foxglove terrain was last built; built only for a viewer.
        let mut terrain_dirty = false;
        let mut last_terrain: Option<Instant> = None;
        let mut last_tasks = start;
        let mut tasks_version = 0;
        while !stop.load(Ordering::Relaxed) {
            let now = Instant::now();
            let wake = [
                self.data.next_deadline(),
                self.control.next_deadline(),
                self.state.next_deadline(),
            ]
            .into_iter()
            .flatten()
            .fold(now + TICK, Instant::min);
            if let Err(e) = self.data.wait(Some(wake)) {
                tracing::warn!(error = %e, "waiting on the hub socket failed");
                std::thread::sleep(TICK);
            }
            let now = Instant::now();
            for c in [&mut self.data, &mut self.control] {
                if let Err(e) = c.poll(now) {
                    tracing::debug!(error = %e, "cannot reach the hub");
                }
            }
            self.receive(now);
            let mut new_status = false;
            loop {
                match self.control.recv_reply() {
                    Ok(Some(Reply::Status(report))) => {
                        let ours: Vec<_> = [&self.data, &self.control]
                            .iter()
                            .filter_map(|c| c.local_addr().ok())
                            .collect();
                        self.game
                            .set_listeners(Listeners::from_status(&report, &ours));
                        self.state.on_status(now, report);
                        new_status = true;
                    }
                    Ok(Some(Reply::Lease { .. } | Reply::Cookie(_))) => {}
                    Ok(None) => break,
                    Err(e) => {
                        tracing::debug!(error = %e, "control socket");
                        break;
                    }
                }
            }
            if new_status {
                for subject in self.state.channels_seen() {
                    self.subscribe(&subject);
                }
            }
            // Closes are read before requests and applied after them: a request a page sent
            // before it closed is then always carried out first, so it cannot take robots
            // for a page already gone.
            let closes: Vec<PageId> = closed.try_iter().collect();
            loop {
                match requests.try_recv() {
                    Ok((page, command, answer)) => {
                        let result = self.carry_out(now, page, command);
                        let _ = answer.send(result);
                    }
                    Err(TryRecvError::Empty) => break,
                    // The web server is gone: so are we.
                    Err(TryRecvError::Disconnected) => {
                        stop.store(true, Ordering::Relaxed);
                        break;
                    }
                }
            }
            for page in closes {
                let n = self.state.page_closed(page);
                if n > 0 {
                    tracing::info!(
                        page = page.0,
                        robots = n,
                        "a page went away: its robots are released"
                    );
                }
            }
            self.state.poll(now);
            self.send_requests();
            let ask_now = now >= next_status
                || (self.state.wants_status()
                    && now >= last_status_ask + Duration::from_millis(200));
            if ask_now {
                if let Err(e) = self.control.request(&[Request::Status]) {
                    tracing::debug!(error = %e, "cannot ask for status");
                }
                last_status_ask = now;
                next_status = now + STATUS_EVERY;
            }
            if !self.state.held().is_empty()
                && (self.state.frame_version() != override_version || now >= next_override)
            {
                override_version = self.state.frame_version();
                next_override = now + OVERRIDE_EVERY;
                for p in self.state.override_packets(now) {
                    if let Err(e) = self.control.publish(&p) {
                        tracing::debug!(error = %e, "cannot publish an override");
                    }
                }
            }
            let since = now.saturating_duration_since(last_world);
            if (self.state.frame_version() != world_version && since >= WORLD_EVERY)
                || since >= WORLD_AT_LEAST
            {
                let frame = self.state.frame_version();
                let bodies = if frame == world_version {
                    self.world_tx.borrow().bodies.clone()
                } else {
                    self.state.world_bodies().into()
                };
                world_version = frame;
                last_world = now;
                self.world_tx.send_replace(WorldSnapshot {
                    json: Arc::from(self.state.world_json(now)),
                    bodies,
                    frame,
                });
            }
            // The arena's scene for Foxglove, within its share of this thread.
            let frame = self.state.frame_version();
            if self.feed.wants_arena() && scene_budget.due(frame, now) {
                let started = Instant::now();
                let world = self.state.world();
                let caches = world.caches().iter().map(|((r, k), p)| (*r, k.0, p.x, p.y));
                let scene = foxglove::scene::arena_scene(
                    world.frame(),
                    world.arena(),
                    world.sizes(),
                    caches,
                    foxglove::now_ns(),
                );
                self.feed.on_arena(scene, foxglove::now_ns());
                let skipped = scene_budget.built(frame, started, started.elapsed());
                self.feed.on_scenes_skipped(skipped);
            }
            let since = now.saturating_duration_since(last_game);
            if (self.game.version() != game_version && since >= GAME_EVERY)
                || since >= GAME_AT_LEAST
            {
                if self.game.version() != game_version && self.feed.wants_battlefield() {
                    if let Some(state) = self.game.state() {
                        let ns = foxglove::now_ns();
                        self.feed
                            .on_battlefield(foxglove::scene::battlefield_scene(state, ns), ns);
                    }
                }
                game_version = self.game.version();
                last_game = now;
                self.game_tx.send_replace(Arc::new(self.game.frame(now)));
            }
            if self.game.chat_version() != chat_version {
                chat_version = self.game.chat_version();
                self.chat_tx.send_replace(Arc::new(self.game.chats()));
            }
            let since = now.saturating_duration_since(last_tasks);
            if (self.tasks.version() != tasks_version && since >= TASKS_EVERY)
                || since >= TASKS_AT_LEAST
            {
                tasks_version = self.tasks.version();
                last_tasks = now;
                self.tasks_tx.send_replace(Arc::from(self.tasks.json(now)));
            }
            // The map only when it changes: it can be large, and every tab
            // gets the newest on connecting anyway.
            if self.game.map_version() != map_version {
                map_version = self.game.map_version();
                terrain_dirty = true;
                self.map_tx.send_replace(Arc::from(self.game.map_json()));
            }
            if terrain_dirty
                && self.feed.wants_battlefield()
                && last_terrain.is_none_or(|t| now.saturating_duration_since(t) >= TERRAIN_EVERY)
            {
                terrain_dirty = false;
                last_terrain = Some(now);
                if let Some(map) = self.game.map() {
                    let ns = foxglove::now_ns();
                    self.feed
                        .on_terrain(foxglove::scene::terrain_scene(map, ns), ns);
                }
            }
            if now >= next_hub_view || new_status {
                next_hub_view = now + HUB_VIEW_EVERY;
                self.hub_tx
                    .send_replace(Arc::from(self.state.hub_json(now)));
            }
        }
        for r in self.state.shutdown() {
            let _ = self.control.request(&[r]);
        }
        let _ = self.data.unsubscribe_all();
        let _ = self.control.unsubscribe_all();
    }

    /// Takes in what waits on the data socket (bounded, so the loop keeps turning).
    fn receive(&mut self, now: Instant) {
        for _ in 0..50_000 {
            match self.data.recv() {
                Ok(Some(packet)) => {
                    // The tap brings every subject anyone publishes on; the hub view (and the
                    // Foxglove feed) keep to the channels it chose, so a forger's new subjects
                    // cannot crowd them.
                    if packet.subjects().all(|s| self.subscribed.contains(s)) {
                        self.state.on_packet(now, &packet);
                        self.feed.on_packet(&packet, foxglove::now_ns());
                    }
                    self.game.on_packet(now, &packet);
                    self.tasks.on_packet(now, &packet);
                }
                Ok(None) => return,
                Err(e) => {
                    tracing::debug!(error = %e, "data socket");
                    return;
                }
            }
        }
    }

    fn send_requests(&mut self) {
        let requests = self.state.take_requests();
        if !requests.is_empty() {
            if let Err(e) = self.control.request(&requests) {
                tracing::warn!(error = %e, "cannot send a request to the hub");
            }
        }
    }

    fn carry_out(
        &mut self,
        now: Instant,
        page: PageId,
        command: Command,
    ) -> Result<String, CommandError> {
        if let Command::Publish(bytes) = &command {
            // Subscribe first, so the hub view shows the packet when it comes back.
            let subjects: Vec<String> = match Packet::parse(bytes) {
                Ok(p) => p.subjects().map(str::to_owned).collect(),
                Err(e) => return Err(CommandError::Packet(e)),
            };
            for s in subjects.iter().filter(|s| s.as_str() != HUB_SUBJECT) {
                self.subscribe(s);
            }
            self.control.publish(bytes).map_err(CommandError::Publish)?;
        }
        if let Command::Game(order) = &command {
            let bytes = order.packet().map_err(CommandError::Write)?;
            self.control
                .publish(&bytes)
                .map_err(CommandError::Publish)?;
        }
        self.state.apply(now, page, command)
    }
}

/// Asks for `bytes` of receive buffer on `client`'s socket, past `net.core.rmem_max` where the
/// process may; what the kernel grants is logged, and too little shows as frames missing.
fn enlarge_receive_buffer(client: &UdpClient, bytes: usize) {
    use colony_sys::buffers::{self, Buffer};
    let _ = buffers::set_size(client, Buffer::Receive, bytes, false);
    if buffers::size(client, Buffer::Receive).map_or(0, |b| b / 2) < bytes {
        let _ = buffers::set_size(client, Buffer::Receive, bytes, true);
    }
    let got = buffers::size(client, Buffer::Receive).map_or(0, |b| b / 2);
    if got < bytes / 4 {
        tracing::warn!(
            asked = bytes,
            got,
            "the monitor's receive buffer is small: a big swarm's frames may go missing \
             (raise net.core.rmem_max)"
        );
    } else {
        tracing::debug!(asked = bytes, got, "the monitor's receive buffer");
    }
}
