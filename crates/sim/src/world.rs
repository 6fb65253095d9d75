//! The world: arena, robots, pucks, and one step function.

use colony_proto::geometry::unit;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::arena::Arena;
use crate::body::RobotGeometry;
use crate::config::{Footprint, SceneConfig};
use crate::error::SimError;
use crate::grid::Grid;
use crate::layout::{sample_pucks, sample_robots};
use crate::physics::{Physics, PhysicsStats};
use crate::snapshot::{PuckSnapshot, RobotSnapshot, WorldSnapshot};
use crate::types::{Pose, Puck, PuckId, PuckKind, RobotId, RobotState, Vec2, WheelCommand};

/// Side of the cells of the grids that speed up sensing, cm (larger in arenas wider
/// than `GRID_CELL * GRID_MAX_CELLS`, so a grid never has more than that many cells a side).
const GRID_CELL: f64 = 10.0;
const GRID_MAX_CELLS: f64 = 256.0;

/// A simulated arena with robots and pucks, deterministic for a seed.
///
/// ```
/// use colony_sim::{SceneConfig, World, WheelCommand, RobotId};
/// let mut world = World::new(&SceneConfig::default(), 7).unwrap();
/// let go = WheelCommand { forward: 1.0, turn: 0.0 };
/// world.step(&[go; 4]);
/// let seen = world.observe(RobotId(0));
/// assert_eq!(world.step_count(), 1);
/// assert!(seen.pucks.len() <= 40);
/// ```
pub struct World {
    pub(crate) config: SceneConfig,
    pub(crate) arena: Arena,
    pub(crate) geometry: RobotGeometry,
    pub(crate) footprint: Footprint,
    physics: Physics,
    pub(crate) robots: Vec<RobotSlot>,
    pub(crate) pucks: Vec<PuckSlot>,
    pub(crate) puck_grid: Grid,
    pub(crate) robot_grid: Grid,
    pub(crate) wall_points: Vec<Vec2>,
    pub(crate) wall_grid: Grid,
    step: u64,
}

/// A robot's rapier body and what the world tracks about it between steps.
#[derive(Debug, Clone)]
pub(crate) struct RobotSlot {
    body: usize,
    pub pose: Pose,
    /// cos and sin of the heading (kept rather than recomputed from `pose.theta`).
    pub cos: f64,
    pub sin: f64,
    pub carrying: Option<PuckId>,
}

impl RobotSlot {
    /// A robot-frame point in the world frame.
    pub fn to_world(&self, p: Vec2) -> Vec2 {
        Vec2::new(
            self.pose.x + self.cos * p.x - self.sin * p.y,
            self.pose.y + self.sin * p.x + self.cos * p.y,
        )
    }

    /// A world-frame point in the robot frame.
    pub fn to_local(&self, p: Vec2) -> Vec2 {
        let (dx, dy) = (p.x - self.pose.x, p.y - self.pose.y);
        Vec2::new(
            self.cos * dx + self.sin * dy,
            -self.sin * dx + self.cos * dy,
        )
    }
}

/// A puck's rapier body and what the world tracks about it between steps.
#[derive(Debug, Clone)]
pub(crate) struct PuckSlot {
    body: usize,
    pub kind: PuckKind,
    pub pos: Vec2,
    /// The robot that carries it (with the carrying hysteresis).
    pub carried_by: Option<RobotId>,
    /// The robot whose gripper pocket holds its centre.
    pub in_pocket_of: Option<RobotId>,
}

/// A robot's shape, for controllers that reason about geometry (robot frame, cm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotShape {
    /// Body length along the heading, gripper excluded.
    pub length: f64,
    /// Body width.
    pub width: f64,
    /// Centre of the gripper's pocket: where a carried puck sits.
    pub gripper_centre: Vec2,
    /// Inner radius of the gripper's pocket.
    pub gripper_radius: f64,
    /// Radius of a circle round the robot's centre that contains the whole robot.
    pub bounding_radius: f64,
}

impl World {
    /// A world with robots and pucks placed uniformly at random, without overlaps,
    /// clear of the walls, robot headings uniform; all randomness from
    /// `ChaCha8Rng::seed_from_u64(seed)`.
    pub fn new(config: &SceneConfig, seed: u64) -> Result<World, SimError> {
        config.validate()?;
        let arena = Arena::new(&config.arena);
        let geometry = RobotGeometry::new(config);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let robots = sample_robots(config, &arena, &geometry, &mut rng)?;
        let centres: Vec<Vec2> = robots.iter().map(Pose::position).collect();
        let positions = sample_pucks(config, &arena, &geometry, &centres, &mut rng)?;
        let pucks: Vec<(PuckKind, Vec2)> = positions
            .into_iter()
            .enumerate()
            .map(|(i, p)| (config.puck_kind(i), p))
            .collect();
        Ok(World::build(
            config.clone(),
            arena,
            geometry,
            &robots,
            &pucks,
        ))
    }

    /// A world with robots and pucks exactly where given (for tests and scripted
    /// scenes). The configuration's robot and puck counts are replaced by the
    /// lengths of the lists (either may be empty); its puck types must include
    /// every kind listed. Overlaps are allowed and resolved by the physics.
    pub fn with_layout(
        config: &SceneConfig,
        robots: &[Pose],
        pucks: &[(PuckKind, Vec2)],
    ) -> Result<World, SimError> {
        let mut cfg = config.clone();
        cfg.robots.count = robots.len();
        cfg.pucks.count = pucks.len();
        cfg.validate_geometry()?;
        let arena = Arena::new(&cfg.arena);
        for (i, r) in robots.iter().enumerate() {
            if !(r.theta.is_finite() && arena.contains(r.position(), 0.0)) {
                return Err(SimError::Layout(format!(
                    "robot {i} at ({}, {}, {}) is not a finite pose inside the arena",
                    r.x, r.y, r.theta
                )));
            }
        }
        for (i, (kind, p)) in pucks.iter().enumerate() {
            if kind.0 as usize >= cfg.pucks.kinds {
                return Err(SimError::Layout(format!(
                    "puck {i} has type {} but the configuration has {} types",
                    kind.0, cfg.pucks.kinds
                )));
            }
            if !arena.contains(*p, 0.0) {
                return Err(SimError::Layout(format!(
                    "puck {i} at ({}, {}) is not inside the arena",
                    p.x, p.y
                )));
            }
        }
        let geometry = RobotGeometry::new(&cfg);
        Ok(World::build(cfg, arena, geometry, robots, pucks))
    }

    fn build(
        config: SceneConfig,
        arena: Arena,
        geometry: RobotGeometry,
        robots: &[Pose],
        pucks: &[(PuckKind, Vec2)],
    ) -> World {
        let mut physics = Physics::new(&config, &arena, &geometry);
        let robots = robots
            .iter()
            .map(|&pose| RobotSlot {
                body: physics.add_robot(&config, &geometry, pose),
                pose,
                cos: 1.0,
                sin: 0.0,
                carrying: None,
            })
            .collect();
        let pucks = pucks
            .iter()
            .map(|&(kind, pos)| PuckSlot {
                body: physics.add_puck(&config, pos),
                kind,
                pos,
                carried_by: None,
                in_pocket_of: None,
            })
            .collect();
        // Grids a little larger than the arena: bodies pressed into a wall stay in range.
        let half = Vec2::new(arena.half_width() + 1.0, arena.half_height() + 1.0);
        let cell = GRID_CELL.max(2.0 * half.x.max(half.y) / GRID_MAX_CELLS);
        let wall_points = arena.wall_points(config.camera.obstacle_spacing);
        let mut wall_grid = Grid::new(half, cell);
        wall_grid.rebuild(wall_points.iter().copied());
        let mut world = World {
            footprint: config.camera.footprint(),
            config,
            arena,
            geometry,
            physics,
            robots,
            pucks,
            puck_grid: Grid::new(half, cell),
            robot_grid: Grid::new(half, cell),
            wall_points,
            wall_grid,
            step: 0,
        };
        world.refresh();
        world
    }

    /// Advances the world by one control step (`physics.substeps` physics steps).
    ///
    /// `commands[i]` drives robot `i` for the whole step (or for
    /// `robots.command_duration`, then it stands still). Values are clamped to
    /// [-1, 1]; NaN counts as 0; a missing command counts as [`WheelCommand::STOP`]
    /// and extra commands are ignored.
    pub fn step(&mut self, commands: &[WheelCommand]) {
        let dt = self.config.physics.dt;
        let speed = self.config.robots.full_speed;
        let rate = self.config.robots.full_turn_rate;
        let command_duration = self.config.robots.command_duration;
        let bodies: Vec<usize> = self.robots.iter().map(|r| r.body).collect();
        let drives: Vec<(f64, f64)> = (0..self.robots.len())
            .map(|i| {
                let c = commands.get(i).copied().unwrap_or(WheelCommand::STOP);
                (unit(c.forward) * speed, unit(c.turn) * rate)
            })
            .collect();
        // The share of each physics step during which the command acts.
        let share = |k: u32| match command_duration {
            None => 1.0,
            Some(d) => ((d - k as f64 * dt) / dt).clamp(0.0, 1.0),
        };
        self.physics
            .steps(self.config.physics.substeps, &bodies, &drives, share);
        self.step += 1;
        self.refresh();
    }

    /// What the contact engine held in the last physics step (for benchmarks).
    pub fn physics_stats(&self) -> PhysicsStats {
        self.physics.stats()
    }

    /// Control steps taken since the world was made.
    pub fn step_count(&self) -> u64 {
        self.step
    }

    /// Simulated time since the world was made, s.
    pub fn time(&self) -> f64 {
        self.step as f64 * self.config.control_step_seconds()
    }

    /// The configuration this world was made with (counts as in the world).
    pub fn config(&self) -> &SceneConfig {
        &self.config
    }

    /// Number of robots.
    pub fn robot_count(&self) -> usize {
        self.robots.len()
    }

    /// Number of pucks.
    pub fn puck_count(&self) -> usize {
        self.pucks.len()
    }

    /// Every robot's pose and carried puck, in id order.
    pub fn robots(&self) -> Vec<RobotState> {
        (0..self.robots.len())
            .filter_map(|i| self.robot(RobotId(i)))
            .collect()
    }

    /// One robot, or `None` for an id out of range.
    pub fn robot(&self, id: RobotId) -> Option<RobotState> {
        self.robots.get(id.0).map(|r| RobotState {
            id,
            pose: r.pose,
            carrying: r.carrying,
        })
    }

    /// Every puck's type and position (the global map), in id order.
    pub fn pucks(&self) -> Vec<Puck> {
        (0..self.pucks.len())
            .filter_map(|i| self.puck(PuckId(i)))
            .collect()
    }

    /// One puck, or `None` for an id out of range.
    pub fn puck(&self, id: PuckId) -> Option<Puck> {
        self.pucks.get(id.0).map(|p| Puck {
            id,
            kind: p.kind,
            pos: p.pos,
        })
    }

    /// Whether a world point lies inside the arena's walls.
    pub fn arena_contains(&self, p: Vec2) -> bool {
        self.arena.contains(p, 0.0)
    }

    /// Distance from a world point to the nearest wall, cm (negative outside the arena).
    pub fn wall_distance(&self, p: Vec2) -> f64 {
        -self.arena.signed_distance(p)
    }

    /// The robots' shape (the same for all robots).
    pub fn robot_shape(&self) -> RobotShape {
        RobotShape {
            length: self.config.robots.length,
            width: self.config.robots.width,
            gripper_centre: self.geometry.pocket,
            gripper_radius: self.geometry.pocket_radius,
            bounding_radius: self.geometry.bounding_radius,
        }
    }

    /// The camera's footprint test (robot frame).
    pub fn footprint(&self) -> Footprint {
        self.footprint
    }

    /// Disturbance: moves the given pucks by `offset` at once (a cluster shift, as in
    /// the paper's supplementary experiments). Each lands at rest; one that would
    /// leave the arena is put at the nearest place inside instead. Ids out of range
    /// and a non-finite offset are ignored. A moved puck leaves any gripper it was in.
    pub fn shift_cluster(&mut self, pucks: &[PuckId], offset: Vec2) {
        if !(offset.x.is_finite() && offset.y.is_finite()) {
            return;
        }
        let margin = self.config.puck_radius() + 0.01;
        for id in pucks {
            if let Some(slot) = self.pucks.get(id.0) {
                let target = self.arena.clamp_inside(slot.pos + offset, margin);
                self.physics.teleport(slot.body, target);
            }
        }
        self.refresh();
    }

    /// Disturbance: puts every puck at a new uniformly random place (re-insertion, as
    /// in the paper's supplementary experiments), clear of the walls, the robots and
    /// each other. Carried pucks are taken from their grippers.
    pub fn reinsert_pucks<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Result<(), SimError> {
        let centres: Vec<Vec2> = self.robots.iter().map(|r| r.pose.position()).collect();
        let mut cfg = self.config.clone();
        cfg.pucks.count = self.pucks.len();
        let positions = sample_pucks(&cfg, &self.arena, &self.geometry, &centres, rng)?;
        for (slot, p) in self.pucks.iter().zip(positions) {
            self.physics.teleport(slot.body, p);
        }
        for r in &mut self.robots {
            r.carrying = None;
        }
        self.refresh();
        Ok(())
    }

    /// Everything needed to draw or replay this instant: serialisable with serde.
    pub fn snapshot(&self) -> WorldSnapshot {
        WorldSnapshot {
            step: self.step,
            time: self.time(),
            arena: self.config.arena,
            robots: self
                .robots
                .iter()
                .enumerate()
                .map(|(i, r)| RobotSnapshot {
                    id: i,
                    pose: r.pose,
                    carrying: r.carrying.map(|p| p.0),
                })
                .collect(),
            pucks: self
                .pucks
                .iter()
                .enumerate()
                .map(|(i, p)| PuckSnapshot {
                    id: i,
                    kind: p.kind,
                    pos: p.pos,
                })
                .collect(),
        }
    }

    /// Re-reads poses from the physics, rebuilds the puck and robot grids and updates which
    /// puck each gripper holds (with the carrying hysteresis).
    fn refresh(&mut self) {
        for r in &mut self.robots {
            let (p, c, s) = self.physics.pose_of(r.body);
            r.pose = Pose {
                x: p.x,
                y: p.y,
                theta: libm::atan2(s, c),
            };
            r.cos = c;
            r.sin = s;
        }
        for p in &mut self.pucks {
            p.pos = self.physics.pose_of(p.body).0;
            p.carried_by = None;
            p.in_pocket_of = None;
        }
        self.puck_grid.rebuild(self.pucks.iter().map(|p| p.pos));
        self.robot_grid
            .rebuild(self.robots.iter().map(|r| r.pose.position()));
        let g = &self.geometry;
        let reach = g.pocket_radius + self.config.puck_radius();
        // A robot keeps its puck while the puck is still in far enough...
        for (i, r) in self.robots.iter_mut().enumerate() {
            if let Some(c) = r.carrying {
                let pocket = r.to_world(g.pocket);
                match self.pucks.get_mut(c.0) {
                    Some(p) if p.pos.distance(pocket) < g.carry_keep_distance => {
                        p.carried_by = Some(RobotId(i))
                    }
                    _ => r.carrying = None,
                }
            }
        }
        // ...and an empty gripper takes the deepest free puck that is in far enough to start.
        for (i, r) in self.robots.iter_mut().enumerate() {
            let pocket = r.to_world(g.pocket);
            let lo = Vec2::new(pocket.x - reach, pocket.y - reach);
            let hi = Vec2::new(pocket.x + reach, pocket.y + reach);
            let mut best: Option<(f64, usize)> = None;
            let pucks = &mut self.pucks;
            self.puck_grid.query(lo, hi, |j| {
                let p = &mut pucks[j as usize];
                let d = p.pos.distance(pocket);
                if d < g.pocket_radius {
                    p.in_pocket_of = Some(RobotId(i));
                }
                if p.carried_by.is_none()
                    && d < g.carry_start_distance
                    && best.is_none_or(|(bd, _)| d < bd)
                {
                    best = Some((d, j as usize));
                }
            });
            if r.carrying.is_none() {
                if let Some((_, j)) = best {
                    r.carrying = Some(PuckId(j));
                    self.pucks[j].carried_by = Some(RobotId(i));
                }
            }
        }
    }
}

impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("step", &self.step)
            .field("robots", &self.robots().len())
            .field("pucks", &self.pucks.len())
            .finish_non_exhaustive()
    }
}
