//! The rapier2d world behind a [`super::Field`].
//!
//! As in the arena's physics: centimetres and grams (`length_unit = 100`), no
//! gravity (a top view), bodies driven by setting their velocity each physics step.
//! Walls and water are two compound colliders on one fixed body, each made of the
//! map's merged rectangles: a 1024 x 1024 map becomes two colliders with their own
//! bounding-volume trees, not a million cells in the broad phase.

use rapier2d::prelude::*;

use super::config::{BoxSpec, FieldConfig, RobotSpec};
use super::map::{Terrain, TileMap};
use crate::rapier::{groups, rapier_pose, Rapier};
use crate::types::{Pose as WorldPose, Vec2};

/// Collision groups. Water is its own group so that only land robots and boxes
/// meet it: amphibians pass through.
const WALL: Group = Group::GROUP_1;
const WATER: Group = Group::GROUP_2;
const LAND: Group = Group::GROUP_3;
const AMPHIBIAN: Group = Group::GROUP_4;
const BOX: Group = Group::GROUP_5;

/// The field's bodies in rapier.
pub(crate) struct FieldPhysics {
    pub rapier: Rapier,
    friction: f32,
    density: f32,
    cell: f64,
    /// The fastest robot's top speed, cm/s: what boxes can be pushed at.
    fastest: f64,
    /// Every box and its least thickness, cm, to switch on their continuous
    /// collision detection when a fast enough robot arrives.
    boxes: Vec<(RigidBodyHandle, f64)>,
}

impl FieldPhysics {
    pub fn new(map: &TileMap, cfg: &FieldConfig) -> FieldPhysics {
        let params = IntegrationParameters {
            dt: cfg.physics_dt() as f32,
            length_unit: 100.0,
            // See the arena's physics: rapier's default would reuse contacts until
            // bodies moved 5 cm relative to each other.
            normalized_contact_recycle_distance: 0.0005,
            // Continuous collision detection only for the bodies that ask for it
            // (those fast enough to cross a cell in one step).
            max_ccd_substeps: 1,
            ..IntegrationParameters::default()
        };
        let mut physics = FieldPhysics {
            rapier: Rapier::new(params),
            friction: cfg.friction as f32,
            density: cfg.robot_density as f32,
            cell: map.cell_cm(),
            fastest: 0.0,
            boxes: Vec::new(),
        };
        let ground = physics.rapier.bodies.insert(RigidBodyBuilder::fixed());
        let rect = |lo: Vec2, hi: Vec2| {
            let half = (hi - lo) * 0.5;
            let c = (lo + hi) * 0.5;
            (
                Pose::translation(c.x as f32, c.y as f32),
                SharedShape::cuboid(half.x as f32, half.y as f32),
            )
        };
        // The border: four slabs outside the map, at least a cell thick, overlapping
        // at the corners.
        let size = map.size_cm();
        let t = map.cell_cm().max(10.0);
        let mut walls = vec![
            rect(Vec2::new(-t, -t), Vec2::new(0.0, size.y + t)),
            rect(Vec2::new(size.x, -t), Vec2::new(size.x + t, size.y + t)),
            rect(Vec2::new(0.0, -t), Vec2::new(size.x, 0.0)),
            rect(Vec2::new(0.0, size.y), Vec2::new(size.x, size.y + t)),
        ];
        for r in map.merged_rects(Terrain::Blocked) {
            let (lo, hi) = map.rect_bounds(r);
            walls.push(rect(lo, hi));
        }
        let water: Vec<_> = map
            .merged_rects(Terrain::Water)
            .into_iter()
            .map(|r| {
                let (lo, hi) = map.rect_bounds(r);
                rect(lo, hi)
            })
            .collect();
        let friction = physics.friction;
        let wall = ColliderBuilder::new(SharedShape::compound(walls))
            .friction(friction)
            .collision_groups(groups(WALL, LAND | AMPHIBIAN | BOX));
        physics.rapier.attach(wall, ground);
        // A compound needs at least one part.
        if !water.is_empty() {
            let water = ColliderBuilder::new(SharedShape::compound(water))
                .friction(friction)
                .collision_groups(groups(WATER, LAND | BOX));
            physics.rapier.attach(water, ground);
        }
        physics
    }

    /// Whether a body this fast and this thick needs continuous collision detection
    /// not to pass through walls one cell thick.
    fn needs_ccd(&self, speed: f64, thickness: f64) -> bool {
        speed * self.rapier.params.dt as f64 > 0.5 * thickness.min(self.cell)
    }

    /// Adds a robot: a disc whose mass follows its footprint's area, that never sleeps
    /// (its velocity is set every step).
    pub fn add_robot(&mut self, spec: &RobotSpec, pose: WorldPose) -> RigidBodyHandle {
        let body = RigidBodyBuilder::dynamic()
            .pose(rapier_pose(pose))
            .can_sleep(false)
            .ccd_enabled(self.needs_ccd(spec.max_speed, spec.radius));
        if spec.max_speed > self.fastest {
            self.fastest = spec.max_speed;
            for k in 0..self.boxes.len() {
                let (handle, thickness) = self.boxes[k];
                if self.needs_ccd(self.fastest, thickness) {
                    if let Some(rb) = self.rapier.bodies.get_mut(handle) {
                        rb.enable_ccd(true);
                    }
                }
            }
        }
        let handle = self.rapier.bodies.insert(body);
        let member = if spec.amphibious { AMPHIBIAN } else { LAND };
        let filter = if spec.amphibious {
            WALL | LAND | AMPHIBIAN | BOX
        } else {
            WALL | WATER | LAND | AMPHIBIAN | BOX
        };
        let collider = ColliderBuilder::ball(spec.radius as f32)
            .density(self.density)
            .friction(self.friction)
            .collision_groups(groups(member, filter));
        self.rapier.attach(collider, handle);
        handle
    }

    /// Adds a box, its floor friction as damping. Boxes stop at water as at walls,
    /// so a box stays where land robots can reach it.
    pub fn add_box(&mut self, spec: &BoxSpec, pose: WorldPose) -> RigidBodyHandle {
        let damping = rapier_damping(spec.damping, self.rapier.params.dt as f64) as f32;
        let thickness = 2.0 * spec.half_width.min(spec.half_length);
        let body = RigidBodyBuilder::dynamic()
            .pose(rapier_pose(pose))
            .linear_damping(damping)
            .angular_damping(damping)
            .ccd_enabled(self.needs_ccd(self.fastest, thickness));
        let handle = self.rapier.bodies.insert(body);
        self.boxes.push((handle, thickness));
        let collider = ColliderBuilder::cuboid(spec.half_length as f32, spec.half_width as f32)
            .mass(spec.mass as f32)
            .friction(self.friction)
            .collision_groups(groups(BOX, WALL | WATER | LAND | AMPHIBIAN | BOX));
        self.rapier.attach(collider, handle);
        handle
    }

    /// Takes a body out of the simulation (it neither moves nor is met) or puts it back.
    pub fn set_enabled(&mut self, handle: RigidBodyHandle, enabled: bool) {
        if let Some(rb) = self.rapier.bodies.get_mut(handle) {
            rb.set_enabled(enabled);
        }
    }

    /// Puts a body at a pose, at rest (a respawn, not physics).
    pub fn place(&mut self, handle: RigidBodyHandle, pose: WorldPose) {
        if let Some(rb) = self.rapier.bodies.get_mut(handle) {
            rb.set_position(rapier_pose(pose), true);
        }
        self.rapier.halt(handle);
    }

    /// A body's pose as the physics holds it.
    pub fn pose_of(&self, handle: RigidBodyHandle) -> Option<WorldPose> {
        let rb = self.rapier.bodies.get(handle)?;
        let t = rb.translation();
        let r = rb.rotation();
        Some(WorldPose {
            x: t.x as f64,
            y: t.y as f64,
            theta: libm::atan2(r.im as f64, r.re as f64),
        })
    }
}

/// Converts a decay rate `c` (speed falls as `exp(-c t)`) to rapier's damping,
/// which multiplies the speed by `1 / (1 + c' dt)` each step, so that a box
/// slows the same whatever the step length.
fn rapier_damping(rate: f64, dt: f64) -> f64 {
    // Past this a box stops dead within a step anyway; it keeps the value finite.
    ((libm::exp(rate * dt) - 1.0) / dt).min(1e9)
}
