//! MURDOCH's messages (Gerkey and Matarić's resource-centric task allocation):
//! the resource sets and tokens they are addressed by, tasks, announcements
//! and everything said on a negotiation subject, each written and read here
//! once. The agents, announcers and user agents that speak them are
//! `colony-tasks`.
//!
//! | module | what it holds |
//! |---|---|
//! | [`resource`] | [`ResourceSet`], [`IDLE`], [`negotiation_subject`]: the whole of MURDOCH's addressing |
//! | [`token`] | [`Token`], the short name a bidder or announcer gives itself |
//! | [`task`] | [`TaskSpec`]: a task as a user writes it |
//! | [`announce`] | [`Announcement`]: a task on offer |
//! | [`negotiate`] | [`Negotiation`], [`Bid`]: bids, awards, renewals, the end of a task |
//! | [`robot`] | [`RobotReport`]: a robot's mode, battery, resources and task, for watchers |
//! | [`fields`] | the limits every reader holds values to ([`MAX_MAGNITUDE`], ...) |
//! | [`error`] | [`EncodeError`]; reading fails with the crate's [`DecodeError`] |
//!
//! # The messages
//!
//! One message per packet, priority 0. Scores are costs: the lowest wins, and
//! equal scores go to the lowest bidder token, so every listener picks the same
//! winner. `deadline_ms` is relative (bids are taken for that long after the
//! announcement is heard), so robots need no common clock.
//!
//! ```text
//! @ <camera> <laser> <mobile> <idle> 0          announcer → capable idle robots
//! task name sentry-duty id 17 negotiation murdoch.user.17.1 deadline_ms 200 length_s 120 announcer user
//! param name x value 350.0
//! param name color value "red"
//! metric name distance weight 1.0
//! metric name battery weight 200.0
//!
//! @ <murdoch.user.17.1> 0                        each capable robot → everyone negotiating
//! bid task 17 bidder r2 score 182.5
//!
//! @ <murdoch.user.17.1> 0                        announcer, at the deadline
//! award task 17 winner r2 score 182.5 bids 3
//!
//! @ <murdoch.user.17.1> 0                        the winner takes it and starts
//! ack task 17 bidder r2
//!
//! @ <murdoch.user.17.1> 0                        a bidder withdraws, or turns an award down
//! decline task 17 bidder r5
//!
//! @ <murdoch.user.17.1> 0                        both ways while the task runs
//! renew task 17 by r2 progress 0.4
//! @ <murdoch.user.17.1> 0
//! renew task 17 by user
//!
//! @ <murdoch.user.17.1> 0                        the winner, at the end
//! done task 17 bidder r2
//!
//! @ <murdoch.user.17.1> 0                        the winner gives up
//! abandon task 17 bidder r2 reason "announcer user silent for 3.0 s"
//!
//! @ <murdoch.user.17.1> 0                        the announcer withdraws it (then auctions it again on .2)
//! cancel task 17 reason "presumed failed: no renewal for 3.0 s"
//!
//! @ <murdoch.user.17.2> 0                        nobody bid
//! unachievable task 17 name sentry-duty reason "no robot with {camera laser mobile} is available"
//!
//! @ <murdoch.robots> 0                           every robot, about once a second, for watchers
//! robot name r2 mode working battery 0.82 resources "camera laser mobile" task 17 task_name sentry-duty
//! ```
//!
//! [`Message::decode`] refuses anything else with the line and field at
//! fault ([`DecodeError`]) and never panics (a property
//! test and a fuzz target hold it to that); a refused packet changes no
//! auction.

pub mod announce;
pub mod error;
pub mod fields;
pub mod negotiate;
pub mod resource;
pub mod robot;
pub mod task;
pub mod token;

pub use announce::Announcement;
pub use error::EncodeError;
pub use fields::{valid_name, MAX_DEADLINE, MAX_LENGTH_S, MAX_MAGNITUDE, MAX_TEXT};
pub use negotiate::{Bid, Negotiation};
pub use resource::{
    negotiation_subject, ResourceError, ResourceSet, IDLE, MAX_TASK_RESOURCES, NEGOTIATION_PREFIX,
};
pub use robot::{RobotMode, RobotReport, ROBOTS};
pub use task::{MetricTerm, Param, ParamValue, SpecError, TaskSpec, MAX_METRICS, MAX_PARAMS};
pub use token::{Token, TokenError, MAX_TOKEN_LEN};

use colony_wire::{Packet, Subject};

use crate::DecodeError;

/// Every label a MURDOCH message's first line may carry, as an error lists them.
pub(crate) const MESSAGES: &str =
    "task, bid, award, ack, decline, renew, done, abandon, cancel, unachievable or robot";

/// The labels of the messages on a negotiation subject.
const NEGOTIATION_LABELS: [&str; 9] = [
    "bid",
    "award",
    "ack",
    "decline",
    "renew",
    "done",
    "abandon",
    "cancel",
    "unachievable",
];

/// Any MURDOCH message.
#[derive(Debug, Clone, PartialEq)]
pub enum Message {
    /// A task on offer, addressed to its resources and `idle`.
    Announce(Announcement),
    /// A robot's report of itself, on [`ROBOTS`].
    Robot(RobotReport),
    /// A message on a negotiation subject.
    Negotiation {
        /// The subject it came on.
        subject: Subject,
        /// What it says.
        message: Negotiation,
    },
}

impl Message {
    /// Reads a message from a packet: an announcement if its first line is
    /// `task`, a robot's report if it is `robot`, otherwise a negotiation message, whose header must be a single
    /// `murdoch.` subject. Lines after a negotiation message's first are ignored,
    /// so later versions can add some.
    pub fn decode(packet: &Packet<'_>) -> Result<Message, DecodeError> {
        let first = packet.lines().next().ok_or(DecodeError::Empty)?;
        if first.label() == "task" {
            return Announcement::decode(packet).map(Message::Announce);
        }
        if first.label() == "robot" {
            let mut subjects = packet.subjects();
            return match (subjects.next(), subjects.next()) {
                (Some(ROBOTS), None) => RobotReport::decode_line(&first).map(Message::Robot),
                _ => Err(DecodeError::Header(format!(
                    "a `robot` report goes to <{ROBOTS}> alone, not to {}",
                    packet.subjects_text()
                ))),
            };
        }
        if !NEGOTIATION_LABELS.contains(&first.label()) {
            return Err(DecodeError::UnknownMessage {
                line: first.number(),
                label: first.label().to_owned(),
                expected: MESSAGES,
            });
        }
        let mut subjects = packet.subjects();
        let subject = match (subjects.next(), subjects.next()) {
            (Some(s), None) if s.starts_with(NEGOTIATION_PREFIX) => {
                Subject::new(s).map_err(|e| DecodeError::Header(e.to_string()))?
            }
            _ => {
                return Err(DecodeError::Header(format!(
                    "a `{}` message goes to one `{NEGOTIATION_PREFIX}` subject, not to {}",
                    first.label(),
                    packet.subjects_text()
                )))
            }
        };
        let message = Negotiation::decode_line(&first)?;
        Ok(Message::Negotiation { subject, message })
    }

    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        match self {
            Message::Announce(a) => a.encode(),
            Message::Robot(r) => r.encode(),
            Message::Negotiation { subject, message } => message.encode(subject),
        }
    }

    /// Parses and reads a datagram.
    pub fn decode_bytes(bytes: &[u8]) -> Result<Message, DecodeError> {
        Message::decode(&Packet::parse(bytes)?)
    }
}
