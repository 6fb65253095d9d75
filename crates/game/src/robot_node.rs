//! A robot's intelligence as a part of the game: it hears its sensors and
//! its orders, and answers each sensor reading with wheels, actions and,
//! when it changes, its active behaviour.

use std::collections::{BTreeSet, VecDeque};

use colony_node::{Node, Time};
use colony_wire::{Packet, Priority, Subject};

use crate::protocol::{self, radio, Order, RadioCommand, Sense};
use crate::robot::Brain;
use crate::rules::RobotKind;

/// When one order reached the robot and when its brain first acted on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrderTiming {
    /// The order's sequence number.
    pub seq: u64,
    /// When it came.
    pub received: Time,
    /// The first tick of the brain that held it (the next sensor reading).
    pub acted: Option<Time>,
}

/// The orders of this many of the latest are timed.
const MAX_TIMED: usize = 4096;

/// One robot.
pub struct RobotNode {
    id: u32,
    brain: Brain,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
    timings: VecDeque<OrderTiming>,
}

impl RobotNode {
    /// Robot `id` of type `kind`.
    pub fn new(id: u32, kind: RobotKind) -> RobotNode {
        RobotNode {
            id,
            brain: Brain::new(id, kind),
            subs: protocol::subjects([protocol::sense_channel(id), protocol::robot_channel(id)]),
            outbox: VecDeque::new(),
            timings: VecDeque::new(),
        }
    }

    /// When the latest orders it took came and were first acted on.
    pub fn timings(&self) -> impl Iterator<Item = &OrderTiming> {
        self.timings.iter()
    }

    /// Its id.
    pub fn id(&self) -> u32 {
        self.id
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

    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
        if packet.has_subject(&protocol::robot_channel(self.id)) {
            match Order::decode(packet) {
                Ok(order) => {
                    let seq = order.seq;
                    if self.brain.order(order) {
                        if self.timings.len() == MAX_TIMED {
                            self.timings.pop_front();
                        }
                        self.timings.push_back(OrderTiming {
                            seq,
                            received: now,
                            acted: None,
                        });
                    }
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
        if let Some(t) = self.timings.back_mut() {
            t.acted.get_or_insert(now);
        }
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
