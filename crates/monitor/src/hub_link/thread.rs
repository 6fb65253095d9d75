//! The hub link's runtime: a thread of its own with the two hub clients, the pages' channels
//! and the Foxglove feed. It moves datagrams and time between the sockets and the
//! [`HubLink`], and what the link says is due out to the web side; it decides nothing itself
//! but what an I/O failure means.
//!
//! The web side reads snapshots from `watch` channels (the latest value only: a slow browser
//! never builds a queue) and sends requests over a bounded channel, each with a one-shot for its
//! answer and the page it came from. When a page's WebSocket closes, its id comes over a channel
//! of its own (one message per connection, never refused for a full queue), and what that page
//! held is released.
//!
//! The loop sleeps on the data socket until the link's next deadline, the clients' own, or
//! [`TICK`], whichever comes first. The tick stays because the pages' requests come over std
//! channels, which cannot wake a thread waiting on a socket: without it, an operator's key
//! press would wait for the next snapshot's deadline (up to 250 ms with the world quiet).

use std::net::SocketAddr;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use colony_client::UdpClient;
use colony_foxglove::{self as foxglove, Feed};
use colony_wire::{Reply, Request};
use tokio::sync::watch;

use super::{HubLink, Output, Scene, Snapshots, Transmit, Watched, WorldSnapshot, LEASE_CHANNEL};
use crate::game::{Chats, GameFrame};
use crate::request::Envelope;
use crate::state::{Command, CommandError, PageId};

/// The longest the loop sleeps, so browser requests are taken promptly.
const TICK: Duration = Duration::from_millis(10);
/// Packets taken in one round at most, so the loop keeps turning under a flood.
const RECEIVE_BUDGET: usize = 50_000;
/// The data client's receive buffer asked for: a 10,000-robot frame is some 80 datagrams of
/// 60 kB arriving at once, and the default buffer (about 208 KiB) would drop all but a few.
const DATA_BUFFER: usize = 32 << 20;

/// Where the pages' snapshots are written.
struct Pages {
    world: watch::Sender<WorldSnapshot>,
    hub: watch::Sender<Arc<str>>,
    game: watch::Sender<Arc<GameFrame>>,
    chat: watch::Sender<Arc<Chats>>,
    map: watch::Sender<Arc<str>>,
    tasks: watch::Sender<Arc<str>>,
}

/// The web side's ends of the hub link.
pub struct Handles {
    /// The system monitor's world.
    pub world: watch::Receiver<WorldSnapshot>,
    /// The hub view's JSON.
    pub hub: watch::Receiver<Arc<str>>,
    /// The game, cut for each page by the page's session (what a team's player may see).
    pub game: watch::Receiver<Arc<GameFrame>>,
    /// Each team's chat, as JSON for the pages playing it.
    pub chat: watch::Receiver<Arc<Chats>>,
    /// The game's map's JSON.
    pub map: watch::Receiver<Arc<str>>,
    /// The task board's JSON.
    pub tasks: watch::Receiver<Arc<str>>,
}

fn channels(first: Snapshots) -> (Pages, Handles) {
    let (world, world_rx) = watch::channel(first.world);
    let (hub, hub_rx) = watch::channel(first.hub);
    let (game, game_rx) = watch::channel(first.game);
    let (chat, chat_rx) = watch::channel(first.chat);
    let (map, map_rx) = watch::channel(first.map);
    let (tasks, tasks_rx) = watch::channel(first.tasks);
    (
        Pages {
            world,
            hub,
            game,
            chat,
            map,
            tasks,
        },
        Handles {
            world: world_rx,
            hub: hub_rx,
            game: game_rx,
            chat: chat_rx,
            map: map_rx,
            tasks: tasks_rx,
        },
    )
}

/// The hub link's two clients, its state and the web side's channels, ready to run on a thread.
pub struct LinkThread {
    data: UdpClient,
    control: UdpClient,
    link: HubLink,
    pages: Pages,
    /// Every packet the hub view shows and the scenes, for Foxglove viewers.
    feed: Feed,
}

impl LinkThread {
    /// Makes both clients for the hub at `hub` (nothing is sent yet but the data client's
    /// tap); the control client signs with `key`, if given, to act as a console.
    pub fn connect(
        hub: SocketAddr,
        key: Option<colony_wire::auth::Key>,
        feed: Feed,
    ) -> Result<(LinkThread, Handles), colony_client::ClientError> {
        let mut data = UdpClient::connect(hub)?;
        enlarge_receive_buffer(&data, DATA_BUFFER);
        // Kept with every refresh; a hub that refuses it counts `too_many_taps`.
        data.set_standing(vec![Request::Tap])?;
        let mut control = UdpClient::connect(hub)?;
        if let Some(key) = key {
            control.set_key(key);
        }
        let ours = [&data, &control]
            .iter()
            .filter_map(|c| c.local_addr().ok())
            .collect();
        let now = Instant::now();
        let wall = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64);
        let link = HubLink::new(now, wall, ours);
        let (pages, handles) = channels(link.snapshots(now));
        let thread = LinkThread {
            data,
            control,
            link,
            pages,
            feed,
        };
        Ok((thread, handles))
    }

    /// Runs until `stop` (or until the web side is gone), then lets every held robot go,
    /// restores the hub's minimum priority if it raised it, and drops its subscriptions.
    pub fn run(
        mut self,
        requests: Receiver<Envelope>,
        closed: Receiver<PageId>,
        stop: Arc<AtomicBool>,
    ) {
        self.link.start(Instant::now());
        self.transmit();
        if let Err(e) = self.control.subscribe(LEASE_CHANNEL) {
            tracing::warn!(error = %e, "cannot take the monitor's lease");
        }
        while !stop.load(Ordering::Relaxed) {
            self.wait();
            let now = Instant::now();
            for c in [&mut self.data, &mut self.control] {
                if let Err(e) = c.poll(now) {
                    tracing::debug!(error = %e, "cannot reach the hub");
                }
            }
            self.receive(now);
            self.read_status(now);
            self.transmit();
            // Closes are read before requests and applied after them: a request a page sent
            // before it closed is then always carried out first, so it cannot take robots
            // for a page already gone.
            let closes: Vec<PageId> = closed.try_iter().collect();
            if self.take_requests(now, &requests).is_break() {
                stop.store(true, Ordering::Relaxed);
            }
            for page in closes {
                self.link.page_closed(page);
            }
            self.link.set_watched(Watched {
                arena: self.feed.wants_arena(),
                battlefield: self.feed.wants_battlefield(),
            });
            self.link.handle_timeout(now);
            self.transmit();
            self.deliver();
        }
        for r in self.link.shutdown() {
            let _ = self.control.request(&[r]);
        }
        let _ = self.data.unsubscribe_all();
        let _ = self.control.unsubscribe_all();
    }

    /// Sleeps on the data socket until a datagram, a deadline, or [`TICK`].
    fn wait(&self) {
        let now = Instant::now();
        let wake = [
            self.data.next_deadline(),
            self.control.next_deadline(),
            Some(self.link.poll_timeout()),
        ]
        .into_iter()
        .flatten()
        .fold(now + TICK, Instant::min);
        if let Err(e) = self.data.wait(Some(wake)) {
            tracing::warn!(error = %e, "waiting on the hub socket failed");
            std::thread::sleep(TICK);
        }
    }

    /// Takes in what waits on the data socket (bounded, so the loop keeps turning).
    fn receive(&mut self, now: Instant) {
        for _ in 0..RECEIVE_BUDGET {
            match self.data.recv() {
                Ok(Some(packet)) => {
                    if self.link.handle_packet(now, &packet) {
                        self.feed.on_packet(&packet, foxglove::now_ns());
                    }
                }
                Ok(None) => return,
                Err(e) => {
                    tracing::debug!(error = %e, "data socket");
                    return;
                }
            }
        }
    }

    /// Takes in the hub's replies on the control socket.
    fn read_status(&mut self, now: Instant) {
        let mut reports = Vec::new();
        loop {
            match self.control.recv_reply() {
                Ok(Some(Reply::Status(report))) => reports.push(report),
                Ok(Some(Reply::Lease { .. } | Reply::Cookie(_))) => {}
                Ok(None) => break,
                Err(e) => {
                    tracing::debug!(error = %e, "control socket");
                    break;
                }
            }
        }
        self.link.handle_status(now, reports);
    }

    /// Carries out every request waiting; breaks when the web server is gone (so are we).
    fn take_requests(&mut self, now: Instant, requests: &Receiver<Envelope>) -> ControlFlow<()> {
        loop {
            match requests.try_recv() {
                Ok((page, command, answer)) => {
                    let result = self.carry_out(now, page, command);
                    let _ = answer.send(result);
                }
                Err(TryRecvError::Empty) => return ControlFlow::Continue(()),
                Err(TryRecvError::Disconnected) => return ControlFlow::Break(()),
            }
        }
    }

    fn carry_out(
        &mut self,
        now: Instant,
        page: PageId,
        command: Command,
    ) -> Result<String, CommandError> {
        let packet = self.link.prepare(&command);
        self.transmit();
        if let Some(bytes) = packet? {
            self.control
                .publish(&bytes)
                .map_err(CommandError::Publish)?;
        }
        self.link.apply(now, page, command)
    }

    /// Does on the hub what the link wants done.
    fn transmit(&mut self) {
        while let Some(t) = self.link.poll_transmit() {
            match t {
                Transmit::Subscribe(subject) => {
                    if let Err(e) = self.data.subscribe(&subject) {
                        tracing::debug!(subject, error = %e, "cannot subscribe");
                        self.link.subscribe_failed(&subject);
                    }
                }
                Transmit::AskStatus => {
                    if let Err(e) = self.control.request(&[Request::Status]) {
                        tracing::debug!(error = %e, "cannot ask for status");
                    }
                }
                Transmit::Request(requests) => {
                    if let Err(e) = self.control.request(&requests) {
                        tracing::warn!(error = %e, "cannot send a request to the hub");
                    }
                }
                Transmit::Publish(packet) => {
                    if let Err(e) = self.control.publish(&packet) {
                        tracing::debug!(error = %e, "cannot publish an override");
                    }
                }
            }
        }
    }

    /// Hands the web side what the link says it is due.
    fn deliver(&mut self) {
        while let Some(output) = self.link.poll_output() {
            match output {
                Output::World(w) => drop(self.pages.world.send_replace(w)),
                Output::Hub(h) => drop(self.pages.hub.send_replace(h)),
                Output::Game(g) => drop(self.pages.game.send_replace(g)),
                Output::Chat(c) => drop(self.pages.chat.send_replace(c)),
                Output::Map(m) => drop(self.pages.map.send_replace(m)),
                Output::Tasks(t) => drop(self.pages.tasks.send_replace(t)),
                Output::Scene(scene) => self.build(scene),
            }
        }
    }

    /// Builds a scene for the Foxglove viewers; the arena's is timed, for its budget.
    fn build(&mut self, scene: Scene) {
        let started = Instant::now();
        let ns = foxglove::now_ns();
        let Some(json) = self.link.scene(scene, ns) else {
            return;
        };
        match scene {
            Scene::Arena => {
                self.feed.on_arena(json, foxglove::now_ns());
                let skipped = self.link.arena_built(started, started.elapsed());
                self.feed.on_scenes_skipped(skipped);
            }
            Scene::Battlefield => self.feed.on_battlefield(json, ns),
            Scene::Terrain => self.feed.on_terrain(json, ns),
        }
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
