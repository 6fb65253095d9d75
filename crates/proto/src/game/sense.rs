//! `game.sense.N`: what robot N's sensors report, from the world to the robot.
//!
//! ```text
//! @ <game.sense.3> 0
//! sense step 120 time 12 x 310.5 y 88.2 theta 1.57 bump_front 0 bump_rear 1 border 0 contact 3.1 sonar 14.2 bearing -0.2
//! ```

use colony_wire::{Packet, PacketBuilder, ParseError, Priority};

use super::sense_channel;
use crate::fields::{b, coord, count, finite, flag, r};
use crate::table::{int, line, num, MessageTable};
use crate::{DecodeError, Pose};

/// What a sense packet holds, on every `game.sense.N`.
pub const TABLE: MessageTable = MessageTable {
    channel: "game.sense.",
    lines: &[line(
        "sense",
        &[
            int("step"),
            num("time"),
            num("x"),
            num("y"),
            num("theta"),
            int("bump_front"),
            int("bump_rear"),
            int("border"),
            num("contact").optional(),
            num("sonar").optional(),
            num("bearing").with("sonar"),
        ],
    )],
};

/// What a robot's sensors report (the paper's touch sensors, sonar and
/// infrared border detector, plus the overhead tracker's pose).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sense {
    /// The world's step.
    pub step: u64,
    /// Game time, s.
    pub time: f64,
    /// Where the overhead tracker sees the robot.
    pub pose: Pose,
    /// The front touch sensor.
    pub bump_front: bool,
    /// The rear touch sensor.
    pub bump_rear: bool,
    /// Robot-frame bearing of the contact point, rad.
    pub contact: Option<f64>,
    /// The nearest echo in the sonar's cone: distance from the robot's edge (cm), bearing (rad).
    pub sonar: Option<(f64, f64)>,
    /// The border detector sees a line it must not cross just ahead.
    pub border: bool,
}

impl Sense {
    /// The packet for robot `id`.
    pub fn encode(&self, id: u32) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([sense_channel(id)], Priority(0));
        let mut l = p.line("sense");
        l.field("step", self.step)
            .field("time", r(self.time))
            .field("x", r(self.pose.x))
            .field("y", r(self.pose.y))
            .field("theta", r(self.pose.theta))
            .field("bump_front", b(self.bump_front))
            .field("bump_rear", b(self.bump_rear))
            .field("border", b(self.border));
        if let Some(c) = self.contact {
            l.field("contact", r(c));
        }
        if let Some((d, a)) = self.sonar {
            l.field("sonar", r(d)).field("bearing", r(a));
        }
        p.finish()
    }

    /// Reads a `sense` packet.
    pub fn decode(packet: &Packet<'_>) -> Result<Sense, DecodeError> {
        let l = packet.line("sense").ok_or(DecodeError::Missing("sense"))?;
        Ok(Sense {
            step: count(&l, "step")?,
            time: finite(&l, "time")?,
            pose: Pose {
                x: coord(&l, "x")?,
                y: coord(&l, "y")?,
                theta: finite(&l, "theta")?,
            },
            bump_front: flag(&l, "bump_front")?,
            bump_rear: flag(&l, "bump_rear")?,
            border: flag(&l, "border")?,
            contact: match l.get("contact") {
                Some(_) => Some(finite(&l, "contact")?),
                None => None,
            },
            sonar: match l.get("sonar") {
                Some(_) => Some((finite(&l, "sonar")?, finite(&l, "bearing")?)),
                None => None,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_sense_survives_the_trip_and_a_negative_step_is_refused() {
        let s = Sense {
            step: 4,
            time: 0.4,
            pose: Pose {
                x: 1.5,
                y: 2.25,
                theta: -0.5,
            },
            bump_front: true,
            bump_rear: false,
            contact: Some(0.25),
            sonar: Some((12.5, -0.1)),
            border: true,
        };
        let bytes = s.encode(3).unwrap();
        let p = Packet::parse(&bytes).unwrap();
        assert!(p.has_subject("game.sense.3"));
        assert_eq!(Sense::decode(&p).unwrap(), s);
        crate::table::check::codec(&TABLE, std::slice::from_ref(&bytes), |p| {
            Sense::decode(p).is_ok()
        });
        let p = b"@ <game.sense.1> 0\nsense step -1 time 0 x 0 y 0 theta 0 bump_front 0 bump_rear 0 border 0\n";
        assert!(Sense::decode(&Packet::parse(p).unwrap()).is_err());
    }

    proptest! {
        #[test]
        fn any_readable_sense_reencodes_to_itself(
            step in 0u64..1_000_000, x in -1e5f64..1e5, y in -1e5f64..1e5, theta in -4f64..4.0,
            front: bool, rear: bool, border: bool, contact in proptest::option::of(-4f64..4.0),
        ) {
            let s = Sense {
                step, time: 1.0, pose: Pose { x: r(x), y: r(y), theta: r(theta) },
                bump_front: front, bump_rear: rear, contact: contact.map(r), sonar: None, border,
            };
            let bytes = s.encode(1).unwrap();
            prop_assert_eq!(Sense::decode(&Packet::parse(&bytes).unwrap()).unwrap(), s);
        }
    }
}
