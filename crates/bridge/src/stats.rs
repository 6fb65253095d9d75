//! What a bridge reports: why it failed, and what it has done so far.

use std::io;
use std::sync::atomic::{AtomicU64, Ordering};

/// Why a bridge could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// The hub's address or socket.
    #[error("hub {hub}: {source}")]
    Hub {
        /// The hub as given.
        hub: String,
        /// Why.
        source: colony_client::ClientError,
    },
    /// Zenoh refused the configuration or could not open.
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// The bridge's own socket or wake-up.
    #[error(transparent)]
    Io(#[from] io::Error),
}

pub(crate) fn zerr(e: impl std::fmt::Display) -> BridgeError {
    BridgeError::Zenoh(e.to_string())
}

/// What a bridge has done, readable from any thread while it runs.
#[derive(Debug, Default)]
pub struct Stats {
    /// Packets put on Zenoh.
    pub exported: AtomicU64,
    /// Packets from other sites published into the hub.
    pub imported: AtomicU64,
    /// Packets of other sites that never arrived (gaps in their numbering).
    pub lost: AtomicU64,
    /// Packets that arrived twice, dropped.
    pub duplicates: AtomicU64,
    /// Samples that were no colony packet, or whose key did not match the
    /// packet, or that addressed the hub: dropped.
    pub rejected: AtomicU64,
    /// Samples dropped because the bridge's thread was behind by [`QUEUE`](crate::run).
    pub overflow: AtomicU64,
    /// Puts Zenoh refused.
    pub put_failed: AtomicU64,
    /// Packets whose number was far from their stream's, or taken already
    /// by other bytes (forged, or the real one after a forgery): passed on,
    /// and counted here rather than in `lost`.
    pub suspect: AtomicU64,
    /// Wants of other sites refused (beyond a site's share of the table, see
    /// [`crate::wants`]) or let go for another site's, and channels left
    /// out of the exports beyond [`MAX_EXPORTS`](crate::relay::MAX_EXPORTS):
    /// each counted once when it happens.
    pub refused_wants: AtomicU64,
    /// Errors talking to the hub (it may be down, or unreachable for a while).
    pub hub_errors: AtomicU64,
}

impl Stats {
    pub(crate) fn add(counter: &AtomicU64, n: u64) {
        counter.fetch_add(n, Ordering::Relaxed);
    }

    /// A counter's value now.
    pub fn get(counter: &AtomicU64) -> u64 {
        counter.load(Ordering::Relaxed)
    }
}
