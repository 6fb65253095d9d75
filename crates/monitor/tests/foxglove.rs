//! The Foxglove endpoint's gate, against a real monitor on a real hub: the page's WebSocket
//! rules (host names, origin, token), and the hosted viewers' origins an operator allows for
//! this endpoint alone; and a viewer that took robots and then froze lets go of them. (What a
//! viewer gets is driven with Foxglove's own client by `tests/browser/foxglove.test.mjs`.)

use std::time::Duration;

use colony_monitor::Liveness;
use colony_testkit::monitor::{monitor, monitor_with, watch_override, with_token, OverrideView};
use colony_testkit::web::Ws;
use colony_testkit::HubOnThread;

#[test]
fn the_foxglove_endpoint_passes_the_pages_gate_and_answers_with_server_info() {
    let hub = HubOnThread::start();
    let m = monitor(&hub);
    let addr = m.local_addr();
    let host = addr.to_string();
    let path = with_token(&m, "/foxglove");
    assert!(m
        .foxglove_url()
        .starts_with(&format!("ws://{host}/foxglove?token=")));
    // No token, another site, another host name: refused as the page's WebSocket is.
    for (path, host, origin) in [
        ("/foxglove", host.as_str(), None),
        (
            path.as_str(),
            host.as_str(),
            Some("https://app.foxglove.dev"),
        ),
        (path.as_str(), "evil.example", None),
    ] {
        let refused = Ws::handshake(addr, path, host, origin)
            .err()
            .unwrap_or_else(|| panic!("{path} {host} {origin:?} was opened"));
        assert!(refused.starts_with("HTTP/1.1 403"), "{refused}");
    }
    // A client that is no page (a desktop viewer, a script), and the monitor's own origin.
    for origin in [None, Some(format!("http://{host}"))] {
        let mut ws = Ws::handshake(addr, &path, &host, origin.as_deref())
            .unwrap_or_else(|head| panic!("{head}"));
        let info = ws.until(Duration::from_secs(10), "serverInfo", |v| {
            v["op"] == "serverInfo"
        });
        assert_eq!(info["capabilities"][0], "clientPublish");
        ws.until(Duration::from_secs(10), "the scene channels", |v| {
            v["op"] == "advertise"
                && v["channels"]
                    .as_array()
                    .is_some_and(|c| c.iter().any(|c| c["topic"] == "/colony/arena"))
        });
        ws.close();
    }
    // An origin the operator allowed opens this endpoint, still with the token, and nothing else.
    m.allow_foxglove_origin("https://app.foxglove.dev/");
    let mut ws = Ws::handshake(addr, &path, &host, Some("https://app.foxglove.dev"))
        .unwrap_or_else(|head| panic!("{head}"));
    ws.until(Duration::from_secs(10), "serverInfo", |v| {
        v["op"] == "serverInfo"
    });
    ws.close();
    for (path, what) in [
        ("/foxglove".to_owned(), "no token"),
        (with_token(&m, "/ws"), "the page's WebSocket"),
    ] {
        let refused = Ws::handshake(addr, &path, &host, Some("https://app.foxglove.dev"))
            .err()
            .unwrap_or_else(|| panic!("{what} was opened to an allowed viewer origin"));
        assert!(refused.starts_with("HTTP/1.1 403"), "{what}: {refused}");
    }
    m.shutdown().unwrap();
}

#[test]
fn a_viewer_that_took_robots_and_stops_answering_lets_go_of_them() {
    let hub = HubOnThread::with_console();
    let m = monitor_with(
        &hub,
        Liveness {
            ping_every: Duration::from_millis(250),
            deadline: Duration::from_secs(2),
        },
    );
    let addr = m.local_addr();
    let mut viewer = Ws::handshake(addr, &with_token(&m, "/foxglove"), &addr.to_string(), None)
        .unwrap_or_else(|head| panic!("{head}"));
    viewer.until(Duration::from_secs(10), "serverInfo", |v| {
        v["op"] == "serverInfo"
    });
    viewer.send(
        r#"{"op":"advertise","channels":[{"id":4,"topic":"/colony/override","encoding":"json","schemaName":"colony.Override"}]}"#,
    );
    for request in [r#"{"t":"take","ids":[5,6]}"#, r#"{"t":"take_all"}"#] {
        let mut frame = vec![1, 4, 0, 0, 0];
        frame.extend_from_slice(request.as_bytes());
        viewer.send_binary(&frame);
    }
    let mut watcher = Ws::connect(addr, &with_token(&m, "/ws"));
    let mut view = OverrideView::default();
    watch_override(
        &mut watcher,
        Some(&mut viewer),
        &mut view,
        Duration::from_secs(30),
        "override in force while its viewer answers",
        OverrideView::in_force,
    );
    assert_eq!(m.foxglove_viewers().0, 1);
    // The viewer freezes with its connection open.
    watch_override(
        &mut watcher,
        None,
        &mut view,
        Duration::from_secs(60),
        "release of a frozen viewer's override",
        OverrideView::released,
    );
    assert_eq!(m.foxglove_viewers().0, 0, "the frozen viewer was dropped");
    drop(viewer);
    m.shutdown().unwrap();
}
