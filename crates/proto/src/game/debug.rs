//! `game.debug`: a robot's active behaviour and why, for the game logic and the monitor.
//!
//! ```text
//! @ <game.debug> 0
//! robot id 3 behaviour avoid-bump reason "bumper front pressed"
//! ```

use colony_wire::{Packet, PacketBuilder, ParseError, Priority};

use super::DEBUG;
use crate::fields::{robot_id, text_or_empty};
use crate::table::{int, line, text, MessageTable};
use crate::DecodeError;

/// What a game debug packet holds.
pub const TABLE: MessageTable = MessageTable {
    channel: DEBUG,
    lines: &[line(
        "robot",
        &[
            int("id"),
            text("behaviour").optional(),
            text("reason").optional(),
        ],
    )],
};

/// A robot's active behaviour and the reason it has control.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotDebug {
    /// The robot.
    pub robot: u32,
    /// The active behaviour's name.
    pub behaviour: String,
    /// Why it is active.
    pub reason: String,
}

impl RobotDebug {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([DEBUG], Priority(0));
        p.line("robot")
            .field("id", self.robot)
            .field("behaviour", self.behaviour.as_str())
            .field("reason", self.reason.as_str());
        p.finish()
    }

    /// Reads one.
    pub fn decode(packet: &Packet<'_>) -> Result<RobotDebug, DecodeError> {
        let l = packet.line("robot").ok_or(DecodeError::Missing("robot"))?;
        Ok(RobotDebug {
            robot: robot_id(&l, "id")?,
            behaviour: text_or_empty(&l, "behaviour")?,
            reason: text_or_empty(&l, "reason")?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_debug_line_survives_the_trip() {
        let d = RobotDebug {
            robot: 3,
            behaviour: "avoid-bump".into(),
            reason: "bumper front pressed".into(),
        };
        let bytes = d.encode().unwrap();
        assert_eq!(
            RobotDebug::decode(&Packet::parse(&bytes).unwrap()).unwrap(),
            d
        );
        crate::table::check::codec(&TABLE, &[bytes], |p| RobotDebug::decode(p).is_ok());
    }
}
