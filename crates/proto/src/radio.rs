//! The `radio` channel: wheel commands for robots, from their controllers and from an operator.
//!
//! ```text
//! @ <radio> 0                       a controller's command for robot 2
//! cmd id 2 forward 0.8 turn -0.25
//! ```
//!
//! A packet may hold many `cmd` lines (an operator holding several robots sends one packet). The
//! priority in the header is the command's priority: an operator's (higher) holds its robot
//! against the controllers' (0) for as long as [`CommandHold`](crate::CommandHold) says.

use colony_wire::{Packet, PacketBuilder, ParseError, Priority};

use crate::fields::{finite, r, robot_id};
use crate::table::{int, line, num, MessageTable};
use crate::{DecodeError, WheelCommand};

/// The channel wheel commands travel on, as in the Broker paper's system.
pub const RADIO: &str = "radio";

/// What a radio packet holds.
pub const TABLE: MessageTable = MessageTable {
    channel: RADIO,
    lines: &[line("cmd", &[int("id"), num("forward"), num("turn")])],
};

/// One robot's wheel command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadioCommand {
    /// The robot it is for.
    pub robot: u32,
    /// What its tracks should do; always within [-1, 1].
    pub wheels: WheelCommand,
}

impl RadioCommand {
    /// A command for `robot`, clamped by [`WheelCommand::clamped`].
    pub fn new(robot: u32, forward: f64, turn: f64) -> RadioCommand {
        RadioCommand {
            robot,
            wheels: WheelCommand::clamped(forward, turn),
        }
    }
}

/// One packet on [`RADIO`] at `priority` holding every command in `commands` (clamped, and
/// rounded to 0.01).
pub fn encode(commands: &[RadioCommand], priority: Priority) -> Result<Vec<u8>, ParseError> {
    let mut p = PacketBuilder::new([RADIO], priority);
    for c in commands {
        let w = WheelCommand::clamped(c.wheels.forward, c.wheels.turn);
        p.line("cmd")
            .field("id", c.robot)
            .field("forward", r(w.forward))
            .field("turn", r(w.turn));
    }
    p.finish()
}

/// Every `cmd` line of a radio packet, clamped to [-1, 1]. A line with a missing field, an id
/// that is not a robot id or a value that is not a finite number makes the whole packet an error:
/// a robot should not act on half of a forged packet.
pub fn decode(packet: &Packet<'_>) -> Result<Vec<RadioCommand>, DecodeError> {
    packet
        .lines_labelled("cmd")
        .map(|l| {
            Ok(RadioCommand::new(
                robot_id(&l, "id")?,
                finite(&l, "forward")?,
                finite(&l, "turn")?,
            ))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn parse(bytes: &[u8]) -> Result<Vec<RadioCommand>, DecodeError> {
        decode(&Packet::parse(bytes).unwrap())
    }

    #[test]
    fn commands_round_trip_clamped_and_rounded() {
        let sent = [
            RadioCommand::new(2, 0.8, -0.25),
            RadioCommand::new(7, 3.0, f64::NAN),
        ];
        let bytes = encode(&sent, Priority(10)).unwrap();
        assert_eq!(
            std::str::from_utf8(&bytes).unwrap(),
            "@ <radio> 10\ncmd id 2 forward 0.8 turn -0.25\ncmd id 7 forward 1.0 turn 0.0\n"
        );
        let got = parse(&bytes).unwrap();
        assert_eq!(
            got,
            [
                RadioCommand::new(2, 0.8, -0.25),
                RadioCommand::new(7, 1.0, 0.0)
            ]
        );
    }

    #[test]
    fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
        let bytes = encode(&[RadioCommand::new(2, 0.8, -0.25)], Priority(10)).unwrap();
        crate::table::check::codec(&TABLE, &[bytes], |p| decode(p).is_ok());
    }

    #[test]
    fn out_of_range_values_in_a_packet_are_clamped_on_reading() {
        let got = parse(b"@ <radio> 10\ncmd id 2 forward 3 turn -7\n").unwrap();
        assert_eq!(got, [RadioCommand::new(2, 1.0, -1.0)]);
    }

    #[test]
    fn a_refusal_names_the_field_and_its_value() {
        let e = parse(b"@ <radio> 0\ncmd id -1 forward 0 turn 0\n").unwrap_err();
        assert!(e.to_string().contains("id -1"), "{e}");
        let e = parse(b"@ <radio> 0\ncmd id 1 forward 0\n").unwrap_err();
        assert!(e.to_string().contains("`turn`"), "{e}");
        let e = parse(b"@ <radio> 0\ncmd id 1 forward NaN turn 0\n").unwrap_err();
        assert!(e.to_string().contains("forward"), "{e}");
    }

    #[test]
    fn a_non_finite_value_or_a_negative_id_is_refused_with_its_line() {
        let e = parse(b"@ <radio> 0\ncmd id 1 forward 0 turn 0\ncmd id 2 forward inf turn 0\n");
        assert!(matches!(e, Err(DecodeError::Bad { line: 3, .. })), "{e:?}");
        let e = parse(b"@ <radio> 0\ncmd id -1 forward 0 turn 0\n");
        assert!(matches!(e, Err(DecodeError::Bad { line: 2, .. })), "{e:?}");
        let e = parse(b"@ <radio> 0\ncmd id 1 turn 0\n");
        assert!(matches!(e, Err(DecodeError::Field(_))), "{e:?}");
    }

    proptest! {
        #[test]
        fn any_command_round_trips_within_rounding(
            id in any::<u32>(), f in -2.0f64..2.0, t in -2.0f64..2.0,
        ) {
            let bytes = encode(&[RadioCommand::new(id, f, t)], Priority(0)).unwrap();
            let got = parse(&bytes).unwrap();
            prop_assert_eq!(got.len(), 1);
            prop_assert_eq!(got[0].robot, id);
            prop_assert!((got[0].wheels.forward - f.clamp(-1.0, 1.0)).abs() <= 0.005 + 1e-12);
            prop_assert!((got[0].wheels.turn - t.clamp(-1.0, 1.0)).abs() <= 0.005 + 1e-12);
        }
    }
}
