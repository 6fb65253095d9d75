//! Everything said on a task's negotiation subject, from the first bid to the end.

use colony_wire::{Line, PacketBuilder, Priority, Subject};

use super::error::{DecodeError, EncodeError};
use super::fields::{self, clip};
use crate::resource::Token;

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

    /// The packet, addressed to `negotiation` alone.
    pub fn encode(&self, negotiation: &Subject) -> Result<Vec<u8>, EncodeError> {
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

    /// Reads one message from its line (the packet's first).
    pub(crate) fn decode_line(line: &Line<'_>) -> Result<Negotiation, DecodeError> {
        let task = fields::task_number(line, "task")?;
        let bidder = || fields::token(line, "bidder");
        Ok(match line.label() {
            "bid" => Negotiation::Bid(Bid {
                task,
                bidder: bidder()?,
                score: fields::finite(line, "score")?,
            }),
            "award" => Negotiation::Award {
                task,
                winner: fields::token(line, "winner")?,
                score: fields::finite(line, "score")?,
                bids: fields::count(line, "bids")?,
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
                reason: fields::text(line, "reason")?,
            },
            "cancel" => Negotiation::Cancel {
                task,
                reason: fields::text(line, "reason")?,
            },
            "unachievable" => Negotiation::Unachievable {
                task,
                name: fields::name(line, "name")?,
                reason: fields::text(line, "reason")?,
            },
            other => {
                return Err(DecodeError::UnknownMessage {
                    line: line.number(),
                    label: other.to_owned(),
                })
            }
        })
    }
}
