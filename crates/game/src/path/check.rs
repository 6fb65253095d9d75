//! Checking the planner against a Moving AI scenario: every query's length against the
//! published optimum, each timed, as `colony path` reports them.
//!
//! ```no_run
//! use colony_game::map::GridMap;
//! use colony_game::path::{check::ScenarioCheck, scen, Algorithm};
//! let map = GridMap::from_file("arena.map")?;
//! let queries = scen::from_file("arena.map.scen")?;
//! let mut check = ScenarioCheck::new(&map, queries, Algorithm::Jps)?;
//! for outcome in check.by_ref() {
//!     assert!(outcome.ok, "query {} found {:?}", outcome.index, outcome.found);
//! }
//! println!("{}", check.summary());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::fmt;
use std::time::Instant;

use super::scen::Query;
use super::{Algorithm, Mover, Planner};
use crate::map::GridMap;

/// Lengths within this of the published ones count as optimal.
pub const TOLERANCE: f64 = 1e-4;

/// A scenario that does not fit its map.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("line {line} of the scenario is for a {width} x {height} map, but the map is {map_width} x {map_height}")]
pub struct WrongMap {
    /// The query's line in the scenario file.
    pub line: usize,
    /// The map width the query was made for.
    pub width: u32,
    /// The map height the query was made for.
    pub height: u32,
    /// The map's width.
    pub map_width: u32,
    /// The map's height.
    pub map_height: u32,
}

/// One query, planned and judged.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Its place in the scenario, from 0.
    pub index: usize,
    /// The query.
    pub query: Query,
    /// The length found, or `None` when the planner found no path.
    pub found: Option<f64>,
    /// How long the planner took, µs.
    pub micros: f64,
    /// Whether the length found is the published optimum.
    pub ok: bool,
}

/// A scenario being checked, one query per [`Iterator::next`].
pub struct ScenarioCheck {
    planner: Planner,
    algorithm: Algorithm,
    queries: std::vec::IntoIter<Query>,
    index: usize,
    micros: Vec<f64>,
    mismatches: usize,
}

impl ScenarioCheck {
    /// A check of `queries` on `map` with `algorithm`, as the benchmarks move (no corner
    /// cutting); refused if a query was made for a map of another size.
    pub fn new(
        map: &GridMap,
        queries: Vec<Query>,
        algorithm: Algorithm,
    ) -> Result<ScenarioCheck, WrongMap> {
        if let Some(q) = queries
            .iter()
            .find(|q| (q.width, q.height) != (map.width(), map.height()))
        {
            return Err(WrongMap {
                line: q.line,
                width: q.width,
                height: q.height,
                map_width: map.width(),
                map_height: map.height(),
            });
        }
        Ok(ScenarioCheck {
            planner: Planner::new(map, Mover::Benchmark),
            algorithm,
            micros: Vec::with_capacity(queries.len()),
            queries: queries.into_iter(),
            index: 0,
            mismatches: 0,
        })
    }

    /// What has been checked so far.
    pub fn summary(&self) -> Summary {
        let total = self.micros.len();
        let mean = if total == 0 {
            0.0
        } else {
            self.micros.iter().sum::<f64>() / total as f64
        };
        let mut sorted = self.micros.clone();
        sorted.sort_by(f64::total_cmp);
        Summary {
            algorithm: self.algorithm,
            total,
            mismatches: self.mismatches,
            mean_micros: mean,
            p99_micros: nearest_rank(&sorted, 0.99),
        }
    }
}

impl Iterator for ScenarioCheck {
    type Item = Outcome;

    fn next(&mut self) -> Option<Outcome> {
        let query = self.queries.next()?;
        let t0 = Instant::now();
        let found = self
            .planner
            .find(self.algorithm, query.start, query.goal)
            .map(|p| p.length);
        let micros = t0.elapsed().as_secs_f64() * 1e6;
        let ok = found.is_some_and(|l| (l - query.optimal).abs() <= TOLERANCE);
        self.micros.push(micros);
        self.mismatches += usize::from(!ok);
        let index = self.index;
        self.index += 1;
        Some(Outcome {
            index,
            query,
            found,
            micros,
            ok,
        })
    }
}

/// The totals of a check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// The algorithm checked.
    pub algorithm: Algorithm,
    /// Queries checked.
    pub total: usize,
    /// Queries whose length was not the published optimum.
    pub mismatches: usize,
    /// Mean planning time, µs.
    pub mean_micros: f64,
    /// 99th percentile (nearest rank) of the planning time, µs.
    pub p99_micros: f64,
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} queries, {} optimal, {} mismatches; {:?}: mean {:.1} µs, p99 {:.1} µs per query",
            self.total,
            self.total - self.mismatches,
            self.mismatches,
            self.algorithm,
            self.mean_micros,
            self.p99_micros
        )
    }
}

/// The `p` quantile (nearest rank) of `sorted`; 0 for none.
fn nearest_rank(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let rank = ((p * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[rank - 1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::Cell;

    const MAP: &str = "type octile\nheight 3\nwidth 4\nmap\n....\n.@@.\n....\n";

    fn query(line: usize, start: Cell, goal: Cell, optimal: f64) -> Query {
        Query {
            line,
            bucket: 0,
            map: "m.map".into(),
            width: 4,
            height: 3,
            start,
            goal,
            optimal,
        }
    }

    #[test]
    fn each_query_is_judged_against_its_published_length_and_counted() {
        let map = GridMap::parse(MAP).unwrap();
        let queries = vec![
            query(2, Cell::new(0, 0), Cell::new(3, 0), 3.0),
            query(3, Cell::new(0, 0), Cell::new(3, 0), 2.0),
        ];
        let mut check = ScenarioCheck::new(&map, queries, Algorithm::Jps).unwrap();
        let outcomes: Vec<Outcome> = check.by_ref().collect();
        assert_eq!(outcomes.len(), 2);
        assert!(outcomes[0].ok && outcomes[0].found == Some(3.0));
        assert!(!outcomes[1].ok, "3 is not the claimed 2");
        let s = check.summary();
        assert_eq!((s.total, s.mismatches), (2, 1));
        assert!(s
            .to_string()
            .starts_with("2 queries, 1 optimal, 1 mismatches; Jps: mean "));
    }

    #[test]
    fn a_scenario_for_another_map_size_is_refused_naming_the_line() {
        let map = GridMap::parse(MAP).unwrap();
        let mut q = query(7, Cell::new(0, 0), Cell::new(1, 0), 1.0);
        q.width = 9;
        let e = ScenarioCheck::new(&map, vec![q], Algorithm::AStar)
            .err()
            .unwrap();
        assert_eq!(e.line, 7);
        assert!(
            e.to_string().contains("9 x 3 map, but the map is 4 x 3"),
            "{e}"
        );
    }

    #[test]
    fn nearest_rank_of_nothing_is_zero_and_of_one_is_itself() {
        assert_eq!(nearest_rank(&[], 0.99), 0.0);
        assert_eq!(nearest_rank(&[5.0], 0.99), 5.0);
        assert_eq!(nearest_rank(&[1.0, 2.0, 3.0, 4.0], 0.5), 2.0);
    }
}
