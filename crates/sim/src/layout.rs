//! Random initial layouts: uniform positions without overlaps, clear of the walls.

use std::collections::HashMap;

use rand::Rng;

use crate::arena::Arena;
use crate::body::RobotGeometry;
use crate::config::SceneConfig;
use crate::error::SimError;
use crate::types::{Pose, Vec2};

/// Gap kept between bodies (and between bodies and walls) by random layouts, cm.
pub(crate) const LAYOUT_GAP: f64 = 0.5;

/// Tries per body before a random layout gives up.
pub(crate) const LAYOUT_TRIES: usize = 10_000;

pub(crate) fn crowded(what: &str, i: usize, n: usize) -> SimError {
    SimError::Layout(format!(
        "could not place {what} {} of {n} clear of the walls and the others after {LAYOUT_TRIES} tries: the arena is too crowded",
        i + 1
    ))
}

/// A uniformly random point at least `radius` (+ a gap) inside the walls that `ok` accepts.
pub(crate) fn sample<R: Rng + ?Sized>(
    arena: &Arena,
    radius: f64,
    rng: &mut R,
    ok: impl Fn(Vec2) -> bool,
) -> Option<Vec2> {
    let (hw, hh) = (arena.half_width(), arena.half_height());
    (0..LAYOUT_TRIES).find_map(|_| {
        let p = Vec2::new(rng.random_range(-hw..hw), rng.random_range(-hh..hh));
        (arena.contains(p, radius + LAYOUT_GAP) && ok(p)).then_some(p)
    })
}

/// Points placed so far, bucketed by square cells as wide as the clearance kept between
/// them, so whether a new point is clear of them all is a look at the 3 x 3 cells around
/// it: placing N bodies costs O(N), not O(N^2). The cells are hashed, so memory follows
/// the points, not the arena.
struct Placed {
    clear: f64,
    cell: f64,
    cells: HashMap<(i64, i64), Vec<Vec2>>,
}

impl Placed {
    fn new(clear: f64) -> Placed {
        Placed {
            clear,
            // A hair wider than the clearance, so rounding in `cell` cannot put two points
            // closer than it two cells apart.
            cell: clear * (1.0 + 1e-9),
            cells: HashMap::new(),
        }
    }

    fn cell(&self, p: Vec2) -> (i64, i64) {
        (
            (p.x / self.cell).floor() as i64,
            (p.y / self.cell).floor() as i64,
        )
    }

    /// Whether `p` is at least the clearance from every point placed.
    fn clear_of(&self, p: Vec2) -> bool {
        let (cx, cy) = self.cell(p);
        (cx - 1..=cx + 1).all(|x| {
            (cy - 1..=cy + 1).all(|y| {
                self.cells
                    .get(&(x, y))
                    .is_none_or(|pts| pts.iter().all(|q| q.distance(p) >= self.clear))
            })
        })
    }

    fn insert(&mut self, p: Vec2) {
        let c = self.cell(p);
        self.cells.entry(c).or_default().push(p);
    }
}

/// Robots at uniformly random places clear of the walls and of each other (as bounding
/// circles), headings uniform.
pub(crate) fn sample_robots<R: Rng + ?Sized>(
    cfg: &SceneConfig,
    arena: &Arena,
    geometry: &RobotGeometry,
    rng: &mut R,
) -> Result<Vec<Pose>, SimError> {
    let r = geometry.bounding_radius;
    let mut placed = Placed::new(2.0 * r + LAYOUT_GAP);
    let mut out = Vec::with_capacity(cfg.robots.count);
    for i in 0..cfg.robots.count {
        let p = sample(arena, r, rng, |p| placed.clear_of(p))
            .ok_or_else(|| crowded("robot", i, cfg.robots.count))?;
        placed.insert(p);
        let theta = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        out.push(Pose {
            x: p.x,
            y: p.y,
            theta,
        });
    }
    Ok(out)
}

/// Random puck positions clear of the walls, of robots (as bounding circles) and of each other.
pub(crate) fn sample_pucks<R: Rng + ?Sized>(
    cfg: &SceneConfig,
    arena: &Arena,
    geometry: &RobotGeometry,
    robots: &[Vec2],
    rng: &mut R,
) -> Result<Vec<Vec2>, SimError> {
    let rp = cfg.puck_radius();
    let mut near_robots = Placed::new(geometry.bounding_radius + rp + LAYOUT_GAP);
    for &r in robots {
        near_robots.insert(r);
    }
    let mut placed = Placed::new(2.0 * rp + LAYOUT_GAP);
    let mut out: Vec<Vec2> = Vec::with_capacity(cfg.pucks.count);
    for i in 0..cfg.pucks.count {
        let p = sample(arena, rp, rng, |p| {
            near_robots.clear_of(p) && placed.clear_of(p)
        })
        .ok_or_else(|| crowded("puck", i, cfg.pucks.count))?;
        placed.insert(p);
        out.push(p);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placed_points_keep_their_clearance_across_cell_borders() {
        let mut placed = Placed::new(2.0);
        placed.insert(Vec2::new(1.99, 0.0));
        assert!(!placed.clear_of(Vec2::new(2.01, 0.0)));
        assert!(!placed.clear_of(Vec2::new(0.0, 0.0)));
        assert!(placed.clear_of(Vec2::new(3.99, 0.0)));
        assert!(placed.clear_of(Vec2::new(-0.02, 0.0)));
        placed.insert(Vec2::new(-5.0, -5.0));
        assert!(!placed.clear_of(Vec2::new(-6.0, -4.0)));
        assert!(placed.clear_of(Vec2::new(-2.0, -2.0)));
    }
}
