//! The parts of a game as hub clients with no socket: each takes packets and
//! returns packets. Live, each runs behind its own hub connection (see
//! `live`); in a fast-forwarded match the same parts exchange the same
//! bytes through an in-memory [`Bus`] that routes like the hub does.

use std::collections::VecDeque;

use colony_wire::Packet;

/// One part of the game.
pub trait Node {
    /// The channels it listens to.
    fn subscriptions(&self) -> Vec<String>;
    /// Handles one packet from a subscribed channel; pushes packets to send.
    fn handle(&mut self, packet: &Packet<'_>, out: &mut Vec<Vec<u8>>);
}

/// Routes packets between nodes by channel, in the order they were sent.
/// Malformed packets are counted and dropped, as the hub does.
#[derive(Default)]
pub struct Bus {
    queue: VecDeque<Vec<u8>>,
    /// Packets delivered to at least one node.
    pub delivered: u64,
    /// Packets that failed to parse.
    pub malformed: u64,
}

impl Bus {
    /// Queues packets.
    pub fn send(&mut self, packets: impl IntoIterator<Item = Vec<u8>>) {
        self.queue.extend(packets);
    }

    /// Delivers until no packet is left; every packet also goes to `tap`
    /// (for a traffic log). Each node sees packets in the order sent.
    pub fn drain(&mut self, nodes: &mut [&mut dyn Node], mut tap: impl FnMut(&[u8])) {
        let subs: Vec<Vec<String>> = nodes.iter().map(|n| n.subscriptions()).collect();
        let mut out = Vec::new();
        while let Some(bytes) = self.queue.pop_front() {
            tap(&bytes);
            let Ok(packet) = Packet::parse(&bytes) else {
                self.malformed += 1;
                continue;
            };
            let mut any = false;
            for (node, subs) in nodes.iter_mut().zip(&subs) {
                // Subject-set addressing: every subject of the packet must be subscribed.
                if packet.subjects().all(|s| subs.iter().any(|x| x == s)) {
                    node.handle(&packet, &mut out);
                    any = true;
                }
            }
            if any {
                self.delivered += 1;
            }
            self.queue.extend(out.drain(..));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records what it hears and, on `ping`, answers on `pong`.
    struct Ear {
        subs: Vec<String>,
        heard: Vec<String>,
    }

    impl Node for Ear {
        fn subscriptions(&self) -> Vec<String> {
            self.subs.clone()
        }
        fn handle(&mut self, packet: &Packet<'_>, out: &mut Vec<Vec<u8>>) {
            self.heard.push(packet.subjects_text().to_string());
            if packet.has_subject("ping") {
                out.push(b"@ <pong> 0\nx\n".to_vec());
            }
        }
    }

    fn ear(subs: &[&str]) -> Ear {
        Ear {
            subs: subs.iter().map(|s| s.to_string()).collect(),
            heard: Vec::new(),
        }
    }

    #[test]
    fn packets_reach_only_nodes_subscribed_to_all_their_subjects_and_answers_follow() {
        let (mut a, mut b, mut c) = (
            ear(&["camera", "laser"]),
            ear(&["camera"]),
            ear(&["ping", "pong"]),
        );
        let mut bus = Bus::default();
        bus.send([
            b"@ <camera> <laser> 0\nt\n".to_vec(),
            b"@ <camera> 0\nt\n".to_vec(),
            b"@ <ping> 0\nt\n".to_vec(),
            b"not a packet".to_vec(),
        ]);
        let mut tapped = 0;
        bus.drain(&mut [&mut a, &mut b, &mut c], |_| tapped += 1);
        assert_eq!(a.heard, ["<camera> <laser>", "<camera>"]);
        assert_eq!(b.heard, ["<camera>"]);
        assert_eq!(
            c.heard,
            ["<ping>", "<pong>"],
            "the answer was delivered in the same drain"
        );
        assert_eq!((bus.delivered, bus.malformed, tapped), (4, 1, 5));
    }
}
