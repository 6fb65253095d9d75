//! A*, jump point search and the replanner against a plain Dijkstra written
//! here from the movement rules alone, on random small grids, and against the
//! published Moving AI lengths.

use colony_game::map::{Cell, GridMap, Terrain};
use colony_game::path::{scen, Algorithm, Mover, Path, Planner, Replanner};
use proptest::prelude::*;

const MOVERS: [Mover; 3] = [Mover::Benchmark, Mover::Land, Mover::Amphibious];

/// Which cells connect, restated independently of the library.
fn region(t: Terrain, mover: Mover) -> Option<u8> {
    match t {
        Terrain::Open | Terrain::Swamp => Some(0),
        Terrain::Water => match mover {
            Mover::Benchmark => Some(1),
            Mover::Amphibious => Some(0),
            Mover::Land => None,
        },
        Terrain::Tree | Terrain::OutOfBounds => None,
    }
}

/// The legal steps out of `c` with their costs.
fn steps(map: &GridMap, mover: Mover, c: Cell) -> Vec<(Cell, f64)> {
    let at = |x: i64, y: i64| -> Option<u8> {
        if x < 0 || y < 0 {
            return None;
        }
        region(map.get(x as u32, y as u32)?, mover)
    };
    let (x, y) = (i64::from(c.x), i64::from(c.y));
    let Some(k) = at(x, y) else { return vec![] };
    let mut out = vec![];
    for dx in -1..=1i64 {
        for dy in -1..=1i64 {
            if (dx, dy) == (0, 0) || at(x + dx, y + dy) != Some(k) {
                continue;
            }
            if dx != 0 && dy != 0 {
                if at(x + dx, y) != Some(k) || at(x, y + dy) != Some(k) {
                    continue;
                }
                out.push((Cell::new((x + dx) as u32, (y + dy) as u32), 2f64.sqrt()));
            } else {
                out.push((Cell::new((x + dx) as u32, (y + dy) as u32), 1.0));
            }
        }
    }
    out
}

fn dijkstra(map: &GridMap, mover: Mover, s: Cell, t: Cell) -> Option<f64> {
    let w = map.width() as usize;
    let idx = |c: Cell| c.y as usize * w + c.x as usize;
    let n = w * map.height() as usize;
    if !map.contains(s) || !map.contains(t) {
        return None;
    }
    region(map.terrain(s)?, mover)?;
    region(map.terrain(t)?, mover)?;
    let mut dist = vec![f64::INFINITY; n];
    let mut done = vec![false; n];
    dist[idx(s)] = 0.0;
    loop {
        // O(n^2) on purpose: simple enough to trust.
        let mut best: Option<(usize, f64)> = None;
        for i in 0..n {
            if !done[i] && dist[i].is_finite() && best.is_none_or(|(_, d)| dist[i] < d) {
                best = Some((i, dist[i]));
            }
        }
        let (i, d) = best?;
        let c = Cell::new((i % w) as u32, (i / w) as u32);
        if c == t {
            return Some(d);
        }
        done[i] = true;
        for (v, cost) in steps(map, mover, c) {
            let j = idx(v);
            if d + cost < dist[j] {
                dist[j] = d + cost;
            }
        }
    }
}

/// The path is made of legal steps from `s` to `t` and its length is theirs.
fn assert_valid(map: &GridMap, mover: Mover, p: &Path, s: Cell, t: Cell) {
    assert_eq!(p.cells.first(), Some(&s));
    assert_eq!(p.cells.last(), Some(&t));
    let mut len = 0.0;
    for w in p.cells.windows(2) {
        let step = steps(map, mover, w[0])
            .into_iter()
            .find(|(c, _)| *c == w[1]);
        let (_, cost) = step.unwrap_or_else(|| panic!("illegal step {} -> {}", w[0], w[1]));
        len += cost;
    }
    assert!((len - p.length).abs() < 1e-9, "{len} vs {}", p.length);
}

fn terrain() -> impl Strategy<Value = Terrain> {
    prop_oneof![
        10 => Just(Terrain::Open),
        2 => Just(Terrain::Swamp),
        3 => Just(Terrain::Tree),
        3 => Just(Terrain::Water),
        1 => Just(Terrain::OutOfBounds),
    ]
}

fn grid(max: u32) -> impl Strategy<Value = GridMap> {
    (1..=max, 1..=max).prop_flat_map(|(w, h)| {
        prop::collection::vec(terrain(), (w * h) as usize).prop_map(move |cells| {
            let rows = cells.chunks(w as usize).map(|r| r.to_vec()).collect();
            GridMap::from_rows(rows).expect("rectangular")
        })
    })
}

fn cell_in(map: &GridMap, (a, b): (u32, u32)) -> Cell {
    Cell::new(a % map.width(), b % map.height())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn astar_and_jps_lengths_equal_dijkstra(
        map in grid(12),
        pairs in prop::collection::vec((any::<(u32, u32)>(), any::<(u32, u32)>()), 1..6),
    ) {
        for mover in MOVERS {
            let mut planner = Planner::new(&map, mover);
            for &(a, b) in &pairs {
                let (s, t) = (cell_in(&map, a), cell_in(&map, b));
                let want = dijkstra(&map, mover, s, t);
                for algorithm in [Algorithm::AStar, Algorithm::Jps] {
                    let got = planner.find(algorithm, s, t);
                    match (&got, want) {
                        (None, None) => {}
                        (Some(p), Some(d)) => {
                            prop_assert!((p.length - d).abs() < 1e-9,
                                "{algorithm:?} {mover:?} {s}->{t}: {} vs {d}\n{map}", p.length);
                            assert_valid(&map, mover, p, s, t);
                        }
                        _ => prop_assert!(false, "{algorithm:?} {mover:?} {s}->{t}: {got:?} vs {want:?}\n{map}"),
                    }
                }
            }
        }
    }

    #[test]
    fn replanner_matches_fresh_astar_after_goal_moves_and_changes(
        map in grid(14),
        start in any::<(u32, u32)>(),
        ops in prop::collection::vec((0u8..4, any::<(u32, u32)>()), 1..25),
        mover_pick in 0usize..3,
    ) {
        let mover = MOVERS[mover_pick];
        let start = cell_in(&map, start);
        let mut goal = cell_in(&map, (start.x + 3, start.y + 2));
        let mut r = Replanner::new(&map, mover, start, goal);
        let mut blocked = std::collections::BTreeSet::new();
        for (kind, at) in ops {
            let c = cell_in(&map, at);
            match kind {
                0 | 1 => { goal = c; r.set_goal(c); }
                2 => { blocked.insert(c); r.set_blocked(c, true); }
                _ => { blocked.remove(&c); r.set_blocked(c, false); }
            }
            let mut now = map.clone();
            for &b in &blocked {
                now.set(b, Terrain::OutOfBounds);
            }
            let want = Planner::new(&now, mover).astar(start, goal);
            let got = r.plan();
            match (&got, &want) {
                (None, None) => {}
                (Some(p), Some(q)) => {
                    prop_assert!((p.length - q.length).abs() < 1e-9,
                        "{mover:?} {start}->{goal}: {} vs {}\n{now}", p.length, q.length);
                    assert_valid(&now, mover, p, start, goal);
                }
                _ => prop_assert!(false, "{mover:?} {start}->{goal}: {got:?} vs {want:?}\n{now}"),
            }
        }
    }
}

#[test]
fn replanning_after_a_small_goal_move_expands_little() {
    let map = GridMap::new(200, 200, Terrain::Open);
    let mut r = Replanner::new(&map, Mover::Land, Cell::new(5, 5), Cell::new(150, 120));
    r.plan().unwrap();
    let first = r.expanded();
    r.set_goal(Cell::new(151, 121));
    let p = r.plan().unwrap();
    let again = r.expanded() - first;
    assert!(again * 10 < first.max(10), "{again} after {first}");
    let fresh = Planner::new(&map, Mover::Land).astar(Cell::new(5, 5), Cell::new(151, 121));
    assert!((p.length - fresh.unwrap().length).abs() < 1e-9);
}

#[test]
fn endpoints_off_the_map_or_blocked_have_no_path() {
    let map = GridMap::parse("type octile\nheight 1\nwidth 3\nmap\n.T.\n").unwrap();
    let mut p = Planner::new(&map, Mover::Land);
    for alg in [Algorithm::AStar, Algorithm::Jps] {
        assert!(p.find(alg, Cell::new(0, 0), Cell::new(5, 0)).is_none());
        assert!(p.find(alg, Cell::new(0, 0), Cell::new(1, 0)).is_none());
        assert!(p.find(alg, Cell::new(0, 0), Cell::new(2, 0)).is_none());
        let same = p.find(alg, Cell::new(2, 0), Cell::new(2, 0)).unwrap();
        assert_eq!((same.cells.len(), same.length), (1, 0.0));
    }
    let empty = GridMap::new(0, 0, Terrain::Open);
    assert!(Planner::new(&empty, Mover::Land)
        .jps(Cell::new(0, 0), Cell::new(0, 0))
        .is_none());
    let mut r = Replanner::new(&empty, Mover::Land, Cell::new(0, 0), Cell::new(0, 0));
    assert!(r.plan().is_none());
}

#[test]
fn benchmark_water_is_entered_only_from_water() {
    // Land on the left, water on the right: under the benchmark rules the
    // shore is a wall both ways; amphibians cross it.
    let map = GridMap::parse("type octile\nheight 2\nwidth 4\nmap\n..WW\n..WW\n").unwrap();
    let (land, water) = (Cell::new(0, 0), Cell::new(3, 1));
    assert!(Planner::new(&map, Mover::Benchmark)
        .jps(land, water)
        .is_none());
    assert!(Planner::new(&map, Mover::Benchmark)
        .astar(water, land)
        .is_none());
    let w = Planner::new(&map, Mover::Benchmark)
        .jps(Cell::new(2, 0), water)
        .unwrap();
    assert!((w.length - 2f64.sqrt()).abs() < 1e-12);
    assert!(Planner::new(&map, Mover::Land).astar(land, water).is_none());
    let a = Planner::new(&map, Mover::Amphibious)
        .jps(land, water)
        .unwrap();
    assert!((a.length - (2.0 + 2f64.sqrt())).abs() < 1e-12);
}

fn check_benchmark(map: &str, scen_file: &str, every: usize, algorithms: &[Algorithm]) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../maps/movingai/");
    let map = GridMap::from_file(format!("{dir}{map}")).unwrap();
    let queries = scen::from_file(format!("{dir}{scen_file}")).unwrap();
    let mut planner = Planner::new(&map, Mover::Benchmark);
    for q in queries.iter().step_by(every) {
        for &alg in algorithms {
            let p = planner.find(alg, q.start, q.goal).expect("reachable");
            assert!(
                (p.length - q.optimal).abs() < 1e-4,
                "{alg:?} line {}: {} vs {}",
                q.line,
                p.length,
                q.optimal
            );
        }
    }
}

#[test]
fn published_lengths_are_reproduced_on_arena_and_random() {
    let both = [Algorithm::AStar, Algorithm::Jps];
    check_benchmark("arena.map", "arena.map.scen", 1, &both);
    check_benchmark(
        "random-32-32-10.map",
        "random-32-32-10-random-1.scen",
        1,
        &both,
    );
}

#[test]
fn published_lengths_are_reproduced_on_a_sample_of_maze512() {
    // A* on the whole maze set takes minutes in a debug build; the CLI test
    // runs all of it with JPS.
    check_benchmark(
        "maze512-32-9.map",
        "maze512-32-9.map.scen",
        97,
        &[Algorithm::Jps],
    );
    check_benchmark(
        "maze512-32-9.map",
        "maze512-32-9.map.scen",
        401,
        &[Algorithm::AStar],
    );
}
