//! Turn points and line of sight: few points, and segments that keep clear.

use colony_game::map::{Cell, GridMap};
use colony_game::path::{astar, line_of_sight, turn_points, Mover};
use proptest::prelude::*;

fn map(rows: &[&str]) -> GridMap {
    let text = format!(
        "type octile\nheight {}\nwidth {}\nmap\n{}\n",
        rows.len(),
        rows[0].len(),
        rows.join("\n")
    );
    GridMap::parse(&text).unwrap()
}

/// Samples the segment densely: no sample may fall within `clearance` of a
/// blocked cell (checked against each blocked square directly).
fn segment_is_clear(m: &GridMap, a: (f64, f64), b: (f64, f64), clearance: f64) -> bool {
    let blocked: Vec<(f64, f64)> = (0..m.height())
        .flat_map(|y| (0..m.width()).map(move |x| (x, y)))
        .filter(|&(x, y)| !m.get(x, y).unwrap().is_land())
        .map(|(x, y)| (f64::from(x), f64::from(y)))
        .collect();
    let n = 400;
    (0..=n).all(|i| {
        let t = f64::from(i) / f64::from(n);
        let (px, py) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        let inside =
            px >= 0.0 && py >= 0.0 && px <= f64::from(m.width()) && py <= f64::from(m.height());
        inside
            && blocked.iter().all(|&(sx, sy)| {
                let dx = (sx - px).max(0.0).max(px - sx - 1.0);
                let dy = (sy - py).max(0.0).max(py - sy - 1.0);
                dx.hypot(dy) >= clearance - 1e-6
            })
    })
}

#[test]
fn a_straight_corridor_gives_two_points() {
    let m = map(&["@@@@@@@@", "@......@", "@@@@@@@@"]);
    let p = astar(&m, Mover::Land, Cell::new(1, 1), Cell::new(6, 1)).unwrap();
    assert_eq!(
        turn_points(&m, Mover::Land, &p, 0.5),
        vec![(1.5, 1.5), (6.5, 1.5)]
    );
}

#[test]
fn an_l_shaped_corridor_gives_three_points() {
    let m = map(&["@@@@@@", "@....@", "@@@@.@", "@@@@.@", "@@@@.@", "@@@@@@"]);
    let p = astar(&m, Mover::Land, Cell::new(1, 1), Cell::new(4, 4)).unwrap();
    assert_eq!(
        turn_points(&m, Mover::Land, &p, 0.3),
        vec![(1.5, 1.5), (4.5, 1.5), (4.5, 4.5)]
    );
}

#[test]
fn open_ground_pulls_a_zigzag_straight() {
    let m = GridMap::new(30, 30, colony_game::map::Terrain::Open);
    let p = astar(&m, Mover::Land, Cell::new(1, 2), Cell::new(27, 11)).unwrap();
    assert!(p.cells.len() > 20);
    assert_eq!(
        turn_points(&m, Mover::Land, &p, 0.5),
        vec![(1.5, 2.5), (27.5, 11.5)]
    );
}

#[test]
fn start_equals_goal_gives_one_point() {
    let m = GridMap::new(3, 3, colony_game::map::Terrain::Open);
    let p = astar(&m, Mover::Land, Cell::new(1, 1), Cell::new(1, 1)).unwrap();
    assert_eq!(turn_points(&m, Mover::Land, &p, 0.5), vec![(1.5, 1.5)]);
}

#[test]
fn line_of_sight_respects_clearance_and_mover() {
    let m = map(&["......", "..T...", "......", "WWWWWW"]);
    // Passing the tree half a cell away.
    assert!(line_of_sight(&m, Mover::Land, (0.5, 0.5), (5.5, 0.5), 0.5));
    assert!(!line_of_sight(
        &m,
        Mover::Land,
        (0.5, 0.5),
        (5.5, 0.5),
        0.51
    ));
    // Through the tree.
    assert!(!line_of_sight(&m, Mover::Land, (0.5, 1.5), (5.5, 1.5), 0.0));
    // Grazing its corner exactly is touching it.
    assert!(!line_of_sight(&m, Mover::Land, (1.0, 0.0), (3.0, 2.0), 0.0));
    // Water: a wall for land units, open for amphibians; under the benchmark
    // rules land and water don't mix.
    assert!(!line_of_sight(&m, Mover::Land, (0.5, 2.5), (0.5, 3.5), 0.0));
    assert!(line_of_sight(
        &m,
        Mover::Amphibious,
        (0.5, 2.5),
        (0.5, 3.5),
        0.0
    ));
    assert!(!line_of_sight(
        &m,
        Mover::Benchmark,
        (0.5, 2.5),
        (0.5, 3.5),
        0.0
    ));
    assert!(line_of_sight(
        &m,
        Mover::Benchmark,
        (0.5, 3.5),
        (5.5, 3.5),
        0.5
    ));
    // Off the map, or nonsense numbers.
    assert!(!line_of_sight(&m, Mover::Land, (0.5, 0.5), (7.5, 0.5), 0.0));
    assert!(!line_of_sight(
        &m,
        Mover::Land,
        (0.5, 0.5),
        (0.5, 0.5),
        -1.0
    ));
    assert!(!line_of_sight(
        &m,
        Mover::Land,
        (f64::NAN, 0.5),
        (0.5, 0.5),
        0.1
    ));
    assert!(!line_of_sight(
        &m,
        Mover::Land,
        (0.5, 0.5),
        (1.5, 0.5),
        f64::INFINITY
    ));
}

fn random_map() -> impl Strategy<Value = GridMap> {
    (2u32..16, 2u32..16).prop_flat_map(|(w, h)| {
        prop::collection::vec(prop::bool::weighted(0.2), (w * h) as usize).prop_map(move |b| {
            let rows: Vec<String> = b
                .chunks(w as usize)
                .map(|r| r.iter().map(|&t| if t { 'T' } else { '.' }).collect())
                .collect();
            let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
            map(&refs)
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn no_turn_point_segment_crosses_or_nears_a_blocked_cell(
        m in random_map(),
        s in any::<(u32, u32)>(),
        t in any::<(u32, u32)>(),
        clearance in prop::sample::select(vec![0.0, 0.2, 0.35, 0.5]),
    ) {
        let s = Cell::new(s.0 % m.width(), s.1 % m.height());
        let t = Cell::new(t.0 % m.width(), t.1 % m.height());
        if let Some(p) = astar(&m, Mover::Land, s, t) {
            let pts = turn_points(&m, Mover::Land, &p, clearance);
            prop_assert_eq!(pts[0], (f64::from(s.x) + 0.5, f64::from(s.y) + 0.5));
            prop_assert_eq!(*pts.last().unwrap(), (f64::from(t.x) + 0.5, f64::from(t.y) + 0.5));
            prop_assert!(pts.len() <= p.cells.len());
            for w in pts.windows(2) {
                prop_assert!(line_of_sight(&m, Mover::Land, w[0], w[1], clearance));
                prop_assert!(segment_is_clear(&m, w[0], w[1], clearance), "{:?}\n{}", w, m);
            }
        }
    }
}
