//! What an announcer reports: events, each task's phase, and its counts.

use crate::protocol::Token;

/// What happened to an announced task.
#[derive(Debug, Clone, PartialEq)]
pub enum AnnouncerEvent {
    /// An auction opened (`attempt` counts from 1; more means a re-auction).
    Announced {
        /// The task's number.
        task: u64,
        /// Its name.
        name: String,
        /// Which auction of this task.
        attempt: u32,
    },
    /// A bid arrived in time.
    Bid {
        /// The task's number.
        task: u64,
        /// Who bid.
        bidder: Token,
        /// Its score.
        score: f64,
    },
    /// The auction closed with a winner.
    Awarded {
        /// The task's number.
        task: u64,
        /// Its name.
        name: String,
        /// The winner.
        winner: Token,
        /// Its score.
        score: f64,
        /// How many bids were heard.
        bids: u32,
    },
    /// The winner acknowledged and started.
    Started {
        /// The task's number.
        task: u64,
        /// The winner.
        winner: Token,
    },
    /// The winner finished.
    Completed {
        /// The task's number.
        task: u64,
        /// Its name.
        name: String,
        /// Who did it.
        winner: Token,
    },
    /// The winner failed, declined or abandoned; a new auction follows.
    WinnerLost {
        /// The task's number.
        task: u64,
        /// Its name.
        name: String,
        /// The lost winner.
        winner: Token,
        /// What happened.
        reason: String,
    },
    /// No robot could take the task; it is dropped. The reason is for the introducer.
    Unachievable {
        /// The task's number.
        task: u64,
        /// Its name.
        name: String,
        /// For example "no robot with {camera laser mobile} is available".
        reason: String,
    },
    /// Withdrawn by [`Announcer::cancel`](super::Announcer::cancel).
    Cancelled {
        /// The task's number.
        task: u64,
    },
}

/// Where a task stands.
#[derive(Debug, Clone, PartialEq)]
pub enum TaskPhase {
    /// Taking bids.
    Bidding,
    /// Awarded, waiting for the acknowledgement.
    Awarded(Token),
    /// Being executed.
    Running(Token),
}

/// Counts of what an announcer did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AnnouncerStats {
    /// Auctions opened (re-auctions included).
    pub auctions: u64,
    /// Bids heard in time.
    pub bids: u64,
    /// Auctions closed with a winner.
    pub awards: u64,
    /// Tasks finished.
    pub completed: u64,
    /// Winners lost (failed, declined, abandoned).
    pub lost: u64,
    /// Tasks reported unachievable.
    pub unachievable: u64,
    /// Packets received that were not valid messages, or not sealed.
    pub rejected: u64,
    /// Sealed messages refused as forged: a bidder's message from a key other
    /// than the one that made its first bid (the winner's, once awarded), a
    /// copy of one taken before, a score no robot can reach.
    pub forged: u64,
}
