//! The names of the report's rows: what each run measured. The measuring code labels its
//! results with them and the report finds its rows by them.

/// The name of the floor row in the latency table.
pub const RAW: &str = "raw UDP relay (floor)";
/// The name of the hub row that the latency target is judged on.
pub const HUB: &str = "colony hub";
/// The name of the floor row in the throughput table.
pub const RELAY: &str = "raw UDP relay (floor)";
/// The name of the row of the hub whose subscribers ask for several packets
/// a datagram, of at most `bytes`.
pub fn hub_batching(bytes: usize) -> String {
    format!("colony hub, batching subscribers ({bytes} B)")
}
/// The name of the GSO experiment's row.
pub const RELAY_GSO: &str = "raw UDP relay with GSO (experiment)";
