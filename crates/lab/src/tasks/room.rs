//! A room of robot bodies in the physics field, over the hub, for task
//! agents that drive one each (`colony tasks room`, then `colony tasks agent
//! --body N`): the room publishes every body on `vision` each control step
//! (the arena centred on the origin, as every colony world), and moves each
//! body by the newest wheel command for it on `radio` (commands hold for half
//! a second, and an operator's higher priority wins, as in the sorting
//! world). The agents see their own pose and everyone else's on `vision`.

use std::collections::{BTreeSet, VecDeque};
use std::time::Duration;

use colony_node::{Node, Time};
use colony_proto::radio::RADIO;
use colony_proto::swarm::{vision, Arena, Sizes, VisionFrame, VisionRobot};
use colony_proto::{CommandHold, Pose};
use colony_sim::field::{Field, FieldConfig, FieldRobotId};
use colony_sim::SimError;
use colony_wire::{Packet, Subject};

use crate::tasks::longterm::bodies::{open_room, pioneer, RADIUS};

/// The most bodies a room holds.
pub const MAX_BODIES: usize = 64;
/// A wheel command moves its body for this many control steps unless replaced.
const HOLD_STEPS: u64 = 5;

/// The room as a [`Node`]: feed it radio packets and time; it publishes vision.
pub struct Room {
    field: Field,
    ids: Vec<FieldRobotId>,
    hold: CommandHold,
    period: Duration,
    steps: u64,
    /// When the next control step is due.
    next: Time,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
}

impl Room {
    /// A square room `side_cm` across with `bodies` robots (at most
    /// [`MAX_BODIES`]) driving at up to `speed` cm/s, standing in a row along
    /// its middle; body `i` is robot `i` on `vision` and `radio`.
    pub fn new(side_cm: f64, bodies: usize, speed: f64) -> Result<Room, SimError> {
        if bodies == 0 || bodies > MAX_BODIES {
            return Err(SimError::Layout(format!(
                "a room holds 1 to {MAX_BODIES} bodies, not {bodies}"
            )));
        }
        let config = FieldConfig::default();
        let period = Duration::from_secs_f64(config.control_step);
        let mut field = open_room(side_cm, config)?;
        let spec = pioneer(speed);
        let size = field.map().size_cm();
        let gap = size.x / (bodies as f64 + 1.0);
        let ids = (0..bodies)
            .map(|i| {
                let pose = Pose {
                    x: gap * (i as f64 + 1.0),
                    y: size.y / 2.0,
                    theta: std::f64::consts::FRAC_PI_2,
                };
                field.add_robot(spec, pose)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let subs = [RADIO]
            .into_iter()
            .filter_map(|s| Subject::new(s).ok())
            .collect();
        Ok(Room {
            field,
            hold: CommandHold::new(ids.len(), HOLD_STEPS),
            ids,
            period,
            steps: 0,
            next: Time::ZERO,
            subs,
            outbox: VecDeque::new(),
        })
    }

    /// Body `i`'s pose, in the frame `vision` uses (the room centred on the origin).
    pub fn pose(&self, i: usize) -> Option<Pose> {
        let p = self.field.robot_pose(*self.ids.get(i)?)?;
        Some(self.field.centred(p))
    }

    fn frame(&self) -> VisionFrame {
        let size = self.field.map().size_cm();
        VisionFrame {
            step: self.steps,
            arena: Some(Arena {
                width: size.x,
                height: size.y,
                corner: 0.0,
            }),
            sizes: Some(Sizes {
                robot_length: 2.0 * RADIUS,
                robot_width: 2.0 * RADIUS,
                gripper_radius: 3.0,
                puck_diameter: 5.0,
            }),
            robots: (0..self.ids.len())
                .filter_map(|i| {
                    self.pose(i).map(|pose| VisionRobot {
                        id: i as u32,
                        pose,
                        carrying: None,
                    })
                })
                .collect(),
            ..VisionFrame::default()
        }
    }

    fn step(&mut self) {
        let commands = self.hold.for_step(self.steps);
        self.field.step(&commands);
        self.steps += 1;
        match vision::encode(&self.frame()) {
            Ok(parts) => self.outbox.extend(parts),
            Err(e) => tracing::warn!(error = %e, "cannot write the room's vision"),
        }
    }
}

impl Node for Room {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, _: Time, packet: &Packet<'_>) {
        if !packet.has_subject(RADIO) {
            return;
        }
        if let Err(e) = self.hold.offer_radio(packet, self.steps) {
            tracing::debug!(error = %e, "ignored a bad radio packet");
        }
    }

    fn handle_timeout(&mut self, now: Time) {
        // Catch up on a few missed steps; after a longer stall (a suspended
        // process) the backlog is dropped, not replayed at full speed.
        for _ in 0..10 {
            if self.next > now {
                return;
            }
            self.step();
            self.next = self.next + self.period;
        }
        if self.next <= now {
            self.next = now + self.period;
        }
    }

    fn poll_timeout(&self) -> Option<Time> {
        Some(self.next)
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}

/// Runs `room` against the hub at `hub`, in real time, until `stop` is set.
pub fn serve(
    room: &mut Room,
    hub: std::net::SocketAddr,
    stop: &std::sync::atomic::AtomicBool,
) -> Result<(), colony_node::LiveError> {
    let mut link = colony_node::Link::new(
        colony_client::UdpClient::connect(hub)?,
        std::time::Instant::now(),
    );
    colony_node::run(room, &mut link, stop, |_, _| {
        std::ops::ControlFlow::Continue(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_proto::radio::{self, RadioCommand};
    use colony_wire::Priority;

    #[test]
    fn bodies_move_by_their_radio_commands_and_are_seen_on_vision() {
        let mut room = Room::new(600.0, 2, 30.0).unwrap();
        let start = room.pose(0).unwrap();
        assert!(start.x < 0.0 && room.pose(1).unwrap().x > 0.0);
        let cmd = radio::encode(&[RadioCommand::new(0, 1.0, 0.0)], Priority(0)).unwrap();
        let mut t = Time::ZERO;
        for _ in 0..20 {
            room.handle_packet(t, &Packet::parse(&cmd).unwrap());
            room.handle_timeout(t);
            t = t + Duration::from_millis(100);
        }
        let moved = room.pose(0).unwrap();
        assert!(moved.y > start.y + 30.0, "{start:?} -> {moved:?}");
        assert_eq!(room.pose(1).unwrap().y, 0.0, "robot 1 had no command");
        let last = std::iter::from_fn(|| room.poll_transmit()).last().unwrap();
        let frame = vision::decode(&Packet::parse(&last).unwrap())
            .unwrap()
            .frame;
        assert_eq!(frame.robots.len(), 2);
        assert!((frame.robots[0].pose.y - moved.y).abs() < 0.01);
    }

    #[test]
    fn a_long_stall_is_not_replayed() {
        let mut room = Room::new(600.0, 1, 30.0).unwrap();
        let later = Time::ZERO + Duration::from_secs(3600);
        room.handle_timeout(later);
        assert_eq!(std::iter::from_fn(|| room.poll_transmit()).count(), 10);
        assert_eq!(
            room.poll_timeout(),
            Some(later + Duration::from_millis(100))
        );
    }

    #[test]
    fn an_impossible_room_is_refused() {
        assert!(Room::new(600.0, 0, 30.0).is_err());
        assert!(Room::new(600.0, MAX_BODIES + 1, 30.0).is_err());
        assert!(
            Room::new(100.0, 8, 30.0).is_err(),
            "no room for 8 Pioneers in 1 m"
        );
    }
}
