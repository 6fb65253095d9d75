//! Random initial layouts: uniform positions without overlaps, clear of the walls.

use rand::Rng;

use crate::arena::Arena;
use crate::body::RobotGeometry;
use crate::config::SceneConfig;
use crate::error::SimError;
use crate::types::Vec2;

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

/// Random puck positions clear of the walls, of robots (as bounding circles) and of each other.
pub(crate) fn sample_pucks<R: Rng + ?Sized>(
    cfg: &SceneConfig,
    arena: &Arena,
    geometry: &RobotGeometry,
    robots: &[Vec2],
    rng: &mut R,
) -> Result<Vec<Vec2>, SimError> {
    let rp = cfg.puck_radius();
    let clear_robot = geometry.bounding_radius + rp + LAYOUT_GAP;
    let clear_puck = 2.0 * rp + LAYOUT_GAP;
    let mut out: Vec<Vec2> = Vec::new();
    for i in 0..cfg.pucks.count {
        let p = sample(arena, rp, rng, |p| {
            robots.iter().all(|r| r.distance(p) >= clear_robot)
                && out.iter().all(|q| q.distance(p) >= clear_puck)
        })
        .ok_or_else(|| crowded("puck", i, cfg.pucks.count))?;
        out.push(p);
    }
    Ok(out)
}
