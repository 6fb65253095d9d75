//! What an agent tells its owner: events to act on, its mode and its counts.

use colony_proto::DecodeError;

use crate::protocol::Announcement;

/// Why a robot stopped a task it had started.
#[derive(Debug, Clone, PartialEq)]
pub enum StopReason {
    /// The announcer withdrew it (it presumed this robot failed, or no longer wants it).
    Cancelled(String),
    /// The announcer stopped renewing: it is gone, and the task with it.
    AnnouncerSilent,
    /// The robot lost a resource the task needs (a sensor failed): it gave
    /// the task up, and the announcer auctions it again.
    LostResource(String),
}

/// What the robot's owner must act on.
#[derive(Debug, Clone, PartialEq)]
pub enum AgentEvent {
    /// Start executing this task; call [`Agent::finish`](super::Agent::finish) when it is done.
    Start(Announcement),
    /// Stop executing the task (the robot is idle again).
    Stop {
        /// The task's number.
        task: u64,
        /// Its name.
        name: String,
        /// Why.
        reason: StopReason,
    },
    /// The battery is low: the robot has unsubscribed from everything; drive to a
    /// charger and call [`Agent::charged`](super::Agent::charged) when full.
    Charge,
    /// Back from charging, listening again.
    Rejoined,
    /// A task was heard but not bid for.
    Skipped {
        /// The task's number.
        task: u64,
        /// Its name.
        name: String,
        /// Why not.
        why: String,
    },
    /// A packet that is not a valid message was ignored.
    Rejected(DecodeError),
}

/// Counts of what a robot did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AgentStats {
    /// Packets received.
    pub heard: u64,
    /// Bids made.
    pub bids: u64,
    /// Tasks won and started.
    pub started: u64,
    /// Tasks finished.
    pub finished: u64,
    /// Tasks stopped before the end (cancelled or abandoned).
    pub stopped: u64,
    /// Trips to the charger.
    pub charges: u64,
    /// Packets refused as malformed or unsealed.
    pub rejected: u64,
    /// Sealed messages refused as forged: an announcer's message not sealed
    /// by the task's announcer (or a copy of one taken before), a bid in this
    /// robot's name from another key, a score no robot can reach.
    pub forged: u64,
}

/// The robot's state: idle (listening, perhaps bidding), working, or
/// charging (unsubscribed from everything). The same as its reports carry.
pub use crate::protocol::RobotMode as AgentMode;
