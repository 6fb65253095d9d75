//! One robot's observation as arrays: the local map as a C×G×G grid, the
//! gripper as a one-hot vector and the pose for methods that remember places.
//!
//! The grid covers the camera's ground footprint (its bounding rectangle in
//! the robot frame) and is laid out like a picture seen from above with the
//! robot looking up the page: row 0 is the far edge, the last row the near
//! edge; column 0 is the left edge (+y), the last column the right edge.
//! Channels:
//!
//! - `0..K` (one per puck kind): how many pucks of that kind have their centre
//!   in the cell. Pucks in another robot's gripper are left out, as the
//!   paper's local map drops them (they read as part of that robot); the
//!   carried puck is never in the grid, since the gripper vector reports it.
//! - `K`: how many other robots have their centre in the cell.
//! - `K + 1`: 1 where a wall or another robot's body has a point in the cell,
//!   else 0. The simulator reports such points about a centimetre apart, so a
//!   count would measure the point spacing rather than the world.
//!
//! Everything is finite: a non-finite position from the world is skipped (a
//! map point) or read as 0 (a pose value), never passed on.

use colony_sim::{Observation, Vec2, World};

/// The sizes of every agent's observation, agent-major in each buffer.
///
/// `map` is C×G×G per agent, channel-major, over the bounding rectangle of
/// the camera footprint in the robot frame (x from `near_cm` to `far_cm`
/// ahead of the robot's centre, y within ±`half_width_cm`). Row 0 is the far
/// edge, column 0 the left edge (+y): a picture from above with the robot
/// looking up. Channels `0..K` count the pucks of each kind whose centre is
/// in a cell (pucks in another robot's gripper are left out, as the paper's
/// local map drops them; the carried puck is never in the grid: `gripper`
/// reports it), channel `K` counts other robots' centres, channel `K + 1` is 1
/// where a wall or another robot's body has a point. `gripper` is one-hot:
/// index 0 empty, `1 + k` carrying kind `k`. `pose` is x / half the arena
/// width, y / half its height (the arena is centred on the origin), cos θ,
/// sin θ. Every value is finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObsLayout {
    /// Agents (robots).
    pub agents: usize,
    /// Puck kinds, K.
    pub kinds: usize,
    /// Map channels, C = K + 2 (one per kind, robots, obstacles).
    pub channels: usize,
    /// Map cells per side, G.
    pub grid: usize,
    /// Gripper vector length, K + 1 (index 0 empty, 1 + k carrying kind k).
    pub gripper: usize,
    /// Pose vector length: 4 (x / half-width, y / half-height, cos θ, sin θ).
    pub pose: usize,
    /// The grid's near edge, robot frame x, cm.
    pub near_cm: f64,
    /// The grid's far edge, robot frame x, cm.
    pub far_cm: f64,
    /// The grid spans y from −`half_width_cm` (right) to +`half_width_cm` (left).
    pub half_width_cm: f64,
}

impl ObsLayout {
    /// One agent's map values, C·G·G.
    pub fn map_len(&self) -> usize {
        self.channels * self.grid * self.grid
    }

    /// Every agent's map values.
    pub fn map_total(&self) -> usize {
        self.agents * self.map_len()
    }

    /// Every agent's gripper values.
    pub fn gripper_total(&self) -> usize {
        self.agents * self.gripper
    }

    /// Every agent's pose values.
    pub fn pose_total(&self) -> usize {
        self.agents * self.pose
    }
}

/// Pose values per agent.
pub(crate) const POSE_LEN: usize = 4;

/// Turns one robot's [`Observation`] into its three arrays.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Encoder {
    layout: ObsLayout,
    /// 1 / half the arena's width and height: the pose's scale.
    inv_half: Vec2,
}

impl Encoder {
    /// The encoder for `world`'s scene, with `grid` cells a side (checked by the config).
    pub fn new(world: &World, grid: usize) -> Encoder {
        let scene = world.config();
        let kinds = scene.pucks.kinds;
        let [near_right, far_right, far_left, _] = world.footprint().corners();
        Encoder {
            layout: ObsLayout {
                agents: world.robot_count(),
                kinds,
                channels: kinds + 2,
                grid,
                gripper: kinds + 1,
                pose: POSE_LEN,
                near_cm: near_right.x,
                far_cm: far_right.x,
                half_width_cm: far_left.y.max(-far_right.y),
            },
            inv_half: Vec2::new(2.0 / scene.arena.width, 2.0 / scene.arena.height),
        }
    }

    /// The sizes.
    pub fn layout(&self) -> ObsLayout {
        self.layout
    }

    /// The cell holding robot-frame point `p` (index into one channel), or
    /// `None` outside the grid or for a non-finite point.
    fn cell(&self, p: Vec2) -> Option<usize> {
        let l = &self.layout;
        let g = l.grid as f64;
        // Fractions across the grid, 0 at the far and left edges.
        let u = (l.far_cm - p.x) / (l.far_cm - l.near_cm);
        let v = (l.half_width_cm - p.y) / (2.0 * l.half_width_cm);
        // Also false for NaN, so a non-finite point never gets a cell.
        if !((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v)) {
            return None;
        }
        // The near and right edges belong to the last row and column.
        let row = ((u * g) as usize).min(l.grid - 1);
        let col = ((v * g) as usize).min(l.grid - 1);
        Some(row * l.grid + col)
    }

    /// Writes `obs` into one agent's slices (`map` C·G·G, `gripper` K+1, `pose` 4).
    pub fn write(&self, obs: &Observation, map: &mut [f32], gripper: &mut [f32], pose: &mut [f32]) {
        let l = &self.layout;
        let plane = l.grid * l.grid;
        map.fill(0.0);
        for p in obs.pucks.iter().filter(|p| !p.held_by_other) {
            let k = usize::from(p.kind.0);
            if let (true, Some(c)) = (k < l.kinds, self.cell(p.pos)) {
                map[k * plane + c] += 1.0;
            }
        }
        let robots = l.kinds * plane;
        for r in &obs.robots {
            if let Some(c) = self.cell(*r) {
                map[robots + c] += 1.0;
            }
        }
        let obstacles = (l.kinds + 1) * plane;
        for o in &obs.obstacles {
            if let Some(c) = self.cell(*o) {
                map[obstacles + c] = 1.0;
            }
        }
        gripper.fill(0.0);
        let held = match obs.gripper {
            Some(g) if usize::from(g.kind.0) < l.kinds => 1 + usize::from(g.kind.0),
            _ => 0,
        };
        gripper[held] = 1.0;
        let fin = |v: f64| if v.is_finite() { v as f32 } else { 0.0 };
        let theta = obs.pose.theta;
        let (sin, cos) = if theta.is_finite() {
            theta.sin_cos()
        } else {
            (0.0, 1.0)
        };
        pose[0] = fin(obs.pose.x * self.inv_half.x);
        pose[1] = fin(obs.pose.y * self.inv_half.y);
        pose[2] = fin(cos);
        pose[3] = fin(sin);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_sim::{Pose, PuckKind, SceneConfig, SeenPuck};

    fn encoder(grid: usize) -> Encoder {
        let world = World::new(&SceneConfig::default(), 1).unwrap();
        Encoder::new(&world, grid)
    }

    fn seen(kind: u8, x: f64, y: f64, held_by_other: bool) -> SeenPuck {
        SeenPuck {
            kind: PuckKind(kind),
            pos: Vec2::new(x, y),
            held_by_other,
        }
    }

    fn buffers(l: &ObsLayout) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        (
            vec![9.0; l.map_len()],
            vec![9.0; l.gripper],
            vec![9.0; l.pose],
        )
    }

    #[test]
    fn the_grid_covers_the_footprint_far_edge_up_and_left_edge_first() {
        let e = encoder(4);
        let l = e.layout();
        assert_eq!((l.channels, l.gripper, l.pose), (4, 3, 4));
        assert!(l.near_cm < l.far_cm && l.half_width_cm > 0.0);
        let far_left = Vec2::new(l.far_cm, l.half_width_cm);
        let near_right = Vec2::new(l.near_cm, -l.half_width_cm);
        assert_eq!(e.cell(far_left), Some(0));
        assert_eq!(e.cell(near_right), Some(15));
        let mid_x = (l.near_cm + l.far_cm) / 2.0;
        assert_eq!(
            e.cell(Vec2::new(l.far_cm - 0.01, -l.half_width_cm)),
            Some(3)
        );
        assert_eq!(e.cell(Vec2::new(mid_x - 0.01, l.half_width_cm)), Some(8));
        for outside in [
            Vec2::new(l.far_cm + 0.1, 0.0),
            Vec2::new(l.near_cm - 0.1, 0.0),
            Vec2::new(mid_x, l.half_width_cm + 0.1),
            Vec2::new(f64::NAN, 0.0),
            Vec2::new(mid_x, f64::INFINITY),
        ] {
            assert_eq!(e.cell(outside), None, "{outside:?}");
        }
    }

    #[test]
    fn env_observation_channels_count_pucks_and_robots_and_mark_obstacles() {
        let e = encoder(2);
        let l = e.layout();
        let (mut map, mut gripper, mut pose) = buffers(&l);
        let far_left = Vec2::new(l.far_cm - 1.0, l.half_width_cm - 1.0);
        let near_right = Vec2::new(l.near_cm + 1.0, -l.half_width_cm + 1.0);
        let obs = Observation {
            pose: Pose {
                x: 187.0 / 2.0,
                y: -187.0 / 4.0,
                theta: std::f64::consts::FRAC_PI_2,
            },
            gripper: Some(seen(1, 8.0, 0.0, false)),
            pucks: vec![
                seen(0, far_left.x, far_left.y, false),
                seen(0, far_left.x, far_left.y, false),
                seen(1, near_right.x, near_right.y, false),
                seen(1, near_right.x, near_right.y, true),
                seen(7, near_right.x, near_right.y, false),
                seen(0, f64::NAN, 0.0, false),
            ],
            robots: vec![near_right],
            obstacles: vec![far_left, far_left, Vec2::new(f64::INFINITY, 1.0)],
        };
        e.write(&obs, &mut map, &mut gripper, &mut pose);
        // Four channels of 2x2: kind 0, kind 1, robots, obstacles.
        assert_eq!(
            map,
            [2., 0., 0., 0., 0., 0., 0., 1., 0., 0., 0., 1., 1., 0., 0., 0.]
        );
        assert_eq!(gripper, [0.0, 0.0, 1.0]);
        assert!((pose[0] - 1.0).abs() < 1e-6 && (pose[1] + 0.5).abs() < 1e-6);
        assert!(pose[2].abs() < 1e-6 && (pose[3] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn env_observation_of_a_non_finite_pose_is_finite() {
        let e = encoder(3);
        let l = e.layout();
        let (mut map, mut gripper, mut pose) = buffers(&l);
        let obs = Observation {
            pose: Pose {
                x: f64::NAN,
                y: f64::INFINITY,
                theta: f64::NAN,
            },
            ..Observation::default()
        };
        e.write(&obs, &mut map, &mut gripper, &mut pose);
        assert!(map.iter().all(|v| *v == 0.0));
        assert_eq!(gripper, [1.0, 0.0, 0.0], "empty gripper");
        assert_eq!(pose, [0.0, 0.0, 1.0, 0.0]);
    }
}
