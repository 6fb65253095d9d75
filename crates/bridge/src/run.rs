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
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::{ClientConfig, Delivery, UdpClient};
use colony_wire::auth::Key;
use colony_wire::{Packet, Reply, Request, Subject};
use mio::unix::SourceFd;
use mio::{Events, Interest, Poll, Token, Waker};
use std::os::fd::AsRawFd;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::sample::SampleKind;
use zenoh::{Session, Wait};

use crate::config::{any_matches, BridgeConfig};
use crate::interest::LocalInterest;
use crate::keys::{self, Site};
use crate::track::{Stamp, Tracker, Verdict};

const HUB: Token = Token(0);
const WAKE: Token = Token(1);
/// Samples waiting for the bridge's thread; beyond, they are dropped and counted.
const QUEUE: usize = 16_384;
/// The most distinct keys numbered at once (a new run id starts afresh).
const MAX_KEYS: usize = 65_536;
/// How often the about text (and the log line) is brought up to date.
const REPORT_EVERY: Duration = Duration::from_secs(1);

/// Why a bridge could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// The hub's address or socket.
    #[error("hub {hub}: {source}")]
    Hub {
        /// The hub as given.
        hub: String,
        /// Why.
        source: colony_client::ClientError,
    },
    /// Zenoh refused the configuration or could not open.
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// The bridge's own socket or wake-up.
    #[error(transparent)]
    Io(#[from] io::Error),
}

fn zerr(e: impl std::fmt::Display) -> BridgeError {
    BridgeError::Zenoh(e.to_string())
}

/// What a bridge has done, readable from any thread while it runs.
#[derive(Debug, Default)]
pub struct Stats {
    /// Packets put on Zenoh.
    pub exported: AtomicU64,
    /// Packets from other sites published into the hub.
    pub imported: AtomicU64,
    /// Packets of other sites that never arrived (gaps in their numbering).
    pub lost: AtomicU64,
    /// Packets that arrived twice, dropped.
    pub duplicates: AtomicU64,
    /// Samples that were no colony packet, or whose key did not match the
    /// packet, or that addressed the hub: dropped.
    pub rejected: AtomicU64,
    /// Samples dropped because the bridge's thread was behind by [`QUEUE`].
    pub overflow: AtomicU64,
    /// Puts Zenoh refused.
    pub put_failed: AtomicU64,
}

impl Stats {
    fn add(counter: &AtomicU64, n: u64) {
        counter.fetch_add(n, Ordering::Relaxed);
    }

    /// A counter's value now.
    pub fn get(counter: &AtomicU64) -> u64 {
        counter.load(Ordering::Relaxed)
    }
}

enum Event {
    Data {
        key: String,
        payload: Vec<u8>,
        stamp: Option<Stamp>,
    },
    Want {
        key: String,
        alive: bool,
    },
}

/// Passes Zenoh's callbacks to the bridge's thread and wakes it.
#[derive(Clone)]
struct Inbox {
    tx: SyncSender<Event>,
    waker: Arc<Waker>,
    stats: Arc<Stats>,
}

impl Inbox {
    fn send(&self, event: Event) {
        match self.tx.try_send(event) {
            Ok(()) => {
                let _ = self.waker.wake();
            }
            Err(TrySendError::Full(_)) => Stats::add(&self.stats.overflow, 1),
            Err(TrySendError::Disconnected(_)) => {}
        }
    }
}

/// A running bridge between one hub and Zenoh.
pub struct Bridge {
    config: BridgeConfig,
    client: UdpClient,
    session: Session,
    poll: Poll,
    inbox: Inbox,
    rx: Receiver<Event>,
    stats: Arc<Stats>,
    /// Drawn at start: names this run in the about text and in every stamp.
    run: u64,
    seqs: HashMap<String, u64>,
    tracker: Tracker,
    /// Other sites' wants: channel -> the sites that want it.
    remote: HashMap<Subject, BTreeSet<Site>>,
    /// Channels kept subscribed on the hub for other sites.
    exported: BTreeSet<Subject>,
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
        let (tx, rx) = mpsc::sync_channel(QUEUE);
        let stats = Arc::new(Stats::default());
        let inbox = Inbox {
            tx,
            waker,
            stats: stats.clone(),
        };
        let wants = {
            let inbox = inbox.clone();
            session
                .liveliness()
                .declare_subscriber(keys::all_wants_expr())
                .history(true)
                .callback(move |sample| {
                    inbox.send(Event::Want {
                        key: sample.key_expr().as_str().to_owned(),
                        alive: sample.kind() == SampleKind::Put,
                    })
                })
                .wait()
                .map_err(zerr)?
        };
        let run = rand::random::<u64>();
        let now = Instant::now();
        let mut bridge = Bridge {
            client,
            session,
            poll,
            inbox,
            rx,
            stats,
            run,
            seqs: HashMap::new(),
            tracker: Tracker::default(),
            remote: HashMap::new(),
            exported: BTreeSet::new(),
            interest: LocalInterest::default(),
            subscribers: HashMap::new(),
            tokens: HashMap::new(),
            _wants: wants,
            next_status: now,
            next_report: now,
            config,
        };
        // Always one lease, so the hub shows the bridge (and keeps its
        // standing requests) even when no site wants anything from it.
        let own = format!("bridge.{}", bridge.config.site);
        bridge
            .client
            .subscribe(&own)
            .map_err(|source| BridgeError::Hub {
                hub: bridge.config.hub.clone(),
                source,
            })?;
        bridge.report()?;
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

    /// Does everything that is waiting or due.
    fn step(&mut self, now: Instant) -> Result<(), BridgeError> {
        self.read_hub()?;
        // Bounded, so the hub's side is never starved by a busy link.
        for _ in 0..QUEUE {
            match self.rx.try_recv() {
                Ok(event) => self.handle(event)?,
                Err(_) => break,
            }
        }
        if now >= self.next_status {
            self.next_status = now + self.config.poll;
            self.client.request(&[Request::Status])?;
        }
        if now >= self.next_report {
            self.next_report = now + REPORT_EVERY;
            self.report()?;
        }
        self.client.poll(now)?;
        Ok(())
    }

    fn read_hub(&mut self) -> Result<(), BridgeError> {
        loop {
            let interest = match self.client.recv_any()? {
                None => return Ok(()),
                Some(Delivery::Packet(packet)) => {
                    export(
                        &self.session,
                        &self.config.site,
                        self.run,
                        &mut self.seqs,
                        &self.stats,
                        &packet,
                    );
                    continue;
                }
                Some(Delivery::Reply(Reply::Status(report))) => {
                    LocalInterest::from_report(&report, &self.marker(), &self.config.import)
                }
                Some(Delivery::Reply(_)) => continue,
            };
            self.want(interest)?;
        }
    }

    fn handle(&mut self, event: Event) -> Result<(), BridgeError> {
        match event {
            Event::Data {
                key,
                payload,
                stamp,
            } => self.import(&key, &payload, stamp)?,
            Event::Want { key, alive } => {
                let Some((site, subject)) = keys::parse_want_key(&key) else {
                    return Ok(());
                };
                if site == self.config.site {
                    return Ok(());
                }
                let sites = self.remote.entry(subject.clone()).or_default();
                if alive {
                    sites.insert(site);
                } else {
                    sites.remove(&site);
                    if sites.is_empty() {
                        self.remote.remove(&subject);
                    }
                }
                self.sync_exports()?;
            }
        }
        Ok(())
    }

    /// Keeps subscribed on the hub exactly the channels other sites want
    /// and the export rules allow.
    fn sync_exports(&mut self) -> Result<(), BridgeError> {
        let wanted: BTreeSet<Subject> = self
            .remote
            .keys()
            .filter(|s| any_matches(&self.config.export, s.as_str()))
            .cloned()
            .collect();
        if wanted != self.exported {
            let names: Vec<&str> = wanted.iter().map(Subject::as_str).collect();
            tracing::info!(site = %self.config.site, "other sites want: {}", names.join(" "));
        }
        for gone in self.exported.difference(&wanted) {
            self.client
                .unsubscribe(gone.as_str())
                .map_err(|source| BridgeError::Hub {
                    hub: self.config.hub.clone(),
                    source,
                })?;
        }
        for new in wanted.difference(&self.exported) {
            self.client
                .subscribe(new.as_str())
                .map_err(|source| BridgeError::Hub {
                    hub: self.config.hub.clone(),
                    source,
                })?;
        }
        self.exported = wanted;
        Ok(())
    }

    /// Declares what this site's clients want, and withdraws what they no
    /// longer do (a client's lease ran out: the site stops asking).
    fn want(&mut self, interest: LocalInterest) -> Result<(), BridgeError> {
        if interest == self.interest {
            return Ok(());
        }
        if interest.channels != self.interest.channels {
            let names: Vec<&str> = interest.channels.iter().map(Subject::as_str).collect();
            tracing::info!(site = %self.config.site, "this site's clients want: {}", names.join(" "));
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
                .callback(move |sample| {
                    inbox.send(Event::Data {
                        key: sample.key_expr().as_str().to_owned(),
                        payload: sample.payload().to_bytes().into_owned(),
                        stamp: sample
                            .attachment()
                            .and_then(|a| Stamp::from_bytes(&a.to_bytes())),
                    })
                })
                .wait()
                .map_err(zerr)?;
            self.subscribers.insert(expr, sub);
        }
        self.interest = interest;
        Ok(())
    }

    /// Publishes into the hub a packet another site put, once it is sure
    /// the packet is what its key says.
    fn import(
        &mut self,
        key: &str,
        payload: &[u8],
        stamp: Option<Stamp>,
    ) -> Result<(), BridgeError> {
        let Some(site) = keys::sample_site(key, payload) else {
            Stats::add(&self.stats.rejected, 1);
            return Ok(());
        };
        // Zenoh hands a session its own puts too.
        if site == self.config.site {
            return Ok(());
        }
        if let Some(stamp) = stamp {
            match self.tracker.check(key, stamp) {
                Verdict::Duplicate => {
                    Stats::add(&self.stats.duplicates, 1);
                    return Ok(());
                }
                Verdict::New { lost } => Stats::add(&self.stats.lost, lost),
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
        match self.client.publish(payload) {
            Ok(()) => Stats::add(&self.stats.imported, 1),
            Err(e) => {
                tracing::debug!(error = %e, "could not publish an import into the hub");
                Stats::add(&self.stats.rejected, 1);
            }
        }
        Ok(())
    }

    /// Brings the about text the hub shows up to date.
    fn report(&mut self) -> Result<(), BridgeError> {
        let list = |names: &mut dyn Iterator<Item = &Subject>| {
            let all: Vec<&str> = names.map(Subject::as_str).collect();
            let shown = all.iter().take(4).copied().collect::<Vec<_>>().join(" ");
            match all.len() {
                0 => "nothing".to_owned(),
                n if n > 4 => format!("{n} ({shown} ...)"),
                n => format!("{n} ({shown})"),
            }
        };
        let s = &self.stats;
        let about = format!(
            "{} zenoh {}; exports {}; imports {}; lost {} rejected {} overflow {}",
            self.marker(),
            self.config.mode.as_str(),
            list(&mut self.exported.iter()),
            list(&mut self.interest.channels.iter()),
            Stats::get(&s.lost),
            Stats::get(&s.rejected),
            Stats::get(&s.overflow),
        );
        self.client
            .set_standing(vec![Request::NoLocal, Request::About(about)])?;
        Ok(())
    }
}

/// Puts one packet from the hub on its key, numbered.
fn export(
    session: &Session,
    site: &Site,
    run: u64,
    seqs: &mut HashMap<String, u64>,
    stats: &Stats,
    packet: &Packet<'_>,
) {
    let key = keys::data_key(site, packet.subjects());
    if seqs.len() >= MAX_KEYS && !seqs.contains_key(&key) {
        seqs.clear();
    }
    let seq = seqs.entry(key.clone()).or_insert(0);
    *seq += 1;
    let stamp = Stamp { run, seq: *seq };
    let (priority, congestion) = keys::zenoh_qos(packet.priority());
    let put = session
        .put(key, packet.as_str().as_bytes().to_vec())
        .priority(priority)
        .congestion_control(congestion)
        .express(priority == zenoh::qos::Priority::RealTime)
        .attachment(stamp.to_bytes().to_vec())
        .wait();
    match put {
        Ok(()) => Stats::add(&stats.exported, 1),
        Err(e) => {
            tracing::debug!(error = %e, "zenoh refused a put");
            Stats::add(&stats.put_failed, 1);
        }
    }
}

/// Zenoh's configuration for this bridge: no multicast scouting (explicit
/// endpoints only), and connections retried every 250 ms to 1 s, forever, so
/// a restarted router or peer is found again within a second or two.
fn zenoh_config(c: &BridgeConfig) -> Result<zenoh::Config, BridgeError> {
    let mut z = zenoh::Config::default();
    let json = |v: &[String]| {
        let quoted: Vec<String> = v.iter().map(|e| format!("{e:?}")).collect();
        format!("[{}]", quoted.join(","))
    };
    let set = |z: &mut zenoh::Config, key: &str, value: &str| {
        z.insert_json5(key, value)
            .map_err(|e| BridgeError::Zenoh(format!("{key} = {value}: {e}")))
    };
    set(&mut z, "mode", &format!("{:?}", c.mode.as_str()))?;
    set(&mut z, "connect/endpoints", &json(&c.connect))?;
    set(&mut z, "listen/endpoints", &json(&c.listen))?;
    set(&mut z, "scouting/multicast/enabled", "false")?;
    // A zero timeout would mean one try and no retry.
    set(&mut z, "connect/timeout_ms", "-1")?;
    set(&mut z, "connect/exit_on_failure", "false")?;
    set(
        &mut z,
        "connect/retry",
        "{period_init_ms: 250, period_max_ms: 1000, period_increase_factor: 2}",
    )?;
    Ok(z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_endpoint_is_a_clear_error() {
        let mut c = BridgeConfig::new("127.0.0.1:7400", Site::new("lab").unwrap());
        c.connect = vec!["nonsense".into()];
        let Err(e) = zenoh_config(&c) else {
            panic!("a bad endpoint was taken")
        };
        assert!(e.to_string().contains("connect/endpoints"), "{e}");
    }
}
