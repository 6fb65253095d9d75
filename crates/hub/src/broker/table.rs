//! The subscription table: who is subscribed to what until when, and who a packet goes to.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::time::Instant;

use colony_wire::{Packet, Subject};

use super::Hub;
use crate::counters::DropReason;

#[derive(Debug)]
pub(super) struct Client {
    /// Each subscription and when its lease runs out.
    pub(super) subs: HashMap<Subject, Instant>,
    pub(super) last_heard: Instant,
    /// Sends this client none of its own packets ([`Request::NoLocal`](colony_wire::Request::NoLocal)).
    pub(super) no_local: bool,
    /// What it says it is ([`Request::About`](colony_wire::Request::About)).
    pub(super) about: Box<str>,
    /// Gets every forwarded packet ([`Request::Tap`](colony_wire::Request::Tap)).
    pub(super) tap: bool,
    /// Its tap was asked for with a console's authority (it is never displaced).
    pub(super) console_tap: bool,
    /// The most bytes of joined packets it takes in one datagram
    /// ([`Request::Batch`](colony_wire::Request::Batch); 0: one packet each).
    pub(super) batch: usize,
}

impl Hub {
    /// Fills `self.dests` with every client subscribed to all of the
    /// packet's subjects, and every client that taps (once each).
    pub(super) fn route(&mut self, packet: &Packet<'_>) {
        self.dests.clear();
        self.route_subscribers(packet);
        let clients = &self.clients;
        for tap in &self.taps {
            // Already a destination exactly when it subscribes to every subject.
            let Some(c) = clients.get(tap).filter(|c| c.tap) else {
                continue;
            };
            if !packet.subjects().all(|s| c.subs.contains_key(s)) {
                self.dests.push(*tap);
            }
        }
    }

    fn route_subscribers(&mut self, packet: &Packet<'_>) {
        // Start from the subject with the fewest subscribers; check the others per client.
        let mut rarest: Option<&Vec<SocketAddr>> = None;
        for s in packet.subjects() {
            match self.subscribers.get(s) {
                None => return,
                Some(list) if rarest.is_none_or(|r| list.len() < r.len()) => rarest = Some(list),
                Some(_) => {}
            }
        }
        let Some(candidates) = rarest else { return };
        if packet.subject_count() == 1 {
            self.dests.extend_from_slice(candidates);
            return;
        }
        for addr in candidates {
            let Some(client) = self.clients.get(addr) else {
                continue;
            };
            if packet.subjects().all(|s| client.subs.contains_key(s)) {
                self.dests.push(*addr);
            }
        }
    }

    pub(super) fn subscribe(
        &mut self,
        now: Instant,
        src: SocketAddr,
        subject: Subject,
        room_made: &mut bool,
    ) -> Result<(), DropReason> {
        if !self.clients.contains_key(&src) && self.clients.len() >= self.config.max_clients {
            // A table scan at most once a packet, however many lines ask.
            if *room_made {
                return Err(DropReason::TooManyClients);
            }
            *room_made = true;
            self.make_room(now, src)?;
        }
        let max_subs = self.config.max_subscriptions;
        let client = self.clients.entry(src).or_insert_with(|| Client {
            subs: HashMap::new(),
            last_heard: now,
            no_local: false,
            about: Box::from(""),
            tap: false,
            console_tap: false,
            batch: 0,
        });
        let expiry = now + self.config.lease;
        if let Some(e) = client.subs.get_mut(&subject) {
            *e = expiry;
            return Ok(());
        }
        if client.subs.len() >= max_subs {
            if client.subs.is_empty() {
                self.clients.remove(&src);
            }
            return Err(DropReason::TooManySubscriptions);
        }
        client.subs.insert(subject.clone(), expiry);
        self.subscribers.entry(subject).or_default().push(src);
        Ok(())
    }

    /// With the table full, a proven newcomer takes the place of a client
    /// that has not renewed anything for half a lease (a live one renews every
    /// third); failing that, of the idlest client of the address that holds
    /// the most places, if that address holds more than the newcomer's. So a
    /// restarted robot can always join, and one host with many ports cannot
    /// keep everyone else out.
    fn make_room(&mut self, now: Instant, newcomer: SocketAddr) -> Result<(), DropReason> {
        let idle_after = self.config.lease / 2;
        let idlest = self
            .clients
            .iter()
            .min_by_key(|(_, c)| c.last_heard)
            .map(|(a, c)| (*a, c.last_heard));
        if let Some((addr, heard)) = idlest {
            if now.saturating_duration_since(heard) >= idle_after {
                self.forget(addr);
                return Ok(());
            }
        }
        let mut per_host: HashMap<std::net::IpAddr, (usize, Instant, SocketAddr)> = HashMap::new();
        for (addr, c) in &self.clients {
            let e = per_host
                .entry(addr.ip())
                .or_insert((0, c.last_heard, *addr));
            e.0 += 1;
            if c.last_heard < e.1 {
                (e.1, e.2) = (c.last_heard, *addr);
            }
        }
        let mine = per_host.get(&newcomer.ip()).map_or(0, |e| e.0);
        match per_host.values().max_by_key(|e| e.0) {
            Some(&(count, _, addr)) if count > mine + 1 => {
                self.forget(addr);
                Ok(())
            }
            _ => Err(DropReason::TooManyClients),
        }
    }

    pub(super) fn unsubscribe(&mut self, src: SocketAddr, subject: &Subject) {
        let Some(client) = self.clients.get_mut(&src) else {
            return;
        };
        if client.subs.remove(subject).is_some() {
            remove_subscriber(&mut self.subscribers, subject.as_str(), src);
        }
        if client.subs.is_empty() {
            self.clients.remove(&src);
        }
    }

    pub(super) fn forget(&mut self, src: SocketAddr) {
        if let Some(client) = self.clients.remove(&src) {
            for subject in client.subs.keys() {
                remove_subscriber(&mut self.subscribers, subject.as_str(), src);
            }
        }
    }
}

pub(super) fn remove_subscriber(
    subscribers: &mut HashMap<Subject, Vec<SocketAddr>>,
    subject: &str,
    addr: SocketAddr,
) {
    if let Some(list) = subscribers.get_mut(subject) {
        if let Some(i) = list.iter().position(|a| *a == addr) {
            list.swap_remove(i);
        }
        if list.is_empty() {
            subscribers.remove(subject);
        }
    }
}
