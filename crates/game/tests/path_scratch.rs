use colony_game::map::GridMap;
use colony_game::path::{scen, Mover, Planner};
#[test]
fn scratch() {
    let map = GridMap::from_file("../../maps/movingai/maze512-32-9.map").unwrap();
    let qs = scen::from_file("../../maps/movingai/maze512-32-9.map.scen").unwrap();
    let mut p = Planner::new(&map, Mover::Benchmark);
    let mut open = 0; let mut total = 0usize; let mut tj = 0usize;
    for q in qs.iter().step_by(100) {
        let t = std::time::Instant::now();
        p.astar(q.start, q.goal).unwrap();
        let e = p.expanded(); total += e;
        let dt = t.elapsed();
        p.jps(q.start, q.goal).unwrap(); tj += p.expanded();
        open += 1;
        if open % 10 == 0 { println!("len {:.0} expanded {} in {:?} jps {}", q.optimal, e, dt, p.expanded()); }
    }
    println!("mean astar expanded {} jps {}", total / open, tj / open);
}
