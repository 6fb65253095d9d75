//! `debug`: what the controllers intend, for the monitor's superimposed graphics.
//!
//! ```text
//! @ <debug> 0
//! robot id 2 state "HOMING" tx 40.0 ty 20.0
//! cache id 2 kind 0 x 40.0 y 20.0
//! ```
//!
//! `robot` gives a controller's state machine state and, when it has one, its target (`tx` and
//! `ty` together); each `cache` line is a cache point that robot believes in for one puck kind.

use colony_wire::{Line, Packet, PacketBuilder, ParseError, Priority};

use super::{puck_kind, PuckKind};
use crate::error::{LinePolicy, Skimmed};
use crate::fields::{bad, coord, r, robot_id};
use crate::table::{int, line, num, text, MessageTable};
use crate::{DecodeError, Vec2};

/// The channel controllers publish their intentions on, for the monitor.
pub const DEBUG: &str = "debug";

/// What a debug packet holds.
pub const TABLE: MessageTable = MessageTable {
    channel: DEBUG,
    lines: &[
        line(
            "robot",
            &[
                int("id"),
                text("state"),
                num("tx").optional(),
                num("ty").with("tx"),
            ],
        ),
        line("cache", &[int("id"), int("kind"), num("x"), num("y")]),
    ],
};

/// What one robot's controller is doing.
#[derive(Debug, Clone, PartialEq)]
pub struct Intent {
    /// Which robot.
    pub robot: u32,
    /// Its state machine's state (`PU_SCAN`, `HOMING`, ...).
    pub state: String,
    /// Where it is heading (world frame), if it has a target.
    pub target: Option<Vec2>,
}

/// A cache point a robot believes in (world frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CachePoint {
    /// The robot that believes in it.
    pub robot: u32,
    /// The puck kind it gathers.
    pub kind: PuckKind,
    /// Where it is.
    pub pos: Vec2,
}

/// One `debug` packet: intentions and cache points, usually one controller's.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Intentions {
    /// `robot` lines.
    pub intents: Vec<Intent>,
    /// `cache` lines.
    pub caches: Vec<CachePoint>,
}

/// `intentions` as one packet on [`DEBUG`]: the `robot` lines, then the `cache` lines.
pub fn encode(intentions: &Intentions) -> Result<Vec<u8>, ParseError> {
    let mut p = PacketBuilder::new([DEBUG], Priority(0));
    for i in &intentions.intents {
        let mut l = p.line("robot");
        l.field("id", i.robot).field("state", i.state.as_str());
        if let Some(t) = i.target {
            l.field("tx", r(t.x)).field("ty", r(t.y));
        }
    }
    for c in &intentions.caches {
        p.line("cache")
            .field("id", c.robot)
            .field("kind", c.kind.0)
            .field("x", r(c.pos.x))
            .field("y", r(c.pos.y));
    }
    p.finish()
}

/// Reads a debug packet; any bad line refuses it.
pub fn decode(packet: &Packet<'_>) -> Result<Intentions, DecodeError> {
    read(packet, &mut LinePolicy::strict())
}

/// Reads a debug packet for a viewer: bad lines are skipped and counted.
pub fn skim(packet: &Packet<'_>) -> Skimmed<Intentions> {
    let mut policy = LinePolicy::skim();
    let read = read(packet, &mut policy).unwrap_or_default();
    policy.skimmed(read)
}

fn read(packet: &Packet<'_>, policy: &mut LinePolicy) -> Result<Intentions, DecodeError> {
    let mut out = Intentions::default();
    for line in packet.lines() {
        match line.label() {
            "robot" => out.intents.extend(policy.take(intent(&line))?),
            "cache" => out.caches.extend(policy.take(cache(&line))?),
            _ => {}
        }
    }
    Ok(out)
}

fn intent(line: &Line<'_>) -> Result<Intent, DecodeError> {
    let target = match (line.get("tx"), line.get("ty")) {
        (None, None) => None,
        (Some(_), Some(_)) => Some(Vec2::new(coord(line, "tx")?, coord(line, "ty")?)),
        _ => return Err(bad(line, "tx and ty go together")),
    };
    Ok(Intent {
        robot: robot_id(line, "id")?,
        state: line.str("state")?.into_owned(),
        target,
    })
}

fn cache(line: &Line<'_>) -> Result<CachePoint, DecodeError> {
    Ok(CachePoint {
        robot: robot_id(line, "id")?,
        kind: puck_kind(line, "kind")?,
        pos: Vec2::new(coord(line, "x")?, coord(line, "y")?),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn parse(text: &str) -> Packet<'_> {
        Packet::parse(text.as_bytes()).unwrap()
    }

    #[test]
    fn intentions_round_trip_as_the_format_says() {
        let sent = Intentions {
            intents: vec![Intent {
                robot: 2,
                state: "HOMING".into(),
                target: Some(Vec2::new(40.0, 20.0)),
            }],
            caches: vec![CachePoint {
                robot: 2,
                kind: PuckKind(0),
                pos: Vec2::new(40.0, 20.0),
            }],
        };
        let bytes = encode(&sent).unwrap();
        assert_eq!(
            std::str::from_utf8(&bytes).unwrap(),
            "@ <debug> 0\nrobot id 2 state \"HOMING\" tx 40.0 ty 20.0\ncache id 2 kind 0 x 40.0 y 20.0\n"
        );
        assert_eq!(decode(&Packet::parse(&bytes).unwrap()).unwrap(), sent);
        let bare = decode(&parse("@ <debug> 0\nrobot id 3 state WANDER\n")).unwrap();
        assert_eq!(bare.intents[0].target, None);
    }

    #[test]
    fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
        let sent = Intentions {
            intents: vec![
                Intent {
                    robot: 2,
                    state: "HOMING".into(),
                    target: Some(Vec2::new(40.0, 20.0)),
                },
                Intent {
                    robot: 3,
                    state: "PU_SCAN".into(),
                    target: None,
                },
            ],
            caches: vec![CachePoint {
                robot: 2,
                kind: PuckKind(0),
                pos: Vec2::new(40.0, 20.0),
            }],
        };
        crate::table::check::codec(&TABLE, &[encode(&sent).unwrap()], |p| decode(p).is_ok());
    }

    #[test]
    fn a_viewer_skips_and_counts_bad_lines_a_node_refuses_them() {
        let text = "@ <debug> 0\nrobot id -1 state A\nrobot id 1 state B tx nan ty 0\nrobot id 2 state C tx 1\ncache id 2 kind 256 x 0 y 0\ncache id 2 kind 1 x 0 y 0\nrobot id 4 state D\n";
        let s = skim(&parse(text));
        assert_eq!(s.bad_lines, 4);
        assert_eq!((s.message.intents.len(), s.message.caches.len()), (1, 1));
        assert!(decode(&parse(text)).is_err());
    }

    proptest! {
        #[test]
        fn any_intention_round_trips(
            robot in any::<u32>(), state in "[ -~]{0,30}", t in proptest::option::of((-1e4f64..1e4, -1e4f64..1e4)),
            kind in any::<u8>(),
        ) {
            let sent = Intentions {
                intents: vec![Intent { robot, state: state.clone(), target: t.map(|(x, y)| Vec2::new(x, y)) }],
                caches: vec![CachePoint { robot, kind: PuckKind(kind), pos: Vec2::new(1.0, -2.0) }],
            };
            let got = decode(&Packet::parse(&encode(&sent).unwrap()).unwrap()).unwrap();
            prop_assert_eq!(&got.intents[0].state, &state);
            prop_assert_eq!(got.intents[0].target.is_some(), t.is_some());
            prop_assert_eq!(got.caches, sent.caches);
        }
    }
}
