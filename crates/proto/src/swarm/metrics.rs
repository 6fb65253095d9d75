//! `metrics`: sorting progress, published by the world every few control steps.
//!
//! ```text
//! @ <metrics> 0
//! sort step 1200 pc 87.5
//! ```
//!
//! `pc` is the percentage completion (how many pucks lie in their kind's largest cluster).

use colony_wire::{Line, Packet, PacketBuilder, ParseError, Priority};

use crate::error::{LinePolicy, Skimmed};
use crate::fields::{count, finite, r};
use crate::table::{int, line, num, MessageTable};
use crate::DecodeError;

/// The channel the world publishes sorting progress on.
pub const METRICS: &str = "metrics";

/// What a metrics packet holds.
pub const TABLE: MessageTable = MessageTable {
    channel: METRICS,
    lines: &[line("sort", &[int("step"), num("pc")])],
};

/// How far sorting has come at one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// The world's control step.
    pub step: u64,
    /// Percentage completion, 0 to 100.
    pub pc: f64,
}

/// `progress` as one packet on [`METRICS`] (`pc` rounded to 0.01).
pub fn encode(progress: Progress) -> Result<Vec<u8>, ParseError> {
    let mut p = PacketBuilder::new([METRICS], Priority(0));
    p.line("sort")
        .field("step", progress.step)
        .field("pc", r(progress.pc));
    p.finish()
}

/// Reads the packet's `sort` line; a missing or bad one is an error.
pub fn decode(packet: &Packet<'_>) -> Result<Progress, DecodeError> {
    let line = packet.line("sort").ok_or(DecodeError::Missing("sort"))?;
    progress(&line)
}

/// Reads the packet's `sort` line for a viewer: `None` when there is none (other metrics may
/// come one day) or it is bad (and counted).
pub fn skim(packet: &Packet<'_>) -> Skimmed<Option<Progress>> {
    let mut policy = LinePolicy::skim();
    let read = packet
        .line("sort")
        .and_then(|l| policy.take(progress(&l)).ok().flatten());
    policy.skimmed(read)
}

fn progress(line: &Line<'_>) -> Result<Progress, DecodeError> {
    Ok(Progress {
        step: count(line, "step")?,
        pc: finite(line, "pc")?,
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
    fn progress_round_trips_as_the_format_says() {
        let bytes = encode(Progress {
            step: 1200,
            pc: 87.5,
        })
        .unwrap();
        assert_eq!(bytes, b"@ <metrics> 0\nsort step 1200 pc 87.5\n");
        assert_eq!(
            decode(&Packet::parse(&bytes).unwrap()).unwrap(),
            Progress {
                step: 1200,
                pc: 87.5
            }
        );
    }

    #[test]
    fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
        let bytes = encode(Progress {
            step: 1200,
            pc: 87.5,
        })
        .unwrap();
        crate::table::check::codec(&TABLE, &[bytes], |p| decode(p).is_ok());
    }

    #[test]
    fn a_viewer_counts_a_bad_line_and_ignores_a_missing_one() {
        let s = skim(&parse("@ <metrics> 0\nsort step -1 pc 3\n"));
        assert_eq!((s.message, s.bad_lines), (None, 1));
        let s = skim(&parse("@ <metrics> 0\nsort step 1 pc inf\n"));
        assert_eq!((s.message, s.bad_lines), (None, 1));
        let s = skim(&parse("@ <metrics> 0\nother x 1\n"));
        assert_eq!((s.message, s.bad_lines), (None, 0));
        assert!(matches!(
            decode(&parse("@ <metrics> 0\nother x 1\n")),
            Err(DecodeError::Missing("sort"))
        ));
    }

    proptest! {
        #[test]
        fn any_progress_round_trips_within_rounding(step in any::<u64>().prop_map(|s| s >> 1), pc in 0.0f64..100.0) {
            let got = decode(&Packet::parse(&encode(Progress { step, pc }).unwrap()).unwrap()).unwrap();
            prop_assert_eq!(got.step, step);
            prop_assert!((got.pc - pc).abs() <= 0.005 + 1e-9);
        }
    }
}
