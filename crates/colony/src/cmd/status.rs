//! `colony status`: what the hub knows, formatted for people.

use std::time::{Duration, Instant};

use colony_wire::{Reply, Request, StatusReport};

use super::HubAddr;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub hub: HubAddr,
    /// Seconds to wait for the hub's answer.
    #[arg(long, default_value_t = 3.0)]
    pub timeout: f64,
}

/// The channel `colony status` subscribes to, for the lease the hub wants
/// to see before it sends a status report.
const STATUS_CHANNEL: &str = "colony-status";

pub fn run(args: Args) -> anyhow::Result<()> {
    if !(args.timeout.is_finite() && args.timeout > 0.0) {
        anyhow::bail!("--timeout must be a positive number of seconds");
    }
    let report = fetch(&args.hub, Duration::from_secs_f64(args.timeout))?;
    print!("{}", format_report(&report));
    Ok(())
}

/// Takes a lease, asks for status, and waits for the answer.
pub fn fetch(hub: &HubAddr, timeout: Duration) -> anyhow::Result<StatusReport> {
    let mut client = hub.connect()?;
    client.subscribe(STATUS_CHANNEL)?;
    let deadline = Instant::now() + timeout;
    let mut leased = false;
    let mut next_ask = Instant::now();
    while Instant::now() < deadline {
        if Instant::now() >= next_ask {
            // Ask again every 300 ms: either datagram may be lost, and the
            // hub answers status only once our lease is in place.
            if leased {
                client.request(&[Request::Status])?;
            } else {
                client.poll(Instant::now())?;
            }
            next_ask = Instant::now() + Duration::from_millis(300);
        }
        client.wait(Some(next_ask.min(deadline)))?;
        while let Some(reply) = client.recv_reply()? {
            match reply {
                Reply::Lease { .. } if !leased => {
                    leased = true;
                    client.request(&[Request::Status])?;
                }
                Reply::Status(report) => {
                    // Leave nothing behind: the lease was only for asking.
                    client.unsubscribe_all()?;
                    return Ok(report);
                }
                Reply::Lease { .. } => {}
            }
        }
    }
    anyhow::bail!(
        "no answer from a hub at {} within {:.1} s (is `colony hub` running there?)",
        client.hub_addr(),
        timeout.as_secs_f64()
    )
}

pub fn format_report(r: &StatusReport) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let min = if r.min_priority.0 == i32::MIN {
        "none".to_string()
    } else {
        r.min_priority.to_string()
    };
    let _ = writeln!(
        out,
        "hub up {:.1} s, lease {:.1} s, minimum priority {min}, {} client(s){}",
        r.uptime_ms as f64 / 1000.0,
        r.lease_ms as f64 / 1000.0,
        r.client_count,
        if r.truncated {
            " (report cut to fit one datagram)"
        } else {
            ""
        }
    );
    let _ = writeln!(out, "\nchannels:");
    if r.channels.is_empty() {
        let _ = writeln!(out, "  (no packets yet)");
    }
    for c in &r.channels {
        let _ = writeln!(
            out,
            "  {:<24} {:>10} packets {:>12} bytes",
            c.subjects, c.packets, c.bytes
        );
    }
    let _ = writeln!(out, "\nclients:");
    for c in &r.clients {
        let subs: Vec<String> = c
            .subscriptions
            .iter()
            .map(|(s, left)| format!("{s} ({:.1} s)", *left as f64 / 1000.0))
            .collect();
        let _ = writeln!(
            out,
            "  {:<22} idle {:>6.1} s  {}",
            c.addr,
            c.idle_ms as f64 / 1000.0,
            subs.join(", ")
        );
    }
    let _ = writeln!(out, "\ndrops:");
    if r.drops.is_empty() {
        let _ = writeln!(out, "  none");
    }
    for (reason, n) in &r.drops {
        let _ = writeln!(out, "  {reason:<24} {n:>10}");
    }
    out
}
