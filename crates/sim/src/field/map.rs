//! The terrain grid: what each square of a tile map is, and where it lies in the world.

use crate::error::SimError;
use crate::types::Vec2;

/// Most cells a map may have along either side: bounds the memory a map file can
/// ask for and the work of building its colliders.
pub const MAX_MAP_CELLS: usize = 4096;

/// Widest a map may be along either side, cm. Rapier computes in `f32`, whose
/// resolution at 100,000 cm (1 km) is still under 0.01 cm.
pub const MAX_MAP_SIDE_CM: f64 = 100_000.0;

/// What a square of ground is, as far as physics cares.
///
/// Games give cells more meanings (swamp, base, flag stand); those that do not
/// change how bodies move are [`Terrain::Open`] here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Terrain {
    /// Ground anything can cross.
    #[default]
    Open,
    /// A wall: nothing crosses it.
    Blocked,
    /// Stops land robots and boxes; amphibious robots cross it.
    Water,
}

/// A rectangular grid of square cells, as read from a map file.
///
/// Cell `(x, y)`: `x` is the column from the left, `y` the row from the *top*
/// (the order of the lines of a map file). The world frame has its origin at the
/// map's bottom-left corner, x to the right and y up, in centimetres, so cell
/// `(x, y)` covers `x·c ..= (x+1)·c` by `(H−1−y)·c ..= (H−y)·c` for cell side `c`
/// and `H` rows.
///
/// ```
/// use colony_sim::field::{Terrain, TileMap};
/// use colony_sim::Vec2;
/// // 3 x 2 cells of 10 cm; the top-right cell is a wall.
/// let map = TileMap::from_fn(3, 2, 10.0, |x, y| {
///     if (x, y) == (2, 0) { Terrain::Blocked } else { Terrain::Open }
/// }).unwrap();
/// assert_eq!(map.cell_center(2, 0), Vec2::new(25.0, 15.0));
/// assert_eq!(map.terrain_at(Vec2::new(25.0, 15.0)), Terrain::Blocked);
/// assert_eq!(map.terrain_at(Vec2::new(-1.0, 5.0)), Terrain::Blocked); // off the map
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct TileMap {
    width: usize,
    height: usize,
    cell_cm: f64,
    cells: Vec<Terrain>,
}

/// A rectangle of whole cells, half-open in map coordinates: columns `x0..x1`, rows `y0..y1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct CellRect {
    pub x0: usize,
    pub x1: usize,
    pub y0: usize,
    pub y1: usize,
}

impl TileMap {
    /// A map of `width` x `height` cells of side `cell_cm`, `cells` in row-major
    /// order from the top row. Refuses empty or oversized maps (more than
    /// [`MAX_MAP_CELLS`] a side or [`MAX_MAP_SIDE_CM`] wide), a cell side that is
    /// not a positive finite number, and a cell list of the wrong length.
    pub fn new(
        width: usize,
        height: usize,
        cell_cm: f64,
        cells: Vec<Terrain>,
    ) -> Result<TileMap, SimError> {
        check_size(width, height, cell_cm)?;
        if cells.len() != width * height {
            return Err(SimError::Map(format!(
                "{} cells given for a {width} x {height} map ({} expected)",
                cells.len(),
                width * height
            )));
        }
        Ok(TileMap {
            width,
            height,
            cell_cm,
            cells,
        })
    }

    /// A map of open ground: an empty field with walls only round its edge.
    pub fn open(width: usize, height: usize, cell_cm: f64) -> Result<TileMap, SimError> {
        TileMap::from_fn(width, height, cell_cm, |_, _| Terrain::Open)
    }

    /// A map whose cell `(x, y)` is `terrain(x, y)`, with the checks of [`TileMap::new`].
    pub fn from_fn(
        width: usize,
        height: usize,
        cell_cm: f64,
        mut terrain: impl FnMut(usize, usize) -> Terrain,
    ) -> Result<TileMap, SimError> {
        // Before allocating what the size asks for.
        check_size(width, height, cell_cm)?;
        let mut cells = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                cells.push(terrain(x, y));
            }
        }
        TileMap::new(width, height, cell_cm, cells)
    }

    /// Columns.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Side of a cell, cm.
    pub fn cell_cm(&self) -> f64 {
        self.cell_cm
    }

    /// The map's extent in the world frame, cm: it spans `(0, 0)` to this corner.
    pub fn size_cm(&self) -> Vec2 {
        Vec2::new(
            self.width as f64 * self.cell_cm,
            self.height as f64 * self.cell_cm,
        )
    }

    /// All cells, row-major from the top row.
    pub fn cells(&self) -> &[Terrain] {
        &self.cells
    }

    /// Cell `(x, y)` (row `y` from the top), or `None` off the map.
    pub fn get(&self, x: usize, y: usize) -> Option<Terrain> {
        if x < self.width && y < self.height {
            Some(self.cells[y * self.width + x])
        } else {
            None
        }
    }

    /// The cell holding a world point, or `None` off the map (or for NaN).
    /// Cells own their left and bottom edges; the map's right and top edges are off it.
    pub fn cell_at(&self, p: Vec2) -> Option<(usize, usize)> {
        let size = self.size_cm();
        if !(p.x >= 0.0 && p.x < size.x && p.y >= 0.0 && p.y < size.y) {
            return None;
        }
        let i = ((p.x / self.cell_cm) as usize).min(self.width - 1);
        let j = ((p.y / self.cell_cm) as usize).min(self.height - 1);
        Some((i, self.height - 1 - j))
    }

    /// The terrain at a world point; everything off the map is [`Terrain::Blocked`],
    /// so the map's edge behaves as a wall.
    pub fn terrain_at(&self, p: Vec2) -> Terrain {
        match self.cell_at(p) {
            Some((x, y)) => self.cells[y * self.width + x],
            None => Terrain::Blocked,
        }
    }

    /// The world position of the centre of cell `(x, y)` (row `y` from the top).
    /// Cells off the map get the centre they would have if the grid went on.
    pub fn cell_center(&self, x: usize, y: usize) -> Vec2 {
        let c = self.cell_cm;
        Vec2::new(
            (x as f64 + 0.5) * c,
            (self.height as f64 - y as f64 - 0.5) * c,
        )
    }

    /// Terrain by column `i` and row `j` counted from the *bottom*, as the world
    /// frame counts them, with everything off the map [`Terrain::Blocked`]: what
    /// geometry that walks the grid in world coordinates needs.
    pub(crate) fn terrain_ij(&self, i: i64, j: i64) -> Terrain {
        if i < 0 || j < 0 || i >= self.width as i64 || j >= self.height as i64 {
            return Terrain::Blocked;
        }
        let row = self.height - 1 - j as usize;
        self.cells[row * self.width + i as usize]
    }

    /// World-frame corners (bottom-left, top-right) of a rectangle of cells.
    pub(crate) fn rect_bounds(&self, r: CellRect) -> (Vec2, Vec2) {
        let c = self.cell_cm;
        let h = self.height as f64;
        (
            Vec2::new(r.x0 as f64 * c, (h - r.y1 as f64) * c),
            Vec2::new(r.x1 as f64 * c, (h - r.y0 as f64) * c),
        )
    }

    /// The cells of one kind covered by few rectangles, so that a large map becomes
    /// few colliders: each row's runs of `kind`, a run merged with the run of the
    /// row above when both span the same columns. Exact (every cell of `kind` in
    /// exactly one rectangle), one pass, deterministic order.
    pub(crate) fn merged_rects(&self, kind: Terrain) -> Vec<CellRect> {
        let mut done = Vec::new();
        // Rectangles still growing downwards, sorted by column (runs of one row are disjoint).
        let mut open: Vec<CellRect> = Vec::new();
        let mut next: Vec<CellRect> = Vec::new();
        for y in 0..self.height {
            let row = &self.cells[y * self.width..(y + 1) * self.width];
            let mut k = 0;
            let mut x = 0;
            while x < self.width {
                if row[x] != kind {
                    x += 1;
                    continue;
                }
                let x0 = x;
                while x < self.width && row[x] == kind {
                    x += 1;
                }
                // Rectangles that start left of this run can no longer be extended.
                while k < open.len() && open[k].x0 < x0 {
                    done.push(open[k]);
                    k += 1;
                }
                match open.get(k) {
                    Some(r) if r.x0 == x0 && r.x1 == x => {
                        next.push(CellRect { y1: y + 1, ..*r });
                        k += 1;
                    }
                    _ => next.push(CellRect {
                        x0,
                        x1: x,
                        y0: y,
                        y1: y + 1,
                    }),
                }
            }
            done.extend_from_slice(&open[k..]);
            std::mem::swap(&mut open, &mut next);
            next.clear();
        }
        done.extend(open);
        done
    }
}

fn check_size(width: usize, height: usize, cell_cm: f64) -> Result<(), SimError> {
    if width == 0 || height == 0 {
        return Err(SimError::Map(format!(
            "{width} x {height} cells: a map needs at least one cell"
        )));
    }
    if width > MAX_MAP_CELLS || height > MAX_MAP_CELLS {
        return Err(SimError::Map(format!(
            "{width} x {height} cells: at most {MAX_MAP_CELLS} cells a side"
        )));
    }
    if !(cell_cm.is_finite() && cell_cm > 0.0) {
        return Err(SimError::Map(format!(
            "cell side {cell_cm} cm: must be a positive number"
        )));
    }
    let (w, h) = (width as f64 * cell_cm, height as f64 * cell_cm);
    if w > MAX_MAP_SIDE_CM || h > MAX_MAP_SIDE_CM {
        return Err(SimError::Map(format!(
            "{w} x {h} cm: at most {MAX_MAP_SIDE_CM} cm a side"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(rows: &[&str]) -> TileMap {
        let h = rows.len();
        let w = rows[0].len();
        TileMap::from_fn(w, h, 10.0, |x, y| match rows[y].as_bytes()[x] {
            b'#' => Terrain::Blocked,
            b'~' => Terrain::Water,
            _ => Terrain::Open,
        })
        .unwrap()
    }

    #[test]
    fn row_zero_is_the_top_of_the_world() {
        let map = parse(&["#..", "..~"]);
        assert_eq!(map.cell_center(0, 0), Vec2::new(5.0, 15.0));
        assert_eq!(map.cell_center(2, 1), Vec2::new(25.0, 5.0));
        assert_eq!(map.terrain_at(Vec2::new(5.0, 15.0)), Terrain::Blocked);
        assert_eq!(map.terrain_at(Vec2::new(25.0, 5.0)), Terrain::Water);
        assert_eq!(map.terrain_at(Vec2::new(5.0, 5.0)), Terrain::Open);
        assert_eq!(map.cell_at(Vec2::new(29.9, 0.0)), Some((2, 1)));
        assert_eq!(map.terrain_ij(0, 1), Terrain::Blocked);
        assert_eq!(map.terrain_ij(2, 0), Terrain::Water);
    }

    #[test]
    fn everything_off_the_map_is_blocked() {
        let map = TileMap::open(2, 2, 10.0).unwrap();
        for p in [
            Vec2::new(-0.1, 5.0),
            Vec2::new(20.0, 5.0),
            Vec2::new(5.0, 20.0),
            Vec2::new(5.0, -3.0),
            Vec2::new(f64::NAN, 5.0),
        ] {
            assert_eq!(map.terrain_at(p), Terrain::Blocked, "{p:?}");
        }
        assert_eq!(map.terrain_ij(-1, 0), Terrain::Blocked);
    }

    #[test]
    fn impossible_maps_are_refused_with_the_reason() {
        let e = TileMap::new(0, 3, 10.0, vec![]).unwrap_err().to_string();
        assert!(e.contains("at least one cell"), "{e}");
        let e = TileMap::new(5000, 1, 1.0, vec![]).unwrap_err().to_string();
        assert!(e.contains("at most 4096"), "{e}");
        let e = TileMap::new(2, 2, -1.0, vec![Terrain::Open; 4])
            .unwrap_err()
            .to_string();
        assert!(e.contains("positive"), "{e}");
        let e = TileMap::new(2, 2, f64::NAN, vec![Terrain::Open; 4]).unwrap_err();
        assert!(matches!(e, SimError::Map(_)));
        let e = TileMap::new(2, 2, 1.0, vec![Terrain::Open; 3])
            .unwrap_err()
            .to_string();
        assert!(e.contains("3 cells given"), "{e}");
        let e = TileMap::open(4000, 4000, 100.0).unwrap_err().to_string();
        assert!(e.contains("cm a side"), "{e}");
        assert!(TileMap::from_fn(1 << 40, 1 << 40, 1.0, |_, _| Terrain::Open).is_err());
    }

    /// Every cell of the kind is covered exactly once, and nothing else.
    fn check_cover(map: &TileMap, kind: Terrain) -> usize {
        let rects = map.merged_rects(kind);
        let mut count = vec![0u8; map.width * map.height];
        for r in &rects {
            assert!(r.x0 < r.x1 && r.y0 < r.y1);
            for y in r.y0..r.y1 {
                for x in r.x0..r.x1 {
                    count[y * map.width + x] += 1;
                }
            }
        }
        for (i, t) in map.cells.iter().enumerate() {
            assert_eq!(count[i], u8::from(*t == kind), "cell {i}");
        }
        rects.len()
    }

    #[test]
    fn merged_rectangles_cover_each_cell_once() {
        let map = parse(&[
            "##..##~~", //
            "##..##~~", "#...##~.", "....#..~", "##..##..",
        ]);
        check_cover(&map, Terrain::Blocked);
        check_cover(&map, Terrain::Water);
        assert_eq!(
            check_cover(&map, Terrain::Open),
            map.merged_rects(Terrain::Open).len()
        );
        // A solid block and a straight river are one rectangle each.
        let map = parse(&["#~.", "#~.", "#~."]);
        assert_eq!(check_cover(&map, Terrain::Blocked), 1);
        assert_eq!(check_cover(&map, Terrain::Water), 1);
        // Pseudo-random noise.
        let mut s = 12345u64;
        let map = TileMap::from_fn(37, 23, 1.0, |_, _| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            [Terrain::Open, Terrain::Blocked, Terrain::Water][(s >> 33) as usize % 3]
        })
        .unwrap();
        check_cover(&map, Terrain::Blocked);
        check_cover(&map, Terrain::Water);
    }

    #[test]
    fn rectangle_bounds_are_in_the_world_frame() {
        let map = parse(&["#..", "...", "..."]);
        let r = map.merged_rects(Terrain::Blocked)[0];
        assert_eq!(
            map.rect_bounds(r),
            (Vec2::new(0.0, 20.0), Vec2::new(10.0, 30.0))
        );
    }
}
