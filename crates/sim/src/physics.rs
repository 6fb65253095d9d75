//! The contact engine behind a [`crate::World`], whichever was chosen
//! ([`crate::Engine`]): rapier2d, or colony's own disc engine ([`crate::disc`]).
//!
//! Lengths are centimetres throughout, and rapier is told so
//! (`IntegrationParameters::length_unit = 100`, i.e. 100 units per metre), which
//! scales its internal tolerances. Masses are grams; gravity is zero (a top view).

use rapier2d::prelude::*;

use crate::arena::Arena;
use crate::body::{Part, RobotGeometry};
use crate::config::{Engine, SceneConfig};
use crate::disc::DiscEngine;
use crate::rapier::{groups, rapier_pose, vector as v, Rapier};
use crate::types::{Pose as WorldPose, Vec2};

/// The arena's bodies in the chosen engine; a body is named by the index its `add_` gave.
pub(crate) enum Physics {
    Rapier(Box<RapierArena>),
    Disc(Box<DiscEngine>),
}

impl Physics {
    pub fn new(cfg: &SceneConfig, arena: &Arena, geometry: &RobotGeometry) -> Physics {
        match cfg.physics.engine {
            Engine::Rapier => Physics::Rapier(Box::new(RapierArena::new(cfg, arena))),
            Engine::Disc => Physics::Disc(Box::new(DiscEngine::new(cfg, arena, geometry))),
        }
    }

    pub fn add_robot(&mut self, cfg: &SceneConfig, geom: &RobotGeometry, pose: WorldPose) -> usize {
        match self {
            Physics::Rapier(r) => r.add_robot(cfg, geom, pose),
            Physics::Disc(d) => d.add_robot(cfg, pose),
        }
    }

    pub fn add_puck(&mut self, cfg: &SceneConfig, pos: Vec2) -> usize {
        match self {
            Physics::Rapier(r) => r.add_puck(cfg, pos),
            Physics::Disc(d) => d.add_puck(cfg, pos),
        }
    }

    /// Moves a body to a new place at rest (a disturbance, not physics).
    pub fn teleport(&mut self, body: usize, pos: Vec2) {
        match self {
            Physics::Rapier(r) => r.teleport(body, pos),
            Physics::Disc(d) => d.teleport(body, pos),
        }
    }

    /// A body's position, and for robots its heading as (cos, sin).
    pub fn pose_of(&self, body: usize) -> (Vec2, f64, f64) {
        match self {
            Physics::Rapier(r) => r.pose_of(body),
            Physics::Disc(d) => d.pose_of(body),
        }
    }

    /// What the last physics step held: contact points and sleeping pucks.
    pub fn stats(&self) -> PhysicsStats {
        match self {
            Physics::Rapier(r) => PhysicsStats {
                contacts: r.rapier.contact_points(),
                sleeping_pucks: r.rapier.sleeping_bodies(),
                stage_seconds: Vec::new(),
            },
            Physics::Disc(d) => PhysicsStats {
                contacts: d.contact_count(),
                sleeping_pucks: d.sleeping_pucks(),
                stage_seconds: crate::disc::STAGES
                    .into_iter()
                    .zip(d.stage_seconds())
                    .collect(),
            },
        }
    }

    /// `n` physics steps; in the `k`-th, robot `bodies[i]` drives at `drives[i]` (speed along
    /// its heading, turn rate) times `share(k)`.
    pub fn steps(
        &mut self,
        n: u32,
        bodies: &[usize],
        drives: &[(f64, f64)],
        share: impl Fn(u32) -> f64 + Send + Sync,
    ) {
        match self {
            Physics::Rapier(r) => {
                let handles = &r.handles;
                r.rapier.steps(n, |rapier, k| {
                    let s = share(k);
                    for (&i, &(speed, turn)) in bodies.iter().zip(drives) {
                        rapier.drive(handles[i], speed * s, turn * s);
                    }
                });
            }
            Physics::Disc(d) => {
                for k in 0..n {
                    let s = share(k);
                    for (&i, &(speed, turn)) in bodies.iter().zip(drives) {
                        d.drive(i, speed * s, turn * s);
                    }
                    d.step();
                }
            }
        }
    }
}

/// Collision groups: walls, robot bodies (with their grippers), gripper bows, pucks.
const WALL: Group = Group::GROUP_1;
const ROBOT: Group = Group::GROUP_2;
const BOW: Group = Group::GROUP_3;
const PUCK: Group = Group::GROUP_4;

/// What a world's contact engine holds after a step, to compare engines by.
#[derive(Debug, Clone, PartialEq)]
pub struct PhysicsStats {
    /// Points of contact (touching or about to) in the last physics step.
    pub contacts: usize,
    /// Pucks asleep: at rest and left out of the step until something moving comes near.
    pub sleeping_pucks: usize,
    /// Seconds each stage of the physics step took since the world was made, where the
    /// engine keeps them (the disc engine does; rapier only with its profiler built in).
    pub stage_seconds: Vec<(&'static str, f64)>,
}

/// The arena's bodies in rapier.
pub(crate) struct RapierArena {
    pub rapier: Rapier,
    handles: Vec<RigidBodyHandle>,
}

impl RapierArena {
    pub fn new(cfg: &SceneConfig, arena: &Arena) -> RapierArena {
        let params = IntegrationParameters {
            dt: cfg.physics.dt as f32,
            length_unit: 100.0,
            num_solver_iterations: cfg.physics.solver_iterations as usize,
            // rapier reuses a pair's contacts until the bodies have moved
            // `normalized_contact_recycle_distance * length_unit` relative to each other:
            // 5 cm by default, as much as a puck's radius, which holds a puck at the
            // gripper's mouth on stale contacts. 0.05 cm keeps the savings for resting pucks.
            normalized_contact_recycle_distance: 0.0005,
            // No continuous collision detection: nothing moves more than 1.5 cm per
            // physics step and the walls are 10 cm thick, so nothing can tunnel; CCD's
            // sweeps would otherwise cost about an eighth of the step.
            max_ccd_substeps: 0,
            ..IntegrationParameters::default()
        };
        let mut physics = RapierArena {
            rapier: Rapier::new(params),
            handles: Vec::new(),
        };
        let walls = physics.rapier.bodies.insert(RigidBodyBuilder::fixed());
        for b in arena.wall_boxes() {
            let collider =
                ColliderBuilder::cuboid(b.half_extents.x as f32, b.half_extents.y as f32)
                    .translation(v(b.centre))
                    .rotation(b.angle as f32)
                    .friction(cfg.robots.friction as f32)
                    .collision_groups(groups(WALL, ROBOT | BOW | PUCK));
            physics.rapier.attach(collider, walls);
        }
        physics
    }

    /// Adds a robot at `pose`; its centre of mass is the body rectangle's centre,
    /// so it turns on the spot like a tracked vehicle.
    pub fn add_robot(&mut self, cfg: &SceneConfig, geom: &RobotGeometry, pose: WorldPose) -> usize {
        let m = cfg.robots.mass as f32;
        let (l, w) = (cfg.robots.length as f32, cfg.robots.width as f32);
        let inertia = m * (l * l + w * w) / 12.0;
        let body = RigidBodyBuilder::dynamic()
            .pose(rapier_pose(pose))
            .additional_mass_properties(MassProperties::new(Vector::ZERO, m, inertia))
            .can_sleep(false);
        let handle = self.rapier.bodies.insert(body);
        let shapes: Vec<(Pose, SharedShape)> = geom
            .parts()
            .into_iter()
            .filter_map(|part| {
                let shape = match part {
                    Part::Rectangle { half_extents } => {
                        SharedShape::cuboid(half_extents.x as f32, half_extents.y as f32)
                    }
                    Part::Capsule { a, b, radius } => {
                        SharedShape::capsule(v(a), v(b), radius as f32)
                    }
                    Part::Polygon(points) => {
                        let pts: Vec<Vector> = points.into_iter().map(v).collect();
                        SharedShape::convex_hull(&pts)?
                    }
                };
                Some((Pose::IDENTITY, shape))
            })
            .collect();
        let solid = ColliderBuilder::new(SharedShape::compound(shapes))
            .density(0.0)
            .friction(cfg.robots.friction as f32)
            .collision_groups(groups(ROBOT, WALL | ROBOT | BOW | PUCK));
        self.rapier.attach(solid, handle);
        let bow = ColliderBuilder::ball(geom.pocket_radius as f32)
            .translation(v(geom.pocket))
            .density(0.0)
            .friction(cfg.robots.friction as f32)
            .collision_groups(groups(BOW, WALL | ROBOT | BOW));
        self.rapier.attach(bow, handle);
        self.handles.push(handle);
        self.handles.len() - 1
    }

    /// Adds a puck: a disc with floor friction modelled as damping.
    pub fn add_puck(&mut self, cfg: &SceneConfig, pos: Vec2) -> usize {
        let dt = cfg.physics.dt;
        let body = RigidBodyBuilder::dynamic()
            .translation(v(pos))
            .linear_damping(rapier_damping(cfg.pucks.linear_damping, dt) as f32)
            .angular_damping(rapier_damping(cfg.pucks.angular_damping, dt) as f32);
        let handle = self.rapier.bodies.insert(body);
        let collider = ColliderBuilder::ball(cfg.puck_radius() as f32)
            .mass(cfg.pucks.mass as f32)
            .friction(cfg.pucks.friction as f32)
            .collision_groups(groups(PUCK, WALL | ROBOT | PUCK));
        self.rapier.attach(collider, handle);
        self.handles.push(handle);
        self.handles.len() - 1
    }

    fn teleport(&mut self, body: usize, pos: Vec2) {
        let handle = self.handles[body];
        self.rapier.bodies[handle].set_translation(v(pos), true);
        self.rapier.halt(handle);
    }

    fn pose_of(&self, body: usize) -> (Vec2, f64, f64) {
        let rb = &self.rapier.bodies[self.handles[body]];
        let t = rb.translation();
        let r = rb.rotation();
        // Renormalise in f64 so headings stay unit vectors to the last bit we use.
        let (c, s) = (r.re as f64, r.im as f64);
        let n = c.hypot(s);
        (Vec2::new(t.x as f64, t.y as f64), c / n, s / n)
    }
}

/// Converts a damping coefficient from Box2D's convention (the authors' JBox2D
/// simulator: velocity times `max(0, 1 - c dt)` each step) to rapier's (velocity
/// times `1 / (1 + c' dt)`), so a puck loses the same share of its speed per physics
/// step. At dt = 1/14, Box2D's 10 keeps 28.6 % per step and becomes rapier's 35.
pub(crate) fn rapier_damping(box2d: f64, dt: f64) -> f64 {
    let keep = (1.0 - box2d * dt).clamp(0.0, 1.0);
    if keep <= 1e-3 {
        // Box2D would stop the body dead each step; rapier's nearest is "very large".
        return 999.0 / dt;
    }
    (1.0 / keep - 1.0) / dt
}
