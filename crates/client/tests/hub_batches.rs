//! The client against a real hub (polled by hand in the test's thread) that
//! joins several packets into one datagram because the client asked.

use std::net::UdpSocket;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_hub::{HubConfig, Server};
use colony_sys::udp::send_connected;
use colony_wire::Request;

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
