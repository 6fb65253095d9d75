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
use std::sync::mpsc::{channel, sync_channel, Sender, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{ConnectInfo, RawQuery, Request, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::middleware::Next;
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use tokio::sync::{oneshot, watch};
use tokio::time::Instant;

use crate::bridge::Bridge;
use crate::gate::{Gate, RefusalLog};
use crate::liveness::{ping_if_due, ready, send_within, End, Liveness, Pinger, MAX_READY};
use crate::protocol::{kind_of, parse_message, ReplyJson, MAX_MESSAGE};
use crate::request::Envelope;
use crate::state::PageId;

const INDEX_HTML: &str = include_str!("../web/index.html");
const APP_JS: &str = include_str!("../web/app.js");
const STYLE_CSS: &str = include_str!("../web/style.css");
const GAME_HTML: &str = include_str!("../web/game.html");
const GAME_JS: &str = include_str!("../web/game.js");
const GAME_CSS: &str = include_str!("../web/game.css");
const TASKS_HTML: &str = include_str!("../web/tasks.html");
const TASKS_JS: &str = include_str!("../web/tasks.js");
/// What the pages' scripts share (an ES module both import).
const COMMON_JS: &str = include_str!("../web/common.js");

/// The browser gets world snapshots at most this often.
const MIN_SEND_INTERVAL: Duration = Duration::from_millis(33);
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
    world: watch::Receiver<crate::bridge::WorldSnapshot>,
    hub: watch::Receiver<Arc<str>>,
    game: watch::Receiver<Arc<crate::game::GameFrame>>,
    chat: watch::Receiver<Arc<crate::game::Chats>>,
    map: watch::Receiver<Arc<str>>,
    tasks: watch::Receiver<Arc<str>>,
    shutdown: watch::Receiver<bool>,
    viewers: crate::foxglove::Viewers,
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
    viewers: crate::foxglove::Viewers,
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
        let (feed, viewers) = crate::foxglove::feed();
        let (bridge, handles) = Bridge::connect(hub, config.key.clone(), feed)?;
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
                let result = runtime.block_on(serve(listener, app, server_guard, shutdown));
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
    /// Lichtblick's "open connection" (see [`crate::foxglove`]).
    pub fn foxglove_url(&self) -> String {
        let page = self.page_url(crate::foxglove::PATH, "");
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

/// How often a monitor page is sent the monitor's own counts, when they changed.
const COUNTS_EVERY: Duration = Duration::from_secs(1);

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

/// What the monitor itself turned away or dropped, for the page (`{"t":"monitor"}`): losses
/// are shown, never silent. Sent on connecting and then each second it changes, whether or
/// not the hub is heard from (someone may knock while it is down).
fn monitor_json(app: &App) -> String {
    let v = &app.viewers;
    serde_json::json!({
        "t": "monitor",
        "refused": app.guard.refused(),
        "foxglove": {
            "viewers": v.connected(),
            "dropped": v.dropped(),
            "refused": v.refused(),
            "not_advertised": v.not_advertised(),
            "scenes_skipped": v.scenes_skipped(),
        },
    })
    .to_string()
}

/// Lets a request through [`Gate`] or answers its refusal (403, or 400), and adds the security
/// headers to every answer.
async fn guarded(
    State(guard): State<Arc<Guard>>,
    ConnectInfo(peer): ConnectInfo<SocketAddr>,
    request: Request,
    next: Next,
) -> Response {
    let headers = request.headers();
    let uri = request.uri();
    let header_str = |name| {
        headers
            .get(name)
            .and_then(|v: &HeaderValue| v.to_str().ok())
    };
    // An absolute request target (`GET http://host/ HTTP/1.1`) names the host too: then it
    // must pass as well as the header, whichever the server below would believe.
    let host = header_str(header::HOST);
    let authority_ok = uri
        .authority()
        .is_none_or(|a| guard.gate.check_host(a.as_str()));
    // A viewer's origin the operator allowed passes for the Foxglove endpoint alone.
    let origin = header_str(header::ORIGIN).filter(|o| {
        uri.path() != crate::foxglove::PATH
            || !guard
                .foxglove_origins
                .read()
                .is_ok_and(|list| list.iter().any(|a| a.eq_ignore_ascii_case(o.trim())))
    });
    let checked = crate::gate::Request {
        path: uri.path(),
        query: uri.query(),
        host,
        more_hosts: headers.get_all(header::HOST).iter().nth(1).is_some(),
        origin,
        upgrade: headers.contains_key(header::UPGRADE)
            || uri.path() == "/ws"
            || uri.path() == crate::foxglove::PATH,
    };
    let verdict = if authority_ok {
        guard.gate.check(&checked)
    } else {
        Err(crate::gate::Refusal::Host)
    };
    let mut response = match verdict {
        Ok(()) => next.run(request).await,
        Err(refusal) => {
            let line = guard
                .log
                .lock()
                .ok()
                .and_then(|mut log| log.on_refusal(std::time::Instant::now()));
            if let Some(unlogged) = line {
                tracing::warn!(
                    reason = refusal.as_str(),
                    %peer,
                    host = %printable(checked.host.unwrap_or("-")),
                    origin = %printable(checked.origin.unwrap_or("-")),
                    path = %printable(checked.path),
                    also_refused = unlogged,
                    "refused a web request"
                );
            }
            (
                StatusCode::from_u16(refusal.status()).unwrap_or(StatusCode::FORBIDDEN),
                [(header::CONTENT_TYPE, "text/plain; charset=utf-8")],
                refusal.message(),
            )
                .into_response()
        }
    };
    let h = response.headers_mut();
    // Another site may not frame the page (clickjacking the take-control buttons)...
    h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static("frame-ancestors 'none'"),
    );
    // ...nor have a response read as another type...
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    // ...nor learn the token from `Referer` when the page links out.
    h.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
    response
}

/// A header from the network as it may go in a log line: short, and printable ASCII only.
fn printable(text: &str) -> String {
    text.chars()
        .take(100)
        .map(|c| {
            if c.is_ascii_graphic() || c == ' ' {
                c
            } else {
                '?'
            }
        })
        .collect()
}

async fn serve(
    listener: std::net::TcpListener,
    app: App,
    guard: Arc<Guard>,
    mut shutdown: watch::Receiver<bool>,
) -> std::io::Result<()> {
    let listener = tokio::net::TcpListener::from_std(listener)?;
    let router = Router::new()
        .route("/", get(index))
        .route("/index.html", get(index))
        .route("/app.js", get(app_js))
        .route("/style.css", get(style_css))
        .route("/game", get(game_html))
        .route("/game.js", get(|| asset("text/javascript", GAME_JS)))
        .route("/game.css", get(|| asset("text/css", GAME_CSS)))
        .route("/tasks", get(|| async { Html(TASKS_HTML) }))
        .route("/tasks.js", get(|| asset("text/javascript", TASKS_JS)))
        .route("/common.js", get(|| asset("text/javascript", COMMON_JS)))
        .route("/ws", get(ws))
        .route(crate::foxglove::PATH, get(foxglove_ws))
        .with_state(app)
        .layer(axum::middleware::from_fn_with_state(guard, guarded));
    axum::serve(
        listener,
        router.into_make_service_with_connect_info::<SocketAddr>(),
    )
    .with_graceful_shutdown(async move {
        let _ = shutdown.wait_for(|s| *s).await;
    })
    .await
}

async fn index() -> Html<&'static str> {
    Html(INDEX_HTML)
}

async fn app_js() -> Response {
    (
        [
            (header::CONTENT_TYPE, "text/javascript; charset=utf-8"),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        APP_JS,
    )
        .into_response()
}

async fn style_css() -> Response {
    (
        [
            (header::CONTENT_TYPE, "text/css; charset=utf-8"),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        STYLE_CSS,
    )
        .into_response()
}

async fn game_html() -> Html<&'static str> {
    Html(GAME_HTML)
}

async fn asset(kind: &'static str, body: &'static str) -> Response {
    let kind = match kind {
        "text/css" => "text/css; charset=utf-8",
        _ => "text/javascript; charset=utf-8",
    };
    (
        [
            (header::CONTENT_TYPE, kind),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        body,
    )
        .into_response()
}

/// What a tab is sent besides replies.
#[derive(Debug, Clone, PartialEq)]
enum View {
    /// The system monitor: world snapshots and the hub view.
    Monitor,
    /// The game page: game state, events and the map, and the chat of the team it plays
    /// (`team=` in the socket's address; none without one).
    Game(Option<String>),
    /// The task board.
    Tasks,
}

async fn ws(
    upgrade: WebSocketUpgrade,
    RawQuery(query): RawQuery,
    State(app): State<App>,
) -> Response {
    let asked = |v: &str| {
        query
            .as_deref()
            .is_some_and(|q| q.split('&').any(|kv| kv == v))
    };
    let view = if asked("view=game") {
        let team = query.as_deref().and_then(|q| {
            q.split('&')
                .find_map(|kv| kv.strip_prefix("team="))
                .filter(|t| colony_proto::game::valid_name(t))
                .map(str::to_owned)
        });
        View::Game(team)
    } else if asked("view=tasks") {
        View::Tasks
    } else {
        View::Monitor
    };
    upgrade
        .max_message_size(MAX_MESSAGE)
        .max_frame_size(MAX_MESSAGE)
        .on_upgrade(move |socket| session(socket, app, view))
}

/// The Foxglove WebSocket: `foxglove.websocket.v1` (see [`crate::foxglove`]).
async fn foxglove_ws(upgrade: WebSocketUpgrade, State(app): State<App>) -> Response {
    use crate::foxglove::{protocol::SUBPROTOCOL, Link, MAX_VIEWER_MESSAGE};
    upgrade
        .protocols([SUBPROTOCOL])
        .max_message_size(MAX_VIEWER_MESSAGE)
        .max_frame_size(MAX_VIEWER_MESSAGE)
        .on_upgrade(move |socket| {
            let link = Link {
                requests: app.requests.clone(),
                closed: app.closed.clone(),
                page: PageId(app.pages.fetch_add(1, Ordering::Relaxed)),
                shutdown: app.shutdown.clone(),
                liveness: app.liveness,
            };
            crate::foxglove::run(socket, app.viewers.clone(), link)
        })
}

fn reply(to: Option<&str>, result: &Result<String, crate::protocol::Refusal>) -> String {
    let r = match result {
        Ok(msg) => ReplyJson {
            t: "reply",
            ok: true,
            to,
            msg,
            line: None,
            column: None,
        },
        Err(e) => ReplyJson {
            t: "reply",
            ok: false,
            to,
            msg: &e.message,
            line: e.line,
            column: e.column,
        },
    };
    serde_json::to_string(&r).unwrap_or_else(|_| "{}".into())
}

/// Checks one browser message and hands it to the bridge; the answer is JSON.
async fn handle(app: &App, page: PageId, text: &str) -> String {
    let to = kind_of(text);
    let command = match parse_message(text) {
        Ok(c) => c,
        Err(e) => return reply(to.as_deref(), &Err(e)),
    };
    let (tx, rx) = oneshot::channel();
    let refusal = |m: &str| crate::protocol::Refusal {
        message: m.into(),
        line: None,
        column: None,
    };
    match app.requests.try_send((page, command, tx)) {
        Ok(()) => {}
        Err(TrySendError::Full(_)) => {
            return reply(
                to.as_deref(),
                &Err(refusal("the monitor is busy; try again")),
            )
        }
        Err(TrySendError::Disconnected(_)) => {
            return reply(to.as_deref(), &Err(refusal("the monitor is stopping")))
        }
    }
    let answer = match tokio::time::timeout(Duration::from_secs(2), rx).await {
        Ok(Ok(Ok(msg))) => Ok(msg),
        Ok(Ok(Err(e))) => Err(refusal(&e.to_string())),
        Ok(Err(_)) => Err(refusal("the monitor is stopping")),
        Err(_) => Err(refusal("no answer from the hub bridge within 2 s")),
    };
    reply(to.as_deref(), &answer)
}

/// Tells the bridge that a page has gone when its session ends, however it ends (the socket
/// closed or failed, the server stopped, the task was dropped): what the page held is let go.
struct PageGuard {
    page: PageId,
    closed: Sender<PageId>,
}

impl Drop for PageGuard {
    fn drop(&mut self) {
        // The bridge gone means the monitor is stopping, and it lets everything go itself.
        let _ = self.closed.send(self.page);
    }
}

async fn session(mut socket: WebSocket, app: App, view: View) {
    let page = PageId(app.pages.fetch_add(1, Ordering::Relaxed));
    let _gone = PageGuard {
        page,
        closed: app.closed.clone(),
    };
    let mut world = app.world.clone();
    let mut hub = app.hub.clone();
    let mut game = app.game.clone();
    let mut chat = app.chat.clone();
    let mut map = app.map.clone();
    let mut tasks = app.tasks.clone();
    let mut shutdown = app.shutdown.clone();
    let monitor = matches!(view, View::Monitor);
    let playing = matches!(view, View::Game(_));
    let team = match &view {
        View::Game(team) => team.clone(),
        _ => None,
    };
    let mut chat_sent: Option<Arc<[crate::game::ChatView]>> = None;
    let at_connect = team.as_ref().and_then(|t| chat.borrow().get(t).cloned());
    let board = matches!(view, View::Tasks);
    // The newest of each, at once.
    world.mark_changed();
    hub.mark_changed();
    game.mark_changed();
    chat.mark_changed();
    map.mark_changed();
    tasks.mark_changed();
    let mut next_world = Instant::now();
    // The whole frame whose bodies this page has (0: none; no world has none to send).
    let mut bodies_sent = 0;
    let mut counts_tick = tokio::time::interval(COUNTS_EVERY);
    let mut counts_sent = String::new();
    let mut pinger = Pinger::new(app.liveness, std::time::Instant::now());
    let within = pinger.deadline();
    let mut end = None;
    loop {
        tokio::select! {
            incoming = socket.recv() => {
                if let Err(e) = take_in(&mut socket, &app, page, &mut pinger, incoming).await {
                    end = Some(e);
                    break;
                }
            }
            changed = world.changed(), if monitor => {
                if changed.is_err() {
                    break;
                }
                // At most 30 a second; whatever arrives meanwhile replaces the snapshot.
                tokio::time::sleep_until(next_world).await;
                let snapshot = world.borrow_and_update().clone();
                // A new whole frame's bodies first, then the JSON that goes with them.
                if snapshot.frame != bodies_sent && snapshot.frame != 0 {
                    let bodies = Message::Binary(snapshot.bodies.clone());
                    if let Err(e) = send_within(&mut socket, bodies, within).await {
                        end = Some(e.into());
                        break;
                    }
                    bodies_sent = snapshot.frame;
                }
                if let Err(e) = send_text(&mut socket, &snapshot.json, within).await {
                    end = Some(e);
                    break;
                }
                next_world = Instant::now() + MIN_SEND_INTERVAL;
            }
            _ = counts_tick.tick(), if monitor => {
                let counts = monitor_json(&app);
                if counts != counts_sent {
                    if let Err(e) = send_text(&mut socket, &counts, within).await {
                        end = Some(e);
                        break;
                    }
                    counts_sent = counts;
                }
            }
            changed = hub.changed(), if monitor => {
                if changed.is_err() {
                    break;
                }
                let snapshot = hub.borrow_and_update().clone();
                if let Err(e) = send_text(&mut socket, &snapshot, within).await {
                    end = Some(e);
                    break;
                }
            }
            changed = map.changed(), if playing => {
                if changed.is_err() {
                    break;
                }
                let snapshot = map.borrow_and_update().clone();
                if let Err(e) = send_text(&mut socket, &snapshot, within).await {
                    end = Some(e);
                    break;
                }
            }
            changed = chat.changed(), if team.is_some() => {
                if changed.is_err() {
                    break;
                }
                // Only this team's lines, and only when they changed.
                let mine = team.as_ref().and_then(|t| chat.borrow_and_update().get(t).cloned());
                if let (Some(mine), Some(team)) = (mine, team.as_deref()) {
                    if chat_sent.as_deref() != Some(&*mine) {
                        // What was said before the page came is its backlog, not news.
                        let backlog = chat_sent.is_none() && at_connect.as_deref() == Some(&*mine);
                        let text = crate::game::chat_message(team, backlog, &mine);
                        if let Err(e) = send_text(&mut socket, &text, within).await {
                            end = Some(e);
                            break;
                        }
                        chat_sent = Some(mine);
                    }
                }
            }
            changed = tasks.changed(), if board => {
                if changed.is_err() {
                    break;
                }
                let snapshot = tasks.borrow_and_update().clone();
                if let Err(e) = send_text(&mut socket, &snapshot, within).await {
                    end = Some(e);
                    break;
                }
            }
            changed = game.changed(), if playing => {
                if changed.is_err() {
                    break;
                }
                let frame = game.borrow_and_update().clone();
                // Cut here, per page: a team's player is never sent another team's plans.
                let text = frame.json(team.as_deref());
                if let Err(e) = send_text(&mut socket, &text, within).await {
                    end = Some(e);
                    break;
                }
            }
            _ = pinger.sleep() => {
                let mut flow = Ok(());
                if pinger.overdue(std::time::Instant::now()) {
                    for _ in 0..MAX_READY {
                        let Some(incoming) = ready(&mut socket).await else { break };
                        flow = take_in(&mut socket, &app, page, &mut pinger, incoming).await;
                        if flow.is_err() {
                            break;
                        }
                    }
                }
                if flow.is_ok() {
                    flow = ping_if_due(&mut pinger, &mut socket).await.map_err(End::from);
                }
                if let Err(e) = flow {
                    end = Some(e);
                    break;
                }
            }
            changed = shutdown.changed() => {
                if changed.is_err() || *shutdown.borrow_and_update() {
                    let _ = send_within(&mut socket, Message::Close(None), within).await;
                    break;
                }
            }
        }
    }
    if let Some(why) = end.and_then(End::frozen) {
        tracing::info!(
            page = page.0,
            "a page was dropped because {why}: what it held is let go"
        );
    }
}

/// Sends `text` to a page, giving up after `within`.
async fn send_text(socket: &mut WebSocket, text: &str, within: Duration) -> Result<(), End> {
    Ok(send_within(socket, Message::Text(text.into()), within).await?)
}

/// Takes in one frame from a page: a request is carried out and answered, a pong goes to
/// `pinger`.
async fn take_in(
    socket: &mut WebSocket,
    app: &App,
    page: PageId,
    pinger: &mut Pinger,
    incoming: Option<Result<Message, axum::Error>>,
) -> Result<(), End> {
    let within = pinger.deadline();
    let text = match incoming {
        None | Some(Err(_)) | Some(Ok(Message::Close(_))) => return Err(End::Closed),
        Some(Ok(Message::Text(t))) => t,
        Some(Ok(Message::Pong(p))) => {
            pinger.on_pong(&p, std::time::Instant::now());
            return Ok(());
        }
        Some(Ok(Message::Binary(_))) => {
            let r = reply(
                None,
                &Err(crate::protocol::Refusal {
                    message: "send JSON text, not binary".into(),
                    line: None,
                    column: None,
                }),
            );
            return send_text(socket, &r, within).await;
        }
        Some(Ok(_)) => return Ok(()),
    };
    let answer = handle(app, page, text.as_str()).await;
    send_text(socket, &answer, within).await
}
