//! The bridge's decisions with no socket, no Zenoh session and no clock: the sans-IO core that
//! [`Bridge`](crate::Bridge) runs.
//!
//! [`Relay`] is in the shape of the hub's own sans-IO `Hub` and the monitor's hub link: what
//! arrived and the time go in, what to do comes out.
//!
//! - **In**: a packet the hub forwarded ([`handle_packet`](Relay::handle_packet)), a status
//!   report ([`handle_status`](Relay::handle_status)), a sample another site put
//!   ([`handle_sample`](Relay::handle_sample)), a want token coming or going
//!   ([`handle_want`](Relay::handle_want)), word that some of those were lost on a full queue
//!   ([`handle_wants_lost`](Relay::handle_wants_lost)) and then Zenoh's list of the live ones
//!   ([`handle_want_list`](Relay::handle_want_list)), and time
//!   ([`handle_timeout`](Relay::handle_timeout), with what the hub client makes of its hub).
//! - **Out**: [`poll_output`](Relay::poll_output), in the order it is to be done: packets to
//!   publish into the hub and control requests for it ([`ToHub`]), puts, want tokens and
//!   subscribers for Zenoh ([`ToZenoh`]); and [`poll_timeout`](Relay::poll_timeout), the next
//!   deadline. What became of an output comes back through [`hub_done`](Relay::hub_done) and
//!   [`put_done`](Relay::put_done), which count it in [`Stats`].
//!
//! It holds everything that decides: other sites' wants and the channels exported for them (at
//! most [`MAX_EXPORTS`], changed at most [`EXPORT_CHANGES`] every [`EXPORT_EVERY`]), this
//! site's interest (the tokens and subscribers declared for it are what it names), the
//! numbering of puts and the verdicts on what arrives, and the timers: status every `poll`, the
//! about text every [`REPORT_EVERY`], Zenoh asked again for the live want tokens at most every
//! [`RELOOK_EVERY`].
//!
//! **Why not colony-node's runtime.** A `colony_node::Node` is one hub client whose only
//! outputs are packets to publish and whose only inputs are forwarded packets and time, and
//! its `Link` (driven by `colony_node::run` or a `Mux`) sleeps on the hub's socket alone. The
//! bridge does not fit that without more than a small extension:
//!
//! - it has a second side that must wake it: Zenoh's callbacks hand samples and want tokens
//!   over from Zenoh's threads and wake the loop through a mio `Waker`. `Link::wait` sleeps
//!   in `UdpClient::wait` on the hub's socket, and `run` looks back only every 50 ms, so an
//!   import would wait up to 50 ms; a `Mux` owns its mio poll and gives no way to register a
//!   waker in it;
//! - most of what it decides is not a packet: Zenoh puts (with priority, congestion control
//!   and a stamp), want tokens and subscribers to declare and undeclare, listings of the live
//!   tokens, and on the hub's side the standing `no_local` and about text and status requests,
//!   none of which `Node::poll_transmit` can say;
//! - it lives on the hub's replies: `Link` reads with `UdpClient::recv`, which passes over the
//!   status reports this site's interest is read from;
//! - no error talking to the hub may end it (a restarting hub is counted in `hub_errors`),
//!   where `Link::pump` returns at the first one and `run` ends; and an import counts as
//!   `imported` only once the hub client took it, where `poll_transmit` is fire and forget;
//! - `Link` holds a new client's packets up to 500 ms for the hub's first cookie: imports
//!   would wait behind it.
//!
//! So the bridge keeps its own thin loop ([`Bridge::run`](crate::Bridge::run)).
//!
//! **Time** is `std::time::Instant`, as the hub client counts its deadlines and the
//! [`Tracker`] the quiet of a stream: `colony_node::Time` would be turned back into an
//! `Instant` at every call. It is an argument only where it decides something (a sample's
//! verdict, the timers): a hub packet, a status report or a want token is handled the same
//! whenever it comes.

use std::collections::{BTreeSet, HashMap, VecDeque};
use std::fmt::Display;
use std::net::SocketAddr;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::HubState;
use colony_wire::{Packet, Request, StatusReport, Subject};
use zenoh::qos::{CongestionControl, Priority as ZPriority};

use crate::config::{any_matches, BridgeConfig};
use crate::interest::LocalInterest;
use crate::keys;
use crate::stats::Stats;
use crate::track::{Stamp, Tracker, Verdict};
use crate::wants::{Offer, Wants};

/// The most channels kept subscribed on the hub for other sites: the hub grants a client 256
/// subscriptions, and one is the bridge's own.
pub const MAX_EXPORTS: usize = 255;
/// Hub subscriptions brought in line with other sites' wants at most this often, and at most
/// [`EXPORT_CHANGES`] changed each time: a stranger toggling want tokens must not make the
/// bridge spend its hub's control rate (200 requests a second by default) and be refused.
pub const EXPORT_EVERY: Duration = Duration::from_millis(100);
/// Subscribes and unsubscribes sent to the hub per [`EXPORT_EVERY`].
pub const EXPORT_CHANGES: usize = 10;
/// Zenoh asked again for the live want tokens at most this often, when a want was refused and
/// room has freed since.
pub const RELOOK_EVERY: Duration = Duration::from_secs(1);
/// How often the about text (and the log line) is brought up to date.
pub const REPORT_EVERY: Duration = Duration::from_secs(1);
/// How long the bridge waits for its hub's first answer before it says none came.
pub const FIRST_ANSWER: Duration = Duration::from_secs(3);
/// The most distinct keys numbered at once (a new stamp run starts afresh).
const MAX_KEYS: usize = 65_536;

/// A sample another site put, as Zenoh's callback hands it over.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sample {
    /// Its key.
    pub key: String,
    /// Its bytes: a colony packet, if it is what its key says.
    pub payload: Vec<u8>,
    /// Its Zenoh priority, as a number.
    pub priority: u8,
    /// Its attachment, if that was a stamp.
    pub stamp: Option<Stamp>,
}

/// A want token coming or going.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Want {
    /// The token's key, `colony/<site>/want/<channel>`.
    pub key: String,
    /// Declared (or listed alive) rather than withdrawn.
    pub alive: bool,
    /// From a fresh listing of the live tokens: refused again, it is not counted again.
    pub again: bool,
}

/// Something to do on the hub, with the bridge's one hub client.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ToHub {
    /// Publish another site's packet (an import).
    Publish(Vec<u8>),
    /// Subscribe to a channel another site wants.
    Subscribe(Subject),
    /// Let go of a channel no other site wants any more.
    Unsubscribe(Subject),
    /// Ask for the status report (what this site's clients subscribe to).
    AskStatus,
    /// Make these the client's standing requests: `no_local` and the about text.
    Standing(Vec<Request>),
}

impl ToHub {
    /// What it is, for a log line.
    pub fn what(&self) -> &'static str {
        match self {
            ToHub::Publish(_) => "publish",
            ToHub::Subscribe(_) => "subscribe",
            ToHub::Unsubscribe(_) => "unsubscribe",
            ToHub::AskStatus => "status request",
            ToHub::Standing(_) => "about",
        }
    }
}

/// A packet from the hub to put on Zenoh.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Put {
    /// Its key ([`keys::data_key`]).
    pub key: String,
    /// The packet's bytes, unchanged.
    pub payload: Vec<u8>,
    /// Zenoh's priority for the packet's ([`keys::zenoh_qos`]).
    pub priority: ZPriority,
    /// Whether Zenoh may drop it on a congested link.
    pub congestion: CongestionControl,
    /// Sent at once rather than batched (the operator's override).
    pub express: bool,
    /// Its number, the attachment.
    pub stamp: Stamp,
}

/// Something to do on Zenoh.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ToZenoh {
    /// Put a packet; tell [`Relay::put_done`] how it went.
    Put(Put),
    /// Declare the want token `key` for `channel`.
    DeclareToken {
        /// The channel this site's clients want.
        channel: Subject,
        /// `colony/<site>/want/<channel>`.
        key: String,
    },
    /// Withdraw the want token for this channel.
    UndeclareToken(Subject),
    /// Declare a subscriber on this key expression, its samples for [`Relay::handle_sample`].
    DeclareSubscriber(String),
    /// Undeclare the subscriber on this key expression.
    UndeclareSubscriber(String),
    /// Ask Zenoh for every live want token without waiting: the answers are for
    /// [`Relay::handle_want`], each with `again` set.
    Relook,
    /// List every live want token now, and hand the keys to [`Relay::handle_want_list`].
    ListWants,
}

/// What the relay wants done, in order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Output {
    /// On the hub.
    Hub(ToHub),
    /// On Zenoh.
    Zenoh(ToZenoh),
}

/// The bridge with no socket, no session and no clock: see the [module](self).
pub struct Relay {
    config: BridgeConfig,
    /// The hub's address, for log lines.
    hub: SocketAddr,
    /// The bridge's own channel, held so the hub shows it.
    own: Subject,
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
    /// What this site's clients want: the tokens and subscribers declared are what it names.
    interest: LocalInterest,
    /// When it started, and whether it has said the hub is not answering (so a person learns
    /// it within seconds, and once).
    started: Instant,
    hub_warned: bool,
    next_export: Instant,
    next_relook: Instant,
    next_status: Instant,
    next_report: Instant,
    outputs: VecDeque<Output>,
}

impl Relay {
    /// A relay for `config`'s site, made at `now`, whose hub is at `hub`. Its first output is
    /// the standing requests (the about text): the hub shows the bridge as soon as it holds
    /// its own channel ([`own_channel`](Self::own_channel)), which the runtime subscribes to
    /// first. Status and the about text are due at once.
    pub fn new(config: BridgeConfig, hub: SocketAddr, now: Instant) -> Relay {
        let own = Subject::new(&format!("bridge.{}", config.site))
            .expect("a site name makes a valid subject");
        let mut relay = Relay {
            config,
            hub,
            own,
            stats: Arc::new(Stats::default()),
            run: rand::random(),
            stamp_run: rand::random(),
            seqs: HashMap::new(),
            tracker: Tracker::default(),
            remote: Wants::default(),
            exported: BTreeSet::new(),
            left_out: BTreeSet::new(),
            wants_changed: false,
            interest: LocalInterest::default(),
            started: now,
            hub_warned: false,
            next_export: now,
            next_relook: now,
            next_status: now,
            next_report: now,
            outputs: VecDeque::new(),
        };
        relay.report();
        relay
    }

    /// The counters, shared with Zenoh's callbacks and whoever reads them.
    pub fn stats(&self) -> Arc<Stats> {
        self.stats.clone()
    }

    /// The channel the bridge always holds on its hub, `bridge.<site>`.
    pub fn own_channel(&self) -> &Subject {
        &self.own
    }

    /// The start of this bridge's about text in the hub's status report.
    pub fn marker(&self) -> String {
        format!("bridge {} run {:016x}:", self.config.site, self.run)
    }

    /// The configuration it runs on.
    pub fn config(&self) -> &BridgeConfig {
        &self.config
    }

    /// The next thing to do, if any.
    pub fn poll_output(&mut self) -> Option<Output> {
        self.outputs.pop_front()
    }

    /// When [`handle_timeout`](Self::handle_timeout) next has something to do: status and the
    /// about text always, the hub subscriptions while other sites' wants changed, a re-look
    /// while one is pending.
    pub fn poll_timeout(&self) -> Instant {
        let mut deadline = self.next_status.min(self.next_report);
        if self.wants_changed {
            deadline = deadline.min(self.next_export);
        }
        if self.remote.relook_pending() {
            deadline = deadline.min(self.next_relook);
        }
        deadline
    }

    fn hub_do(&mut self, op: ToHub) {
        self.outputs.push_back(Output::Hub(op));
    }

    fn zenoh_do(&mut self, op: ToZenoh) {
        self.outputs.push_back(Output::Zenoh(op));
    }

    /// A failure to talk to the hub: counted and logged, never the end of the bridge (the hub
    /// may be restarting, or its host rebooting).
    pub fn hub_error(&self, what: &str, e: &dyn Display) {
        Stats::add(&self.stats.hub_errors, 1);
        tracing::debug!(error = %e, "hub: {what}");
    }

    /// What became of `op` on the hub: an import counts once the client took it.
    pub fn hub_done(&self, op: &ToHub, result: Result<(), String>) {
        match result {
            Ok(()) if matches!(op, ToHub::Publish(_)) => Stats::add(&self.stats.imported, 1),
            Ok(()) => {}
            Err(e) => self.hub_error(op.what(), &e),
        }
    }

    /// What became of a [`ToZenoh::Put`].
    pub fn put_done(&self, result: Result<(), String>) {
        match result {
            Ok(()) => Stats::add(&self.stats.exported, 1),
            Err(e) => {
                tracing::debug!(error = %e, "zenoh refused a put");
                Stats::add(&self.stats.put_failed, 1);
            }
        }
    }

    /// A packet the hub forwarded: put on Zenoh if other sites asked for every one of its
    /// subjects (a datagram forged from the hub's address is no reason to put anything).
    pub fn handle_packet(&mut self, packet: &Packet<'_>) {
        if packet.subjects().all(|s| self.exported.contains(s)) {
            self.export(packet);
        }
    }

    /// Numbers `packet` per key and Zenoh priority, and puts it.
    fn export(&mut self, packet: &Packet<'_>) {
        let key = keys::data_key(&self.config.site, packet.subjects());
        let (priority, congestion) = keys::zenoh_qos(packet.priority());
        let stream = (key, priority as u8);
        if self.seqs.len() >= MAX_KEYS && !self.seqs.contains_key(&stream) {
            // Numbering afresh under the same run would read as repeats.
            self.seqs.clear();
            self.stamp_run = rand::random();
        }
        let seq = self.seqs.entry(stream.clone()).or_insert(0);
        *seq += 1;
        let stamp = Stamp {
            run: self.stamp_run,
            seq: *seq,
        };
        self.zenoh_do(ToZenoh::Put(Put {
            key: stream.0,
            payload: packet.as_str().as_bytes().to_vec(),
            priority,
            congestion,
            express: priority == ZPriority::RealTime,
            stamp,
        }));
    }

    /// A status report: what this site's clients subscribe to, within `import`, becomes the
    /// wants declared. A report cut short only adds: it leaves clients out, and must not
    /// withdraw what they want.
    pub fn handle_status(&mut self, report: &StatusReport) {
        let seen = LocalInterest::from_report(report, &self.marker(), &self.config.import);
        let seen = if report.truncated {
            let mut wider = self.interest.clone();
            wider.widen(seen);
            wider
        } else {
            seen
        };
        self.want(seen);
    }

    /// Declares what this site's clients want, and withdraws what they no longer do (a
    /// client's lease ran out: the site stops asking).
    fn want(&mut self, interest: LocalInterest) {
        if interest == self.interest {
            return;
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
        let before = std::mem::replace(&mut self.interest, interest);
        let gone: Vec<Subject> = before
            .channels
            .difference(&self.interest.channels)
            .cloned()
            .collect();
        let new: Vec<Subject> = self
            .interest
            .channels
            .difference(&before.channels)
            .cloned()
            .collect();
        for channel in gone {
            self.zenoh_do(ToZenoh::UndeclareToken(channel));
        }
        for channel in new {
            let key = keys::want_key(&self.config.site, channel.as_str());
            self.zenoh_do(ToZenoh::DeclareToken { channel, key });
        }
        let (had, has) = (before.key_exprs(), self.interest.key_exprs());
        for expr in had.difference(&has) {
            self.zenoh_do(ToZenoh::UndeclareSubscriber(expr.clone()));
        }
        for expr in has.difference(&had) {
            self.zenoh_do(ToZenoh::DeclareSubscriber(expr.clone()));
        }
    }

    /// Another site's want coming or going.
    pub fn handle_want(&mut self, want: Want) {
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

    /// Want tokens came faster than they were taken, and some were lost: Zenoh is to list
    /// every live one ([`ToZenoh::ListWants`]).
    pub fn handle_wants_lost(&mut self) {
        tracing::warn!(
            "want tokens arrived faster than the bridge took them: asking Zenoh for all again"
        );
        self.zenoh_do(ToZenoh::ListWants);
    }

    /// Zenoh's list of the live want tokens' keys: other sites' wants are rebuilt from it.
    pub fn handle_want_list(&mut self, keys: impl IntoIterator<Item = String>) {
        self.remote.clear();
        for key in keys {
            self.handle_want(Want {
                key,
                alive: true,
                again: true,
            });
        }
        self.wants_changed = true;
    }

    /// A sample another site put, arriving at `now`: published into the hub once it is sure
    /// the packet is what its key says and that this site asked for all of it.
    pub fn handle_sample(&mut self, now: Instant, sample: Sample) {
        let Some((site, subjects)) = keys::read_sample(&sample.key, &sample.payload) else {
            Stats::add(&self.stats.rejected, 1);
            return;
        };
        if site == self.config.site {
            return;
        }
        // Sets are taken wholesale for clients of many channels; the import rules, and a
        // withdrawal still in flight, are checked here.
        if !subjects.iter().all(|s| self.interest.channels.contains(s)) {
            Stats::add(&self.stats.rejected, 1);
            return;
        }
        if let Some(stamp) = sample.stamp {
            let verdict =
                self.tracker
                    .check(&sample.key, sample.priority, stamp, &sample.payload, now);
            match verdict {
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
        self.hub_do(ToHub::Publish(sample.payload));
    }

    /// Does everything due by `now`: a re-look at the live want tokens, the hub subscriptions
    /// brought toward other sites' wants, status asked for (and, with `hub` as the hub client
    /// sees it, a word when the hub stops or starts answering), the about text.
    pub fn handle_timeout(&mut self, now: Instant, hub: HubState) {
        if now >= self.next_relook && self.remote.relook_due() {
            self.next_relook = now + RELOOK_EVERY;
            self.zenoh_do(ToZenoh::Relook);
        }
        if self.wants_changed && now >= self.next_export {
            self.next_export = now + EXPORT_EVERY;
            self.wants_changed = false;
            self.sync_exports();
        }
        if now >= self.next_status {
            self.next_status = now + self.config.poll;
            self.hub_do(ToHub::AskStatus);
            self.say_whether_the_hub_answers(now, hub);
            // A hub that has gone quiet has no clients to serve: stop asking other sites for
            // their packets until it answers again.
            if matches!(hub, HubState::Unreachable { .. })
                && self.interest != LocalInterest::default()
            {
                tracing::warn!(site = %self.config.site, "the hub is not answering: withdrawing this site's wants");
                self.want(LocalInterest::default());
            }
        }
        if now >= self.next_report {
            self.next_report = now + REPORT_EVERY;
            self.report();
        }
    }

    /// Says, once, that the hub has not answered (within [`FIRST_ANSWER`] of the start, or
    /// since it fell silent), and again when it answers.
    fn say_whether_the_hub_answers(&mut self, now: Instant, state: HubState) {
        let hub = self.hub;
        match state {
            HubState::Alive if self.hub_warned => {
                self.hub_warned = false;
                tracing::warn!(site = %self.config.site, %hub, "the hub answers again");
            }
            HubState::Unreachable { .. } if !self.hub_warned => {
                self.hub_warned = true;
                tracing::warn!(site = %self.config.site, %hub, "the hub does not answer; still trying");
            }
            HubState::Unknown
                if !self.hub_warned
                    && now.saturating_duration_since(self.started) >= FIRST_ANSWER =>
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

    /// Brings the hub subscriptions toward the channels other sites want and the export rules
    /// allow (at most [`MAX_EXPORTS`], shared between sites), at most [`EXPORT_CHANGES`] at a
    /// time.
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
            self.exported.remove(&gone);
            self.hub_do(ToHub::Unsubscribe(gone));
        }
        let new: Vec<Subject> = wanted.difference(&self.exported).cloned().collect();
        for new in new.into_iter().take(budget) {
            if self.exported.len() >= MAX_EXPORTS {
                break;
            }
            self.exported.insert(new.clone());
            self.hub_do(ToHub::Subscribe(new));
        }
        if self.exported != wanted {
            self.wants_changed = true;
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
        self.hub_do(ToHub::Standing(vec![
            Request::NoLocal,
            Request::About(about),
        ]));
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

#[cfg(test)]
mod tests;
