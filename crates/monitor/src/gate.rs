//! Who may use the monitor's web server, with no socket and no clock.
//!
//! The page drives robots, so any web page the operator happens to visit must not be able to
//! drive them through the operator's browser. Three checks, in this order:
//!
//! - **Host**: every request must name one of the monitor's own hosts (the address it is bound
//!   to, `localhost`, `127.0.0.1` and `[::1]` with its port, and names given with
//!   `--allow-host`), once. This defeats DNS rebinding: a page at `evil.example` whose name is
//!   made to point at 127.0.0.1 still sends `Host: evil.example`. A request with two `Host`
//!   headers is refused whatever they say (`400`, as RFC 9112 §3.2 asks): the gate would judge
//!   one while a proxy in front, or a handler behind, might believe the other.
//! - **Origin**: a WebSocket upgrade that carries an `Origin` must come from
//!   `http://` (or `https://`) one of those hosts. Browsers do not apply the same-origin policy
//!   to WebSockets; this is the check that stops cross-site WebSocket hijacking.
//! - **Token**: unless started with `--no-token`, the pages and the WebSocket need
//!   `?token=...`, a random 128-bit value the monitor prints in its URL (as Jupyter does), so
//!   another user of the machine, or a page that guessed the port, gets nothing. The scripts and
//!   style sheets are served without it: they are the same for everyone and hold no secret, and
//!   nothing works without the page and the WebSocket.
//!
//! A refusal is answered `403` (`400` for two `Host` headers) with a one-line reason;
//! [`RefusalLog`] counts refusals and says when one may be logged (about one line a second,
//! however fast they come).

use std::net::{IpAddr, SocketAddr};
use std::time::{Duration, Instant};

/// The paths served without the token: assets the same for everyone.
const PUBLIC_ASSETS: [&str; 6] = [
    "/app.js",
    "/style.css",
    "/game.js",
    "/game.css",
    "/tasks.js",
    "/common.js",
];
/// At most one refusal line per this long; the others are counted into the next line.
const LOG_EVERY: Duration = Duration::from_secs(1);

/// Why a request was refused; [`message`](Self::message) is the 403's body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// The `Host` header is missing or names a host that is not the monitor's.
    Host,
    /// More than one `Host` header.
    Hosts,
    /// A WebSocket upgrade from a page of another origin.
    Origin,
    /// The token is missing or wrong.
    Token,
}

impl Refusal {
    /// The answer's HTTP status: `400` for a request no server may take, `403` for one this
    /// monitor does not take.
    pub fn status(self) -> u16 {
        match self {
            Refusal::Hosts => 400,
            Refusal::Host | Refusal::Origin | Refusal::Token => 403,
        }
    }

    /// A short plain-text reason, for the browser.
    pub fn message(self) -> &'static str {
        match self {
            Refusal::Hosts => "400 bad request: more than one Host header\n",
            Refusal::Host => {
                "403 forbidden: this monitor answers only to its own host names \
                 (start it with --allow-host NAME to add one)\n"
            }
            Refusal::Origin => {
                "403 forbidden: a page from another site may not open the monitor's WebSocket\n"
            }
            Refusal::Token => {
                "403 forbidden: this monitor needs its token: open the address it printed \
                 (ending in ?token=...)\n"
            }
        }
    }

    /// One word for the log.
    pub fn as_str(self) -> &'static str {
        match self {
            Refusal::Host => "host",
            Refusal::Hosts => "hosts",
            Refusal::Origin => "origin",
            Refusal::Token => "token",
        }
    }
}

/// What the gate looks at in one request.
#[derive(Debug, Clone, Copy, Default)]
pub struct Request<'a> {
    /// The path, without the query.
    pub path: &'a str,
    /// The query, without the `?`.
    pub query: Option<&'a str>,
    /// The `Host` header (or the authority of an absolute request target).
    pub host: Option<&'a str>,
    /// Whether the request carried more than one `Host` header.
    pub more_hosts: bool,
    /// The `Origin` header.
    pub origin: Option<&'a str>,
    /// Whether this asks for a WebSocket (an `Upgrade` header, or the WebSocket's path).
    pub upgrade: bool,
}

/// The monitor's own hosts and its token: what [`check`](Self::check) lets through.
#[derive(Debug, Clone)]
pub struct Gate {
    /// `host:port` as a browser writes it in `Host`, lowercase.
    hosts: Vec<String>,
    token: Option<String>,
}

impl Gate {
    /// The gate of a monitor bound to `bound`, also answering to the names in `allow` (each a
    /// name or address, with or without a port; without one, the monitor's port is meant),
    /// and needing `token` if there is one.
    pub fn new(bound: SocketAddr, allow: &[String], token: Option<String>) -> Gate {
        let port = bound.port();
        let mut names: Vec<String> = vec!["localhost".into(), "127.0.0.1".into(), "[::1]".into()];
        if !bound.ip().is_unspecified() {
            names.push(bracketed(bound.ip()));
        }
        let mut hosts = Vec::new();
        for name in names {
            hosts.push(format!("{name}:{port}"));
        }
        for name in allow {
            let name = name.trim().to_ascii_lowercase();
            if name.is_empty() {
                continue;
            }
            hosts.push(match name.parse::<IpAddr>() {
                // A bare IPv6 address: its colons are not a port.
                Ok(ip) => format!("{}:{port}", bracketed(ip)),
                Err(_) if has_port(&name) => name,
                Err(_) => format!("{name}:{port}"),
            });
        }
        // A browser leaves the default port out of `Host`.
        if port == 80 {
            let bare: Vec<String> = hosts
                .iter()
                .filter_map(|h| h.strip_suffix(":80").map(str::to_owned))
                .collect();
            hosts.extend(bare);
        }
        hosts.sort();
        hosts.dedup();
        Gate { hosts, token }
    }

    /// The hosts accepted in `Host`, `host:port`.
    pub fn hosts(&self) -> &[String] {
        &self.hosts
    }

    /// The token, if one is needed.
    pub fn token(&self) -> Option<&str> {
        self.token.as_deref()
    }

    /// Whether `request` may go on, and if not, why.
    pub fn check(&self, request: &Request<'_>) -> Result<(), Refusal> {
        if request.more_hosts {
            return Err(Refusal::Hosts);
        }
        let host_ok = request.host.is_some_and(|h| self.check_host(h));
        if !host_ok {
            return Err(Refusal::Host);
        }
        if request.upgrade {
            if let Some(origin) = request.origin {
                let host = origin
                    .strip_prefix("http://")
                    .or_else(|| origin.strip_prefix("https://"));
                if !host.is_some_and(|h| self.check_host(h)) {
                    return Err(Refusal::Origin);
                }
            }
        }
        if let Some(token) = &self.token {
            if !PUBLIC_ASSETS.contains(&request.path) {
                let given = request
                    .query
                    .unwrap_or("")
                    .split('&')
                    .find_map(|kv| kv.strip_prefix("token="));
                if !given.is_some_and(|g| same(g.as_bytes(), token.as_bytes())) {
                    return Err(Refusal::Token);
                }
            }
        }
        Ok(())
    }

    /// Whether `host` (as in `Host`: `name:port`) is one of the monitor's own.
    pub fn check_host(&self, host: &str) -> bool {
        let host = host.trim().to_ascii_lowercase();
        self.hosts.contains(&host)
    }
}

/// An address as it stands before `:port` in a URL.
fn bracketed(ip: IpAddr) -> String {
    match ip {
        IpAddr::V4(v4) => v4.to_string(),
        IpAddr::V6(v6) => format!("[{v6}]"),
    }
}

/// Whether `name` (not a bare IPv6 address) ends in `:port`.
fn has_port(name: &str) -> bool {
    name.rsplit_once(':').is_some_and(|(host, port)| {
        !host.is_empty() && !port.is_empty() && port.bytes().all(|b| b.is_ascii_digit())
    })
}

/// Compares two tokens in time that does not depend on where they differ, so the token cannot
/// be guessed a character at a time by timing refusals.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// A new random token: 128 bits as 32 lowercase hex digits.
pub fn new_token() -> String {
    format!("{:032x}", rand::random::<u128>())
}

/// Counts refusals and says when one may be logged: a page hammering the monitor must not
/// flood its log, yet the operator must learn that something is knocking.
#[derive(Debug, Default)]
pub struct RefusalLog {
    refused: u64,
    last_line: Option<Instant>,
    unlogged: u64,
}

impl RefusalLog {
    /// A refusal at `now`. Returns `Some(n)` when a line should be logged for it, `n` being
    /// the refusals not logged since the last line; `None` when it is only counted.
    pub fn on_refusal(&mut self, now: Instant) -> Option<u64> {
        self.refused += 1;
        match self.last_line {
            Some(last) if now.saturating_duration_since(last) < LOG_EVERY => {
                self.unlogged += 1;
                None
            }
            _ => {
                self.last_line = Some(now);
                Some(std::mem::take(&mut self.unlogged))
            }
        }
    }

    /// Refusals since the start.
    pub fn refused(&self) -> u64 {
        self.refused
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOKEN: &str = "00112233445566778899aabbccddeeff";

    fn gate() -> Gate {
        Gate::new(
            "127.0.0.1:8080".parse().unwrap(),
            &[
                "robots.lab".into(),
                "proxy.lab:443".into(),
                "fe80::1".into(),
            ],
            Some(TOKEN.into()),
        )
    }

    fn page<'a>(host: &'a str, query: Option<&'a str>) -> Request<'a> {
        Request {
            path: "/",
            query,
            host: Some(host),
            ..Request::default()
        }
    }

    fn ws<'a>(host: &'a str, origin: Option<&'a str>) -> Request<'a> {
        Request {
            path: "/ws",
            query: Some("view=game&token=00112233445566778899aabbccddeeff"),
            host: Some(host),
            origin,
            upgrade: true,
            more_hosts: false,
        }
    }

    #[test]
    fn only_the_monitors_own_host_names_are_answered() {
        let g = gate();
        let q = Some("token=00112233445566778899aabbccddeeff");
        for host in [
            "127.0.0.1:8080",
            "localhost:8080",
            "LocalHost:8080",
            "[::1]:8080",
            "robots.lab:8080",
            "proxy.lab:443",
            "[fe80::1]:8080",
        ] {
            assert_eq!(g.check(&page(host, q)), Ok(()), "{host}");
        }
        for host in [
            "evil.example:8080",
            "localhost",
            "localhost:8081",
            "127.0.0.1",
            "robots.lab",
            "proxy.lab:8080",
            "127.0.0.1:8080.evil.example",
            "",
        ] {
            assert_eq!(g.check(&page(host, q)), Err(Refusal::Host), "{host}");
        }
        let no_host = Request {
            path: "/app.js",
            ..Request::default()
        };
        assert_eq!(g.check(&no_host), Err(Refusal::Host));
    }

    #[test]
    fn two_host_headers_are_refused_whatever_they_say() {
        let g = gate();
        let q = Some("token=00112233445566778899aabbccddeeff");
        let mut r = page("127.0.0.1:8080", q);
        assert_eq!(g.check(&r), Ok(()));
        r.more_hosts = true;
        assert_eq!(g.check(&r), Err(Refusal::Hosts));
        assert_eq!(Refusal::Hosts.status(), 400);
        assert!(Refusal::Hosts.message().starts_with("400"));
        let mut socket = ws("127.0.0.1:8080", None);
        socket.more_hosts = true;
        assert_eq!(g.check(&socket), Err(Refusal::Hosts));
        for r in [Refusal::Host, Refusal::Origin, Refusal::Token] {
            assert_eq!(r.status(), 403);
            assert!(r.message().starts_with("403"));
        }
    }

    #[test]
    fn port_80_is_also_matched_without_it() {
        let g = Gate::new("10.0.0.5:80".parse().unwrap(), &["lab".into()], None);
        for host in ["10.0.0.5", "10.0.0.5:80", "localhost", "lab", "lab:80"] {
            assert_eq!(g.check(&page(host, None)), Ok(()), "{host}");
        }
        let any = Gate::new("0.0.0.0:9000".parse().unwrap(), &[], None);
        assert!(!any.hosts().iter().any(|h| h.starts_with("0.0.0.0")));
    }

    #[test]
    fn a_websocket_from_another_origin_is_refused() {
        let g = gate();
        assert_eq!(
            g.check(&ws("127.0.0.1:8080", None)),
            Ok(()),
            "no Origin: not a browser page"
        );
        for origin in [
            "http://127.0.0.1:8080",
            "http://localhost:8080",
            "https://proxy.lab:443",
        ] {
            assert_eq!(
                g.check(&ws("localhost:8080", Some(origin))),
                Ok(()),
                "{origin}"
            );
        }
        for origin in [
            "http://evil.example",
            "http://127.0.0.1:8081",
            "null",
            "http://127.0.0.1:8080.evil.example",
            "file://",
        ] {
            assert_eq!(
                g.check(&ws("127.0.0.1:8080", Some(origin))),
                Err(Refusal::Origin),
                "{origin}"
            );
        }
        // A plain page load's Origin is the browser's business (reads across origins are
        // blocked by the browser anyway).
        let mut r = page(
            "127.0.0.1:8080",
            Some("token=00112233445566778899aabbccddeeff"),
        );
        r.origin = Some("http://evil.example");
        assert_eq!(g.check(&r), Ok(()));
    }

    #[test]
    fn the_pages_and_the_websocket_need_the_token_the_assets_do_not() {
        let g = gate();
        let h = "127.0.0.1:8080";
        for query in [
            None,
            Some(""),
            Some("token="),
            Some("token=00112233445566778899aabbccddeefe"),
            Some("token=00112233445566778899aabbccddeeff0"),
            Some("xtoken=00112233445566778899aabbccddeeff"),
        ] {
            assert_eq!(g.check(&page(h, query)), Err(Refusal::Token), "{query:?}");
        }
        assert_eq!(
            g.check(&page(
                h,
                Some("team=red&token=00112233445566778899aabbccddeeff")
            )),
            Ok(())
        );
        let mut socket = ws(h, None);
        socket.query = Some("view=game");
        assert_eq!(g.check(&socket), Err(Refusal::Token));
        for path in ["/game", "/tasks", "/index.html", "/nothing-here"] {
            let r = Request {
                path,
                host: Some(h),
                ..Request::default()
            };
            assert_eq!(g.check(&r), Err(Refusal::Token), "{path}");
        }
        for path in PUBLIC_ASSETS {
            let r = Request {
                path,
                host: Some(h),
                ..Request::default()
            };
            assert_eq!(g.check(&r), Ok(()), "{path}");
        }
        let open = Gate::new(h.parse().unwrap(), &[], None);
        assert_eq!(open.check(&page(h, None)), Ok(()), "--no-token");
    }

    #[test]
    fn tokens_are_32_hex_digits_and_differ() {
        let (a, b) = (new_token(), new_token());
        assert_eq!(a.len(), 32);
        assert!(a
            .bytes()
            .all(|c| c.is_ascii_hexdigit() && !c.is_ascii_uppercase()));
        assert_ne!(a, b);
    }

    #[test]
    fn refusals_are_all_counted_and_logged_about_once_a_second() {
        let mut log = RefusalLog::default();
        let t0 = Instant::now();
        assert_eq!(log.on_refusal(t0), Some(0));
        for i in 1..100 {
            assert_eq!(log.on_refusal(t0 + Duration::from_millis(i * 5)), None);
        }
        assert_eq!(log.on_refusal(t0 + Duration::from_millis(1000)), Some(99));
        assert_eq!(log.on_refusal(t0 + Duration::from_millis(1001)), None);
        assert_eq!(log.refused(), 102);
    }
}
