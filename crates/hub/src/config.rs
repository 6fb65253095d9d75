//! The hub's limits, each with the reason for its default.

use std::time::Duration;

use colony_wire::auth::Key;

use crate::access::Cidr;

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
    /// The status report is built at most once in this time and served
    /// from that copy meanwhile, so status requests cannot stall forwarding.
    pub status_interval: Duration,
    /// Sources that may send operator requests (`min_priority`), with a
    /// valid cookie. Empty: only packets signed with [`key`](Self::key).
    pub consoles: Vec<Cidr>,
    /// Sources that may use the hub at all; empty: any source.
    pub allow: Vec<Cidr>,
    /// The shared key: a packet signed with it may send operator requests
    /// from anywhere.
    pub key: Option<Key>,
    /// Every packet must be signed with [`key`](Self::key).
    pub auth_all: bool,
    /// Control packets one source may send per second on average...
    pub control_rate: f64,
    /// ...and at once. A client refreshes its subscriptions in a few packets
    /// every few seconds, so these leave it two orders of magnitude to spare.
    pub control_burst: f64,
    /// How far a signed packet's counter may lie from the hub's clock.
    pub auth_window: Duration,
}

/// The shortest lease: a client refreshes three times a lease, and below
/// this a hub and its clients would spend their time on refreshes.
pub const MIN_LEASE: Duration = Duration::from_millis(colony_wire::MIN_LEASE_MS);

impl Default for HubConfig {
    fn default() -> Self {
        HubConfig {
            lease: Duration::from_secs(10),
            max_clients: 4096,
            max_subscriptions: 256,
            max_channels: 1024,
            status_interval: Duration::from_millis(100),
            consoles: Vec::new(),
            allow: Vec::new(),
            key: None,
            auth_all: false,
            control_rate: 200.0,
            control_burst: 400.0,
            auth_window: Duration::from_secs(30),
        }
    }
}
