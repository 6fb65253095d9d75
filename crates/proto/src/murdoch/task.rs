//! Tasks as users write them: a name, the resources it needs, how long it takes,
//! its parameters and how robots score themselves for it.

use std::fmt;

use super::{ResourceSet, MAX_TASK_RESOURCES};
use crate::fields::{self, valid_subject_name as valid_name, MAX_MAGNITUDE, MAX_TEXT};

/// The longest task length, s (a week).
pub const MAX_LENGTH_S: f64 = 7.0 * 24.0 * 3600.0;

/// The most `param` lines one task may carry.
pub const MAX_PARAMS: usize = 32;
/// The most `metric` lines one task may carry.
pub const MAX_METRICS: usize = 16;
/// The largest value any metric takes: metrics are costs, from 0 up to this
/// (a distance across ten kilometres in centimetres, a battery's whole
/// charge), so a bid's score lies within [`TaskSpec::score_bounds`].
pub const MAX_METRIC_VALUE: f64 = 1e6;

/// A task parameter's value: a number (a goal's coordinate) or text (a colour).
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    /// A finite number, written bare.
    Number(f64),
    /// Text, written quoted.
    Text(String),
}

/// One `param name NAME value VALUE` line.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    /// What the parameter is (`x`, `y`, `color`).
    pub name: String,
    /// Its value.
    pub value: ParamValue,
}

/// One term of a task's score: `weight · metric(name)`. Scores are costs:
/// the lowest total wins.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricTerm {
    /// Which metric every robot evaluates (the metric vocabulary is the task crate's).
    pub name: String,
    /// Its weight in the sum.
    pub weight: f64,
}

/// A task as it is introduced: what it is called, what it needs, how long it
/// takes and how robots should score themselves for it.
///
/// ```
/// use colony_proto::murdoch::TaskSpec;
/// let spec = TaskSpec::new("sentry-duty", "camera laser mobile".parse().unwrap())
///     .length(120.0)
///     .param("x", 350.0)
///     .param("y", 80.0)
///     .metric("distance", 1.0)
///     .metric("battery", 200.0);
/// assert!(spec.validate().is_ok());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct TaskSpec {
    /// The task's name in the shared vocabulary (`push-left-end`).
    pub name: String,
    /// The resources a robot needs to do it.
    pub resources: ResourceSet,
    /// Expected length, s.
    pub length_s: f64,
    /// Parameters, in order.
    pub params: Vec<Param>,
    /// Score terms, in order; none means every bid scores 0 and the tie-break decides.
    pub metrics: Vec<MetricTerm>,
}

/// A task that cannot be announced.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpecError {
    /// A name outside the vocabulary's alphabet.
    #[error("{what} `{name}` is not a name: use 1 to 64 characters of A-Z a-z 0-9 _ - . : /")]
    Name {
        /// Which kind of name.
        what: &'static str,
        /// The name given.
        name: String,
    },
    /// Too many resources for one header.
    #[error("{0} resources are more than the {MAX_TASK_RESOURCES} one announcement can address")]
    TooManyResources(usize),
    /// A number that is not finite or is out of range.
    #[error("{what} {value} is out of range ({range})")]
    Range {
        /// Which number.
        what: String,
        /// Its value.
        value: f64,
        /// The range allowed.
        range: &'static str,
    },
    /// Too many lines of one kind.
    #[error("{count} {what} lines are more than the {max} allowed")]
    TooMany {
        /// Which lines.
        what: &'static str,
        /// How many there are.
        count: usize,
        /// The limit.
        max: usize,
    },
    /// A parameter or metric named twice.
    #[error("{what} `{name}` appears twice")]
    Duplicate {
        /// Which kind of line.
        what: &'static str,
        /// The name.
        name: String,
    },
}

impl TaskSpec {
    /// A task called `name` needing `resources`, of length 0 with no parameters or metrics.
    pub fn new(name: &str, resources: ResourceSet) -> TaskSpec {
        TaskSpec {
            name: name.to_owned(),
            resources,
            length_s: 0.0,
            params: Vec::new(),
            metrics: Vec::new(),
        }
    }

    /// Sets the expected length, s.
    pub fn length(mut self, seconds: f64) -> TaskSpec {
        self.length_s = seconds;
        self
    }

    /// Adds a numeric parameter.
    pub fn param(mut self, name: &str, value: f64) -> TaskSpec {
        self.params.push(Param {
            name: name.to_owned(),
            value: ParamValue::Number(value),
        });
        self
    }

    /// Adds a text parameter.
    pub fn text_param(mut self, name: &str, value: &str) -> TaskSpec {
        self.params.push(Param {
            name: name.to_owned(),
            value: ParamValue::Text(value.to_owned()),
        });
        self
    }

    /// Adds a score term.
    pub fn metric(mut self, name: &str, weight: f64) -> TaskSpec {
        self.metrics.push(MetricTerm {
            name: name.to_owned(),
            weight,
        });
        self
    }

    /// A numeric parameter's value.
    pub fn number(&self, name: &str) -> Option<f64> {
        self.params.iter().find_map(|p| match &p.value {
            ParamValue::Number(v) if p.name == name => Some(*v),
            _ => None,
        })
    }

    /// A text parameter's value.
    pub fn text(&self, name: &str) -> Option<&str> {
        self.params.iter().find_map(|p| match &p.value {
            ParamValue::Text(v) if p.name == name => Some(v.as_str()),
            _ => None,
        })
    }

    /// The lowest and highest score a bid for this task can carry: each
    /// metric between 0 and [`MAX_METRIC_VALUE`], times its weight. A bid
    /// outside them comes from no robot scoring this task, and is ignored.
    pub fn score_bounds(&self) -> (f64, f64) {
        self.metrics
            .iter()
            .map(|m| m.weight * MAX_METRIC_VALUE)
            .fold((0.0, 0.0), |(lo, hi), w| (lo + w.min(0.0), hi + w.max(0.0)))
    }

    /// Whether `score` is one a robot can bid for this task.
    pub fn admits_score(&self, score: f64) -> bool {
        let (lo, hi) = self.score_bounds();
        (lo..=hi).contains(&score)
    }

    /// Checks everything a reader would refuse.
    pub fn validate(&self) -> Result<(), SpecError> {
        let name = |what, n: &str| {
            if valid_name(n) {
                Ok(())
            } else {
                Err(SpecError::Name {
                    what,
                    name: fields::clip(n),
                })
            }
        };
        name("task name", &self.name)?;
        if self.resources.len() > MAX_TASK_RESOURCES {
            return Err(SpecError::TooManyResources(self.resources.len()));
        }
        if !(self.length_s.is_finite() && (0.0..=MAX_LENGTH_S).contains(&self.length_s)) {
            return Err(SpecError::Range {
                what: "length_s".into(),
                value: self.length_s,
                range: "0 to 604800 s",
            });
        }
        if self.params.len() > MAX_PARAMS {
            return Err(SpecError::TooMany {
                what: "param",
                count: self.params.len(),
                max: MAX_PARAMS,
            });
        }
        if self.metrics.len() > MAX_METRICS {
            return Err(SpecError::TooMany {
                what: "metric",
                count: self.metrics.len(),
                max: MAX_METRICS,
            });
        }
        for (i, p) in self.params.iter().enumerate() {
            name("param", &p.name)?;
            if self.params[..i].iter().any(|q| q.name == p.name) {
                return Err(SpecError::Duplicate {
                    what: "param",
                    name: p.name.clone(),
                });
            }
            match &p.value {
                ParamValue::Number(v) if !(v.is_finite() && v.abs() <= MAX_MAGNITUDE) => {
                    return Err(SpecError::Range {
                        what: format!("param {}", p.name),
                        value: *v,
                        range: "finite, within ±1e12",
                    });
                }
                ParamValue::Text(t) if t.chars().count() > MAX_TEXT => {
                    return Err(SpecError::Range {
                        what: format!("param {} length", p.name),
                        value: t.chars().count() as f64,
                        range: "at most 512 characters",
                    });
                }
                _ => {}
            }
        }
        for (i, m) in self.metrics.iter().enumerate() {
            name("metric", &m.name)?;
            if self.metrics[..i].iter().any(|q| q.name == m.name) {
                return Err(SpecError::Duplicate {
                    what: "metric",
                    name: m.name.clone(),
                });
            }
            if !(m.weight.is_finite() && m.weight.abs() <= MAX_MAGNITUDE) {
                return Err(SpecError::Range {
                    what: format!("metric {} weight", m.name),
                    value: m.weight,
                    range: "finite, within ±1e12",
                });
            }
        }
        Ok(())
    }
}

impl fmt::Display for TaskSpec {
    /// `sentry-duty {camera laser mobile} 120 s`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} {} s", self.name, self.resources, self.length_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn look() -> TaskSpec {
        TaskSpec::new("look", "camera".parse().unwrap()).length(3.0)
    }

    #[test]
    fn a_score_no_metric_can_add_up_to_is_not_admitted() {
        let spec = look().metric("distance", 1.0).metric("battery", 200.0);
        assert_eq!(spec.score_bounds(), (0.0, 201.0 * MAX_METRIC_VALUE));
        assert!(spec.admits_score(182.5));
        assert!(!spec.admits_score(-1e12));
        assert!(!spec.admits_score(-0.5));
        assert!(!spec.admits_score(f64::NAN));
        let mixed = look().metric("distance", 1.0).metric("battery", -2.0);
        assert!(mixed.admits_score(-1.0));
        assert!(!mixed.admits_score(-2.0 * MAX_METRIC_VALUE - 1.0));
        // No metrics: every robot scores 0.
        assert!(look().admits_score(0.0));
        assert!(!look().admits_score(1.0));
    }

    #[test]
    fn lookups_find_parameters_by_name_and_kind() {
        let spec = look().param("x", 2.0).text_param("color", "red");
        assert_eq!(spec.number("x"), Some(2.0));
        assert_eq!(spec.text("color"), Some("red"));
        assert_eq!(spec.number("color"), None);
        assert_eq!(spec.text("x"), None);
        assert_eq!(spec.number("y"), None);
    }

    #[test]
    fn validate_accepts_the_limits_and_refuses_one_past_them() {
        assert!(look().length(MAX_LENGTH_S).validate().is_ok());
        assert!(look().length(MAX_LENGTH_S + 1.0).validate().is_err());
        assert!(look().param("x", MAX_MAGNITUDE).validate().is_ok());
        assert!(look().param("x", -MAX_MAGNITUDE * 1.5).validate().is_err());
        assert!(look()
            .text_param("t", &"é".repeat(MAX_TEXT))
            .validate()
            .is_ok());
        assert!(matches!(
            look().text_param("t", &"é".repeat(MAX_TEXT + 1)).validate(),
            Err(SpecError::Range { .. })
        ));
    }

    #[test]
    fn validate_counts_params_and_metrics() {
        let mut spec = look();
        for i in 0..=MAX_PARAMS {
            spec = spec.param(&format!("p{i}"), 1.0);
        }
        assert_eq!(
            spec.validate(),
            Err(SpecError::TooMany {
                what: "param",
                count: MAX_PARAMS + 1,
                max: MAX_PARAMS
            })
        );
        let mut spec = look();
        for i in 0..=MAX_METRICS {
            spec = spec.metric(&format!("m{i}"), 1.0);
        }
        assert!(matches!(
            spec.validate(),
            Err(SpecError::TooMany { what: "metric", .. })
        ));
    }

    #[test]
    fn validate_names_the_bad_or_repeated_name() {
        assert_eq!(
            look().param("x", 1.0).text_param("x", "a").validate(),
            Err(SpecError::Duplicate {
                what: "param",
                name: "x".into()
            })
        );
        assert_eq!(
            look().metric("not ok", 1.0).validate(),
            Err(SpecError::Name {
                what: "metric",
                name: "not ok".into()
            })
        );
        assert!(matches!(
            TaskSpec::new("", ResourceSet::new()).validate(),
            Err(SpecError::Name {
                what: "task name",
                ..
            })
        ));
    }

    #[test]
    fn a_task_prints_its_name_resources_and_length() {
        let spec = TaskSpec::new("sentry-duty", "mobile camera".parse().unwrap()).length(120.0);
        assert_eq!(spec.to_string(), "sentry-duty {camera mobile} 120 s");
    }
}
