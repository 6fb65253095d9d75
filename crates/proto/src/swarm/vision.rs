//! `vision`: the whole world at one control step, as an overhead camera would publish it.
//!
//! ```text
//! @ <vision> 20
//! step n 1200 part 0 parts 1
//! arena width 187 height 187 corner 15
//! sizes robot_length 12.5 robot_width 10.8 gripper_radius 3.6 puck_diameter 6.3
//! robot id 0 x 12.5 y -40.1 theta 1.57 carrying 7
//! puck id 7 kind 0 x 20 y -38
//! box id 0 x 10 y -170 theta 0.1 length 60 width 8
//! goal x 10 y 100
//! ```
//!
//! `box` (a body robots push, drawn to scale) and `goal` (where something is to go) are for
//! worlds other than the sorting arena, such as MURDOCH's box pushing; older readers skip them.
//!
//! A large swarm does not fit in one datagram, so [`encode`] splits a [`VisionFrame`] into
//! parts of at most [`PART_BUDGET`] bytes. Each part starts `step n N part I parts P` and stands
//! alone; the first also gives the arena (`arena`: a rectangle with rounded corners centred on the
//! origin) and the bodies' sizes (`sizes`), so a viewer can draw to scale. A reader puts the parts
//! of one step back together with a [`VisionAssembler`](super::VisionAssembler). A one-part frame
//! may leave out `part` and `parts`.
//!
//! The packet goes at [`PRIORITY`]: above any controller's or operator's, so that an operator
//! raising the hub's minimum priority to silence the controllers (the Broker paper's override)
//! still sees the world.

use std::fmt::Write;

use colony_wire::{Packet, PacketBuilder, ParseError, Priority};

use super::{puck_kind, PuckKind};
use crate::error::{LinePolicy, Skimmed};
use crate::fields::{bad, coord, count, finite, puck_id, push_r, r, robot_id, within, MAX_COORD};
use crate::table::{int, line, num, MessageTable};
use crate::{DecodeError, Pose, Vec2};

/// The channel the world's global state is published on.
pub const VISION: &str = "vision";

/// The priority `vision` goes at.
pub const PRIORITY: Priority = Priority(20);

/// What a vision part holds.
pub const TABLE: MessageTable = MessageTable {
    channel: VISION,
    lines: &[
        line(
            "step",
            &[int("n"), int("part").optional(), int("parts").optional()],
        ),
        line("arena", &[num("width"), num("height"), num("corner")]),
        line(
            "sizes",
            &[
                num("robot_length"),
                num("robot_width"),
                num("gripper_radius").optional(),
                num("puck_diameter"),
            ],
        ),
        line(
            "robot",
            &[
                int("id"),
                num("x"),
                num("y"),
                num("theta"),
                int("carrying").optional(),
            ],
        ),
        line("puck", &[int("id"), int("kind"), num("x"), num("y")]),
        line(
            "box",
            &[
                int("id"),
                num("x"),
                num("y"),
                num("theta"),
                num("length"),
                num("width"),
            ],
        ),
        line("goal", &[num("x"), num("y")]),
    ],
};

/// The largest vision part written, in bytes: well inside one datagram.
pub const PART_BUDGET: usize = 60_000;

/// The most parts one frame may be split into; a part claiming more is refused.
pub const MAX_PARTS: u32 = 4096;

/// Body sizes are below this (cm); a larger one is refused.
const MAX_SIZE: f64 = 1000.0;

/// The gripper's radius as a fraction of the puck's diameter, for writers that leave it out.
const GRIPPER_PER_PUCK: f64 = 0.57;

/// The arena's walls: a rectangle with rounded corners centred on the origin (cm).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Arena {
    /// Side along x, cm.
    pub width: f64,
    /// Side along y, cm.
    pub height: f64,
    /// Corner radius, cm.
    pub corner: f64,
}

/// Body sizes, so a viewer draws to scale (cm).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Sizes {
    /// A robot's body, front to back.
    pub robot_length: f64,
    /// A robot's body, side to side.
    pub robot_width: f64,
    /// The gripper's pocket: its centre is this far ahead of the body's front.
    pub gripper_radius: f64,
    /// A puck's diameter.
    pub puck_diameter: f64,
}

/// One robot as the overhead camera sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisionRobot {
    /// Which robot.
    pub id: u32,
    /// Where it is, world frame.
    pub pose: Pose,
    /// The id of the puck in its gripper.
    pub carrying: Option<u32>,
}

/// One puck as the overhead camera sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisionPuck {
    /// Which puck.
    pub id: u32,
    /// Its type (colour).
    pub kind: PuckKind,
    /// Its centre, world frame.
    pub pos: Vec2,
}

/// A box the robots push: a rectangle, its length along `pose.theta`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisionBox {
    /// Which box.
    pub id: u32,
    /// Its centre and the heading of its length, world frame.
    pub pose: Pose,
    /// End to end, cm.
    pub length: f64,
    /// Side to side, cm.
    pub width: f64,
}

/// The world at one control step (or, inside a [`VisionPart`], the share of it one part holds).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VisionFrame {
    /// The world's control step.
    pub step: u64,
    /// The walls, when known.
    pub arena: Option<Arena>,
    /// The bodies' sizes, when known.
    pub sizes: Option<Sizes>,
    /// Every robot.
    pub robots: Vec<VisionRobot>,
    /// Every puck.
    pub pucks: Vec<VisionPuck>,
    /// Every box.
    pub boxes: Vec<VisionBox>,
    /// Where something is to go, when the world has such a place.
    pub goal: Option<Vec2>,
}

/// One `vision` packet: part `part` of `parts` of the frame of `frame.step`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VisionPart {
    /// Which part, 0-based.
    pub part: u32,
    /// How many parts the frame has (at least 1, at most [`MAX_PARTS`]).
    pub parts: u32,
    /// What this part holds.
    pub frame: VisionFrame,
}

/// `frame` as one packet, or several when it would not fit in a datagram; the arena and sizes go
/// in the first. Values are rounded to 0.01.
pub fn encode(frame: &VisionFrame) -> Result<Vec<Vec<u8>>, ParseError> {
    let robots = frame.robots.iter().map(robot_line).collect();
    let pucks = frame.pucks.iter().map(puck_line).collect();
    encode_with_lines(frame, robots, pucks)
}

/// A robot's line in a vision frame.
pub fn robot_line(rb: &VisionRobot) -> String {
    let mut l = String::with_capacity(64);
    let _ = write!(l, "robot id {} x ", rb.id);
    push_r(&mut l, rb.pose.x);
    l.push_str(" y ");
    push_r(&mut l, rb.pose.y);
    l.push_str(" theta ");
    push_r(&mut l, rb.pose.theta);
    if let Some(c) = rb.carrying {
        let _ = write!(l, " carrying {c}");
    }
    l
}

/// A puck's line in a vision frame.
pub fn puck_line(pk: &VisionPuck) -> String {
    let mut l = String::with_capacity(48);
    let _ = write!(l, "puck id {} kind {} x ", pk.id, pk.kind.0);
    push_r(&mut l, pk.pos.x);
    l.push_str(" y ");
    push_r(&mut l, pk.pos.y);
    l
}

/// [`encode`], the robots' and pucks' lines already written ([`robot_line`] and [`puck_line`]
/// of `frame.robots` and `frame.pucks`, in order): for a caller that writes a swarm's
/// lines on several threads.
pub fn encode_with_lines(
    frame: &VisionFrame,
    robot_lines: Vec<String>,
    puck_lines: Vec<String>,
) -> Result<Vec<Vec<u8>>, ParseError> {
    // Lines are written as text first, so that each part's size is known before it is cut.
    let mut lines: Vec<String> = Vec::with_capacity(robot_lines.len() + puck_lines.len() + 2);
    if let Some(a) = &frame.arena {
        lines.push(format!(
            "arena width {} height {} corner {}",
            r(a.width),
            r(a.height),
            r(a.corner)
        ));
    }
    if let Some(s) = &frame.sizes {
        lines.push(format!(
            "sizes robot_length {} robot_width {} gripper_radius {} puck_diameter {}",
            r(s.robot_length),
            r(s.robot_width),
            r(s.gripper_radius),
            r(s.puck_diameter)
        ));
    }
    lines.extend(robot_lines);
    lines.extend(puck_lines);
    for b in &frame.boxes {
        lines.push(format!(
            "box id {} x {} y {} theta {} length {} width {}",
            b.id,
            r(b.pose.x),
            r(b.pose.y),
            r(b.pose.theta),
            r(b.length),
            r(b.width)
        ));
    }
    if let Some(g) = frame.goal {
        lines.push(format!("goal x {} y {}", r(g.x), r(g.y)));
    }
    let mut chunks: Vec<Vec<&str>> = vec![Vec::new()];
    let mut size = 0;
    for l in &lines {
        if size + l.len() + 1 > PART_BUDGET && !chunks.last().is_some_and(Vec::is_empty) {
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
            let mut p = PacketBuilder::new([VISION], PRIORITY);
            p.line("step")
                .field("n", frame.step)
                .field("part", i)
                .field("parts", parts);
            for l in chunk {
                p.raw_line(l);
            }
            p.finish()
        })
        .collect()
}

/// Reads one vision part; any bad line refuses it.
pub fn decode(packet: &Packet<'_>) -> Result<VisionPart, DecodeError> {
    read(packet, &mut LinePolicy::strict())
}

/// Reads one vision part for a viewer: bad lines are skipped and counted. Only a part whose
/// `step` line cannot be read (it says which frame the rest belongs to) is an error.
pub fn skim(packet: &Packet<'_>) -> Result<Skimmed<VisionPart>, DecodeError> {
    let mut policy = LinePolicy::skim();
    let part = read(packet, &mut policy)?;
    Ok(policy.skimmed(part))
}

fn read(packet: &Packet<'_>, policy: &mut LinePolicy) -> Result<VisionPart, DecodeError> {
    let head = packet.line("step").ok_or(DecodeError::Missing("step"))?;
    let step = count(&head, "n")?;
    let part = match head.get("part") {
        Some(_) => count(&head, "part")?,
        None => 0,
    };
    let parts = match head.get("parts") {
        Some(_) => count(&head, "parts")?,
        None => 1,
    };
    if parts == 0 || parts > u64::from(MAX_PARTS) || part >= parts {
        return Err(bad(
            &head,
            format!("part {part} of {parts} is not a part of at most {MAX_PARTS}"),
        ));
    }
    let mut frame = VisionFrame {
        step,
        ..VisionFrame::default()
    };
    for line in packet.lines() {
        match line.label() {
            "robot" => frame.robots.extend(policy.take(robot(&line))?),
            "puck" => frame.pucks.extend(policy.take(puck(&line))?),
            "box" => frame.boxes.extend(policy.take(a_box(&line))?),
            "goal" => {
                let g = policy.take(goal(&line))?;
                frame.goal = g.or(frame.goal);
            }
            "arena" => {
                let a = policy.take(arena(&line))?;
                frame.arena = a.or(frame.arena);
            }
            "sizes" => {
                let s = policy.take(sizes(&line))?;
                frame.sizes = s.or(frame.sizes);
            }
            _ => {}
        }
    }
    Ok(VisionPart {
        part: part as u32,
        parts: parts as u32,
        frame,
    })
}

// A swarm's frame has a line per body, so robots' and pucks' fields are picked in one pass.
fn robot(line: &colony_wire::Line<'_>) -> Result<VisionRobot, DecodeError> {
    let line = &line.pick(["id", "x", "y", "theta", "carrying"]);
    Ok(VisionRobot {
        id: robot_id(line, "id")?,
        pose: Pose {
            x: coord(line, "x")?,
            y: coord(line, "y")?,
            theta: finite(line, "theta")?,
        },
        carrying: match line.get("carrying") {
            Some(_) => Some(puck_id(line, "carrying")?),
            None => None,
        },
    })
}

fn puck(line: &colony_wire::Line<'_>) -> Result<VisionPuck, DecodeError> {
    let line = &line.pick(["id", "kind", "x", "y"]);
    Ok(VisionPuck {
        id: puck_id(line, "id")?,
        kind: puck_kind(line, "kind")?,
        pos: Vec2::new(coord(line, "x")?, coord(line, "y")?),
    })
}

fn a_box(line: &colony_wire::Line<'_>) -> Result<VisionBox, DecodeError> {
    let size = |name| within(line, name, 0.0..MAX_SIZE);
    Ok(VisionBox {
        id: robot_id(line, "id")?,
        pose: Pose {
            x: coord(line, "x")?,
            y: coord(line, "y")?,
            theta: finite(line, "theta")?,
        },
        length: size("length")?,
        width: size("width")?,
    })
}

fn goal(line: &colony_wire::Line<'_>) -> Result<Vec2, DecodeError> {
    Ok(Vec2::new(coord(line, "x")?, coord(line, "y")?))
}

fn arena(line: &colony_wire::Line<'_>) -> Result<Arena, DecodeError> {
    let side = |name| within(line, name, 0.0..=2.0 * MAX_COORD);
    Ok(Arena {
        width: side("width")?,
        height: side("height")?,
        corner: side("corner")?,
    })
}

fn sizes(line: &colony_wire::Line<'_>) -> Result<Sizes, DecodeError> {
    let size = |name| {
        let v = within(line, name, 0.0..MAX_SIZE)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(bad(line, format!("{name} must be more than 0")))
        }
    };
    let puck_diameter = size("puck_diameter")?;
    Ok(Sizes {
        robot_length: size("robot_length")?,
        robot_width: size("robot_width")?,
        gripper_radius: match line.get("gripper_radius") {
            Some(_) => size("gripper_radius")?,
            None => puck_diameter * GRIPPER_PER_PUCK,
        },
        puck_diameter,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn parse(text: &str) -> Packet<'_> {
        Packet::parse(text.as_bytes()).unwrap()
    }

    fn big_frame() -> VisionFrame {
        VisionFrame {
            step: 9,
            arena: Some(Arena {
                width: 1234.567,
                height: 1234.567,
                corner: 15.0,
            }),
            sizes: Some(Sizes {
                robot_length: 12.5,
                robot_width: 10.8,
                gripper_radius: 3.6,
                puck_diameter: 6.3,
            }),
            robots: (0..256)
                .map(|i| VisionRobot {
                    id: i,
                    pose: Pose {
                        x: 1.5,
                        y: -2.5,
                        theta: 0.25,
                    },
                    carrying: (i % 3 == 0).then_some(i),
                })
                .collect(),
            pucks: (0..2560)
                .map(|i| VisionPuck {
                    id: i,
                    kind: PuckKind((i % 8) as u8),
                    pos: Vec2::new(-123.45, 67.89),
                })
                .collect(),
            ..VisionFrame::default()
        }
    }

    #[test]
    fn a_large_swarm_is_split_into_parts_that_each_fit_a_datagram() {
        let frame = big_frame();
        let parts = encode(&frame).unwrap();
        assert!(parts.len() >= 2);
        let (mut robots_seen, mut pucks_seen) = (0, 0);
        for (i, bytes) in parts.iter().enumerate() {
            assert!(bytes.len() <= colony_wire::MAX_PACKET);
            let p = decode(&Packet::parse(bytes).unwrap()).unwrap();
            assert_eq!(
                (p.frame.step, p.part, p.parts),
                (9, i as u32, parts.len() as u32)
            );
            assert_eq!(
                p.frame.arena.is_some(),
                i == 0,
                "the arena is in the first part only"
            );
            robots_seen += p.frame.robots.len();
            pucks_seen += p.frame.pucks.len();
        }
        assert_eq!((robots_seen, pucks_seen), (256, 2560));
        let first = Packet::parse(&parts[0]).unwrap();
        assert_eq!(first.priority(), PRIORITY);
        let first = decode(&first).unwrap().frame;
        assert_eq!(first.arena.unwrap().width, 1234.57);
        assert_eq!(first.sizes, frame.sizes);
        assert_eq!(first.robots[3].carrying, Some(3));
    }

    #[test]
    fn a_part_reads_as_the_format_says() {
        let frame = VisionFrame {
            step: 7,
            arena: Some(Arena {
                width: 187.0,
                height: 187.0,
                corner: 15.0,
            }),
            sizes: None,
            robots: vec![VisionRobot {
                id: 1,
                pose: Pose {
                    x: 10.0,
                    y: 0.0,
                    theta: 1.571,
                },
                carrying: Some(3),
            }],
            pucks: vec![VisionPuck {
                id: 3,
                kind: PuckKind(1),
                pos: Vec2::new(17.0, 0.5),
            }],
            boxes: vec![VisionBox {
                id: 0,
                pose: Pose {
                    x: 10.0,
                    y: -70.0,
                    theta: 0.1,
                },
                length: 60.0,
                width: 8.0,
            }],
            goal: Some(Vec2::new(10.0, 60.0)),
        };
        let bytes = encode(&frame).unwrap();
        assert_eq!(
            std::str::from_utf8(&bytes[0]).unwrap(),
            "@ <vision> 20\nstep n 7 part 0 parts 1\narena width 187 height 187 corner 15\n\
             robot id 1 x 10 y 0 theta 1.57 carrying 3\npuck id 3 kind 1 x 17 y 0.5\n\
             box id 0 x 10 y -70 theta 0.1 length 60 width 8\ngoal x 10 y 60\n"
        );
        let back = decode(&Packet::parse(&bytes[0]).unwrap()).unwrap().frame;
        let frame = VisionFrame {
            arena: back.arena,
            robots: frame
                .robots
                .iter()
                .map(|r| VisionRobot {
                    pose: Pose {
                        theta: 1.57,
                        ..r.pose
                    },
                    ..*r
                })
                .collect(),
            ..frame
        };
        assert_eq!(back, frame);
    }

    #[test]
    fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
        let mut frame = big_frame();
        frame.robots.truncate(4);
        frame.pucks.truncate(2);
        frame.boxes.push(VisionBox {
            id: 0,
            pose: Pose {
                x: 10.0,
                y: -70.0,
                theta: 0.1,
            },
            length: 60.0,
            width: 8.0,
        });
        frame.goal = Some(Vec2::new(10.0, 60.0));
        crate::table::check::codec(&TABLE, &encode(&frame).unwrap(), |p| decode(p).is_ok());
    }

    #[test]
    fn a_viewer_skips_and_counts_bad_lines_a_node_refuses_them() {
        let text = "@ <vision> 0\nstep n 1\nrobot id -4 x 0 y 0 theta 0\nrobot id 2 x nan y 0 theta 0\npuck id 1 kind 0 x 1\nrobot id 3 x 1 y 2 theta 0\nsizes robot_length 12 robot_width 10 puck_diameter 6\n";
        let s = skim(&parse(text)).unwrap();
        assert_eq!(s.bad_lines, 3);
        assert_eq!(s.message.frame.robots.len(), 1);
        assert_eq!(
            (s.message.part, s.message.parts),
            (0, 1),
            "one part when not said"
        );
        assert!((s.message.frame.sizes.unwrap().gripper_radius - 3.42).abs() < 1e-9);
        assert!(decode(&parse(text)).is_err());
        for head in [
            "@ <vision> 0\nstep n 2 part 5 parts 2\n",
            "@ <vision> 0\nstep n 2 part 0 parts 0\n",
            "@ <vision> 0\nstep n 2 part 0 parts 5000\n",
            "@ <vision> 0\nstep n x\n",
            "@ <vision> 0\nstep n -1\n",
            "@ <vision> 0\nball x 1\n",
        ] {
            assert!(skim(&parse(head)).is_err(), "{head:?}");
        }
    }

    proptest! {
        #[test]
        fn any_frame_round_trips_within_rounding(
            step in any::<u32>(),
            robots in proptest::collection::vec((any::<u32>(), -1e4f64..1e4, -1e4f64..1e4, -4.0f64..4.0, proptest::option::of(any::<u32>())), 0..20),
            pucks in proptest::collection::vec((any::<u32>(), any::<u8>(), -1e4f64..1e4, -1e4f64..1e4), 0..20),
        ) {
            let frame = VisionFrame {
                step: u64::from(step),
                arena: None,
                sizes: None,
                robots: robots.iter().map(|&(id, x, y, theta, carrying)| VisionRobot { id, pose: Pose { x, y, theta }, carrying }).collect(),
                pucks: pucks.iter().map(|&(id, k, x, y)| VisionPuck { id, kind: PuckKind(k), pos: Vec2::new(x, y) }).collect(),
                ..VisionFrame::default()
            };
            let parts = encode(&frame).unwrap();
            prop_assert_eq!(parts.len(), 1);
            let got = decode(&Packet::parse(&parts[0]).unwrap()).unwrap().frame;
            prop_assert_eq!(got.step, frame.step);
            prop_assert_eq!(got.robots.len(), frame.robots.len());
            for (a, b) in got.robots.iter().zip(&frame.robots) {
                prop_assert_eq!((a.id, a.carrying), (b.id, b.carrying));
                prop_assert!(a.pose.position().distance(b.pose.position()) <= 0.01);
            }
            for (a, b) in got.pucks.iter().zip(&frame.pucks) {
                prop_assert_eq!((a.id, a.kind), (b.id, b.kind));
                prop_assert!(a.pos.distance(b.pos) <= 0.01);
            }
        }

        #[test]
        fn any_text_is_skimmed_without_a_panic(body in "[a-z0-9 .\\-\\n]{0,200}") {
            let text = format!("@ <vision> 0\nstep n 1\n{body}\n");
            if let Ok(p) = Packet::parse(text.as_bytes()) {
                let _ = skim(&p);
                let _ = decode(&p);
            }
        }
    }
}
