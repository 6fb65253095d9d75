//! The web side: the pages, their scripts (with `common.js`, the module both
//! import) and style (compiled into the binary), and one WebSocket per
//! browser tab.
//!
//! Server to browser: `{"t":"world",...}` snapshots at most 30 times a
//! second (coalesced: a slow tab gets the newest, never a backlog), each new whole frame's
//! robots and pucks just before its snapshot as one binary message
//! ([`crate::state::bodies`]),
//! `{"t":"hub",...}` about once a second, and `{"t":"reply",...}` answers.
//! The game page opens `/ws?view=game` and gets `{"t":"game",...}` and
//! `{"t":"map",...}` (see [`crate::game`]) instead of world and hub; the task
//! board opens `/ws?view=tasks` and gets `{"t":"tasks",...}` (see [`crate::tasks`]).
//! Browser to server: the requests of [`crate::protocol`].
//!
//! Every request passes [`crate::gate`] first (its own host names, the
//! WebSocket's origin, the token), and every answer carries headers that keep
//! the pages out of other sites' frames and the token out of `Referer`.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{channel, sync_channel, Sender, SyncSender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use colony_foxglove::Liveness;
use tokio::sync::watch;

use crate::gate::{Gate, RefusalLog};
use crate::hub_link::LinkThread;
use crate::request::Envelope;
use crate::state::PageId;

mod http;
mod page;
mod viewer;

/// Requests waiting for the bridge, at most.
const REQUEST_QUEUE: usize = 256;

/// Where the monitor listens and which hub it joins.
#[derive(Debug, Clone)]
pub struct MonitorConfig {
    /// The hub's address, `HOST:PORT`.
    pub hub: String,
    /// Where the web server listens, `HOST:PORT` (port 0: any free one).
    pub bind: String,
    /// Host names the web server answers to besides its address, `localhost`, `127.0.0.1`
    /// and `[::1]` (each with or without a port; without one, the server's port is meant):
    /// needed when the page is opened by a name, as through a tunnel or a proxy.
    pub allow_hosts: Vec<String>,
    /// Whether the pages and the WebSocket need the random token that [`Monitor::url`]
    /// carries. Off only where every user of every browser that can reach the port may drive
    /// the robots.
    pub token: bool,
    /// The hub's shared key: the monitor signs what it sends with it, so a
    /// hub started with `--key` takes its operator requests (`min_priority`).
    pub key: Option<colony_wire::auth::Key>,
}

impl Default for MonitorConfig {
    fn default() -> Self {
        MonitorConfig {
            hub: "127.0.0.1:7400".into(),
            bind: "127.0.0.1:8080".into(),
            allow_hosts: Vec::new(),
            token: true,
            key: None,
        }
    }
}

/// Why the monitor could not start or stopped badly.
#[derive(Debug, thiserror::Error)]
pub enum MonitorError {
    /// The web server's address could not be bound.
    #[error(
        "cannot listen on `{addr}` (is something else using that port? choose another with --bind)"
    )]
    Bind {
        /// The address asked for.
        addr: String,
        /// Why.
        source: std::io::Error,
    },
    /// The hub's address does not resolve.
    #[error("hub address `{addr}`")]
    Hub {
        /// The address given.
        addr: String,
        /// Why.
        source: std::io::Error,
    },
    /// A hub client could not be made.
    #[error(transparent)]
    Client(#[from] colony_client::ClientError),
    /// A socket or thread could not be set up.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// One of the monitor's threads panicked (which one).
    #[error("the monitor's {0} thread panicked")]
    Panicked(&'static str),
}

#[derive(Clone)]
struct App {
    requests: SyncSender<Envelope>,
    /// Each page's id, when its WebSocket ends.
    closed: Sender<PageId>,
    /// The next page's id.
    pages: Arc<AtomicU64>,
    world: watch::Receiver<crate::hub_link::WorldSnapshot>,
    hub: watch::Receiver<Arc<str>>,
    game: watch::Receiver<Arc<crate::game::GameFrame>>,
    chat: watch::Receiver<Arc<crate::game::Chats>>,
    map: watch::Receiver<Arc<str>>,
    tasks: watch::Receiver<Arc<str>>,
    shutdown: watch::Receiver<bool>,
    viewers: colony_foxglove::Viewers,
    /// For the refusals the page shows.
    guard: Arc<Guard>,
    /// When a page or a viewer that stopped answering is dropped.
    liveness: Liveness,
}

/// A running monitor: the web server and the hub bridge, each on its own
/// thread. [`shutdown`](Monitor::shutdown) (or dropping it) stops both.
pub struct Monitor {
    addr: SocketAddr,
    hub: SocketAddr,
    guard: Arc<Guard>,
    stop: Arc<AtomicBool>,
    shutdown_tx: watch::Sender<bool>,
    server: Option<JoinHandle<std::io::Result<()>>>,
    bridge: Option<JoinHandle<()>>,
    viewers: colony_foxglove::Viewers,
}

impl Monitor {
    /// Binds the web server and joins the hub; returns once both are in place,
    /// so a port already taken is an error here. Pages and viewers are pinged as
    /// [`Liveness::default`] says.
    pub fn start(config: &MonitorConfig) -> Result<Monitor, MonitorError> {
        Monitor::start_with_liveness(config, Liveness::default())
    }

    /// [`start`](Self::start), dropping a page or a Foxglove viewer, and letting go what it
    /// held, when it does not answer a ping or take a message within `liveness`' bounds.
    pub fn start_with_liveness(
        config: &MonitorConfig,
        liveness: Liveness,
    ) -> Result<Monitor, MonitorError> {
        let hub = resolve(&config.hub)?;
        let listener = std::net::TcpListener::bind(config.bind.as_str()).map_err(|source| {
            MonitorError::Bind {
                addr: config.bind.clone(),
                source,
            }
        })?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("monitor-web")
            .enable_all()
            .build()?;
        let (feed, viewers) = colony_foxglove::feed();
        let (bridge, handles) = LinkThread::connect(hub, config.key.clone(), feed)?;
        let stop = Arc::new(AtomicBool::new(false));
        let (requests, requests_rx) = sync_channel(REQUEST_QUEUE);
        let (closed, closed_rx) = channel();
        let bridge_stop = stop.clone();
        let bridge = std::thread::Builder::new()
            .name("monitor-bridge".into())
            .spawn(move || bridge.run(requests_rx, closed_rx, bridge_stop))?;
        let token = config.token.then(crate::gate::new_token);
        let guard = Arc::new(Guard {
            gate: Gate::new(addr, &config.allow_hosts, token),
            log: Mutex::new(RefusalLog::default()),
            foxglove_origins: std::sync::RwLock::new(Vec::new()),
        });
        let (shutdown_tx, shutdown) = watch::channel(false);
        let app = App {
            requests,
            closed,
            pages: Arc::new(AtomicU64::new(1)),
            world: handles.world,
            hub: handles.hub,
            game: handles.game,
            chat: handles.chat,
            map: handles.map,
            tasks: handles.tasks,
            shutdown: shutdown.clone(),
            viewers: viewers.clone(),
            guard: guard.clone(),
            liveness,
        };
        let server_guard = guard.clone();
        let server = std::thread::Builder::new()
            .name("monitor-server".into())
            .spawn(move || {
                let result = runtime.block_on(http::serve(listener, app, server_guard, shutdown));
                runtime.shutdown_timeout(Duration::from_secs(1));
                result
            });
        let server = match server {
            Ok(s) => s,
            Err(e) => {
                stop.store(true, Ordering::Relaxed);
                return Err(e.into());
            }
        };
        Ok(Monitor {
            addr,
            hub,
            guard,
            stop,
            shutdown_tx,
            server: Some(server),
            bridge: Some(bridge),
            viewers,
        })
    }

    /// Where the web server listens.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// The hub the monitor joined.
    pub fn hub_addr(&self) -> SocketAddr {
        self.hub
    }

    /// The page's address, with the token when one is needed: the address to print for the
    /// operator to open.
    pub fn url(&self) -> String {
        self.page_url("/", "")
    }

    /// The address of the page at `path` (such as `/game`) with `query` (such as `team=red`,
    /// or empty) and the token when one is needed.
    pub fn page_url(&self, path: &str, query: &str) -> String {
        let mut q: Vec<String> = Vec::new();
        if !query.is_empty() {
            q.push(query.to_owned());
        }
        if let Some(token) = self.guard.gate.token() {
            q.push(format!("token={token}"));
        }
        let q = if q.is_empty() {
            String::new()
        } else {
            format!("?{}", q.join("&"))
        };
        // Bound to every address (0.0.0.0): no browser host name is that; loopback always works.
        let mut addr = self.addr;
        if addr.ip().is_unspecified() {
            addr.set_ip(match addr.ip() {
                std::net::IpAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
                std::net::IpAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
            });
        }
        format!("http://{addr}{path}{q}")
    }

    /// The Foxglove WebSocket's address (`ws://.../foxglove?token=...`), for Foxglove or
    /// Lichtblick's "open connection" (see [`colony_foxglove`]).
    pub fn foxglove_url(&self) -> String {
        let page = self.page_url(colony_foxglove::PATH, "");
        format!("ws://{}", page.trim_start_matches("http://"))
    }

    /// Lets pages of `origin` (`https://app.foxglove.dev`: scheme, host and any port, as a
    /// browser writes `Origin`) open the Foxglove endpoint, as a hosted viewer needs; the host
    /// names and the token are still checked, and no other path is opened to them.
    pub fn allow_foxglove_origin(&self, origin: &str) {
        if let Ok(mut list) = self.guard.foxglove_origins.write() {
            list.push(origin.trim().trim_end_matches('/').to_ascii_lowercase());
        }
    }

    /// Foxglove viewers connected now, and messages dropped for slow ones so far.
    pub fn foxglove_viewers(&self) -> (u64, u64) {
        (self.viewers.connected(), self.viewers.dropped())
    }

    /// Packets whose topic found no room in the Foxglove channel list, and Foxglove connections
    /// refused past the cap on viewers, so far.
    pub fn foxglove_refusals(&self) -> (u64, u64) {
        (self.viewers.not_advertised(), self.viewers.refused())
    }

    /// The token the pages need, if one is.
    pub fn token(&self) -> Option<&str> {
        self.guard.gate.token()
    }

    /// Requests refused so far (a foreign host, a foreign origin, no token).
    pub fn refused(&self) -> u64 {
        self.guard.refused()
    }

    /// Whether both threads are still running.
    pub fn is_running(&self) -> bool {
        self.server.as_ref().is_some_and(|t| !t.is_finished())
            && self.bridge.as_ref().is_some_and(|t| !t.is_finished())
    }

    /// Stops the web server and the bridge (which lets held robots go and
    /// restores the hub's minimum priority), and waits for both.
    pub fn shutdown(mut self) -> Result<(), MonitorError> {
        self.stop_threads()
    }

    fn stop_threads(&mut self) -> Result<(), MonitorError> {
        let _ = self.shutdown_tx.send(true);
        self.stop.store(true, Ordering::Relaxed);
        let mut result = Ok(());
        if let Some(t) = self.bridge.take() {
            if t.join().is_err() {
                result = Err(MonitorError::Panicked("bridge"));
            }
        }
        if let Some(t) = self.server.take() {
            match t.join() {
                Ok(Ok(())) => {}
                Ok(Err(e)) => result = result.and(Err(MonitorError::Io(e))),
                Err(_) => result = result.and(Err(MonitorError::Panicked("web server"))),
            }
        }
        result
    }
}

impl Drop for Monitor {
    fn drop(&mut self) {
        let _ = self.stop_threads();
    }
}

fn resolve(addr: &str) -> Result<SocketAddr, MonitorError> {
    use std::net::ToSocketAddrs as _;
    addr.to_socket_addrs()
        .and_then(|mut a| {
            a.next().ok_or_else(|| {
                std::io::Error::new(std::io::ErrorKind::NotFound, "no address found")
            })
        })
        .map_err(|source| MonitorError::Hub {
            addr: addr.to_owned(),
            source,
        })
}

/// The gate and its count of refusals, shared by every request.
struct Guard {
    gate: Gate,
    log: Mutex<RefusalLog>,
    /// Other sites' origins the operator let open the Foxglove endpoint (a hosted viewer).
    foxglove_origins: std::sync::RwLock<Vec<String>>,
}

impl Guard {
    fn refused(&self) -> u64 {
        // A count is still a count after a panic elsewhere held the lock.
        self.log
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .refused()
    }
}
