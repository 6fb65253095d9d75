//! One-shot optimal searches (A* and jump point search) over memory kept
//! between queries.
//!
//! A game asks for many paths on one map, so a [`Planner`] allocates its
//! per-cell arrays once. A query does not clear them: each cell carries the
//! number of the query that last wrote it, and anything older reads as
//! "unseen", so a short query on a huge map costs only what it touches.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::map::{Cell, GridMap};

use super::grid::{ClassGrid, Cost, STEP};
use super::{Algorithm, Mover, Path};

/// An entry of the open list. Ordered so the binary (max-)heap pops the
/// smallest `f` first and, among equal `f`, the largest `g` (the node
/// deepest along its path, which reaches the goal with fewer expansions).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Open {
    pub f: f64,
    pub g: f64,
    pub index: u32,
}

impl PartialEq for Open {
    fn eq(&self, other: &Open) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Open {}

impl PartialOrd for Open {
    fn partial_cmp(&self, other: &Open) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Open {
    fn cmp(&self, other: &Open) -> Ordering {
        other.f.total_cmp(&self.f).then(self.g.total_cmp(&other.g))
    }
}

/// Reusable optimal path finder for one map and one [`Mover`].
///
/// ```
/// use colony_game::map::{Cell, GridMap};
/// use colony_game::path::{Algorithm, Mover, Planner};
/// let map = GridMap::parse("type octile\nheight 3\nwidth 3\nmap\n...\n.T.\n...\n").unwrap();
/// let mut planner = Planner::new(&map, Mover::Land);
/// let path = planner.find(Algorithm::Jps, Cell::new(0, 0), Cell::new(2, 2)).unwrap();
/// assert!((path.length - 4.0).abs() < 1e-9); // around the tree, no corner cutting
/// ```
#[derive(Debug, Clone)]
pub struct Planner {
    pub(crate) grid: ClassGrid,
    pub(crate) g: Vec<Cost>,
    pub(crate) parent: Vec<u32>,
    /// `query` when the cell is open (its `g` and `parent` are valid this
    /// query), `query + 1` when it is closed; anything else means unseen.
    pub(crate) state: Vec<u32>,
    pub(crate) query: u32,
    pub(crate) heap: BinaryHeap<Open>,
    pub(crate) expanded: usize,
}

impl Planner {
    /// A planner for `map` as `mover` sees it. Costs one pass over the map;
    /// later queries allocate nothing but their result.
    pub fn new(map: &GridMap, mover: Mover) -> Planner {
        let grid = ClassGrid::new(map, mover);
        let n = grid.len();
        Planner {
            grid,
            g: vec![Cost::ZERO; n],
            parent: vec![0; n],
            state: vec![0; n],
            query: 0,
            heap: BinaryHeap::new(),
            expanded: 0,
        }
    }

    /// Whether `mover` may stand on `cell`.
    pub fn passable(&self, cell: Cell) -> bool {
        self.grid
            .index(cell)
            .is_some_and(|i| self.grid.class[i] != 0)
    }

    /// Nodes the last query expanded (for benchmarks and tuning).
    pub fn expanded(&self) -> usize {
        self.expanded
    }

    /// The shortest path from `start` to `goal` by `algorithm`; `None` when
    /// either is off the map or impassable, or no path exists.
    pub fn find(&mut self, algorithm: Algorithm, start: Cell, goal: Cell) -> Option<Path> {
        match algorithm {
            Algorithm::AStar => self.astar(start, goal),
            Algorithm::Jps => self.jps(start, goal),
        }
    }

    /// Optimal A* with the octile heuristic.
    pub fn astar(&mut self, start: Cell, goal: Cell) -> Option<Path> {
        let (s, t) = self.endpoints(start, goal)?;
        if s == t {
            return Some(Path::single(start));
        }
        let open = self.begin(s, t);
        let closed = open + 1;
        while let Some(u) = self.expand_next(closed) {
            if u == t {
                return Some(self.trace(s, t));
            }
            let gu = self.g[u];
            let moves = self.grid.moves(u);
            for (dir, &cost) in STEP.iter().enumerate() {
                if moves & (1 << dir) == 0 {
                    continue;
                }
                let v = self.grid.step(u, dir);
                let ng = gu.plus(cost);
                let st = self.state[v];
                if st == closed || (st == open && ng.value() >= self.g[v].value()) {
                    continue;
                }
                self.relax(v, u, ng, t, open);
            }
        }
        None
    }

    /// Checks the endpoints; their padded indices when a path may exist.
    pub(crate) fn endpoints(&self, start: Cell, goal: Cell) -> Option<(usize, usize)> {
        let s = self.grid.index(start)?;
        let t = self.grid.index(goal)?;
        let k = self.grid.class[s];
        (k != 0 && self.grid.class[t] == k).then_some((s, t))
    }

    /// The next cell to expand, closed and counted: the open list's best entry that is not
    /// stale (closed already, or superseded by a cheaper one pushed later).
    pub(crate) fn expand_next(&mut self, closed: u32) -> Option<usize> {
        while let Some(node) = self.heap.pop() {
            let u = node.index as usize;
            if self.state[u] == closed || node.g > self.g[u].value() {
                continue;
            }
            self.state[u] = closed;
            self.expanded += 1;
            return Some(u);
        }
        None
    }

    /// Starts a query at `s`: a fresh query number, the start on the open
    /// list. Returns the number that marks open cells.
    pub(crate) fn begin(&mut self, s: usize, t: usize) -> u32 {
        if self.query >= u32::MAX - 3 {
            // After four billion queries the numbers wrap: forget them all.
            self.state.fill(0);
            self.query = 0;
        }
        self.query += 2;
        self.heap.clear();
        self.expanded = 0;
        let open = self.query;
        self.g[s] = Cost::ZERO;
        self.parent[s] = s as u32;
        self.state[s] = open;
        self.heap.push(Open {
            f: self.grid.distance(s, t),
            g: 0.0,
            index: s as u32,
        });
        open
    }

    /// Records a better way to `v` through `u`.
    #[inline]
    pub(crate) fn relax(&mut self, v: usize, u: usize, g: Cost, t: usize, open: u32) {
        self.g[v] = g;
        self.parent[v] = u as u32;
        self.state[v] = open;
        self.heap.push(Open {
            f: g.plus(self.grid.octile_cost(v, t)).value(),
            g: g.value(),
            index: v as u32,
        });
    }

    /// The path to `t` by parents, with every cell (jump point search's
    /// parents are whole straight or diagonal runs apart, filled in here).
    pub(crate) fn trace(&self, s: usize, t: usize) -> Path {
        let mut points = vec![t];
        let mut i = t;
        while i != s {
            i = self.parent[i] as usize;
            points.push(i);
        }
        points.reverse();
        let mut cells = Vec::with_capacity(points.len());
        cells.push(self.grid.cell(s));
        for w in points.windows(2) {
            let (a, b) = (self.grid.cell(w[0]), self.grid.cell(w[1]));
            let sx = (i64::from(b.x) - i64::from(a.x)).signum();
            let sy = (i64::from(b.y) - i64::from(a.y)).signum();
            let (mut x, mut y) = (i64::from(a.x), i64::from(a.y));
            while (x, y) != (i64::from(b.x), i64::from(b.y)) {
                x += sx;
                y += sy;
                // Coordinates stay between a and b, both on the map.
                cells.push(Cell::new(x as u32, y as u32));
            }
        }
        Path {
            cells,
            length: self.g[t].value(),
        }
    }
}
