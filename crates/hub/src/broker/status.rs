//! The status report: the table, the channels and the drops, within one datagram.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use colony_wire::{ChannelInfo, ClientInfo, Priority, StatusReport, MAX_PACKET};

use super::Hub;
use crate::counters::DropReason;

impl Hub {
    pub(super) fn status_request(&mut self, now: Instant, src: SocketAddr) {
        let fresh = self.status_cache.as_ref().is_some_and(|(at, _)| {
            now.saturating_duration_since(*at) < self.config.status_interval
        });
        if !fresh {
            self.status_cache = Some((now, self.status(now).to_packet()));
        }
        let payload = self
            .status_cache
            .as_ref()
            .map(|(_, p)| p.clone())
            .unwrap_or_default();
        self.reply(src, payload);
    }

    /// The hub's state as the `status` request reports it. Its cost is
    /// bounded whatever the table holds: clients are listed in address order
    /// only until one datagram is full.
    pub fn status(&self, now: Instant) -> StatusReport {
        let ms = |d: Duration| d.as_millis() as u64;
        let mut addrs: Vec<&SocketAddr> = self.clients.keys().collect();
        addrs.sort_by_cached_key(|a| a.to_string());
        let mut clients = Vec::new();
        // Half the datagram for clients, the rest for channels and drops.
        let mut budget = MAX_PACKET / 2;
        let mut truncated = false;
        for addr in addrs {
            let c = &self.clients[addr];
            // A client line costs about its subscriptions' names plus a few
            // digits each; stop before the report could not be sent anyway.
            let cost =
                48 + c.about.len() + c.subs.keys().map(|s| s.as_str().len() + 8).sum::<usize>();
            if cost > budget {
                truncated = true;
                break;
            }
            budget -= cost;
            let mut subscriptions: Vec<(String, u64)> = c
                .subs
                .iter()
                .map(|(s, exp)| (s.to_string(), ms(exp.saturating_duration_since(now))))
                .collect();
            subscriptions.sort();
            clients.push(ClientInfo {
                addr: addr.to_string(),
                idle_ms: ms(now.saturating_duration_since(c.last_heard)),
                subscriptions,
                about: c.about.to_string(),
                tap: c.tap,
                batch: c.batch,
            });
        }
        let min_priority = if self.min_priority_lapsed(now) {
            Priority(i32::MIN)
        } else {
            self.min_priority
        };
        StatusReport {
            uptime_ms: ms(now.saturating_duration_since(self.started)),
            lease_ms: ms(self.config.lease),
            min_priority,
            client_count: self.clients.len() as u64,
            clients,
            channels: self
                .counters
                .channels()
                .into_iter()
                .map(|(subjects, packets, bytes)| ChannelInfo {
                    subjects,
                    packets,
                    bytes,
                })
                .collect(),
            drops: DropReason::ALL
                .iter()
                .map(|&r| (r.name().to_owned(), self.counters.drops(r)))
                .filter(|&(_, n)| n > 0)
                .collect(),
            truncated,
        }
    }
}
