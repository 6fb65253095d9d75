//! The robots' control and senses: where the watcher drives (ahead of the box,
//! towards the goal) and what it can see, where it wants each end pushed, how
//! a pusher scores a push by what it sees, gets behind its end and pushes,
//! and where a pusher switched on again is put back.

use std::f64::consts::PI;

use colony_proto::{wrap_angle, Pose, Speed, Steer, Vec2, WheelCommand};
use colony_sim::field::{BoxSpec, Field, RobotSpec};

use super::{PUSH_LEFT, PUSH_RIGHT};
use colony_tasks::protocol::{Announcement, ResourceSet, TaskSpec};
use colony_tasks::RobotView;

pub(super) const BOX: BoxSpec = BoxSpec {
    half_length: 30.0,
    half_width: 4.0,
    mass: 400.0,
    damping: 6.0,
};

/// Every robot's body, the watcher's too (the paper's were all Pioneers).
pub(super) const PUSHER: RobotSpec = RobotSpec {
    radius: 8.0,
    max_speed: 20.0,
    max_turn: 2.0,
    amphibious: false,
};

/// How far the watcher's laser sees the box, cm: beyond it, it cannot tell
/// how the box lies, and announces nothing until it is close again.
pub(super) const LASER_RANGE: f64 = 250.0;
/// How far a pusher's camera makes out an end of the box, cm: a pusher that
/// cannot see the end it is offered does not bid for it.
pub(super) const CAMERA_RANGE: f64 = 450.0;
/// How far ahead of the box, towards the goal, the watcher drives, cm...
const LEAD: f64 = 110.0;
/// ...and how far to the side of the box's path, so the box never meets it.
const SIDE: f64 = 70.0;
/// What a turn costs a pusher in its `placement` score, cm per radian.
const TURN_COST: f64 = 25.0;

/// The metric a pusher bids with: how well placed it is, by what it sees.
pub(super) const PLACEMENT: &str = "placement";

/// Where the watcher wants to be: ahead of the box towards the goal (never
/// past it) and off to the side of the box's path.
pub(super) fn lead_point(box_pose: Pose, goal: Vec2) -> Vec2 {
    let centre = box_pose.position();
    let g = goal - centre;
    let d = g.length();
    if d < 1e-6 {
        return centre + Vec2::new(0.0, SIDE);
    }
    let ahead = g * (1.0 / d);
    let left = Vec2::new(-ahead.y, ahead.x);
    centre + ahead * d.min(LEAD) + left * SIDE
}

/// The watcher's wheels: to its lead point, then facing the box.
pub(super) fn watcher_wheels(me: Pose, box_pose: Pose, goal: Vec2) -> WheelCommand {
    let target = lead_point(box_pose, goal);
    if me.position().distance(target) > 6.0 {
        return drive_to(me, target);
    }
    let e = wrap_angle((box_pose.position() - me.position()).angle() - me.theta);
    DRIVE.wheels(e, 0.0)
}

/// Whether the watcher, at `me`, sees the box with its laser.
pub(super) fn watcher_sees(me: Pose, box_pose: Pose) -> bool {
    me.position().distance(box_pose.position()) <= LASER_RANGE
}

/// A pusher's score for a push task (a cost, cm): the way to stand behind
/// the end (around the box when it is on the wrong side), plus the turn to
/// face it. `None` when it cannot see that end.
pub(super) fn placement(task: &TaskSpec, robot: &RobotView<'_>) -> Option<f64> {
    let p = Vec2::new(task.number("x")?, task.number("y")?);
    let n = Vec2::new(task.number("nx")?, task.number("ny")?);
    let pos = robot.position?;
    if pos.distance(p) > CAMERA_RANGE {
        return None;
    }
    let stand = p - n * (PUSHER.radius + 10.0);
    let behind = dot(pos - p, n) < 0.0;
    // Going round the end: out past the end and back, about twice the box's length.
    let detour = if behind { 0.0 } else { 4.0 * BOX.half_length };
    let turn = robot
        .heading
        .map_or(PI / 2.0, |h| wrap_angle((stand - pos).angle() - h).abs());
    Some(pos.distance(stand) + detour + TURN_COST * turn)
}

/// What the watcher needs: to drive, range the box and find the goal.
pub(super) fn watcher_resources() -> ResourceSet {
    resources(["camera", "laser", "mobile"])
}

/// Which way the watcher wants the box to go, and which ends are which.
#[derive(Debug, Clone, Copy)]
pub(super) struct Frame {
    pub(super) centre: Vec2,
    /// Along the length, towards the right end.
    pub(super) u: Vec2,
    /// The push direction: perpendicular to the length, towards the goal's side.
    pub(super) n: Vec2,
    /// Signed angle from `n` to the goal; positive means turn left.
    pub(super) error: f64,
}

pub(super) fn frame(pose: Pose, goal: Vec2) -> Frame {
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

pub(super) fn dot(a: Vec2, b: Vec2) -> f64 {
    a.x * b.x + a.y * b.y
}

/// Where on the box's back face to push the end `side` (-1 left, +1 right).
pub(super) fn push_point(f: &Frame, side: f64) -> Vec2 {
    f.centre + f.u * (side * BOX.half_length * 0.7) - f.n * BOX.half_width
}

/// The watcher's pushing task for one end.
pub(super) fn push_task(f: &Frame, side: f64, push_s: f64) -> TaskSpec {
    let p = push_point(f, side);
    let name = if side < 0.0 { PUSH_LEFT } else { PUSH_RIGHT };
    TaskSpec::new(name, pusher_resources())
        .length(push_s)
        .param("x", p.x)
        .param("y", p.y)
        .param("nx", f.n.x)
        .param("ny", f.n.y)
        .metric(PLACEMENT, 1.0)
}

pub(super) fn pusher_resources() -> ResourceSet {
    resources(["bumpers", "camera", "mobile"])
}

fn resources<const N: usize>(names: [&str; N]) -> ResourceSet {
    let mut r = ResourceSet::new();
    for name in names {
        // Every name here is a valid resource; a failure would be a typo in this file.
        let _ = r.insert(name);
    }
    r
}

/// A pusher executing one task: get behind the end, face the push direction, push.
#[derive(Debug, Clone)]
pub(super) struct Push {
    /// -1 left end, +1 right end, in the box's own frame (fixed at the start).
    end: f64,
    /// The push direction at the start, to pick the same face as the box turns.
    n0: Vec2,
    pushing_since: Option<f64>,
    started: f64,
    push_s: f64,
}

impl Push {
    pub(super) fn new(ann: &Announcement, box_pose: Pose, now: f64) -> Push {
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
    pub(super) fn step(&mut self, me: Pose, box_pose: Pose, now: f64) -> Option<WheelCommand> {
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
                    return Some(DRIVE.wheels(e, 0.0));
                }
            } else {
                return Some(drive_to(me, target));
            }
        }
        // Push: head for a point beyond the face, so the robot stays on its end.
        Some(drive_to(me, face + n * 40.0))
    }
}

/// The watcher's and the pushers' gains.
const DRIVE: Steer = Steer {
    turn_gain: 2.0,
    align: 0.6,
    speed: Speed::Ramp {
        over_cm: 15.0,
        base: 0.0,
        min: 0.15,
    },
};

/// A go-to-point controller that backs up to close targets behind it.
fn drive_to(me: Pose, target: Vec2) -> WheelCommand {
    let d = target - me.position();
    let dist = d.length();
    let e = wrap_angle(d.angle() - me.theta);
    let speed = DRIVE.speed.at(dist);
    if dist < 30.0 && e.abs() > PI / 2.0 {
        let back = wrap_angle(e - PI);
        return WheelCommand {
            forward: -speed * back.cos().max(0.0),
            turn: DRIVE.wheels(back, 0.0).turn,
        };
    }
    DRIVE.wheels(e, speed)
}

/// Where a pusher switched on again is put back: behind the box, on the side
/// away from the other pusher, at the first free place.
pub(super) fn comeback_pose(
    field: &Field,
    box_pose: Pose,
    goal: Vec2,
    other: Pose,
) -> Option<Pose> {
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
