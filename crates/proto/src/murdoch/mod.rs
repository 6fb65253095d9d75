//! MURDOCH's messages (Gerkey and Matarić's resource-centric task allocation):
//! the resource sets and tokens they are addressed by, tasks, announcements
//! and everything said on a negotiation subject, each written and read here
//! once. The agents, announcers and user agents that speak them are
//! `colony-tasks`.
//!
//! | module | what it holds |
//! |---|---|
//! | [`resource`] | [`ResourceSet`], [`IDLE`], [`negotiation_subject`] and its inverse [`parse_negotiation_subject`]: the whole of MURDOCH's addressing |
//! | [`token`] | [`Token`], the short name a bidder or announcer gives itself |
//! | [`task`] | [`TaskSpec`]: a task as a user writes it |
//! | [`announce`] | [`Announcement`]: a task on offer |
//! | [`negotiate`] | [`Negotiation`], [`Bid`]: bids, awards, renewals, the end of a task |
//! | [`robot`] | [`RobotReport`]: a robot's mode, battery, resources and task, for watchers |
//! | [`crate::fields`] | the limits every reader holds values to ([`MAX_MAGNITUDE`], ...), shared with the other messages |
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
//!
//! # Who may say what
//!
//! Every message is sealed ([`colony_wire::seal`]: a last line `seal n N key K
//! sig S`, an Ed25519 signature under a key each agent and announcer makes for
//! itself), and agents and announcers act only on sealed messages
//! ([`Message::open`]). A task's messages are bound to their senders' keys:
//! - the key that sealed an announcement is the task's announcer: only it may
//!   award, cancel, renew as the announcer or call the task unachievable;
//! - the key that sealed a bidder's first bid in an auction is that bidder:
//!   only it may bid again, decline, acknowledge, renew, finish or abandon
//!   under that bidder's token in that auction;
//! - a sealed message is taken once, and only after every earlier one from its
//!   key ([`colony_wire::seal::Counter`]), so a copy sent again keeps no task
//!   alive;
//! - a bid's score lies within what the task's metrics can add up to
//!   ([`TaskSpec::score_bounds`]).
//!
//! Seals say who spoke, not who may take part: on an open hub anyone can
//! announce tasks or bid for them under a token of their own. A hub run with
//! `--auth-all` (and every agent and announcer with its `--key`) admits only
//! holders of its key.

pub mod announce;
pub mod error;
pub mod negotiate;
pub mod resource;
pub mod robot;
pub mod task;
pub mod token;

pub use crate::fields::{valid_subject_name as valid_name, MAX_DEADLINE, MAX_MAGNITUDE, MAX_TEXT};
pub use announce::Announcement;
pub use error::EncodeError;
pub use negotiate::{Bid, Negotiation};
pub use resource::{
    negotiation_subject, parse_negotiation_subject, ResourceError, ResourceSet, IDLE,
    MAX_TASK_RESOURCES, NEGOTIATION_PREFIX,
};
pub use robot::{RobotMode, RobotReport, ROBOTS};
pub use task::{
    MetricTerm, Param, ParamValue, SpecError, TaskSpec, MAX_LENGTH_S, MAX_METRICS,
    MAX_METRIC_VALUE, MAX_PARAMS,
};
pub use token::{Token, TokenError, MAX_TOKEN_LEN};

use colony_wire::seal::{self, Identity, PublicKey};
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

/// A message whose seal checked out, with who sealed it.
#[derive(Debug, Clone, PartialEq)]
pub struct Signed {
    /// What it says.
    pub message: Message,
    /// The key that sealed it: who said it.
    pub key: PublicKey,
    /// Its count among the messages that key sealed.
    pub n: u64,
}

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
    /// Reads a sealed message and checks its seal: what an agent or an
    /// announcer acts on. An unsealed packet is refused.
    pub fn open(packet: &Packet<'_>) -> Result<Signed, DecodeError> {
        let sealed = seal::open(packet.as_str().as_bytes())?;
        let message = Message::decode_unsealed(&Packet::parse(sealed.body)?)?;
        Ok(Signed {
            message,
            key: sealed.key,
            n: sealed.n,
        })
    }

    /// Reads a message, sealed or not, without checking a seal: for watchers
    /// that only show what was said (the monitor's task board).
    pub fn decode(packet: &Packet<'_>) -> Result<Message, DecodeError> {
        let bytes = packet.as_str().as_bytes();
        let body = seal::strip(bytes);
        if body.len() == bytes.len() {
            Message::decode_unsealed(packet)
        } else {
            Message::decode_unsealed(&Packet::parse(body)?)
        }
    }

    /// Reads a message from a packet: an announcement if its first line is
    /// `task`, a robot's report if it is `robot`, otherwise a negotiation message, whose header must be a single
    /// `murdoch.` subject. Lines after a negotiation message's first are ignored,
    /// so later versions can add some.
    fn decode_unsealed(packet: &Packet<'_>) -> Result<Message, DecodeError> {
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

    /// The packet, sealed by `identity`.
    pub fn seal(&self, identity: &mut Identity) -> Result<Vec<u8>, EncodeError> {
        Ok(identity.sealed(self.encode()?))
    }

    /// Parses and reads a datagram (its seal unchecked, as [`Message::decode`]).
    pub fn decode_bytes(bytes: &[u8]) -> Result<Message, DecodeError> {
        Message::decode(&Packet::parse(bytes)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn done() -> Message {
        Message::Negotiation {
            subject: negotiation_subject(&Token::new("u").unwrap(), 17, 1),
            message: Negotiation::Done {
                task: 17,
                bidder: Token::new("r2").unwrap(),
            },
        }
    }

    #[test]
    fn a_sealed_message_opens_with_its_key_and_reads_as_before() {
        let mut id = Identity::from_seed([7; 32]);
        let bytes = done().seal(&mut id).unwrap();
        let packet = Packet::parse(&bytes).unwrap();
        let signed = Message::open(&packet).unwrap();
        assert_eq!(signed.message, done());
        assert_eq!((signed.key, signed.n), (id.public(), 1));
        // Watchers read it as any other message.
        assert_eq!(Message::decode(&packet).unwrap(), done());
    }

    #[test]
    fn an_unsealed_or_altered_message_does_not_open() {
        let plain = done().encode().unwrap();
        let packet = Packet::parse(&plain).unwrap();
        assert!(matches!(Message::open(&packet), Err(DecodeError::Seal(_))));
        assert_eq!(Message::decode(&packet).unwrap(), done());
        let mut id = Identity::from_seed([8; 32]);
        let sealed = String::from_utf8(done().seal(&mut id).unwrap()).unwrap();
        let forged = sealed.replace("bidder r2", "bidder r3");
        let packet = Packet::parse(forged.as_bytes()).unwrap();
        assert!(matches!(Message::open(&packet), Err(DecodeError::Seal(_))));
    }

    #[test]
    fn a_sealed_announcement_reads_with_its_params() {
        let ann = Announcement {
            spec: TaskSpec::new("goto", "mobile".parse().unwrap())
                .length(10.0)
                .param("x", 3.0)
                .metric("distance", 1.0),
            id: 4,
            negotiation: negotiation_subject(&Token::new("u").unwrap(), 4, 1),
            deadline: std::time::Duration::from_millis(200),
            announcer: Token::new("u").unwrap(),
        };
        let mut id = Identity::from_seed([9; 32]);
        let bytes = Message::Announce(ann.clone()).seal(&mut id).unwrap();
        let signed = Message::open(&Packet::parse(&bytes).unwrap()).unwrap();
        assert_eq!(signed.message, Message::Announce(ann.clone()));
        assert_eq!(
            Message::decode_bytes(&bytes).unwrap(),
            Message::Announce(ann)
        );
    }
}
