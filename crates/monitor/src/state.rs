//! What the monitor knows, with no socket and no clock: packets and status
//! reports go in with the time they arrived, JSON snapshots and the
//! operator's radio commands come out.
//!
//! - The world: `vision` packets, split into parts for big swarms, are put
//!   back together per step; a frame is shown only once all its parts are in.
//! - Intentions: each robot's FSM state and target from `debug`, and the
//!   cache points the robots believe in.
//! - The hub: every channel with its rate (from the packet counts of two
//!   status reports) and its last packet, clients, drops, minimum priority.
//! - Staleness: no word from the hub, or no vision, for [`STALE_AFTER`].
//! - The operator's override: which robots are held and how each is driven
//!   (stopped, by keys, or steered to a point by [`steer`]).

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::time::{Duration, Instant};

use colony_wire::{Packet, PacketBuilder, Priority, Request, StatusReport, Subject, HUB_SUBJECT};
use serde::Serialize;

/// The channel the world's global state arrives on.
pub const VISION: &str = "vision";
/// The channel controllers publish their intentions on.
pub const DEBUG: &str = "debug";
/// The channel sorting progress arrives on.
pub const METRICS: &str = "metrics";
/// The channel wheel commands travel on.
pub const RADIO: &str = "radio";
/// The channels the monitor always subscribes to.
pub const CORE_CHANNELS: [&str; 4] = [VISION, DEBUG, METRICS, RADIO];

/// The priority of the operator's commands: above the controllers' 0, so
/// the world lets the operator hold a robot while the others keep sorting.
pub const OVERRIDE_PRIORITY: i32 = 10;
/// With nothing heard for this long, the hub or the vision is shown as stale.
pub const STALE_AFTER: Duration = Duration::from_secs(2);
/// A key-driven command lapses (the robot stops, still held) unless the
/// browser repeats it within this time: a closed tab must not leave a robot driving.
pub const DRIVE_LAPSE: Duration = Duration::from_millis(500);
/// A robot steered to a point stops this close to it (cm).
pub const ARRIVED_CM: f64 = 3.0;
/// Robots sent to one point together are spread on a grid this wide (cm).
const GOTO_SPACING_CM: f64 = 16.0;
/// The longest last-packet text kept per channel.
const LAST_TEXT_LIMIT: usize = 1500;
/// Points kept in the completion plot (older ones are thinned out).
const PC_POINTS: usize = 600;
/// Channels tracked at most (the hub itself counts at most 1024).
const MAX_CHANNELS: usize = 2048;
/// Vision parts per frame accepted at most.
const MAX_PARTS: u64 = 4096;
/// Robots held at once, at most (one radio packet each control step).
pub const MAX_HELD: usize = 1500;
/// Clients listed in the hub view at most.
const MAX_CLIENTS_SHOWN: usize = 400;
/// Coordinates accepted from the operator, cm (the largest arena is 100 m).
pub const MAX_COORD: f64 = 100_000.0;

/// The arena's walls: a rectangle with rounded corners centred on the origin (cm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Arena {
    pub width: f64,
    pub height: f64,
    pub corner: f64,
}

/// Body sizes, so the page draws to scale (cm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sizes {
    pub robot_length: f64,
    pub robot_width: f64,
    /// The gripper's pocket: its centre is this far ahead of the body's front.
    pub gripper_radius: f64,
    pub puck_diameter: f64,
}

/// One robot as the overhead camera sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotView {
    pub id: u32,
    pub x: f64,
    pub y: f64,
    pub theta: f64,
    pub carrying: Option<u32>,
}

/// One puck as the overhead camera sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PuckView {
    pub id: u32,
    pub kind: u32,
    pub x: f64,
    pub y: f64,
}

/// The world at one step.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Frame {
    pub step: u64,
    pub robots: Vec<RobotView>,
    pub pucks: Vec<PuckView>,
}

/// A frame whose parts are still arriving.
#[derive(Debug)]
struct Assembly {
    step: u64,
    seen: Vec<bool>,
    frame: Frame,
}

/// What a robot's controller says it is doing.
#[derive(Debug, Clone, PartialEq)]
pub struct Intent {
    pub state: String,
    pub target: Option<(f64, f64)>,
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

/// How a held robot is driven.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// Held still.
    Stop,
    /// Driven by keys until `until`, then stopped.
    Drive {
        forward: f64,
        turn: f64,
        until: Instant,
    },
    /// Steered to a point from its vision pose.
    Goto { x: f64, y: f64 },
}

/// Where the hub's minimum priority stands for "take control of all".
#[derive(Debug, Clone, Copy, PartialEq)]
enum MinPlan {
    /// The monitor has not touched it.
    Idle,
    /// Raise it once a status report has told the current value.
    WantRaise,
    /// Raised to the override priority; restore `previous` on release.
    Raised { previous: Priority },
    /// It was already at or above the override priority: leave it alone.
    AlreadyHigh,
}

/// A request the browser made, already checked.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Publish this packet (already parsed once) as it stands.
    Publish(Vec<u8>),
    Take(Vec<u32>),
    TakeAll,
    Release(Vec<u32>),
    ReleaseAll,
    /// Drive held robots (those among `ids`, or all held ones).
    Drive {
        ids: Option<Vec<u32>>,
        forward: f64,
        turn: f64,
    },
    /// Steer held robots (those among `ids`, or all held ones) to a point.
    Goto {
        ids: Option<Vec<u32>>,
        x: f64,
        y: f64,
    },
    /// A player's order to a squad of the strategy game (the bridge publishes it).
    Squad(crate::game::squad::SquadOrder),
}

/// Everything the monitor knows. Feed it with [`on_packet`](Self::on_packet),
/// [`on_status`](Self::on_status) and [`apply`](Self::apply); read it with
/// the snapshot methods and [`override_packets`](Self::override_packets).
#[derive(Debug)]
pub struct MonitorState {
    started: Instant,
    /// Wall-clock milliseconds since the Unix epoch at `started`.
    wall_start_ms: u64,
    arena: Option<Arena>,
    sizes: Option<Sizes>,
    frame: Frame,
    frame_at: Option<Instant>,
    frame_version: u64,
    assembly: Option<Assembly>,
    vision_at: Option<Instant>,
    intents: BTreeMap<u32, Intent>,
    caches: BTreeMap<(u32, u32), (f64, f64)>,
    pc: VecDeque<(u64, f64)>,
    pc_gap: u64,
    channels: BTreeMap<String, ChannelView>,
    status: Option<StatusReport>,
    status_at: Option<Instant>,
    last_from_hub: Option<Instant>,
    bad_lines: u64,
    held: BTreeMap<u32, Mode>,
    all: bool,
    min_plan: MinPlan,
    outbox: Vec<Request>,
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Wraps an angle to (-pi, pi].
fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let a = a.rem_euclid(t);
    if a > std::f64::consts::PI {
        a - t
    } else {
        a
    }
}

/// The steering law for a held robot sent to a point: turn toward it in
/// proportion to the heading error, drive only when roughly aligned (slowing
/// near the point and for the remaining error), stop within [`ARRIVED_CM`].
/// Returns `(forward, turn)`, each in [-1, 1]; `turn` > 0 is counter-clockwise.
pub fn steer(x: f64, y: f64, theta: f64, tx: f64, ty: f64) -> (f64, f64) {
    let (dx, dy) = (tx - x, ty - y);
    let dist = dx.hypot(dy);
    if !dist.is_finite() || !theta.is_finite() || dist < ARRIVED_CM {
        return (0.0, 0.0);
    }
    let error = wrap(dy.atan2(dx) - theta);
    let turn = (1.2 * error).clamp(-1.0, 1.0);
    let forward = if error.abs() < 0.6 {
        (dist / 15.0).clamp(0.15, 1.0) * error.cos()
    } else {
        0.0
    };
    (forward, turn)
}

/// Checks a packet typed by the operator, as the hub will: the error names its line and column.
pub fn check_forged(text: &str) -> Result<Vec<u8>, ForgeError> {
    let mut bytes = text.replace("\r\n", "\n").into_bytes();
    if !bytes.ends_with(b"\n") {
        bytes.push(b'\n');
    }
    match Packet::parse(&bytes) {
        Ok(_) => Ok(bytes),
        Err(e) => Err(ForgeError {
            line: e.line,
            column: e.column,
            message: e.to_string(),
        }),
    }
}

/// Why a forged packet was refused, and where.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ForgeError {
    pub line: u32,
    pub column: u32,
    pub message: String,
}

/// The world as the page draws it (sent as JSON).
#[derive(Serialize)]
struct WorldJson<'a> {
    t: &'static str,
    now: u64,
    step: Option<u64>,
    arena: Option<Arena>,
    sizes: Option<Sizes>,
    /// `[id, x, y, theta, carrying or -1]`
    robots: Vec<(u32, f64, f64, f64, i64)>,
    /// `[id, kind, x, y]`
    pucks: Vec<(u32, u32, f64, f64)>,
    /// `[id, state, tx or null, ty or null]`
    intents: Vec<(u32, &'a str, Option<f64>, Option<f64>)>,
    /// `[robot, kind, x, y]`
    caches: Vec<(u32, u32, f64, f64)>,
    pc: Option<(u64, f64)>,
    held: Vec<u32>,
    all: bool,
    min_raised: bool,
    /// `[id, x, y]` for robots steered to a point.
    targets: Vec<(u32, f64, f64)>,
    hub_stale_since: Option<u64>,
    vision_stale_since: Option<u64>,
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
struct HubJson<'a> {
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

impl MonitorState {
    /// A monitor started at `now`, when the wall clock read `wall_ms` (Unix milliseconds).
    pub fn new(now: Instant, wall_ms: u64) -> MonitorState {
        MonitorState {
            started: now,
            wall_start_ms: wall_ms,
            arena: None,
            sizes: None,
            frame: Frame::default(),
            frame_at: None,
            frame_version: 0,
            assembly: None,
            vision_at: None,
            intents: BTreeMap::new(),
            caches: BTreeMap::new(),
            pc: VecDeque::new(),
            pc_gap: 0,
            channels: BTreeMap::new(),
            status: None,
            status_at: None,
            last_from_hub: None,
            bad_lines: 0,
            held: BTreeMap::new(),
            all: false,
            min_plan: MinPlan::Idle,
            outbox: Vec::new(),
        }
    }

    fn wall(&self, t: Instant) -> u64 {
        self.wall_start_ms + t.saturating_duration_since(self.started).as_millis() as u64
    }

    /// The newest complete frame.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    /// Counts complete frames; changes whenever a new one is in.
    pub fn frame_version(&self) -> u64 {
        self.frame_version
    }

    pub fn arena(&self) -> Option<Arena> {
        self.arena
    }

    pub fn intent(&self, robot: u32) -> Option<&Intent> {
        self.intents.get(&robot)
    }

    /// Cache points the robots announced: `(robot, kind) -> (x, y)`.
    pub fn caches(&self) -> &BTreeMap<(u32, u32), (f64, f64)> {
        &self.caches
    }

    /// Percentage completion over time: `(step, pc)`.
    pub fn pc_series(&self) -> impl Iterator<Item = &(u64, f64)> {
        self.pc.iter()
    }

    /// The held robots and how each is driven.
    pub fn held(&self) -> &BTreeMap<u32, Mode> {
        &self.held
    }

    /// Whether "take control of all" is in force.
    pub fn all_held(&self) -> bool {
        self.all
    }

    /// Lines in received packets that did not read as what their channel carries.
    pub fn bad_lines(&self) -> u64 {
        self.bad_lines
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

    /// Since when (wall-clock ms) the hub has been silent, if for longer than [`STALE_AFTER`].
    pub fn hub_stale_since(&self, now: Instant) -> Option<u64> {
        let since = self.last_from_hub.unwrap_or(self.started);
        (now.saturating_duration_since(since) > STALE_AFTER).then(|| self.wall(since))
    }

    /// Since when (wall-clock ms) no vision has arrived, if for longer than [`STALE_AFTER`].
    pub fn vision_stale_since(&self, now: Instant) -> Option<u64> {
        let since = self.vision_at.unwrap_or(self.started);
        (now.saturating_duration_since(since) > STALE_AFTER).then(|| self.wall(since))
    }

    /// Takes in a packet received at `now` on a subscribed channel.
    pub fn on_packet(&mut self, now: Instant, packet: &Packet<'_>) {
        self.last_from_hub = Some(now);
        self.note_channel(now, packet);
        if packet.subject_count() != 1 {
            return;
        }
        if packet.has_subject(VISION) {
            self.on_vision(now, packet);
        } else if packet.has_subject(DEBUG) {
            self.on_debug(packet);
        } else if packet.has_subject(METRICS) {
            self.on_metrics(packet);
        }
    }

    fn note_channel(&mut self, now: Instant, packet: &Packet<'_>) {
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

    fn on_vision(&mut self, now: Instant, packet: &Packet<'_>) {
        self.vision_at = Some(now);
        let Some(head) = packet.line("step") else {
            self.bad_lines += 1;
            return;
        };
        let (Ok(step), part, parts) = (
            head.i64("n"),
            head.i64("part").unwrap_or(0),
            head.i64("parts").unwrap_or(1),
        ) else {
            self.bad_lines += 1;
            return;
        };
        let (Ok(step), Ok(part), Ok(parts)) = (
            u64::try_from(step),
            u64::try_from(part),
            u64::try_from(parts),
        ) else {
            self.bad_lines += 1;
            return;
        };
        if parts == 0 || parts > MAX_PARTS || part >= parts {
            self.bad_lines += 1;
            return;
        }
        // A part of another step (newer, or an older one after the world
        // restarted) starts the frame afresh; an unfinished one is dropped.
        let fresh = match &self.assembly {
            Some(a) => a.step != step || a.seen.len() as u64 != parts,
            None => true,
        };
        if fresh {
            self.assembly = Some(Assembly {
                step,
                seen: vec![false; parts as usize],
                frame: Frame {
                    step,
                    ..Frame::default()
                },
            });
        }
        let mut bad = 0;
        let Some(a) = self.assembly.as_mut() else {
            return;
        };
        if a.seen[part as usize] {
            return; // a duplicate
        }
        a.seen[part as usize] = true;
        for line in packet.lines() {
            match line.label() {
                "robot" => {
                    let r = (|| {
                        Some(RobotView {
                            id: u32::try_from(line.i64("id").ok()?).ok()?,
                            x: finite(line.f64("x").ok()?)?,
                            y: finite(line.f64("y").ok()?)?,
                            theta: finite(line.f64("theta").ok()?)?,
                            carrying: match line.get("carrying") {
                                None => None,
                                Some(_) => Some(u32::try_from(line.i64("carrying").ok()?).ok()?),
                            },
                        })
                    })();
                    match r {
                        Some(r) => a.frame.robots.push(r),
                        None => bad += 1,
                    }
                }
                "puck" => {
                    let p = (|| {
                        Some(PuckView {
                            id: u32::try_from(line.i64("id").ok()?).ok()?,
                            kind: u32::try_from(line.i64("kind").ok()?).ok()?,
                            x: finite(line.f64("x").ok()?)?,
                            y: finite(line.f64("y").ok()?)?,
                        })
                    })();
                    match p {
                        Some(p) => a.frame.pucks.push(p),
                        None => bad += 1,
                    }
                }
                "arena" => {
                    let r = (|| {
                        let v = |n| {
                            finite(line.f64(n).ok()?).filter(|v| *v >= 0.0 && *v <= 2.0 * MAX_COORD)
                        };
                        Some(Arena {
                            width: v("width")?,
                            height: v("height")?,
                            corner: v("corner")?,
                        })
                    })();
                    match r {
                        Some(r) => self.arena = Some(r),
                        None => bad += 1,
                    }
                }
                "sizes" => {
                    let s = (|| {
                        let v = |n| finite(line.f64(n).ok()?).filter(|v| *v > 0.0 && *v < 1000.0);
                        let puck_diameter = v("puck_diameter")?;
                        Some(Sizes {
                            robot_length: v("robot_length")?,
                            robot_width: v("robot_width")?,
                            gripper_radius: match line.get("gripper_radius") {
                                Some(_) => v("gripper_radius")?,
                                None => puck_diameter * 0.57,
                            },
                            puck_diameter,
                        })
                    })();
                    match s {
                        Some(s) => self.sizes = Some(s),
                        None => bad += 1,
                    }
                }
                _ => {}
            }
        }
        self.bad_lines += bad;
        if a.seen.iter().all(|s| *s) {
            let Some(done) = self.assembly.take() else {
                return;
            };
            let mut frame = done.frame;
            frame.robots.sort_by_key(|r| r.id);
            frame.pucks.sort_by_key(|p| p.id);
            if self.all {
                for r in &frame.robots {
                    if self.held.len() < MAX_HELD {
                        self.held.entry(r.id).or_insert(Mode::Stop);
                    }
                }
            }
            self.frame = frame;
            self.frame_at = Some(now);
            self.frame_version += 1;
        }
    }

    fn on_debug(&mut self, packet: &Packet<'_>) {
        for line in packet.lines() {
            match line.label() {
                "robot" => {
                    let (Ok(id), Ok(state)) = (line.i64("id"), line.str("state")) else {
                        self.bad_lines += 1;
                        continue;
                    };
                    let Ok(id) = u32::try_from(id) else {
                        self.bad_lines += 1;
                        continue;
                    };
                    let target = match (line.f64("tx"), line.f64("ty")) {
                        (Ok(x), Ok(y)) if x.is_finite() && y.is_finite() => Some((x, y)),
                        _ => None,
                    };
                    if !self.intents.contains_key(&id) && self.intents.len() >= MAX_HELD * 4 {
                        continue;
                    }
                    let state: String = state.chars().take(40).collect();
                    self.intents.insert(id, Intent { state, target });
                }
                "cache" => {
                    let c = (|| {
                        Some((
                            u32::try_from(line.i64("id").ok()?).ok()?,
                            u32::try_from(line.i64("kind").ok()?).ok()?,
                            finite(line.f64("x").ok()?)?,
                            finite(line.f64("y").ok()?)?,
                        ))
                    })();
                    match c {
                        Some((id, kind, x, y))
                            if self.caches.contains_key(&(id, kind))
                                || self.caches.len() < MAX_HELD * 16 =>
                        {
                            self.caches.insert((id, kind), (x, y));
                        }
                        Some(_) => {}
                        None => self.bad_lines += 1,
                    }
                }
                _ => {}
            }
        }
    }

    fn on_metrics(&mut self, packet: &Packet<'_>) {
        let Some(line) = packet.line("sort") else {
            return;
        };
        let (Ok(step), Ok(pc)) = (line.i64("step"), line.f64("pc")) else {
            self.bad_lines += 1;
            return;
        };
        let (Ok(step), true) = (u64::try_from(step), pc.is_finite()) else {
            self.bad_lines += 1;
            return;
        };
        match self.pc.back() {
            // The world restarted: a new run, a new plot.
            Some(&(last, _)) if step < last => {
                self.pc.clear();
                self.pc_gap = 0;
            }
            Some(&(last, _)) if step < last + self.pc_gap || step == last => return,
            _ => {}
        }
        self.pc.push_back((step, pc.clamp(0.0, 100.0)));
        if self.pc.len() > PC_POINTS {
            // Keep every other point: the whole run stays on the plot.
            let kept: VecDeque<(u64, f64)> = self.pc.iter().copied().step_by(2).collect();
            self.pc = kept;
            if let (Some(first), Some(last)) = (self.pc.front(), self.pc.back()) {
                self.pc_gap = (last.0 - first.0) / (PC_POINTS as u64 / 2).max(1);
            }
        }
    }

    /// Takes in a status report received at `now`: rates, channels, and the
    /// minimum-priority step of "take control of all".
    pub fn on_status(&mut self, now: Instant, report: StatusReport) {
        self.last_from_hub = Some(now);
        let dt_ms = match &self.status {
            Some(prev) if report.uptime_ms > prev.uptime_ms => {
                Some((report.uptime_ms - prev.uptime_ms) as f64)
            }
            _ => None,
        };
        let previous: BTreeMap<&str, u64> = self
            .status
            .iter()
            .flat_map(|r| r.channels.iter())
            .map(|c| (c.subjects.as_str(), c.packets))
            .collect();
        let mut rates = Vec::with_capacity(report.channels.len());
        for c in &report.channels {
            let rate = match (dt_ms, previous.get(c.subjects.as_str())) {
                (Some(dt), Some(&before)) if c.packets >= before => {
                    Some((c.packets - before) as f64 * 1000.0 / dt)
                }
                _ => None,
            };
            rates.push(rate);
        }
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
        match self.min_plan {
            MinPlan::WantRaise if report.min_priority.0 < OVERRIDE_PRIORITY => {
                self.min_plan = MinPlan::Raised {
                    previous: report.min_priority,
                };
                self.outbox
                    .push(Request::MinPriority(Priority(OVERRIDE_PRIORITY)));
            }
            MinPlan::WantRaise => self.min_plan = MinPlan::AlreadyHigh,
            // The hub restarted (or someone lowered it): raise it again.
            MinPlan::Raised { .. } if report.min_priority.0 < OVERRIDE_PRIORITY => {
                self.outbox
                    .push(Request::MinPriority(Priority(OVERRIDE_PRIORITY)));
            }
            _ => {}
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

    /// Requests for the hub that the override wants sent (minimum priority).
    pub fn take_requests(&mut self) -> Vec<Request> {
        std::mem::take(&mut self.outbox)
    }

    /// Whether a status report is wanted now (to learn the minimum priority).
    pub fn wants_status(&self) -> bool {
        self.min_plan == MinPlan::WantRaise
    }

    fn select(&self, ids: &Option<Vec<u32>>) -> Vec<u32> {
        match ids {
            Some(ids) => ids
                .iter()
                .copied()
                .filter(|id| self.held.contains_key(id))
                .collect(),
            None => self.held.keys().copied().collect(),
        }
    }

    /// Carries out a checked request from the browser at `now`; the answer
    /// (or the reason it could not be done) is for the operator to read.
    /// Publishing is the bridge's part: here it only answers.
    pub fn apply(&mut self, now: Instant, command: Command) -> Result<String, String> {
        match command {
            Command::Publish(bytes) => Ok(format!("published {} bytes", bytes.len())),
            Command::Squad(order) => Ok(format!("sent {order}")),
            Command::Take(ids) => {
                if ids.is_empty() {
                    return Err("no robot selected: click robots or type their ids".into());
                }
                for id in &ids {
                    if self.held.len() >= MAX_HELD && !self.held.contains_key(id) {
                        return Err(format!("at most {MAX_HELD} robots can be held"));
                    }
                    self.held.entry(*id).or_insert(Mode::Stop);
                }
                Ok(format!("holding {}", list(&ids)))
            }
            Command::TakeAll => {
                self.all = true;
                for r in &self.frame.robots {
                    if self.held.len() < MAX_HELD {
                        self.held.entry(r.id).or_insert(Mode::Stop);
                    }
                }
                if matches!(self.min_plan, MinPlan::Idle) {
                    self.min_plan = MinPlan::WantRaise;
                }
                Ok(format!(
                    "holding all {} robots; raising the hub's minimum priority to {OVERRIDE_PRIORITY}",
                    self.held.len()
                ))
            }
            Command::Release(ids) => {
                let mut released = Vec::new();
                for id in &ids {
                    if self.held.remove(id).is_some() {
                        released.push(*id);
                    }
                }
                if self.held.is_empty() && self.all {
                    self.release_all();
                }
                if released.is_empty() {
                    Err(format!("{} not held", list(&ids)))
                } else {
                    Ok(format!("released {}", list(&released)))
                }
            }
            Command::ReleaseAll => {
                let n = self.held.len();
                self.release_all();
                Ok(format!("released {n} robots"))
            }
            Command::Drive { ids, forward, turn } => {
                let chosen = self.select(&ids);
                if chosen.is_empty() {
                    return Err("no held robot to drive: take control first".into());
                }
                for id in chosen {
                    self.held.insert(
                        id,
                        Mode::Drive {
                            forward,
                            turn,
                            until: now + DRIVE_LAPSE,
                        },
                    );
                }
                Ok("driving".into())
            }
            Command::Goto { ids, x, y } => {
                let chosen = self.select(&ids);
                if chosen.is_empty() {
                    return Err("no held robot to send: take control first".into());
                }
                // Several robots to one point: a grid around it, so they do not fight for it.
                let n = chosen.len();
                let side = (n as f64).sqrt().ceil() as usize;
                for (i, id) in chosen.iter().enumerate() {
                    let (row, col) = ((i / side) as f64, (i % side) as f64);
                    let half = (side as f64 - 1.0) / 2.0;
                    let (ox, oy) = if n == 1 {
                        (0.0, 0.0)
                    } else {
                        (
                            (col - half) * GOTO_SPACING_CM,
                            (half - row) * GOTO_SPACING_CM,
                        )
                    };
                    self.held.insert(
                        *id,
                        Mode::Goto {
                            x: x + ox,
                            y: y + oy,
                        },
                    );
                }
                Ok(format!("sending {} to ({x:.1}, {y:.1})", list(&chosen)))
            }
        }
    }

    fn release_all(&mut self) {
        self.held.clear();
        self.all = false;
        if let MinPlan::Raised { previous } = self.min_plan {
            self.outbox.push(Request::MinPriority(previous));
        }
        self.min_plan = MinPlan::Idle;
    }

    /// Lets every robot go and puts the hub's minimum priority back (when the monitor stops).
    pub fn shutdown(&mut self) -> Vec<Request> {
        self.release_all();
        self.take_requests()
    }

    /// Each held robot's command at `now`: `(id, forward, turn)`.
    pub fn override_commands(&mut self, now: Instant) -> Vec<(u32, f64, f64)> {
        let poses: BTreeMap<u32, &RobotView> =
            self.frame.robots.iter().map(|r| (r.id, r)).collect();
        let mut out = Vec::with_capacity(self.held.len());
        for (id, mode) in self.held.iter_mut() {
            let cmd = match *mode {
                Mode::Stop => (0.0, 0.0),
                Mode::Drive {
                    forward,
                    turn,
                    until,
                } => {
                    if now < until {
                        (forward, turn)
                    } else {
                        *mode = Mode::Stop;
                        (0.0, 0.0)
                    }
                }
                Mode::Goto { x, y } => match poses.get(id) {
                    Some(r) => steer(r.x, r.y, r.theta, x, y),
                    None => (0.0, 0.0),
                },
            };
            out.push((*id, cmd.0, cmd.1));
        }
        out
    }

    /// The radio packets that hold the held robots at `now`, at [`OVERRIDE_PRIORITY`].
    pub fn override_packets(&mut self, now: Instant) -> Vec<Vec<u8>> {
        let cmds = self.override_commands(now);
        cmds.chunks(1000)
            .filter_map(|chunk| {
                let mut p = PacketBuilder::new([RADIO], Priority(OVERRIDE_PRIORITY));
                for (id, f, t) in chunk {
                    p.line("cmd")
                        .field("id", *id)
                        .field("forward", round(*f))
                        .field("turn", round(*t));
                }
                p.finish().ok()
            })
            .collect()
    }

    /// The world as JSON for the page.
    pub fn world_json(&self, now: Instant) -> String {
        let f = &self.frame;
        let w = WorldJson {
            t: "world",
            now: self.wall(now),
            step: self.frame_at.map(|_| f.step),
            arena: self.arena,
            sizes: self.sizes,
            robots: f
                .robots
                .iter()
                .map(|r| (r.id, r.x, r.y, r.theta, r.carrying.map_or(-1, i64::from)))
                .collect(),
            pucks: f.pucks.iter().map(|p| (p.id, p.kind, p.x, p.y)).collect(),
            intents: self
                .intents
                .iter()
                .map(|(id, i)| {
                    (
                        *id,
                        i.state.as_str(),
                        i.target.map(|t| t.0),
                        i.target.map(|t| t.1),
                    )
                })
                .collect(),
            caches: self
                .caches
                .iter()
                .map(|(&(r, k), &(x, y))| (r, k, x, y))
                .collect(),
            pc: self.pc.back().copied(),
            held: self.held.keys().copied().collect(),
            all: self.all,
            min_raised: matches!(self.min_plan, MinPlan::Raised { .. }),
            targets: self
                .held
                .iter()
                .filter_map(|(id, m)| match m {
                    Mode::Goto { x, y } => Some((*id, *x, *y)),
                    _ => None,
                })
                .collect(),
            hub_stale_since: self.hub_stale_since(now),
            vision_stale_since: self.vision_stale_since(now),
        };
        serde_json::to_string(&w).unwrap_or_else(|_| "{}".into())
    }

    /// The hub view as JSON for the page.
    pub fn hub_json(&self, now: Instant) -> String {
        let secs = |d: Duration| (d.as_secs_f64() * 10.0).round() / 10.0;
        let r = self.status.as_ref();
        let h = HubJson {
            t: "hub",
            now: self.wall(now),
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
            bad_lines: self.bad_lines,
            pc: self.pc.iter().copied().collect(),
        };
        serde_json::to_string(&h).unwrap_or_else(|_| "{}".into())
    }
}

fn round(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

fn list(ids: &[u32]) -> String {
    let shown: Vec<String> = ids.iter().take(12).map(u32::to_string).collect();
    let more = ids.len().saturating_sub(12);
    let word = if ids.len() == 1 { "robot" } else { "robots" };
    if more > 0 {
        format!("{word} {} and {more} more", shown.join(", "))
    } else {
        format!("{word} {}", shown.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_wire::ChannelInfo;

    fn parse(text: &str) -> Packet<'_> {
        Packet::parse(text.as_bytes()).unwrap()
    }

    fn state() -> (MonitorState, Instant) {
        let t0 = Instant::now();
        (MonitorState::new(t0, 1_000_000), t0)
    }

    fn ms(t0: Instant, ms: u64) -> Instant {
        t0 + Duration::from_millis(ms)
    }

    const ONE_PART: &str = "@ <vision> 20\nstep n 7 part 0 parts 1\narena width 187 height 187 corner 15\nsizes robot_length 12.5 robot_width 10.8 gripper_radius 3.6 puck_diameter 6.3\nrobot id 1 x 10 y 0 theta 0 carrying 3\nrobot id 0 x -5 y 2.5 theta 1.57\npuck id 3 kind 1 x 17 y 0\n";

    #[test]
    fn a_one_part_frame_shows_robots_pucks_and_the_arena() {
        let (mut s, t0) = state();
        s.on_packet(ms(t0, 10), &parse(ONE_PART));
        let f = s.frame();
        assert_eq!((f.step, f.robots.len(), f.pucks.len()), (7, 2, 1));
        assert_eq!(f.robots[0].id, 0, "sorted by id");
        assert_eq!(f.robots[1].carrying, Some(3));
        assert_eq!(
            s.arena(),
            Some(Arena {
                width: 187.0,
                height: 187.0,
                corner: 15.0
            })
        );
        assert_eq!(s.frame_version(), 1);
        assert_eq!(s.bad_lines(), 0);
    }

    #[test]
    fn a_split_frame_is_shown_only_once_every_part_is_in() {
        let (mut s, t0) = state();
        let p1 = "@ <vision> 0\nstep n 9 part 1 parts 2\npuck id 0 kind 0 x 1 y 1\n";
        let p0 = "@ <vision> 0\nstep n 9 part 0 parts 2\nrobot id 0 x 0 y 0 theta 0\n";
        s.on_packet(ms(t0, 1), &parse(p1));
        assert_eq!(s.frame_version(), 0);
        s.on_packet(ms(t0, 2), &parse(p1));
        assert_eq!(s.frame_version(), 0, "a duplicate part completes nothing");
        s.on_packet(ms(t0, 3), &parse(p0));
        assert_eq!(s.frame_version(), 1);
        assert_eq!((s.frame().robots.len(), s.frame().pucks.len()), (1, 1));
        // A lost part: the next step's parts replace the unfinished frame.
        s.on_packet(
            ms(t0, 4),
            &parse("@ <vision> 0\nstep n 10 part 0 parts 2\nrobot id 0 x 5 y 0 theta 0\n"),
        );
        s.on_packet(
            ms(t0, 5),
            &parse("@ <vision> 0\nstep n 11 part 1 parts 2\npuck id 0 kind 0 x 2 y 2\n"),
        );
        s.on_packet(
            ms(t0, 6),
            &parse("@ <vision> 0\nstep n 11 part 0 parts 2\nrobot id 0 x 6 y 0 theta 0\n"),
        );
        assert_eq!(s.frame().step, 11);
        assert_eq!(s.frame().robots[0].x, 6.0);
        assert_eq!(s.frame().pucks[0].x, 2.0);
    }

    #[test]
    fn nonsense_in_vision_lines_is_counted_and_skipped() {
        let (mut s, t0) = state();
        s.on_packet(
            t0,
            &parse("@ <vision> 0\nstep n 1\nrobot id -4 x 0 y 0 theta 0\nrobot id 2 x nan y 0 theta 0\npuck id 1 kind 0 x 1\nrobot id 3 x 1 y 2 theta 0\n"),
        );
        assert_eq!(s.frame().robots.len(), 1);
        assert_eq!(s.bad_lines(), 3);
        s.on_packet(
            t0,
            &parse("@ <vision> 0\nstep n 2 part 5 parts 2\nrobot id 3 x 1 y 2 theta 0\n"),
        );
        s.on_packet(t0, &parse("@ <vision> 0\nstep n x\n"));
        s.on_packet(t0, &parse("@ <vision> 0\nball x 1\n"));
        assert_eq!(s.frame().step, 1);
        assert_eq!(s.bad_lines(), 6);
    }

    #[test]
    fn intentions_and_cache_points_come_from_debug() {
        let (mut s, t0) = state();
        s.on_packet(
            t0,
            &parse("@ <debug> 0\nrobot id 2 state \"HOMING\" tx 40 ty 20\ncache id 2 kind 0 x 40 y 20\n"),
        );
        s.on_packet(t0, &parse("@ <debug> 0\nrobot id 3 state WANDER\n"));
        assert_eq!(
            s.intent(2),
            Some(&Intent {
                state: "HOMING".into(),
                target: Some((40.0, 20.0))
            })
        );
        assert_eq!(s.intent(3).unwrap().target, None);
        assert_eq!(s.caches().get(&(2, 0)), Some(&(40.0, 20.0)));
    }

    #[test]
    fn the_completion_plot_keeps_the_whole_run_within_its_points() {
        let (mut s, t0) = state();
        for step in 1..=5000u64 {
            let text = format!(
                "@ <metrics> 0\nsort step {} pc {}\n",
                step * 10,
                step as f64 / 50.0
            );
            s.on_packet(t0, &parse(&text));
        }
        let pts: Vec<_> = s.pc_series().copied().collect();
        assert!(
            pts.len() <= PC_POINTS && pts.len() >= PC_POINTS / 4,
            "{}",
            pts.len()
        );
        assert_eq!(pts[0].0, 10);
        assert!(pts.last().unwrap().0 > 49_000);
        s.on_packet(t0, &parse("@ <metrics> 0\nsort step 5 pc 1\n"));
        assert_eq!(
            s.pc_series().count(),
            1,
            "a restarted world starts a new plot"
        );
    }

    fn report(uptime_ms: u64, vision_packets: u64, min: i32) -> StatusReport {
        StatusReport {
            uptime_ms,
            lease_ms: 10_000,
            min_priority: Priority(min),
            client_count: 1,
            clients: vec![],
            channels: vec![
                ChannelInfo {
                    subjects: "vision".into(),
                    packets: vision_packets,
                    bytes: vision_packets * 100,
                },
                ChannelInfo {
                    subjects: "a b".into(),
                    packets: 1,
                    bytes: 10,
                },
            ],
            drops: vec![("below min priority".into(), 3)],
            truncated: false,
        }
    }

    #[test]
    fn rates_come_from_two_status_reports_and_restart_with_the_hub() {
        let (mut s, t0) = state();
        s.on_status(t0, report(1000, 100, i32::MIN));
        assert_eq!(s.rate("vision"), None);
        s.on_status(ms(t0, 1000), report(3000, 160, i32::MIN));
        assert_eq!(s.rate("vision"), Some(30.0));
        s.on_status(ms(t0, 2000), report(500, 10, i32::MIN));
        assert_eq!(s.rate("vision"), None, "a restarted hub has no rate yet");
        assert_eq!(s.channels_seen(), ["a", "b", "vision"]);
        let json: serde_json::Value = serde_json::from_str(&s.hub_json(ms(t0, 2000))).unwrap();
        assert_eq!(json["t"], "hub");
        assert_eq!(json["drops"][0][0], "below min priority");
        assert_eq!(json["min_priority"], serde_json::Value::Null);
    }

    #[test]
    fn the_last_packet_of_each_channel_is_kept_readable_and_short() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse("@ <test.chan> 3\nhello who \"operator\"\n"));
        assert_eq!(
            s.last_packet("test.chan"),
            Some("@ <test.chan> 3\nhello who \"operator\"\n")
        );
        let big = format!("@ <big> 0\n{}", "x v é\n".repeat(1000));
        s.on_packet(t0, &parse(&big));
        let kept = s.last_packet("big").unwrap();
        assert!(kept.len() <= LAST_TEXT_LIMIT && kept.starts_with("@ <big> 0"));
        s.on_packet(t0, &parse("@ <a> <b> 0\nx v 1\n"));
        assert!(s.last_packet("a b").is_some());
    }

    #[test]
    fn hub_and_vision_go_stale_after_two_silent_seconds_and_recover() {
        let (mut s, t0) = state();
        assert_eq!(s.hub_stale_since(ms(t0, 1000)), None);
        assert_eq!(s.hub_stale_since(ms(t0, 2500)), Some(1_000_000));
        s.on_packet(ms(t0, 3000), &parse(ONE_PART));
        assert_eq!(s.hub_stale_since(ms(t0, 3100)), None);
        assert_eq!(s.vision_stale_since(ms(t0, 3100)), None);
        assert_eq!(s.vision_stale_since(ms(t0, 5100)), Some(1_003_000));
        s.on_status(ms(t0, 5000), report(1, 1, 0));
        assert_eq!(s.hub_stale_since(ms(t0, 5100)), None);
        assert!(s.vision_stale_since(ms(t0, 5100)).is_some());
        let json: serde_json::Value = serde_json::from_str(&s.world_json(ms(t0, 5100))).unwrap();
        assert_eq!(json["vision_stale_since"], 1_003_000);
        assert_eq!(json["hub_stale_since"], serde_json::Value::Null);
    }

    #[test]
    fn the_steering_law_turns_first_then_drives_and_stops_at_the_point() {
        // Straight ahead, far: full speed, no turn.
        let (f, t) = steer(0.0, 0.0, 0.0, 100.0, 0.0);
        assert!((f - 1.0).abs() < 1e-9 && t.abs() < 1e-9);
        // Behind and to the left: turn counter-clockwise on the spot.
        let (f, t) = steer(0.0, 0.0, 0.0, -10.0, 1.0);
        assert_eq!((f, t), (0.0, 1.0));
        // To the right: turn clockwise.
        let (_, t) = steer(0.0, 0.0, 0.0, 0.0, -50.0);
        assert_eq!(t, -1.0);
        // Angles wrap: heading pi, target at -x is straight ahead.
        let (f, t) = steer(0.0, 0.0, std::f64::consts::PI, -50.0, 0.0);
        assert!(f > 0.9 && t.abs() < 1e-9);
        // Close: slow; arrived: stop.
        let (f, _) = steer(0.0, 0.0, 0.0, 4.0, 0.0);
        assert!(f > 0.0 && f < 0.5);
        assert_eq!(steer(0.0, 0.0, 0.0, 2.0, 1.0), (0.0, 0.0));
        assert_eq!(steer(0.0, 0.0, f64::NAN, 20.0, 1.0), (0.0, 0.0));
    }

    #[test]
    fn a_held_robot_is_stopped_driven_or_steered_and_released() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        assert!(
            s.override_packets(t0).is_empty(),
            "nobody held: nothing sent"
        );
        s.apply(t0, Command::Take(vec![1])).unwrap();
        assert_eq!(s.override_commands(t0), [(1, 0.0, 0.0)]);
        s.apply(
            t0,
            Command::Drive {
                ids: None,
                forward: 0.5,
                turn: -0.2,
            },
        )
        .unwrap();
        assert_eq!(s.override_commands(ms(t0, 100)), [(1, 0.5, -0.2)]);
        assert_eq!(
            s.override_commands(ms(t0, 600)),
            [(1, 0.0, 0.0)],
            "key commands lapse"
        );
        // Robot 1 is at (10, 0) facing +x: a point ahead means drive.
        s.apply(
            t0,
            Command::Goto {
                ids: Some(vec![1]),
                x: 60.0,
                y: 0.0,
            },
        )
        .unwrap();
        let cmds = s.override_commands(t0);
        assert_eq!(cmds[0].0, 1);
        assert!(cmds[0].1 > 0.9);
        let packets = s.override_packets(t0);
        let p = Packet::parse(&packets[0]).unwrap();
        assert_eq!(p.priority(), Priority(OVERRIDE_PRIORITY));
        assert!(p.has_subject("radio"));
        assert_eq!(p.line("cmd").unwrap().i64("id").unwrap(), 1);
        assert!(s
            .apply(
                t0,
                Command::Goto {
                    ids: Some(vec![0]),
                    x: 0.0,
                    y: 0.0
                }
            )
            .is_err());
        s.apply(t0, Command::Release(vec![1])).unwrap();
        assert!(
            s.override_packets(t0).is_empty(),
            "released: the AI has it back"
        );
        assert!(s.apply(t0, Command::Release(vec![1])).is_err());
        assert!(
            s.take_requests().is_empty(),
            "single robots leave the hub alone"
        );
    }

    #[test]
    fn several_robots_sent_to_one_point_are_spread_around_it() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        s.apply(t0, Command::Take(vec![0, 1])).unwrap();
        s.apply(
            t0,
            Command::Goto {
                ids: None,
                x: 0.0,
                y: 0.0,
            },
        )
        .unwrap();
        let targets: Vec<_> = s.held().values().copied().collect();
        assert_ne!(targets[0], targets[1]);
    }

    #[test]
    fn taking_all_raises_the_minimum_priority_and_release_restores_the_old_one() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        s.apply(t0, Command::TakeAll).unwrap();
        assert_eq!(s.held().len(), 2);
        assert!(s.wants_status());
        assert!(
            s.take_requests().is_empty(),
            "not before the old value is known"
        );
        s.on_status(t0, report(1, 1, 3));
        assert_eq!(
            s.take_requests(),
            [Request::MinPriority(Priority(OVERRIDE_PRIORITY))]
        );
        // The hub restarted and forgot: raise it again.
        s.on_status(t0, report(1, 1, i32::MIN));
        assert_eq!(
            s.take_requests(),
            [Request::MinPriority(Priority(OVERRIDE_PRIORITY))]
        );
        s.apply(t0, Command::ReleaseAll).unwrap();
        assert_eq!(s.take_requests(), [Request::MinPriority(Priority(3))]);
        assert!(s.held().is_empty() && !s.all_held());
        // Already high: left alone, and nothing to restore.
        s.apply(t0, Command::TakeAll).unwrap();
        s.on_status(t0, report(1, 1, 50));
        assert!(s.take_requests().is_empty());
        assert!(s.shutdown().is_empty());
    }

    #[test]
    fn robots_appearing_while_all_are_held_are_held_too() {
        let (mut s, t0) = state();
        s.apply(t0, Command::TakeAll).unwrap();
        assert!(s.held().is_empty());
        s.on_packet(t0, &parse(ONE_PART));
        assert_eq!(s.held().len(), 2);
        s.on_status(t0, report(1, 1, i32::MIN));
        s.take_requests();
        assert_eq!(
            s.shutdown(),
            [Request::MinPriority(Priority(i32::MIN))],
            "stopping the monitor lets go"
        );
    }

    #[test]
    fn a_forged_packet_is_checked_with_its_line_and_column() {
        assert_eq!(
            check_forged("@ <test> 0\nhello x 1").unwrap(),
            b"@ <test> 0\nhello x 1\n"
        );
        let e = check_forged("@ <test> 0\nhello x (y 1\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.column > 1);
        assert!(!e.message.is_empty());
        assert_eq!(check_forged("").unwrap_err().line, 1);
        assert!(check_forged("@ <a b> 0\n").is_err());
    }

    #[test]
    fn the_world_snapshot_is_compact_json() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        s.on_packet(t0, &parse("@ <debug> 0\nrobot id 0 state \"SEARCH\"\n"));
        s.apply(t0, Command::Take(vec![0])).unwrap();
        let json: serde_json::Value = serde_json::from_str(&s.world_json(t0)).unwrap();
        assert_eq!(json["t"], "world");
        assert_eq!(json["step"], 7);
        assert_eq!(json["robots"][1], serde_json::json!([1, 10.0, 0.0, 0.0, 3]));
        assert_eq!(json["robots"][0][4], -1);
        assert_eq!(json["pucks"][0], serde_json::json!([3, 1, 17.0, 0.0]));
        assert_eq!(
            json["intents"][0],
            serde_json::json!([0, "SEARCH", null, null])
        );
        assert_eq!(json["held"], serde_json::json!([0]));
        assert_eq!(json["arena"]["corner"], 15.0);
    }
}
