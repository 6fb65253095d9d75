//! Turn points: a grid path reduced to the few places where a robot must
//! turn, with straight segments between them that keep clear of obstacles.
//!
//! A grid path zigzags in 45-degree steps; a robot driving it would stop and
//! turn at every cell. Pulling the path straight wherever a robot of a given
//! radius fits ("string pulling") gives the route it should actually drive.
//!
//! Points are in continuous cell coordinates: cell `(x, y)` is the square
//! `[x, x+1] x [y, y+1]` (rows downward, as in the map file), its centre
//! `(x + 0.5, y + 0.5)`. `Battlefield::point_to_world` turns them into
//! centimetres.
//!
//! Clearance is exact, not sampled: a segment is clear when its distance to
//! every impassable cell's square is at least the clearance (and never zero,
//! so a segment may not even graze a blocked cell). Steps between adjacent
//! path cells keep at least half a cell from any obstacle, so clearances up
//! to 0.5 are always achievable; for a wider robot, plan on a map whose
//! obstacles were grown by its radius, or accept that narrow passages keep
//! every cell of the path as a turn point.

use crate::map::{Cell, GridMap};

use super::grid::class_of;
use super::{Mover, Path};

/// Slack for rounding in distance comparisons.
const EPS: f64 = 1e-9;

/// The turn points of `path` for a robot `clearance_cells` in radius: the
/// start cell's centre, each cell centre where the robot must turn, and the
/// goal cell's centre. Consecutive points are joined by segments that pass
/// [`line_of_sight`] whenever the path's own steps do.
///
/// ```
/// use colony_game::map::{Cell, GridMap, Terrain};
/// use colony_game::path::{astar, turn_points, Mover};
/// let map = GridMap::new(10, 3, Terrain::Open);
/// let path = astar(&map, Mover::Land, Cell::new(0, 1), Cell::new(9, 1)).unwrap();
/// assert_eq!(turn_points(&map, Mover::Land, &path, 0.4), vec![(0.5, 1.5), (9.5, 1.5)]);
/// ```
pub fn turn_points(
    map: &GridMap,
    mover: Mover,
    path: &Path,
    clearance_cells: f64,
) -> Vec<(f64, f64)> {
    let centre = |c: Cell| (f64::from(c.x) + 0.5, f64::from(c.y) + 0.5);
    let cells = &path.cells;
    let Some(&first) = cells.first() else {
        return Vec::new();
    };
    let mut points = vec![centre(first)];
    let mut anchor = 0;
    let mut i = 1;
    while i < cells.len() {
        if line_of_sight(
            map,
            mover,
            centre(cells[anchor]),
            centre(cells[i]),
            clearance_cells,
        ) {
            i += 1;
            continue;
        }
        // The last cell still in sight becomes a turn point; if even the
        // next step is too tight, keep that step as it is.
        let turn = if i - 1 > anchor { i - 1 } else { i };
        points.push(centre(cells[turn]));
        anchor = turn;
        i = turn + 1;
    }
    let last = centre(cells[cells.len() - 1]);
    if cells.len() > 1 && points.last() != Some(&last) {
        points.push(last);
    }
    points
}

/// Whether a robot of radius `clearance` (in cells) can drive straight from
/// `a` to `b` (continuous cell coordinates) as `mover`: every cell it could
/// touch is passable and of the same kind as the cell under `a` (under
/// [`Mover::Benchmark`], land and water do not mix). A negative or non-finite
/// clearance, or a point off the map, gives `false`.
pub fn line_of_sight(
    map: &GridMap,
    mover: Mover,
    a: (f64, f64),
    b: (f64, f64),
    clearance: f64,
) -> bool {
    let finite = a.0.is_finite() && a.1.is_finite() && b.0.is_finite() && b.1.is_finite();
    if !(finite && clearance >= 0.0 && clearance.is_finite()) {
        return false;
    }
    let at = |x: f64, y: f64| -> Option<u8> {
        if x < 0.0 || y < 0.0 {
            return None;
        }
        let t = map.get(x.floor() as u32, y.floor() as u32)?;
        Some(class_of(t, mover))
    };
    let Some(k) = at(a.0, a.1).filter(|&k| k != 0) else {
        return false;
    };
    let blocked = |cx: i64, cy: i64| -> bool {
        if cx < 0 || cy < 0 || cx >= i64::from(map.width()) || cy >= i64::from(map.height()) {
            return true;
        }
        map.get(cx as u32, cy as u32)
            .is_none_or(|t| class_of(t, mover) != k)
    };
    // Visit, column by column, the cells within `reach` of the segment.
    let reach = clearance + EPS;
    let (x0, x1) = (a.0.min(b.0), a.0.max(b.0));
    let y_at = |x: f64| -> f64 {
        if (b.0 - a.0).abs() < 1e-12 {
            a.1
        } else {
            a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
        }
    };
    let first_col = (x0 - reach).floor() as i64;
    let last_col = (x1 + reach).floor() as i64;
    for cx in first_col..=last_col {
        let lo = (cx as f64 - reach).max(x0);
        let hi = (cx as f64 + 1.0 + reach).min(x1);
        let (ya, yb) = if lo > hi {
            // The column is beside the segment's x range: nearest endpoint.
            let y = if (cx as f64) < x0 { y_at(x0) } else { y_at(x1) };
            (y, y)
        } else if (b.0 - a.0).abs() < 1e-12 {
            (a.1.min(b.1), a.1.max(b.1))
        } else {
            (y_at(lo), y_at(hi))
        };
        let first_row = (ya.min(yb) - reach).floor() as i64;
        let last_row = (ya.max(yb) + reach).floor() as i64;
        for cy in first_row..=last_row {
            if blocked(cx, cy) {
                let d = segment_square_distance(a, b, cx as f64, cy as f64);
                if d < clearance - EPS || d <= EPS {
                    return false;
                }
            }
        }
    }
    true
}

/// Distance from segment `a`-`b` to the unit square with corner `(sx, sy)`.
fn segment_square_distance(a: (f64, f64), b: (f64, f64), sx: f64, sy: f64) -> f64 {
    if segment_hits_box(a, b, sx, sy) {
        return 0.0;
    }
    // Apart, convex shapes are nearest at a vertex of one of them.
    let corners = [
        (sx, sy),
        (sx + 1.0, sy),
        (sx, sy + 1.0),
        (sx + 1.0, sy + 1.0),
    ];
    let mut d = point_box_distance(a, sx, sy).min(point_box_distance(b, sx, sy));
    for c in corners {
        d = d.min(point_segment_distance(c, a, b));
    }
    d
}

fn point_box_distance(p: (f64, f64), sx: f64, sy: f64) -> f64 {
    let dx = (sx - p.0).max(0.0).max(p.0 - sx - 1.0);
    let dy = (sy - p.1).max(0.0).max(p.1 - sy - 1.0);
    dx.hypot(dy)
}

fn point_segment_distance(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (vx, vy) = (b.0 - a.0, b.1 - a.1);
    let len2 = vx * vx + vy * vy;
    let t = if len2 > 0.0 {
        (((p.0 - a.0) * vx + (p.1 - a.1) * vy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p.0 - a.0 - t * vx).hypot(p.1 - a.1 - t * vy)
}

/// Liang-Barsky: does the closed segment meet the closed unit square?
fn segment_hits_box(a: (f64, f64), b: (f64, f64), sx: f64, sy: f64) -> bool {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let mut t0 = 0.0f64;
    let mut t1 = 1.0f64;
    for (p, q) in [
        (-dx, a.0 - sx),
        (dx, sx + 1.0 - a.0),
        (-dy, a.1 - sy),
        (dy, sy + 1.0 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
            if t0 > t1 {
                return false;
            }
        }
    }
    true
}
