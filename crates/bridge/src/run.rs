//! The bridge at work: one thread with the hub client and the Zenoh session, woken by the
//! hub's socket and by Zenoh's callbacks (through a mio [`Waker`]). It moves packets, samples,
//! want tokens and time between them and the [`Relay`], and does what the relay says; it
//! decides nothing itself but what an I/O failure means.
//!
//! - **Export.** Other sites' want tokens say which channels they need; the relay keeps those
//!   subscribed on the hub (as a `no_local` client, so the bridge never hears its own imports
//!   back) and puts each packet once on its key. Zenoh sends it only to sites whose bridge
//!   declared a matching subscriber, once per link.
//! - **Import.** The hub's status report says what this site's clients subscribe to; the relay
//!   has the matching want tokens and Zenoh subscribers declared, and what arrives published
//!   into the hub, which hands each packet to exactly the clients subscribed to all its
//!   subjects.
//!
//! Packets go into the hub unchanged, so every site sees the same bytes. A packet comes back
//! out of Zenoh at most once per site: the key expressions never overlap, and a bridge takes
//! nothing from its own site. Why this loop is the bridge's own rather than colony-node's is
//! in [`crate::relay`].

use std::collections::HashMap;
use std::io;
use std::os::fd::AsRawFd;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_client::{ClientConfig, Delivery, UdpClient};
use colony_wire::auth::Key;
use colony_wire::{Reply, Request, Subject};
use mio::unix::SourceFd;
use mio::{Events, Interest, Poll, Token, Waker};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::sample::SampleKind;
use zenoh::{Session, Wait};

use crate::config::BridgeConfig;
use crate::keys;
use crate::relay::{Output, Relay, Sample, ToHub, ToZenoh, Want};
use crate::stats::{zerr, BridgeError, Stats};
use crate::zenoh_io::{self, zenoh_config, Inbox};

const HUB: Token = Token(0);
const WAKE: Token = Token(1);
/// Samples waiting for the bridge's thread; beyond, they are dropped and counted.
const QUEUE: usize = 16_384;
/// Want tokens coming and going, queued apart from data so that a flood of samples cannot lose
/// one; should even these overflow, the bridge asks Zenoh for every live token again.
const WANT_QUEUE: usize = 65_536;
/// Datagrams taken from the hub per step, so the Zenoh side and the timers are served under any
/// flood.
const HUB_BATCH: usize = 1_024;
/// The longest the loop sleeps, so `stop` is seen.
const TICK: Duration = Duration::from_millis(100);
/// How long a listing of the live want tokens waits for each answer.
const LIST_PATIENCE: Duration = Duration::from_secs(2);

/// A running bridge between one hub and Zenoh.
pub struct Bridge {
    relay: Relay,
    client: UdpClient,
    session: Session,
    poll: Poll,
    inbox: Inbox,
    data: Receiver<Sample>,
    wants: Receiver<Want>,
    /// The Zenoh subscribers the relay declared, by key expression.
    subscribers: HashMap<String, Subscriber<()>>,
    /// The want tokens the relay declared, by channel.
    tokens: HashMap<Subject, LivelinessToken>,
    _wants: Subscriber<()>,
}

impl Bridge {
    /// Opens the Zenoh session and the hub client. The hub need not be up yet, nor any other
    /// site: both are found when they come.
    pub fn start(config: BridgeConfig, key: Option<Key>) -> Result<Bridge, BridgeError> {
        let hub = config.hub.clone();
        let hub_error = |source| BridgeError::Hub {
            hub: hub.clone(),
            source,
        };
        let mut client = UdpClient::with_config(config.hub.as_str(), ClientConfig::default())
            .map_err(hub_error)?;
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
        let relay = Relay::new(config, client.hub_addr(), Instant::now());
        let inbox = Inbox {
            data: data_tx,
            wants: wants_tx,
            wants_lost: Arc::new(AtomicBool::new(false)),
            waker,
            stats: relay.stats(),
            own_prefix: format!("{}/{}/", keys::PREFIX, relay.config().site),
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
        // Always one lease, so the hub shows the bridge (and keeps its standing requests)
        // even when no site wants anything from it.
        client
            .subscribe(relay.own_channel().as_str())
            .map_err(hub_error)?;
        let mut bridge = Bridge {
            relay,
            client,
            session,
            poll,
            inbox,
            data,
            wants,
            subscribers: HashMap::new(),
            tokens: HashMap::new(),
            _wants: want_sub,
        };
        bridge.flush()?;
        Ok(bridge)
    }

    /// The counters, shared: read them while [`run`](Self::run) goes on.
    pub fn stats(&self) -> Arc<Stats> {
        self.relay.stats()
    }

    /// The start of this bridge's about text in the hub's status report.
    pub fn marker(&self) -> String {
        self.relay.marker()
    }

    /// Runs until `stop` is set (checked at least every 100 ms).
    pub fn run(&mut self, stop: &AtomicBool) -> Result<(), BridgeError> {
        let mut events = Events::with_capacity(16);
        while !stop.load(Ordering::Relaxed) {
            let now = Instant::now();
            let deadline = [self.client.next_deadline(), Some(self.relay.poll_timeout())]
                .into_iter()
                .flatten()
                .fold(now + TICK, Instant::min);
            let wait = deadline.saturating_duration_since(now);
            match self.poll.poll(&mut events, Some(wait)) {
                Ok(()) => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            }
            self.step(Instant::now())?;
        }
        Ok(())
    }

    /// Hands the relay everything waiting and the time, doing what it says after each.
    fn step(&mut self, now: Instant) -> Result<(), BridgeError> {
        self.read_hub()?;
        for _ in 0..WANT_QUEUE {
            match self.wants.try_recv() {
                Ok(want) => self.relay.handle_want(want),
                Err(_) => break,
            }
        }
        if self.inbox.wants_lost.swap(false, Ordering::Relaxed) {
            self.relay.handle_wants_lost();
        }
        self.flush()?;
        // Bounded, so the hub's side is never starved by a busy link.
        for _ in 0..QUEUE {
            match self.data.try_recv() {
                Ok(sample) => self.relay.handle_sample(now, sample),
                Err(_) => break,
            }
            self.flush()?;
        }
        self.relay.handle_timeout(now, self.client.hub_state());
        self.flush()?;
        if let Err(e) = self.client.poll(now) {
            self.relay.hub_error("refresh", &e);
        }
        Ok(())
    }

    /// Takes what the hub sent, at most [`HUB_BATCH`] datagrams.
    fn read_hub(&mut self) -> Result<(), BridgeError> {
        for _ in 0..HUB_BATCH {
            match self.client.recv_any() {
                Ok(None) => return Ok(()),
                Err(e) => {
                    self.relay.hub_error("receive", &e);
                    return Ok(());
                }
                Ok(Some(Delivery::Packet(packet))) => self.relay.handle_packet(&packet),
                Ok(Some(Delivery::Reply(Reply::Status(report)))) => {
                    self.relay.handle_status(&report)
                }
                Ok(Some(Delivery::Reply(_))) => continue,
            }
            self.flush()?;
        }
        Ok(())
    }

    /// Does what the relay wants done. Only Zenoh refusing a declaration ends the bridge.
    fn flush(&mut self) -> Result<(), BridgeError> {
        while let Some(output) = self.relay.poll_output() {
            match output {
                Output::Hub(op) => self.on_hub(op),
                Output::Zenoh(op) => self.on_zenoh(op)?,
            }
        }
        Ok(())
    }

    fn on_hub(&mut self, op: ToHub) {
        let c = &mut self.client;
        let done = match &op {
            ToHub::Publish(packet) => c.publish(packet).map_err(|e| e.to_string()),
            ToHub::Subscribe(s) => c.subscribe(s.as_str()).map_err(|e| e.to_string()),
            ToHub::Unsubscribe(s) => c.unsubscribe(s.as_str()).map_err(|e| e.to_string()),
            ToHub::AskStatus => c.request(&[Request::Status]).map_err(|e| e.to_string()),
            ToHub::Standing(requests) => {
                c.set_standing(requests.clone()).map_err(|e| e.to_string())
            }
        };
        self.relay.hub_done(&op, done);
    }

    fn on_zenoh(&mut self, op: ToZenoh) -> Result<(), BridgeError> {
        match op {
            ToZenoh::Put(put) => {
                let done = zenoh_io::put(&self.session, put);
                self.relay.put_done(done);
            }
            ToZenoh::DeclareToken { channel, key } => {
                let token = self
                    .session
                    .liveliness()
                    .declare_token(key)
                    .wait()
                    .map_err(zerr)?;
                self.tokens.insert(channel, token);
            }
            ToZenoh::UndeclareToken(channel) => drop(self.tokens.remove(&channel)),
            ToZenoh::DeclareSubscriber(expr) => {
                let inbox = self.inbox.clone();
                let sub = self
                    .session
                    .declare_subscriber(expr.as_str())
                    .callback(move |sample| inbox.data(&sample))
                    .wait()
                    .map_err(zerr)?;
                self.subscribers.insert(expr, sub);
            }
            ToZenoh::UndeclareSubscriber(expr) => drop(self.subscribers.remove(&expr)),
            ToZenoh::Relook => self.relook(),
            ToZenoh::ListWants => self.list_wants(),
        }
        Ok(())
    }

    /// Asks Zenoh again for every live want token; the answers come through the want queue,
    /// so the bridge never waits on a Zenoh peer here.
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

    /// Lists the live want tokens, waiting for the answers, for the relay to rebuild other
    /// sites' wants from: changes were lost on a full queue, so only a whole list will do.
    fn list_wants(&mut self) {
        let replies = match self.session.liveliness().get(keys::all_wants_expr()).wait() {
            Ok(r) => r,
            Err(e) => {
                tracing::warn!(error = %e, "could not list the live want tokens");
                return;
            }
        };
        let mut keys = Vec::new();
        while let Ok(Some(reply)) = replies.recv_timeout(LIST_PATIENCE) {
            if let Ok(sample) = reply.result() {
                keys.push(sample.key_expr().as_str().to_owned());
            }
        }
        self.relay.handle_want_list(keys);
    }
}
