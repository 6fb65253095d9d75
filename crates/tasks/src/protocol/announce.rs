//! Tasks as users write them ([`TaskSpec`]) and as announcers publish them
//! ([`Announcement`]).

use std::fmt;
use std::time::Duration;

use colony_wire::{Packet, PacketBuilder, Priority, Subject, Value};

use super::error::{bad, DecodeError, EncodeError};
use super::fields::{self, valid_name, MAX_LENGTH_S, MAX_MAGNITUDE, MAX_TEXT};
use crate::resource::{ResourceSet, Token, IDLE, MAX_TASK_RESOURCES, NEGOTIATION_PREFIX};

/// The most `param` lines one task may carry.
pub const MAX_PARAMS: usize = 32;
/// The most `metric` lines one task may carry.
pub const MAX_METRICS: usize = 16;

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
    /// Which metric every robot evaluates (see [`crate::metric`]).
    pub name: String,
    /// Its weight in the sum.
    pub weight: f64,
}

/// A task as it is introduced: what it is called, what it needs, how long it
/// takes and how robots should score themselves for it.
///
/// ```
/// use colony_tasks::TaskSpec;
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

/// A task on offer: published to its resources and [`IDLE`], so that only robots
/// that could do it now hear it.
#[derive(Debug, Clone, PartialEq)]
pub struct Announcement {
    /// The task.
    pub spec: TaskSpec,
    /// The announcer's number for it (the same across re-auctions).
    pub id: u64,
    /// The fresh subject bids and everything after go to.
    pub negotiation: Subject,
    /// How long after hearing the announcement bids are taken (`deadline_ms`):
    /// relative, so that robots need no common clock.
    pub deadline: Duration,
    /// Who announced it.
    pub announcer: Token,
}

impl Announcement {
    /// The subjects the announcement is addressed to: the task's resources and `idle`.
    pub fn subjects(&self) -> Vec<&str> {
        let mut s: Vec<&str> = self.spec.resources.iter().map(|r| r.as_str()).collect();
        s.push(IDLE);
        s
    }

    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        self.spec.validate()?;
        let mut p = PacketBuilder::new(self.subjects(), Priority(0));
        p.line("task")
            .bare("name", &self.spec.name)
            .field("id", self.id)
            .bare("negotiation", self.negotiation.as_str())
            .field("deadline_ms", self.deadline.as_millis().max(1) as u64)
            .field("length_s", self.spec.length_s)
            .bare("announcer", self.announcer.as_str());
        for param in &self.spec.params {
            let mut l = p.line("param");
            l.bare("name", &param.name);
            match &param.value {
                ParamValue::Number(v) => l.field("value", *v),
                ParamValue::Text(t) => l.field("value", fields::clip(t).as_str()),
            };
        }
        for m in &self.spec.metrics {
            p.line("metric")
                .bare("name", &m.name)
                .field("weight", m.weight);
        }
        Ok(p.finish()?)
    }

    /// Reads an announcement; `packet`'s first line must be `task`.
    pub fn decode(packet: &Packet<'_>) -> Result<Announcement, DecodeError> {
        let mut lines = packet.lines();
        let first = lines.next().ok_or(DecodeError::Empty)?;
        if first.label() != "task" {
            return Err(DecodeError::UnknownMessage {
                line: first.number(),
                label: first.label().to_owned(),
            });
        }
        let mut resources = ResourceSet::new();
        let mut idle = false;
        for s in packet.subjects() {
            if s == IDLE {
                idle = true;
            } else if s.starts_with(NEGOTIATION_PREFIX) {
                return Err(DecodeError::Header(format!(
                    "an announcement goes to resources, not to the negotiation subject <{s}>"
                )));
            } else {
                resources
                    .insert(s)
                    .map_err(|e| DecodeError::Header(e.to_string()))?;
            }
        }
        if !idle {
            return Err(DecodeError::Header(format!(
                "an announcement is addressed to <{IDLE}> as well as its resources"
            )));
        }
        let negotiation = fields::subject(&first, "negotiation")?;
        if !negotiation.as_str().starts_with(NEGOTIATION_PREFIX) {
            return Err(bad(
                &first,
                "negotiation",
                format!("`{negotiation}` does not start with `{NEGOTIATION_PREFIX}`"),
            ));
        }
        let length_s = fields::finite(&first, "length_s")?;
        if !(0.0..=MAX_LENGTH_S).contains(&length_s) {
            return Err(bad(
                &first,
                "length_s",
                format!("{length_s} is not between 0 and {MAX_LENGTH_S} s"),
            ));
        }
        let mut spec = TaskSpec {
            name: fields::name(&first, "name")?,
            resources,
            length_s,
            params: Vec::new(),
            metrics: Vec::new(),
        };
        let id = fields::task_number(&first, "id")?;
        let deadline = fields::millis(&first, "deadline_ms")?;
        let announcer = fields::token(&first, "announcer")?;
        for line in lines {
            match line.label() {
                "param" => {
                    if spec.params.len() == MAX_PARAMS {
                        return Err(bad(
                            &line,
                            "param",
                            format!("more than {MAX_PARAMS} params"),
                        ));
                    }
                    let name = fields::name(&line, "name")?;
                    if spec.params.iter().any(|p| p.name == name) {
                        return Err(bad(&line, "name", format!("param `{name}` appears twice")));
                    }
                    let value = match line.get("value") {
                        Some(Value::Quoted(q)) => ParamValue::Text(fields::clip(&q.unescape())),
                        Some(Value::Bare(t)) => match t.parse::<f64>() {
                            Ok(_) => ParamValue::Number(fields::finite(&line, "value")?),
                            Err(_) => ParamValue::Text(fields::clip(t)),
                        },
                        Some(Value::Group(_)) => {
                            return Err(bad(&line, "value", "a group is not a parameter value"))
                        }
                        None => {
                            return Err(match line.str("value") {
                                Err(e) => e.into(),
                                Ok(_) => bad(&line, "value", "missing"),
                            })
                        }
                    };
                    spec.params.push(Param { name, value });
                }
                "metric" => {
                    if spec.metrics.len() == MAX_METRICS {
                        return Err(bad(
                            &line,
                            "metric",
                            format!("more than {MAX_METRICS} metrics"),
                        ));
                    }
                    let name = fields::name(&line, "name")?;
                    if spec.metrics.iter().any(|m| m.name == name) {
                        return Err(bad(&line, "name", format!("metric `{name}` appears twice")));
                    }
                    let weight = fields::finite(&line, "weight")?;
                    spec.metrics.push(MetricTerm { name, weight });
                }
                other => {
                    return Err(bad(
                        &line,
                        "label",
                        format!("`{other}` lines do not belong in a task (param, metric)"),
                    ))
                }
            }
        }
        Ok(Announcement {
            spec,
            id,
            negotiation,
            deadline,
            announcer,
        })
    }
}
