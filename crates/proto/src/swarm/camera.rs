//! `camera.N`: what robot N's sensors report after a control step, for its controller.
//!
//! ```text
//! @ <camera.2> 0
//! step n 1200
//! pose x 12.5 y -40.1 theta 1.57
//! gripper kind 0 x 8.1 y 0.0
//! puck kind 1 x 20.3 y -4.0 held 0
//! robot x 30.0 y 10.0
//! obstacle x 35.0 y -12.0
//! ```
//!
//! Only a node reads this channel, so it has only the strict decoder.

use colony_wire::{Packet, PacketBuilder, ParseError, Priority};

use super::{puck_kind, PuckKind};
use crate::error::LinePolicy;
use crate::fields::{coord, count, finite, flag, r};
use crate::table::{int, line, num, MessageTable};
use crate::{DecodeError, Pose, Vec2};

/// A puck the forward camera sees, in the robot frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeenPuck {
    /// Its type (colour).
    pub kind: PuckKind,
    /// Its centre in the robot frame, cm.
    pub pos: Vec2,
    /// It lies in another robot's gripper (the paper's perception drops such pucks).
    pub held_by_other: bool,
}

/// What one robot's sensors report after a step; everything but `pose` is in the robot frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Observation {
    /// The pose a localisation system (overhead tracker) reports, in the world frame.
    pub pose: Pose,
    /// The puck in this robot's own gripper, at the gripper's position.
    pub gripper: Option<SeenPuck>,
    /// Pucks inside the camera's ground footprint, the carried one excluded.
    pub pucks: Vec<SeenPuck>,
    /// Centres of other robots inside the footprint.
    pub robots: Vec<Vec2>,
    /// Points on walls and on other robots' bodies inside the footprint,
    /// about 1 cm apart: the occupancy grid's obstacle cells.
    pub obstacles: Vec<Vec2>,
}

/// One `camera.N` packet: the control step it was taken at and what the robot senses.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CameraView {
    /// The world's control step.
    pub step: u64,
    /// What the robot senses.
    pub observation: Observation,
}

/// The channel robot `robot`'s camera view is published on.
pub fn camera_channel(robot: u32) -> String {
    format!("camera.{robot}")
}

/// What a camera view holds, on every `camera.N`.
pub const TABLE: MessageTable = MessageTable {
    channel: "camera.",
    lines: &[
        line("step", &[int("n")]),
        line("pose", &[num("x"), num("y"), num("theta")]),
        line("gripper", &[int("kind"), num("x"), num("y")]),
        line("puck", &[int("kind"), num("x"), num("y"), int("held")]),
        line("robot", &[num("x"), num("y")]),
        line("obstacle", &[num("x"), num("y")]),
    ],
};

/// Robot `robot`'s observation at control step `step`, on [`camera_channel`]`(robot)`.
pub fn encode(robot: u32, step: u64, obs: &Observation) -> Result<Vec<u8>, ParseError> {
    let mut p = PacketBuilder::new([camera_channel(robot)], Priority(0));
    p.line("step").field("n", step);
    p.line("pose")
        .field("x", r(obs.pose.x))
        .field("y", r(obs.pose.y))
        .field("theta", r(obs.pose.theta));
    if let Some(g) = &obs.gripper {
        p.line("gripper")
            .field("kind", g.kind.0)
            .field("x", r(g.pos.x))
            .field("y", r(g.pos.y));
    }
    for s in &obs.pucks {
        p.line("puck")
            .field("kind", s.kind.0)
            .field("x", r(s.pos.x))
            .field("y", r(s.pos.y))
            .field("held", u8::from(s.held_by_other));
    }
    for v in &obs.robots {
        p.line("robot").field("x", r(v.x)).field("y", r(v.y));
    }
    for v in &obs.obstacles {
        p.line("obstacle").field("x", r(v.x)).field("y", r(v.y));
    }
    p.finish()
}

/// Reads a camera packet back; any bad line, or no `step` line, refuses the packet (a robot
/// should not act on half an observation).
pub fn decode(packet: &Packet<'_>) -> Result<CameraView, DecodeError> {
    let mut policy = LinePolicy::strict();
    let mut obs = Observation::default();
    let mut step = None;
    for line in packet.lines() {
        let point = |line| -> Result<Vec2, DecodeError> {
            Ok(Vec2::new(coord(line, "x")?, coord(line, "y")?))
        };
        let seen = |line, held: bool| -> Result<SeenPuck, DecodeError> {
            Ok(SeenPuck {
                kind: puck_kind(line, "kind")?,
                pos: point(line)?,
                held_by_other: held,
            })
        };
        match line.label() {
            "step" => step = policy.take(count(&line, "n"))?,
            "pose" => {
                let pose = (|| {
                    Ok(Pose {
                        x: coord(&line, "x")?,
                        y: coord(&line, "y")?,
                        theta: finite(&line, "theta")?,
                    })
                })();
                if let Some(pose) = policy.take(pose)? {
                    obs.pose = pose;
                }
            }
            "gripper" => obs.gripper = policy.take(seen(&line, false))?,
            "puck" => {
                let puck = flag(&line, "held").and_then(|held| seen(&line, held));
                obs.pucks.extend(policy.take(puck)?);
            }
            "robot" => obs.robots.extend(policy.take(point(&line))?),
            "obstacle" => obs.obstacles.extend(policy.take(point(&line))?),
            _ => {}
        }
    }
    Ok(CameraView {
        step: step.ok_or(DecodeError::Missing("step"))?,
        observation: obs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn observation() -> Observation {
        Observation {
            pose: Pose {
                x: 12.5,
                y: -40.1,
                theta: 1.57,
            },
            gripper: Some(SeenPuck {
                kind: PuckKind(0),
                pos: Vec2::new(8.1, 0.0),
                held_by_other: false,
            }),
            pucks: vec![SeenPuck {
                kind: PuckKind(1),
                pos: Vec2::new(20.3, -4.0),
                held_by_other: true,
            }],
            robots: vec![Vec2::new(30.0, 10.0)],
            obstacles: vec![Vec2::new(35.0, -12.0), Vec2::new(35.0, -11.0)],
        }
    }

    #[test]
    fn an_observation_survives_the_trip_through_a_packet() {
        let obs = observation();
        let bytes = encode(2, 1200, &obs).unwrap();
        let packet = Packet::parse(&bytes).unwrap();
        assert!(packet.has_subject("camera.2"));
        assert_eq!(
            decode(&packet).unwrap(),
            CameraView {
                step: 1200,
                observation: obs
            }
        );
    }

    #[test]
    fn the_packet_reads_as_the_format_says() {
        let bytes = encode(2, 1200, &observation()).unwrap();
        assert_eq!(
            std::str::from_utf8(&bytes).unwrap(),
            "@ <camera.2> 0\nstep n 1200\npose x 12.5 y -40.1 theta 1.57\n\
             gripper kind 0 x 8.1 y 0.0\npuck kind 1 x 20.3 y -4.0 held 1\n\
             robot x 30.0 y 10.0\nobstacle x 35.0 y -12.0\nobstacle x 35.0 y -11.0\n"
        );
    }

    #[test]
    fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
        let bytes = encode(2, 1200, &observation()).unwrap();
        crate::table::check::codec(&TABLE, &[bytes], |p| decode(p).is_ok());
    }

    #[test]
    fn one_bad_line_refuses_the_whole_observation() {
        for text in [
            "@ <camera.1> 0\nstep n 3\nrobot x nan y 0\n",
            "@ <camera.1> 0\nstep n 3\npuck kind 300 x 0 y 0 held 0\n",
            "@ <camera.1> 0\nstep n 3\npuck kind 1 x 0 y 0 held 2\n",
            "@ <camera.1> 0\nstep n -3\n",
            "@ <camera.1> 0\npose x 0 y 0 theta 0\n",
            "@ <camera.1> 0\nstep n 3\npose x 0 y 0 theta inf\n",
        ] {
            let p = Packet::parse(text.as_bytes()).unwrap();
            assert!(decode(&p).is_err(), "{text:?} was accepted");
        }
    }

    proptest! {
        #[test]
        fn any_observation_round_trips_within_rounding(
            step in any::<u32>(),
            x in -1e4f64..1e4, y in -1e4f64..1e4, theta in -7.0f64..7.0,
            pucks in proptest::collection::vec((any::<u8>(), -500.0f64..500.0, -500.0f64..500.0, any::<bool>()), 0..8),
        ) {
            let obs = Observation {
                pose: Pose { x, y, theta },
                gripper: None,
                pucks: pucks.iter().map(|&(k, x, y, h)| SeenPuck { kind: PuckKind(k), pos: Vec2::new(x, y), held_by_other: h }).collect(),
                robots: vec![],
                obstacles: vec![Vec2::new(x / 3.0, y)],
            };
            let bytes = encode(7, u64::from(step), &obs).unwrap();
            let got = decode(&Packet::parse(&bytes).unwrap()).unwrap();
            prop_assert_eq!(got.step, u64::from(step));
            let o = got.observation;
            prop_assert!((o.pose.x - x).abs() <= 0.005 + 1e-9 && (o.pose.theta - theta).abs() <= 0.005 + 1e-9);
            prop_assert_eq!(o.pucks.len(), obs.pucks.len());
            for (a, b) in o.pucks.iter().zip(&obs.pucks) {
                prop_assert_eq!((a.kind, a.held_by_other), (b.kind, b.held_by_other));
                prop_assert!(a.pos.distance(b.pos) <= 0.01);
            }
        }

        #[test]
        fn any_text_decodes_or_is_refused_without_a_panic(body in "[a-z0-9 .\\-\\n]{0,200}") {
            let text = format!("@ <camera.0> 0\n{body}\n");
            if let Ok(p) = Packet::parse(text.as_bytes()) {
                let _ = decode(&p);
            }
        }
    }
}
