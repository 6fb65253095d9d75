//! The operator's override (the Broker paper's): which robots the monitor holds, how each is
//! driven, and the hub's minimum priority for "take control of all".
//!
//! Held robots are commanded on `radio` at [`OVERRIDE_PRIORITY`], above the controllers' 0, so
//! the world lets the operator hold a robot while the others keep sorting
//! ([`colony_proto::CommandHold`] is the world's side of that rule). "Take control of all" also
//! raises the hub's minimum priority to that value once a status report has told the old one,
//! re-sends it every third of the hub's lease (the hub lets a raised minimum lapse after one
//! lease, so a monitor that dies cannot hold the swarm forever), and restores it on release.
//!
//! Every hold belongs to the page that took it ([`PageId`]): when that page goes away (its
//! WebSocket closes: a tab closed, a laptop asleep), what it held is released as if its operator
//! had pressed release, so no robot stays stopped for an operator who is no longer there.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use colony_proto::radio::{self, RadioCommand};
use colony_proto::swarm::VisionFrame;
use colony_proto::{Vec2, WheelCommand};
use colony_wire::{Priority, Request};
use serde::Serialize;

use super::command::{Command, CommandError};
use super::steer::steer;

/// The priority of the operator's commands: above the controllers' 0, so
/// the world lets the operator hold a robot while the others keep sorting.
pub const OVERRIDE_PRIORITY: i32 = 10;
/// A key-driven command lapses (the robot stops, still held) unless the
/// browser repeats it within this time: a closed tab must not leave a robot driving.
pub const DRIVE_LAPSE: Duration = Duration::from_millis(500);
/// Robots held at once, at most (one radio packet each control step).
pub const MAX_HELD: usize = 1500;
/// Coordinates accepted from the operator, cm (the largest arena is 100 m).
pub const MAX_COORD: f64 = 100_000.0;
/// Robots sent to one point together are spread on a grid this wide (cm).
const GOTO_SPACING_CM: f64 = 16.0;
/// The hub's lease until a status report tells it (the hub's default).
const DEFAULT_LEASE: Duration = Duration::from_secs(10);
/// A raised minimum priority is refreshed at least this often, however long the lease.
const MAX_REFRESH: Duration = Duration::from_secs(3);

/// Which browser page (one WebSocket) asked for something: holds are that page's, and end
/// with it. The web server numbers its connections; tests use any number.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct PageId(pub u64);

/// Commands per radio packet (each line is about 40 bytes: well inside a datagram).
const COMMANDS_PER_PACKET: usize = 1000;

/// How a held robot is driven.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// Held still.
    Stop,
    /// Driven by keys until `until`, then stopped.
    Drive {
        /// Forward speed, -1 to 1.
        forward: f64,
        /// Turn rate, -1 to 1 (counter-clockwise positive).
        turn: f64,
        /// When the command lapses unless repeated.
        until: Instant,
    },
    /// Steered to a point from its vision pose.
    Goto {
        /// The point's x, cm.
        x: f64,
        /// The point's y, cm.
        y: f64,
    },
}

/// Where the hub's minimum priority stands for "take control of all".
#[derive(Debug, Clone, Copy, PartialEq, Default)]
enum MinPlan {
    /// The monitor has not touched it.
    #[default]
    Idle,
    /// Raise it once a status report has told the current value.
    WantRaise,
    /// Raised to the override priority; restore `previous` on release.
    Raised {
        previous: Priority,
        /// When the raised value was last sent (it lapses at the hub after one lease).
        sent: Instant,
    },
    /// It was already at or above the override priority: leave it alone.
    AlreadyHigh,
}

/// The robots the operator holds, and what the hub should be asked for them.
#[derive(Debug, Default)]
pub struct Override {
    held: BTreeMap<u32, Mode>,
    /// The page that took each held robot (the last one to take it).
    holders: BTreeMap<u32, PageId>,
    /// The page that pressed "take control of all", while it is in force.
    all: Option<PageId>,
    min_plan: MinPlan,
    /// The hub's lease, from its status reports.
    lease: Option<Duration>,
    outbox: Vec<Request>,
}

/// The override's part of the page's snapshot.
#[derive(Serialize)]
pub(super) struct OverrideJson {
    held: Vec<u32>,
    all: bool,
    min_raised: bool,
    /// `[id, x, y]` for robots steered to a point.
    targets: Vec<(u32, f64, f64)>,
}

impl Override {
    /// The held robots and how each is driven.
    pub fn held(&self) -> &BTreeMap<u32, Mode> {
        &self.held
    }

    /// Whether "take control of all" is in force.
    pub fn all_held(&self) -> bool {
        self.all.is_some()
    }

    /// Which page holds robot `id`, if it is held.
    pub fn holder(&self, id: u32) -> Option<PageId> {
        self.holders.get(&id).copied()
    }

    /// Requests for the hub that the override wants sent (minimum priority).
    pub fn take_requests(&mut self) -> Vec<Request> {
        std::mem::take(&mut self.outbox)
    }

    /// Whether a status report is wanted now (to learn the minimum priority).
    pub fn wants_status(&self) -> bool {
        self.min_plan == MinPlan::WantRaise
    }

    /// A new complete frame: while all are held, robots appearing in it are held too.
    pub(super) fn on_frame(&mut self, frame: &VisionFrame) {
        if let Some(page) = self.all {
            self.hold_all(page, frame);
        }
    }

    fn hold_all(&mut self, page: PageId, frame: &VisionFrame) {
        for r in &frame.robots {
            if self.held.len() < MAX_HELD && !self.held.contains_key(&r.id) {
                self.held.insert(r.id, Mode::Stop);
                self.holders.insert(r.id, page);
            }
        }
    }

    /// The hub's minimum priority and lease, from a status report received at `now`: the step
    /// of "take control of all".
    pub(super) fn on_min_priority(&mut self, now: Instant, min: Priority, lease_ms: u64) {
        if lease_ms > 0 {
            self.lease = Some(Duration::from_millis(lease_ms));
        }
        match self.min_plan {
            MinPlan::WantRaise if min.0 < OVERRIDE_PRIORITY => {
                self.min_plan = MinPlan::Raised {
                    previous: min,
                    sent: now,
                };
                self.outbox
                    .push(Request::MinPriority(Priority(OVERRIDE_PRIORITY)));
            }
            MinPlan::WantRaise => self.min_plan = MinPlan::AlreadyHigh,
            // The hub restarted, the raise lapsed or someone lowered it: raise it again.
            MinPlan::Raised { previous, .. } if min.0 < OVERRIDE_PRIORITY => {
                self.min_plan = MinPlan::Raised {
                    previous,
                    sent: now,
                };
                self.outbox
                    .push(Request::MinPriority(Priority(OVERRIDE_PRIORITY)));
            }
            _ => {}
        }
    }

    /// How often a raised minimum priority is sent again: a third of the hub's lease (so one
    /// lost request does not let it lapse), and at least every [`MAX_REFRESH`].
    fn refresh_every(&self) -> Duration {
        (self.lease.unwrap_or(DEFAULT_LEASE) / 3).min(MAX_REFRESH)
    }

    /// When [`poll`](Self::poll) next has something to do, if ever.
    pub fn next_deadline(&self) -> Option<Instant> {
        match self.min_plan {
            MinPlan::Raised { sent, .. } => Some(sent + self.refresh_every()),
            _ => None,
        }
    }

    /// Time passes: a raised minimum priority is sent again when its refresh is due.
    pub fn poll(&mut self, now: Instant) {
        if let MinPlan::Raised { previous, sent } = self.min_plan {
            if now >= sent + self.refresh_every() {
                self.min_plan = MinPlan::Raised {
                    previous,
                    sent: now,
                };
                self.outbox
                    .push(Request::MinPriority(Priority(OVERRIDE_PRIORITY)));
            }
        }
    }

    /// Page `page` went away: whatever it held is released as if it had pressed release
    /// (and, if it took all, the hub's minimum priority is restored). Holds of other pages stay.
    /// Returns how many robots were let go.
    pub fn page_closed(&mut self, page: PageId) -> usize {
        let mine: Vec<u32> = self
            .holders
            .iter()
            .filter(|(_, p)| **p == page)
            .map(|(id, _)| *id)
            .collect();
        for id in &mine {
            self.held.remove(id);
            self.holders.remove(id);
        }
        if self.all == Some(page) {
            self.end_all();
        }
        mine.len()
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

    /// Carries out an override request from `page` at `now`, `frame` being the newest world.
    pub(super) fn apply(
        &mut self,
        now: Instant,
        page: PageId,
        command: Command,
        frame: &VisionFrame,
    ) -> Result<String, CommandError> {
        match command {
            Command::Publish(bytes) => Ok(format!("published {} bytes", bytes.len())),
            Command::Game(order) => Ok(format!("sent {order}")),
            Command::Take(ids) => {
                if ids.is_empty() {
                    return Err(CommandError::NoneSelected);
                }
                for id in &ids {
                    if self.held.len() >= MAX_HELD && !self.held.contains_key(id) {
                        return Err(CommandError::TooMany);
                    }
                    self.held.entry(*id).or_insert(Mode::Stop);
                    // Taking a robot another page holds makes it this page's.
                    self.holders.insert(*id, page);
                }
                Ok(format!("holding {}", list(&ids)))
            }
            Command::TakeAll => {
                self.all = Some(page);
                self.hold_all(page, frame);
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
                    self.holders.remove(id);
                }
                if self.held.is_empty() && self.all.is_some() {
                    self.release_all();
                }
                if released.is_empty() {
                    Err(CommandError::NotHeld(list(&ids)))
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
                    return Err(CommandError::NoneHeld("drive"));
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
                    return Err(CommandError::NoneHeld("send"));
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
        self.holders.clear();
        self.end_all();
    }

    /// "Take control of all" ends: new robots are no longer held, and the hub's minimum
    /// priority goes back to what it was.
    fn end_all(&mut self) {
        self.all = None;
        if let MinPlan::Raised { previous, .. } = self.min_plan {
            self.outbox.push(Request::MinPriority(previous));
        }
        self.min_plan = MinPlan::Idle;
    }

    /// Lets every robot go and puts the hub's minimum priority back (when the monitor stops).
    pub(super) fn shutdown(&mut self) -> Vec<Request> {
        self.release_all();
        self.take_requests()
    }

    /// Each held robot's command at `now`, steering from its pose in `frame`.
    pub(super) fn commands(&mut self, now: Instant, frame: &VisionFrame) -> Vec<RadioCommand> {
        let poses: BTreeMap<u32, _> = frame.robots.iter().map(|r| (r.id, r.pose)).collect();
        let mut out = Vec::with_capacity(self.held.len());
        for (id, mode) in self.held.iter_mut() {
            let wheels = match *mode {
                Mode::Stop => WheelCommand::STOP,
                Mode::Drive {
                    forward,
                    turn,
                    until,
                } => {
                    if now < until {
                        WheelCommand::clamped(forward, turn)
                    } else {
                        *mode = Mode::Stop;
                        WheelCommand::STOP
                    }
                }
                Mode::Goto { x, y } => match poses.get(id) {
                    Some(pose) => steer(*pose, Vec2::new(x, y)),
                    None => WheelCommand::STOP,
                },
            };
            out.push(RadioCommand { robot: *id, wheels });
        }
        out
    }

    /// The radio packets that hold the held robots at `now`, at [`OVERRIDE_PRIORITY`].
    pub(super) fn packets(&mut self, now: Instant, frame: &VisionFrame) -> Vec<Vec<u8>> {
        let cmds = self.commands(now, frame);
        cmds.chunks(COMMANDS_PER_PACKET)
            .filter_map(|chunk| radio::encode(chunk, Priority(OVERRIDE_PRIORITY)).ok())
            .collect()
    }

    pub(super) fn json(&self) -> OverrideJson {
        OverrideJson {
            held: self.held.keys().copied().collect(),
            all: self.all.is_some(),
            min_raised: matches!(self.min_plan, MinPlan::Raised { .. }),
            targets: self
                .held
                .iter()
                .filter_map(|(id, m)| match m {
                    Mode::Goto { x, y } => Some((*id, *x, *y)),
                    _ => None,
                })
                .collect(),
        }
    }
}

/// Robot ids for a message, the first dozen named.
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
