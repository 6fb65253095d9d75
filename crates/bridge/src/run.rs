//! The bridge at work: one thread with the hub client, woken by the hub's
//! socket and by Zenoh's callbacks.
//!
//! - **Export.** Other sites' want tokens say which channels they need; the
//!   bridge keeps those subscribed on its hub (as a `no_local` client, so it
//!   never hears its own imports back) and puts each packet once on its key.
//!   Zenoh sends it only to sites whose bridge declared a matching
//!   subscriber, once per link.
//! - **Import.** The hub's status report says what this site's clients
//!   subscribe to; the bridge declares the matching want tokens and Zenoh
//!   subscribers, and publishes what arrives into its hub, which hands each
//!   packet to exactly the clients subscribed to all its subjects.
//!
//! Packets go into the hub unchanged, so every site sees the same bytes. A
//! packet comes back out of Zenoh at most once per site: the key
//! expressions never overlap, and a bridge takes nothing from its own site.

use std::collections::{BTreeSet, HashMap};
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::{ClientConfig, Delivery, HubState, UdpClient};
use colony_wire::auth::Key;
use colony_wire::{Reply, Request, Subject};
use mio::unix::SourceFd;
use mio::{Events, Interest, Poll, Token, Waker};
use std::os::fd::AsRawFd;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::sample::SampleKind;
use zenoh::{Session, Wait};

use crate::config::{any_matches, BridgeConfig};
use crate::interest::LocalInterest;
use crate::keys;
use crate::stats::{zerr, BridgeError, Stats};
use crate::track::{Tracker, Verdict};
use crate::wants::{Offer, Wants};
use crate::zenoh_io::{export, zenoh_config, Data, Inbox, Want};

/// How long the bridge waits for its hub's first answer before it says none came.
const FIRST_ANSWER: Duration = Duration::from_secs(3);
const HUB: Token = Token(0);
const WAKE: Token = Token(1);
/// Samples waiting for the bridge's thread; beyond, they are dropped and counted.
const QUEUE: usize = 16_384;
/// Want tokens coming and going, queued apart from data so that a flood of
/// samples cannot lose one; should even these overflow, the bridge asks
/// Zenoh for every live token again.
const WANT_QUEUE: usize = 65_536;
/// The most channels kept subscribed on the hub for other sites: the hub
/// grants a client 256 subscriptions, and one is the bridge's own.
const MAX_EXPORTS: usize = 255;
/// Hub subscriptions brought in line with other sites' wants at most this
/// often, and at most [`EXPORT_CHANGES`] changed each time: a stranger
/// toggling want tokens must not make the bridge spend its hub's control
/// rate (200 requests a second by default) and be refused.
const EXPORT_EVERY: Duration = Duration::from_millis(100);
/// Subscribes and unsubscribes sent to the hub per [`EXPORT_EVERY`].
const EXPORT_CHANGES: usize = 10;
/// Zenoh asked again for the live want tokens at most this often, when a
/// want was refused and room has freed since.
const RELOOK_EVERY: Duration = Duration::from_secs(1);
/// Datagrams taken from the hub per step, so the Zenoh side and the timers
/// are served under any flood.
const HUB_BATCH: usize = 1_024;
/// How often the about text (and the log line) is brought up to date.
const REPORT_EVERY: Duration = Duration::from_secs(1);

/// A running bridge between one hub and Zenoh.
pub struct Bridge {
    config: BridgeConfig,
    client: UdpClient,
    session: Session,
    poll: Poll,
    inbox: Inbox,
    data: Receiver<Data>,
    wants: Receiver<Want>,
    stats: Arc<Stats>,
    /// Drawn at start: names this run in the about text.
    run: u64,
    /// Names the numbering of puts; drawn again whenever it starts afresh.
    stamp_run: u64,
    seqs: HashMap<(String, u8), u64>,
    tracker: Tracker,
    /// Other sites' wants.
    remote: Wants,
    /// Channels kept subscribed on the hub for other sites.
    exported: BTreeSet<Subject>,
    /// Channels other sites want that are not exported (counted once each).
    left_out: BTreeSet<Subject>,
    /// Other sites' wants changed since the hub subscriptions were brought in line.
    wants_changed: bool,
    next_export: Instant,
    next_relook: Instant,
    /// When it started, and whether it has said the hub is not answering (so
    /// a person learns it within seconds, and once).
    started: Instant,
    hub_warned: bool,
    /// The bridge's own channel, held so the hub shows it.
    own: Subject,
    interest: LocalInterest,
    subscribers: HashMap<String, Subscriber<()>>,
    tokens: HashMap<Subject, LivelinessToken>,
    _wants: Subscriber<()>,
    next_status: Instant,
    next_report: Instant,
}

impl Bridge {
    /// Opens the Zenoh session and the hub client. The hub need not be up
    /// yet, nor any other site: both are found when they come.
    pub fn start(config: BridgeConfig, key: Option<Key>) -> Result<Bridge, BridgeError> {
        let mut client = UdpClient::with_config(config.hub.as_str(), ClientConfig::default())
            .map_err(|source| BridgeError::Hub {
                hub: config.hub.clone(),
                source,
            })?;
        if let Some(key) = key {
            client.set_key(key);
        }
        let session = zenoh::open(zenoh_config(&config)?).wait().map_err(zerr)?;
        let poll = Poll::new()?;
        poll.registry()
            .register(&mut SourceFd(&client.as_raw_fd()), HUB, Interest::READABLE)?;
        let waker = Arc::new(Waker::new(poll.registry(), WAKE)?);
        let (data_tx, data) = mpsc::sync_channel(QUEUE);
        let (wants_tx, wants) = mpsc::sync_channel(WANT_QUEUE);
        let stats = Arc::new(Stats::default());
        let inbox = Inbox {
            data: data_tx,
            wants: wants_tx,
            wants_lost: Arc::new(AtomicBool::new(false)),
            waker,
            stats: stats.clone(),
            own_prefix: format!("{}/{}/", keys::PREFIX, config.site),
        };
        let want_sub = {
            let inbox = inbox.clone();
            session
                .liveliness()
                .declare_subscriber(keys::all_wants_expr())
                .history(true)
                .callback(move |sample| {
                    inbox.want(Want {
                        key: sample.key_expr().as_str().to_owned(),
                        alive: sample.kind() == SampleKind::Put,
                        again: false,
                    })
                })
                .wait()
                .map_err(zerr)?
        };
        let own = Subject::new(&format!("bridge.{}", config.site))
            .expect("a site name makes a valid subject");
        let now = Instant::now();
        let mut bridge = Bridge {
            client,
            session,
            poll,
            inbox,
            data,
            wants,
            stats,
            run: rand::random(),
            stamp_run: rand::random(),
            seqs: HashMap::new(),
            tracker: Tracker::default(),
            remote: Wants::default(),
            exported: BTreeSet::new(),
            left_out: BTreeSet::new(),
            wants_changed: false,
            next_export: now,
            next_relook: now,
            started: now,
            hub_warned: false,
            own,
            interest: LocalInterest::default(),
            subscribers: HashMap::new(),
            tokens: HashMap::new(),
            _wants: want_sub,
            next_status: now,
            next_report: now,
            config,
        };
        // Always one lease, so the hub shows the bridge (and keeps its
        // standing requests) even when no site wants anything from it.
        let own = bridge.own.as_str().to_owned();
        bridge
            .client
            .subscribe(&own)
            .map_err(|source| BridgeError::Hub {
                hub: bridge.config.hub.clone(),
                source,
            })?;
        bridge.report();
        Ok(bridge)
    }

    /// The counters, shared: read them while [`run`](Self::run) goes on.
    pub fn stats(&self) -> Arc<Stats> {
        self.stats.clone()
    }

    /// The start of this bridge's about text in the hub's status report.
    pub fn marker(&self) -> String {
        format!("bridge {} run {:016x}:", self.config.site, self.run)
    }

    /// Runs until `stop` is set (checked at least every 100 ms).
    pub fn run(&mut self, stop: &AtomicBool) -> Result<(), BridgeError> {
        let mut events = Events::with_capacity(16);
        while !stop.load(Ordering::Relaxed) {
            let now = Instant::now();
            let mut deadline = self.next_status.min(self.next_report);
            if let Some(d) = self.client.next_deadline() {
                deadline = deadline.min(d);
            }
            if self.wants_changed {
                deadline = deadline.min(self.next_export);
            }
            if self.remote.relook_pending() {
                deadline = deadline.min(self.next_relook);
            }
            let wait = deadline
                .saturating_duration_since(now)
                .min(Duration::from_millis(100));
            match self.poll.poll(&mut events, Some(wait)) {
                Ok(()) => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            }
            self.step(Instant::now())?;
        }
        Ok(())
    }

    /// Notes a failure to talk to the hub: counted and logged, never the
    /// end of the bridge (the hub may be restarting, or its host rebooting).
    fn hub_error(&self, what: &str, e: &dyn std::fmt::Display) {
        Stats::add(&self.stats.hub_errors, 1);
        tracing::debug!(error = %e, "hub: {what}");
    }

    /// Does everything that is waiting or due.
    fn step(&mut self, now: Instant) -> Result<(), BridgeError> {
        self.read_hub()?;
        for _ in 0..WANT_QUEUE {
            match self.wants.try_recv() {
                Ok(want) => self.note_want(want),
                Err(_) => break,
            }
        }
        if self.inbox.wants_lost.swap(false, Ordering::Relaxed) {
            self.resync_wants();
        }
        if now >= self.next_relook && self.remote.relook_due() {
            self.next_relook = now + RELOOK_EVERY;
            self.relook();
        }
        if self.wants_changed && now >= self.next_export {
            self.next_export = now + EXPORT_EVERY;
            self.wants_changed = false;
            self.sync_exports();
        }
        // Bounded, so the hub's side is never starved by a busy link.
        for _ in 0..QUEUE {
            match self.data.try_recv() {
                Ok(data) => self.import(data, now),
                Err(_) => break,
            }
        }
        if now >= self.next_status {
            self.next_status = now + self.config.poll;
            if let Err(e) = self.client.request(&[Request::Status]) {
                self.hub_error("status request", &e);
            }
            self.say_whether_the_hub_answers(now);
            // A hub that has gone quiet has no clients to serve: stop asking
            // other sites for their packets until it answers again.
            if matches!(self.client.hub_state(), HubState::Unreachable { .. })
                && self.interest != LocalInterest::default()
            {
                tracing::warn!(site = %self.config.site, "the hub is not answering: withdrawing this site's wants");
                self.want(LocalInterest::default())?;
            }
        }
        if now >= self.next_report {
            self.next_report = now + REPORT_EVERY;
            self.report();
        }
        if let Err(e) = self.client.poll(now) {
            self.hub_error("refresh", &e);
        }
        Ok(())
    }

    /// Says, once, that the hub has not answered (within [`FIRST_ANSWER`] of
    /// the start, or since it fell silent), and again when it answers.
    fn say_whether_the_hub_answers(&mut self, now: Instant) {
        let hub = self.client.hub_addr();
        match self.client.hub_state() {
            HubState::Alive if self.hub_warned => {
                self.hub_warned = false;
                tracing::warn!(site = %self.config.site, %hub, "the hub answers again");
            }
            HubState::Unreachable { .. } if !self.hub_warned => {
                self.hub_warned = true;
                tracing::warn!(site = %self.config.site, %hub, "the hub does not answer; still trying");
            }
            HubState::Unknown
                if !self.hub_warned && now.duration_since(self.started) >= FIRST_ANSWER =>
            {
                self.hub_warned = true;
                tracing::warn!(
                    site = %self.config.site,
                    %hub,
                    "no answer from the hub yet; still trying (is `colony hub` running there? a hub run with --auth-all needs the bridge's --key)"
                );
            }
            _ => {}
        }
    }

    fn read_hub(&mut self) -> Result<(), BridgeError> {
        for _ in 0..HUB_BATCH {
            let seen = match self.client.recv_any() {
                Ok(None) => return Ok(()),
                Err(e) => {
                    self.hub_error("receive", &e);
                    return Ok(());
                }
                Ok(Some(Delivery::Packet(packet))) => {
                    // Only what other sites asked for: a datagram forged from
                    // the hub's address is no reason to put anything.
                    if packet.subjects().all(|s| self.exported.contains(s)) {
                        export(
                            &self.session,
                            &self.config.site,
                            &mut self.stamp_run,
                            &mut self.seqs,
                            &self.stats,
                            &packet,
                        );
                    }
                    continue;
                }
                Ok(Some(Delivery::Reply(Reply::Status(report)))) => {
                    let seen =
                        LocalInterest::from_report(&report, &self.marker(), &self.config.import);
                    if report.truncated {
                        let mut wider = self.interest.clone();
                        wider.widen(seen);
                        wider
                    } else {
                        seen
                    }
                }
                Ok(Some(Delivery::Reply(_))) => continue,
            };
            self.want(seen)?;
        }
        Ok(())
    }

    /// Notes another site's want coming or going.
    fn note_want(&mut self, want: Want) {
        let Some((site, subject)) = keys::parse_want_key(&want.key) else {
            return;
        };
        if site == self.config.site || subject == self.own {
            return;
        }
        if !want.alive {
            if self.remote.withdraw(&site, &subject) {
                self.wants_changed = true;
            }
            return;
        }
        match self.remote.offer(&site, &subject) {
            Offer::Known => {}
            Offer::Held => self.wants_changed = true,
            Offer::HeldInstead(other, gone) => {
                tracing::debug!(%site, %other, %gone, "a want let go for another site's");
                Stats::add(&self.stats.refused_wants, 1);
                self.wants_changed = true;
            }
            Offer::Refused if want.again => {}
            Offer::Refused => Stats::add(&self.stats.refused_wants, 1),
        }
    }

    /// Asks Zenoh again for every live want token, after one was refused
    /// and room has freed. The answers come through the want queue, so the
    /// bridge never waits on a Zenoh peer here.
    fn relook(&mut self) {
        let inbox = self.inbox.clone();
        let asked = self
            .session
            .liveliness()
            .get(keys::all_wants_expr())
            .callback(move |reply| {
                if let Ok(sample) = reply.result() {
                    inbox.want(Want {
                        key: sample.key_expr().as_str().to_owned(),
                        alive: true,
                        again: true,
                    });
                }
            })
            .wait();
        if let Err(e) = asked {
            tracing::warn!(error = %e, "could not list the live want tokens");
        }
    }

    /// Rebuilds other sites' wants from Zenoh's list of live tokens, after
    /// changes were lost on a full queue.
    fn resync_wants(&mut self) {
        tracing::warn!(
            "want tokens arrived faster than the bridge took them: asking Zenoh for all again"
        );
        let replies = match self.session.liveliness().get(keys::all_wants_expr()).wait() {
            Ok(r) => r,
            Err(e) => {
                tracing::warn!(error = %e, "could not list the live want tokens");
                return;
            }
        };
        self.remote.clear();
        while let Ok(Some(reply)) = replies.recv_timeout(Duration::from_secs(2)) {
            if let Ok(sample) = reply.result() {
                let key = sample.key_expr().as_str().to_owned();
                self.note_want(Want {
                    key,
                    alive: true,
                    again: true,
                });
            }
        }
        self.wants_changed = true;
    }

    /// Brings the hub subscriptions toward the channels other sites want
    /// and the export rules allow (at most [`MAX_EXPORTS`], shared between
    /// sites), at most [`EXPORT_CHANGES`] at a time.
    fn sync_exports(&mut self) {
        let export = &self.config.export;
        let allowed = |s: &Subject| any_matches(export, s.as_str());
        let wanted = self.remote.choose(allowed, MAX_EXPORTS);
        let mut left_out = self.remote.wanted(allowed);
        left_out.retain(|s| !wanted.contains(s));
        let newly = left_out.difference(&self.left_out).count();
        Stats::add(&self.stats.refused_wants, newly as u64);
        self.left_out = left_out;
        if wanted == self.exported {
            return;
        }
        tracing::info!(
            site = %self.config.site,
            "other sites want {} channel(s): {}",
            wanted.len(),
            first_names(wanted.iter())
        );
        let mut budget = EXPORT_CHANGES;
        // Room first: the hub refuses a subscription beyond its limit.
        let gone: Vec<Subject> = self.exported.difference(&wanted).cloned().collect();
        for gone in gone.into_iter().take(budget) {
            budget -= 1;
            if let Err(e) = self.client.unsubscribe(gone.as_str()) {
                self.hub_error("unsubscribe", &e);
            }
            self.exported.remove(&gone);
        }
        let new: Vec<Subject> = wanted.difference(&self.exported).cloned().collect();
        for new in new.into_iter().take(budget) {
            if self.exported.len() >= MAX_EXPORTS {
                break;
            }
            if let Err(e) = self.client.subscribe(new.as_str()) {
                self.hub_error("subscribe", &e);
            }
            self.exported.insert(new);
        }
        if self.exported != wanted {
            self.wants_changed = true;
        }
    }

    /// Declares what this site's clients want, and withdraws what they no
    /// longer do (a client's lease ran out: the site stops asking).
    fn want(&mut self, interest: LocalInterest) -> Result<(), BridgeError> {
        if interest == self.interest {
            return Ok(());
        }
        if interest.channels != self.interest.channels {
            tracing::info!(
                site = %self.config.site,
                "this site's clients want {} channel(s): {}",
                interest.channels.len(),
                first_names(interest.channels.iter())
            );
        }
        if interest.other_bridges > 0 && self.interest.other_bridges == 0 {
            tracing::warn!(
                "another bridge is a client of this hub: its subscriptions are taken for no one's \
                 here; run one bridge per hub"
            );
        }
        self.tokens.retain(|s, _| interest.channels.contains(s));
        for channel in &interest.channels {
            if !self.tokens.contains_key(channel) {
                let token = self
                    .session
                    .liveliness()
                    .declare_token(keys::want_key(&self.config.site, channel.as_str()))
                    .wait()
                    .map_err(zerr)?;
                self.tokens.insert(channel.clone(), token);
            }
        }
        let exprs = interest.key_exprs();
        self.subscribers.retain(|e, _| exprs.contains(e));
        for expr in exprs {
            if self.subscribers.contains_key(&expr) {
                continue;
            }
            let inbox = self.inbox.clone();
            let sub = self
                .session
                .declare_subscriber(expr.as_str())
                .callback(move |sample| inbox.data(&sample))
                .wait()
                .map_err(zerr)?;
            self.subscribers.insert(expr, sub);
        }
        self.interest = interest;
        Ok(())
    }

    /// Publishes into the hub a packet another site put, once it is sure
    /// the packet is what its key says and that this site asked for all of it.
    fn import(&mut self, data: Data, now: Instant) {
        let Some((site, subjects)) = keys::read_sample(&data.key, &data.payload) else {
            Stats::add(&self.stats.rejected, 1);
            return;
        };
        if site == self.config.site {
            return;
        }
        // Sets are taken wholesale for clients of many channels; the import
        // rules, and a withdrawal still in flight, are checked here.
        if !subjects.iter().all(|s| self.interest.channels.contains(s)) {
            Stats::add(&self.stats.rejected, 1);
            return;
        }
        if let Some(stamp) = data.stamp {
            match self
                .tracker
                .check(&data.key, data.priority, stamp, &data.payload, now)
            {
                Verdict::Duplicate => {
                    Stats::add(&self.stats.duplicates, 1);
                    return;
                }
                Verdict::New { lost } => Stats::add(&self.stats.lost, lost),
                Verdict::Suspect => Stats::add(&self.stats.suspect, 1),
                Verdict::Late => {
                    let _ =
                        self.stats
                            .lost
                            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |l| {
                                Some(l.saturating_sub(1))
                            });
                }
            }
        }
        match self.client.publish(&data.payload) {
            Ok(()) => Stats::add(&self.stats.imported, 1),
            Err(e) => self.hub_error("publish", &e),
        }
    }

    /// Brings the about text the hub shows up to date.
    fn report(&mut self) {
        let s = &self.stats;
        let about = format!(
            "{} zenoh {}; exports {}; imports {}; lost {} dup {} suspect {} rejected {} overflow {} put_failed {} refused {}",
            self.marker(),
            self.config.mode.as_str(),
            counted(&self.exported),
            counted(&self.interest.channels),
            Stats::get(&s.lost),
            Stats::get(&s.duplicates),
            Stats::get(&s.suspect),
            Stats::get(&s.rejected),
            Stats::get(&s.overflow),
            Stats::get(&s.put_failed),
            Stats::get(&s.refused_wants),
        );
        if let Err(e) = self
            .client
            .set_standing(vec![Request::NoLocal, Request::About(about)])
        {
            self.hub_error("about", &e);
        }
    }
}

/// The first few names, for a log line or the about text.
fn first_names<'a>(names: impl Iterator<Item = &'a Subject>) -> String {
    let shown: Vec<&str> = names.take(4).map(Subject::as_str).collect();
    shown.join(" ")
}

/// `N (a b c d ...)`, or `nothing`.
fn counted(names: &BTreeSet<Subject>) -> String {
    match names.len() {
        0 => "nothing".to_owned(),
        n if n > 4 => format!("{n} ({} ...)", first_names(names.iter())),
        n => format!("{n} ({})", first_names(names.iter())),
    }
}
