//! Asking a hub what it knows (`colony status`): its clients, channels and
//! drops, and that report written out for people.

use std::fmt::Write as _;
use std::io;
use std::time::{Duration, Instant};

use colony_wire::{terminal_line, Reply, Request, StatusReport};

use crate::{ClientError, ConnectError, UdpClient};

/// Why no status report came back.
#[derive(Debug, thiserror::Error)]
pub enum StatusError {
    /// The address is not a hub's (it does not resolve, or cannot be reached).
    #[error(transparent)]
    Connect(#[from] ConnectError),
    /// Nothing answered in time.
    #[error("no answer from a hub at {addr} within {:.1} s (is `colony hub` running there? a hub run with --auth-all answers only packets signed with its key: --key FILE or COLONY_KEY)", timeout.as_secs_f64())]
    NoAnswer {
        /// The hub's address, resolved.
        addr: std::net::SocketAddr,
        /// How long we waited.
        timeout: Duration,
    },
    /// The client failed while asking.
    #[error(transparent)]
    Client(#[from] ClientError),
    /// The socket failed while waiting.
    #[error(transparent)]
    Io(#[from] io::Error),
}

/// Asks the hub at `hub` for its status and waits up to `timeout` for the
/// answer. The first request brings a cookie back rather than the report
/// (the hub answers a large reply only to an address that proved it
/// receives there); the session asks again with it by itself.
pub fn fetch_status(hub: &str, timeout: Duration) -> Result<StatusReport, StatusError> {
    fetch_status_with(&mut UdpClient::connect_to(hub)?, timeout)
}

/// As [`fetch_status`], through a client of the hub made by the caller (one
/// that signs with the hub's key, for a hub that asks every packet to be signed).
pub fn fetch_status_with(
    client: &mut UdpClient,
    timeout: Duration,
) -> Result<StatusReport, StatusError> {
    // A timeout beyond what the clock can hold waits as long as it can.
    let deadline = Instant::now()
        .checked_add(timeout)
        .unwrap_or_else(|| Instant::now() + Duration::from_secs(100 * 365 * 24 * 3600));
    let mut next_ask = Instant::now();
    while Instant::now() < deadline {
        if Instant::now() >= next_ask {
            // Ask again every 300 ms: a request or its answer may be lost.
            client.request(&[Request::Status])?;
            next_ask = Instant::now() + Duration::from_millis(300);
        }
        client.wait(Some(next_ask.min(deadline)))?;
        while let Some(reply) = client.recv_reply()? {
            if let Reply::Status(report) = reply {
                return Ok(report);
            }
        }
    }
    Err(StatusError::NoAnswer {
        addr: client.hub_addr(),
        timeout,
    })
}

/// The report as `colony status` prints it: a summary line, then channels,
/// clients and drops, one per line.
pub fn format_report(r: &StatusReport) -> String {
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
        let batch = if c.batch > 0 {
            format!("[batches of up to {} B] ", c.batch)
        } else {
            String::new()
        };
        let _ = writeln!(
            out,
            "  {:<22} idle {:>6.1} s  {}{batch}{}",
            terminal_line(&c.addr),
            c.idle_ms as f64 / 1000.0,
            if c.tap { "[taps every channel] " } else { "" },
            subs.join(", ")
        );
        if !c.about.is_empty() {
            // Words any client chose: no control or bidirectional character
            // reaches the terminal.
            let _ = writeln!(out, "  {:<22} {}", "", terminal_line(&c.about));
        }
    }
    let _ = writeln!(out, "\ndrops:");
    if r.drops.is_empty() {
        let _ = writeln!(out, "  none");
    }
    for (reason, n) in &r.drops {
        // A reply forged from the hub's address could name any reason.
        let _ = writeln!(out, "  {:<24} {n:>10}", terminal_line(reason));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_wire::{ChannelInfo, Priority};

    #[test]
    fn a_report_lists_channels_and_says_when_nothing_was_dropped() {
        let r = StatusReport {
            uptime_ms: 1500,
            lease_ms: 10_000,
            min_priority: Priority(i32::MIN),
            client_count: 0,
            channels: vec![ChannelInfo {
                subjects: "vision".into(),
                packets: 1,
                bytes: 20,
            }],
            ..StatusReport::default()
        };
        let text = format_report(&r);
        assert!(
            text.starts_with("hub up 1.5 s, lease 10.0 s, minimum priority none, 0 client(s)\n")
        );
        assert!(text.contains("vision") && text.contains("1 packets"));
        assert!(text.ends_with("drops:\n  none\n"));
    }

    #[test]
    fn what_a_client_says_it_is_is_shown_without_control_or_bidi_characters() {
        let r = StatusReport {
            clients: vec![colony_wire::ClientInfo {
                addr: "127.0.0.1:5000".into(),
                idle_ms: 0,
                subscriptions: vec![("a".into(), 900)],
                about: "bridge site lab\u{1b}[2J \u{202e}evil\u{9b}".into(),
                tap: false,
                batch: 1472,
            }],
            ..StatusReport::default()
        };
        let text = format_report(&r);
        assert!(
            text.contains("[batches of up to 1472 B] a (0.9 s)"),
            "{text}"
        );
        assert!(
            text.contains("bridge site lab\\u{1b}[2J \\u{202e}evil\\u{9b}"),
            "{text}"
        );
        assert!(!text.contains(['\u{1b}', '\u{202e}', '\u{9b}']));
    }

    #[test]
    fn a_silent_address_is_no_answer() {
        let quiet = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        let addr = quiet.local_addr().unwrap().to_string();
        match fetch_status(&addr, Duration::from_millis(50)) {
            Err(StatusError::NoAnswer { .. }) => {}
            other => panic!("{other:?}"),
        }
    }
}
