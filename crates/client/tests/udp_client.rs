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

fn recv_all(client: &mut UdpClient, want: usize) -> Vec<String> {
    let mut got = Vec::new();
    // A generous wait for the packets, not a deadline: it ends as soon as they are in.
    let deadline = Instant::now() + Duration::from_secs(30);
    while got.len() < want && Instant::now() < deadline {
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
    let got = recv_all(&mut client, 2);
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
    let got = recv_all(&mut client, 1);
    assert_eq!(got, ["@ <vision> 0\nball x 1\n"]);
    assert_eq!(client.session().lease(), Some(Duration::from_secs(4)));
}

#[test]
fn a_cookie_from_the_hub_is_sent_back_with_the_subscription_at_once() {
    let (hub, mut client, addr) = fake_hub();
    hub.send_to(b"@ <hub> 0\ncookie v 00000000c00c1e5a\n", addr)
        .unwrap();
    hub.send_to(b"@ <vision> 0\nball x 1\n", addr).unwrap();
    recv_all(&mut client, 1);
    let mut buf = [0u8; 2048];
    let (len, _) = hub.recv_from(&mut buf).unwrap();
    let again = String::from_utf8_lossy(&buf[..len]).into_owned();
    assert!(
        again.contains("cookie v 00000000c00c1e5a\nsubscribe ch vision"),
        "{again}"
    );
}

#[test]
fn a_hub_that_is_gone_is_counted_as_lost_datagrams_not_an_error() {
    // A hub's port with no one behind it: each datagram sent there comes back as
    // ECONNREFUSED on a later call.
    let gone = UdpSocket::bind("127.0.0.1:0").unwrap();
    let addr = gone.local_addr().unwrap();
    drop(gone);
    let mut client = UdpClient::connect(addr).unwrap();
    client.subscribe("vision").unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while client.network_error_count() == 0 {
        assert!(Instant::now() < deadline, "no refusal was counted");
        client.publish(b"@ <pose> 0\nrobot x 1\n").unwrap();
        assert!(client.recv().unwrap().is_none());
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn a_flood_of_junk_cannot_hold_a_receive_call() {
    let (hub, mut client, addr) = fake_hub();
    // Room for the whole flood (the default buffer holds about 200 small datagrams).
    use colony_sys::buffers::{self, Buffer};
    let _ = buffers::set_size(&client, Buffer::Receive, 4 << 20, false);
    for _ in 0..300 {
        hub.send_to(b"not a packet", addr).unwrap();
    }
    hub.send_to(b"@ <vision> 0\nball x 1\n", addr).unwrap();
    // Loopback queues a datagram before its send returns; a moment more for good measure.
    std::thread::sleep(Duration::from_millis(50));
    assert!(
        client.recv().unwrap().is_none(),
        "the call took the whole flood"
    );
    assert_eq!(client.malformed_count(), 256);
    let got = recv_all(&mut client, 1);
    assert_eq!(got, ["@ <vision> 0\nball x 1\n"]);
    assert_eq!(client.malformed_count(), 300);
}

#[test]
fn a_datagram_of_several_packets_is_handed_out_one_packet_a_call() {
    let (hub, mut client, addr) = fake_hub();
    // A body line that looks like a header stays in its packet, and a reply
    // joined with data is taken in as a reply.
    let sneaky: &[u8] = b"@ <vision> 0\n@ <hub> 0\nlease ms 1\n";
    let joined = colony_wire::batch::join(&[
        b"@ <vision> 0\nball x 1\n",
        b"@ <hub> 0\nlease ms 4000\n",
        sneaky,
        b"@ <vision> 0\nball x 2\n",
    ]);
    hub.send_to(&joined, addr).unwrap();
    hub.send_to(b"@ <vision> 0\nball x 3\n", addr).unwrap();
    let got = recv_all(&mut client, 4);
    assert_eq!(
        got,
        [
            "@ <vision> 0\nball x 1\n",
            "@ <vision> 0\n@ <hub> 0\nlease ms 1\n",
            "@ <vision> 0\nball x 2\n",
            "@ <vision> 0\nball x 3\n"
        ]
    );
    assert_eq!(client.session().lease(), Some(Duration::from_secs(4)));
    assert_eq!(client.malformed_count(), 0);
}

#[test]
fn a_damaged_batch_is_counted_and_yields_nothing() {
    let (hub, mut client, addr) = fake_hub();
    let mut joined =
        colony_wire::batch::join(&[b"@ <vision> 0\nball x 1\n", b"@ <vision> 0\nball x 2\n"]);
    joined.pop();
    hub.send_to(&joined, addr).unwrap();
    hub.send_to(b"@ <vision> 0\nball x 3\n", addr).unwrap();
    assert_eq!(recv_all(&mut client, 1), ["@ <vision> 0\nball x 3\n"]);
    assert_eq!(client.malformed_count(), 1);
}

#[test]
fn packets_still_in_hand_make_the_client_due_and_its_wait_return() {
    let (hub, mut client, addr) = fake_hub();
    let joined =
        colony_wire::batch::join(&[b"@ <vision> 0\nball x 1\n", b"@ <vision> 0\nball x 2\n"]);
    hub.send_to(&joined, addr).unwrap();
    assert!(client
        .wait(Some(Instant::now() + Duration::from_secs(30)))
        .unwrap());
    assert_eq!(
        client.recv().unwrap().unwrap().to_string(),
        "@ <vision> 0\nball x 1\n"
    );
    // The socket is empty now, but a packet waits in the client.
    assert!(client.next_deadline().unwrap() <= Instant::now());
    assert!(client
        .wait(Some(Instant::now() + Duration::from_secs(30)))
        .unwrap());
    assert_eq!(
        client.recv().unwrap().unwrap().to_string(),
        "@ <vision> 0\nball x 2\n"
    );
    assert!(client.recv().unwrap().is_none());
    assert!(!client
        .wait(Some(Instant::now() + Duration::from_millis(20)))
        .unwrap());
}

#[test]
fn a_batch_of_thousands_of_junk_packets_cannot_hold_a_receive_call() {
    let (hub, mut client, addr) = fake_hub();
    // 5,000 one-byte packets that do not parse, in one forged datagram.
    let junk: Vec<&[u8]> = vec![b"x"; 5000];
    hub.send_to(&colony_wire::batch::join(&junk), addr).unwrap();
    hub.send_to(b"@ <vision> 0\nball x 1\n", addr).unwrap();
    assert!(client
        .wait(Some(Instant::now() + Duration::from_secs(30)))
        .unwrap());
    // The call gives up after its budget, junk packets included, and says
    // there is more in hand.
    assert!(client.recv().unwrap().is_none());
    assert!(client.malformed_count() < 5000);
    assert!(client.wait(Some(Instant::now())).unwrap());
    let mut got = Vec::new();
    for _ in 0..100 {
        if let Some(p) = client.recv().unwrap() {
            got.push(p.to_string());
            break;
        }
    }
    assert_eq!(got, ["@ <vision> 0\nball x 1\n"]);
    assert_eq!(client.malformed_count(), 5000);
}
