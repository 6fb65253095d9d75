//! Optimal path finding on battlefield grids, and what a robot needs to
//! drive the result.
//!
//! Movement follows the Moving AI benchmarks (so our planners can be checked
//! against their published optimal lengths): 8-connected, cost 1 for a
//! straight step and `sqrt(2)` for a diagonal one, and a diagonal step only
//! when both cells beside it are passable too (no corner cutting, so a robot
//! never clips the corner of a tree or a wall).
//!
//! Which terrain is passable depends on the [`Mover`]. Internally each cell
//! gets a class and steps join only cells of the same class; the Moving AI
//! rule "water is entered only from water" becomes "land and water are two
//! classes", which is how their reference code (HOG2's `Map::CanStep`)
//! decides it. So under [`Mover::Benchmark`] a diagonal step needs all four
//! cells of its 2 x 2 block on the same side of the shore, and no query ever
//! mixes land and water.
//!
//! - [`Planner`]: A* and jump point search, reusing memory across queries.
//! - [`Replanner`]: incremental replanning when the goal moves or cells get
//!   blocked.
//! - [`turn_points`] and [`line_of_sight`]: from cells to a drivable route.
//! - [`scen`]: Moving AI benchmark scenario files.

pub mod check;
mod grid;
mod jps;
mod planner;
mod replan;
pub mod scen;
mod smooth;

pub use planner::Planner;
pub use replan::Replanner;
pub use smooth::{line_of_sight, turn_points};

use crate::map::{Cell, GridMap};

/// Who is moving, which decides what terrain is passable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Mover {
    /// The Moving AI convention: open ground and swamp connect; water
    /// connects only to water (a unit in water stays in water); trees and
    /// out of bounds are blocked. For reproducing benchmark results.
    Benchmark,
    /// A ground robot (scout, tank, infantry): open ground and swamp only.
    Land,
    /// A unit that also crosses water, at the same cost as land.
    Amphibious,
}

/// Which one-shot search [`Planner::find`] runs. Both are optimal and give
/// the same lengths; they may pick different paths among equally short ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Algorithm {
    /// A* with the octile heuristic.
    AStar,
    /// Jump point search: the same answers, usually several times faster.
    /// Valid for every [`Mover`] (see the module docs).
    #[default]
    Jps,
}

impl Algorithm {
    /// The fastest algorithm that is valid for `mover`: jump point search
    /// for all of them, since every query is on a uniform-cost grid.
    pub fn fastest(mover: Mover) -> Algorithm {
        let _ = mover;
        Algorithm::Jps
    }
}

/// A path: every cell from start to goal inclusive, each a single straight
/// or diagonal step from the one before.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    /// The cells, start first.
    pub cells: Vec<Cell>,
    /// The cost: 1 per straight step, `sqrt(2)` per diagonal one.
    pub length: f64,
}

impl Path {
    /// The empty trip: start equals goal.
    pub(crate) fn single(cell: Cell) -> Path {
        Path {
            cells: vec![cell],
            length: 0.0,
        }
    }
}

/// A* once on `map`; for many queries keep a [`Planner`].
pub fn astar(map: &GridMap, mover: Mover, start: Cell, goal: Cell) -> Option<Path> {
    Planner::new(map, mover).astar(start, goal)
}

/// Jump point search once on `map`; for many queries keep a [`Planner`].
pub fn jps(map: &GridMap, mover: Mover, start: Cell, goal: Cell) -> Option<Path> {
    Planner::new(map, mover).jps(start, goal)
}
