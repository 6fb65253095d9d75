//! Control requests: subscriptions and leases, taps, batches and the operator's minimum
//! priority, each acted on only for a source proven by its cookie.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use colony_wire::{Cookie, Packet, Priority, Reply, Request};

use super::{
    Hub, Outcome, Proof, Transmit, MAX_REPLY_BYTES, MAX_REQUESTS, MAX_TAPS, MAX_TAPS_PER_HOST,
};
use crate::counters::DropReason;

impl Hub {
    pub(super) fn control(
        &mut self,
        now: Instant,
        src: SocketAddr,
        packet: &Packet<'_>,
        len: usize,
        proof: Proof,
    ) -> Outcome<'_> {
        let requests = match Request::parse_all(packet) {
            Ok(r) if r.len() <= MAX_REQUESTS => r,
            Ok(_) => return self.dropped(DropReason::BadControl),
            Err(e) => {
                tracing::debug!(%src, error = %e, "bad control request");
                return self.dropped(DropReason::BadControl);
            }
        };
        let cookie = requests.iter().find_map(|r| match r {
            Request::Cookie(c) => Some(*c),
            _ => None,
        });
        // Only a packet that proves its source, with a cookie the hub gave
        // that address, may act: otherwise anyone could aim a stream, or a
        // status report, at an address of their choice. A signature is no
        // such proof: a signed packet seen on the wire can be sent again from
        // any address.
        let proven = cookie.is_some_and(|c| self.cookies.check(&src, now, c));
        let acts = requests.iter().any(|r| !matches!(r, Request::Cookie(_)));
        if !proven {
            if acts {
                self.challenge(now, src, cookie, len);
            }
            return Outcome::Control;
        }
        // Checked only once the source is proven, so that a forger cannot
        // spend a real client's rate.
        if !self.rates.take(&src, now) {
            return self.dropped(DropReason::RateLimited);
        }
        if let Some(client) = self.clients.get_mut(&src) {
            client.last_heard = now;
        }
        let mut subscribed = false;
        let mut room_made = false;
        let mut status_sent = false;
        for request in requests {
            match request {
                Request::Subscribe(subject) => {
                    match self.subscribe(now, src, subject, &mut room_made) {
                        Ok(()) => subscribed = true,
                        Err(reason) => self.counters.drop(reason, 1),
                    }
                }
                Request::Unsubscribe(subject) => self.unsubscribe(src, &subject),
                Request::UnsubscribeAll => self.forget(src),
                Request::MinPriority(p) => self.set_min_priority(now, src, p, proof),
                // One report per packet, however many lines ask.
                Request::Status if !status_sent => {
                    status_sent = true;
                    self.status_request(now, src);
                }
                Request::Status | Request::Cookie(_) => {}
                // Kept only by a client that holds a lease, so they cost an
                // unsubscribed source nothing; a client sends them with every
                // refresh.
                Request::NoLocal => {
                    if let Some(c) = self.clients.get_mut(&src) {
                        c.no_local = true;
                    }
                }
                Request::About(text) => {
                    if let Some(c) = self.clients.get_mut(&src) {
                        c.about = text.into_boxed_str();
                    }
                }
                Request::Tap => self.tap(src, proof),
                Request::Batch(bytes) => {
                    if let Some(c) = self.clients.get_mut(&src) {
                        c.batch = bytes;
                        self.batching += usize::from(bytes > 0);
                    }
                }
            }
        }
        if subscribed {
            let lease = Reply::lease_packet(self.config.lease.as_millis() as u64);
            self.reply(src, lease);
        }
        Outcome::Control
    }

    /// Lets a client with a lease tap, while fewer than [`MAX_TAPS`] do and
    /// its host holds fewer than [`MAX_TAPS_PER_HOST`]. A console (by
    /// address or key) always may: if every place is taken, it takes the
    /// place of the oldest tap that is not a console's.
    fn tap(&mut self, src: SocketAddr, proof: Proof) {
        let Some(client) = self.clients.get(&src) else {
            return;
        };
        if client.tap {
            return;
        }
        let console = self.is_console(src, proof);
        let clients = &self.clients;
        self.taps.retain(|a| clients.get(a).is_some_and(|c| c.tap));
        let same_host = self.taps.iter().filter(|a| a.ip() == src.ip()).count();
        let full = self.taps.len() >= MAX_TAPS;
        if !console && (full || same_host >= MAX_TAPS_PER_HOST) {
            self.counters.drop(DropReason::TooManyTaps, 1);
            return;
        }
        if full {
            let clients = &self.clients;
            let Some(i) = self
                .taps
                .iter()
                .position(|a| clients.get(a).is_some_and(|c| !c.console_tap))
            else {
                self.counters.drop(DropReason::TooManyTaps, 1);
                return;
            };
            let displaced = self.taps.remove(i);
            if let Some(c) = self.clients.get_mut(&displaced) {
                c.tap = false;
            }
            self.counters.drop(DropReason::TooManyTaps, 1);
        }
        if let Some(c) = self.clients.get_mut(&src) {
            c.tap = true;
            c.console_tap = console;
            self.taps.push(src);
        }
    }

    /// Whether `src` may act as an operator: signed with the key, or a console's address.
    fn is_console(&self, src: SocketAddr, proof: Proof) -> bool {
        proof == Proof::Key || self.config.consoles.iter().any(|c| c.contains(&src))
    }

    /// Answers an unproven request with the cookie for its source: never
    /// more than it sent, so a forged source cannot make the hub an amplifier.
    fn challenge(&mut self, now: Instant, src: SocketAddr, cookie: Option<Cookie>, len: usize) {
        if cookie.is_some_and(|c| c != Cookie::NONE) {
            self.counters.drop(DropReason::BadCookie, 1);
        }
        if !self.challenges.take(&src, now) {
            self.counters.drop(DropReason::RateLimited, 1);
            return;
        }
        let reply = Reply::cookie_packet(self.cookies.issue(&src, now));
        if reply.len() <= len {
            self.reply(src, reply);
        } else {
            self.counters.drop(DropReason::Unproven, 1);
        }
    }

    /// Queues a reply, unless the queue is already as long as it may grow.
    pub(super) fn reply(&mut self, dest: SocketAddr, payload: Vec<u8>) {
        if self.reply_bytes + payload.len() > MAX_REPLY_BYTES {
            self.counters.drop(DropReason::RateLimited, 1);
            return;
        }
        self.reply_bytes += payload.len();
        self.replies.push_back(Transmit { dest, payload });
    }

    /// An operator's request: from a console (by address, with a cookie) or
    /// signed with the key. A raised minimum lasts one lease unless renewed,
    /// so a console that dies hands the robots back.
    fn set_min_priority(&mut self, now: Instant, src: SocketAddr, p: Priority, proof: Proof) {
        if !self.is_console(src, proof) {
            self.counters.drop(DropReason::NotConsole, 1);
            self.log_operator(now, src, "minimum priority refused: not a console");
            return;
        }
        if p != self.min_priority {
            self.log_operator(now, src, "minimum priority set");
        }
        self.min_priority = p;
        self.min_priority_until = (p != Priority(i32::MIN)).then(|| now + self.config.lease);
    }

    /// Whether a raised minimum priority has outlived its lease by `now`.
    pub(super) fn min_priority_lapsed(&self, now: Instant) -> bool {
        self.min_priority_until.is_some_and(|t| t <= now)
    }

    pub(super) fn lapse_min_priority(&mut self, now: Instant) {
        if self.min_priority_lapsed(now) {
            tracing::info!(
                min_priority = self.min_priority.0,
                "minimum priority lapsed: its console did not renew it"
            );
            self.min_priority = Priority(i32::MIN);
            self.min_priority_until = None;
        }
    }

    /// Logs an operator action, at most once a second: a flood of requests
    /// must not become a flood of log lines.
    fn log_operator(&mut self, now: Instant, src: SocketAddr, what: &str) {
        if self
            .last_log
            .is_some_and(|t| now.duration_since(t) < Duration::from_secs(1))
        {
            self.quiet_logs += 1;
            return;
        }
        self.last_log = Some(now);
        let unlogged = std::mem::take(&mut self.quiet_logs);
        tracing::info!(%src, min_priority = self.min_priority.0, unlogged, "{what}");
    }
}
