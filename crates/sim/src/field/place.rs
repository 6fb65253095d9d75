//! Where robots and boxes may be put: refusing overlaps up front, because the
//! contact solver would resolve them by flinging bodies apart (or through a wall).

use std::fmt;

use super::geom::Obb;
use super::map::Terrain;
use super::{BoxSpec, Field, FieldBoxId, FieldRobotId, Refusal, RobotSpec};
use crate::error::SimError;
use crate::types::{Pose, Vec2};

/// The error for a refused place, naming what was placed and where.
fn placement(
    what: impl fmt::Display,
    pose: Pose,
    refusal: Option<Refusal>,
) -> Result<(), SimError> {
    match refusal {
        None => Ok(()),
        Some(reason) => Err(SimError::Placement {
            what: what.to_string(),
            x: pose.x,
            y: pose.y,
            reason,
        }),
    }
}

impl Field {
    /// Refuses a place for robot `id` (which may already exist: it is ignored).
    pub(super) fn check_robot_place(
        &self,
        id: FieldRobotId,
        spec: &RobotSpec,
        pose: Pose,
    ) -> Result<(), SimError> {
        placement(id, pose, self.robot_refusal(id, spec, pose))
    }

    /// Refuses a place for box `id` (which may already exist: it is ignored).
    pub(super) fn check_box_place(
        &self,
        id: FieldBoxId,
        spec: &BoxSpec,
        pose: Pose,
    ) -> Result<(), SimError> {
        placement(id, pose, self.box_refusal(id, spec, pose))
    }

    fn robot_refusal(&self, id: FieldRobotId, spec: &RobotSpec, pose: Pose) -> Option<Refusal> {
        if !(pose.x.is_finite() && pose.y.is_finite() && pose.theta.is_finite()) {
            return Some(Refusal::NotFinite);
        }
        let c = pose.position();
        let r = spec.radius;
        let reach = Vec2::new(r, r);
        if let Some(refusal) = self.terrain_refusal(c - reach, c + reach, spec.amphibious, |cell| {
            cell.overlaps_disc(c, r)
        }) {
            return Some(refusal);
        }
        for k in self.robots_near(c, r, id.0) {
            let other = &self.robots[k];
            if other.pose.position().distance(c) < r + other.spec.radius {
                return Some(Refusal::Robot(FieldRobotId(k)));
            }
        }
        for (k, b) in self.boxes.iter().enumerate() {
            if box_obb(&b.spec, b.pose).overlaps_disc(c, r) {
                return Some(Refusal::Box(FieldBoxId(k)));
            }
        }
        None
    }

    fn box_refusal(&self, id: FieldBoxId, spec: &BoxSpec, pose: Pose) -> Option<Refusal> {
        if !(pose.x.is_finite() && pose.y.is_finite() && pose.theta.is_finite()) {
            return Some(Refusal::NotFinite);
        }
        let obb = box_obb(spec, pose);
        let (lo, hi) = obb.bounds();
        if let Some(refusal) = self.terrain_refusal(lo, hi, false, |cell| cell.overlaps(&obb)) {
            return Some(refusal);
        }
        let centre = (lo + hi) * 0.5;
        let reach = (hi.x - lo.x).max(hi.y - lo.y) * 0.5;
        for k in self.robots_near(centre, reach, usize::MAX) {
            let r = &self.robots[k];
            if obb.overlaps_disc(r.pose.position(), r.spec.radius) {
                return Some(Refusal::Robot(FieldRobotId(k)));
            }
        }
        for (k, b) in self.boxes.iter().enumerate() {
            if k != id.0 && box_obb(&b.spec, b.pose).overlaps(&obb) {
                return Some(Refusal::Box(FieldBoxId(k)));
            }
        }
        None
    }

    /// The first cell between `lo` and `hi` (a body's bounding box) that `overlaps`
    /// says the body meets and that stops it, or [`Refusal::OffMap`] if the box
    /// leaves the map.
    fn terrain_refusal(
        &self,
        lo: Vec2,
        hi: Vec2,
        amphibious: bool,
        overlaps: impl Fn(&Obb) -> bool,
    ) -> Option<Refusal> {
        let size = self.map.size_cm();
        if !(lo.x >= 0.0 && lo.y >= 0.0 && hi.x <= size.x && hi.y <= size.y) {
            return Some(Refusal::OffMap);
        }
        let cell = self.map.cell_cm();
        let (w, h) = (self.map.width(), self.map.height());
        let i0 = ((lo.x / cell) as usize).min(w - 1);
        let i1 = ((hi.x / cell) as usize).min(w - 1);
        let j0 = ((lo.y / cell) as usize).min(h - 1);
        let j1 = ((hi.y / cell) as usize).min(h - 1);
        // Top row first, so the cell reported is the first in map order.
        for j in (j0..=j1).rev() {
            for i in i0..=i1 {
                let terrain = self.map.terrain_ij(i as i64, j as i64);
                let stops = match terrain {
                    Terrain::Open => false,
                    Terrain::Blocked => true,
                    Terrain::Water => !amphibious,
                };
                let rect = Obb::aligned(
                    Vec2::new(i as f64 * cell, j as f64 * cell),
                    Vec2::new((i + 1) as f64 * cell, (j + 1) as f64 * cell),
                );
                if stops && overlaps(&rect) {
                    let (x, y) = (i, h - 1 - j);
                    return Some(if terrain == Terrain::Water {
                        Refusal::Water { x, y }
                    } else {
                        Refusal::Blocked { x, y }
                    });
                }
            }
        }
        None
    }
}

pub(super) fn box_obb(spec: &BoxSpec, pose: Pose) -> Obb {
    Obb::from_pose(pose, Vec2::new(spec.half_length, spec.half_width))
}
