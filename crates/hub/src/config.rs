//! The hub's limits, each with the reason for its default.

use std::time::Duration;

/// Limits that keep the hub's memory bounded and its leases short.
#[derive(Debug, Clone)]
pub struct HubConfig {
    /// How long a subscription lasts without a refresh. Short enough that a
    /// dead client, or a subscription forged for a victim's address, costs
    /// little; long enough that a client refreshing every few seconds over a
    /// lossy link keeps its lease.
    pub lease: Duration,
    /// Clients held at once; subscriptions from further addresses are dropped.
    pub max_clients: usize,
    /// Subscriptions one client may hold.
    pub max_subscriptions: usize,
    /// Distinct channels (or subject sets) with their own traffic counters;
    /// the rest are counted together under `*other*`.
    pub max_channels: usize,
    /// The shortest time between two status replies to one client.
    pub status_interval: Duration,
}

impl Default for HubConfig {
    fn default() -> Self {
        HubConfig {
            lease: Duration::from_secs(10),
            max_clients: 4096,
            max_subscriptions: 256,
            max_channels: 1024,
            status_interval: Duration::from_millis(100),
        }
    }
}
