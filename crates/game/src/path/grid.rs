//! The search graph every planner here shares: the map reduced to one byte
//! per cell, padded so that neighbour lookups need no bounds checks.
//!
//! Each cell holds a *class*: 0 for impassable, otherwise a number such that
//! a unit may step between two cells exactly when both have the same nonzero
//! class. This one rule expresses all three movers (see [`Mover`]), and it
//! makes every query a plain boolean grid over the start's class, which is
//! what lets jump point search run on maps with water.

use crate::map::{Cell, GridMap, Terrain};

use super::Mover;

/// `sqrt(2)`, the cost of a diagonal step.
pub(crate) const SQRT2: f64 = std::f64::consts::SQRT_2;

/// The class of `terrain` for `mover`: 0 impassable, else cells of equal
/// class connect.
pub(crate) fn class_of(terrain: Terrain, mover: Mover) -> u8 {
    match (terrain, mover) {
        (Terrain::Open | Terrain::Swamp, _) => 1,
        (Terrain::Water, Mover::Amphibious) => 1,
        (Terrain::Water, Mover::Benchmark) => 2,
        _ => 0,
    }
}

/// A path cost as counts of straight and diagonal steps, worth
/// `straight + diagonal * sqrt(2)`.
///
/// Summing floats makes equal costs reached by different paths differ in the
/// last bits, which defeats tie-breaking: on open ground A* then expands the
/// whole plateau of equal-`f` cells instead of running straight to the
/// goal. As `sqrt(2)` is irrational, equal costs have equal counts, and the
/// same counts always convert to the same float.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Cost {
    pub straight: u32,
    pub diagonal: u32,
}

impl Cost {
    pub const ZERO: Cost = Cost {
        straight: 0,
        diagonal: 0,
    };
    pub const STRAIGHT: Cost = Cost {
        straight: 1,
        diagonal: 0,
    };
    pub const DIAGONAL: Cost = Cost {
        straight: 0,
        diagonal: 1,
    };
    /// "No path": absorbs anything added to it.
    pub const INFINITE: Cost = Cost {
        straight: u32::MAX,
        diagonal: u32::MAX,
    };

    /// The length, with [`Cost::INFINITE`] as infinity.
    #[inline]
    pub fn length(self) -> f64 {
        if self == Cost::INFINITE {
            f64::INFINITY
        } else {
            self.value()
        }
    }

    /// The cost as a length.
    #[inline]
    pub fn value(self) -> f64 {
        f64::from(self.straight) + SQRT2 * f64::from(self.diagonal)
    }

    /// The sum (saturating; no path on a 2^16-sided map comes near).
    #[inline]
    pub fn plus(self, other: Cost) -> Cost {
        Cost {
            straight: self.straight.saturating_add(other.straight),
            diagonal: self.diagonal.saturating_add(other.diagonal),
        }
    }

    /// The octile distance for offsets `dx`, `dy`.
    #[inline]
    pub fn octile(dx: u32, dy: u32) -> Cost {
        let (lo, hi) = if dx < dy { (dx, dy) } else { (dy, dx) };
        Cost {
            straight: hi - lo,
            diagonal: lo,
        }
    }
}

/// The map as classes on a grid with a one-cell border of class 0.
#[derive(Debug, Clone)]
pub(crate) struct ClassGrid {
    /// Padded row length (`width + 2`).
    pub stride: usize,
    pub width: u32,
    pub height: u32,
    pub class: Vec<u8>,
    /// Index offsets of the 8 neighbours: E, W, S, N, then SE, SW, NE, NW,
    /// so diagonal `4 + k` is straight `DIAG_PARTS[k]` combined.
    pub offsets: [isize; 8],
}

/// The two straight directions each diagonal (4..8) is made of.
pub(crate) const DIAG_PARTS: [(usize, usize); 4] = [(0, 2), (1, 2), (0, 3), (1, 3)];

/// Cost of a step in each direction, in the order of [`ClassGrid::offsets`].
pub(crate) const STEP: [Cost; 8] = [
    Cost::STRAIGHT,
    Cost::STRAIGHT,
    Cost::STRAIGHT,
    Cost::STRAIGHT,
    Cost::DIAGONAL,
    Cost::DIAGONAL,
    Cost::DIAGONAL,
    Cost::DIAGONAL,
];

impl ClassGrid {
    pub fn new(map: &GridMap, mover: Mover) -> ClassGrid {
        let (width, height) = (map.width(), map.height());
        let stride = width as usize + 2;
        let mut class = vec![0u8; stride * (height as usize + 2)];
        if width > 0 {
            for (y, row) in map.cells().chunks(width as usize).enumerate() {
                let base = (y + 1) * stride + 1;
                for (slot, &t) in class[base..base + row.len()].iter_mut().zip(row) {
                    *slot = class_of(t, mover);
                }
            }
        }
        let s = stride as isize;
        ClassGrid {
            stride,
            width,
            height,
            class,
            offsets: [1, -1, s, -s, s + 1, s - 1, -s + 1, -s - 1],
        }
    }

    /// Cells in the padded grid.
    pub fn len(&self) -> usize {
        self.class.len()
    }

    /// The padded index of `cell`, or `None` off the map.
    #[inline]
    pub fn index(&self, cell: Cell) -> Option<usize> {
        (cell.x < self.width && cell.y < self.height)
            .then(|| (cell.y as usize + 1) * self.stride + cell.x as usize + 1)
    }

    /// The cell at a padded index inside the map.
    #[inline]
    pub fn cell(&self, i: usize) -> Cell {
        Cell {
            x: (i % self.stride) as u32 - 1,
            y: (i / self.stride) as u32 - 1,
        }
    }

    /// Padded column and row of an index (cheaper than [`ClassGrid::cell`]
    /// where only differences matter).
    #[inline]
    pub fn xy(&self, i: usize) -> (u32, u32) {
        ((i % self.stride) as u32, (i / self.stride) as u32)
    }

    /// Octile distance between two padded indices.
    #[inline]
    pub fn distance(&self, a: usize, b: usize) -> f64 {
        self.octile_cost(a, b).value()
    }

    /// Octile distance between two padded indices, as exact counts.
    #[inline]
    pub fn octile_cost(&self, a: usize, b: usize) -> Cost {
        let (ax, ay) = self.xy(a);
        let (bx, by) = self.xy(b);
        Cost::octile(ax.abs_diff(bx), ay.abs_diff(by))
    }

    /// The neighbour of `i` in direction `dir`. Callers only pass indices
    /// inside the map, whose neighbours all lie in the padded grid.
    #[inline]
    pub fn step(&self, i: usize, dir: usize) -> usize {
        i.wrapping_add_signed(self.offsets[dir])
    }

    /// Which of the 8 moves out of `i` are legal, as a bit mask over the
    /// directions of [`ClassGrid::offsets`]: the target has `i`'s class, and
    /// for a diagonal both orthogonally adjacent cells do too (no corner
    /// cutting).
    #[inline]
    pub fn moves(&self, i: usize) -> u8 {
        let k = self.class[i];
        if k == 0 {
            return 0;
        }
        let mut m = 0u8;
        for dir in 0..4 {
            if self.class[self.step(i, dir)] == k {
                m |= 1 << dir;
            }
        }
        for (d, &(a, b)) in DIAG_PARTS.iter().enumerate() {
            let dir = 4 + d;
            if m & (1 << a) != 0 && m & (1 << b) != 0 && self.class[self.step(i, dir)] == k {
                m |= 1 << dir;
            }
        }
        m
    }
}
