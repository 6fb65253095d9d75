//! A uniform bucket grid over the arena, for "what is near here" queries.

use crate::types::Vec2;

/// Items (indices into some array of points) bucketed by cell, stored compactly:
/// the items of cell `c` are `items[start[c]..start[c + 1]]`.
#[derive(Debug, Clone)]
pub(crate) struct Grid {
    origin: Vec2,
    inv_cell: f64,
    nx: usize,
    ny: usize,
    start: Vec<u32>,
    items: Vec<u32>,
    scratch: Vec<u32>,
    cursor: Vec<u32>,
}

impl Grid {
    /// An empty grid covering `[-half.x, half.x] x [-half.y, half.y]` with square cells.
    pub fn new(half: Vec2, cell: f64) -> Grid {
        Grid::over(Vec2::new(-half.x, -half.y), half, cell)
    }

    /// An empty grid covering the box `[lo, hi]` with square cells.
    pub fn over(lo: Vec2, hi: Vec2, cell: f64) -> Grid {
        let nx = (((hi.x - lo.x) / cell).ceil() as usize).max(1);
        let ny = (((hi.y - lo.y) / cell).ceil() as usize).max(1);
        Grid {
            origin: lo,
            inv_cell: 1.0 / cell,
            nx,
            ny,
            start: vec![0; nx * ny + 1],
            items: Vec::new(),
            scratch: Vec::new(),
            cursor: Vec::new(),
        }
    }

    fn cell_xy(&self, p: Vec2) -> (usize, usize) {
        let cx = ((p.x - self.origin.x) * self.inv_cell).floor();
        let cy = ((p.y - self.origin.y) * self.inv_cell).floor();
        // Points outside (possible for a body pushed into a wall) go to the border cells.
        let cx = cx.clamp(0.0, (self.nx - 1) as f64) as usize;
        let cy = cy.clamp(0.0, (self.ny - 1) as f64) as usize;
        (cx, cy)
    }

    /// Refills the grid with `points[i]` for every `i` (item `i` is the index).
    pub fn rebuild(&mut self, points: impl Iterator<Item = Vec2> + Clone) {
        let cells = self.nx * self.ny;
        self.start.clear();
        self.start.resize(cells + 1, 0);
        self.scratch.clear();
        for p in points.clone() {
            let (cx, cy) = self.cell_xy(p);
            let c = cy * self.nx + cx;
            self.scratch.push(c as u32);
            self.start[c + 1] += 1;
        }
        for c in 0..cells {
            self.start[c + 1] += self.start[c];
        }
        self.items.clear();
        self.items.resize(self.scratch.len(), 0);
        // Fill using a running cursor per cell.
        self.cursor.clear();
        self.cursor.extend_from_slice(&self.start[..cells]);
        for (i, &c) in self.scratch.iter().enumerate() {
            let slot = &mut self.cursor[c as usize];
            self.items[*slot as usize] = i as u32;
            *slot += 1;
        }
    }

    /// Calls `f` with every item whose cell meets the box `[lo, hi]`, in a fixed order.
    pub fn query(&self, lo: Vec2, hi: Vec2, mut f: impl FnMut(u32)) {
        let (x0, y0) = self.cell_xy(lo);
        let (x1, y1) = self.cell_xy(hi);
        for cy in y0..=y1 {
            let row = cy * self.nx;
            let (a, b) = (
                self.start[row + x0] as usize,
                self.start[row + x1 + 1] as usize,
            );
            for &i in &self.items[a..b] {
                f(i);
            }
        }
    }
}
