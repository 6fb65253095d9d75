//! One viewer's connection, with no socket and no clock: what it subscribed to, the channels
//! it publishes on, and what waits to be sent to it.
//!
//! A slow viewer never holds anything up: each channel keeps at most its [`PER_CHANNEL`] newest
//! messages waiting, and the connection at most [`MAX_PENDING`] (beyond that the oldest of the
//! longest queue goes; [`Session::on_message`]), so a viewer that cannot keep up is sent the
//! newest data and every message dropped before it went out is counted ([`Session::dropped`]);
//! a status message tells the viewer how many, at most every [`DROP_REPORT_EVERY`]. (A few per
//! channel, not one: several publishers share a channel, such as each robot's `debug`, and their
//! packets of one step arrive together.) A scene channel ([`Session::newest_only`]) keeps only
//! its newest message: each is a whole frame of the world (megabytes for 10,000 robots), so a
//! slow viewer has older frames dropped whole, counted, and never a backlog of them. Waiting
//! channels are sent in turn, so one busy channel cannot starve the others.
//!
//! A viewer may publish only the operator's override: on [`OVERRIDE_TOPIC`] (the monitor page's
//! own override requests as JSON, such as `{"t":"drive","ids":[3],"forward":0.5,"turn":0}`) or
//! on `radio` (a colony packet in colony-schema's JSON, whose `cmd` lines take and drive those
//! robots). Either is handed on as a [`Request`], which the application the endpoint serves reads
//! as its override's commands (the monitor: the page's, carried out exactly as a page's, held
//! for this connection, released when it closes; see [`crate::Operator`]). Anything else is
//! refused.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::time::{Duration, Instant};

use colony_proto::radio::{self, RadioCommand};
use colony_wire::Packet;

use crate::protocol::{self, Channel, ClientChannel, ClientOp, Level};

/// The topic a viewer publishes the monitor page's override requests on.
pub const OVERRIDE_TOPIC: &str = "/colony/override";
/// Subscriptions one viewer may hold at once.
pub const MAX_SUBSCRIPTIONS: usize = 1024;
/// Channels one viewer may advertise at once.
pub const MAX_CLIENT_CHANNELS: usize = 16;
/// Messages waiting per channel, at most.
pub const PER_CHANNEL: usize = 8;
/// Messages waiting per connection, at most.
pub const MAX_PENDING: usize = 256;
/// Status messages waiting to be sent, at most (older ones are dropped first).
const MAX_TEXTS: usize = 64;
/// Drops are reported at most this often.
pub const DROP_REPORT_EVERY: Duration = Duration::from_secs(2);

/// Something for the connection to do.
#[derive(Debug, Clone, PartialEq)]
pub enum Out<P> {
    /// Send this text frame.
    Text(String),
    /// Send this subscription's message, received at `receive_ns`.
    Message {
        /// The viewer's subscription id.
        subscription: u32,
        /// When the monitor received it, nanoseconds since the Unix epoch.
        receive_ns: u64,
        /// The message.
        payload: P,
    },
}

/// What a viewer published on a channel it may publish on, read as far as the endpoint reads
/// it; what it means is the application's ([`crate::Operator::read`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    /// A message on [`OVERRIDE_TOPIC`]: the monitor page's own override request, JSON text.
    Override(String),
    /// A message on `radio`: the `cmd` lines of a packet on `radio` alone (at least one).
    Radio(Vec<RadioCommand>),
}

/// Where a viewer's client channel goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sink {
    /// The page's override requests, as JSON.
    Override,
    /// Radio packets in colony-schema's JSON.
    Radio,
}

/// One viewer's state. `P` is what a message is (the connection's payload).
#[derive(Debug)]
pub struct Session<P> {
    /// Channels the viewer was told of, by id.
    known: BTreeMap<u32, String>,
    /// Subscription id to channel id, and back.
    subscriptions: HashMap<u32, u32>,
    by_channel: HashMap<u32, u32>,
    client_channels: HashMap<u32, Sink>,
    /// The newest messages waiting on each channel, oldest first.
    pending: BTreeMap<u32, VecDeque<(u64, P)>>,
    /// Messages in `pending`.
    waiting: usize,
    /// The channel sent last, so waiting channels go in turn.
    last_sent: Option<u32>,
    texts: VecDeque<String>,
    dropped: u64,
    reported: u64,
    next_report: Option<Instant>,
    /// Channels that keep only their newest message waiting (scenes: each a whole frame).
    newest_only: std::collections::BTreeSet<u32>,
}

impl<P> Default for Session<P> {
    fn default() -> Self {
        Session {
            known: BTreeMap::new(),
            subscriptions: HashMap::new(),
            by_channel: HashMap::new(),
            client_channels: HashMap::new(),
            pending: BTreeMap::new(),
            waiting: 0,
            last_sent: None,
            texts: VecDeque::new(),
            newest_only: std::collections::BTreeSet::new(),
            dropped: 0,
            reported: 0,
            next_report: None,
        }
    }
}

impl<P: Clone> Session<P> {
    /// A new connection: `serverInfo` waits to be sent.
    pub fn new(name: &str, session_id: &str) -> Session<P> {
        let mut s = Session::default();
        s.texts.push_back(protocol::server_info(name, session_id));
        s
    }

    /// Messages replaced before they were sent, and missed by falling behind the feed.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Whether the viewer is subscribed to any channel.
    pub fn has_subscriptions(&self) -> bool {
        !self.by_channel.is_empty()
    }

    /// Whether the viewer is subscribed to `channel`.
    pub fn is_subscribed(&self, channel: u32) -> bool {
        self.by_channel.contains_key(&channel)
    }

    /// Channels the server now offers: those new to this viewer are advertised. (Advertisements
    /// are never dropped: there are at most as many as the feed's channels.)
    pub fn on_channels(&mut self, channels: &[Channel]) {
        let new: Vec<&Channel> = channels
            .iter()
            .filter(|c| !self.known.contains_key(&c.id))
            .collect();
        if new.is_empty() {
            return;
        }
        for c in &new {
            self.known.insert(c.id, c.topic.clone());
        }
        self.texts.push_back(protocol::advertise(&new));
    }

    /// Keeps at most one message of `channel` waiting, the newest: a channel whose every
    /// message is a whole frame (a scene), where an older one is of no use once a newer is in.
    pub fn newest_only(&mut self, channel: u32) {
        self.newest_only.insert(channel);
    }

    /// A message on `channel`, received at `receive_ns`: kept if the viewer subscribed. When
    /// its channel already has [`PER_CHANNEL`] waiting (one, for a [`newest_only`](Self::newest_only)
    /// channel), the oldest of them is dropped; when the connection has [`MAX_PENDING`], the
    /// oldest of the longest queue.
    pub fn on_message(&mut self, channel: u32, receive_ns: u64, payload: P) {
        if !self.by_channel.contains_key(&channel) {
            return;
        }
        let room = if self.newest_only.contains(&channel) {
            1
        } else {
            PER_CHANNEL
        };
        let full = self.pending.get(&channel).is_some_and(|q| q.len() >= room);
        let victim = if full {
            Some(channel)
        } else if self.waiting >= MAX_PENDING {
            self.pending
                .iter()
                .max_by_key(|(_, q)| q.len())
                .map(|(c, _)| *c)
        } else {
            None
        };
        if let Some(q) = victim.and_then(|c| self.pending.get_mut(&c)) {
            if q.pop_front().is_some() {
                self.waiting -= 1;
                self.dropped += 1;
            }
        }
        self.pending
            .entry(channel)
            .or_default()
            .push_back((receive_ns, payload));
        self.waiting += 1;
    }

    /// The viewer fell behind the feed by `n` messages.
    pub fn on_missed(&mut self, n: u64) {
        self.dropped += n;
    }

    /// A text frame from the viewer; returns the override requests it carries, if any.
    pub fn handle_text(&mut self, text: &str) -> Vec<Request> {
        match protocol::parse_text(text) {
            Ok(op) => self.handle(op),
            Err(e) => {
                self.status(Level::Error, &e.to_string());
                Vec::new()
            }
        }
    }

    /// A binary frame from the viewer; returns the override requests it carries, if any.
    pub fn handle_binary(&mut self, frame: &[u8]) -> Vec<Request> {
        match protocol::parse_binary(frame) {
            Ok(op) => self.handle(op),
            Err(e) => {
                self.status(Level::Error, &e.to_string());
                Vec::new()
            }
        }
    }

    /// Queues a status message for the viewer (the oldest goes when too many wait).
    pub fn status(&mut self, level: Level, message: &str) {
        if self.texts.len() >= MAX_TEXTS {
            self.texts.pop_front();
        }
        self.texts.push_back(protocol::status(level, message));
    }

    /// Reads `requests` with `read` (the application's reading of its override, see
    /// [`crate::Operator::read`]) into commands; each one refused is told to the viewer in an
    /// error `status`.
    pub fn read<C>(
        &mut self,
        requests: Vec<Request>,
        read: impl Fn(Request) -> Result<Vec<C>, String>,
    ) -> Vec<C> {
        let mut commands = Vec::new();
        for r in requests {
            match read(r) {
                Ok(c) => commands.extend(c),
                Err(e) => self.status(Level::Error, &e),
            }
        }
        commands
    }

    fn handle(&mut self, op: ClientOp) -> Vec<Request> {
        match op {
            ClientOp::Subscribe(subs) => {
                for s in subs {
                    if self.subscriptions.contains_key(&s.id) {
                        self.status(
                            Level::Error,
                            &format!("subscription id {} is already in use", s.id),
                        );
                    } else if !self.known.contains_key(&s.channel_id) {
                        self.status(
                            Level::Error,
                            &format!("no channel {} has been advertised", s.channel_id),
                        );
                    } else if self.by_channel.contains_key(&s.channel_id) {
                        self.status(
                            Level::Error,
                            &format!("channel {} is already subscribed", s.channel_id),
                        );
                    } else if self.subscriptions.len() >= MAX_SUBSCRIPTIONS {
                        self.status(
                            Level::Error,
                            &format!("at most {MAX_SUBSCRIPTIONS} subscriptions"),
                        );
                    } else {
                        self.subscriptions.insert(s.id, s.channel_id);
                        self.by_channel.insert(s.channel_id, s.id);
                    }
                }
                Vec::new()
            }
            ClientOp::Unsubscribe(ids) => {
                for id in ids {
                    match self.subscriptions.remove(&id) {
                        Some(channel) => {
                            self.by_channel.remove(&channel);
                            if let Some(q) = self.pending.remove(&channel) {
                                self.waiting -= q.len();
                            }
                        }
                        None => {
                            self.status(Level::Warning, &format!("no subscription {id}"));
                        }
                    }
                }
                Vec::new()
            }
            ClientOp::Advertise(channels) => {
                for c in channels {
                    self.client_advertise(c);
                }
                Vec::new()
            }
            ClientOp::Unadvertise(ids) => {
                for id in ids {
                    self.client_channels.remove(&id);
                }
                Vec::new()
            }
            ClientOp::MessageData { channel, payload } => {
                match self.client_channels.get(&channel) {
                    None => {
                        self.status(
                            Level::Error,
                            &format!("client channel {channel} was not advertised"),
                        );
                        Vec::new()
                    }
                    Some(sink) => match read_request(*sink, &payload) {
                        Ok(request) => vec![request],
                        Err(e) => {
                            self.status(Level::Error, &e);
                            Vec::new()
                        }
                    },
                }
            }
        }
    }

    fn client_advertise(&mut self, c: ClientChannel) {
        let sink = match c.topic.as_str() {
            OVERRIDE_TOPIC => Sink::Override,
            radio::RADIO => Sink::Radio,
            _ => {
                self.status(
                    Level::Error,
                    &format!(
                        "a viewer may publish only the operator's override: on `{OVERRIDE_TOPIC}` \
                         or `radio`, not `{}`",
                        printable(&c.topic)
                    ),
                );
                return;
            }
        };
        if c.encoding != "json" {
            self.status(
                Level::Error,
                &format!(
                    "encoding `{}` on `{}`: this server reads json only",
                    printable(&c.encoding),
                    c.topic
                ),
            );
            return;
        }
        if !self.client_channels.contains_key(&c.id)
            && self.client_channels.len() >= MAX_CLIENT_CHANNELS
        {
            self.status(
                Level::Error,
                &format!("at most {MAX_CLIENT_CHANNELS} client channels"),
            );
            return;
        }
        self.client_channels.insert(c.id, sink);
    }

    /// Asks for a status about drops if there were new ones and the last report is old enough.
    pub fn poll_timeout(&mut self, now: Instant) {
        if self.dropped > self.reported && self.next_report.is_none_or(|t| now >= t) {
            let n = self.dropped - self.reported;
            self.reported = self.dropped;
            self.next_report = Some(now + DROP_REPORT_EVERY);
            self.status(
                Level::Warning,
                &format!(
                    "this connection is slower than the data: {n} messages dropped \
                     ({} in all); the newest of each channel are sent",
                    self.dropped
                ),
            );
        }
    }

    /// The next frame to send, if any: text first (serverInfo, advertisements, status), then
    /// the waiting channels in turn.
    pub fn poll_transmit(&mut self) -> Option<Out<P>> {
        if let Some(t) = self.texts.pop_front() {
            return Some(Out::Text(t));
        }
        let next = match self.last_sent {
            Some(last) => self
                .pending
                .range(last + 1..)
                .next()
                .or_else(|| self.pending.iter().next())
                .map(|(k, _)| *k),
            None => self.pending.keys().next().copied(),
        }?;
        let queue = self.pending.get_mut(&next)?;
        let (receive_ns, payload) = queue.pop_front()?;
        if queue.is_empty() {
            self.pending.remove(&next);
        }
        self.waiting -= 1;
        self.last_sent = Some(next);
        let subscription = *self.by_channel.get(&next)?;
        Some(Out::Message {
            subscription,
            receive_ns,
            payload,
        })
    }
}

/// A viewer's message on one of its client channels, read as far as the endpoint reads it.
fn read_request(sink: Sink, payload: &[u8]) -> Result<Request, String> {
    let text = std::str::from_utf8(payload)
        .map_err(|_| "an override message must be JSON text (UTF-8)".to_string())?;
    match sink {
        Sink::Override => Ok(Request::Override(text.to_owned())),
        Sink::Radio => {
            let (packet, _) = colony_schema::packet_text(payload).ok_or_else(|| {
                "a radio message is colony-schema JSON: {\"packet\": \"@ <radio> 10\\ncmd id 0 forward 0.5 turn 0\\n\"}"
                    .to_string()
            })?;
            let packet = Packet::parse(packet.as_bytes()).map_err(|e| e.to_string())?;
            if !packet.has_subject(radio::RADIO) || packet.subject_count() != 1 {
                return Err("the packet must be on `radio` alone".into());
            }
            let commands = radio::decode(&packet).map_err(|e| e.to_string())?;
            if commands.is_empty() {
                return Err("the radio packet holds no `cmd` line".into());
            }
            Ok(Request::Radio(commands))
        }
    }
}

/// A name from the network as it may go in a status message.
fn printable(text: &str) -> String {
    text.chars()
        .take(64)
        .map(|c| if c.is_ascii_graphic() { c } else { '?' })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(id: u32, topic: &str) -> Channel {
        Channel {
            id,
            topic: topic.into(),
            encoding: "json".into(),
            schema_name: topic.into(),
            schema: "{}".into(),
            schema_encoding: "jsonschema".into(),
        }
    }

    fn texts(s: &mut Session<u32>) -> Vec<serde_json::Value> {
        let mut out = Vec::new();
        while let Some(Out::Text(t)) = s.poll_transmit() {
            out.push(serde_json::from_str(&t).unwrap());
        }
        out
    }

    fn session() -> Session<u32> {
        let mut s = Session::new("colony monitor", "1");
        s.on_channels(&[channel(1, "vision"), channel(2, "debug")]);
        s
    }

    #[test]
    fn a_new_viewer_gets_server_info_then_the_channels() {
        let mut s = session();
        let t = texts(&mut s);
        assert_eq!(t[0]["op"], "serverInfo");
        assert_eq!(t[1]["op"], "advertise");
        assert_eq!(t[1]["channels"][1]["topic"], "debug");
        // A channel seen again is not advertised again; a new one is.
        s.on_channels(&[channel(1, "vision"), channel(3, "metrics")]);
        let t = texts(&mut s);
        assert_eq!(t.len(), 1);
        assert_eq!(t[0]["channels"].as_array().unwrap().len(), 1);
    }

    #[test]
    fn only_subscribed_channels_are_sent_with_the_subscription_id() {
        let mut s = session();
        texts(&mut s);
        s.on_message(1, 5, 100);
        assert_eq!(s.poll_transmit(), None);
        s.handle_text(r#"{"op":"subscribe","subscriptions":[{"id":9,"channelId":1}]}"#);
        s.on_message(1, 6, 101);
        s.on_message(2, 6, 200);
        assert_eq!(
            s.poll_transmit(),
            Some(Out::Message {
                subscription: 9,
                receive_ns: 6,
                payload: 101
            })
        );
        assert_eq!(s.poll_transmit(), None);
        s.handle_text(r#"{"op":"unsubscribe","subscriptionIds":[9]}"#);
        s.on_message(1, 7, 102);
        assert_eq!(s.poll_transmit(), None);
    }

    #[test]
    fn a_slow_viewer_of_a_scene_has_whole_frames_dropped_for_the_newest_and_counted() {
        let mut s = session();
        texts(&mut s);
        s.newest_only(1);
        s.handle_text(
            r#"{"op":"subscribe","subscriptions":[{"id":0,"channelId":1},{"id":1,"channelId":2}]}"#,
        );
        // Ten frames of the scene while the viewer sends nothing; the other channel keeps its few.
        for i in 0..10 {
            s.on_message(1, i, i as u32);
            s.on_message(2, i, 100 + i as u32);
        }
        assert_eq!(s.dropped(), 9 + (10 - PER_CHANNEL as u64));
        let mut scenes = Vec::new();
        while let Some(out) = s.poll_transmit() {
            if let Out::Message {
                subscription: 0,
                payload,
                ..
            } = out
            {
                scenes.push(payload);
            }
        }
        assert_eq!(scenes, [9], "the newest frame, whole, and no backlog");
    }

    #[test]
    fn a_slow_viewer_gets_the_newest_of_each_channel_and_the_rest_is_counted() {
        let mut s = session();
        texts(&mut s);
        s.handle_text(
            r#"{"op":"subscribe","subscriptions":[{"id":0,"channelId":1},{"id":1,"channelId":2}]}"#,
        );
        for i in 0..100 {
            s.on_message(1, i, i as u32);
        }
        s.on_message(2, 0, 500);
        s.on_missed(10);
        assert_eq!(s.dropped(), 100 - PER_CHANNEL as u64 + 10);
        let now = Instant::now();
        s.poll_timeout(now);
        let mut got = Vec::new();
        let mut t = Vec::new();
        while let Some(out) = s.poll_transmit() {
            match out {
                Out::Message { payload, .. } => got.push(payload),
                Out::Text(text) => {
                    t.push(serde_json::from_str::<serde_json::Value>(&text).unwrap())
                }
            }
        }
        assert_eq!(t[0]["level"], 1);
        assert!(t[0]["message"].as_str().unwrap().contains("102"), "{t:?}");
        // The newest of channel 1 and channel 2's one, in turn.
        assert_eq!(got, [92, 500, 93, 94, 95, 96, 97, 98, 99]);
        // Reported again only after a while, and only if there is something new.
        s.on_missed(1);
        s.poll_timeout(now + Duration::from_millis(10));
        assert_eq!(s.poll_transmit(), None);
        s.poll_timeout(now + DROP_REPORT_EVERY);
        assert_eq!(texts(&mut s).len(), 1);
    }

    #[test]
    fn a_burst_on_one_channel_is_kept_and_the_connection_is_bounded() {
        let mut s = Session::new("colony monitor", "1");
        let many: Vec<Channel> = (1..=100).map(|i| channel(i, &format!("c{i}"))).collect();
        s.on_channels(&many);
        texts(&mut s);
        let subs: Vec<String> = (1..=100)
            .map(|i| format!(r#"{{"id":{i},"channelId":{i}}}"#))
            .collect();
        s.handle_text(&format!(
            r#"{{"op":"subscribe","subscriptions":[{}]}}"#,
            subs.join(",")
        ));
        // Four robots' debug packets of one step: none lost.
        for r in 0..4 {
            s.on_message(1, 0, r);
        }
        assert_eq!(s.dropped(), 0);
        // Every channel full: the connection holds MAX_PENDING, the rest counted.
        for c in 1..=100 {
            for i in 0..PER_CHANNEL as u32 {
                s.on_message(c, 0, i);
            }
        }
        let mut sent = 0;
        while s.poll_transmit().is_some() {
            sent += 1;
        }
        assert_eq!(sent, MAX_PENDING);
        assert_eq!(s.dropped() as usize, 4 + 100 * PER_CHANNEL - MAX_PENDING);
    }

    #[test]
    fn a_busy_channel_does_not_starve_the_others() {
        let mut s = session();
        texts(&mut s);
        s.handle_text(
            r#"{"op":"subscribe","subscriptions":[{"id":0,"channelId":1},{"id":1,"channelId":2}]}"#,
        );
        s.on_message(1, 0, 1);
        s.on_message(2, 0, 2);
        let mut order = Vec::new();
        for i in 0..4 {
            let Some(Out::Message { subscription, .. }) = s.poll_transmit() else {
                panic!()
            };
            order.push(subscription);
            s.on_message(1, i, 1);
            s.on_message(2, i, 2);
        }
        assert_eq!(order, [0, 1, 0, 1]);
    }

    #[test]
    fn bad_subscriptions_are_answered_with_an_error_status() {
        let mut s = session();
        texts(&mut s);
        s.handle_text(r#"{"op":"subscribe","subscriptions":[{"id":0,"channelId":77}]}"#);
        s.handle_text(r#"{"op":"subscribe","subscriptions":[{"id":0,"channelId":1}]}"#);
        s.handle_text(r#"{"op":"subscribe","subscriptions":[{"id":0,"channelId":2}]}"#);
        s.handle_text(r#"{"op":"subscribe","subscriptions":[{"id":1,"channelId":1}]}"#);
        s.handle_text(r#"{"op":"getParameters","parameterNames":[]}"#);
        s.handle_text("not json");
        s.handle_binary(&[9, 9]);
        let t = texts(&mut s);
        assert_eq!(t.len(), 6, "{t:?}");
        assert!(t.iter().all(|m| m["op"] == "status" && m["level"] == 2));
    }

    #[test]
    fn status_messages_waiting_are_bounded() {
        let mut s = session();
        for _ in 0..10_000 {
            s.handle_text("{");
        }
        assert!(texts(&mut s).len() <= MAX_TEXTS);
    }

    #[test]
    fn publishing_anywhere_else_is_refused() {
        let mut s = session();
        texts(&mut s);
        s.handle_text(r#"{"op":"advertise","channels":[{"id":1,"topic":"vision","encoding":"json"},{"id":2,"topic":"radio","encoding":"cdr"}]}"#);
        let mut frame = vec![1, 1, 0, 0, 0];
        frame.extend_from_slice(b"{}");
        assert!(s.handle_binary(&frame).is_empty());
        let t = texts(&mut s);
        assert_eq!(t.len(), 3, "{t:?}");
        assert!(t[0]["message"]
            .as_str()
            .unwrap()
            .contains("only the operator's override"));
    }
}
