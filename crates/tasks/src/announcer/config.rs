//! An announcer's timings.

use std::time::Duration;

/// An announcer's timings.
#[derive(Debug, Clone, PartialEq)]
pub struct AuctionConfig {
    /// How long bids are taken after the announcement (`deadline_ms`).
    pub bid_window: Duration,
    /// How long the winner has to acknowledge the award.
    pub ack_timeout: Duration,
    /// How often the announcer tells the winner it is still there.
    pub renew_interval: Duration,
    /// A winner silent this long is presumed failed and its task auctioned again.
    pub renew_timeout: Duration,
    /// Auctions of one task (the first and its re-auctions) before it is
    /// reported unachievable all the same.
    pub max_attempts: u32,
}

impl Default for AuctionConfig {
    fn default() -> Self {
        AuctionConfig {
            bid_window: Duration::from_millis(200),
            ack_timeout: Duration::from_secs(1),
            renew_interval: Duration::from_secs(1),
            renew_timeout: Duration::from_secs(3),
            max_attempts: 16,
        }
    }
}
