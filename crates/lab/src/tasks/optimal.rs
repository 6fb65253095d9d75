//! MURDOCH's greedy allocation against the optimal one.
//!
//! The paper calls MURDOCH "an instantaneous greedy task scheduler": each task
//! goes to the best robot free when it is announced, and an early task can take
//! the robot a later one needed. Here one stream of tasks is allocated twice:
//! by real auctions (agents and an announcer on the in-memory bus, the tasks
//! announced one after another, each robot taking at most one), and centrally,
//! with full knowledge of every robot and task, by the Kuhn-Munkres algorithm
//! on the same metrics. Both are scored by the number of tasks allocated and
//! the total of the winners' scores.

use std::time::Duration;

use colony_proto::Vec2;
use pathfinding::kuhn_munkres::kuhn_munkres;
use pathfinding::matrix::Matrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::longterm::{roster, PAPER_TASKS};
use colony_node::Bus;
use colony_node::Node;
use colony_node::Time;
use colony_tasks::protocol::{ResourceSet, SpecError, TaskSpec, Token, TokenError};
use colony_tasks::{Agent, AgentConfig};
use colony_tasks::{Announcer, AnnouncerEvent, AuctionConfig};
use colony_tasks::{Metrics, RobotView};

/// One comparison's setting.
#[derive(Debug, Clone, PartialEq)]
pub struct CompareConfig {
    /// Seeds positions, batteries and the stream.
    pub seed: u64,
    /// Robots (their sensor sets cycle through the long-term roster's).
    pub robots: usize,
    /// Tasks in the stream (of the paper's three mobile kinds).
    pub tasks: usize,
    /// Whether tasks add the `resources` metric, the paper's proposed remedy
    /// for greedy allocation (specialists before generalists).
    pub resources_term: bool,
}

/// Both allocations of one stream.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// The seed.
    pub seed: u64,
    /// Robots.
    pub robots: usize,
    /// Tasks.
    pub tasks: usize,
    /// Tasks MURDOCH allocated.
    pub greedy_allocated: usize,
    /// Total score of MURDOCH's winners.
    pub greedy_cost: f64,
    /// Tasks the optimal assignment allocates (the most possible).
    pub optimal_allocated: usize,
    /// Its total score (the least for that many tasks).
    pub optimal_cost: f64,
    /// Packets the auctions took.
    pub messages: u64,
}

impl Comparison {
    /// Greedy cost over optimal cost, when both allocated as many tasks.
    pub fn cost_ratio(&self) -> Option<f64> {
        (self.greedy_allocated == self.optimal_allocated && self.optimal_cost > 0.0)
            .then(|| self.greedy_cost / self.optimal_cost)
    }
}

/// What comparisons over many seeds add up to, for one setting of the metrics.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CompareSummary {
    /// Tasks MURDOCH allocated, over every seed.
    pub greedy_allocated: usize,
    /// Tasks the optimal assignment allocated, over every seed.
    pub optimal_allocated: usize,
    /// The cost ratios of the seeds where both allocated as many tasks, sorted.
    ratios: Vec<f64>,
}

impl CompareSummary {
    /// Adds one seed's comparison.
    pub fn add(&mut self, c: &Comparison) {
        self.greedy_allocated += c.greedy_allocated;
        self.optimal_allocated += c.optimal_allocated;
        if let Some(r) = c.cost_ratio() {
            let at = self.ratios.partition_point(|x| x.total_cmp(&r).is_le());
            self.ratios.insert(at, r);
        }
    }

    /// Seeds where both allocated as many tasks (those the ratios are over).
    pub fn seeds_compared(&self) -> usize {
        self.ratios.len()
    }

    /// The mean cost ratio greedy/optimal; 0 over no seeds.
    pub fn mean_ratio(&self) -> f64 {
        self.ratios.iter().sum::<f64>() / self.ratios.len().max(1) as f64
    }

    /// The median cost ratio (the upper one of an even count); NaN over no seeds.
    pub fn median_ratio(&self) -> f64 {
        self.ratios
            .get(self.ratios.len() / 2)
            .copied()
            .unwrap_or(f64::NAN)
    }

    /// The worst (largest) cost ratio; NaN over no seeds.
    pub fn worst_ratio(&self) -> f64 {
        self.ratios.last().copied().unwrap_or(f64::NAN)
    }
}

struct Robot {
    name: String,
    resources: ResourceSet,
    position: Vec2,
    battery: f64,
}

/// Integer weights for Kuhn-Munkres: scores in hundredths.
const SCALE: f64 = 100.0;

/// Why a comparison could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompareError {
    /// Too few or too many robots or tasks.
    #[error("robots and tasks must be between 1 and 500, not {robots} robots and {tasks} tasks")]
    Size {
        /// Robots asked for.
        robots: usize,
        /// Tasks asked for.
        tasks: usize,
    },
    /// A robot's name is not a token.
    #[error(transparent)]
    Token(#[from] TokenError),
    /// A task of the stream is invalid.
    #[error(transparent)]
    Spec(#[from] SpecError),
}

/// Allocates one stream both ways.
pub fn compare(cfg: &CompareConfig) -> Result<Comparison, CompareError> {
    if cfg.robots == 0 || cfg.tasks == 0 || cfg.robots > 500 || cfg.tasks > 500 {
        return Err(CompareError::Size {
            robots: cfg.robots,
            tasks: cfg.tasks,
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let kinds: Vec<_> = roster().into_iter().filter(|a| a.robot).collect();
    let robots: Vec<Robot> = (0..cfg.robots)
        .map(|i| {
            let kind = &kinds[i % kinds.len()];
            Robot {
                name: format!("r{i}"),
                resources: kind.resources.parse().unwrap_or_default(),
                position: Vec2::new(rng.random_range(0.0..2000.0), rng.random_range(0.0..2000.0)),
                battery: rng.random_range(0.4..1.0),
            }
        })
        .collect();
    let tasks: Vec<TaskSpec> = (0..cfg.tasks)
        .map(|_| {
            let kind = PAPER_TASKS[rng.random_range(0..3)];
            let mut spec = TaskSpec::new(kind.name, kind.resources.parse().unwrap_or_default())
                .length(3600.0)
                .param("x", rng.random_range(0.0..2000.0))
                .param("y", rng.random_range(0.0..2000.0))
                .metric("distance", 1.0)
                .metric("battery", 500.0);
            if cfg.resources_term {
                spec = spec.metric("resources", 100.0);
            }
            spec
        })
        .collect();

    // MURDOCH: the real protocol, tasks announced one by one.
    let mut bus = Bus::new(Duration::from_millis(2));
    let mut agents = Vec::new();
    for r in &robots {
        let token = Token::new(&r.name)?;
        // Nobody watches: no reports.
        let config = AgentConfig {
            report_interval: None,
            ..AgentConfig::default()
        };
        let mut a = Agent::new(token, r.resources.clone(), config, Time::ZERO);
        a.set_position(r.position);
        a.set_battery(r.battery);
        agents.push(a);
    }
    let mut announcer = Announcer::new(Token::new("user")?, AuctionConfig::default());
    let mut greedy_allocated = 0;
    let mut greedy_cost = 0.0;
    let mut now = Time::ZERO;
    for spec in &tasks {
        announcer.announce(now, spec.clone())?;
        now = now + Duration::from_secs(1);
        let mut nodes: Vec<&mut dyn Node> = agents.iter_mut().map(|a| a as &mut dyn Node).collect();
        nodes.push(&mut announcer);
        bus.run_until(&mut nodes, now);
        while let Some(e) = announcer.poll_event() {
            if let AnnouncerEvent::Awarded { score, .. } = e {
                greedy_allocated += 1;
                greedy_cost += score;
            }
        }
    }

    // The optimum, centrally, on the same metrics.
    let metrics = Metrics::standard();
    let cost = |r: &Robot, t: &TaskSpec| -> Option<f64> {
        if !t.resources.is_subset(&r.resources) {
            return None;
        }
        let view = RobotView {
            position: Some(r.position),
            heading: None,
            battery: r.battery,
            resources: &r.resources,
        };
        metrics.score(t, &view).ok()
    };
    let costs: Vec<Vec<Option<f64>>> = tasks
        .iter()
        .map(|t| robots.iter().map(|r| cost(r, t)).collect())
        .collect();
    let worst = costs
        .iter()
        .flatten()
        .flatten()
        .fold(0.0f64, |m, &c| m.max(c.abs()));
    // One more allocated task is worth more than any difference in total cost.
    let big = ((worst * SCALE).ceil() as i64 + 1) * (cfg.tasks.max(cfg.robots) as i64 + 1);
    let weight = |c: Option<f64>| c.map_or(0, |c| big - (c * SCALE).round() as i64);
    // kuhn_munkres wants no more rows than columns.
    let (rows, cols) = (cfg.tasks.min(cfg.robots), cfg.tasks.max(cfg.robots));
    let tasks_are_rows = cfg.tasks <= cfg.robots;
    let m = Matrix::from_fn(rows, cols, |(i, j)| {
        let (t, r) = if tasks_are_rows { (i, j) } else { (j, i) };
        weight(costs[t][r])
    });
    let (_, assignment) = kuhn_munkres(&m);
    let mut optimal_allocated = 0;
    let mut optimal_cost = 0.0;
    for (i, &j) in assignment.iter().enumerate() {
        let (t, r) = if tasks_are_rows { (i, j) } else { (j, i) };
        if let Some(c) = costs[t][r] {
            optimal_allocated += 1;
            optimal_cost += c;
        }
    }
    Ok(Comparison {
        seed: cfg.seed,
        robots: cfg.robots,
        tasks: cfg.tasks,
        greedy_allocated,
        greedy_cost,
        optimal_allocated,
        optimal_cost,
        messages: bus.stats().sent,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn comparison(greedy: (usize, f64), optimal: (usize, f64)) -> Comparison {
        Comparison {
            seed: 0,
            robots: 4,
            tasks: 4,
            greedy_allocated: greedy.0,
            greedy_cost: greedy.1,
            optimal_allocated: optimal.0,
            optimal_cost: optimal.1,
            messages: 0,
        }
    }

    #[test]
    fn a_summary_counts_every_seed_but_takes_ratios_only_where_both_allocated_as_many() {
        let mut s = CompareSummary::default();
        assert_eq!(s.mean_ratio(), 0.0);
        assert!(s.median_ratio().is_nan() && s.worst_ratio().is_nan());
        s.add(&comparison((3, 30.0), (3, 20.0)));
        s.add(&comparison((2, 10.0), (3, 20.0)));
        s.add(&comparison((3, 22.0), (3, 20.0)));
        assert_eq!((s.greedy_allocated, s.optimal_allocated), (8, 9));
        assert_eq!(s.seeds_compared(), 2);
        assert!((s.mean_ratio() - 1.3).abs() < 1e-12);
        assert_eq!(s.median_ratio(), 1.5, "the upper of two");
        assert_eq!(s.worst_ratio(), 1.5);
    }
}
