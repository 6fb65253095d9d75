//! The world as the swarm channels show it: the newest complete `vision` frame with the arena
//! and body sizes, each robot's intention and cache points from `debug`, and the percentage
//! completion over time from `metrics`.
//!
//! Packets are read with proto's viewer decoders ([`vision::skim`], [`debug::skim`],
//! [`metrics::skim`]): a bad line is skipped and counted, and the rest is shown. What is left
//! here is the monitor's own policy: how much it keeps, and how the completion plot is thinned.

use std::collections::{BTreeMap, VecDeque};
use std::time::Instant;

use colony_proto::swarm::{
    debug, metrics, vision, Arena, Intent, PuckKind, Sizes, VisionAssembler, VisionFrame,
};
use colony_proto::Vec2;
use colony_wire::Packet;
use serde::Serialize;

use super::operator::MAX_HELD;

pub use colony_proto::swarm::Progress;

/// Points kept in the completion plot (older ones are thinned out).
pub const PC_POINTS: usize = 600;
/// The longest state name kept (a page has no room for more).
const MAX_STATE_CHARS: usize = 40;
/// Robots whose intentions are kept, at most.
const MAX_INTENTS: usize = MAX_HELD * 4;
/// Cache points kept, at most.
const MAX_CACHES: usize = MAX_HELD * 16;
/// A frame of at most this many robots and pucks together is also written into the world's
/// JSON (for tools and tests that read it); the page draws from the binary bodies
/// ([`super::bodies`]) whatever the size, and a larger frame is there only.
pub const JSON_BODIES_MAX: usize = 4096;

/// What the swarm channels have shown of the world.
#[derive(Debug, Default)]
pub struct WorldView {
    arena: Option<Arena>,
    sizes: Option<Sizes>,
    frame: VisionFrame,
    frame_at: Option<Instant>,
    frame_version: u64,
    assembler: VisionAssembler,
    vision_at: Option<Instant>,
    intents: BTreeMap<u32, Intent>,
    caches: BTreeMap<(u32, PuckKind), Vec2>,
    pc: VecDeque<(u64, f64)>,
    pc_gap: u64,
}

/// The world's part of the page's snapshot.
#[derive(Serialize)]
pub(super) struct WorldJson<'a> {
    step: Option<u64>,
    /// Robots and pucks in the newest whole frame (in `robots` and `pucks` too when the frame
    /// has at most [`JSON_BODIES_MAX`] bodies, and always in the binary bodies message).
    nrobots: usize,
    npucks: usize,
    /// Whole frames put together so far.
    frames: u64,
    /// Frames dropped with some of their parts missing: never drawn, counted.
    frames_missing: u64,
    arena: Option<Arena>,
    sizes: Option<Sizes>,
    /// `[id, x, y, theta, carrying or -1]`
    robots: Vec<(u32, f64, f64, f64, i64)>,
    /// `[id, kind, x, y]`
    pucks: Vec<(u32, u8, f64, f64)>,
    /// `[id, state, tx or null, ty or null]`
    intents: Vec<(u32, &'a str, Option<f64>, Option<f64>)>,
    /// `[robot, kind, x, y]`
    caches: Vec<(u32, u8, f64, f64)>,
    /// `[id, x, y, theta, length, width]`
    boxes: Vec<(u32, f64, f64, f64, f64, f64)>,
    /// `[x, y]`
    goal: Option<(f64, f64)>,
    pc: Option<(u64, f64)>,
}

impl WorldView {
    /// The newest complete frame (robots and pucks sorted by id).
    pub fn frame(&self) -> &VisionFrame {
        &self.frame
    }

    /// Counts complete frames; changes whenever a new one is in.
    pub fn frame_version(&self) -> u64 {
        self.frame_version
    }

    /// Frames dropped with some of their parts in and not all: never shown, counted.
    pub fn frames_missing(&self) -> u64 {
        self.assembler.missing()
    }

    /// The newest whole frame's robots and pucks as the page's binary message.
    pub fn bodies(&self) -> Vec<u8> {
        super::bodies::encode(&self.frame, self.frame_version)
    }

    /// The arena's walls, once a vision part has said them.
    pub fn arena(&self) -> Option<Arena> {
        self.arena
    }

    /// The bodies' sizes, once a vision part has said them.
    pub fn sizes(&self) -> Option<Sizes> {
        self.sizes
    }

    /// When the last vision packet arrived.
    pub fn vision_at(&self) -> Option<Instant> {
        self.vision_at
    }

    /// What `robot`'s controller last said it is doing.
    pub fn intent(&self, robot: u32) -> Option<&Intent> {
        self.intents.get(&robot)
    }

    /// Cache points the robots announced: `(robot, kind) -> point`.
    pub fn caches(&self) -> &BTreeMap<(u32, PuckKind), Vec2> {
        &self.caches
    }

    /// Percentage completion over time: `(step, pc)`.
    pub fn pc_series(&self) -> impl Iterator<Item = &(u64, f64)> {
        self.pc.iter()
    }

    /// Takes in a vision part received at `now`: the bad lines it had, and whether it completed
    /// a frame.
    pub(super) fn on_vision(&mut self, now: Instant, packet: &Packet<'_>) -> (u64, bool) {
        self.vision_at = Some(now);
        let Ok(part) = vision::skim(packet) else {
            return (1, false);
        };
        let bad = part.bad_lines;
        let part = part.message;
        // The walls and sizes are shown as soon as they are known, even before a frame is whole.
        self.arena = part.frame.arena.or(self.arena);
        self.sizes = part.frame.sizes.or(self.sizes);
        let Some(frame) = self.assembler.offer(part) else {
            return (bad, false);
        };
        self.frame = frame;
        self.frame_at = Some(now);
        self.frame_version += 1;
        (bad, true)
    }

    /// Takes in intentions and cache points; returns the bad lines.
    pub(super) fn on_debug(&mut self, packet: &Packet<'_>) -> u64 {
        let read = debug::skim(packet);
        for mut intent in read.message.intents {
            if !self.intents.contains_key(&intent.robot) && self.intents.len() >= MAX_INTENTS {
                continue;
            }
            intent.state = intent.state.chars().take(MAX_STATE_CHARS).collect();
            self.intents.insert(intent.robot, intent);
        }
        for c in read.message.caches {
            let key = (c.robot, c.kind);
            if self.caches.contains_key(&key) || self.caches.len() < MAX_CACHES {
                self.caches.insert(key, c.pos);
            }
        }
        read.bad_lines
    }

    /// Takes in sorting progress; returns the bad lines.
    pub(super) fn on_metrics(&mut self, packet: &Packet<'_>) -> u64 {
        let read = metrics::skim(packet);
        if let Some(p) = read.message {
            self.add_progress(p);
        }
        read.bad_lines
    }

    fn add_progress(&mut self, Progress { step, pc }: Progress) {
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

    pub(super) fn json(&self) -> WorldJson<'_> {
        let f = &self.frame;
        let small = f.robots.len() + f.pucks.len() <= JSON_BODIES_MAX;
        WorldJson {
            step: self.frame_at.map(|_| f.step),
            nrobots: f.robots.len(),
            npucks: f.pucks.len(),
            frames: self.frame_version,
            frames_missing: self.frames_missing(),
            arena: self.arena,
            sizes: self.sizes,
            robots: f
                .robots
                .iter()
                .take(if small { usize::MAX } else { 0 })
                .map(|r| {
                    let p = r.pose;
                    (r.id, p.x, p.y, p.theta, r.carrying.map_or(-1, i64::from))
                })
                .collect(),
            pucks: f
                .pucks
                .iter()
                .take(if small { usize::MAX } else { 0 })
                .map(|p| (p.id, p.kind.0, p.pos.x, p.pos.y))
                .collect(),
            intents: self
                .intents
                .iter()
                .map(|(id, i)| {
                    let t = i.target;
                    (*id, i.state.as_str(), t.map(|t| t.x), t.map(|t| t.y))
                })
                .collect(),
            caches: self
                .caches
                .iter()
                .map(|(&(r, k), p)| (r, k.0, p.x, p.y))
                .collect(),
            boxes: f
                .boxes
                .iter()
                .map(|b| (b.id, b.pose.x, b.pose.y, b.pose.theta, b.length, b.width))
                .collect(),
            goal: f.goal.map(|g| (g.x, g.y)),
            pc: self.pc.back().copied(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Packet<'_> {
        Packet::parse(text.as_bytes()).unwrap()
    }

    #[test]
    fn the_completion_plot_keeps_the_whole_run_within_its_points() {
        let mut w = WorldView::default();
        for step in 1..=5000u64 {
            let text = format!(
                "@ <metrics> 0\nsort step {} pc {}\n",
                step * 10,
                step as f64 / 50.0
            );
            w.on_metrics(&parse(&text));
        }
        let pts: Vec<_> = w.pc_series().copied().collect();
        assert!(
            pts.len() <= PC_POINTS && pts.len() >= PC_POINTS / 4,
            "{}",
            pts.len()
        );
        assert_eq!(pts[0].0, 10);
        assert!(pts.last().unwrap().0 > 49_000);
        w.on_metrics(&parse("@ <metrics> 0\nsort step 5 pc 1\n"));
        assert_eq!(
            w.pc_series().count(),
            1,
            "a restarted world starts a new plot"
        );
    }

    #[test]
    fn a_big_frame_goes_to_the_page_as_bodies_not_json() {
        use colony_proto::swarm::{VisionPuck, VisionRobot};
        use colony_proto::Pose;
        let frame = VisionFrame {
            step: 3,
            robots: (0..500)
                .map(|id| VisionRobot {
                    id,
                    pose: Pose {
                        x: 1.0,
                        y: 2.0,
                        theta: 0.0,
                    },
                    carrying: None,
                })
                .collect(),
            pucks: (0..5000)
                .map(|id| VisionPuck {
                    id,
                    kind: PuckKind(1),
                    pos: Vec2::new(3.0, 4.0),
                })
                .collect(),
            ..VisionFrame::default()
        };
        let mut w = WorldView::default();
        let now = Instant::now();
        for bytes in vision::encode(&frame).unwrap() {
            w.on_vision(now, &Packet::parse(&bytes).unwrap());
        }
        assert_eq!(w.frame_version(), 1);
        let json = serde_json::to_value(w.json()).unwrap();
        assert_eq!(
            (&json["nrobots"], &json["npucks"]),
            (&500.into(), &5000.into())
        );
        assert_eq!(json["robots"], serde_json::json!([]), "too many for JSON");
        assert_eq!(json["pucks"], serde_json::json!([]));
        assert_eq!(
            w.bodies().len(),
            super::super::bodies::HEADER + 500 * 20 + 5000 * 13
        );
    }

    #[test]
    fn intentions_and_cache_points_come_from_debug() {
        let mut w = WorldView::default();
        let bad = w.on_debug(&parse(
            "@ <debug> 0\nrobot id 2 state \"HOMING\" tx 40 ty 20\ncache id 2 kind 0 x 40 y 20\n",
        ));
        w.on_debug(&parse("@ <debug> 0\nrobot id 3 state WANDER\n"));
        assert_eq!(bad, 0);
        assert_eq!(
            w.intent(2),
            Some(&Intent {
                robot: 2,
                state: "HOMING".into(),
                target: Some(Vec2::new(40.0, 20.0))
            })
        );
        assert_eq!(w.intent(3).unwrap().target, None);
        assert_eq!(
            w.caches().get(&(2, PuckKind(0))),
            Some(&Vec2::new(40.0, 20.0))
        );
        let long = format!("@ <debug> 0\nrobot id 4 state {}\n", "A".repeat(100));
        w.on_debug(&parse(&long));
        assert_eq!(w.intent(4).unwrap().state.len(), MAX_STATE_CHARS);
    }
}
