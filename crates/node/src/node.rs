//! What every participant is to a transport: a hub client with no socket and no clock.

use std::collections::BTreeSet;

use colony_wire::{Packet, Subject};

use crate::time::Time;

/// A participant in a colony protocol, in the shape of quinn-proto's
/// `Connection`: it owns no socket, reads no clock and starts no thread, so the
/// same value runs over the real hub ([`Link`](crate::Link),
/// [`Mux`](crate::Mux)) and over the in-memory [`Bus`](crate::Bus) on
/// simulated time.
///
/// The methods fall into three groups.
///
/// - **Getter**: [`subscriptions`](Node::subscriptions), the subjects the
///   transport must hold for it. The transport keeps the hub's subscriptions
///   equal to this set (subscribing, refreshing leases, resubscribing after a
///   hub restart); the node never sees that control traffic.
/// - **Inputs**: [`handle_packet`](Node::handle_packet) for each packet the hub
///   forwards to it, and [`handle_timeout`](Node::handle_timeout) once the time
///   [`poll_timeout`](Node::poll_timeout) named has come. `now` is always an
///   argument and never goes back.
/// - **Outputs**: [`poll_transmit`](Node::poll_transmit), the packets to
///   publish, and [`poll_timeout`](Node::poll_timeout), the next deadline.
///
/// After every input (and after the owner changes the node between inputs),
/// a transport reads, in this order: [`subscriptions`](Node::subscriptions),
/// so a reply's answer finds the node already subscribed; then
/// [`poll_transmit`](Node::poll_transmit) until it gives `None`; then
/// [`poll_timeout`](Node::poll_timeout), which may have moved.
///
/// A node that must stop while its owner runs it (a robot killed) is simply
/// not driven any more: the transport drops its subscriptions.
pub trait Node {
    /// The subjects this participant should be subscribed to now. A packet
    /// reaches it only if every one of the packet's subjects is among them
    /// (the hub's subject-set addressing).
    fn subscriptions(&self) -> &BTreeSet<Subject>;
    /// A packet the hub forwarded, arriving at `now`.
    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>);
    /// Time has come to `now`: run every timer due by then. A node with no
    /// timer (one that only answers packets) keeps the default, which does nothing.
    fn handle_timeout(&mut self, now: Time) {
        let _ = now;
    }
    /// When [`handle_timeout`](Node::handle_timeout) is next needed; `None`
    /// while no timer runs (the default).
    fn poll_timeout(&self) -> Option<Time> {
        None
    }
    /// The next packet to publish, whole and well formed; `None` when there
    /// is nothing more to send now.
    fn poll_transmit(&mut self) -> Option<Vec<u8>>;
}

/// Implements [`Node`] for a pointer to a node by handing every call through.
macro_rules! delegate_node {
    ($(#[$doc:meta])* $pointer:ty) => {
        $(#[$doc])*
        impl<T: Node + ?Sized> Node for $pointer {
            fn subscriptions(&self) -> &BTreeSet<Subject> {
                (**self).subscriptions()
            }
            fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
                (**self).handle_packet(now, packet)
            }
            fn handle_timeout(&mut self, now: Time) {
                (**self).handle_timeout(now)
            }
            fn poll_timeout(&self) -> Option<Time> {
                (**self).poll_timeout()
            }
            fn poll_transmit(&mut self) -> Option<Vec<u8>> {
                (**self).poll_transmit()
            }
        }
    };
}

delegate_node!(Box<T>);
delegate_node!(
    /// A borrowed node is a node: a [`Mux`](crate::Mux) can serve nodes its
    /// caller keeps.
    &mut T
);

#[cfg(test)]
mod tests {
    use super::*;

    fn set(s: &str) -> BTreeSet<Subject> {
        s.split_whitespace()
            .map(|s| Subject::new(s).unwrap())
            .collect()
    }

    struct Counter {
        subs: BTreeSet<Subject>,
        packets: u32,
        timeouts: u32,
    }

    impl Node for Counter {
        fn subscriptions(&self) -> &BTreeSet<Subject> {
            &self.subs
        }
        fn handle_packet(&mut self, _: Time, _: &Packet<'_>) {
            self.packets += 1;
        }
        fn handle_timeout(&mut self, _: Time) {
            self.timeouts += 1;
        }
        fn poll_timeout(&self) -> Option<Time> {
            Some(Time::from_micros(u64::from(self.timeouts)))
        }
        fn poll_transmit(&mut self) -> Option<Vec<u8>> {
            (self.packets > 0).then(|| b"@ <a> 0\nx\n".to_vec())
        }
    }

    #[test]
    fn boxed_and_borrowed_nodes_pass_every_call_through() {
        let mut c = Counter {
            subs: set("a"),
            packets: 0,
            timeouts: 0,
        };
        let packet = Packet::parse(b"@ <a> 0\nx\n").unwrap();
        {
            let mut borrowed: &mut Counter = &mut c;
            let node: &mut dyn Node = &mut borrowed;
            node.handle_packet(Time::ZERO, &packet);
            node.handle_timeout(Time::ZERO);
            assert_eq!(node.poll_timeout(), Some(Time::from_micros(1)));
            assert!(node.poll_transmit().is_some());
            assert_eq!(node.subscriptions(), &set("a"));
        }
        let mut boxed: Box<dyn Node> = Box::new(c);
        boxed.handle_packet(Time::ZERO, &packet);
        boxed.handle_timeout(Time::ZERO);
        assert_eq!(boxed.poll_timeout(), Some(Time::from_micros(2)));
        assert!(boxed.poll_transmit().is_some());
        assert_eq!(boxed.subscriptions(), &set("a"));
    }
}
