//! The HTTP side: the gate in front of every request, the security headers on every answer,
//! and the pages and scripts compiled into the binary.

use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::{ConnectInfo, Request, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::middleware::Next;
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use tokio::sync::watch;

use super::page::ws;
use super::viewer::foxglove_ws;
use super::{App, Guard};

const INDEX_HTML: &str = include_str!("../../web/index.html");
const APP_JS: &str = include_str!("../../web/app.js");
const STYLE_CSS: &str = include_str!("../../web/style.css");
const GAME_HTML: &str = include_str!("../../web/game.html");
const GAME_JS: &str = include_str!("../../web/game.js");
const GAME_CSS: &str = include_str!("../../web/game.css");
const TASKS_HTML: &str = include_str!("../../web/tasks.html");
const TASKS_JS: &str = include_str!("../../web/tasks.js");
/// What the pages' scripts share (an ES module both import).
const COMMON_JS: &str = include_str!("../../web/common.js");

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
        uri.path() != colony_foxglove::PATH
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
            || uri.path() == colony_foxglove::PATH,
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

pub(super) async fn serve(
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
        .route(colony_foxglove::PATH, get(foxglove_ws))
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
