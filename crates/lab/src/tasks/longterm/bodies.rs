//! The long-term run's robots as bodies in the physics field: discs the size
//! of a Pioneer in an open room, each driven to its target (a task's place, a
//! charger) by a go-to controller that steers round whatever its sonar sees
//! ahead (another robot, at work or on its way) and backs off a bumper. A
//! robot that has come within its target's reach has arrived; one that has
//! made no headway for [`STUCK_AFTER`] arrives where it is (a crowded charger,
//! a task's place taken by a robot at work there), so no run waits on a jam.

use std::f64::consts::PI;

use colony_proto::{Pose, Speed, Steer, Vec2, WheelCommand};
use colony_sim::field::{Field, FieldConfig, FieldRobotId, FieldSense, RobotSpec, TileMap};
use colony_sim::SimError;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// A Pioneer 2-DX is about 44 cm across.
pub const RADIUS: f64 = 22.0;
/// The room's floor is cut into cells this size (it is open: only its edge is a wall).
const CELL: f64 = 20.0;

/// An open square room `side_cm` across, its floor cut into 20 cm cells (`CELL`).
pub fn open_room(side_cm: f64, config: FieldConfig) -> Result<Field, SimError> {
    let cells = (side_cm / CELL).ceil().max(1.0) as usize;
    Field::new(TileMap::open(cells, cells, CELL)?, config)
}

/// A Pioneer's body, driving at up to `speed` cm/s.
pub fn pioneer(speed: f64) -> RobotSpec {
    RobotSpec {
        radius: RADIUS,
        max_speed: speed,
        max_turn: 1.5,
        amphibious: false,
    }
}
/// An echo closer than this, with the target further, is steered round, cm.
const AVOID: f64 = 60.0;
/// Without this much headway in [`STUCK_AFTER`], a robot stops where it is, cm.
const HEADWAY: f64 = 20.0;
/// See `HEADWAY`, s.
pub const STUCK_AFTER: f64 = 60.0;

/// Where a robot is to go, and how close is close enough.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// The place, cm.
    pub at: Vec2,
    /// Close enough, cm from the robot's centre.
    pub reach: f64,
}

#[derive(Debug, Clone, Copy)]
struct Way {
    target: Target,
    /// The closest it has been, and when it last got closer by [`HEADWAY`].
    best: f64,
    since: f64,
}

/// Every robot's body, in the order they were added.
pub struct Bodies {
    field: Field,
    ways: Vec<Option<Way>>,
    /// Robots that arrived by giving up on a jam.
    stuck: u64,
}

impl Bodies {
    /// An open square room `side_cm` across, with no robot yet.
    pub fn new(side_cm: f64) -> Result<Bodies, SimError> {
        let config = FieldConfig {
            sonar_range: 2.0 * AVOID,
            sonar_half_angle: 30f64.to_radians(),
            ..FieldConfig::default()
        };
        Ok(Bodies {
            field: open_room(side_cm, config)?,
            ways: Vec::new(),
            stuck: 0,
        })
    }

    /// Adds a robot driving at up to `speed` cm/s at the first free place of
    /// a few tried at random; its index.
    pub fn add(&mut self, speed: f64, rng: &mut ChaCha8Rng) -> Result<usize, SimError> {
        let spec = pioneer(speed);
        let size = self.field.map().size_cm();
        let mut last = None;
        for _ in 0..64 {
            let pose = Pose {
                x: rng.random_range(2.0 * RADIUS..size.x - 2.0 * RADIUS),
                y: rng.random_range(2.0 * RADIUS..size.y - 2.0 * RADIUS),
                theta: rng.random_range(-PI..PI),
            };
            match self.field.add_robot(spec, pose) {
                Ok(id) => {
                    self.ways.push(None);
                    return Ok(id.0);
                }
                Err(e) => last = Some(e),
            }
        }
        Err(last.unwrap_or_else(|| SimError::Layout("no free place for a robot".into())))
    }

    /// Where robot `i` is.
    pub fn position(&self, i: usize) -> Vec2 {
        self.field
            .robot_pose(FieldRobotId(i))
            .map_or(Vec2::ZERO, |p| p.position())
    }

    /// Sends robot `i` towards `target` (`None`: it stops and stays).
    pub fn go(&mut self, i: usize, target: Option<Target>, now_s: f64) {
        let Some(way) = self.ways.get_mut(i) else {
            return;
        };
        if way.map(|w| w.target) == target {
            return;
        }
        *way = target.map(|target| Way {
            target,
            best: f64::INFINITY,
            since: now_s,
        });
    }

    /// Robots that stopped short of a target because they were stuck.
    pub fn stuck(&self) -> u64 {
        self.stuck
    }

    /// Drives every robot for `seconds` from `now_s`; the robots that arrived
    /// on the way (each stops there, and its target is cleared).
    pub fn advance(&mut self, now_s: f64, seconds: f64) -> Vec<usize> {
        let dt = self.field.config().control_step;
        let steps = (seconds / dt).round().max(1.0) as usize;
        let mut arrived = Vec::new();
        let mut commands = vec![WheelCommand::STOP; self.ways.len()];
        for k in 0..steps {
            let t = now_s + k as f64 * dt;
            for (i, way) in self.ways.iter_mut().enumerate() {
                commands[i] = WheelCommand::STOP;
                let (Some(w), Some(sense)) = (way.as_mut(), self.field.sense(FieldRobotId(i)))
                else {
                    continue;
                };
                let d = sense.pose.position().distance(w.target.at);
                if d + HEADWAY <= w.best {
                    w.best = d;
                    w.since = t;
                }
                let stuck = t - w.since >= STUCK_AFTER;
                if d <= w.target.reach || stuck {
                    self.stuck += u64::from(stuck && d > w.target.reach);
                    *way = None;
                    arrived.push(i);
                    continue;
                }
                commands[i] = steer(&sense, w.target.at);
            }
            self.field.step(&commands);
        }
        arrived
    }
}

/// A Pioneer's gains on the way to its target.
const DRIVE: Steer = Steer {
    turn_gain: 2.0,
    align: 0.5,
    speed: Speed::Full,
};

/// Towards `target`, round what the sonar sees on the way, off a pressed bumper.
fn steer(sense: &FieldSense, target: Vec2) -> WheelCommand {
    let me = sense.pose;
    let to = target - me.position();
    if sense.bump_front {
        // Back off, turning away from the contact.
        let away = if sense.contact_bearing.unwrap_or(0.0) >= 0.0 {
            -1.0
        } else {
            1.0
        };
        return WheelCommand {
            forward: -0.4,
            turn: away,
        };
    }
    if let Some(echo) = sense.sonar {
        if echo.distance < AVOID && echo.distance + RADIUS < to.length() {
            // Something on the way: keep it on the left (robots meeting head-on
            // both turn right and pass), slower the closer it is.
            let away = if echo.bearing > 0.3 { -1.0 } else { -0.6 };
            return WheelCommand {
                forward: 0.5 * (echo.distance / AVOID).clamp(0.0, 1.0),
                turn: away,
            };
        }
    }
    DRIVE.toward(me, target)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn room() -> (Bodies, ChaCha8Rng) {
        (Bodies::new(600.0).unwrap(), ChaCha8Rng::seed_from_u64(3))
    }

    #[test]
    fn a_robot_drives_to_its_target_and_stops_there() {
        let (mut b, mut rng) = room();
        let r = b.add(30.0, &mut rng).unwrap();
        let target = Target {
            at: Vec2::new(300.0, 300.0),
            reach: 20.0,
        };
        b.go(r, Some(target), 0.0);
        let mut t = 0.0;
        let mut arrived = false;
        while t < 120.0 && !arrived {
            arrived = b.advance(t, 1.0).contains(&r);
            t += 1.0;
        }
        assert!(arrived, "at {:?} after {t} s", b.position(r));
        assert!(b.position(r).distance(target.at) <= 20.0);
        let there = b.position(r);
        b.advance(t, 5.0);
        assert!(b.position(r).distance(there) < 1.0, "it stays");
        assert_eq!(b.stuck(), 0);
    }

    #[test]
    fn robots_crossing_head_on_steer_round_each_other() {
        let (mut b, mut rng) = room();
        let (r0, r1) = (
            b.add(30.0, &mut rng).unwrap(),
            b.add(30.0, &mut rng).unwrap(),
        );
        // Each to where the other is, more or less: they must pass.
        let (p0, p1) = (b.position(r0), b.position(r1));
        b.go(
            r0,
            Some(Target {
                at: p1,
                reach: 30.0,
            }),
            0.0,
        );
        b.go(
            r1,
            Some(Target {
                at: p0,
                reach: 30.0,
            }),
            0.0,
        );
        let mut done = [false, false];
        let mut t = 0.0;
        while t < 200.0 && !(done[0] && done[1]) {
            for i in b.advance(t, 1.0) {
                done[i] = true;
            }
            t += 1.0;
        }
        assert!(done[0] && done[1], "both arrived within {t} s");
        assert!(b.position(r0).distance(p1) < 60.0 && b.position(r1).distance(p0) < 60.0);
    }

    #[test]
    fn a_robot_that_cannot_get_closer_stops_where_it_is() {
        let (mut b, mut rng) = room();
        let r = b.add(30.0, &mut rng).unwrap();
        // Outside the room: the wall is in the way for ever.
        b.go(
            r,
            Some(Target {
                at: Vec2::new(-500.0, 300.0),
                reach: 10.0,
            }),
            0.0,
        );
        let mut t = 0.0;
        let mut arrived = false;
        while t < 300.0 && !arrived {
            arrived = b.advance(t, 1.0).contains(&r);
            t += 1.0;
        }
        assert!(arrived && b.stuck() == 1, "t {t}");
    }
}
