//! The tightly coupled experiment of section 6.1: a watcher and two pushers
//! move a long box to a goal in the physics field.
//!
//! The watcher is the machine with the overhead camera. A user agent
//! introduces one high-level task, `move-box` (needs `overhead-camera`); the
//! watcher wins it, and executing it means watching the box and announcing
//! pushing tasks through an [`Announcer`] of its own: while the box faces the
//! goal, `push-left-end` and `push-right-end` together; when it is turned away,
//! only the end that turns it back. The pushers (`mobile bumpers`) are not
//! handed: both run the same program and bid by how far they are from the end
//! to push. A pusher switched off mid-run stops renewing; its task is auctioned
//! again, and the other pusher, alone, see-saws the box to the goal, switching
//! ends as the watcher asks. Switched on again (on the other side), it is
//! brought straight back into the team.

use std::f64::consts::PI;
use std::time::Duration;

use colony_proto::{wrap_angle, Pose, Vec2, WheelCommand};
use colony_sim::field::{
    BoxSpec, Field, FieldBoxId, FieldConfig, FieldRobotId, RobotSpec, TileMap,
};
use colony_sim::SimError;
use serde::Serialize;

use super::Progress;
use crate::agent::{Agent, AgentConfig, AgentEvent};
use crate::announcer::{Announcer, AnnouncerEvent, AuctionConfig};
use crate::bus::Bus;
use crate::node::Node;
use crate::protocol::{
    Announcement, ResourceError, ResourceSet, SpecError, TaskSpec, Token, TokenError,
};
use crate::time::Time;
use crate::user::{Backoff, UserAgent, UserEvent};

/// The high-level task the user introduces.
pub const MOVE_BOX: &str = "move-box";
/// Push the end on the left, looking from behind the box towards the goal.
pub const PUSH_LEFT: &str = "push-left-end";
/// Push the end on the right.
pub const PUSH_RIGHT: &str = "push-right-end";

/// A run's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxPushConfig {
    /// Where the box starts: centre and heading of its length, cm and rad.
    pub box_start: Pose,
    /// Where it must go, cm.
    pub goal: Vec2,
    /// Close enough, cm from the box's centre.
    pub tolerance_cm: f64,
    /// Switch one pusher off at this time, s.
    pub off_at: Option<f64>,
    /// Switch it on again at this time, s.
    pub on_at: Option<f64>,
    /// Give up after this long, s.
    pub max_s: f64,
    /// How long each push lasts once a pusher is in place, s.
    pub push_s: f64,
    /// Box turned further than this from facing the goal gets a one-ended push, rad.
    pub align_tolerance: f64,
}

impl Default for BoxPushConfig {
    fn default() -> Self {
        BoxPushConfig {
            box_start: Pose {
                x: 300.0,
                y: 120.0,
                theta: 0.0,
            },
            goal: Vec2::new(360.0, 400.0),
            tolerance_cm: 25.0,
            off_at: None,
            on_at: None,
            max_s: 900.0,
            push_s: 2.0,
            align_tolerance: 0.15,
        }
    }
}

/// How a run went.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct BoxPushReport {
    /// The box reached the goal.
    pub reached: bool,
    /// When (or when the run stopped), s.
    pub time_s: f64,
    /// The box's centre's distance from the goal at the end, cm.
    pub final_distance_cm: f64,
    /// Pushing tasks announced.
    pub announced: u64,
    /// Pushes finished, by task: left, right.
    pub pushes_left: u64,
    /// See `pushes_left`.
    pub pushes_right: u64,
    /// Pushes finished by each pusher.
    pub pushes_by: Vec<u64>,
    /// Push tasks no pusher could take.
    pub unachievable: u64,
    /// Push tasks auctioned again after their pusher failed.
    pub reallocated: u64,
    /// Times the pusher doing a push changed from the one before it on that end.
    pub role_swaps: u64,
    /// Packets published.
    pub messages: u64,
}

/// A run: its report, and the box's pose each second.
#[derive(Debug, Clone)]
pub struct BoxPushOutcome {
    /// The summary.
    pub report: BoxPushReport,
    /// Time (s) and box pose, once a second.
    pub track: Vec<(f64, Pose)>,
    /// Notable events as text, with their time.
    pub events: Vec<(f64, String)>,
}

const BOX: BoxSpec = BoxSpec {
    half_length: 30.0,
    half_width: 4.0,
    mass: 400.0,
    damping: 6.0,
};

const PUSHER: RobotSpec = RobotSpec {
    radius: 8.0,
    max_speed: 20.0,
    max_turn: 2.0,
    amphibious: false,
};

/// Which way the watcher wants the box to go, and which ends are which.
#[derive(Debug, Clone, Copy)]
struct Frame {
    centre: Vec2,
    /// Along the length, towards the right end.
    u: Vec2,
    /// The push direction: perpendicular to the length, towards the goal's side.
    n: Vec2,
    /// Signed angle from `n` to the goal; positive means turn left.
    error: f64,
}

fn frame(pose: Pose, goal: Vec2) -> Frame {
    let centre = pose.position();
    let mut u = Vec2::new(pose.theta.cos(), pose.theta.sin());
    let mut n = Vec2::new(-u.y, u.x);
    let g = goal - centre;
    if n.x * g.x + n.y * g.y < 0.0 {
        n = n * -1.0;
        u = u * -1.0;
    }
    let error = (n.x * g.y - n.y * g.x).atan2(n.x * g.x + n.y * g.y);
    // With n = perp(u), the end at -u is on the left looking along n.
    Frame {
        centre,
        u,
        n,
        error,
    }
}

fn dot(a: Vec2, b: Vec2) -> f64 {
    a.x * b.x + a.y * b.y
}

/// Where on the box's back face to push the end `side` (-1 left, +1 right).
fn push_point(f: &Frame, side: f64) -> Vec2 {
    f.centre + f.u * (side * BOX.half_length * 0.7) - f.n * BOX.half_width
}

/// The watcher's pushing task for one end.
fn push_task(f: &Frame, side: f64, push_s: f64) -> TaskSpec {
    let p = push_point(f, side);
    let name = if side < 0.0 { PUSH_LEFT } else { PUSH_RIGHT };
    TaskSpec::new(name, pusher_resources())
        .length(push_s)
        .param("x", p.x)
        .param("y", p.y)
        .param("nx", f.n.x)
        .param("ny", f.n.y)
        .metric("distance", 1.0)
}

fn pusher_resources() -> ResourceSet {
    let mut r = ResourceSet::new();
    // Both names are valid resources; a failure here would be a typo in this file.
    let _ = r.insert("mobile");
    let _ = r.insert("bumpers");
    r
}

/// A pusher executing one task: get behind the end, face the push direction, push.
#[derive(Debug, Clone)]
struct Push {
    /// -1 left end, +1 right end, in the box's own frame (fixed at the start).
    end: f64,
    /// The push direction at the start, to pick the same face as the box turns.
    n0: Vec2,
    pushing_since: Option<f64>,
    started: f64,
    push_s: f64,
}

impl Push {
    fn new(ann: &Announcement, box_pose: Pose, now: f64) -> Push {
        let p = Vec2::new(
            ann.spec.number("x").unwrap_or(box_pose.x),
            ann.spec.number("y").unwrap_or(box_pose.y),
        );
        let n0 = Vec2::new(
            ann.spec.number("nx").unwrap_or(0.0),
            ann.spec.number("ny").unwrap_or(1.0),
        );
        // Which end of the box, in its own frame, the point is at.
        let along = Vec2::new(box_pose.theta.cos(), box_pose.theta.sin());
        let end = if dot(p - box_pose.position(), along) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        Push {
            end,
            n0,
            pushing_since: None,
            started: now,
            push_s: ann.spec.length_s,
        }
    }

    /// The wheels for this step, or `None` when the push is over.
    fn step(&mut self, me: Pose, box_pose: Pose, now: f64) -> Option<WheelCommand> {
        if let Some(since) = self.pushing_since {
            if now - since >= self.push_s {
                return None;
            }
        }
        if now - self.started > 60.0 {
            return None; // stuck: give the watcher a fresh look
        }
        let along = Vec2::new(box_pose.theta.cos(), box_pose.theta.sin());
        let mut n = Vec2::new(-along.y, along.x);
        if dot(n, self.n0) < 0.0 {
            n = n * -1.0;
        }
        let end = box_pose.position() + along * (self.end * BOX.half_length * 0.7);
        let face = end - n * BOX.half_width;
        let pos = me.position();
        let stand = face - n * (PUSHER.radius + 10.0);
        if self.pushing_since.is_none() {
            // In front of the back face: go round the end first.
            let behind = dot(pos - box_pose.position(), n);
            let target = if behind > -(BOX.half_width + PUSHER.radius) {
                end + along * (self.end * (BOX.half_length * 0.3 + PUSHER.radius + 15.0))
                    - n * (BOX.half_width + PUSHER.radius + 15.0)
            } else {
                stand
            };
            let d = target - pos;
            if target == stand && d.length() < 3.0 {
                let e = wrap_angle(n.angle() - me.theta);
                if e.abs() < 0.08 {
                    self.pushing_since = Some(now);
                } else {
                    return Some(WheelCommand {
                        forward: 0.0,
                        turn: (2.0 * e).clamp(-1.0, 1.0),
                    });
                }
            } else {
                return Some(drive_to(me, target));
            }
        }
        // Push: head for a point beyond the face, so the robot stays on its end.
        Some(drive_to(me, face + n * 40.0))
    }
}

/// A go-to-point controller that backs up to close targets behind it.
fn drive_to(me: Pose, target: Vec2) -> WheelCommand {
    let d = target - me.position();
    let dist = d.length();
    let e = wrap_angle(d.angle() - me.theta);
    let speed = (dist / 15.0).clamp(0.15, 1.0);
    if dist < 30.0 && e.abs() > PI / 2.0 {
        let back = wrap_angle(e - PI);
        return WheelCommand {
            forward: -speed * back.cos().max(0.0),
            turn: (2.0 * back).clamp(-1.0, 1.0),
        };
    }
    WheelCommand {
        forward: if e.abs() < 0.6 { speed * e.cos() } else { 0.0 },
        turn: (2.0 * e).clamp(-1.0, 1.0),
    }
}

/// The watcher's side of `move-box`: look, decide, announce, wait for the round.
struct Watcher {
    announcer: Announcer,
    open: Vec<(u64, String)>,
    next_look: f64,
}

struct Pusher {
    robot: FieldRobotId,
    agent: Option<Agent>,
    push: Option<(u64, String, Push)>,
    name: String,
}

fn quick_agent() -> AgentConfig {
    AgentConfig {
        renew_interval: Duration::from_millis(500),
        renew_timeout: Duration::from_millis(1500),
        award_grace: Duration::from_millis(300),
        linger: Duration::from_millis(1500),
        ..AgentConfig::default()
    }
}

fn quick_auction() -> AuctionConfig {
    AuctionConfig {
        bid_window: Duration::from_millis(100),
        ack_timeout: Duration::from_millis(500),
        renew_interval: Duration::from_millis(500),
        renew_timeout: Duration::from_millis(1500),
        max_attempts: 8,
    }
}

fn pusher_agent(name: &str, now: Time) -> Result<Agent, TokenError> {
    Ok(Agent::new(
        Token::new(name)?,
        pusher_resources(),
        quick_agent(),
        now,
    ))
}

/// Why a run could not be made or could not go on.
#[derive(Debug, thiserror::Error)]
pub enum BoxPushError {
    /// The goal or the time limit is not a finite number.
    #[error("the goal and the time limit must be finite numbers")]
    NotFinite,
    /// A switching time that is not a time.
    #[error("{what} must be a time in seconds, not {value}")]
    BadTime {
        /// The option (`--off-at`, `--on-at`).
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// Switched on before it was switched off.
    #[error("--on-at ({on}) must come after --off-at ({off})")]
    OnBeforeOff {
        /// When it is switched on, s.
        on: f64,
        /// When it is switched off, s.
        off: f64,
    },
    /// Switched on without being switched off.
    #[error("--on-at needs --off-at")]
    OnWithoutOff,
    /// A goal outside the field.
    #[error("the goal ({}, {}) is off the {} x {} cm field", .goal.x, .goal.y, .size.x, .size.y)]
    GoalOffField {
        /// The goal, cm.
        goal: Vec2,
        /// The field's size, cm.
        size: Vec2,
    },
    /// The physics field refused the map, the box or a robot.
    #[error(transparent)]
    Field(#[from] SimError),
    /// An agent's name is not a token.
    #[error(transparent)]
    Token(#[from] TokenError),
    /// A resource name is not a resource.
    #[error(transparent)]
    Resources(#[from] ResourceError),
    /// A task the user or the watcher introduces is invalid.
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// The user agent gave up on `move-box` (nobody could take it for too long).
    #[error("the user agent gave up on moving the box: {0}")]
    GaveUp(String),
}

/// A run in progress: built from its settings, advanced one control step of
/// the field at a time by [`step`](BoxPush::step), so a caller can watch the
/// box ([`box_pose`](BoxPush::box_pose), [`events`](BoxPush::events)) or stop
/// part-way; [`finish`](BoxPush::finish) gives the outcome.
pub struct BoxPush {
    cfg: BoxPushConfig,
    field: Field,
    bx: FieldBoxId,
    /// The field's control step, s.
    dt: f64,
    pushers: Vec<Pusher>,
    watcher_agent: Agent,
    /// The watcher at work on `move-box`, once it has won it.
    watcher: Option<Watcher>,
    user: UserAgent,
    /// The watcher's announcer while it is not at work.
    spare_announcer: Announcer,
    bus: Bus,
    report: BoxPushReport,
    track: Vec<(f64, Pose)>,
    events: Vec<(f64, String)>,
    /// Who pushed each end (left, right) last, to count role swaps.
    last_on_end: [Option<usize>; 2],
    switched_off: bool,
    switched_on: bool,
    /// Control steps in the time limit.
    steps: u64,
    /// Control steps taken.
    step: u64,
    done: bool,
}

impl BoxPush {
    /// Checks the settings and sets the field up: the box, the two pushers
    /// behind it, the watcher, and the user with `move-box` introduced.
    pub fn new(cfg: &BoxPushConfig) -> Result<BoxPush, BoxPushError> {
        let finite = |v: f64| v.is_finite();
        if !(finite(cfg.goal.x) && finite(cfg.goal.y) && cfg.max_s.is_finite() && cfg.max_s > 0.0) {
            return Err(BoxPushError::NotFinite);
        }
        for (what, t) in [("--off-at", cfg.off_at), ("--on-at", cfg.on_at)] {
            if let Some(t) = t {
                if !(t.is_finite() && t >= 0.0) {
                    return Err(BoxPushError::BadTime { what, value: t });
                }
            }
        }
        if let (Some(off), Some(on)) = (cfg.off_at, cfg.on_at) {
            if on <= off {
                return Err(BoxPushError::OnBeforeOff { on, off });
            }
        }
        if cfg.on_at.is_some() && cfg.off_at.is_none() {
            return Err(BoxPushError::OnWithoutOff);
        }
        let map = TileMap::open(70, 60, 10.0)?;
        let size = map.size_cm();
        if !(cfg.goal.x > 0.0 && cfg.goal.x < size.x && cfg.goal.y > 0.0 && cfg.goal.y < size.y) {
            return Err(BoxPushError::GoalOffField {
                goal: cfg.goal,
                size,
            });
        }
        let field_cfg = FieldConfig::default();
        let dt = field_cfg.control_step;
        let mut field = Field::new(map, field_cfg)?;
        let bx: FieldBoxId = field.add_box(BOX, cfg.box_start)?;
        let f0 = frame(cfg.box_start, cfg.goal);
        let mut pushers = Vec::new();
        for (k, side) in [-1.0, 1.0].into_iter().enumerate() {
            let at = push_point(&f0, side) - f0.n * (PUSHER.radius + 30.0);
            let pose = Pose {
                x: at.x,
                y: at.y,
                theta: f0.n.angle(),
            };
            let robot = field.add_robot(PUSHER, pose)?;
            let name = format!("pusher{}", k + 1);
            pushers.push(Pusher {
                robot,
                agent: Some(pusher_agent(&name, Time::ZERO)?),
                push: None,
                name,
            });
        }
        let watcher_agent = Agent::new(
            Token::new("watcher")?,
            "overhead-camera".parse()?,
            quick_agent(),
            Time::ZERO,
        );
        let mut user = UserAgent::new(Token::new("user")?, quick_auction(), Backoff::default(), 1);
        let goal_task = TaskSpec::new(MOVE_BOX, "overhead-camera".parse()?)
            .param("x", cfg.goal.x)
            .param("y", cfg.goal.y)
            .length(cfg.max_s);
        user.introduce(Time::ZERO, goal_task)?;
        let spare_announcer = Announcer::new(Token::new("watcher")?, quick_auction());
        let report = BoxPushReport {
            pushes_by: vec![0; pushers.len()],
            ..BoxPushReport::default()
        };
        Ok(BoxPush {
            cfg: cfg.clone(),
            field,
            bx,
            dt,
            pushers,
            watcher_agent,
            watcher: None,
            user,
            spare_announcer,
            bus: Bus::new(Duration::from_millis(2)),
            report,
            track: Vec::new(),
            events: Vec::new(),
            last_on_end: [None, None],
            switched_off: false,
            switched_on: false,
            steps: (cfg.max_s / dt).ceil() as u64,
            step: 0,
            done: false,
        })
    }

    /// Simulated time so far, s.
    pub fn now_s(&self) -> f64 {
        self.step as f64 * self.dt
    }

    /// Where the box is now.
    pub fn box_pose(&self) -> Pose {
        self.field.box_pose(self.bx).unwrap_or(self.cfg.box_start)
    }

    /// The counts so far.
    pub fn report(&self) -> &BoxPushReport {
        &self.report
    }

    /// Notable events so far, with their time.
    pub fn events(&self) -> &[(f64, String)] {
        &self.events
    }

    /// Advances the run by one control step of the field: switching the
    /// pusher off or on, the protocol, the watcher's look and announcements,
    /// the pushers' wheels and the physics. [`Progress::Done`] once the box is
    /// at the goal or the time limit is reached; further steps do nothing.
    pub fn step(&mut self) -> Result<Progress, BoxPushError> {
        if self.done || self.step >= self.steps {
            self.done = true;
            return Ok(Progress::Done);
        }
        self.step += 1;
        let step = self.step;
        let now_s = step as f64 * self.dt;
        let now = Time::from_secs_f64(now_s);
        // Switching a pusher off and on.
        if self.cfg.off_at.is_some_and(|t| now_s >= t) && !self.switched_off {
            self.switched_off = true;
            let p = &mut self.pushers[0];
            self.field.set_active(p.robot, false)?;
            p.agent = None;
            p.push = None;
            self.events
                .push((now_s, format!("{} switched off", p.name)));
        }
        if self.cfg.on_at.is_some_and(|t| now_s >= t) && self.switched_off && !self.switched_on {
            let box_pose = self.field.box_pose(self.bx).unwrap_or(self.cfg.box_start);
            let other = self
                .field
                .robot_pose(self.pushers[1].robot)
                .unwrap_or_default();
            if let Some(pose) = comeback_pose(&self.field, box_pose, self.cfg.goal, other) {
                if self.field.respawn(self.pushers[0].robot, pose).is_ok() {
                    self.switched_on = true;
                    let name = self.pushers[0].name.clone();
                    self.pushers[0].agent = Some(pusher_agent(&name, now)?);
                    self.events.push((
                        now_s,
                        format!("{name} switched on again at ({:.0}, {:.0})", pose.x, pose.y),
                    ));
                }
            }
        }
        // Everyone's view of the world, for their metrics.
        for p in &mut self.pushers {
            if let (Some(a), Some(pose)) = (p.agent.as_mut(), self.field.robot_pose(p.robot)) {
                a.set_position(pose.position());
            }
        }
        // The protocol.
        {
            let announcer: &mut Announcer = match self.watcher.as_mut() {
                Some(w) => &mut w.announcer,
                None => &mut self.spare_announcer,
            };
            let mut nodes: Vec<&mut dyn Node> = self
                .pushers
                .iter_mut()
                .filter_map(|p| p.agent.as_mut().map(|a| a as &mut dyn Node))
                .collect();
            nodes.push(&mut self.watcher_agent);
            nodes.push(announcer);
            nodes.push(&mut self.user);
            self.bus.run_until(&mut nodes, now);
        }
        while let Some(e) = self.user.poll_event() {
            if let UserEvent::GaveUp { reason, .. } = e {
                self.done = true;
                return Err(BoxPushError::GaveUp(reason));
            }
        }
        // The watcher: is it at work, and what does it see?
        while let Some(e) = self.watcher_agent.poll_event() {
            match e {
                AgentEvent::Start(_) => {
                    self.watcher = Some(Watcher {
                        announcer: std::mem::replace(
                            &mut self.spare_announcer,
                            Announcer::new(Token::new("watcher")?, quick_auction()),
                        ),
                        open: Vec::new(),
                        next_look: now_s,
                    });
                    self.events.push((now_s, "watcher took move-box".into()));
                }
                AgentEvent::Stop { .. } => self.watcher = None,
                _ => {}
            }
        }
        let box_pose = self.field.box_pose(self.bx).unwrap_or(self.cfg.box_start);
        if step % (1.0 / self.dt).round() as u64 == 0 {
            self.track.push((now_s, box_pose));
        }
        let distance = box_pose.position().distance(self.cfg.goal);
        if let Some(w) = self.watcher.as_mut() {
            while let Some(e) = w.announcer.poll_event() {
                match e {
                    AnnouncerEvent::Completed { task, name, winner } => {
                        w.open.retain(|(t, _)| *t != task);
                        let k = self.pushers.iter().position(|p| p.name == winner.as_str());
                        let end = usize::from(name == PUSH_RIGHT);
                        if let Some(k) = k {
                            self.report.pushes_by[k] += 1;
                            if self.last_on_end[end].is_some_and(|prev| prev != k) {
                                self.report.role_swaps += 1;
                            }
                            self.last_on_end[end] = Some(k);
                        }
                        if end == 1 {
                            self.report.pushes_right += 1;
                        } else {
                            self.report.pushes_left += 1;
                        }
                    }
                    AnnouncerEvent::Unachievable { task, name, reason } => {
                        w.open.retain(|(t, _)| *t != task);
                        self.report.unachievable += 1;
                        self.events.push((now_s, format!("{name}: {reason}")));
                    }
                    AnnouncerEvent::WinnerLost {
                        name,
                        winner,
                        reason,
                        ..
                    } => {
                        self.report.reallocated += 1;
                        self.events.push((
                            now_s,
                            format!("{name}: lost {winner} ({reason}); auctioning again"),
                        ));
                    }
                    AnnouncerEvent::Cancelled { task } => w.open.retain(|(t, _)| *t != task),
                    _ => {}
                }
            }
            if distance <= self.cfg.tolerance_cm {
                for (t, _) in std::mem::take(&mut w.open) {
                    w.announcer.cancel(t, "the box is at the goal");
                }
                self.watcher_agent.finish(now);
                self.report.reached = true;
                self.report.time_s = now_s;
                self.events
                    .push((now_s, format!("the box is at the goal ({distance:.1} cm)")));
                self.done = true;
                return Ok(Progress::Done);
            }
            if w.open.is_empty() && now_s >= w.next_look {
                let f = frame(box_pose, self.cfg.goal);
                let sides: &[f64] = if f.error > self.cfg.align_tolerance {
                    &[1.0]
                } else if f.error < -self.cfg.align_tolerance {
                    &[-1.0]
                } else {
                    &[-1.0, 1.0]
                };
                for &side in sides {
                    let spec = push_task(&f, side, self.cfg.push_s);
                    let name = spec.name.clone();
                    let id = w.announcer.announce(now, spec)?;
                    self.report.announced += 1;
                    w.open.push((id, name));
                }
                // A moment between rounds, for the box to settle.
                w.next_look = now_s + 0.5;
            }
        }
        // The pushers.
        let mut commands = vec![WheelCommand::STOP; self.field.robot_count()];
        for p in &mut self.pushers {
            let Some(agent) = p.agent.as_mut() else {
                continue;
            };
            while let Some(e) = agent.poll_event() {
                match e {
                    AgentEvent::Start(ann) => {
                        let push = Push::new(&ann, box_pose, now_s);
                        p.push = Some((ann.id, ann.spec.name.clone(), push));
                    }
                    AgentEvent::Stop { .. } => p.push = None,
                    _ => {}
                }
            }
            let Some(me) = self.field.robot_pose(p.robot) else {
                continue;
            };
            if let Some((_, _, push)) = p.push.as_mut() {
                match push.step(me, box_pose, now_s) {
                    Some(c) => commands[p.robot.0] = c,
                    None => {
                        agent.finish(now);
                        p.push = None;
                    }
                }
            }
        }
        self.field.step(&commands);
        self.report.time_s = now_s;
        Ok(if self.step >= self.steps {
            self.done = true;
            Progress::Done
        } else {
            Progress::Running
        })
    }

    /// The outcome: the report with the box's final distance and the
    /// packets sent, the track and the events.
    pub fn finish(self) -> BoxPushOutcome {
        let mut report = self.report;
        let box_pose = self.field.box_pose(self.bx).unwrap_or(self.cfg.box_start);
        report.final_distance_cm = box_pose.position().distance(self.cfg.goal);
        report.messages = self.bus.stats().sent;
        BoxPushOutcome {
            report,
            track: self.track,
            events: self.events,
        }
    }
}

/// Runs the experiment to its end.
pub fn run(cfg: &BoxPushConfig) -> Result<BoxPushOutcome, BoxPushError> {
    let mut run = BoxPush::new(cfg)?;
    while run.step()? == Progress::Running {}
    Ok(run.finish())
}

/// Where a pusher switched on again is put back: behind the box, on the side
/// away from the other pusher, at the first free place.
fn comeback_pose(field: &Field, box_pose: Pose, goal: Vec2, other: Pose) -> Option<Pose> {
    let f = frame(box_pose, goal);
    let side = if dot(other.position() - f.centre, f.u) >= 0.0 {
        -1.0
    } else {
        1.0
    };
    let theta = f.n.angle();
    (0..8).find_map(|k| {
        let back = PUSHER.radius + 30.0 + 15.0 * k as f64;
        let at = push_point(&f, side) - f.n * back;
        let pose = Pose {
            x: at.x,
            y: at.y,
            theta,
        };
        let size = field.map().size_cm();
        let inside = at.x > PUSHER.radius
            && at.y > PUSHER.radius
            && at.x < size.x - PUSHER.radius
            && at.y < size.y - PUSHER.radius;
        inside.then_some(pose)
    })
}

impl BoxPushReport {
    /// The summary as pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}

impl BoxPushOutcome {
    /// The box's track as CSV.
    pub fn track_csv(&self) -> String {
        let mut out = String::from("time_s,x,y,theta\n");
        for (t, p) in &self.track {
            out.push_str(&format!("{t:.1},{:.2},{:.2},{:.4}\n", p.x, p.y, p.theta));
        }
        out
    }
}
