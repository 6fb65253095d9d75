//! One WebSocket per browser tab: what each view is sent, and each request carried to the
//! hub side and answered.

use std::sync::atomic::Ordering;
use std::sync::mpsc::Sender;
use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{RawQuery, State};
use axum::response::Response;
use colony_foxglove::liveness::{ping_if_due, ready, send_within, End, Pinger, MAX_READY};
use tokio::sync::watch;
use tokio::time::Instant;

use super::App;
use crate::protocol::{kind_of, parse_message, ReplyJson, MAX_MESSAGE};
use crate::state::PageId;

/// The browser gets world snapshots at most this often.
const MIN_SEND_INTERVAL: Duration = Duration::from_millis(33);
/// How often a monitor page is sent the monitor's own counts, when they changed.
const COUNTS_EVERY: Duration = Duration::from_secs(1);

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

pub(super) async fn ws(
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
    let answer = crate::request::carry_out(&app.requests, page, command)
        .await
        .map_err(|message| crate::protocol::Refusal {
            message,
            line: None,
            column: None,
        });
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

/// What became of one event of a page's session.
enum Flow {
    /// Go on.
    On,
    /// The server is stopping, or what fed the page is gone.
    Stop,
    /// The page closed, failed or stopped answering.
    End(End),
}

impl From<Result<(), End>> for Flow {
    fn from(r: Result<(), End>) -> Flow {
        match r {
            Ok(()) => Flow::On,
            Err(e) => Flow::End(e),
        }
    }
}

/// What a page has been sent that it must not be sent again.
struct Sent {
    /// When the next world snapshot may go.
    next_world: Instant,
    /// The whole frame whose bodies this page has (0: none; no world has none to send).
    bodies: u64,
    /// The monitor's own counts, as last sent.
    counts: String,
    /// This team's chat, as last sent.
    chat: Option<Arc<[crate::game::ChatView]>>,
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
    let at_connect = team.as_ref().and_then(|t| chat.borrow().get(t).cloned());
    let board = matches!(view, View::Tasks);
    // The newest of each, at once.
    world.mark_changed();
    hub.mark_changed();
    game.mark_changed();
    chat.mark_changed();
    map.mark_changed();
    tasks.mark_changed();
    let mut sent = Sent {
        next_world: Instant::now(),
        bodies: 0,
        counts: String::new(),
        chat: None,
    };
    let mut counts_tick = tokio::time::interval(COUNTS_EVERY);
    let mut pinger = Pinger::new(app.liveness, std::time::Instant::now());
    let within = pinger.deadline();
    let end = loop {
        let flow = tokio::select! {
            incoming = socket.recv() => {
                take_in(&mut socket, &app, page, &mut pinger, incoming).await.into()
            }
            changed = world.changed(), if monitor => match changed {
                Err(_) => Flow::Stop,
                Ok(()) => send_world(&mut socket, &mut world, &mut sent, within).await.into(),
            },
            _ = counts_tick.tick(), if monitor => {
                let counts = monitor_json(&app);
                if counts == sent.counts {
                    Flow::On
                } else {
                    let r = send_text(&mut socket, &counts, within).await;
                    sent.counts = counts;
                    r.into()
                }
            }
            changed = hub.changed(), if monitor => send_latest(&mut socket, changed, &mut hub, within).await,
            changed = map.changed(), if playing => send_latest(&mut socket, changed, &mut map, within).await,
            changed = tasks.changed(), if board => send_latest(&mut socket, changed, &mut tasks, within).await,
            changed = chat.changed(), if team.is_some() => match (changed, team.as_deref()) {
                (Ok(()), Some(team)) => {
                    // Only this team's lines, and only when they changed.
                    let mine = chat.borrow_and_update().get(team).cloned();
                    send_chat(&mut socket, team, mine, at_connect.as_deref(), &mut sent, within).await.into()
                }
                _ => Flow::Stop,
            },
            changed = game.changed(), if playing => match changed {
                Err(_) => Flow::Stop,
                Ok(()) => {
                    let frame = game.borrow_and_update().clone();
                    // Cut here, per page: a team's player is never sent another team's plans.
                    send_text(&mut socket, &frame.json(team.as_deref()), within).await.into()
                }
            },
            _ = pinger.sleep() => keep_alive(&mut socket, &app, page, &mut pinger).await.into(),
            changed = shutdown.changed() => {
                if changed.is_err() || *shutdown.borrow_and_update() {
                    let _ = send_within(&mut socket, Message::Close(None), within).await;
                    Flow::Stop
                } else {
                    Flow::On
                }
            }
        };
        match flow {
            Flow::On => {}
            Flow::Stop => break None,
            Flow::End(e) => break Some(e),
        }
    };
    if let Some(why) = end.and_then(End::frozen) {
        tracing::info!(
            page = page.0,
            "a page was dropped because {why}: what it held is let go"
        );
    }
}

/// Sends the newest world snapshot, at most 30 a second (whatever arrives meanwhile replaces
/// it): a new whole frame's bodies first, then the JSON that goes with them.
async fn send_world(
    socket: &mut WebSocket,
    world: &mut watch::Receiver<crate::hub_link::WorldSnapshot>,
    sent: &mut Sent,
    within: Duration,
) -> Result<(), End> {
    tokio::time::sleep_until(sent.next_world).await;
    let snapshot = world.borrow_and_update().clone();
    if snapshot.frame != sent.bodies && snapshot.frame != 0 {
        let bodies = Message::Binary(snapshot.bodies.clone());
        send_within(socket, bodies, within).await?;
        sent.bodies = snapshot.frame;
    }
    send_text(socket, &snapshot.json, within).await?;
    sent.next_world = Instant::now() + MIN_SEND_INTERVAL;
    Ok(())
}

/// Sends a view that goes out whole each time it changes (the hub view, the map, the board).
async fn send_latest(
    socket: &mut WebSocket,
    changed: Result<(), watch::error::RecvError>,
    view: &mut watch::Receiver<Arc<str>>,
    within: Duration,
) -> Flow {
    if changed.is_err() {
        return Flow::Stop;
    }
    let snapshot = view.borrow_and_update().clone();
    send_text(socket, &snapshot, within).await.into()
}

/// Sends a team's chat when it changed; what was said before the page came is its backlog,
/// not news.
async fn send_chat(
    socket: &mut WebSocket,
    team: &str,
    mine: Option<Arc<[crate::game::ChatView]>>,
    at_connect: Option<&[crate::game::ChatView]>,
    sent: &mut Sent,
    within: Duration,
) -> Result<(), End> {
    let Some(mine) = mine else { return Ok(()) };
    if sent.chat.as_deref() == Some(&*mine) {
        return Ok(());
    }
    let backlog = sent.chat.is_none() && at_connect == Some(&*mine);
    let text = crate::game::chat_message(team, backlog, &mine);
    send_text(socket, &text, within).await?;
    sent.chat = Some(mine);
    Ok(())
}

/// When a ping falls due: a page that has not answered in time gets its waiting frames read
/// first (a pong may be among them), then is pinged, or dropped.
async fn keep_alive(
    socket: &mut WebSocket,
    app: &App,
    page: PageId,
    pinger: &mut Pinger,
) -> Result<(), End> {
    if pinger.overdue(std::time::Instant::now()) {
        for _ in 0..MAX_READY {
            let Some(incoming) = ready(socket).await else {
                break;
            };
            take_in(socket, app, page, pinger, incoming).await?;
        }
    }
    Ok(ping_if_due(pinger, socket).await?)
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
