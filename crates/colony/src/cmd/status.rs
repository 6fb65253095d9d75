//! `colony status`: what the hub knows, formatted for people or as JSON.

use colony_client::status::{fetch_status_with, format_report};
use colony_wire::StatusReport;
use serde_json::{json, Value};

use super::HubAddr;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub hub: HubAddr,
    /// Seconds to wait for the hub's answer.
    #[arg(long, default_value_t = 3.0, value_parser = super::TIMEOUT)]
    pub timeout: f64,
    /// Print the report as one JSON object, for programs.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let timeout = super::seconds("--timeout", args.timeout)?;
    let report = fetch_status_with(&mut args.hub.connect()?, timeout)?;
    if args.json {
        println!("{}", to_json(&report));
    } else {
        print!("{}", format_report(&report));
    }
    Ok(())
}

/// The report as JSON, with the names the Python client's `status()` uses
/// (`ch`, `subs`), and everything else the report holds.
fn to_json(r: &StatusReport) -> Value {
    let min_priority = (r.min_priority.0 != i32::MIN).then_some(r.min_priority.0);
    json!({
        "uptime_ms": r.uptime_ms,
        "lease_ms": r.lease_ms,
        "min_priority": min_priority,
        "client_count": r.client_count,
        "truncated": r.truncated,
        "drops": r.drops.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
        "channels": r.channels.iter().map(|c| json!({
            "ch": c.subjects, "packets": c.packets, "bytes": c.bytes,
        })).collect::<Vec<_>>(),
        "clients": r.clients.iter().map(|c| json!({
            "addr": c.addr,
            "idle_ms": c.idle_ms,
            "subs": c.subscriptions.iter().map(|(s, ms)| (s.clone(), json!(ms))).collect::<serde_json::Map<_, _>>(),
            "about": c.about,
            "tap": c.tap,
            "batch": c.batch,
        })).collect::<Vec<_>>(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_wire::{ChannelInfo, ClientInfo, Priority};

    #[test]
    fn the_json_holds_every_part_of_the_report() {
        let r = StatusReport {
            uptime_ms: 5,
            lease_ms: 10_000,
            min_priority: Priority(i32::MIN),
            client_count: 1,
            clients: vec![ClientInfo {
                addr: "127.0.0.1:5000".into(),
                idle_ms: 3,
                subscriptions: vec![("vision".into(), 9_000)],
                about: "agent r1".into(),
                tap: false,
                batch: 0,
            }],
            channels: vec![ChannelInfo {
                subjects: "vision".into(),
                packets: 7,
                bytes: 700,
            }],
            drops: vec![("malformed".into(), 2)],
            truncated: false,
        };
        let j = to_json(&r);
        assert_eq!(j["min_priority"], Value::Null);
        assert_eq!(j["drops"]["malformed"], 2);
        assert_eq!(j["channels"][0]["ch"], "vision");
        assert_eq!(j["clients"][0]["subs"]["vision"], 9_000);
        assert_eq!(j["clients"][0]["about"], "agent r1");
    }
}
