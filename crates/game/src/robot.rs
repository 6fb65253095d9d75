//! Robot intelligence (the paper's section 4.4): what runs on each robot.
//!
//! A subsumption stack, highest priority first:
//!
//! | priority | behaviour | wants control when |
//! |---|---|---|
//! | 40 | `avoid-bump` | a touch sensor is pressed (turn 90° away from the contact, move off) |
//! | 30 | `respect-border` | the infrared sensor sees water or the edge ahead (turn 90° away) |
//! | 20 | `avoid-sonar` | the sonar sees something closer than `d_crit` (turn 90°, move `d_crit·tan α`) |
//! | 10 | `command` | a command from the swarm intelligence is held |
//! | 0 | `idle` | always (stand still) |
//!
//! Reflexes are manoeuvres: once triggered they keep control until the turn
//! and the short move are done, then hand control back to the command, which
//! carries on from where it was. At most one (sequence) command is held; a
//! newer order replaces it, an older one (UDP may reorder) is dropped.

use std::collections::VecDeque;
use std::f64::consts::{FRAC_PI_2, PI};

use colony_behave::{Arbitrator, Behaviour, Reason};
use colony_proto::wrap_angle;
use colony_sim::{Pose, Vec2};

use crate::protocol::{Action, Command, Order, RobotDebug, Sense};
use crate::rules::{KindRules, KindStats, RobotKind};

/// The sonar's critical distance, cm from the robot's edge (Table 1's d_crit).
pub const D_CRIT: f64 = 5.0;
/// The sonar's half viewing angle, rad (Table 1's α); matches the simulator's default.
pub const SONAR_HALF_ANGLE: f64 = 15.0 * PI / 180.0;
/// A GoTo is done this close to its point, cm.
pub const ARRIVED: f64 = 6.0;
/// A GoTo with another GoTo after it is a point to pass on the way: done this close, cm. A
/// waypoint another robot happens to stand on must not hold a robot forever, its sonar
/// turning it away each time it comes within `ARRIVED`.
pub const PASSED: f64 = 14.0;
/// A manoeuvre that hasn't finished in this long is given up (s): a robot
/// wedged against something must not hold its reflex forever.
const MANOEUVRE_TIMEOUT: f64 = 3.0;
/// Heading error below which a turn is done, rad.
const ALIGNED: f64 = 0.08;
/// Heading error above which a GoTo turns on the spot before driving, rad.
const TURN_FIRST: f64 = 0.6;

/// What the behaviours read and write each tick.
#[derive(Debug, Clone)]
pub struct Ctx {
    /// The robot's type.
    pub stats: KindStats,
    /// Its id.
    pub id: u32,
    /// The newest sensor reading.
    pub sense: Sense,
    /// The commands left of the order held.
    pub commands: VecDeque<Command>,
    /// The heading a Rotate aims for, once started.
    rotate_to: Option<f64>,
    /// Wheels for this tick: forward and turn fractions.
    pub wheels: (f64, f64),
    /// Requests for the game logic.
    pub actions: Vec<Action>,
    /// When it last fired, s.
    last_fire: f64,
    /// When a Drive being carried out ends, s.
    drive_until: Option<f64>,
}

impl Ctx {
    fn turn_toward(&mut self, heading: f64) -> f64 {
        let err = wrap_angle(heading - self.sense.pose.theta);
        // Proportional, saturating: full rate until about 30° off.
        let turn = (err * 2.0).clamp(-1.0, 1.0);
        self.wheels = (0.0, turn);
        err
    }

    /// Where the current command wants to go, if anywhere (a reflex turns toward its side).
    fn goal(&self) -> Option<Vec2> {
        match self.commands.front()? {
            Command::GoTo { to, .. } => Some(*to),
            Command::Shoot { at, .. } => Some(*at),
            _ => None,
        }
    }
}

/// A reflex's manoeuvre: turn to a heading, then drive a short distance.
#[derive(Debug, Clone, Copy)]
struct Manoeuvre {
    heading: f64,
    forward_cm: f64,
    from: Option<Vec2>,
    started: f64,
}

impl Manoeuvre {
    fn new(ctx: &Ctx, turn: f64, forward_cm: f64) -> Manoeuvre {
        Manoeuvre {
            heading: wrap_angle(ctx.sense.pose.theta + turn),
            forward_cm,
            from: None,
            started: ctx.sense.time,
        }
    }

    /// Drives one tick; false when done.
    fn drive(&mut self, ctx: &mut Ctx) -> bool {
        if ctx.sense.time - self.started > MANOEUVRE_TIMEOUT {
            return false;
        }
        match self.from {
            None => {
                if ctx.turn_toward(self.heading).abs() < ALIGNED {
                    self.from = Some(ctx.sense.pose.position());
                    ctx.wheels = (0.0, 0.0);
                }
                true
            }
            Some(from) => {
                if ctx.sense.pose.position().distance(from) >= self.forward_cm {
                    return false;
                }
                ctx.wheels = (0.6, 0.0);
                true
            }
        }
    }
}

/// Which way a reflex turns: away from the side of the stimulus, or toward
/// the goal when the stimulus has no side.
fn away(bearing: Option<f64>, ctx: &Ctx) -> f64 {
    let side = match bearing {
        Some(b) if b.abs() > 1e-3 => -b.signum(),
        _ => match ctx.goal() {
            Some(g) => {
                let local = ctx.sense.pose.to_local(g);
                if local.y >= 0.0 {
                    1.0
                } else {
                    -1.0
                }
            }
            None => 1.0,
        },
    };
    side * FRAC_PI_2
}

/// A reflex: a trigger and the manoeuvre it starts.
struct Reflex {
    name: &'static str,
    trigger: fn(&Ctx) -> Option<(Reason, f64, f64)>,
    doing: Option<(Manoeuvre, Reason)>,
}

impl Behaviour<Ctx> for Reflex {
    fn name(&self) -> &str {
        self.name
    }

    fn wants_control(&mut self, ctx: &Ctx) -> Option<Reason> {
        if let Some((_, why)) = &self.doing {
            return Some(why.clone());
        }
        let (why, turn, forward) = (self.trigger)(ctx)?;
        self.doing = Some((Manoeuvre::new(ctx, turn, forward), why.clone()));
        Some(why)
    }

    fn act(&mut self, ctx: &mut Ctx) {
        if let Some((m, _)) = &mut self.doing {
            if !m.drive(ctx) {
                self.doing = None;
                ctx.wheels = (0.0, 0.0);
            }
        }
    }

    fn suppressed(&mut self, _ctx: &mut Ctx) {
        // A higher reflex took over: its manoeuvre replaces this one.
        self.doing = None;
    }
}

fn bump_trigger(ctx: &Ctx) -> Option<(Reason, f64, f64)> {
    let s = &ctx.sense;
    if !(s.bump_front || s.bump_rear) {
        return None;
    }
    let which = if s.bump_front { "front" } else { "rear" };
    Some((
        format!("{which} touch sensor pressed").into(),
        away(s.contact, ctx),
        ctx.stats.radius_cm,
    ))
}

fn border_trigger(ctx: &Ctx) -> Option<(Reason, f64, f64)> {
    ctx.sense.border.then(|| {
        (
            "border line ahead".into(),
            away(None, ctx),
            ctx.stats.radius_cm * 0.5,
        )
    })
}

fn sonar_trigger(ctx: &Ctx) -> Option<(Reason, f64, f64)> {
    let (d, bearing) = ctx.sense.sonar?;
    (d < D_CRIT).then(|| {
        (
            format!("sonar: obstacle at {d:.0} cm").into(),
            away(Some(bearing), ctx),
            D_CRIT * SONAR_HALF_ANGLE.tan(),
        )
    })
}

/// Carries out the command held, one tick at a time.
struct CommandBehaviour;

impl Behaviour<Ctx> for CommandBehaviour {
    fn name(&self) -> &str {
        "command"
    }

    fn wants_control(&mut self, ctx: &Ctx) -> Option<Reason> {
        let c = ctx.commands.front()?;
        Some(match ctx.commands.len() {
            1 => c.to_string().into(),
            n => format!("{c} (+{} more)", n - 1).into(),
        })
    }

    fn act(&mut self, ctx: &mut Ctx) {
        let Some(cmd) = ctx.commands.front().cloned() else {
            return;
        };
        let done = match cmd {
            Command::Beep => {
                ctx.actions.push(Action::Beep { robot: ctx.id });
                true
            }
            Command::Stop => {
                ctx.wheels = (0.0, 0.0);
                true
            }
            Command::PickUp { flag } => {
                ctx.wheels = (0.0, 0.0);
                ctx.actions.push(Action::PickUp {
                    robot: ctx.id,
                    flag,
                });
                true
            }
            Command::Rotate { deg } => {
                let target = *ctx
                    .rotate_to
                    .get_or_insert(wrap_angle(ctx.sense.pose.theta + deg.to_radians()));
                let finished = ctx.turn_toward(target).abs() < ALIGNED;
                if finished {
                    ctx.rotate_to = None;
                }
                finished
            }
            Command::GoTo { to, speed } => {
                let on_the_way = matches!(ctx.commands.get(1), Some(Command::GoTo { .. }));
                go_to(ctx, to, speed, if on_the_way { PASSED } else { ARRIVED })
            }
            Command::Drive {
                forward,
                turn,
                secs,
            } => {
                let now = ctx.sense.time;
                let until = *ctx.drive_until.get_or_insert(now + secs);
                let finished = now >= until;
                ctx.wheels = if finished {
                    (0.0, 0.0)
                } else {
                    (forward, turn)
                };
                if finished {
                    ctx.drive_until = None;
                }
                finished
            }
            Command::Shoot { target, at } => {
                let err = ctx.turn_toward((at - ctx.sense.pose.position()).angle());
                if err.abs() < 0.3 && ctx.sense.time - ctx.last_fire >= ctx.stats.reload_s {
                    ctx.last_fire = ctx.sense.time;
                    ctx.actions.push(Action::Fire {
                        robot: ctx.id,
                        target,
                    });
                }
                // Shooting goes on until the next order replaces it.
                false
            }
        };
        if done {
            ctx.commands.pop_front();
        }
    }

    fn suppressed(&mut self, ctx: &mut Ctx) {
        // A reflex turned the robot: a Rotate measures from where it ends up.
        ctx.rotate_to = None;
    }
}

/// One tick of GoTo: turn on the spot when far off the bearing, else drive
/// and steer; true once within `done` cm.
fn go_to(ctx: &mut Ctx, to: Vec2, speed: Option<f64>, done: f64) -> bool {
    let pos = ctx.sense.pose.position();
    let d = pos.distance(to);
    if d < done {
        ctx.wheels = (0.0, 0.0);
        return true;
    }
    let err = wrap_angle((to - pos).angle() - ctx.sense.pose.theta);
    if err.abs() > TURN_FIRST {
        ctx.turn_toward((to - pos).angle());
        return false;
    }
    let cap = speed.map_or(1.0, |s| (s / ctx.stats.speed_cm_s).min(1.0));
    // Slow down over the last 20 cm so it doesn't overshoot the point.
    let forward = cap * (d / 20.0).clamp(0.3, 1.0);
    ctx.wheels = (forward, (err * 2.0).clamp(-1.0, 1.0));
    false
}

/// Stands still.
struct Idle;

impl Behaviour<Ctx> for Idle {
    fn name(&self) -> &str {
        "idle"
    }
    fn wants_control(&mut self, _ctx: &Ctx) -> Option<Reason> {
        Some("no command".into())
    }
    fn act(&mut self, ctx: &mut Ctx) {
        ctx.wheels = (0.0, 0.0);
    }
}

/// What one tick of a robot produces.
#[derive(Debug, Clone, PartialEq)]
pub struct Tick {
    /// Forward and turn fractions for the wheels.
    pub wheels: (f64, f64),
    /// Requests for the game logic.
    pub actions: Vec<Action>,
    /// The active behaviour, when it changed (or every so often, for a monitor that joined late).
    pub debug: Option<RobotDebug>,
}

/// One robot's intelligence.
pub struct Brain {
    arbitrator: Arbitrator<Ctx>,
    ctx: Ctx,
    seq: Option<u64>,
    ticks: u64,
}

/// The active behaviour is repeated at least this often (ticks).
const DEBUG_EVERY: u64 = 10;

impl Brain {
    /// The brain of robot `id` of type `kind`.
    pub fn new(id: u32, kind: RobotKind) -> Brain {
        let mut arbitrator = Arbitrator::new();
        arbitrator.add(
            40,
            Reflex {
                name: "avoid-bump",
                trigger: bump_trigger,
                doing: None,
            },
        );
        arbitrator.add(
            30,
            Reflex {
                name: "respect-border",
                trigger: border_trigger,
                doing: None,
            },
        );
        arbitrator.add(
            20,
            Reflex {
                name: "avoid-sonar",
                trigger: sonar_trigger,
                doing: None,
            },
        );
        arbitrator.add(10, CommandBehaviour);
        arbitrator.add(0, Idle);
        Brain {
            arbitrator,
            ctx: Ctx {
                stats: kind.stats(),
                id,
                sense: Sense::default(),
                commands: VecDeque::new(),
                rotate_to: None,
                wheels: (0.0, 0.0),
                actions: Vec::new(),
                last_fire: f64::NEG_INFINITY,
                drive_until: None,
            },
            seq: None,
            ticks: 0,
        }
    }

    /// Takes an order; false (and nothing changes) when it is for another
    /// robot or not newer than the one held.
    pub fn order(&mut self, order: Order) -> bool {
        if order.robot != self.ctx.id || self.seq.is_some_and(|s| order.seq <= s) {
            return false;
        }
        self.seq = Some(order.seq);
        self.ctx.commands = order.commands.into();
        self.ctx.rotate_to = None;
        self.ctx.drive_until = None;
        true
    }

    /// The commands left.
    pub fn commands(&self) -> impl Iterator<Item = &Command> {
        self.ctx.commands.iter()
    }

    /// The robot's pose as last sensed.
    pub fn pose(&self) -> Pose {
        self.ctx.sense.pose
    }

    /// One tick on a fresh sensor reading.
    pub fn tick(&mut self, sense: Sense) -> Tick {
        self.ctx.sense = sense;
        self.ctx.wheels = (0.0, 0.0);
        self.ctx.actions.clear();
        self.ticks += 1;
        let decision = self.arbitrator.step(&mut self.ctx);
        let debug = decision
            .filter(|d| d.changed || self.ticks % DEBUG_EVERY == 0)
            .map(|d| RobotDebug {
                robot: self.ctx.id,
                behaviour: d.name.clone(),
                reason: d.reason.to_string(),
            });
        Tick {
            wheels: self.ctx.wheels,
            actions: std::mem::take(&mut self.ctx.actions),
            debug,
        }
    }

    /// The behaviour in control after the last tick.
    pub fn active(&self) -> Option<&str> {
        self.arbitrator.active().map(|d| d.name.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sense(t: f64, pose: Pose) -> Sense {
        Sense {
            time: t,
            pose,
            ..Sense::default()
        }
    }

    /// Integrates the wheels like the simulator would, ideally.
    fn drive(pose: &mut Pose, wheels: (f64, f64), stats: &KindStats, dt: f64) {
        pose.theta = wrap_angle(pose.theta + wheels.1 * stats.turn_rad_s * dt);
        pose.x += wheels.0 * stats.speed_cm_s * dt * pose.theta.cos();
        pose.y += wheels.0 * stats.speed_cm_s * dt * pose.theta.sin();
    }

    #[test]
    fn a_goto_sequence_is_driven_point_by_point() {
        let mut b = Brain::new(1, RobotKind::Infantry);
        let stats = RobotKind::Infantry.stats();
        assert!(b.order(Order {
            robot: 1,
            seq: 1,
            commands: vec![
                Command::GoTo {
                    to: Vec2::new(100.0, 0.0),
                    speed: None
                },
                Command::GoTo {
                    to: Vec2::new(100.0, 100.0),
                    speed: None
                },
            ],
        }));
        let mut pose = Pose::default();
        for i in 0..400 {
            let t = b.tick(sense(i as f64 * 0.1, pose));
            drive(&mut pose, t.wheels, &stats, 0.1);
        }
        assert!(pose.position().distance(Vec2::new(100.0, 100.0)) < ARRIVED + 1.0);
        assert_eq!(b.commands().count(), 0);
        assert_eq!(b.active(), Some("idle"));
    }

    #[test]
    fn a_drive_holds_the_wheels_for_its_time_and_then_the_robot_stands() {
        let mut b = Brain::new(1, RobotKind::Infantry);
        b.order(Order {
            robot: 1,
            seq: 1,
            commands: vec![Command::Drive {
                forward: 0.8,
                turn: -0.5,
                secs: 0.5,
            }],
        });
        let pose = Pose::default();
        assert_eq!(b.tick(sense(10.0, pose)).wheels, (0.8, -0.5));
        assert_eq!(b.tick(sense(10.4, pose)).wheels, (0.8, -0.5));
        assert_eq!(b.tick(sense(10.5, pose)).wheels, (0.0, 0.0));
        assert_eq!(b.active(), Some("command"));
        assert_eq!(b.tick(sense(10.6, pose)).wheels, (0.0, 0.0));
        assert_eq!(b.active(), Some("idle"));
        // A repeat starts its own half second from when it arrives.
        b.order(Order {
            robot: 1,
            seq: 2,
            commands: vec![Command::Drive {
                forward: -1.0,
                turn: 0.0,
                secs: 0.5,
            }],
        });
        assert_eq!(b.tick(sense(20.0, pose)).wheels, (-1.0, 0.0));
        assert_eq!(b.tick(sense(20.45, pose)).wheels, (-1.0, 0.0));
    }

    #[test]
    fn a_reflex_preempts_a_command_and_hands_control_back() {
        let mut b = Brain::new(2, RobotKind::Scout);
        let stats = RobotKind::Scout.stats();
        b.order(Order {
            robot: 2,
            seq: 5,
            commands: vec![Command::GoTo {
                to: Vec2::new(300.0, 0.0),
                speed: None,
            }],
        });
        let mut pose = Pose::default();
        let t = b.tick(sense(0.0, pose));
        assert_eq!(b.active(), Some("command"));
        assert_eq!(t.debug.unwrap().behaviour, "command");
        drive(&mut pose, t.wheels, &stats, 0.1);
        // Something touches the front-left: the bump reflex takes over.
        let mut s = sense(0.1, pose);
        s.bump_front = true;
        s.contact = Some(0.3);
        let t = b.tick(s);
        let d = t.debug.unwrap();
        assert_eq!(
            (d.behaviour.as_str(), d.reason.as_str()),
            ("avoid-bump", "front touch sensor pressed")
        );
        assert!(
            t.wheels.1 < 0.0,
            "turns right, away from a contact on the left"
        );
        let mut saw_command_again = false;
        for i in 2..200 {
            let t = b.tick(sense(i as f64 * 0.1, pose));
            drive(&mut pose, t.wheels, &stats, 0.1);
            if b.active() == Some("command") {
                saw_command_again = true;
                break;
            }
            assert_eq!(b.active(), Some("avoid-bump"));
        }
        assert!(saw_command_again, "control went back to the command");
        assert_eq!(b.commands().count(), 1, "the command was kept, not dropped");
    }

    #[test]
    fn only_the_newest_order_counts() {
        let mut b = Brain::new(3, RobotKind::Tank);
        let order = |seq| Order {
            robot: 3,
            seq,
            commands: vec![Command::Beep],
        };
        assert!(b.order(order(4)));
        assert!(!b.order(order(4)), "a repeat is stale");
        assert!(!b.order(order(2)), "an older one is stale");
        assert!(!b.order(Order {
            robot: 9,
            ..order(10)
        }));
        let t = b.tick(sense(0.0, Pose::default()));
        assert_eq!(t.actions, vec![Action::Beep { robot: 3 }]);
    }

    #[test]
    fn shooting_respects_the_rate_of_fire() {
        let mut b = Brain::new(4, RobotKind::Tank);
        b.order(Order {
            robot: 4,
            seq: 1,
            commands: vec![Command::Shoot {
                target: 8,
                at: Vec2::new(50.0, 0.0),
            }],
        });
        let mut shots = 0;
        for i in 0..50 {
            shots += b.tick(sense(i as f64 * 0.1, Pose::default())).actions.len();
        }
        // 5 s at one shot per 1.2 s: the first at t=0, then 1.2, 2.4, 3.6, 4.8.
        assert_eq!(shots, 5);
    }
}
