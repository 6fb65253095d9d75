//! The feed: where the hub link writes every packet the monitor receives and each scene, and
//! what the connections read from it (a `tokio` broadcast, the channel list and the scenes kept
//! for new subscribers).

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock, RwLock};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use colony_wire::Packet;
use tokio::sync::broadcast;

use crate::protocol::Channel;
use crate::scene;
use crate::{
    ARENA_TOPIC, BATTLEFIELD_TOPIC, FRAMES_TOPIC, MAX_CHANNELS, SINGLE_SUBJECT_RESERVE,
    TERRAIN_TOPIC,
};

/// Messages the broadcast holds for a viewer that is behind, at most.
pub(crate) const FEED_CAPACITY: usize = 512;

/// A message for viewers: a hub packet's text (written as JSON once, by the first viewer that
/// wants it, and shared by the rest) or a message already in JSON (a scene).
#[derive(Debug, Clone)]
pub enum Payload {
    /// A packet as received.
    Packet(Arc<PacketText>),
    /// JSON, as it goes out.
    Json(Arc<[u8]>),
}

/// A packet's text and, once a viewer asked, its JSON.
#[derive(Debug)]
pub struct PacketText {
    text: Box<[u8]>,
    json: OnceLock<Arc<[u8]>>,
}

impl Payload {
    pub(crate) fn packet(text: &[u8]) -> Self {
        Payload::Packet(Arc::new(PacketText {
            text: text.into(),
            json: OnceLock::new(),
        }))
    }

    /// The message as a viewer gets it (the same bytes for every viewer).
    pub(crate) fn to_json(&self) -> Arc<[u8]> {
        match self {
            Payload::Json(j) => j.clone(),
            Payload::Packet(p) => p
                .json
                .get_or_init(|| match Packet::parse(&p.text) {
                    Ok(p) => Arc::from(colony_schema::to_json(&p, None)),
                    Err(_) => Arc::from(Vec::new()),
                })
                .clone(),
        }
    }
}

#[derive(Debug, Clone)]
pub(crate) enum Event {
    /// New channels are in the registry.
    Channels,
    Message {
        channel: u32,
        receive_ns: u64,
        payload: Payload,
    },
}

#[derive(Debug, Default)]
pub(crate) struct Registry {
    by_topic: HashMap<String, u32>,
    channels: Vec<Channel>,
    /// The newest message of each scene channel, for new subscribers.
    latched: HashMap<u32, (u64, Payload)>,
}

/// Counters shared by the feed and the connections.
#[derive(Debug, Default)]
pub(crate) struct Counters {
    pub(crate) viewers: AtomicU64,
    pub(crate) dropped: AtomicU64,
    /// Connections subscribed to the arena's scene, and to the battlefield's.
    pub(crate) arena_subscribers: AtomicU64,
    pub(crate) battlefield_subscribers: AtomicU64,
    /// Packets whose topic found no room in the channel list (never advertised).
    pub(crate) not_advertised: AtomicU64,
    /// Connections refused past [`MAX_VIEWERS`](crate::MAX_VIEWERS).
    pub(crate) refused_viewers: AtomicU64,
    /// World frames whose arena scene was never built: a newer frame came while the scene
    /// budget ([`SceneBudget`]) was spent.
    pub(crate) scenes_skipped: AtomicU64,
}

/// The share of the hub link's thread that building arena scenes may take: a scene of 10,000
/// robots and 100,000 pucks takes the hub link some 100 ms, and at every world frame it would
/// leave too little time to read the hub's datagrams.
pub const SCENE_SHARE: f64 = 0.25;
/// Scenes are built at most this often, however cheap.
pub const SCENE_EVERY: Duration = Duration::from_millis(33);

/// When the hub link may build the next arena scene: a build that took `t` is followed by none
/// for `t / SCENE_SHARE` (at least [`SCENE_EVERY`]). World frames that come meanwhile are not
/// built at all, only the newest once the budget allows; the ones passed over are counted
/// ([`Viewers::scenes_skipped`]). No clock: the hub link passes the times.
#[derive(Debug, Default)]
pub struct SceneBudget {
    next: Option<std::time::Instant>,
    /// The world frame the last scene was built from.
    built: u64,
}

impl SceneBudget {
    /// Whether the scene of world frame `frame` (the newest) should be built at `now`.
    pub fn due(&self, frame: u64, now: std::time::Instant) -> bool {
        frame != self.built && self.next.is_none_or(|t| now >= t)
    }

    /// The scene of world frame `frame` was built from `started`, taking `took`; returns how
    /// many frames since the last built one were passed over.
    pub fn built(&mut self, frame: u64, started: std::time::Instant, took: Duration) -> u64 {
        let skipped = frame.saturating_sub(self.built).saturating_sub(1);
        self.built = frame;
        self.next = Some(started + took.div_f64(SCENE_SHARE).max(SCENE_EVERY));
        skipped
    }
}

/// The hub link's end: where received packets and scenes are written.
#[derive(Debug)]
pub struct Feed {
    tx: broadcast::Sender<Event>,
    registry: Arc<RwLock<Registry>>,
    counters: Arc<Counters>,
    /// The scene channels' ids.
    arena: u32,
    battlefield: u32,
    terrain: u32,
    frames: u32,
}

/// The web server's end: what each connection reads.
#[derive(Debug, Clone)]
pub struct Viewers {
    pub(crate) tx: broadcast::Sender<Event>,
    pub(crate) registry: Arc<RwLock<Registry>>,
    pub(crate) counters: Arc<Counters>,
    pub(crate) session_id: Arc<str>,
    /// The arena's, the battlefield's and its terrain's scene channels.
    pub(crate) scenes: [u32; 3],
}

/// The wall clock now, nanoseconds since the Unix epoch.
pub fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// A new feed, with its scene channels, and the web server's end of it.
pub fn feed() -> (Feed, Viewers) {
    let (tx, _) = broadcast::channel(FEED_CAPACITY);
    let registry = Arc::new(RwLock::new(Registry::default()));
    let counters = Arc::new(Counters::default());
    let mut feed = Feed {
        tx: tx.clone(),
        registry: registry.clone(),
        counters: counters.clone(),
        arena: 0,
        battlefield: 0,
        terrain: 0,
        frames: 0,
    };
    let schema = scene::scene_update_schema();
    for (i, topic) in [ARENA_TOPIC, BATTLEFIELD_TOPIC, TERRAIN_TOPIC]
        .into_iter()
        .enumerate()
    {
        let id = feed.register(topic, scene::SCENE_UPDATE.into(), schema.clone());
        match i {
            0 => feed.arena = id.unwrap_or(0),
            1 => feed.battlefield = id.unwrap_or(0),
            _ => feed.terrain = id.unwrap_or(0),
        }
    }
    feed.frames = feed
        .register(
            FRAMES_TOPIC,
            scene::FRAME_TRANSFORMS.into(),
            scene::frame_transforms_schema(),
        )
        .unwrap_or(0);
    let session_id: Arc<str> = Arc::from(now_ns().to_string());
    let scenes = [feed.arena, feed.battlefield, feed.terrain];
    (
        feed,
        Viewers {
            tx,
            registry,
            counters,
            session_id,
            scenes,
        },
    )
}

/// How long the channel list may be for a new `topic` to join it: subject sets (`a+b`) leave
/// [`SINGLE_SUBJECT_RESERVE`] for single subjects.
fn room(topic: &str) -> usize {
    if topic.contains('+') {
        MAX_CHANNELS - SINGLE_SUBJECT_RESERVE
    } else {
        MAX_CHANNELS
    }
}

impl Feed {
    /// Whether any viewer is connected (else packets need not be handed on).
    pub fn has_viewers(&self) -> bool {
        self.tx.receiver_count() > 0
    }

    /// Whether a viewer is subscribed to the arena's scene (else it need not be built).
    pub fn wants_arena(&self) -> bool {
        self.counters.arena_subscribers.load(Ordering::Relaxed) > 0
    }

    /// Whether a viewer is subscribed to the battlefield's scene or its terrain.
    pub fn wants_battlefield(&self) -> bool {
        self.counters
            .battlefield_subscribers
            .load(Ordering::Relaxed)
            > 0
    }

    /// Adds a channel, or finds it; `None` once the list has no room for it (see [`room`]).
    fn register(&mut self, topic: &str, schema_name: String, schema: String) -> Option<u32> {
        let Ok(mut r) = self.registry.write() else {
            return None;
        };
        if let Some(id) = r.by_topic.get(topic) {
            return Some(*id);
        }
        if r.channels.len() >= room(topic) {
            drop(r);
            self.refuse(topic);
            return None;
        }
        let id = r.channels.len() as u32 + 1;
        r.by_topic.insert(topic.to_owned(), id);
        r.channels.push(Channel {
            id,
            topic: topic.to_owned(),
            encoding: colony_schema::MESSAGE_ENCODING.into(),
            schema_name,
            schema,
            schema_encoding: colony_schema::SCHEMA_ENCODING.into(),
        });
        drop(r);
        let _ = self.tx.send(Event::Channels);
        Some(id)
    }

    /// Counts a packet whose topic has no room, and says so in the log now and then.
    fn refuse(&self, topic: &str) {
        let n = self.counters.not_advertised.fetch_add(1, Ordering::Relaxed) + 1;
        if n.is_power_of_two() {
            tracing::warn!(
                topic,
                not_advertised = n,
                "the Foxglove channel list is full: packets of new topics are not advertised"
            );
        }
    }

    fn channel_of(&mut self, packet: &Packet<'_>) -> Option<u32> {
        let topic = if packet.subject_count() == 1 {
            packet.subjects().next().unwrap_or_default().to_owned()
        } else {
            colony_schema::topic(packet)
        };
        // Found, or refused, under the read lock: a full list costs no schema and no write lock.
        if let Ok(r) = self.registry.read() {
            if let Some(id) = r.by_topic.get(&topic) {
                return Some(*id);
            }
            if r.channels.len() >= room(&topic) {
                drop(r);
                self.refuse(&topic);
                return None;
            }
        }
        let schema = colony_schema::schema_for(&topic);
        let text = String::from_utf8_lossy(&schema.data).into_owned();
        self.register(&topic, schema.name, text)
    }

    /// A packet the monitor received at `receive_ns`.
    pub fn on_packet(&mut self, packet: &Packet<'_>, receive_ns: u64) {
        let Some(channel) = self.channel_of(packet) else {
            return;
        };
        if self.has_viewers() {
            let payload = Payload::packet(packet.as_str().as_bytes());
            let _ = self.tx.send(Event::Message {
                channel,
                receive_ns,
                payload,
            });
        }
    }

    fn send_scene(&mut self, channel: u32, receive_ns: u64, json: Vec<u8>) {
        let payload = Payload::Json(Arc::from(json));
        if let Ok(mut r) = self.registry.write() {
            r.latched.insert(channel, (receive_ns, payload.clone()));
        }
        let _ = self.tx.send(Event::Message {
            channel,
            receive_ns,
            payload,
        });
    }

    /// World frames whose arena scene was passed over for the budget ([`SceneBudget`]).
    pub fn on_scenes_skipped(&mut self, n: u64) {
        self.counters.scenes_skipped.fetch_add(n, Ordering::Relaxed);
    }

    /// The arena's newest scene (see [`scene::arena_scene`]), and the frames with its time.
    pub fn on_arena(&mut self, json: Vec<u8>, receive_ns: u64) {
        self.send_scene(self.arena, receive_ns, json);
        self.send_scene(self.frames, receive_ns, scene::frame_transforms(receive_ns));
    }

    /// The battlefield's robots and flags, and the frames with their time.
    pub fn on_battlefield(&mut self, json: Vec<u8>, receive_ns: u64) {
        self.send_scene(self.battlefield, receive_ns, json);
        self.send_scene(self.frames, receive_ns, scene::frame_transforms(receive_ns));
    }

    /// The battlefield's terrain.
    pub fn on_terrain(&mut self, json: Vec<u8>, receive_ns: u64) {
        self.send_scene(self.terrain, receive_ns, json);
    }
}

impl Viewers {
    /// Viewers connected now.
    pub fn connected(&self) -> u64 {
        self.counters.viewers.load(Ordering::Relaxed)
    }

    /// Messages dropped for slow viewers so far, all connections together.
    pub fn dropped(&self) -> u64 {
        self.counters.dropped.load(Ordering::Relaxed)
    }

    /// World frames whose arena scene was never built, for the budget ([`SceneBudget`]).
    pub fn scenes_skipped(&self) -> u64 {
        self.counters.scenes_skipped.load(Ordering::Relaxed)
    }

    /// Packets whose topic found no room in the channel list, so far.
    pub fn not_advertised(&self) -> u64 {
        self.counters.not_advertised.load(Ordering::Relaxed)
    }

    /// Connections refused past [`MAX_VIEWERS`](crate::MAX_VIEWERS) so far.
    pub fn refused(&self) -> u64 {
        self.counters.refused_viewers.load(Ordering::Relaxed)
    }

    pub(crate) fn channels(&self) -> Vec<Channel> {
        self.registry
            .read()
            .map(|r| r.channels.clone())
            .unwrap_or_default()
    }

    pub(crate) fn latched(&self) -> Vec<(u32, u64, Payload)> {
        self.registry
            .read()
            .map(|r| {
                r.latched
                    .iter()
                    .map(|(c, (ns, p))| (*c, *ns, p.clone()))
                    .collect()
            })
            .unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::connection::not_advertised_status;

    #[test]
    fn scenes_keep_to_their_share_of_the_bridge_and_passed_over_frames_are_counted() {
        let t0 = std::time::Instant::now();
        let ms = |n| t0 + Duration::from_millis(n);
        let mut b = SceneBudget::default();
        assert!(b.due(1, t0));
        // A 100 ms scene: none for the next 400 ms.
        assert_eq!(b.built(1, t0, Duration::from_millis(100)), 0);
        assert!(!b.due(1, ms(500)), "that frame's scene is built already");
        for frame in 2..=5 {
            assert!(!b.due(frame, ms(100 * frame - 150)), "frame {frame}");
        }
        assert!(b.due(5, ms(400)));
        assert_eq!(
            b.built(5, ms(400), Duration::from_millis(1)),
            3,
            "frames 2 to 4"
        );
        assert!(!b.due(6, ms(420)), "at most every 33 ms");
        assert!(b.due(6, ms(433)));
    }

    #[test]
    fn a_scene_of_2000_robots_and_20000_pucks_is_whole() {
        use colony_proto::swarm::{PuckKind, VisionFrame, VisionPuck, VisionRobot};
        use colony_proto::{Pose, Vec2};
        let frame = VisionFrame {
            step: 1,
            robots: (0..2000)
                .map(|id| VisionRobot {
                    id,
                    pose: Pose {
                        x: f64::from(id),
                        y: 0.0,
                        theta: 0.0,
                    },
                    carrying: None,
                })
                .collect(),
            pucks: (0..20_000)
                .map(|id| VisionPuck {
                    id,
                    kind: PuckKind(1),
                    pos: Vec2::new(0.0, f64::from(id)),
                })
                .collect(),
            ..VisionFrame::default()
        };
        let json = scene::arena_scene(&frame, None, None, [], 1);
        let v: serde_json::Value = serde_json::from_slice(&json).unwrap();
        let by_id = |id: &str| {
            v["entities"]
                .as_array()
                .unwrap()
                .iter()
                .find(|e| e["id"] == id)
                .unwrap()
                .clone()
        };
        assert_eq!(by_id("robots")["cubes"].as_array().unwrap().len(), 2000);
        assert_eq!(
            by_id("pucks")["cylinders"].as_array().unwrap().len(),
            20_000
        );
    }

    fn packet(text: &str) -> Packet<'_> {
        Packet::parse(text.as_bytes()).unwrap()
    }

    #[test]
    fn each_topic_becomes_one_channel_with_its_schema_and_viewers_hear_of_it() {
        let (mut feed, viewers) = feed();
        let mut rx = viewers.tx.subscribe();
        let scenes = viewers.channels().len();
        assert_eq!(scenes, 4);
        feed.on_packet(&packet("@ <vision> 20\nstep n 1\n"), 5);
        feed.on_packet(&packet("@ <vision> 20\nstep n 2\n"), 6);
        feed.on_packet(&packet("@ <a> <b> 0\nx y 1\n"), 7);
        let channels = viewers.channels();
        let topics: Vec<&str> = channels.iter().map(|c| c.topic.as_str()).collect();
        assert_eq!(&topics[scenes..], ["vision", "a+b"]);
        let vision = &channels[scenes];
        assert_eq!(vision.encoding, "json");
        assert_eq!(vision.schema_encoding, "jsonschema");
        assert!(serde_json::from_str::<serde_json::Value>(&vision.schema).is_ok());
        // A new channel is announced, then each message with its receive time.
        let mut got = Vec::new();
        while let Ok(e) = rx.try_recv() {
            got.push(match e {
                Event::Channels => "channels".to_string(),
                Event::Message {
                    channel,
                    receive_ns,
                    payload,
                } => {
                    let json: serde_json::Value =
                        serde_json::from_slice(&payload.to_json()).unwrap();
                    // Built once: every viewer shares the same bytes.
                    assert!(Arc::ptr_eq(&payload.to_json(), &payload.to_json()));
                    format!("{channel}@{receive_ns}:{}", json["subjects"])
                }
            });
        }
        let v = vision.id;
        assert_eq!(
            got,
            [
                "channels".to_string(),
                format!("{v}@5:[\"vision\"]"),
                format!("{v}@6:[\"vision\"]"),
                "channels".to_string(),
                format!("{}@7:[\"a\",\"b\"]", v + 1),
            ]
        );
    }

    #[test]
    fn subject_sets_cannot_crowd_out_single_subjects_and_refusals_are_counted() {
        let (mut feed, viewers) = feed();
        for i in 0..2000 {
            let text = format!("@ <vision> <c{i}> 0\nx\n");
            feed.on_packet(&packet(&text), 0);
        }
        assert_eq!(
            viewers.channels().len(),
            MAX_CHANNELS - SINGLE_SUBJECT_RESERVE
        );
        let refused = viewers.not_advertised();
        assert_eq!(
            refused,
            2000 + 4 - (MAX_CHANNELS - SINGLE_SUBJECT_RESERVE) as u64
        );
        // A real channel seen later is still advertised.
        feed.on_packet(&packet("@ <game.state> 0\nx\n"), 0);
        assert!(viewers.channels().iter().any(|c| c.topic == "game.state"));
        assert_eq!(viewers.not_advertised(), refused);
        assert!(not_advertised_status(refused).contains(&refused.to_string()));
    }

    #[test]
    fn channels_are_bounded_and_scenes_wait_for_new_subscribers() {
        let (mut feed, viewers) = feed();
        for i in 0..MAX_CHANNELS + 10 {
            let text = format!("@ <c{i}> 0\nx\n");
            feed.on_packet(&packet(&text), 0);
        }
        assert_eq!(viewers.channels().len(), MAX_CHANNELS);
        assert_eq!(viewers.not_advertised(), 14);
        // No viewer: packets are not handed on, but a scene is kept for the next subscriber.
        assert!(!feed.has_viewers() && !feed.wants_arena());
        feed.on_arena(b"{}".to_vec(), 9);
        let latched: Vec<u32> = viewers.latched().iter().map(|(c, _, _)| *c).collect();
        assert!(latched.contains(&feed.arena) && latched.contains(&feed.frames));
    }
}
