//! `game.world`: every robot's pose after a step of the world, for the game logic.
//!
//! ```text
//! @ <game.world> 0
//! step n 120 time 12
//! robot id 3 x 310.5 y 88.2 theta 1.57 active 1
//! ```

use colony_wire::{Packet, PacketBuilder, ParseError, Priority};

use super::WORLD;
use crate::fields::{b, coord, count, finite, flag, r, robot_id};
use crate::table::{int, line, num, MessageTable};
use crate::{DecodeError, Pose};

/// What a world frame holds.
pub const TABLE: MessageTable = MessageTable {
    channel: WORLD,
    lines: &[
        line("step", &[int("n"), num("time")]),
        line(
            "robot",
            &[int("id"), num("x"), num("y"), num("theta"), int("active")],
        ),
    ],
};

/// One robot in a world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotPose {
    /// Its id.
    pub id: u32,
    /// Where it is.
    pub pose: Pose,
    /// Still in the world (not destroyed).
    pub active: bool,
}

/// Every robot's pose after one step of the world.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WorldFrame {
    /// The world's step.
    pub step: u64,
    /// Game time, s.
    pub time: f64,
    /// The robots.
    pub robots: Vec<RobotPose>,
}

impl WorldFrame {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([WORLD], Priority(0));
        p.line("step")
            .field("n", self.step)
            .field("time", r(self.time));
        for rb in &self.robots {
            p.line("robot")
                .field("id", rb.id)
                .field("x", r(rb.pose.x))
                .field("y", r(rb.pose.y))
                .field("theta", r(rb.pose.theta))
                .field("active", b(rb.active));
        }
        p.finish()
    }

    /// Reads a world frame.
    pub fn decode(packet: &Packet<'_>) -> Result<WorldFrame, DecodeError> {
        let l = packet.line("step").ok_or(DecodeError::Missing("step"))?;
        let step = count(&l, "n")?;
        let time = finite(&l, "time")?;
        let robots = packet
            .lines_labelled("robot")
            .map(|l| {
                Ok(RobotPose {
                    id: robot_id(&l, "id")?,
                    pose: Pose {
                        x: coord(&l, "x")?,
                        y: coord(&l, "y")?,
                        theta: finite(&l, "theta")?,
                    },
                    active: flag(&l, "active")?,
                })
            })
            .collect::<Result<_, DecodeError>>()?;
        Ok(WorldFrame { step, time, robots })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_world_frame_survives_the_trip() {
        let w = WorldFrame {
            step: 7,
            time: 0.7,
            robots: vec![
                RobotPose {
                    id: 0,
                    pose: Pose {
                        x: 1.0,
                        y: -2.5,
                        theta: 3.1,
                    },
                    active: true,
                },
                RobotPose {
                    id: 9,
                    pose: Pose::default(),
                    active: false,
                },
            ],
        };
        let bytes = w.encode().unwrap();
        assert_eq!(
            WorldFrame::decode(&Packet::parse(&bytes).unwrap()).unwrap(),
            w
        );
        let p = b"@ <game.world> 0\nstep n 1 time 0\nrobot id 1 x 0 y 0 theta 0 active 2\n";
        assert!(WorldFrame::decode(&Packet::parse(p).unwrap()).is_err());
        crate::table::check::codec(&TABLE, &[bytes], |p| WorldFrame::decode(p).is_ok());
    }
}
