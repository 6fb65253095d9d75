//! Jump point search for grids without corner cutting.
//!
//! On a uniform-cost grid most optimal paths are symmetric variants of each
//! other; JPS (Harabor and Grastien, 2011) keeps one canonical variant by
//! scanning straight and diagonal runs without putting their cells on the
//! open list, stopping only at "jump points" where a path may have to turn.
//! Forbidding corner cutting changes the rules of the original paper:
//!
//! - a diagonal step needs both orthogonally adjacent cells open, so a
//!   diagonal run never has forced neighbours; it stops where one of its two
//!   straight sub-scans finds a jump point;
//! - a straight run stops at a cell with an open side cell whose neighbour
//!   behind it (beside the previous cell) is blocked: from there the side and
//!   forward-diagonal cells can be reached optimally only through this cell.
//!
//! JPS needs every passable cell to cost the same and every step between
//! passable cells to be allowed. Our graph has that shape per query: steps
//! only join cells of one class (see the `grid` module), so the search runs on
//! the boolean grid "same class as the start". Under [`Mover::Benchmark`]
//! that is land for a land start and water for a water start, exactly the
//! Moving AI rule that `W` is entered only from `W`; there is no case where
//! it must fall back to A*.
//!
//! [`Mover::Benchmark`]: super::Mover::Benchmark

use crate::map::Cell;

use super::grid::{ClassGrid, DIAG_PARTS};
use super::planner::Planner;
use super::Path;

/// The straight scan from `i` in direction `dir` (0..4), over cells of
/// class `k`; the jump point where it stops, if any.
#[inline]
fn jump_straight(grid: &ClassGrid, mut i: usize, dir: usize, k: u8, t: usize) -> Option<usize> {
    let d = grid.offsets[dir];
    // The two side directions: N/S for E/W scans and E/W for N/S scans.
    let (sa, sb) = if dir < 2 {
        (grid.offsets[2], grid.offsets[3])
    } else {
        (grid.offsets[0], grid.offsets[1])
    };
    let c = &grid.class;
    loop {
        let n = i.wrapping_add_signed(d);
        if c[n] != k {
            return None;
        }
        if n == t {
            return Some(n);
        }
        let forced = (c[n.wrapping_add_signed(sa)] == k && c[i.wrapping_add_signed(sa)] != k)
            || (c[n.wrapping_add_signed(sb)] == k && c[i.wrapping_add_signed(sb)] != k);
        if forced {
            return Some(n);
        }
        i = n;
    }
}

/// The diagonal scan from `i` in direction `dir` (4..8).
#[inline]
fn jump_diagonal(grid: &ClassGrid, mut i: usize, dir: usize, k: u8, t: usize) -> Option<usize> {
    let (a, b) = DIAG_PARTS[dir - 4];
    let (da, db) = (grid.offsets[a], grid.offsets[b]);
    let c = &grid.class;
    loop {
        if c[i.wrapping_add_signed(da)] != k || c[i.wrapping_add_signed(db)] != k {
            return None;
        }
        let n = i.wrapping_add_signed(da + db);
        if c[n] != k {
            return None;
        }
        if n == t
            || jump_straight(grid, n, a, k, t).is_some()
            || jump_straight(grid, n, b, k, t).is_some()
        {
            return Some(n);
        }
        i = n;
    }
}

/// The direction (0..8) of the step from `p` towards `u`, which lie on one
/// straight or diagonal line.
#[inline]
fn direction(grid: &ClassGrid, p: usize, u: usize) -> usize {
    let (px, py) = grid.xy(p);
    let (ux, uy) = grid.xy(u);
    match (ux.cmp(&px), uy.cmp(&py)) {
        (std::cmp::Ordering::Greater, std::cmp::Ordering::Equal) => 0,
        (std::cmp::Ordering::Less, std::cmp::Ordering::Equal) => 1,
        (std::cmp::Ordering::Equal, std::cmp::Ordering::Greater) => 2,
        (std::cmp::Ordering::Equal, _) => 3,
        (std::cmp::Ordering::Greater, std::cmp::Ordering::Greater) => 4,
        (std::cmp::Ordering::Less, std::cmp::Ordering::Greater) => 5,
        (std::cmp::Ordering::Greater, _) => 6,
        (std::cmp::Ordering::Less, _) => 7,
    }
}

impl Planner {
    /// Optimal jump point search: the same lengths as [`Planner::astar`],
    /// usually with far fewer open-list operations.
    pub fn jps(&mut self, start: Cell, goal: Cell) -> Option<Path> {
        let (s, t) = self.endpoints(start, goal)?;
        if s == t {
            return Some(Path::single(start));
        }
        let k = self.grid.class[s];
        let open = self.begin(s, t);
        let closed = open + 1;
        while let Some(u) = self.expand_next(closed) {
            if u == t {
                return Some(self.trace(s, t));
            }
            let dirs = self.pruned(u, s, k);
            let gu = self.g[u];
            for dir in 0..8 {
                if dirs & (1 << dir) == 0 {
                    continue;
                }
                let found = if dir < 4 {
                    jump_straight(&self.grid, u, dir, k, t)
                } else {
                    jump_diagonal(&self.grid, u, dir, k, t)
                };
                let Some(v) = found else { continue };
                let ng = gu.plus(self.grid.octile_cost(u, v));
                let st = self.state[v];
                if st == closed || (st == open && ng.value() >= self.g[v].value()) {
                    continue;
                }
                self.relax(v, u, ng, t, open);
            }
        }
        None
    }

    /// The directions worth scanning from jump point `u`: all legal moves at
    /// the start; otherwise onward from the parent's direction, plus the
    /// turns its forced neighbours allow.
    fn pruned(&self, u: usize, s: usize, k: u8) -> u8 {
        let grid = &self.grid;
        if u == s {
            return grid.moves(u);
        }
        let dir = direction(grid, self.parent[u] as usize, u);
        if dir >= 4 {
            let (a, b) = DIAG_PARTS[dir - 4];
            return (1 << dir) | (1 << a) | (1 << b);
        }
        let (sides, back) = if dir < 2 {
            ([2, 3], dir ^ 1)
        } else {
            ([0, 1], dir ^ 1)
        };
        let behind = grid.step(u, back);
        let mut m = 1u8 << dir;
        for side in sides {
            if grid.class[grid.step(u, side)] == k && grid.class[grid.step(behind, side)] != k {
                m |= 1 << side;
                m |= 1 << diagonal(dir, side);
            }
        }
        m
    }
}

/// The diagonal direction made of straight directions `a` and `b`.
fn diagonal(a: usize, b: usize) -> usize {
    let pair = if a < b { (a, b) } else { (b, a) };
    match pair {
        (0, 2) => 4,
        (1, 2) => 5,
        (0, 3) => 6,
        _ => 7,
    }
}
