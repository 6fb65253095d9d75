//! `game.robot.N`: a (sequence) command for robot N from the swarm intelligence; the robot keeps
//! only the newest.
//!
//! ```text
//! @ <game.robot.3> 0
//! order robot 3 seq 17
//! goto x 300 y 120 speed 14
//! shoot target 9 x 350 y 130
//! ```

use std::fmt;

use colony_wire::{Line, Packet, PacketBuilder, ParseError, Priority};

use super::robot_channel;
use crate::fields::{bad, coord, count, finite, plain_name, r, robot_id, within};
use crate::table::{int, line, num, text, MessageTable};
use crate::{DecodeError, Vec2};

/// What an order holds, on every `game.robot.N`: its head, then one line per command.
pub const TABLE: MessageTable = MessageTable {
    channel: "game.robot.",
    lines: &[
        line("order", &[int("robot"), int("seq")]),
        line("beep", &[]),
        line("rotate", &[num("deg")]),
        line("goto", &[num("x"), num("y"), num("speed").optional()]),
        line("shoot", &[int("target"), num("x"), num("y")]),
        line("pickup", &[text("flag")]),
        line("stop", &[]),
        line("drive", &[num("forward"), num("turn"), num("secs")]),
    ],
};

/// One robot command (the paper's Table 2, plus PickUp from its Capture the
/// Flag run and Stop).
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// A short beep.
    Beep,
    /// Turn on the spot by this many degrees (counter-clockwise positive).
    Rotate {
        /// Degrees.
        deg: f64,
    },
    /// Turn toward the point and drive to it in a straight line.
    GoTo {
        /// Where, cm.
        to: Vec2,
        /// Top speed, cm/s (a squad moves at its slowest member's speed).
        speed: Option<f64>,
    },
    /// Face the enemy and fire at the type's rate until told otherwise.
    Shoot {
        /// The enemy robot.
        target: u32,
        /// Where it was last seen, cm.
        at: Vec2,
    },
    /// Pick up a team's flag (it must be within reach).
    PickUp {
        /// Whose flag.
        flag: String,
    },
    /// Stand still.
    Stop,
    /// The player's direct control: these wheel fractions for `secs`, then stand still.
    Drive {
        /// Forward, -1 to 1.
        forward: f64,
        /// Turn, -1 (right) to 1 (left).
        turn: f64,
        /// For how long, s.
        secs: f64,
    },
}

impl Command {
    fn write(&self, p: &mut PacketBuilder) {
        match self {
            Command::Beep => {
                p.line("beep");
            }
            Command::Rotate { deg } => {
                p.line("rotate").field("deg", r(*deg));
            }
            Command::GoTo { to, speed } => {
                let mut l = p.line("goto");
                l.field("x", r(to.x)).field("y", r(to.y));
                if let Some(s) = speed {
                    l.field("speed", r(*s));
                }
            }
            Command::Shoot { target, at } => {
                p.line("shoot")
                    .field("target", *target)
                    .field("x", r(at.x))
                    .field("y", r(at.y));
            }
            Command::PickUp { flag } => {
                p.line("pickup").bare("flag", flag);
            }
            Command::Stop => {
                p.line("stop");
            }
            Command::Drive {
                forward,
                turn,
                secs,
            } => {
                p.line("drive")
                    .field("forward", r(*forward))
                    .field("turn", r(*turn))
                    .field("secs", r(*secs));
            }
        }
    }

    fn read(l: &Line<'_>) -> Result<Option<Command>, DecodeError> {
        Ok(Some(match l.label() {
            "beep" => Command::Beep,
            "rotate" => Command::Rotate {
                deg: finite(l, "deg")?,
            },
            "goto" => Command::GoTo {
                to: Vec2::new(coord(l, "x")?, coord(l, "y")?),
                speed: match l.get("speed") {
                    Some(_) => {
                        let s = finite(l, "speed")?;
                        if s <= 0.0 {
                            return Err(bad(l, "speed must be positive"));
                        }
                        Some(s)
                    }
                    None => None,
                },
            },
            "shoot" => Command::Shoot {
                target: robot_id(l, "target")?,
                at: Vec2::new(coord(l, "x")?, coord(l, "y")?),
            },
            "pickup" => Command::PickUp {
                flag: plain_name(l, "flag")?,
            },
            "stop" => Command::Stop,
            "drive" => Command::Drive {
                forward: within(l, "forward", -1.0..=1.0)?,
                turn: within(l, "turn", -1.0..=1.0)?,
                secs: within(l, "secs", 0.0..=10.0)?,
            },
            _ => return Ok(None),
        }))
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Command::Beep => f.write_str("beep"),
            Command::Rotate { deg } => write!(f, "rotate {deg:.0}"),
            Command::GoTo { to, .. } => write!(f, "goto {:.0} {:.0}", to.x, to.y),
            Command::Shoot { target, .. } => write!(f, "shoot {target}"),
            Command::PickUp { flag } => write!(f, "pickup {flag}"),
            Command::Stop => f.write_str("stop"),
            Command::Drive { forward, turn, .. } => {
                write!(f, "driven by the player ({forward:.1}, {turn:.1})")
            }
        }
    }
}

/// Commands sent at most in one order (a sequence command).
pub const MAX_COMMANDS: usize = 256;

/// A (sequence) command for one robot. The robot keeps only the newest: an
/// order whose `seq` is not above the one it holds is stale (UDP may reorder).
#[derive(Debug, Clone, PartialEq)]
pub struct Order {
    /// The robot.
    pub robot: u32,
    /// Increases with every order the swarm intelligence sends this robot.
    pub seq: u64,
    /// Done in order; a single command is a sequence of one.
    pub commands: Vec<Command>,
}

impl Order {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([robot_channel(self.robot)], Priority(0));
        p.line("order")
            .field("robot", self.robot)
            .field("seq", self.seq);
        for c in self.commands.iter().take(MAX_COMMANDS) {
            c.write(&mut p);
        }
        p.finish()
    }

    /// Reads an order; unknown command lines are an error, so a typo can't
    /// silently drop a step of the sequence.
    pub fn decode(packet: &Packet<'_>) -> Result<Order, DecodeError> {
        let head = packet.line("order").ok_or(DecodeError::Missing("order"))?;
        let robot = robot_id(&head, "robot")?;
        let seq = count(&head, "seq")?;
        let mut commands = Vec::new();
        for l in packet.lines() {
            if l.label() == "order" {
                continue;
            }
            match Command::read(&l)? {
                Some(c) if commands.len() < MAX_COMMANDS => commands.push(c),
                Some(_) => return Err(bad(&l, format!("more than {MAX_COMMANDS} commands"))),
                None => {
                    return Err(bad(
                        &l,
                        format!(
                        "unknown command {:?} (expected beep, rotate, goto, shoot, pickup or stop)",
                        l.label()
                    ),
                    ))
                }
            }
        }
        Ok(Order {
            robot,
            seq,
            commands,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn round(o: &Order) -> Order {
        Order::decode(&Packet::parse(&o.encode().unwrap()).unwrap()).unwrap()
    }

    #[test]
    fn every_command_survives_the_trip() {
        let o = Order {
            robot: 7,
            seq: 9,
            commands: vec![
                Command::GoTo {
                    to: Vec2::new(10.0, 20.0),
                    speed: Some(14.0),
                },
                Command::Rotate { deg: 90.0 },
                Command::Beep,
                Command::Shoot {
                    target: 2,
                    at: Vec2::new(3.0, 4.0),
                },
                Command::PickUp {
                    flag: "blue".into(),
                },
                Command::Stop,
            ],
        };
        assert_eq!(round(&o), o);
        let mut all = o.clone();
        all.commands.push(Command::Drive {
            forward: 0.5,
            turn: -0.25,
            secs: 1.0,
        });
        crate::table::check::codec(&TABLE, &[all.encode().unwrap()], |p| {
            Order::decode(p).is_ok()
        });
    }

    #[test]
    fn an_unknown_command_names_its_line() {
        let p = b"@ <game.robot.1> 0\norder robot 1 seq 3\nfly x 1\n";
        let e = Order::decode(&Packet::parse(p).unwrap()).unwrap_err();
        assert!(
            e.to_string().starts_with("line 3: unknown command \"fly\""),
            "{e}"
        );
        let p = b"@ <game.robot.1> 0\norder robot 1 seq 3\ngoto x 1 y 1 speed 0\n";
        assert!(Order::decode(&Packet::parse(p).unwrap()).is_err());
    }

    proptest! {
        #[test]
        fn any_order_of_gotos_reencodes_to_itself(
            seq in 0u64..u64::from(u32::MAX),
            points in proptest::collection::vec((-1e5f64..1e5, -1e5f64..1e5), 0..20),
        ) {
            let o = Order {
                robot: 3,
                seq,
                commands: points
                    .into_iter()
                    .map(|(x, y)| Command::GoTo { to: Vec2::new(r(x), r(y)), speed: None })
                    .collect(),
            };
            prop_assert_eq!(round(&o), o);
        }

        #[test]
        fn the_order_decoder_never_panics(text in "[a-z0-9 .\n-]{0,200}") {
            let bytes = format!("@ <game.robot.1> 0\n{text}");
            if let Ok(p) = Packet::parse(bytes.as_bytes()) {
                let _ = Order::decode(&p);
            }
        }
    }
}
