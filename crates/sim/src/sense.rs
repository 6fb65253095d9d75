//! What a robot's sensors report, computed from the geometry (no rendering).
//!
//! The camera sees the ground inside its footprint ([`crate::CameraConfig`]). A puck
//! is seen when its centre (the centroid of its colour blob) is inside; another
//! robot when its centre is; obstacles are points about `camera.obstacle_spacing`
//! apart on the walls' inner surface and on other robots' body outlines (their
//! grippers are not reported, as in the authors' simulator). There is no
//! occlusion: a puck behind another robot is still seen. The pose is exact (the
//! overhead tracker).

use crate::types::{Observation, PuckId, RobotId, SeenPuck, Vec2};
use crate::world::World;

impl World {
    /// What robot `id` senses now. An id out of range gives an empty observation.
    ///
    /// Everything but the pose is in the robot frame (origin at the body's centre,
    /// x forward, y left); the camera sits `camera.offset` (3.75 cm) ahead of the
    /// centre and its footprint is measured from there, so the standard footprint
    /// spans x = 6.25 to 39.35 in the robot frame.
    ///
    /// - `pose`: exact, world frame (the overhead tracker).
    /// - `gripper`: the puck this robot carries (by the carrying hysteresis), where it
    ///   really is; a seated puck is at about (9.4, 0), the pocket's centre being
    ///   (9.85, 0) ([`World::robot_shape`]).
    /// - `pucks`: every other puck whose centre is in the footprint;
    ///   `held_by_other` when another robot carries it or its centre is in another
    ///   robot's pocket.
    /// - `robots`: centres of the other robots that are in the footprint.
    /// - `obstacles`: points in the footprint on the walls' inner surface (spaced
    ///   `camera.obstacle_spacing`, precomputed) and on the outlines of other robots'
    ///   bodies (same spacing; grippers are not reported, as in the authors' simulator).
    ///
    /// No occlusion is modelled: what lies behind another robot is still seen.
    pub fn observe(&self, id: RobotId) -> Observation {
        let mut out = Observation::default();
        self.observe_into(id, &mut out);
        out
    }

    /// [`World::observe`] into a reused value, to spare allocations in long runs.
    pub fn observe_into(&self, id: RobotId, out: &mut Observation) {
        out.gripper = None;
        out.pucks.clear();
        out.robots.clear();
        out.obstacles.clear();
        let Some(me) = self.robots.get(id.0) else {
            out.pose = Default::default();
            return;
        };
        out.pose = me.pose;
        let fp = &self.footprint;
        if let Some(c) = me.carrying {
            let p = &self.pucks[c.0];
            out.gripper = Some(SeenPuck {
                kind: p.kind,
                pos: me.to_local(p.pos),
                held_by_other: false,
            });
        }
        // The footprint's bounding box in the world frame.
        let (mut lo, mut hi) = (Vec2::new(f64::MAX, f64::MAX), Vec2::new(f64::MIN, f64::MIN));
        for c in fp.corners() {
            let w = me.to_world(c);
            lo = Vec2::new(lo.x.min(w.x), lo.y.min(w.y));
            hi = Vec2::new(hi.x.max(w.x), hi.y.max(w.y));
        }
        self.puck_grid.query(lo, hi, |j| {
            if me.carrying == Some(PuckId(j as usize)) {
                return;
            }
            let p = &self.pucks[j as usize];
            let local = me.to_local(p.pos);
            if fp.contains(local) {
                let other = |r: Option<RobotId>| r.is_some_and(|r| r != id);
                let held_by_other = other(p.carried_by) || other(p.in_pocket_of);
                out.pucks.push(SeenPuck {
                    kind: p.kind,
                    pos: local,
                    held_by_other,
                });
            }
        });
        self.wall_grid.query(lo, hi, |j| {
            let local = me.to_local(self.wall_points[j as usize]);
            if fp.contains(local) {
                out.obstacles.push(local);
            }
        });
        let near = fp.reach() + self.geometry.bounding_radius;
        // Only robots whose centres are in the box around `near` can be seen; they are
        // visited in id order, as a scan of every robot would.
        let mut nearby: Vec<u32> = Vec::new();
        let centre = me.pose.position();
        self.robot_grid.query(
            Vec2::new(centre.x - near, centre.y - near),
            Vec2::new(centre.x + near, centre.y + near),
            |k| nearby.push(k),
        );
        nearby.sort_unstable();
        for k in nearby.into_iter().map(|k| k as usize) {
            let other = &self.robots[k];
            if k == id.0 {
                continue;
            }
            let centre = me.to_local(other.pose.position());
            if centre.length() > near {
                continue;
            }
            if fp.contains(centre) {
                out.robots.push(centre);
            }
            for &q in &self.geometry.outline {
                let local = me.to_local(other.to_world(q));
                if fp.contains(local) {
                    out.obstacles.push(local);
                }
            }
        }
    }
}
