//! Time per path query on the Moving AI benchmark sets, ours against the
//! `pathfinding` crate, and replanning for a moving target against planning
//! afresh.
//!
//! ```text
//! cargo bench -p colony-game --bench path -- --warm-up-time 1 --measurement-time 3
//! ```
//!
//! `query/SET/ALGORITHM`: each iteration runs the next query of the set (in
//! a fixed shuffled order, so a partial pass is still a fair sample); the
//! figure is the mean time per query. `astar` and `jps` are ours;
//! `pathfinding` is `pathfinding::directed::astar::astar` with a successor
//! function that applies the same rules (8-connected, no corner cutting,
//! water only from water) and integer costs 10000 / 14142 with the matching
//! octile heuristic. Its `Grid` type cuts corners, so it is not used. For
//! maze512 a sample of every 20th query is used.
//!
//! `replan/SET/...`: the target walks 1-3 cells per iteration (a fixed walk
//! out and back, so it never drifts off); `lpa` moves the goal of one
//! [`Replanner`] and replans, `astar` and `jps` plan from scratch each time.

use std::time::Duration;

use colony_game::map::{Cell, GridMap, Terrain};
use colony_game::path::{scen, Mover, Planner, Replanner};
use criterion::{criterion_group, criterion_main, Criterion};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../maps/movingai/");

struct Set {
    name: &'static str,
    map: GridMap,
    queries: Vec<(Cell, Cell)>,
}

fn load(name: &'static str, map: &str, scen_file: &str, every: usize) -> Set {
    let map = GridMap::from_file(format!("{DIR}{map}")).expect("benchmark map");
    let mut queries: Vec<(Cell, Cell)> = scen::from_file(format!("{DIR}{scen_file}"))
        .expect("benchmark scenario")
        .iter()
        .step_by(every)
        .map(|q| (q.start, q.goal))
        .collect();
    queries.shuffle(&mut ChaCha8Rng::seed_from_u64(7));
    Set { name, map, queries }
}

fn sets() -> Vec<Set> {
    vec![
        load("arena", "arena.map", "arena.map.scen", 1),
        load(
            "random32",
            "random-32-32-10.map",
            "random-32-32-10-random-1.scen",
            1,
        ),
        load("maze512", "maze512-32-9.map", "maze512-32-9.map.scen", 20),
    ]
}

/// The benchmark rules for the peer: the class of each cell (0 blocked,
/// steps only between equal classes).
struct PeerGrid {
    width: i32,
    height: i32,
    class: Vec<u8>,
}

impl PeerGrid {
    fn new(map: &GridMap) -> PeerGrid {
        PeerGrid {
            width: map.width() as i32,
            height: map.height() as i32,
            class: map
                .cells()
                .iter()
                .map(|t| match t {
                    Terrain::Open | Terrain::Swamp => 1,
                    Terrain::Water => 2,
                    _ => 0,
                })
                .collect(),
        }
    }

    fn at(&self, x: i32, y: i32) -> u8 {
        if x < 0 || y < 0 || x >= self.width || y >= self.height {
            0
        } else {
            self.class[(y * self.width + x) as usize]
        }
    }

    fn successors(&self, &(x, y): &(i32, i32)) -> Vec<((i32, i32), u32)> {
        let k = self.at(x, y);
        let mut out = Vec::with_capacity(8);
        for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            if self.at(x + dx, y + dy) == k {
                out.push(((x + dx, y + dy), 10_000));
            }
        }
        for (dx, dy) in [(1, 1), (1, -1), (-1, 1), (-1, -1)] {
            if self.at(x + dx, y) == k && self.at(x, y + dy) == k && self.at(x + dx, y + dy) == k {
                out.push(((x + dx, y + dy), 14_142));
            }
        }
        out
    }

    fn find(&self, s: Cell, t: Cell) -> Option<u32> {
        let goal = (t.x as i32, t.y as i32);
        let h = |&(x, y): &(i32, i32)| {
            let (dx, dy) = ((x - goal.0).unsigned_abs(), (y - goal.1).unsigned_abs());
            let (lo, hi) = (dx.min(dy), dx.max(dy));
            10_000 * (hi - lo) + 14_142 * lo
        };
        pathfinding::directed::astar::astar(
            &(s.x as i32, s.y as i32),
            |p| self.successors(p),
            h,
            |p| *p == goal,
        )
        .map(|(_, cost)| cost)
    }
}

fn queries(c: &mut Criterion) {
    for set in sets() {
        let mut group = c.benchmark_group(format!("query/{}", set.name));
        if set.name == "maze512" {
            group.sample_size(10);
        }
        let n = set.queries.len();
        let mut planner = Planner::new(&set.map, Mover::Benchmark);
        let mut i = 0;
        group.bench_function("astar", |b| {
            b.iter(|| {
                let (s, t) = set.queries[i % n];
                i += 1;
                planner.astar(s, t)
            })
        });
        let mut i = 0;
        group.bench_function("jps", |b| {
            b.iter(|| {
                let (s, t) = set.queries[i % n];
                i += 1;
                planner.jps(s, t)
            })
        });
        let peer = PeerGrid::new(&set.map);
        let mut i = 0;
        group.bench_function("pathfinding", |b| {
            b.iter(|| {
                let (s, t) = set.queries[i % n];
                i += 1;
                peer.find(s, t)
            })
        });
        group.finish();
    }
}

/// A walk of the target from `goal`: `steps` moves of 1-3 cells to passable
/// cells reachable from `start`, then the same way back.
fn walk(map: &GridMap, start: Cell, goal: Cell, steps: usize) -> Vec<Cell> {
    let mut planner = Planner::new(map, Mover::Benchmark);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut out = vec![goal];
    let mut at = goal;
    while out.len() <= steps {
        let d = rng.random_range(1..=3i64);
        let (dx, dy) = [
            (d, 0),
            (-d, 0),
            (0, d),
            (0, -d),
            (d, d),
            (-d, d),
            (d, -d),
            (-d, -d),
        ][rng.random_range(0..8)];
        let (x, y) = (i64::from(at.x) + dx, i64::from(at.y) + dy);
        if x < 0 || y < 0 {
            continue;
        }
        let next = Cell::new(x as u32, y as u32);
        if map.contains(next) && planner.jps(start, next).is_some() {
            out.push(next);
            at = next;
        }
    }
    let back: Vec<Cell> = out.iter().rev().skip(1).copied().collect();
    out.extend(back);
    out
}

fn replanning(c: &mut Criterion) {
    for set in sets().into_iter().filter(|s| s.name != "random32") {
        // The longest query of the sample: the hardest case to plan afresh.
        let mut planner = Planner::new(&set.map, Mover::Benchmark);
        let (start, goal) = *set
            .queries
            .iter()
            .max_by(|a, b| {
                let la = planner.jps(a.0, a.1).map_or(0.0, |p| p.length);
                let lb = planner.jps(b.0, b.1).map_or(0.0, |p| p.length);
                la.total_cmp(&lb)
            })
            .expect("queries");
        let goals = walk(&set.map, start, goal, 200);
        let n = goals.len();
        let mut group = c.benchmark_group(format!("replan/{}", set.name));
        let mut r = Replanner::new(&set.map, Mover::Benchmark, start, goal);
        r.plan();
        let mut i = 0;
        group.bench_function("lpa", |b| {
            b.iter(|| {
                i += 1;
                r.set_goal(goals[i % n]);
                r.plan()
            })
        });
        let mut i = 0;
        group.bench_function("astar", |b| {
            b.iter(|| {
                i += 1;
                planner.astar(start, goals[i % n])
            })
        });
        let mut i = 0;
        group.bench_function("jps", |b| {
            b.iter(|| {
                i += 1;
                planner.jps(start, goals[i % n])
            })
        });
        group.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    targets = queries, replanning
}
criterion_main!(benches);
