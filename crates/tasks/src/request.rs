//! One task introduced into a running system, from anywhere: a user agent
//! that announces it, follows its auctions and re-auctions, and reports how
//! it ends. What `colony tasks announce` runs.

use std::net::SocketAddr;
use std::ops::ControlFlow;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use colony_node::{Link, LiveError};

use crate::announcer::{AnnouncerEvent, AuctionConfig};
use crate::protocol::{TaskSpec, Token};
use crate::user::{Backoff, UserAgent, UserEvent};

/// How a request ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// A robot did it.
    Done {
        /// Who.
        by: Token,
    },
    /// No robot could, before the deadline.
    GaveUp {
        /// The last reason heard.
        reason: String,
    },
    /// Stopped from outside before it ended.
    Interrupted,
}

/// Introduces `spec` as `announcer` through the hub at `hub` (signing with
/// `key` when there is one), retrying an unachievable task with backoff until
/// `deadline`, and returns how it ended; each step of its auctions goes to `say`.
#[allow(clippy::too_many_arguments)]
pub fn introduce(
    hub: SocketAddr,
    key: Option<&colony_wire::auth::Key>,
    announcer: Token,
    spec: TaskSpec,
    auction: AuctionConfig,
    deadline: Duration,
    stop: &AtomicBool,
    mut say: impl FnMut(&str),
) -> Result<Outcome, LiveError> {
    let epoch = Instant::now();
    let mut link = Link::new(crate::robot::connect(hub, key)?, epoch);
    let backoff = Backoff {
        initial: Duration::from_millis(500),
        max: Duration::from_secs(4),
        give_up_after: deadline,
    };
    let mut user = UserAgent::new(announcer, auction, backoff, rand::random());
    // Subscribed to its negotiations before the first announcement goes out.
    link.flush(&mut user)?;
    let request = user
        .introduce(link.now(), spec.clone())
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e.to_string()))?;
    say(&format!("introduce #{request} {spec}"));
    let mut outcome = Outcome::Interrupted;
    colony_node::run(&mut user, &mut link, stop, |user, now| {
        let stamp = format!("{:7.2}", now.as_secs_f64());
        while let Some(e) = user.poll_event() {
            let line = match e {
                UserEvent::Auction { event, .. } => match event {
                    AnnouncerEvent::Announced { attempt, .. } => {
                        format!("{stamp} auction {attempt} open")
                    }
                    AnnouncerEvent::Bid { bidder, score, .. } => {
                        format!("{stamp} bid from {bidder}: {score:.2}")
                    }
                    AnnouncerEvent::Awarded {
                        winner,
                        score,
                        bids,
                        ..
                    } => {
                        format!("{stamp} awarded to {winner} (score {score:.2}, {bids} bids)")
                    }
                    AnnouncerEvent::Started { winner, .. } => format!("{stamp} {winner} started"),
                    AnnouncerEvent::WinnerLost { winner, reason, .. } => {
                        format!("{stamp} {winner} lost it ({reason}): auctioned again")
                    }
                    AnnouncerEvent::Unachievable { reason, .. } => {
                        format!("{stamp} unachievable: {reason}")
                    }
                    AnnouncerEvent::Completed { winner, .. } => {
                        format!("{stamp} {winner} reports it done")
                    }
                    other => format!("{stamp} {other:?}"),
                },
                UserEvent::Allocated { winner, tries, .. } => {
                    format!("{stamp} allocated to {winner} after {tries} introduction(s)")
                }
                UserEvent::Completed { winner, .. } => {
                    say(&format!("{stamp} done by {winner}"));
                    outcome = Outcome::Done { by: winner };
                    return ControlFlow::Break(());
                }
                UserEvent::Unachievable {
                    reason, retry_in, ..
                } => format!(
                    "{stamp} no robot can ({reason}); again in {:.1} s",
                    retry_in.as_secs_f64()
                ),
                UserEvent::GaveUp { reason, .. } => {
                    say(&format!("{stamp} gave up: {reason}"));
                    outcome = Outcome::GaveUp { reason };
                    return ControlFlow::Break(());
                }
            };
            say(&line);
        }
        ControlFlow::Continue(())
    })?;
    Ok(outcome)
}
