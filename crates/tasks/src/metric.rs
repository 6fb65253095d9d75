//! Metrics: how a robot scores its own fitness for a task.
//!
//! Every robot knows the same metric names (the shared vocabulary the paper
//! assumes); a task lists the ones to use with their weights, and a robot's
//! score is `Σ weight · metric`. Scores are costs, lowest wins. A robot that
//! cannot evaluate one of a task's metrics does not bid.

use std::collections::BTreeMap;
use std::fmt;

use colony_proto::Vec2;

use crate::protocol::ResourceSet;
use crate::protocol::TaskSpec;

/// What a metric may look at: the robot's own view of itself.
#[derive(Debug, Clone, Copy)]
pub struct RobotView<'a> {
    /// Where the robot believes it is, cm (none for a robot with no localisation).
    pub position: Option<Vec2>,
    /// Which way it faces, rad (none when it does not know).
    pub heading: Option<f64>,
    /// Its battery's charge, 0 (flat) to 1 (full).
    pub battery: f64,
    /// Its resources.
    pub resources: &'a ResourceSet,
}

/// A metric: `None` when it cannot be evaluated for this robot and task.
pub type MetricFn = dyn Fn(&TaskSpec, &RobotView<'_>) -> Option<f64> + Send;

/// Why a robot cannot score a task.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MetricError {
    /// The task names a metric this robot does not know.
    #[error("unknown metric `{0}`")]
    Unknown(String),
    /// The metric does not apply (a distance without a goal, or without a position).
    #[error("metric `{0}` cannot be evaluated for this task and robot")]
    NotApplicable(String),
}

/// The metrics a robot knows, by name.
///
/// ```
/// use colony_tasks::{Metrics, RobotView, TaskSpec, ResourceSet};
/// use colony_proto::Vec2;
/// let metrics = Metrics::standard();
/// let task = TaskSpec::new("goto", "mobile".parse().unwrap())
///     .param("x", 30.0).param("y", 40.0)
///     .metric("distance", 1.0).metric("battery", 100.0);
/// let resources: ResourceSet = "mobile camera".parse().unwrap();
/// let me = RobotView { position: Some(Vec2::ZERO), heading: None, battery: 0.75, resources: &resources };
/// assert_eq!(metrics.score(&task, &me).unwrap(), 50.0 + 25.0);
/// ```
pub struct Metrics {
    table: BTreeMap<String, Box<MetricFn>>,
}

impl Metrics {
    /// No metrics at all.
    pub fn empty() -> Metrics {
        Metrics {
            table: BTreeMap::new(),
        }
    }

    /// The standard vocabulary:
    /// - `distance`: straight-line distance, cm, from the robot to the task's
    ///   `x`, `y` parameters;
    /// - `battery`: charge used, `1 - battery`, so fuller robots score better;
    /// - `resources`: how many resources the robot would tie up, so a
    ///   specialist beats a generalist who may be needed later (the paper's
    ///   proposed fix for greedy allocation);
    /// - `length`: the task's expected length, s (the same for every bidder;
    ///   useful only to weight tasks against each other in comparisons).
    pub fn standard() -> Metrics {
        let mut m = Metrics::empty();
        m.insert("distance", |task, robot| {
            let goal = Vec2::new(task.number("x")?, task.number("y")?);
            Some(robot.position?.distance(goal))
        });
        m.insert("battery", |_, robot| {
            Some(1.0 - robot.battery.clamp(0.0, 1.0))
        });
        m.insert("resources", |_, robot| Some(robot.resources.len() as f64));
        m.insert("length", |task, _| Some(task.length_s));
        m
    }

    /// Adds or replaces a metric.
    pub fn insert(
        &mut self,
        name: &str,
        f: impl Fn(&TaskSpec, &RobotView<'_>) -> Option<f64> + Send + 'static,
    ) {
        self.table.insert(name.to_owned(), Box::new(f));
    }

    /// Whether a metric of this name is known.
    pub fn knows(&self, name: &str) -> bool {
        self.table.contains_key(name)
    }

    /// The task's score for this robot: the weighted sum of its metrics (0 if it lists none).
    pub fn score(&self, task: &TaskSpec, robot: &RobotView<'_>) -> Result<f64, MetricError> {
        let mut total = 0.0;
        for term in &task.metrics {
            let f = self
                .table
                .get(&term.name)
                .ok_or_else(|| MetricError::Unknown(term.name.clone()))?;
            let v = f(task, robot)
                .filter(|v| v.is_finite())
                .ok_or_else(|| MetricError::NotApplicable(term.name.clone()))?;
            total += term.weight * v;
        }
        if total.is_finite() {
            Ok(total)
        } else {
            Err(MetricError::NotApplicable("(sum)".into()))
        }
    }
}

impl Default for Metrics {
    fn default() -> Self {
        Metrics::standard()
    }
}

impl fmt::Debug for Metrics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.table.keys()).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn resources() -> ResourceSet {
        "camera laser mobile".parse().unwrap()
    }

    fn view(resources: &ResourceSet, position: Option<Vec2>, battery: f64) -> RobotView<'_> {
        RobotView {
            position,
            heading: None,
            battery,
            resources,
        }
    }

    fn goto(x: f64, y: f64) -> TaskSpec {
        TaskSpec::new("goto", "mobile".parse().unwrap())
            .param("x", x)
            .param("y", y)
            .length(30.0)
    }

    #[test]
    fn distance_is_the_straight_line_to_the_tasks_x_and_y() {
        let r = resources();
        let task = goto(3.0, 4.0).metric("distance", 1.0);
        let me = view(&r, Some(Vec2::ZERO), 1.0);
        assert_eq!(Metrics::standard().score(&task, &me), Ok(5.0));
    }

    #[test]
    fn battery_scores_the_charge_used_so_fuller_is_cheaper() {
        let r = resources();
        let task = goto(0.0, 0.0).metric("battery", 1.0);
        let m = Metrics::standard();
        assert_eq!(m.score(&task, &view(&r, None, 1.0)), Ok(0.0));
        assert_eq!(m.score(&task, &view(&r, None, 0.25)), Ok(0.75));
        // Out-of-range charges are clamped, not extrapolated.
        assert_eq!(m.score(&task, &view(&r, None, 1.5)), Ok(0.0));
        assert_eq!(m.score(&task, &view(&r, None, -2.0)), Ok(1.0));
    }

    #[test]
    fn resources_counts_what_the_robot_would_tie_up() {
        let r = resources();
        let task = goto(0.0, 0.0).metric("resources", 1.0);
        assert_eq!(
            Metrics::standard().score(&task, &view(&r, None, 1.0)),
            Ok(3.0)
        );
    }

    #[test]
    fn length_is_the_tasks_own_length_for_every_robot() {
        let r = resources();
        let task = goto(0.0, 0.0).metric("length", 2.0);
        assert_eq!(
            Metrics::standard().score(&task, &view(&r, Some(Vec2::new(9.0, 9.0)), 0.1)),
            Ok(60.0)
        );
    }

    #[test]
    fn the_score_is_the_weighted_sum_of_the_tasks_metrics() {
        let r = resources();
        let task = goto(6.0, 8.0)
            .metric("distance", 0.5)
            .metric("battery", 100.0)
            .metric("resources", -2.0);
        let me = view(&r, Some(Vec2::ZERO), 0.5);
        // 0.5·10 + 100·0.5 − 2·3
        assert_eq!(Metrics::standard().score(&task, &me), Ok(49.0));
    }

    #[test]
    fn a_task_with_no_metrics_scores_zero() {
        let r = resources();
        let task = goto(1.0, 1.0);
        assert_eq!(Metrics::empty().score(&task, &view(&r, None, 0.0)), Ok(0.0));
    }

    #[test]
    fn an_unknown_metric_is_named() {
        let r = resources();
        let task = goto(0.0, 0.0)
            .metric("battery", 1.0)
            .metric("charisma", 1.0);
        let e = Metrics::standard()
            .score(&task, &view(&r, None, 1.0))
            .unwrap_err();
        assert_eq!(e, MetricError::Unknown("charisma".into()));
        assert_eq!(e.to_string(), "unknown metric `charisma`");
    }

    #[test]
    fn distance_without_a_position_does_not_apply() {
        let r = resources();
        let task = goto(3.0, 4.0).metric("distance", 1.0);
        assert_eq!(
            Metrics::standard().score(&task, &view(&r, None, 1.0)),
            Err(MetricError::NotApplicable("distance".into()))
        );
    }

    #[test]
    fn distance_without_a_goal_does_not_apply() {
        let r = resources();
        let task = TaskSpec::new("wander", "mobile".parse().unwrap())
            .param("x", 3.0)
            .text_param("y", "north")
            .metric("distance", 1.0);
        assert_eq!(
            Metrics::standard().score(&task, &view(&r, Some(Vec2::ZERO), 1.0)),
            Err(MetricError::NotApplicable("distance".into()))
        );
    }

    #[test]
    fn a_metric_that_returns_a_non_finite_value_does_not_apply() {
        let r = resources();
        let mut m = Metrics::empty();
        m.insert("broken", |_, _| Some(f64::NAN));
        m.insert("endless", |_, _| Some(f64::INFINITY));
        for name in ["broken", "endless"] {
            let task = goto(0.0, 0.0).metric(name, 1.0);
            assert_eq!(
                m.score(&task, &view(&r, None, 1.0)),
                Err(MetricError::NotApplicable(name.into()))
            );
        }
    }

    #[test]
    fn a_sum_that_overflows_is_refused_rather_than_bid() {
        let r = resources();
        let mut m = Metrics::empty();
        m.insert("huge", |_, _| Some(f64::MAX));
        m.insert("huge2", |_, _| Some(f64::MAX));
        let task = goto(0.0, 0.0).metric("huge", 1.0).metric("huge2", 1.0);
        assert_eq!(
            m.score(&task, &view(&r, None, 1.0)),
            Err(MetricError::NotApplicable("(sum)".into()))
        );
    }

    #[test]
    fn insert_replaces_a_metric_of_the_same_name() {
        let r = resources();
        let mut m = Metrics::standard();
        m.insert("battery", |_, _| Some(42.0));
        let task = goto(0.0, 0.0).metric("battery", 1.0);
        assert_eq!(m.score(&task, &view(&r, None, 1.0)), Ok(42.0));
    }

    #[test]
    fn knows_lists_exactly_the_standard_vocabulary() {
        let m = Metrics::standard();
        for name in ["distance", "battery", "resources", "length"] {
            assert!(m.knows(name), "{name}");
        }
        assert!(!m.knows("speed"));
        assert!(!Metrics::empty().knows("distance"));
        assert_eq!(
            format!("{m:?}"),
            r#"["battery", "distance", "length", "resources"]"#
        );
    }
}
