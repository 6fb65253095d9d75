//! A robot's intelligence as a part of the game: it hears its sensors and
//! its orders, and answers each sensor reading with wheels, actions and,
//! when it changes, its active behaviour.

use colony_wire::{Packet, Priority};

use crate::node::Node;
use crate::protocol::{self, radio, Order, RadioCommand, Sense};
use crate::robot::Brain;
use crate::rules::RobotKind;

/// One robot.
pub struct RobotNode {
    id: u32,
    brain: Brain,
}

impl RobotNode {
    /// Robot `id` of type `kind`.
    pub fn new(id: u32, kind: RobotKind) -> RobotNode {
        RobotNode {
            id,
            brain: Brain::new(id, kind),
        }
    }

    /// Its brain.
    pub fn brain(&self) -> &Brain {
        &self.brain
    }
}

impl Node for RobotNode {
    fn subscriptions(&self) -> Vec<String> {
        vec![
            protocol::sense_channel(self.id),
            protocol::robot_channel(self.id),
        ]
    }

    fn handle(&mut self, packet: &Packet<'_>, out: &mut Vec<Vec<u8>>) {
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
                Ok(p) => out.push(p),
                Err(e) => tracing::warn!(robot = self.id, error = %e, "could not write a packet"),
            }
        }
    }
}
