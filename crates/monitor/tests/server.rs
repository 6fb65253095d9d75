//! The monitor's web server on loopback, next to a real hub: it serves its
//! page, script and style from the binary, reports a taken port clearly,
//! joins the hub as an ordinary client, and stops promptly. It answers only
//! to its own host names, opens no WebSocket for another site's page, needs
//! its token, refuses a request with two `Host` headers, and lets a page's robots go when the
//! page goes, or freezes.

use std::time::{Duration, Instant};

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use colony_monitor::{Liveness, Monitor, MonitorConfig, MonitorError};

use colony_testkit::monitor::{monitor, monitor_with, watch_override, with_token, OverrideView};
use colony_testkit::web::{get, request, Ws};
use colony_testkit::HubOnThread;

#[test]
fn the_page_its_script_and_its_style_are_served_from_the_binary() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    assert!(m.url().starts_with("http://127.0.0.1:"));
    let page = get(m.local_addr(), &with_token(&m, "/"));
    assert!(page.starts_with("HTTP/1.0 200"), "{page}");
    assert!(page.contains("<title>colony monitor</title>") && page.contains("/app.js"));
    let js = get(m.local_addr(), "/app.js");
    assert!(
        js.contains("text/javascript") && js.contains("window.colony"),
        "{js:.300}"
    );
    let css = get(m.local_addr(), "/style.css");
    assert!(
        css.contains("text/css") && css.contains(".stale-banner"),
        "{css:.300}"
    );
    assert!(get(m.local_addr(), &with_token(&m, "/nothing-here")).starts_with("HTTP/1.0 404"));
    // A plain GET on the WebSocket route is refused, not a crash.
    assert!(!get(m.local_addr(), &with_token(&m, "/ws")).starts_with("HTTP/1.0 200"));
    assert!(m.is_running());
    m.shutdown().unwrap();
}

#[test]
fn a_taken_port_is_a_clear_error() {
    let hub = HubOnThread::start();
    let first = monitor(&hub);
    let taken = first.local_addr().to_string();
    let e = Monitor::start(&MonitorConfig {
        hub: hub.addr.to_string(),
        bind: taken.clone(),
        ..MonitorConfig::default()
    })
    .err()
    .expect("a second monitor on the same port fails");
    assert!(matches!(e, MonitorError::Bind { .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains(&taken) && text.contains("--bind"),
        "the message names the address and the way out: {text}"
    );
    let bad_hub = Monitor::start(&MonitorConfig {
        hub: "not an address".into(),
        bind: "127.0.0.1:0".into(),
        ..MonitorConfig::default()
    })
    .err()
    .expect("a hub address that does not resolve fails");
    assert!(bad_hub.to_string().contains("not an address"), "{bad_hub}");
}

#[test]
fn the_monitor_joins_the_hub_as_a_client_and_stops_promptly() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    // The hub lists the monitor's subscriptions once they arrive.
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut status = String::new();
    while Instant::now() < deadline {
        let mut c = colony_client::UdpClient::connect(hub.addr).unwrap();
        c.subscribe("probe").unwrap();
        let until = Instant::now() + Duration::from_millis(500);
        let mut leased = false;
        while Instant::now() < until {
            let _ = c.wait(Some(Instant::now() + Duration::from_millis(20)));
            while let Ok(Some(r)) = c.recv_reply() {
                match r {
                    colony_wire::Reply::Lease { .. } if !leased => {
                        leased = true;
                        c.request(&[colony_wire::Request::Status]).unwrap();
                    }
                    colony_wire::Reply::Status(s) => {
                        status = format!("{:?}", s.clients);
                    }
                    _ => {}
                }
            }
        }
        if status.contains("vision") && status.contains(colony_monitor::LEASE_CHANNEL) {
            break;
        }
    }
    assert!(
        status.contains("vision") && status.contains("radio") && status.contains("debug"),
        "{status}"
    );
    let t0 = Instant::now();
    m.shutdown().unwrap();
    // Shutdown ends the bridge and the server (it returning at all is the behaviour; the
    // bound only keeps a hang from stalling the suite).
    assert!(t0.elapsed() < Duration::from_secs(60), "{:?}", t0.elapsed());
}

/// The value of header `name` in a raw HTTP answer, if it is there.
fn header<'a>(answer: &'a str, name: &str) -> Option<&'a str> {
    let head = answer.split("\r\n\r\n").next().unwrap_or("");
    head.lines().find_map(|l| {
        let (n, v) = l.split_once(':')?;
        n.eq_ignore_ascii_case(name).then(|| v.trim())
    })
}

#[test]
fn a_page_of_another_site_cannot_open_the_websocket() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let addr = m.local_addr();
    let host = addr.to_string();
    let path = with_token(&m, "/ws");
    for origin in [
        "http://evil.example",
        "null",
        &format!("http://{host}.evil.example"),
    ] {
        let refused = Ws::handshake(addr, &path, &host, Some(origin))
            .err()
            .unwrap_or_else(|| panic!("a WebSocket from {origin} was opened"));
        assert!(
            refused.starts_with("HTTP/1.1 403") && refused.contains("another site"),
            "{refused}"
        );
    }
    assert_eq!(m.refused(), 3);
    // The monitor's own page, by any of its names; and a client that is no page (no Origin).
    let port = addr.port();
    for (host, origin) in [
        (host.clone(), Some(format!("http://{host}"))),
        (
            format!("localhost:{port}"),
            Some(format!("http://localhost:{port}")),
        ),
        (host.clone(), None),
    ] {
        let mut ws = Ws::handshake(addr, &path, &host, origin.as_deref())
            .unwrap_or_else(|head| panic!("{host} {origin:?}: {head}"));
        ws.until(Duration::from_secs(10), "a world snapshot", |v| {
            v["t"] == "world"
        });
    }
    // The operator's page is told of the refusals.
    let mut ws = Ws::handshake(addr, &path, &host, None).unwrap();
    let counts = ws.until(Duration::from_secs(10), "the monitor's counts", |v| {
        v["t"] == "monitor"
    });
    assert_eq!(counts["refused"], 3, "{counts}");
    assert_eq!(counts["foxglove"]["viewers"], 0, "{counts}");
    assert_eq!(counts["foxglove"]["dropped"], 0, "{counts}");
    // A refusal while the page is open reaches it too, with the hub gone: someone may knock
    // just when it is down.
    drop(hub);
    assert!(Ws::handshake(addr, &path, &host, Some("http://evil.example")).is_err());
    ws.until(Duration::from_secs(10), "the new refusal", |v| {
        v["t"] == "monitor" && v["refused"] == 4
    });
    m.shutdown().unwrap();
}

#[test]
fn a_request_for_another_host_name_is_refused() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let addr = m.local_addr();
    let page = with_token(&m, "/");
    let port = addr.port();
    // DNS rebinding: evil.example now points at 127.0.0.1, but the browser still says whose
    // page it is loading.
    for host in [
        format!("evil.example:{port}"),
        "127.0.0.1".into(),
        format!("localhost:{}", port + 1),
    ] {
        for path in [page.as_str(), "/app.js"] {
            let answer = request(
                addr,
                &format!("GET {path} HTTP/1.0\r\nHost: {host}\r\n\r\n"),
            );
            assert!(
                answer.starts_with("HTTP/1.0 403") && answer.contains("own host names"),
                "{host} {path}: {answer}"
            );
        }
        let refused = Ws::handshake(addr, &with_token(&m, "/ws"), &host, None).err();
        assert!(
            refused.is_some_and(|r| r.starts_with("HTTP/1.1 403")),
            "{host}"
        );
    }
    let no_host = request(addr, &format!("GET {page} HTTP/1.0\r\n\r\n"));
    assert!(no_host.starts_with("HTTP/1.0 403"), "{no_host}");
    let absolute = request(
        addr,
        &format!(
            "GET http://evil.example{page} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
        ),
    );
    assert!(absolute.starts_with("HTTP/1.1 403"), "{absolute}");
    assert_eq!(m.refused(), 11);
    let ok = request(
        addr,
        &format!("GET {page} HTTP/1.0\r\nHost: localhost:{port}\r\n\r\n"),
    );
    assert!(ok.starts_with("HTTP/1.0 200"), "{ok:.300}");
    m.shutdown().unwrap();

    // A name given with --allow-host is the monitor's too.
    let m = Monitor::start(&MonitorConfig {
        hub: hub.addr.to_string(),
        bind: "127.0.0.1:0".into(),
        allow_hosts: vec!["robots.lab".into()],
        ..MonitorConfig::default()
    })
    .unwrap();
    let port = m.local_addr().port();
    let answer = request(
        m.local_addr(),
        &format!(
            "GET {} HTTP/1.0\r\nHost: robots.lab:{port}\r\n\r\n",
            with_token(&m, "/")
        ),
    );
    assert!(answer.starts_with("HTTP/1.0 200"), "{answer:.300}");
    m.shutdown().unwrap();
}

#[test]
fn the_pages_and_the_websocket_need_the_token_the_printed_address_carries() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let addr = m.local_addr();
    let token = m.token().expect("a token by default").to_owned();
    assert_eq!(token.len(), 32);
    assert_eq!(m.url(), format!("http://{addr}/?token={token}"));
    assert_eq!(
        m.page_url("/game", "team=red"),
        format!("http://{addr}/game?team=red&token={token}")
    );
    for path in [
        "/",
        "/game",
        "/?token=",
        "/?token=00000000000000000000000000000000",
    ] {
        let answer = get(addr, path);
        assert!(
            answer.starts_with("HTTP/1.0 403") && answer.contains("token"),
            "{path}: {answer}"
        );
    }
    let refused = Ws::handshake(addr, "/ws?view=game", &addr.to_string(), None).err();
    assert!(refused.is_some_and(|r| r.starts_with("HTTP/1.1 403")));
    // The scripts and styles hold no secret; the page that loads them needs the token.
    assert!(get(addr, "/common.js").starts_with("HTTP/1.0 200"));
    let path = m
        .url()
        .trim_start_matches(&format!("http://{addr}"))
        .to_owned();
    assert!(get(addr, &path).starts_with("HTTP/1.0 200"));
    m.shutdown().unwrap();

    let open = Monitor::start(&MonitorConfig {
        hub: hub.addr.to_string(),
        bind: "127.0.0.1:0".into(),
        token: false,
        ..MonitorConfig::default()
    })
    .unwrap();
    assert_eq!(open.token(), None);
    assert_eq!(open.url(), format!("http://{}/", open.local_addr()));
    assert!(get(open.local_addr(), "/").starts_with("HTTP/1.0 200"));
    open.shutdown().unwrap();

    // Bound to every address, the printed address is one a browser may use.
    let everywhere = Monitor::start(&MonitorConfig {
        hub: hub.addr.to_string(),
        bind: "0.0.0.0:0".into(),
        ..MonitorConfig::default()
    })
    .unwrap();
    let port = everywhere.local_addr().port();
    let url = everywhere.url();
    assert!(
        url.starts_with(&format!("http://127.0.0.1:{port}/?token=")),
        "{url}"
    );
    let loopback = std::net::SocketAddr::from(([127, 0, 0, 1], port));
    let path = url.trim_start_matches(&format!("http://{loopback}"));
    assert!(get(loopback, path).starts_with("HTTP/1.0 200"));
    everywhere.shutdown().unwrap();
}

#[test]
fn every_answer_carries_the_security_headers() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let addr = m.local_addr();
    for answer in [
        get(addr, &with_token(&m, "/")),
        get(addr, "/app.js"),
        get(addr, "/"),
        request(addr, "GET /app.js HTTP/1.0\r\nHost: evil.example\r\n\r\n"),
    ] {
        assert_eq!(
            header(&answer, "x-frame-options"),
            Some("DENY"),
            "{answer:.400}"
        );
        assert_eq!(
            header(&answer, "content-security-policy"),
            Some("frame-ancestors 'none'")
        );
        assert_eq!(header(&answer, "x-content-type-options"), Some("nosniff"));
        assert_eq!(header(&answer, "referrer-policy"), Some("no-referrer"));
    }
    m.shutdown().unwrap();
}

/// Robot ids the monitor holds, from a world snapshot.
fn held(world: &serde_json::Value) -> Vec<u64> {
    world["held"]
        .as_array()
        .map(|a| a.iter().filter_map(|v| v.as_u64()).collect())
        .unwrap_or_default()
}

#[test]
fn closing_the_page_that_took_robots_hands_them_back() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let addr = m.local_addr();
    let path = with_token(&m, "/ws");
    let mut watcher = Ws::connect(addr, &path);
    let mut holder = Ws::connect(addr, &path);
    holder.send(r#"{"t":"take","ids":[5,6]}"#);
    let reply = holder.until(Duration::from_secs(10), "the reply", |v| v["t"] == "reply");
    assert_eq!(reply["ok"], true, "{reply}");
    watcher.until(Duration::from_secs(10), "robots 5 and 6 held", |v| {
        v["t"] == "world" && held(v) == [5, 6]
    });
    // Another page coming and going leaves them held.
    Ws::connect(addr, &path).close();
    holder.close();
    watcher.until(Duration::from_secs(10), "robots 5 and 6 handed back", |v| {
        v["t"] == "world" && held(v).is_empty()
    });
    m.shutdown().unwrap();
}

#[test]
fn a_request_with_two_host_headers_is_refused() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let addr = m.local_addr();
    let page = with_token(&m, "/");
    let port = addr.port();
    // Its own host first, then another: the gate must not judge one while a proxy or a
    // handler believes the other. Nor two of its own, nor either order.
    for (first, second) in [
        (addr.to_string(), format!("evil.example:{port}")),
        (format!("evil.example:{port}"), addr.to_string()),
        (addr.to_string(), addr.to_string()),
        (addr.to_string(), format!("localhost:{port}")),
    ] {
        for path in [page.as_str(), "/app.js"] {
            let answer = request(
                addr,
                &format!(
                    "GET {path} HTTP/1.1\r\nHost: {first}\r\nHost: {second}\r\n\
                     Connection: close\r\n\r\n"
                ),
            );
            assert!(
                answer.starts_with("HTTP/1.1 400") && answer.contains("more than one Host"),
                "{first} {second} {path}: {answer}"
            );
        }
        let refused = Ws::handshake(
            addr,
            &with_token(&m, "/ws"),
            &format!("{first}\r\nHost: {second}"),
            None,
        )
        .err();
        assert!(
            refused.is_some_and(|r| r.starts_with("HTTP/1.1 400")),
            "{first} {second}"
        );
    }
    assert_eq!(m.refused(), 12);
    // One of its own is still served, and one foreign is still refused as before.
    let ok = request(
        addr,
        &format!("GET {page} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"),
    );
    assert!(ok.starts_with("HTTP/1.1 200"), "{ok:.300}");
    let foreign = request(
        addr,
        &format!("GET {page} HTTP/1.1\r\nHost: evil.example:{port}\r\nConnection: close\r\n\r\n"),
    );
    assert!(foreign.starts_with("HTTP/1.1 403"), "{foreign}");
    m.shutdown().unwrap();
}

/// Pings every quarter second, two seconds to answer: a frozen peer goes well within the
/// tests' waits.
const QUICK: Liveness = Liveness {
    ping_every: Duration::from_millis(250),
    deadline: Duration::from_secs(2),
};

/// A page on `m` that takes robots 5 and 6 and then all of them.
fn holder(m: &Monitor) -> Ws {
    let mut holder = Ws::connect(m.local_addr(), &with_token(m, "/ws"));
    holder.send(r#"{"t":"take","ids":[5,6]}"#);
    holder.send(r#"{"t":"take_all"}"#);
    holder
}

#[test]
fn a_page_that_stops_answering_lets_go_of_the_robots_and_the_hubs_minimum() {
    let hub = HubOnThread::with_console();
    let m = monitor_with(&hub, QUICK);
    let mut holder = holder(&m);
    let mut watcher = Ws::connect(m.local_addr(), &with_token(&m, "/ws"));
    let mut view = OverrideView::default();
    watch_override(
        &mut watcher,
        Some(&mut holder),
        &mut view,
        Duration::from_secs(30),
        "override in force while its page answers",
        OverrideView::in_force,
    );
    // The page freezes: its connection stays open, and it reads nothing more, so it never
    // sees a ping.
    watch_override(
        &mut watcher,
        None,
        &mut view,
        Duration::from_secs(60),
        "release of a frozen page's override",
        OverrideView::released,
    );
    drop(holder);
    m.shutdown().unwrap();
}

/// A vision frame of `n` robots: a world snapshot of a few dozen kilobytes.
fn big_frame(step: u64, n: u32) -> String {
    let mut f = format!(
        "@ <vision> 20\nstep n {step} part 0 parts 1\narena width 3000 height 3000 corner 15\n\
         sizes robot_length 12.5 robot_width 10.8 gripper_radius 3.6 puck_diameter 6.3\n"
    );
    for id in 0..n {
        let (x, y) = (
            (id % 40) as f64 * 20.0,
            (id / 40) as f64 * 20.0 + step as f64 % 7.0,
        );
        f.push_str(&format!("robot id {id} x {x:.1} y {y:.1} theta 0.25\n"));
    }
    f
}

#[test]
fn a_page_whose_connection_stays_full_lets_go_even_without_pings() {
    let hub = HubOnThread::with_console();
    // Pings all but off: only a send that cannot finish can find this page gone.
    let m = monitor_with(
        &hub,
        Liveness {
            ping_every: Duration::from_secs(86_400),
            ..QUICK
        },
    );
    let mut holder = holder(&m);
    let mut watcher = Ws::connect(m.local_addr(), &with_token(&m, "/ws"));
    let mut view = OverrideView::default();
    watch_override(
        &mut watcher,
        Some(&mut holder),
        &mut view,
        Duration::from_secs(30),
        "override in force while its page reads",
        OverrideView::in_force,
    );
    // Big snapshots, many a second, until the frozen page's buffers are full.
    let stop = Arc::new(AtomicBool::new(false));
    let flood = {
        let stop = stop.clone();
        let addr = hub.addr;
        std::thread::spawn(move || {
            let mut c = colony_client::UdpClient::connect(addr).unwrap();
            let mut step = 0;
            while !stop.load(Ordering::Relaxed) {
                step += 1;
                let _ = c.publish(big_frame(step, 1000).as_bytes());
                std::thread::sleep(Duration::from_millis(20));
            }
        })
    };
    watch_override(
        &mut watcher,
        None,
        &mut view,
        Duration::from_secs(90),
        "release of the override of a page that reads nothing",
        OverrideView::released,
    );
    stop.store(true, Ordering::Relaxed);
    flood.join().unwrap();
    drop(holder);
    m.shutdown().unwrap();
}
