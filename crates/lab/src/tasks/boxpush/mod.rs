//! The tightly coupled experiment of section 6.1: a watcher and two pushers
//! move a long box to a goal in the physics field.
//!
//! The watcher is a robot with a laser and a camera, as in the paper. A user
//! agent introduces one high-level task, `move-box` (needs `camera laser
//! mobile`); the watcher wins it, and executing it means driving ahead of the
//! box towards the goal (which it finds with its camera, wherever the goal is
//! now: it may be moved during the run), ranging the box with its laser, and
//! announcing pushing tasks through an [`Announcer`] of its own: while the box
//! faces the goal, `push-left-end` and `push-right-end` together; when it is
//! turned away, only the end that turns it back. It announces nothing while
//! the box is out of its laser's range. The pushers (`bumpers camera mobile`)
//! are not handed: both run the same program and bid by what they see
//! (`placement`: the way to stand behind that end, round the box if needed,
//! and the turn to face it; no bid for an end out of camera range). A pusher
//! switched off mid-run stops renewing; its task is auctioned again, and the
//! other pusher, alone, see-saws the box to the goal, switching ends as the
//! watcher asks. Switched on again (on the other side), it is brought straight
//! back into the team.

mod control;
mod live;
mod report;
mod settings;

use std::time::Duration;

use colony_proto::{Pose, Vec2, WheelCommand};
use colony_sim::field::{Field, FieldBoxId, FieldConfig, FieldRobotId, TileMap};
use colony_sim::SimError;

pub use live::{run_live, LiveBoxPushError};
pub use report::{BoxPushOutcome, BoxPushReport};
pub use settings::{BoxPushConfig, MOVE_BOX, PUSH_LEFT, PUSH_RIGHT};

use super::Progress;
use colony_node::Bus;
use colony_node::Node;
use colony_node::Time;
use colony_tasks::protocol::{ResourceError, SpecError, TaskSpec, Token, TokenError};
use colony_tasks::Metrics;
use colony_tasks::{Agent, AgentConfig, AgentEvent};
use colony_tasks::{Announcer, AnnouncerEvent, AuctionConfig};
use colony_tasks::{Backoff, UserAgent, UserEvent};
use control::{
    comeback_pose, frame, lead_point, placement, push_point, push_task, pusher_resources,
    watcher_resources, watcher_sees, watcher_wheels, Push, BOX, PLACEMENT, PUSHER,
};

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
    let mut metrics = Metrics::standard();
    metrics.insert(PLACEMENT, placement);
    Ok(Agent::new(Token::new(name)?, pusher_resources(), quick_agent(), now).with_metrics(metrics))
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
    /// The goal moved to a time that is not a time.
    #[error("the goal's move must be at a time in seconds, not {0}")]
    BadMoveTime(f64),
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
    /// The watcher's body.
    watcher_robot: FieldRobotId,
    /// Where the goal is now (it may move during the run).
    goal: Vec2,
    goal_moved: bool,
    /// Whether the watcher saw the box at its last look.
    saw_box: bool,
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
        let goals = std::iter::once(cfg.goal).chain(cfg.move_goal.map(|(_, g)| g));
        for goal in goals {
            if !(goal.x.is_finite() && goal.y.is_finite()) {
                return Err(BoxPushError::NotFinite);
            }
            if !(goal.x > 0.0 && goal.x < size.x && goal.y > 0.0 && goal.y < size.y) {
                return Err(BoxPushError::GoalOffField { goal, size });
            }
        }
        if let Some((t, _)) = cfg.move_goal {
            if !(t.is_finite() && t >= 0.0) {
                return Err(BoxPushError::BadMoveTime(t));
            }
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
        let lead = lead_point(cfg.box_start, cfg.goal);
        let watcher_robot = field.add_robot(
            PUSHER,
            Pose {
                x: lead.x,
                y: lead.y,
                theta: (cfg.box_start.position() - lead).angle(),
            },
        )?;
        let watcher_agent = Agent::new(
            Token::new("watcher")?,
            watcher_resources(),
            quick_agent(),
            Time::ZERO,
        );
        let mut user = UserAgent::new(Token::new("user")?, quick_auction(), Backoff::default(), 1);
        let goal_task = TaskSpec::new(MOVE_BOX, watcher_resources())
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
            watcher_robot,
            goal: cfg.goal,
            goal_moved: false,
            saw_box: true,
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

    /// Where the goal is now.
    pub fn goal(&self) -> Vec2 {
        self.goal
    }

    /// Every robot's pose (the two pushers, then the watcher); a robot
    /// switched off is left out.
    pub fn robot_poses(&self) -> Vec<Pose> {
        self.pushers
            .iter()
            .map(|p| p.robot)
            .chain([self.watcher_robot])
            .filter_map(|r| self.field.robot_pose(r))
            .collect()
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
        self.switch_pusher(now, now_s)?;
        self.move_goal(now_s);
        self.run_protocol(now)?;
        self.follow_watcher(now_s)?;
        let box_pose = self.field.box_pose(self.bx).unwrap_or(self.cfg.box_start);
        if step % (1.0 / self.dt).round() as u64 == 0 {
            self.track.push((now_s, box_pose));
        }
        if self.watch(now, now_s, box_pose)? {
            self.done = true;
            return Ok(Progress::Done);
        }
        let mut commands = self.drive_pushers(now, now_s, box_pose);
        if self.watcher.is_some() {
            if let Some(me) = self.field.robot_pose(self.watcher_robot) {
                commands[self.watcher_robot.0] = watcher_wheels(me, box_pose, self.goal);
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

    /// Moves the goal when the settings say: the watcher's camera finds it there from then on.
    fn move_goal(&mut self, now_s: f64) {
        if let Some((at, to)) = self.cfg.move_goal {
            if now_s >= at && !self.goal_moved {
                self.goal_moved = true;
                self.goal = to;
                self.events.push((
                    now_s,
                    format!("the goal moved to ({:.0}, {:.0})", to.x, to.y),
                ));
            }
        }
    }

    /// Switches the first pusher off, and on again behind the box, when the settings say.
    fn switch_pusher(&mut self, now: Time, now_s: f64) -> Result<(), BoxPushError> {
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
            if let Some(pose) = comeback_pose(&self.field, box_pose, self.goal, other) {
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
        Ok(())
    }

    /// Everyone's view of the world for their metrics, then the protocol up to `now`; fails if the user agent gave up.
    fn run_protocol(&mut self, now: Time) -> Result<(), BoxPushError> {
        // Everyone's view of the world, for their metrics.
        for p in &mut self.pushers {
            if let (Some(a), Some(pose)) = (p.agent.as_mut(), self.field.robot_pose(p.robot)) {
                a.set_position(pose.position());
                a.set_heading(pose.theta);
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
        Ok(())
    }

    /// The watcher: is it at work on `move-box`?
    fn follow_watcher(&mut self, now_s: f64) -> Result<(), BoxPushError> {
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
        Ok(())
    }

    /// The watcher at work: counts what its auctions did, and looks at the box: at the goal (true), or time to announce the next pushes.
    fn watch(&mut self, now: Time, now_s: f64, box_pose: Pose) -> Result<bool, BoxPushError> {
        let distance = box_pose.position().distance(self.goal);
        let sees = self
            .field
            .robot_pose(self.watcher_robot)
            .is_some_and(|me| watcher_sees(me, box_pose));
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
                return Ok(true);
            }
            if sees != self.saw_box {
                self.saw_box = sees;
                let what = if sees {
                    "sees the box again"
                } else {
                    "lost sight of the box"
                };
                self.events.push((now_s, format!("the watcher {what}")));
            }
            if w.open.is_empty() && now_s >= w.next_look && sees {
                let f = frame(box_pose, self.goal);
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
        Ok(false)
    }

    /// The pushers: start and stop their pushes as their agents say, and each one's wheels for this step.
    fn drive_pushers(&mut self, now: Time, now_s: f64, box_pose: Pose) -> Vec<WheelCommand> {
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
        commands
    }

    /// The outcome: the report with the box's final distance and the
    /// packets sent, the track and the events.
    pub fn finish(self) -> BoxPushOutcome {
        let mut report = self.report;
        let box_pose = self.field.box_pose(self.bx).unwrap_or(self.cfg.box_start);
        report.final_distance_cm = box_pose.position().distance(self.goal);
        // The robots' reports are for watchers, not part of the protocol's cost.
        let stats = self.bus.stats();
        report.messages = stats.sent - stats.by_label.get("robot").copied().unwrap_or(0);
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
