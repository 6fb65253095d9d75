//! Hub status reports as the bridge's tests build them.

use colony_wire::{ClientInfo, StatusReport};

/// A client of the hub that says `about` and holds `subs`.
pub(crate) fn client(about: &str, subs: &[&str]) -> ClientInfo {
    ClientInfo {
        addr: "127.0.0.1:1".into(),
        idle_ms: 0,
        subscriptions: subs.iter().map(|s| (s.to_string(), 1000)).collect(),
        about: about.into(),
        tap: false,
        batch: 0,
    }
}

/// A status report listing `clients` and nothing else.
pub(crate) fn report(clients: Vec<ClientInfo>) -> StatusReport {
    StatusReport {
        clients,
        ..StatusReport::default()
    }
}
