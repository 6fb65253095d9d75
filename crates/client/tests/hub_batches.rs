//! Several packets in one datagram, for a subscriber that asks (`batch bytes
//! N`), on loopback, seen raw and through the Rust client: the hub joins only
//! packets it has in hand, never past the subscriber's limit, keeps each
//! subscriber's order, and sends the others one datagram a packet. The
//! server is polled by hand, so a burst sent before the poll is in hand at
//! once. (Here rather than in the hub's tests: the client's crate may use the
//! hub's, not the other way round.)

use std::net::UdpSocket;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_hub::{HubConfig, Server};
use colony_sys::udp::send_connected;
use colony_wire::{batch, Request};

/// Subscribes `sock` to `channel` with these further request lines,
/// polling the server by hand; answers a cookie challenge.
fn subscribe(server: &mut Server, sock: &UdpSocket, channel: &str, extra: &str) {
    let hub = server.local_addr().unwrap();
    sock.set_read_timeout(Some(Duration::from_millis(20)))
        .unwrap();
    let mut cookie = colony_wire::Cookie::NONE.to_string();
    for _ in 0..200 {
        let req = format!("@ <hub> 0\ncookie v {cookie}\nsubscribe ch {channel}\n{extra}");
        sock.send_to(req.as_bytes(), hub).unwrap();
        server.poll(Duration::from_millis(10)).unwrap();
        let mut buf = [0; 2048];
        let Ok(n) = sock.recv(&mut buf) else {
            continue;
        };
        let reply = String::from_utf8_lossy(&buf[..n]).into_owned();
        if reply.contains("lease") {
            sock.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
            return;
        }
        if let Some(c) = reply.split("cookie v ").nth(1) {
            c.trim().clone_into(&mut cookie);
        }
    }
    panic!("no lease for {channel}");
}

/// 60 packets of differing lengths; some have a body line that looks like
/// a header, which must stay inside its packet.
fn burst() -> Vec<Vec<u8>> {
    (0..60)
        .map(|i| {
            let body = if i % 10 == 3 {
                "@ <secret> 99\n".to_owned()
            } else {
                format!("x n {i} pad {}\n", "z".repeat(1 + i * 7 % 90))
            };
            format!("@ <batched> 0\n{body}").into_bytes()
        })
        .collect()
}

fn publish_and_poll(server: &mut Server, packets: &[Vec<u8>]) {
    let publisher = UdpSocket::bind("127.0.0.1:0").unwrap();
    publisher.connect(server.local_addr().unwrap()).unwrap();
    let msgs: Vec<&[u8]> = packets.iter().map(Vec::as_slice).collect();
    let mut sent = 0;
    while sent < msgs.len() {
        sent += send_connected(&publisher, &msgs[sent..]).unwrap();
    }
    let mut handled = 0;
    let deadline = Instant::now() + Duration::from_secs(30);
    while handled < packets.len() && Instant::now() < deadline {
        handled += server.poll(Duration::from_millis(10)).unwrap();
    }
    assert_eq!(handled, packets.len());
}

#[test]
fn a_subscriber_that_asks_gets_packets_joined_within_its_limit_and_others_one_each() {
    let mut server = Server::bind("127.0.0.1:0", HubConfig::default()).unwrap();
    let joined = UdpSocket::bind("127.0.0.1:0").unwrap();
    let plain = UdpSocket::bind("127.0.0.1:0").unwrap();
    subscribe(&mut server, &joined, "batched", "batch bytes 1400\n");
    subscribe(&mut server, &plain, "batched", "");
    let packets = burst();
    publish_and_poll(&mut server, &packets);

    let mut buf = vec![0; 65_536];
    for p in &packets {
        let n = plain.recv(&mut buf).unwrap();
        assert_eq!(&buf[..n], &p[..], "one datagram a packet, in order");
    }
    let mut got: Vec<Vec<u8>> = Vec::new();
    let mut datagrams = 0;
    while got.len() < packets.len() {
        let n = joined.recv(&mut buf).unwrap();
        let d = &buf[..n];
        assert!(n <= 1400, "a datagram of {n} bytes, over the 1,400 asked");
        datagrams += 1;
        got.extend(batch::split(d).unwrap().map(|r| d[r].to_vec()));
    }
    assert_eq!(got, packets);
    // 60 packets of 30 to 130 bytes: about a dozen fill 1,400 bytes.
    assert!(datagrams <= 10, "{datagrams} datagrams for 60 packets");
}

#[test]
fn a_subscriber_that_asks_for_0_bytes_gets_one_packet_a_datagram_again() {
    let mut server = Server::bind("127.0.0.1:0", HubConfig::default()).unwrap();
    let sub = UdpSocket::bind("127.0.0.1:0").unwrap();
    subscribe(&mut server, &sub, "batched", "batch bytes 65507\n");
    subscribe(&mut server, &sub, "batched", "batch bytes 0\n");
    let packets = burst();
    publish_and_poll(&mut server, &packets);
    let mut buf = vec![0; 65_536];
    for p in &packets {
        let n = sub.recv(&mut buf).unwrap();
        assert_eq!(&buf[..n], &p[..]);
    }
}

#[test]
fn the_rust_client_asking_for_batches_receives_every_packet_in_order() {
    let mut server = Server::bind("127.0.0.1:0", HubConfig::default()).unwrap();
    let mut client = UdpClient::connect(server.local_addr().unwrap()).unwrap();
    client
        .set_standing(vec![Request::Batch(colony_wire::MAX_PACKET)])
        .unwrap();
    client.subscribe("batched").unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while client.session().lease().is_none() && Instant::now() < deadline {
        server.poll(Duration::from_millis(10)).unwrap();
        client.poll(Instant::now()).unwrap();
        while client.recv().unwrap().is_some() {}
    }
    assert!(client.session().lease().is_some(), "no lease");
    let packets = burst();
    publish_and_poll(&mut server, &packets);
    let mut got = Vec::new();
    while got.len() < packets.len() && Instant::now() < deadline {
        client
            .wait(Some(Instant::now() + Duration::from_millis(50)))
            .unwrap();
        while let Some(p) = client.recv().unwrap() {
            got.push(p.as_str().as_bytes().to_vec());
        }
    }
    assert_eq!(got, packets);
    assert_eq!(client.malformed_count(), 0);
}
