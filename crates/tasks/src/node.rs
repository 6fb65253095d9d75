//! What every participant is to a transport: a sans-IO hub client.

use std::collections::BTreeSet;

use colony_wire::{Packet, Subject};

use crate::time::Time;

/// A participant in the protocol with no socket and no clock, in the shape of
/// quinn-proto's `Connection`: feed it packets with
/// [`handle_packet`](Node::handle_packet) and time with
/// [`handle_timeout`](Node::handle_timeout) once [`poll_timeout`](Node::poll_timeout)
/// comes; then send what [`poll_transmit`](Node::poll_transmit) gives, and keep
/// the transport's subscriptions equal to [`subscriptions`](Node::subscriptions).
///
/// The same value runs over the real hub ([`crate::live::Link`]) and over the
/// in-memory [`crate::bus::Bus`].
pub trait Node {
    /// The subjects this participant should be subscribed to now. A packet
    /// reaches it only if every one of the packet's subjects is among them.
    fn subscriptions(&self) -> &BTreeSet<Subject>;
    /// A packet from the hub.
    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>);
    /// Time has come to `now`: run every timer due by then.
    fn handle_timeout(&mut self, now: Time);
    /// When [`handle_timeout`](Node::handle_timeout) is next needed.
    fn poll_timeout(&self) -> Option<Time>;
    /// The next packet to publish.
    fn poll_transmit(&mut self) -> Option<Vec<u8>>;
}

/// Whether a subscriber holding `subs` receives a packet addressed to
/// `subjects`: it must hold every one of them (MURDOCH's subject-set addressing,
/// as the hub routes).
pub fn receives<'a>(subs: &BTreeSet<Subject>, mut subjects: impl Iterator<Item = &'a str>) -> bool {
    subjects.all(|s| subs.contains(s))
}

impl<T: Node + ?Sized> Node for Box<T> {
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
