//! Replanning for a target that moves and a map that changes: Lifelong
//! Planning A* (Koenig, Likhachev and Furcy, 2004) rooted at the start.
//!
//! Why rooted at the start: in the game a robot chases something that moves
//! (an enemy carrying our flag, a squad leader). LPA* keeps, for every cell it
//! has touched, the exact distance *from the root*, and those distances do
//! not depend on where the goal is. So when the goal moves, nothing already
//! computed becomes wrong; only the heuristic that orders the open list
//! changes. D* Lite roots its search at the goal for the opposite case (a
//! robot moving towards a fixed goal); for a moving goal it would throw away
//! everything.
//!
//! A changed heuristic would normally mean re-sorting the open list. Instead
//! we use D* Lite's key modifier mirrored: when the goal moves from `a` to
//! `b`, `km` grows by `h(a, b)`; keys already on the list are then lower
//! bounds of the true ones (triangle inequality), and a popped entry whose
//! key is stale is pushed back with the fresh key. Moving the goal costs
//! O(1), and the next [`Replanner::plan`] expands only cells the old search
//! had not settled yet, often none.
//!
//! A cell that becomes blocked (or clear) changes the costs of the edges
//! around it, within its 3 x 3 block (diagonals that used it as a corner
//! included); LPA* repairs just the distances that depended on them.
//!
//! Moving the start re-roots the search and costs as much as a fresh one:
//! a robot following its path keeps its replanner until it drifts off the
//! path or the path grows much longer than needed, then starts a new one
//! from where it stands.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::map::{Cell, GridMap};

use super::grid::{ClassGrid, Cost, STEP};
use super::{Mover, Path};

/// An LPA* priority: `[min(g, rhs) + h + km, min(g, rhs)]`, compared
/// lexicographically.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Key(f64, f64);

impl Key {
    fn cmp(&self, other: &Key) -> Ordering {
        self.0.total_cmp(&other.0).then(self.1.total_cmp(&other.1))
    }
}

#[derive(Debug, Clone, Copy)]
struct Entry {
    key: Key,
    index: u32,
}

impl PartialEq for Entry {
    fn eq(&self, other: &Entry) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Entry) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Entry) -> Ordering {
        // Reversed: the max-heap pops the smallest key.
        other.key.cmp(&self.key)
    }
}

/// One cell's LPA* state.
#[derive(Debug, Clone, Copy)]
struct Node {
    g: Cost,
    rhs: Cost,
    /// The key the cell is queued under, valid while `queued` is set.
    key: Key,
    queued: bool,
    epoch: u32,
}

impl Node {
    const FRESH: Node = Node {
        g: Cost::INFINITE,
        rhs: Cost::INFINITE,
        key: Key(f64::INFINITY, f64::INFINITY),
        queued: false,
        epoch: 0,
    };
}

/// An incremental planner from a fixed start to a goal that may move, on a
/// map whose cells may become blocked or clear again.
///
/// ```
/// use colony_game::map::{Cell, GridMap, Terrain};
/// use colony_game::path::{Mover, Replanner};
/// let map = GridMap::new(20, 20, Terrain::Open);
/// let mut r = Replanner::new(&map, Mover::Land, Cell::new(0, 0), Cell::new(10, 10));
/// assert!(r.plan().is_some());
/// r.set_goal(Cell::new(11, 10)); // the target stepped aside
/// r.set_blocked(Cell::new(5, 5), true); // a wreck on the way
/// let path = r.plan().unwrap();
/// assert_eq!(path.cells.last(), Some(&Cell::new(11, 10)));
/// ```
#[derive(Debug, Clone)]
pub struct Replanner {
    grid: ClassGrid,
    /// The map's own classes, restored when a cell is unblocked.
    base: Vec<u8>,
    /// Search state per cell, valid where its `epoch` is the current one.
    nodes: Vec<Node>,
    /// Bumped when the search is re-rooted, which makes every node stale
    /// without touching the array.
    epoch: u32,
    queued_count: usize,
    heap: BinaryHeap<Entry>,
    start: usize,
    goal: Cell,
    /// The last goal on the map: the heuristic's target in every key.
    key_goal: usize,
    /// How far the goal has moved since the search was rooted, as exact counts: a key that
    /// is a lower bound of the fresh one in exact arithmetic must stay one when both are
    /// rounded, or a tie between a stale key and the goal's ends the search early.
    km: Cost,
    expanded: usize,
}

impl Replanner {
    /// A replanner on `map` for `mover` from `start` to `goal`. Allocates
    /// arrays the size of the map; plans nothing yet. A start off the map is
    /// clamped onto it.
    pub fn new(map: &GridMap, mover: Mover, start: Cell, goal: Cell) -> Replanner {
        let grid = ClassGrid::new(map, mover);
        let n = grid.len();
        let mut r = Replanner {
            base: grid.class.clone(),
            grid,
            nodes: vec![Node::FRESH; n],
            epoch: 0,
            queued_count: 0,
            heap: BinaryHeap::new(),
            start: 0,
            goal,
            key_goal: 0,
            km: Cost::ZERO,
            expanded: 0,
        };
        r.set_start(start);
        r
    }

    /// The start the search is rooted at.
    pub fn start(&self) -> Cell {
        self.grid.cell(self.start)
    }

    /// The current goal.
    pub fn goal(&self) -> Cell {
        self.goal
    }

    /// Cells expanded by all [`Replanner::plan`] calls since the start was
    /// last set (for benchmarks and tests).
    pub fn expanded(&self) -> usize {
        self.expanded
    }

    /// Moves the goal. Costs O(1); the next [`Replanner::plan`] reuses every
    /// distance found so far.
    pub fn set_goal(&mut self, goal: Cell) {
        self.goal = goal;
        // Off the map there is no path; keys keep aiming at the last goal
        // on it, which is still a valid (if weaker) ordering.
        if let Some(b) = self.grid.index(goal) {
            self.km = self.km.plus(self.grid.octile_cost(self.key_goal, b));
            self.key_goal = b;
        }
    }

    /// Re-roots the search at `start` (clamped onto the map). The same start
    /// again changes nothing; a new one makes the next [`Replanner::plan`] as
    /// costly as a fresh search (but no costlier: nothing the size of the map
    /// is cleared).
    pub fn set_start(&mut self, start: Cell) {
        let start = Cell::new(
            start.x.min(self.grid.width.saturating_sub(1)),
            start.y.min(self.grid.height.saturating_sub(1)),
        );
        if self.epoch != 0 && self.grid.index(start) == Some(self.start) {
            return;
        }
        if self.epoch == u32::MAX {
            self.nodes.fill(Node::FRESH);
            self.epoch = 0;
        }
        self.epoch += 1;
        self.queued_count = 0;
        self.heap.clear();
        self.km = Cost::ZERO;
        self.expanded = 0;
        // An empty map has no cells; index 0 is then a border cell of class 0.
        self.start = self.grid.index(start).unwrap_or(0);
        self.key_goal = self.grid.index(self.goal).unwrap_or(self.start);
        self.node_mut(self.start).rhs = Cost::ZERO;
        self.enqueue(self.start);
    }

    /// Marks `cell` blocked (a newly seen obstacle) or clears that mark,
    /// which restores the map's own terrain there. Off-map cells are ignored.
    pub fn set_blocked(&mut self, cell: Cell, blocked: bool) {
        let Some(c) = self.grid.index(cell) else {
            return;
        };
        let class = if blocked { 0 } else { self.base[c] };
        if self.grid.class[c] == class {
            return;
        }
        self.grid.class[c] = class;
        // Every edge whose cost changed has both ends in this 3 x 3 block.
        // (Neighbours in the border have no moves, so updating them is a
        // harmless no-op.)
        self.update(c);
        for dir in 0..8 {
            self.update(self.grid.step(c, dir));
        }
    }

    /// Whether `cell` is passable now (map terrain and blocked marks).
    pub fn passable(&self, cell: Cell) -> bool {
        self.grid
            .index(cell)
            .is_some_and(|i| self.grid.class[i] != 0)
    }

    /// The shortest path from the start to the current goal, repairing the
    /// search only as far as the changes since the last call require.
    pub fn plan(&mut self) -> Option<Path> {
        let t = self.grid.index(self.goal)?;
        let k = self.grid.class[self.start];
        if k == 0 || self.grid.class[t] != k {
            return None;
        }
        self.compute(t);
        if self.node(t).g == Cost::INFINITE {
            return None;
        }
        self.extract(t)
    }

    /// The state of cell `i` (fresh if not touched since re-rooting).
    #[inline]
    fn node(&self, i: usize) -> Node {
        let n = self.nodes[i];
        if n.epoch == self.epoch {
            n
        } else {
            Node::FRESH
        }
    }

    /// The state of cell `i` for writing, made current first.
    #[inline]
    fn node_mut(&mut self, i: usize) -> &mut Node {
        let epoch = self.epoch;
        let n = &mut self.nodes[i];
        if n.epoch != epoch {
            *n = Node {
                epoch,
                ..Node::FRESH
            };
        }
        n
    }

    fn calc_key(&self, i: usize) -> Key {
        let n = self.node(i);
        let m = min(n.g, n.rhs);
        if m == Cost::INFINITE {
            return Key(f64::INFINITY, f64::INFINITY);
        }
        let f = m
            .plus(self.grid.octile_cost(i, self.key_goal))
            .plus(self.km)
            .value();
        Key(f, m.value())
    }

    /// Queues `i` under its current key (replacing an older entry).
    fn enqueue(&mut self, i: usize) {
        let key = self.calc_key(i);
        let n = self.node_mut(i);
        let newly = !n.queued;
        n.queued = true;
        n.key = key;
        if newly {
            self.queued_count += 1;
        }
        self.heap.push(Entry {
            key,
            index: i as u32,
        });
        if self.heap.len() > 4 * self.queued_count + 4096 {
            // Drop superseded entries so the heap tracks the open set.
            let nodes = &self.nodes;
            self.heap.retain(|e| {
                let n = &nodes[e.index as usize];
                n.queued && n.key == e.key
            });
        }
    }

    fn dequeue(&mut self, i: usize) {
        if self.node(i).queued {
            self.node_mut(i).queued = false;
            self.queued_count -= 1;
        }
    }

    /// `rhs` from the neighbours, and the queue membership that follows.
    fn update(&mut self, u: usize) {
        if u != self.start {
            let mut best = Cost::INFINITE;
            let moves = self.grid.moves(u);
            for (dir, &cost) in STEP.iter().enumerate() {
                if moves & (1 << dir) != 0 {
                    best = min(best, self.node(self.grid.step(u, dir)).g.plus(cost));
                }
            }
            if best != self.node(u).rhs {
                self.node_mut(u).rhs = best;
            }
        }
        let n = self.node(u);
        if n.g != n.rhs {
            self.enqueue(u);
        } else {
            self.dequeue(u);
        }
    }

    /// The smallest current entry, dropping superseded ones.
    fn top(&mut self) -> Option<Entry> {
        while let Some(&e) = self.heap.peek() {
            // Entries in the heap were pushed this epoch, so their nodes
            // are current.
            let n = &self.nodes[e.index as usize];
            if n.queued && n.key == e.key {
                return Some(e);
            }
            self.heap.pop();
        }
        None
    }

    /// LPA*'s main loop: settle cells until the goal's distance is exact.
    fn compute(&mut self, t: usize) {
        while let Some(top) = self.top() {
            let goal_key = self.calc_key(t);
            let goal = self.node(t);
            if top.key.cmp(&goal_key) != Ordering::Less && goal.g == goal.rhs {
                break;
            }
            let u = top.index as usize;
            let fresh = self.calc_key(u);
            if top.key.cmp(&fresh) == Ordering::Less {
                // Queued before the goal moved: a lower bound; requeue.
                self.heap.pop();
                self.node_mut(u).key = fresh;
                self.heap.push(Entry {
                    key: fresh,
                    index: u as u32,
                });
                continue;
            }
            self.heap.pop();
            self.expanded += 1;
            let moves_before = self.grid.moves(u);
            let n = self.node(u);
            if n.g.length() > n.rhs.length() {
                self.node_mut(u).g = n.rhs;
                self.dequeue(u);
            } else {
                self.node_mut(u).g = Cost::INFINITE;
                self.update(u);
            }
            for dir in 0..8 {
                if moves_before & (1 << dir) != 0 {
                    self.update(self.grid.step(u, dir));
                }
            }
        }
    }

    /// Walks back from the goal, each step to the settled neighbour that
    /// explains its distance.
    fn extract(&self, t: usize) -> Option<Path> {
        let mut cells = vec![self.grid.cell(t)];
        let mut u = t;
        // A simple path visits each cell at most once.
        for _ in 0..self.grid.len() {
            if u == self.start {
                cells.reverse();
                return Some(Path {
                    cells,
                    length: self.node(t).g.value(),
                });
            }
            let moves = self.grid.moves(u);
            let mut best = (f64::INFINITY, u);
            for (dir, &cost) in STEP.iter().enumerate() {
                if moves & (1 << dir) != 0 {
                    let v = self.grid.step(u, dir);
                    let n = self.node(v);
                    // A cell the search has not settled since the map changed (g != rhs) may
                    // hold a stale, too small g: the path must not lead through it.
                    if n.g != n.rhs {
                        continue;
                    }
                    let d = n.g.plus(cost).length();
                    if d < best.0 {
                        best = (d, v);
                    }
                }
            }
            if best.1 == u || self.node(best.1).g.length() >= self.node(u).g.length() {
                return None;
            }
            u = best.1;
            cells.push(self.grid.cell(u));
        }
        None
    }
}

/// The smaller of two costs.
fn min(a: Cost, b: Cost) -> Cost {
    if b.length() < a.length() {
        b
    } else {
        a
    }
}
