//! Hub clients that wait, within bounds, for what a test needs of them.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use colony_client::UdpClient;

/// Polls `client` until `deadline`, collecting every packet's text.
pub fn drain_until(
    client: &mut UdpClient,
    deadline: Instant,
    mut done: impl FnMut(&[String]) -> bool,
) -> Vec<String> {
    let mut got = Vec::new();
    while Instant::now() < deadline && !done(&got) {
        let _ = client.wait(Some(Instant::now() + Duration::from_millis(20)));
        client.poll(Instant::now()).expect("poll");
        while let Some(p) = client.recv().expect("recv") {
            got.push(p.to_string());
        }
    }
    got
}

/// Subscribes and waits until the hub has acknowledged the lease.
pub fn subscribed(hub: SocketAddr, subjects: &[&str]) -> UdpClient {
    let mut c = UdpClient::connect(hub).expect("client");
    for s in subjects {
        c.subscribe(s).expect("subscribe");
    }
    let deadline = Instant::now() + Duration::from_secs(5);
    while c.session().lease().is_none() {
        assert!(
            Instant::now() < deadline,
            "the hub at {hub} never acknowledged a subscription"
        );
        let _ = c.wait(Some(Instant::now() + Duration::from_millis(20)));
        c.poll(Instant::now()).unwrap();
        while c.recv_reply().unwrap().is_some() {}
    }
    c
}
