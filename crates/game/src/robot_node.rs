//! A robot's intelligence as a part of the game: it hears its sensors and
//! its orders, and answers each sensor reading with wheels, actions and,
//! when it changes, its active behaviour.

use std::collections::{BTreeSet, VecDeque};

use colony_node::{Node, Time};
use colony_wire::{Packet, Priority, Subject};

use crate::protocol::{self, radio, Order, RadioCommand, Sense};
use crate::robot::Brain;
use crate::rules::RobotKind;

/// One robot.
pub struct RobotNode {
    id: u32,
    brain: Brain,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
}

impl RobotNode {
    /// Robot `id` of type `kind`.
    pub fn new(id: u32, kind: RobotKind) -> RobotNode {
        RobotNode {
            id,
            brain: Brain::new(id, kind),
            subs: protocol::subjects([protocol::sense_channel(id), protocol::robot_channel(id)]),
            outbox: VecDeque::new(),
        }
    }

    /// Its brain.
    pub fn brain(&self) -> &Brain {
        &self.brain
    }
}

/// It has no timer: its brain ticks on its sensor packets.
impl Node for RobotNode {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, _now: Time, packet: &Packet<'_>) {
        if packet.has_subject(&protocol::robot_channel(self.id)) {
            match Order::decode(packet) {
                Ok(order) => {
                    self.brain.order(order);
                }
                Err(e) => tracing::debug!(robot = self.id, error = %e, "ignored a bad order"),
            }
            return;
        }
        let sense = match Sense::decode(packet) {
            Ok(s) => s,
            Err(e) => {
                tracing::debug!(robot = self.id, error = %e, "ignored a bad sensor packet");
                return;
            }
        };
        let tick = self.brain.tick(sense);
        let wheels = RadioCommand::new(self.id, tick.wheels.0, tick.wheels.1);
        let packets = std::iter::once(radio::encode(&[wheels], Priority(0)))
            .chain(tick.actions.iter().map(|a| a.encode()))
            .chain(tick.debug.iter().map(|d| d.encode()));
        for p in packets {
            match p {
                Ok(p) => self.outbox.push_back(p),
                Err(e) => tracing::warn!(robot = self.id, error = %e, "could not write a packet"),
            }
        }
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}
