//! Everything said on a task's negotiation subject, from the first bid to the end.

use colony_wire::{Line, PacketBuilder, Priority, Subject};

use super::error::{unwritable, EncodeError};
use super::{Token, MESSAGES, NEGOTIATION_PREFIX};
use crate::fields::{self, clip, valid_subject_name as valid_name};
use crate::table::{int, line, num, text, MessageTable};
use crate::DecodeError;

/// What a negotiation packet holds, on every `murdoch.` negotiation subject: one line, whose
/// label says which message it is.
pub const TABLE: MessageTable = MessageTable {
    channel: NEGOTIATION_PREFIX,
    lines: &[
        line("bid", &[int("task"), text("bidder"), num("score")]),
        line(
            "award",
            &[int("task"), text("winner"), num("score"), int("bids")],
        ),
        line("ack", &[int("task"), text("bidder")]),
        line("decline", &[int("task"), text("bidder")]),
        line(
            "renew",
            &[int("task"), text("by"), num("progress").optional()],
        ),
        line("done", &[int("task"), text("bidder")]),
        line("abandon", &[int("task"), text("bidder"), text("reason")]),
        line("cancel", &[int("task"), text("reason")]),
        line("unachievable", &[int("task"), text("name"), text("reason")]),
    ],
};

/// A robot's offer: its score for the task (a cost: lowest wins).
#[derive(Debug, Clone, PartialEq)]
pub struct Bid {
    /// The task's number.
    pub task: u64,
    /// Who bids.
    pub bidder: Token,
    /// Its score, the weighted sum of the task's metrics.
    pub score: f64,
}

impl Bid {
    /// Whether this bid beats `other`: a lower score, or the same score and a
    /// lower bidder token, so every listener picks the same winner.
    pub fn beats(&self, other: &Bid) -> bool {
        (self.score, &self.bidder) < (other.score, &other.bidder)
    }
}

/// One message on a negotiation subject.
#[derive(Debug, Clone, PartialEq)]
pub enum Negotiation {
    /// `bid`: a capable robot's score.
    Bid(Bid),
    /// `award`: the announcer closes the auction and names the best bid it heard.
    Award {
        /// The task's number.
        task: u64,
        /// Who won.
        winner: Token,
        /// The winning score.
        score: f64,
        /// How many bids were heard.
        bids: u32,
    },
    /// `ack`: the winner takes the task and starts.
    Ack {
        /// The task's number.
        task: u64,
        /// The winner.
        bidder: Token,
    },
    /// `decline`: a bidder withdraws its bid, or turns down an award it can no
    /// longer take (it took another task meanwhile).
    Decline {
        /// The task's number.
        task: u64,
        /// Who declines.
        bidder: Token,
    },
    /// `renew`: "still here"; the winner adds how far along it is.
    Renew {
        /// The task's number.
        task: u64,
        /// Who renews: the winner or the announcer.
        by: Token,
        /// The winner's progress, 0 to 1.
        progress: Option<f64>,
    },
    /// `done`: the winner finished the task.
    Done {
        /// The task's number.
        task: u64,
        /// The winner.
        bidder: Token,
    },
    /// `abandon`: the winner gives the task up.
    Abandon {
        /// The task's number.
        task: u64,
        /// The winner.
        bidder: Token,
        /// Why.
        reason: String,
    },
    /// `cancel`: the announcer withdraws the task (it presumed the winner failed,
    /// or no longer needs it).
    Cancel {
        /// The task's number.
        task: u64,
        /// Why.
        reason: String,
    },
    /// `unachievable`: no robot could take the task; the reason names what is missing.
    Unachievable {
        /// The task's number.
        task: u64,
        /// The task's name.
        name: String,
        /// Why, as the introducer is told.
        reason: String,
    },
}

impl Negotiation {
    /// The task the message is about.
    pub fn task(&self) -> u64 {
        match self {
            Negotiation::Bid(b) => b.task,
            Negotiation::Award { task, .. }
            | Negotiation::Ack { task, .. }
            | Negotiation::Decline { task, .. }
            | Negotiation::Renew { task, .. }
            | Negotiation::Done { task, .. }
            | Negotiation::Abandon { task, .. }
            | Negotiation::Cancel { task, .. }
            | Negotiation::Unachievable { task, .. } => *task,
        }
    }

    /// The line's label.
    pub fn label(&self) -> &'static str {
        match self {
            Negotiation::Bid(_) => "bid",
            Negotiation::Award { .. } => "award",
            Negotiation::Ack { .. } => "ack",
            Negotiation::Decline { .. } => "decline",
            Negotiation::Renew { .. } => "renew",
            Negotiation::Done { .. } => "done",
            Negotiation::Abandon { .. } => "abandon",
            Negotiation::Cancel { .. } => "cancel",
            Negotiation::Unachievable { .. } => "unachievable",
        }
    }

    /// The packet, addressed to `negotiation` alone. Refuses a message
    /// [`Message::decode`](super::Message::decode) would refuse.
    pub fn encode(&self, negotiation: &Subject) -> Result<Vec<u8>, EncodeError> {
        self.check(negotiation)?;
        let mut p = PacketBuilder::new([negotiation.as_str()], Priority(0));
        let mut l = p.line(self.label());
        l.field("task", self.task());
        match self {
            Negotiation::Bid(b) => {
                l.bare("bidder", b.bidder.as_str()).field("score", b.score);
            }
            Negotiation::Award {
                winner,
                score,
                bids,
                ..
            } => {
                l.bare("winner", winner.as_str())
                    .field("score", *score)
                    .field("bids", *bids);
            }
            Negotiation::Ack { bidder, .. }
            | Negotiation::Decline { bidder, .. }
            | Negotiation::Done { bidder, .. } => {
                l.bare("bidder", bidder.as_str());
            }
            Negotiation::Renew { by, progress, .. } => {
                l.bare("by", by.as_str());
                if let Some(p) = progress {
                    l.field("progress", *p);
                }
            }
            Negotiation::Abandon { bidder, reason, .. } => {
                l.bare("bidder", bidder.as_str())
                    .field("reason", clip(reason).as_str());
            }
            Negotiation::Cancel { reason, .. } => {
                l.field("reason", clip(reason).as_str());
            }
            Negotiation::Unachievable { name, reason, .. } => {
                l.bare("name", name).field("reason", clip(reason).as_str());
            }
        }
        Ok(p.finish()?)
    }

    /// Everything [`decode_line`](Negotiation::decode_line) and the header
    /// check would refuse that the types allow.
    fn check(&self, negotiation: &Subject) -> Result<(), EncodeError> {
        if !negotiation.as_str().starts_with(NEGOTIATION_PREFIX) {
            return Err(unwritable(
                "subject",
                format!("<{negotiation}> is not a `{NEGOTIATION_PREFIX}` subject"),
            ));
        }
        fields::writable_task_number("task", self.task())?;
        match self {
            Negotiation::Bid(Bid { score, .. }) | Negotiation::Award { score, .. } => {
                fields::writable_finite("score", *score)
            }
            Negotiation::Renew {
                progress: Some(p), ..
            } if !(0.0..=1.0).contains(p) => Err(unwritable(
                "progress",
                format!("{p} is not between 0 and 1"),
            )),
            Negotiation::Unachievable { name, .. } if !valid_name(name) => Err(unwritable(
                "name",
                format!(
                    "`{}` is not a name: use 1 to 64 characters of A-Z a-z 0-9 _ - . : /",
                    clip(name)
                ),
            )),
            _ => Ok(()),
        }
    }

    /// Reads one message from its line (the packet's first).
    pub(crate) fn decode_line(line: &Line<'_>) -> Result<Negotiation, DecodeError> {
        let task = fields::task_number(line, "task")?;
        let bidder = || fields::token(line, "bidder");
        Ok(match line.label() {
            "bid" => Negotiation::Bid(Bid {
                task,
                bidder: bidder()?,
                score: fields::finite_within_magnitude(line, "score")?,
            }),
            "award" => Negotiation::Award {
                task,
                winner: fields::token(line, "winner")?,
                score: fields::finite_within_magnitude(line, "score")?,
                bids: fields::tally(line, "bids")?,
            },
            "ack" => Negotiation::Ack {
                task,
                bidder: bidder()?,
            },
            "decline" => Negotiation::Decline {
                task,
                bidder: bidder()?,
            },
            "renew" => Negotiation::Renew {
                task,
                by: fields::token(line, "by")?,
                progress: match line.get("progress") {
                    Some(_) => Some(fields::fraction(line, "progress")?),
                    None => None,
                },
            },
            "done" => Negotiation::Done {
                task,
                bidder: bidder()?,
            },
            "abandon" => Negotiation::Abandon {
                task,
                bidder: bidder()?,
                reason: fields::clipped_text(line, "reason")?,
            },
            "cancel" => Negotiation::Cancel {
                task,
                reason: fields::clipped_text(line, "reason")?,
            },
            "unachievable" => Negotiation::Unachievable {
                task,
                name: fields::subject_name(line, "name")?,
                reason: fields::clipped_text(line, "reason")?,
            },
            other => {
                return Err(DecodeError::UnknownMessage {
                    line: line.number(),
                    label: other.to_owned(),
                    expected: MESSAGES,
                })
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use colony_wire::Packet;

    use super::*;
    use crate::murdoch::negotiation_subject;
    use crate::murdoch::{Message, MAX_TEXT, NEGOTIATION_LABELS};

    fn token(s: &str) -> Token {
        Token::new(s).unwrap()
    }

    fn subject() -> Subject {
        negotiation_subject(&token("user"), 17, 1)
    }

    fn bid(bidder: &str, score: f64) -> Bid {
        Bid {
            task: 17,
            bidder: token(bidder),
            score,
        }
    }

    fn every(task: u64) -> Vec<Negotiation> {
        let t = token("r2");
        vec![
            Negotiation::Bid(Bid {
                task,
                bidder: t.clone(),
                score: 1.0,
            }),
            Negotiation::Award {
                task,
                winner: t.clone(),
                score: 1.0,
                bids: 2,
            },
            Negotiation::Ack {
                task,
                bidder: t.clone(),
            },
            Negotiation::Decline {
                task,
                bidder: t.clone(),
            },
            Negotiation::Renew {
                task,
                by: t.clone(),
                progress: None,
            },
            Negotiation::Done {
                task,
                bidder: t.clone(),
            },
            Negotiation::Abandon {
                task,
                bidder: t,
                reason: "tired".into(),
            },
            Negotiation::Cancel {
                task,
                reason: "no longer needed".into(),
            },
            Negotiation::Unachievable {
                task,
                name: "goto".into(),
                reason: "nobody".into(),
            },
        ]
    }

    fn round_trip(m: &Negotiation) -> Negotiation {
        let bytes = m.encode(&subject()).unwrap();
        match Message::decode_bytes(&bytes).unwrap() {
            Message::Negotiation {
                subject: s,
                message,
            } => {
                assert_eq!(s, subject());
                message
            }
            other => panic!("read back as {other:?}"),
        }
    }

    fn decode(text: &str) -> Result<Negotiation, DecodeError> {
        let packet = Packet::parse(text.as_bytes()).unwrap();
        Negotiation::decode_line(&packet.lines().next().unwrap())
    }

    #[test]
    fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
        let mut all = every(17);
        all.push(Negotiation::Renew {
            task: 17,
            by: token("user"),
            progress: Some(0.4),
        });
        let samples: Vec<Vec<u8>> = all.iter().map(|m| m.encode(&subject()).unwrap()).collect();
        crate::table::check::codec(&TABLE, &samples, |p| {
            matches!(Message::decode(p), Ok(Message::Negotiation { .. }))
        });
    }

    #[test]
    fn the_lower_score_beats_the_higher() {
        assert!(bid("zulu", 1.0).beats(&bid("alpha", 2.0)));
        assert!(!bid("alpha", 2.0).beats(&bid("zulu", 1.0)));
        assert!(bid("r", -5.0).beats(&bid("r", 0.0)));
    }

    #[test]
    fn equal_scores_go_to_the_lower_token() {
        assert!(bid("alpha", 3.0).beats(&bid("bravo", 3.0)));
        assert!(!bid("bravo", 3.0).beats(&bid("alpha", 3.0)));
        // Byte order: upper case before lower, digits before letters.
        assert!(bid("Zed", 3.0).beats(&bid("abe", 3.0)));
        assert!(bid("r10", 3.0).beats(&bid("r9", 3.0)));
    }

    #[test]
    fn signed_zeros_tie_and_the_token_decides() {
        assert!(bid("a", 0.0).beats(&bid("b", -0.0)));
        assert!(!bid("b", -0.0).beats(&bid("a", 0.0)));
    }

    #[test]
    fn no_bid_beats_itself() {
        let b = bid("r1", 4.0);
        assert!(!b.beats(&b.clone()));
    }

    #[test]
    fn every_label_is_one_the_decoder_routes_to_a_negotiation() {
        let labels: Vec<&str> = every(1).iter().map(Negotiation::label).collect();
        assert_eq!(labels, NEGOTIATION_LABELS);
    }

    #[test]
    fn every_message_names_its_task_and_reads_back() {
        for m in every(99) {
            assert_eq!(m.task(), 99, "{m:?}");
            assert_eq!(round_trip(&m), m);
        }
    }

    #[test]
    fn a_renewal_without_progress_writes_no_progress_field() {
        let m = Negotiation::Renew {
            task: 17,
            by: token("user"),
            progress: None,
        };
        let text = String::from_utf8(m.encode(&subject()).unwrap()).unwrap();
        assert_eq!(text, "@ <murdoch.user.17.1> 0\nrenew task 17 by user\n");
    }

    #[test]
    fn progress_at_both_ends_reads_back() {
        for p in [0.0, 1.0] {
            let m = Negotiation::Renew {
                task: 1,
                by: token("r1"),
                progress: Some(p),
            };
            assert_eq!(round_trip(&m), m);
        }
    }

    #[test]
    fn a_long_reason_is_clipped_on_the_wire() {
        let reason = "é".repeat(MAX_TEXT + 100);
        let m = Negotiation::Cancel {
            task: 1,
            reason: reason.clone(),
        };
        let Negotiation::Cancel { reason: back, .. } = round_trip(&m) else {
            panic!("not a cancel");
        };
        assert_eq!(back, clip(&reason));
        assert_eq!(back.chars().count(), MAX_TEXT);
    }

    #[test]
    fn a_reason_with_quotes_and_newlines_reads_back() {
        let m = Negotiation::Abandon {
            task: 3,
            bidder: token("r1"),
            reason: "said \"no\"\nthen left\t\\".into(),
        };
        assert_eq!(round_trip(&m), m);
    }

    #[test]
    fn the_largest_counts_and_task_numbers_read_back() {
        let m = Negotiation::Award {
            task: i64::MAX as u64,
            winner: token("r1"),
            score: -1e12,
            bids: u32::MAX,
        };
        assert_eq!(round_trip(&m), m);
    }

    #[test]
    fn unknown_fields_on_the_line_are_ignored() {
        assert_eq!(
            decode("@ <murdoch.user.17.1> 0\nbid task 17 bidder r2 score 5 eta 30\n"),
            Ok(Negotiation::Bid(bid("r2", 5.0)))
        );
    }

    #[test]
    fn a_quoted_token_reads_as_the_token() {
        assert_eq!(
            decode("@ <murdoch.user.17.1> 0\ndone task 17 bidder \"r2\"\n"),
            Ok(Negotiation::Done {
                task: 17,
                bidder: token("r2")
            })
        );
    }

    #[test]
    fn a_renewal_with_unreadable_progress_is_refused_not_treated_as_none() {
        let e = decode("@ <murdoch.user.17.1> 0\nrenew task 17 by r2 progress lots\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`progress`"), "{e}");
    }

    #[test]
    fn an_unknown_label_is_named_with_its_line() {
        assert_eq!(
            decode("@ <murdoch.user.17.1> 0\nhello task 17\n"),
            Err(DecodeError::UnknownMessage {
                line: 2,
                label: "hello".into(),
                expected: MESSAGES,
            })
        );
    }

    #[test]
    fn the_task_number_is_read_before_the_label_is_judged() {
        let e = decode("@ <murdoch.user.17.1> 0\nhello\n").unwrap_err();
        assert!(e.to_string().contains("`task`"), "{e}");
    }

    fn refusal(m: &Negotiation, on: &Subject) -> String {
        match m.encode(on) {
            Ok(bytes) => panic!("{m:?} was written as {:?}", String::from_utf8_lossy(&bytes)),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn a_score_no_reader_accepts_is_not_written() {
        for score in [f64::NAN, f64::INFINITY, 1.5e12, -1e13] {
            let e = refusal(&Negotiation::Bid(bid("r1", score)), &subject());
            assert!(e.contains("`score`"), "{score}: {e}");
            let award = Negotiation::Award {
                task: 1,
                winner: token("r1"),
                score,
                bids: 1,
            };
            assert!(refusal(&award, &subject()).contains("`score`"));
        }
    }

    #[test]
    fn progress_outside_zero_to_one_is_not_written() {
        for p in [1.5, -0.1, f64::NAN] {
            let m = Negotiation::Renew {
                task: 1,
                by: token("r1"),
                progress: Some(p),
            };
            let e = refusal(&m, &subject());
            assert!(e.contains("`progress`"), "{p}: {e}");
        }
    }

    #[test]
    fn a_task_number_beyond_a_packets_integers_is_not_written() {
        let m = Negotiation::Ack {
            task: i64::MAX as u64 + 1,
            bidder: token("r1"),
        };
        assert!(refusal(&m, &subject()).contains("`task`"));
    }

    #[test]
    fn an_unachievable_task_name_that_is_not_a_name_is_not_written() {
        // Written bare, `a b c` would read back as the name `a`.
        for name in ["a b c", "", "x\"y"] {
            let m = Negotiation::Unachievable {
                task: 1,
                name: name.into(),
                reason: "r".into(),
            };
            assert!(refusal(&m, &subject()).contains("`name`"), "{name:?}");
        }
    }

    #[test]
    fn a_negotiation_message_goes_only_to_a_negotiation_subject() {
        let camera = Subject::new("camera").unwrap();
        let e = refusal(&Negotiation::Bid(bid("r1", 1.0)), &camera);
        assert!(e.contains("<camera>") && e.contains("murdoch."), "{e}");
    }
}
