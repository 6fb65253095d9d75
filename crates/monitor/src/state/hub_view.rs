//! The hub as the monitor sees it: every channel with its rate (from the packet counts of two
//! status reports) and its last packet, the clients with their subscriptions, drops by reason,
//! the minimum priority; and when the hub was last heard from, for the staleness banner.

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use colony_client::rate::rates_between;
use colony_wire::{Packet, StatusReport, Subject, HUB_SUBJECT};
use serde::Serialize;

/// The longest last-packet text kept per channel.
pub const LAST_TEXT_LIMIT: usize = 1500;
/// Channels tracked at most (the hub itself counts at most 1024).
const MAX_CHANNELS: usize = 2048;
/// Clients listed in the hub view at most.
const MAX_CLIENTS_SHOWN: usize = 400;

/// What the hub's status reports and the packets received say about it.
#[derive(Debug, Default)]
pub struct HubView {
    channels: BTreeMap<String, ChannelView>,
    status: Option<StatusReport>,
    status_at: Option<Instant>,
    last_from_hub: Option<Instant>,
}

#[derive(Debug, Default)]
struct ChannelView {
    /// From the newest status report.
    packets: u64,
    bytes: u64,
    rate: Option<f64>,
    in_status: bool,
    /// From the packets this monitor received.
    last_text: Option<String>,
    last_len: usize,
    last_at: Option<Instant>,
}

#[derive(Serialize)]
struct ChannelJson<'a> {
    name: &'a str,
    packets: u64,
    bytes: u64,
    rate: Option<f64>,
    last: Option<&'a str>,
    last_len: usize,
    last_age: Option<f64>,
    in_status: bool,
}

#[derive(Serialize)]
struct ClientJson<'a> {
    addr: &'a str,
    idle: f64,
    subs: Vec<(&'a str, f64)>,
}

/// The hub view (sent as JSON about once a second).
#[derive(Serialize)]
pub(super) struct HubJson<'a> {
    t: &'static str,
    now: u64,
    status_age: Option<f64>,
    uptime: Option<f64>,
    lease: Option<f64>,
    min_priority: Option<i32>,
    client_count: u64,
    truncated: bool,
    channels: Vec<ChannelJson<'a>>,
    clients: Vec<ClientJson<'a>>,
    clients_left_off: usize,
    drops: Vec<(&'a str, u64)>,
    bad_lines: u64,
    /// `[step, pc]`
    pc: Vec<(u64, f64)>,
}

impl HubView {
    /// When anything last came from the hub (a packet or a status report).
    pub fn last_heard(&self) -> Option<Instant> {
        self.last_from_hub
    }

    /// The last packet received on a channel (as text, possibly cut short).
    pub fn last_packet(&self, channel: &str) -> Option<&str> {
        self.channels.get(channel)?.last_text.as_deref()
    }

    /// Packets per second on a channel, from the last two status reports.
    pub fn rate(&self, channel: &str) -> Option<f64> {
        self.channels.get(channel)?.rate
    }

    /// The newest status report.
    pub fn status(&self) -> Option<&StatusReport> {
        self.status.as_ref()
    }

    /// Notes a packet received at `now`: the hub is alive, and this is its channel's last packet.
    pub(super) fn on_packet(&mut self, now: Instant, packet: &Packet<'_>) {
        self.last_from_hub = Some(now);
        let key: String = if packet.subject_count() == 1 {
            packet.subjects().next().unwrap_or_default().to_owned()
        } else {
            packet.subjects().collect::<Vec<_>>().join(" ")
        };
        if !self.channels.contains_key(&key) && self.channels.len() >= MAX_CHANNELS {
            return;
        }
        let text = packet.as_str();
        let entry = self.channels.entry(key).or_default();
        entry.last_len = text.len();
        entry.last_at = Some(now);
        let cut = if text.len() > LAST_TEXT_LIMIT {
            let mut end = LAST_TEXT_LIMIT;
            while !text.is_char_boundary(end) {
                end -= 1;
            }
            &text[..end]
        } else {
            text
        };
        match &mut entry.last_text {
            Some(s) => {
                s.clear();
                s.push_str(cut);
            }
            None => entry.last_text = Some(cut.to_owned()),
        }
    }

    /// Takes in a status report received at `now`: rates from the packet counts since the
    /// previous one (none across a hub restart), and the channels it names.
    pub(super) fn on_status(&mut self, now: Instant, report: StatusReport) {
        self.last_from_hub = Some(now);
        let rates = rates_between(self.status.as_ref(), &report);
        for c in self.channels.values_mut() {
            c.in_status = false;
            c.rate = None;
            c.packets = 0;
            c.bytes = 0;
        }
        for (c, rate) in report.channels.iter().zip(rates) {
            if !self.channels.contains_key(&c.subjects) && self.channels.len() >= MAX_CHANNELS {
                continue;
            }
            let entry = self.channels.entry(c.subjects.clone()).or_default();
            entry.rate = rate;
            entry.packets = c.packets;
            entry.bytes = c.bytes;
            entry.in_status = true;
        }
        self.status = Some(report);
        self.status_at = Some(now);
    }

    /// Subjects seen in status reports, for the bridge to subscribe to so
    /// their last packet can be shown (the hub and the overflow bucket excepted).
    pub fn channels_seen(&self) -> Vec<String> {
        let mut out = BTreeSet::new();
        if let Some(r) = &self.status {
            for c in &r.channels {
                for s in c.subjects.split(' ') {
                    if s != HUB_SUBJECT && Subject::new(s).is_ok() {
                        out.insert(s.to_owned());
                    }
                }
            }
        }
        out.into_iter().collect()
    }

    /// The hub view for the page at `now` (`wall`: `now` on the wall clock, Unix ms), with the
    /// monitor's count of bad lines and the completion plot.
    pub(super) fn json<'a>(
        &'a self,
        now: Instant,
        wall: u64,
        bad_lines: u64,
        pc: impl Iterator<Item = &'a (u64, f64)>,
    ) -> HubJson<'a> {
        let secs = |d: Duration| (d.as_secs_f64() * 10.0).round() / 10.0;
        let r = self.status.as_ref();
        HubJson {
            t: "hub",
            now: wall,
            status_age: self
                .status_at
                .map(|t| secs(now.saturating_duration_since(t))),
            uptime: r.map(|r| r.uptime_ms as f64 / 1000.0),
            lease: r.map(|r| r.lease_ms as f64 / 1000.0),
            min_priority: r
                .and_then(|r| (r.min_priority.0 != i32::MIN).then_some(r.min_priority.0)),
            client_count: r.map_or(0, |r| r.client_count),
            truncated: r.is_some_and(|r| r.truncated),
            channels: self
                .channels
                .iter()
                .map(|(name, c)| ChannelJson {
                    name,
                    packets: c.packets,
                    bytes: c.bytes,
                    rate: c.rate.map(|v| (v * 10.0).round() / 10.0),
                    last: c.last_text.as_deref(),
                    last_len: c.last_len,
                    last_age: c.last_at.map(|t| secs(now.saturating_duration_since(t))),
                    in_status: c.in_status,
                })
                .collect(),
            clients: r.map_or_else(Vec::new, |r| {
                r.clients
                    .iter()
                    .take(MAX_CLIENTS_SHOWN)
                    .map(|c| ClientJson {
                        addr: &c.addr,
                        idle: c.idle_ms as f64 / 1000.0,
                        subs: c
                            .subscriptions
                            .iter()
                            .map(|(s, left)| (s.as_str(), *left as f64 / 1000.0))
                            .collect(),
                    })
                    .collect()
            }),
            clients_left_off: r.map_or(0, |r| {
                (r.client_count as usize).saturating_sub(r.clients.len().min(MAX_CLIENTS_SHOWN))
            }),
            drops: r.map_or_else(Vec::new, |r| {
                r.drops.iter().map(|(s, n)| (s.as_str(), *n)).collect()
            }),
            bad_lines,
            pc: pc.copied().collect(),
        }
    }
}
