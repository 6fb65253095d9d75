//! Observations, wheel commands and intentions as hub packets.
//!
//! ```text
//! @ <camera.2> 0                       what robot 2's sensors report
//! step n 1200
//! pose x 12.5 y -40.1 theta 1.57
//! gripper kind 0 x 8.1 y 0.0
//! puck kind 1 x 20.3 y -4.0 held 0
//! robot x 30.0 y 10.0
//! obstacle x 35.0 y -12.0
//!
//! @ <radio> 0                          a controller's command for robot 2
//! cmd id 2 forward 0.8 turn -0.25
//!
//! @ <debug> 0                          what robot 2 intends (for the monitor)
//! robot id 2 state "HOMING" tx 40.0 ty 20.0
//! cache id 2 kind 0 x 40.0 y 20.0
//!
//! @ <vision> 20                        the whole world (split into parts for big swarms)
//! step n 1200 part 0 parts 1
//! arena width 187 height 187 corner 15  (first part only: the walls and body sizes, cm)
//! sizes robot_length 12.5 robot_width 10.8 gripper_radius 3.6 puck_diameter 6.3
//! robot id 0 x 12.5 y -40.1 theta 1.57 carrying 7
//! puck id 7 kind 0 x 20.0 y -38.0
//!
//! @ <metrics> 0                        sorting progress
//! sort step 1200 pc 87.5
//! ```
//!
//! A `cmd` of higher priority (an operator's) holds its robot until it
//! lapses; see [`super::world::Commands`].

use colony_sim::{Observation, Pose, PuckKind, SeenPuck, Vec2, WheelCommand};
use colony_wire::{Packet, PacketBuilder, ParseError, Priority};

/// The channel a robot's camera view is published on.
pub fn camera_channel(robot: usize) -> String {
    format!("camera.{robot}")
}

/// The channel wheel commands travel on, as in the Broker paper's system.
pub const RADIO: &str = "radio";
/// The channel the world's global state is published on.
pub const VISION: &str = "vision";
/// The channel controllers publish their intentions on, for the monitor.
pub const DEBUG: &str = "debug";
/// The channel the world publishes sorting progress on.
pub const METRICS: &str = "metrics";

/// Sorting progress at `step`: `sort step N pc X`.
pub fn metrics_packet(step: u64, pc: f64) -> Result<Vec<u8>, ParseError> {
    let mut p = PacketBuilder::new([METRICS], Priority(0));
    p.line("sort").field("step", step).field("pc", r(pc));
    p.finish()
}

/// Rounds to 0.01 cm or rad: finer than any sensor, and keeps packets short.
fn r(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

/// Writes one robot's observation at control step `step`.
pub fn observation_packet(
    robot: usize,
    step: u64,
    obs: &Observation,
) -> Result<Vec<u8>, ParseError> {
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
            .field("held", s.held_by_other as u8);
    }
    for v in &obs.robots {
        p.line("robot").field("x", r(v.x)).field("y", r(v.y));
    }
    for v in &obs.obstacles {
        p.line("obstacle").field("x", r(v.x)).field("y", r(v.y));
    }
    p.finish()
}

/// A packet's content did not make sense as what it claimed to be.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    #[error(transparent)]
    Field(#[from] colony_wire::FieldError),
    #[error("line {line}: {what} {value} is out of range")]
    OutOfRange {
        line: u32,
        what: &'static str,
        value: i64,
    },
    #[error("the packet has no `{0}` line")]
    Missing(&'static str),
}

fn kind(line: &colony_wire::Line<'_>) -> Result<PuckKind, DecodeError> {
    let k = line.i64("kind")?;
    u8::try_from(k)
        .map(PuckKind)
        .map_err(|_| DecodeError::OutOfRange {
            line: line.number(),
            what: "kind",
            value: k,
        })
}

fn point(line: &colony_wire::Line<'_>) -> Result<Vec2, DecodeError> {
    Ok(Vec2::new(line.f64("x")?, line.f64("y")?))
}

/// Reads an observation packet back: `(step, observation)`.
pub fn parse_observation(packet: &Packet<'_>) -> Result<(u64, Observation), DecodeError> {
    let mut obs = Observation::default();
    let mut step = None;
    for line in packet.lines() {
        match line.label() {
            "step" => step = Some(line.i64("n")?.max(0) as u64),
            "pose" => {
                obs.pose = Pose {
                    x: line.f64("x")?,
                    y: line.f64("y")?,
                    theta: line.f64("theta")?,
                }
            }
            "gripper" => {
                obs.gripper = Some(SeenPuck {
                    kind: kind(&line)?,
                    pos: point(&line)?,
                    held_by_other: false,
                })
            }
            "puck" => obs.pucks.push(SeenPuck {
                kind: kind(&line)?,
                pos: point(&line)?,
                held_by_other: line.i64("held")? != 0,
            }),
            "robot" => obs.robots.push(point(&line)?),
            "obstacle" => obs.obstacles.push(point(&line)?),
            _ => {}
        }
    }
    Ok((step.ok_or(DecodeError::Missing("step"))?, obs))
}

/// A wheel command for one robot.
pub fn command_packet(
    robot: usize,
    cmd: WheelCommand,
    priority: Priority,
) -> Result<Vec<u8>, ParseError> {
    let mut p = PacketBuilder::new([RADIO], priority);
    p.line("cmd")
        .field("id", robot)
        .field("forward", r(cmd.forward))
        .field("turn", r(cmd.turn));
    p.finish()
}

/// Every `cmd` line of a radio packet, as `(robot, command)`; values are clamped to [-1, 1].
pub fn parse_commands(packet: &Packet<'_>) -> Result<Vec<(usize, WheelCommand)>, DecodeError> {
    packet
        .lines_labelled("cmd")
        .map(|line| {
            let id = line.i64("id")?;
            let id = usize::try_from(id).map_err(|_| DecodeError::OutOfRange {
                line: line.number(),
                what: "id",
                value: id,
            })?;
            let clamp = |v: f64| {
                if v.is_finite() {
                    v.clamp(-1.0, 1.0)
                } else {
                    0.0
                }
            };
            Ok((
                id,
                WheelCommand {
                    forward: clamp(line.f64("forward")?),
                    turn: clamp(line.f64("turn")?),
                },
            ))
        })
        .collect()
}

/// What a controller intends, for the monitor's superimposed graphics.
pub fn debug_packet(
    robot: usize,
    state: &str,
    target: Option<Vec2>,
    caches: &[(PuckKind, Vec2)],
) -> Result<Vec<u8>, ParseError> {
    let mut p = PacketBuilder::new([DEBUG], Priority(0));
    {
        let mut l = p.line("robot");
        l.field("id", robot).field("state", state);
        if let Some(t) = target {
            l.field("tx", r(t.x)).field("ty", r(t.y));
        }
    }
    for (k, c) in caches {
        p.line("cache")
            .field("id", robot)
            .field("kind", k.0)
            .field("x", r(c.x))
            .field("y", r(c.y));
    }
    p.finish()
}

/// Largest vision part we write: well inside one datagram.
const VISION_PART_BUDGET: usize = 60_000;

/// The priority of `vision`: above any controller's or operator's, so that
/// an operator raising the hub's minimum priority to silence the controllers
/// (the Broker paper's override) still sees the world.
pub const VISION_PRIORITY: Priority = Priority(20);

/// The world's global state for one step, as an overhead camera would
/// publish it: one packet, or several when a large swarm would not fit in a
/// datagram. Each part starts `step n N part I parts P` and stands alone; the
/// first also gives the arena's size (`arena width W height H corner R`) and
/// the bodies' (`sizes robot_length L robot_width W gripper_radius G puck_diameter D`), so a
/// monitor can draw to scale.
pub fn vision_packets(
    step: u64,
    scene: &colony_sim::SceneConfig,
    robots: &[colony_sim::RobotState],
    pucks: &[colony_sim::Puck],
) -> Result<Vec<Vec<u8>>, ParseError> {
    let mut lines: Vec<String> = Vec::with_capacity(robots.len() + pucks.len() + 2);
    lines.push(format!(
        "arena width {} height {} corner {}",
        r(scene.arena.width),
        r(scene.arena.height),
        r(scene.arena.corner_radius)
    ));
    lines.push(format!(
        "sizes robot_length {} robot_width {} gripper_radius {} puck_diameter {}",
        r(scene.robots.length),
        r(scene.robots.width),
        r(scene.robots.gripper_radius),
        r(scene.pucks.diameter)
    ));
    for rb in robots {
        let mut l = format!(
            "robot id {} x {} y {} theta {}",
            rb.id.0,
            r(rb.pose.x),
            r(rb.pose.y),
            r(rb.pose.theta)
        );
        if let Some(c) = rb.carrying {
            l.push_str(&format!(" carrying {}", c.0));
        }
        lines.push(l);
    }
    for pk in pucks {
        lines.push(format!(
            "puck id {} kind {} x {} y {}",
            pk.id.0,
            pk.kind.0,
            r(pk.pos.x),
            r(pk.pos.y)
        ));
    }
    let mut chunks: Vec<Vec<&str>> = vec![Vec::new()];
    let mut size = 0;
    for l in &lines {
        if size + l.len() + 1 > VISION_PART_BUDGET && !chunks.last().is_some_and(Vec::is_empty) {
            chunks.push(Vec::new());
            size = 0;
        }
        size += l.len() + 1;
        chunks.last_mut().expect("one chunk at least").push(l);
    }
    let parts = chunks.len();
    chunks
        .iter()
        .enumerate()
        .map(|(i, chunk)| {
            let mut p = PacketBuilder::new([VISION], VISION_PRIORITY);
            p.line("step")
                .field("n", step)
                .field("part", i)
                .field("parts", parts);
            for l in chunk {
                p.raw_line(l);
            }
            p.finish()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_observation_survives_the_trip_through_a_packet() {
        let obs = Observation {
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
        };
        let bytes = observation_packet(2, 1200, &obs).unwrap();
        let packet = Packet::parse(&bytes).unwrap();
        assert!(packet.has_subject("camera.2"));
        assert_eq!(parse_observation(&packet).unwrap(), (1200, obs));
    }

    #[test]
    fn commands_are_clamped_and_bad_ids_are_errors() {
        let p = Packet::parse(
            b"@ <radio> 5\ncmd id 1 forward 3 turn -0.5\ncmd id 2 forward 0.1 turn nan\n",
        )
        .unwrap();
        let cmds = parse_commands(&p).unwrap();
        assert_eq!(
            cmds[0],
            (
                1,
                WheelCommand {
                    forward: 1.0,
                    turn: -0.5
                }
            )
        );
        assert_eq!(
            cmds[1],
            (
                2,
                WheelCommand {
                    forward: 0.1,
                    turn: 0.0
                }
            )
        );
        let bad = Packet::parse(b"@ <radio> 0\ncmd id -1 forward 0 turn 0\n").unwrap();
        assert!(parse_commands(&bad)
            .unwrap_err()
            .to_string()
            .contains("id -1"));
        let missing = Packet::parse(b"@ <radio> 0\ncmd id 1 forward 0\n").unwrap();
        assert!(parse_commands(&missing)
            .unwrap_err()
            .to_string()
            .contains("turn"));
    }

    #[test]
    fn a_large_swarm_is_split_into_parts_that_each_fit_a_datagram() {
        let robots: Vec<colony_sim::RobotState> = (0..256)
            .map(|i| colony_sim::RobotState {
                id: colony_sim::RobotId(i),
                pose: Pose {
                    x: 1.5,
                    y: -2.5,
                    theta: 0.25,
                },
                carrying: None,
            })
            .collect();
        let pucks: Vec<colony_sim::Puck> = (0..2560)
            .map(|i| colony_sim::Puck {
                id: colony_sim::PuckId(i),
                kind: PuckKind((i % 8) as u8),
                pos: Vec2::new(-123.45, 67.89),
            })
            .collect();
        let scene = colony_sim::SceneConfig::scaled(256);
        let parts = vision_packets(9, &scene, &robots, &pucks).unwrap();
        assert!(parts.len() >= 2);
        let (mut robots_seen, mut pucks_seen) = (0, 0);
        for (i, bytes) in parts.iter().enumerate() {
            assert!(bytes.len() <= colony_wire::MAX_PACKET);
            let p = Packet::parse(bytes).unwrap();
            let step = p.line("step").unwrap();
            assert_eq!(
                (
                    step.i64("n").unwrap(),
                    step.i64("part").unwrap(),
                    step.i64("parts").unwrap()
                ),
                (9, i as i64, parts.len() as i64)
            );
            robots_seen += p.lines_labelled("robot").count();
            pucks_seen += p.lines_labelled("puck").count();
        }
        assert_eq!((robots_seen, pucks_seen), (256, 2560));
        let first = Packet::parse(&parts[0]).unwrap();
        let arena = first.line("arena").unwrap();
        assert_eq!(
            arena.f64("width").unwrap(),
            (scene.arena.width * 100.0).round() / 100.0
        );
        assert_eq!(arena.f64("corner").unwrap(), 15.0);
        assert!(first.line("sizes").is_some());
        assert_eq!(first.priority(), VISION_PRIORITY);
    }

    #[test]
    fn a_command_round_trips() {
        let bytes = command_packet(
            3,
            WheelCommand {
                forward: 0.5,
                turn: -0.25,
            },
            Priority(0),
        )
        .unwrap();
        let p = Packet::parse(&bytes).unwrap();
        assert_eq!(
            parse_commands(&p).unwrap(),
            [(
                3,
                WheelCommand {
                    forward: 0.5,
                    turn: -0.25
                }
            )]
        );
    }
}
