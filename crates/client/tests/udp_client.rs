//! The UDP client against a hub played by a plain socket.

use std::net::UdpSocket;
use std::time::{Duration, Instant};

use colony_client::UdpClient;

/// A fake hub: a socket the test speaks through, and the client's address once it subscribed.
fn fake_hub() -> (UdpSocket, UdpClient, std::net::SocketAddr) {
    let hub = UdpSocket::bind("127.0.0.1:0").unwrap();
    hub.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let mut client = UdpClient::connect(hub.local_addr().unwrap()).unwrap();
    client.subscribe("vision").unwrap();
    let mut buf = [0u8; 2048];
    let (len, from) = hub.recv_from(&mut buf).unwrap();
    assert!(String::from_utf8_lossy(&buf[..len]).contains("subscribe ch vision"));
    (hub, client, from)
}

fn recv_all(client: &mut UdpClient) -> Vec<String> {
    let mut got = Vec::new();
    // A generous wait for the two packets, not a deadline: it ends as soon as they are in.
    let deadline = Instant::now() + Duration::from_secs(30);
    while got.len() < 2 && Instant::now() < deadline {
        client
            .wait(Some(Instant::now() + Duration::from_millis(50)))
            .unwrap();
        while let Some(p) = client.recv().unwrap() {
            got.push(p.to_string());
        }
    }
    got
}

#[test]
fn a_malformed_datagram_is_counted_and_skipped_not_an_error() {
    let (hub, mut client, addr) = fake_hub();
    hub.send_to(b"@ <vision> 0\nball x 1\n", addr).unwrap();
    hub.send_to(b"@ <vision> 0\nball y 1 y 2\n", addr).unwrap();
    hub.send_to(b"\xff\xfe", addr).unwrap();
    hub.send_to(b"@ <vision> 0\nball x 2\n", addr).unwrap();
    let got = recv_all(&mut client);
    assert_eq!(
        got,
        ["@ <vision> 0\nball x 1\n", "@ <vision> 0\nball x 2\n"]
    );
    assert_eq!(client.malformed_count(), 2);
}

#[test]
fn hub_replies_are_taken_in_and_not_returned_as_data() {
    let (hub, mut client, addr) = fake_hub();
    hub.send_to(b"@ <hub> 0\nlease ms 4000\n", addr).unwrap();
    hub.send_to(b"@ <vision> 0\nball x 1\n", addr).unwrap();
    let got = recv_all(&mut client);
    assert_eq!(got, ["@ <vision> 0\nball x 1\n"]);
    assert_eq!(client.session().lease(), Some(Duration::from_secs(4)));
}
