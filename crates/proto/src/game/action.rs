//! `game.action`: a robot asks the game logic to act on the world (fire, pick up a flag, beep).
//!
//! ```text
//! @ <game.action> 0
//! fire id 3 target 9
//! pickup id 3 flag blue
//! ```

use colony_wire::{Packet, PacketBuilder, ParseError, Priority};

use super::ACTION;
use crate::fields::{bad, plain_name, robot_id};
use crate::table::{int, line, text, MessageTable};
use crate::DecodeError;

/// What an action packet holds: one line per action.
pub const TABLE: MessageTable = MessageTable {
    channel: ACTION,
    lines: &[
        line("fire", &[int("id"), int("target")]),
        line("pickup", &[int("id"), text("flag")]),
        line("beep", &[int("id")]),
    ],
};

/// What a robot asks the game logic to do to the world.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// One shot at an enemy.
    Fire {
        /// The shooter.
        robot: u32,
        /// The enemy.
        target: u32,
    },
    /// Take a flag.
    PickUp {
        /// Who.
        robot: u32,
        /// Whose flag.
        flag: String,
    },
    /// A beep (heard by the logger).
    Beep {
        /// Who.
        robot: u32,
    },
}

impl Action {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([ACTION], Priority(0));
        match self {
            Action::Fire { robot, target } => {
                p.line("fire").field("id", *robot).field("target", *target);
            }
            Action::PickUp { robot, flag } => {
                p.line("pickup").field("id", *robot).bare("flag", flag);
            }
            Action::Beep { robot } => {
                p.line("beep").field("id", *robot);
            }
        }
        p.finish()
    }

    /// Reads every action in the packet.
    pub fn decode(packet: &Packet<'_>) -> Result<Vec<Action>, DecodeError> {
        packet
            .lines()
            .map(|l| {
                Ok(match l.label() {
                    "fire" => Action::Fire {
                        robot: robot_id(&l, "id")?,
                        target: robot_id(&l, "target")?,
                    },
                    "pickup" => Action::PickUp {
                        robot: robot_id(&l, "id")?,
                        flag: plain_name(&l, "flag")?,
                    },
                    "beep" => Action::Beep {
                        robot: robot_id(&l, "id")?,
                    },
                    other => {
                        return Err(bad(
                            &l,
                            format!("unknown action {other:?} (expected fire, pickup or beep)"),
                        ))
                    }
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_action_survives_the_trip() {
        for a in [
            Action::Fire {
                robot: 1,
                target: 2,
            },
            Action::PickUp {
                robot: 3,
                flag: "red".into(),
            },
            Action::Beep { robot: 4 },
        ] {
            let bytes = a.encode().unwrap();
            assert_eq!(
                Action::decode(&Packet::parse(&bytes).unwrap()).unwrap(),
                vec![a]
            );
        }
        let samples: Vec<Vec<u8>> = [
            Action::Fire {
                robot: 1,
                target: 2,
            },
            Action::PickUp {
                robot: 3,
                flag: "red".into(),
            },
            Action::Beep { robot: 4 },
        ]
        .iter()
        .map(|a| a.encode().unwrap())
        .collect();
        crate::table::check::codec(&TABLE, &samples, |p| Action::decode(p).is_ok());
        let p = b"@ <game.action> 0\nfly id 1\n";
        assert!(Action::decode(&Packet::parse(p).unwrap()).is_err());
    }
}
