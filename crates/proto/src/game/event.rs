//! `game.event`: what happened (hits, kills, flags, refusals, the end), for players and the log.
//!
//! ```text
//! @ <game.event> 0
//! event kind hit time 12 text "robot 3 hits robot 9 for 15 (health 45)"
//! ```

use colony_wire::{Line, Packet, PacketBuilder, ParseError, Priority};

use super::EVENT;
use crate::fields::{finite, plain_name, r, text_or_empty};
use crate::table::{line, num, text, MessageTable};
use crate::DecodeError;
use crate::Skimmed;

/// What an event packet holds.
pub const TABLE: MessageTable = MessageTable {
    channel: EVENT,
    lines: &[line(
        "event",
        &[text("kind"), num("time"), text("text").optional()],
    )],
};

/// Something that happened, for players and the log.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    /// Game time, s.
    pub time: f64,
    /// `hit`, `destroyed`, `flag-taken`, `flag-dropped`, `flag-returned`,
    /// `captured`, `refused`, `over`, `beep`.
    pub kind: String,
    /// The text a person reads.
    pub text: String,
}

impl Event {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([EVENT], Priority(0));
        p.line("event")
            .bare("kind", &self.kind)
            .field("time", r(self.time))
            .field("text", self.text.as_str());
        p.finish()
    }

    /// Reads the packet's (first) event.
    pub fn decode(packet: &Packet<'_>) -> Result<Event, DecodeError> {
        let l = packet.line("event").ok_or(DecodeError::Missing("event"))?;
        Event::read(&l)
    }

    /// Reads every `event` line of a packet for a viewer: a line that does not read is skipped
    /// and counted.
    pub fn decode_lenient(packet: &Packet<'_>) -> Skimmed<Vec<Event>> {
        let mut events = Vec::new();
        let mut skipped = 0;
        for l in packet.lines_labelled("event") {
            match Event::read(&l) {
                Ok(e) => events.push(e),
                Err(_) => skipped += 1,
            }
        }
        Skimmed {
            message: events,
            bad_lines: skipped,
        }
    }

    fn read(l: &Line<'_>) -> Result<Event, DecodeError> {
        Ok(Event {
            kind: plain_name(l, "kind")?,
            time: finite(l, "time")?,
            text: text_or_empty(l, "text")?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn events_survive_the_trip_and_a_viewer_skips_the_bad_ones() {
        let e = Event {
            time: 12.5,
            kind: "refused".into(),
            text: "squad zulu: no such squad".into(),
        };
        let bytes = e.encode().unwrap();
        assert_eq!(Event::decode(&Packet::parse(&bytes).unwrap()).unwrap(), e);
        crate::table::check::codec(&TABLE, std::slice::from_ref(&bytes), |p| {
            Event::decode(p).is_ok()
        });
        let p = Packet::parse(
            b"@ <game.event> 0\nevent kind hit time 1 text a\nevent kind \"two words\" time 1\nevent time 1\nevent kind over time 2\n",
        )
        .unwrap();
        let read = Event::decode_lenient(&p);
        assert_eq!(read.bad_lines, 2);
        assert_eq!(
            read.message
                .iter()
                .map(|e| e.kind.as_str())
                .collect::<Vec<_>>(),
            ["hit", "over"]
        );
        assert_eq!(read.message[1].text, "", "a missing text reads as empty");
    }

    proptest! {
        #[test]
        fn any_event_reencodes_to_itself(
            kind in "[a-z][a-z-]{0,20}", time in 0f64..1e5, text in "\\PC{0,80}",
        ) {
            let e = Event { time: r(time), kind, text };
            let bytes = e.encode().unwrap();
            prop_assert_eq!(Event::decode(&Packet::parse(&bytes).unwrap()).unwrap(), e);
        }
    }
}
