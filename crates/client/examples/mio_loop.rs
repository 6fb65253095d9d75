//! The client inside an application's own mio loop, beside a timer of its
//! own: the library only hands over its descriptor and its next deadline.
//!
//! Run a hub (`colony hub`), then `cargo run -p colony-client --example mio_loop`,
//! and publish with `colony pub vision_out 'ball x 1 y 2'`.

use std::os::fd::AsRawFd;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_wire::{PacketBuilder, Priority};
use mio::unix::SourceFd;
use mio::{Events, Interest, Poll, Token};

const HUB: Token = Token(0);

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let hub = std::env::var("COLONY_HUB").unwrap_or_else(|_| "127.0.0.1:7400".into());
    let mut client = UdpClient::connect(hub.as_str())?;
    client.subscribe("vision_out")?;

    let mut poll = Poll::new()?;
    poll.registry()
        .register(&mut SourceFd(&client.as_raw_fd()), HUB, Interest::READABLE)?;
    let mut events = Events::with_capacity(16);

    // The application's own work: a heartbeat every second.
    let mut next_beat = Instant::now();
    let mut beats = 0u64;
    loop {
        let now = Instant::now();
        let wake = client
            .next_deadline()
            .map_or(next_beat, |d| d.min(next_beat));
        poll.poll(&mut events, Some(wake.saturating_duration_since(now)))?;

        let now = Instant::now();
        client.poll(now)?;
        if now >= next_beat {
            let mut p = PacketBuilder::new(["heartbeat"], Priority(0));
            p.line("beat").field("n", beats);
            client.publish(&p.finish()?)?;
            beats += 1;
            next_beat = now + Duration::from_secs(1);
        }
        // mio is edge-triggered: drain everything that is waiting.
        while let Some(packet) = client.recv()? {
            print!("{packet}");
        }
    }
}
