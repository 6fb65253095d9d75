//! Battlefield maps: the terrain grid, and where each team's base, flag and
//! spawn area are.
//!
//! The grid is stored in the Moving AI Lab's `.map` format so that the public
//! path-finding benchmarks (and the tools that read them) work on our maps
//! unchanged, and so our path finder can be checked against theirs. A map file
//! is:
//!
//! ```text
//! type octile
//! height 3
//! width 5
//! map
//! @@@@@
//! @.TW@
//! @@@@@
//! ```
//!
//! Terrain characters: `.` `G` open ground, `S` swamp (passable, same cost),
//! `T` trees, `@` `O` out of bounds, `W` water. Cells are addressed as in
//! Moving AI `.scen` files: `x` is the column, `y` the row, row 0 the first map
//! row in the file.
//!
//! # The battlefield extension
//!
//! The game needs more than terrain, so a map may go on after its last grid
//! row with lines that Moving AI tools never read (they stop after `height`
//! rows):
//!
//! ```text
//! # a comment: anything after `#` on a line of its own
//! cell 20
//! team red base 5 40 flag 6 42 spawn 3 38
//! team blue base 58 5 flag 57 4 spawn 60 7
//! ```
//!
//! - `cell SIDE`: the side of one cell in centimetres (a positive number; at
//!   most one such line; 20 when absent).
//! - `team NAME base X Y flag X Y spawn X Y`: one line per team, the three
//!   sites in that order, in cell coordinates. `NAME` is letters, digits, `_`
//!   or `-`, unique in the file. Every site must lie on the map, on open or
//!   swamp ground (not water: robots spawn and flags stand on land).
//! - Blank lines and `#` comment lines may appear anywhere after the grid.
//!
//! Anything else after the grid is an error rather than being ignored, so a
//! typo in a team line, or a map with more rows than its header says, is
//! reported instead of silently dropped. Every error gives the 1-based line
//! and column and says what was expected, e.g.
//! `line 7, column 13: expected one of . G @ O T S W, found 'x'`.
//!
//! # World coordinates
//!
//! The simulator works in centimetres with `y` up and the origin at the map's
//! bottom-left corner, while files count rows downwards;
//! [`Battlefield::cell_center`] and [`Battlefield::cell_at`] convert.

mod battlefield;
mod error;
mod grid;
mod parse;
mod shipped;

pub use battlefield::{Battlefield, TeamSite, DEFAULT_CELL_CM};
pub use error::{MapError, Problem};
pub use grid::{Cell, GridMap, Terrain};
pub use shipped::shipped_map;

#[cfg(test)]
mod tests;
