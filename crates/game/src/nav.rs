//! Navigation in centimetres: the swarm intelligence's view of path finding.
//! Plans on the battlefield's cells and hands back turn points in the world
//! frame, snapping points that fall on obstacles to the nearest free cell.

use std::collections::VecDeque;
use std::sync::Arc;

use colony_sim::Vec2;

use crate::map::{Battlefield, Cell};
use crate::path::{self, Algorithm, Mover, Planner, Replanner};

/// Clearance kept between a straight leg and any impassable cell, in cells:
/// with the shipped maps' 25 cm cells that is 11 cm, against a largest robot
/// radius of 6.5 cm.
pub const CLEARANCE_CELLS: f64 = 0.45;

/// Path finding for one battlefield, with reusable search buffers.
pub struct Nav {
    field: Arc<Battlefield>,
    land: Planner,
    amphibious: Planner,
}

impl Nav {
    /// Navigation on `field`.
    pub fn new(field: Arc<Battlefield>) -> Nav {
        Nav {
            land: Planner::new(&field.grid, Mover::Land),
            amphibious: Planner::new(&field.grid, Mover::Amphibious),
            field,
        }
    }

    fn planner(&mut self, mover: Mover) -> &mut Planner {
        match mover {
            Mover::Amphibious => &mut self.amphibious,
            _ => &mut self.land,
        }
    }

    fn passable(&self, mover: Mover, c: Cell) -> bool {
        match mover {
            Mover::Amphibious => self.amphibious.passable(c),
            _ => self.land.passable(c),
        }
    }

    /// The battlefield.
    pub fn field(&self) -> &Arc<Battlefield> {
        &self.field
    }

    /// The cell under a point, if it is on the map.
    pub fn cell(&self, p: Vec2) -> Option<Cell> {
        self.field.cell_at(p.x, p.y)
    }

    /// A cell's centre.
    pub fn centre(&self, c: Cell) -> Vec2 {
        let (x, y) = self.field.cell_center(c);
        Vec2::new(x, y)
    }

    /// Whether `mover` may stand on the point.
    pub fn is_free(&self, p: Vec2, mover: Mover) -> bool {
        self.cell(p).is_some_and(|c| self.passable(mover, c))
    }

    /// Whether a body of `radius` cm centred on `p` touches only cells
    /// `mover` may enter: a formation slot must leave room for the robot, not
    /// just have its centre on open ground.
    pub fn has_room(&self, p: Vec2, mover: Mover, radius: f64) -> bool {
        let d = radius * std::f64::consts::FRAC_1_SQRT_2;
        self.is_free(p, mover)
            && [
                (radius, 0.0),
                (-radius, 0.0),
                (0.0, radius),
                (0.0, -radius),
                (d, d),
                (d, -d),
                (-d, d),
                (-d, -d),
            ]
            .iter()
            .all(|&(dx, dy)| self.is_free(p + Vec2::new(dx, dy), mover))
    }

    /// The free cell nearest to `p` (breadth-first over the grid, at most
    /// `limit` cells searched), or None.
    pub fn nearest_free(&self, p: Vec2, mover: Mover) -> Option<Cell> {
        let grid = &self.field.grid;
        let (w, h) = (grid.width() as i64, grid.height() as i64);
        let fx = (p.x / self.field.cell_cm).floor() as i64;
        let fy = h - 1 - (p.y / self.field.cell_cm).floor() as i64;
        let start = (fx.clamp(0, w - 1), fy.clamp(0, h - 1));
        let mut seen = std::collections::HashSet::from([start]);
        let mut queue = VecDeque::from([start]);
        let limit = 200_000;
        while let Some((x, y)) = queue.pop_front() {
            let c = Cell::new(x as u32, y as u32);
            if self.passable(mover, c) {
                return Some(c);
            }
            if seen.len() > limit {
                return None;
            }
            for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                let n = (x + dx, y + dy);
                if n.0 >= 0 && n.1 >= 0 && n.0 < w && n.1 < h && seen.insert(n) {
                    queue.push_back(n);
                }
            }
        }
        None
    }

    /// The turn points of an optimal path from `from` to `to` for `mover`,
    /// both ends snapped to free cells; the first point is the start cell's
    /// centre, the last the goal cell's. None when there is no way.
    pub fn plan(&mut self, from: Vec2, to: Vec2, mover: Mover) -> Option<Vec<Vec2>> {
        let a = self.nearest_free(from, mover)?;
        let b = self.nearest_free(to, mover)?;
        // Land and water are both uniform-cost, where Jump Point Search is optimal.
        let found = self.planner(mover).find(Algorithm::Jps, a, b)?;
        Some(self.points(&found, mover))
    }

    /// A passable route from `from` through a player's drawn `points`, for `mover`: each point
    /// that lies in water or a wall (water is fine for an amphibian) is moved to the nearest
    /// passable cell, and a leg that crosses water or walls becomes the optimal way round. None
    /// when some point cannot be reached at all.
    pub fn route(&mut self, from: Vec2, points: &[Vec2], mover: Mover) -> Option<Vec<Vec2>> {
        let mut route = vec![self.centre(self.nearest_free(from, mover)?)];
        // A hand's stroke has a point every few centimetres; a cell apart is plenty to steer
        // by, and each point is a waypoint for every robot of the formation.
        let spacing = self.field.cell_cm;
        let last = points.len().saturating_sub(1);
        for (k, &p) in points.iter().enumerate() {
            if k < last && route.last().is_some_and(|r| r.distance(p) < spacing) {
                continue;
            }
            let to = if self.is_free(p, mover) {
                p
            } else {
                self.centre(self.nearest_free(p, mover)?)
            };
            let at = *route.last()?;
            if at.distance(to) < 1.0 {
                continue;
            }
            if self.line_of_sight(at, to, mover) {
                route.push(to);
            } else {
                let way = self.plan(at, to, mover)?;
                route.extend(way.into_iter().skip(1));
                // The plan ends at the cell's centre; the drawn point is where the player meant.
                if let Some(last) = route.last_mut() {
                    *last = to;
                }
            }
        }
        Some(route)
    }

    /// A path's turn points in centimetres.
    pub fn points(&self, found: &path::Path, mover: Mover) -> Vec<Vec2> {
        path::turn_points(&self.field.grid, mover, found, CLEARANCE_CELLS)
            .into_iter()
            .map(|(x, y)| self.continuous(x, y))
            .collect()
    }

    /// Cell coordinates (x right, y down, cell centre at +0.5) to centimetres.
    fn continuous(&self, x: f64, y: f64) -> Vec2 {
        let c = self.field.cell_cm;
        Vec2::new(x * c, (self.field.grid.height() as f64 - y) * c)
    }

    /// Whether a robot can drive straight from `a` to `b`.
    pub fn line_of_sight(&self, a: Vec2, b: Vec2, mover: Mover) -> bool {
        let c = self.field.cell_cm;
        let h = self.field.grid.height() as f64;
        let cell = |p: Vec2| (p.x / c, h - p.y / c);
        path::line_of_sight(&self.field.grid, mover, cell(a), cell(b), CLEARANCE_CELLS)
    }

    /// A replanner from `from` to `to` that reuses its search as the goal moves.
    pub fn replanner(&self, from: Vec2, to: Vec2, mover: Mover) -> Option<Replanner> {
        let a = self.nearest_free(from, mover)?;
        let b = self.nearest_free(to, mover)?;
        Some(Replanner::new(&self.field.grid, mover, a, b))
    }
}
