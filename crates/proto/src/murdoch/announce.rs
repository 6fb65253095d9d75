//! Tasks as announcers publish them: an [`Announcement`], addressed to the
//! task's resources and [`IDLE`].

use std::time::Duration;

use colony_wire::{Packet, PacketBuilder, Priority, Subject, Value};

use super::error::{unwritable, EncodeError};
use super::{
    MetricTerm, Param, ParamValue, ResourceSet, TaskSpec, Token, IDLE, MAX_LENGTH_S, MAX_METRICS,
    MAX_PARAMS, MESSAGES, NEGOTIATION_PREFIX,
};
use crate::fields::{self, bad_field, MAX_DEADLINE};
use crate::table::{int, line, num, num_or_text, text, MessageTable};
use crate::DecodeError;

/// What an announcement holds: the task, then its parameters and metrics.
pub const TABLE: MessageTable = MessageTable {
    channel: IDLE,
    lines: &[
        line(
            "task",
            &[
                text("name"),
                int("id"),
                text("negotiation"),
                int("deadline_ms"),
                num("length_s"),
                text("announcer"),
            ],
        ),
        line("param", &[text("name"), num_or_text("value")]),
        line("metric", &[text("name"), num("weight")]),
    ],
};

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

    /// The packet. Refuses an announcement no reader would accept: an invalid
    /// task, a deadline beyond [`MAX_DEADLINE`], a negotiation subject without
    /// the `murdoch.` prefix. A deadline under a millisecond is written as 1 ms.
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        self.spec.validate()?;
        fields::writable_task_number("id", self.id)?;
        if self.deadline > MAX_DEADLINE {
            return Err(unwritable(
                "deadline_ms",
                format!(
                    "{} ms is longer than the {} ms a reader accepts",
                    self.deadline.as_millis(),
                    MAX_DEADLINE.as_millis()
                ),
            ));
        }
        if !self.negotiation.as_str().starts_with(NEGOTIATION_PREFIX) {
            return Err(unwritable(
                "negotiation",
                format!(
                    "`{}` does not start with `{NEGOTIATION_PREFIX}`",
                    self.negotiation
                ),
            ));
        }
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
                expected: MESSAGES,
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
            return Err(bad_field(
                &first,
                "negotiation",
                format!("`{negotiation}` does not start with `{NEGOTIATION_PREFIX}`"),
            ));
        }
        let length_s = fields::finite_within_magnitude(&first, "length_s")?;
        if !(0.0..=MAX_LENGTH_S).contains(&length_s) {
            return Err(bad_field(
                &first,
                "length_s",
                format!("{length_s} is not between 0 and {MAX_LENGTH_S} s"),
            ));
        }
        let mut spec = TaskSpec {
            name: fields::subject_name(&first, "name")?,
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
                        return Err(bad_field(
                            &line,
                            "param",
                            format!("more than {MAX_PARAMS} params"),
                        ));
                    }
                    let name = fields::subject_name(&line, "name")?;
                    if spec.params.iter().any(|p| p.name == name) {
                        return Err(bad_field(
                            &line,
                            "name",
                            format!("param `{name}` appears twice"),
                        ));
                    }
                    let value = match line.get("value") {
                        Some(Value::Quoted(q)) => ParamValue::Text(fields::clip(&q.unescape())),
                        Some(Value::Bare(t)) => match t.parse::<f64>() {
                            Ok(_) => {
                                ParamValue::Number(fields::finite_within_magnitude(&line, "value")?)
                            }
                            Err(_) => ParamValue::Text(fields::clip(t)),
                        },
                        Some(Value::Group(_)) => {
                            return Err(bad_field(
                                &line,
                                "value",
                                "a group is not a parameter value",
                            ))
                        }
                        None => {
                            return Err(match line.str("value") {
                                Err(e) => e.into(),
                                Ok(_) => bad_field(&line, "value", "missing"),
                            })
                        }
                    };
                    spec.params.push(Param { name, value });
                }
                "metric" => {
                    if spec.metrics.len() == MAX_METRICS {
                        return Err(bad_field(
                            &line,
                            "metric",
                            format!("more than {MAX_METRICS} metrics"),
                        ));
                    }
                    let name = fields::subject_name(&line, "name")?;
                    if spec.metrics.iter().any(|m| m.name == name) {
                        return Err(bad_field(
                            &line,
                            "name",
                            format!("metric `{name}` appears twice"),
                        ));
                    }
                    let weight = fields::finite_within_magnitude(&line, "weight")?;
                    spec.metrics.push(MetricTerm { name, weight });
                }
                other => {
                    return Err(bad_field(
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::murdoch::{negotiation_subject, SpecError, MAX_TASK_RESOURCES};

    fn token(s: &str) -> Token {
        Token::new(s).unwrap()
    }

    fn ann(spec: TaskSpec) -> Announcement {
        Announcement {
            spec,
            id: 4,
            negotiation: negotiation_subject(&token("u"), 4, 1),
            deadline: Duration::from_millis(100),
            announcer: token("u"),
        }
    }

    fn look() -> TaskSpec {
        TaskSpec::new("look", "camera".parse().unwrap()).length(3.0)
    }

    const HEAD: &str = "@ <camera> <idle> 0\ntask name look id 4 negotiation murdoch.u.4.1 deadline_ms 100 length_s 3 announcer u\n";

    fn read(extra: &str) -> Result<Announcement, DecodeError> {
        let text = format!("{HEAD}{extra}");
        Announcement::decode(&Packet::parse(text.as_bytes()).unwrap())
    }

    fn refused(extra: &str) -> String {
        match read(extra) {
            Ok(a) => panic!("{extra:?} should be refused, read {a:?}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
        let spec = look()
            .param("x", 3.5)
            .text_param("color", "red")
            .metric("distance", 1.0);
        crate::table::check::codec(&TABLE, &[ann(spec).encode().unwrap()], |p| {
            Announcement::decode(p).is_ok()
        });
    }

    #[test]
    fn the_bare_header_reads_as_the_task() {
        assert_eq!(read(""), Ok(ann(look())));
    }

    #[test]
    fn a_bare_word_value_is_text_and_a_bare_number_is_a_number() {
        let a = read("param name color value red\nparam name x value 1e3\n").unwrap();
        assert_eq!(a.spec.text("color"), Some("red"));
        assert_eq!(a.spec.number("x"), Some(1000.0));
    }

    #[test]
    fn a_quoted_number_stays_text() {
        let a = read("param name code value \"42\"\nparam name mood value \"inf\"\n").unwrap();
        assert_eq!(a.spec.params[0].value, ParamValue::Text("42".into()));
        assert_eq!(a.spec.text("mood"), Some("inf"));
        assert_eq!(a.spec.number("code"), None);
    }

    #[test]
    fn a_bare_value_that_parses_as_a_non_finite_number_is_refused() {
        for v in ["inf", "NaN", "1e400"] {
            let e = refused(&format!("param name x value {v}\n"));
            assert!(e.contains("line 3, field `value`"), "{v}: {e}");
        }
    }

    #[test]
    fn a_group_value_is_refused() {
        let e = refused("param name x value (a 1)\n");
        assert!(e.contains("a group is not a parameter value"), "{e}");
    }

    #[test]
    fn a_param_without_a_value_is_refused() {
        let e = refused("param name x\n");
        assert!(e.contains("line 3") && e.contains("value"), "{e}");
    }

    #[test]
    fn more_params_than_allowed_are_refused_at_the_first_extra_line() {
        let lines: String = (0..=MAX_PARAMS)
            .map(|i| format!("param name p{i} value {i}\n"))
            .collect();
        let e = refused(&lines);
        assert!(e.contains(&format!("line {}", MAX_PARAMS + 3)), "{e}");
        assert!(e.contains("more than 32 params"), "{e}");
        let ok: String = (0..MAX_PARAMS)
            .map(|i| format!("param name p{i} value {i}\n"))
            .collect();
        assert_eq!(read(&ok).unwrap().spec.params.len(), MAX_PARAMS);
    }

    #[test]
    fn more_metrics_than_allowed_are_refused() {
        let lines: String = (0..=MAX_METRICS)
            .map(|i| format!("metric name m{i} weight 1\n"))
            .collect();
        let e = refused(&lines);
        assert!(e.contains("more than 16 metrics"), "{e}");
    }

    #[test]
    fn a_metric_named_twice_is_refused() {
        let e = refused("metric name distance weight 1\nmetric name distance weight 2\n");
        assert!(
            e.contains("line 4") && e.contains("metric `distance` appears twice"),
            "{e}"
        );
    }

    #[test]
    fn params_and_metrics_keep_their_order() {
        let a = read(
            "metric name b weight 2\nparam name z value 1\nmetric name a weight 1\nparam name y value 2\n",
        )
        .unwrap();
        let params: Vec<&str> = a.spec.params.iter().map(|p| p.name.as_str()).collect();
        let metrics: Vec<&str> = a.spec.metrics.iter().map(|m| m.name.as_str()).collect();
        assert_eq!((params, metrics), (vec!["z", "y"], vec!["b", "a"]));
    }

    #[test]
    fn a_reserved_resource_in_the_header_is_refused() {
        let text = "@ <hub> <idle> 0\ntask name look id 4 negotiation murdoch.u.4.1 deadline_ms 100 length_s 3 announcer u\n";
        let e = Announcement::decode(&Packet::parse(text.as_bytes()).unwrap()).unwrap_err();
        assert!(
            matches!(&e, DecodeError::Header(h) if h.contains("`hub` is reserved")),
            "{e}"
        );
    }

    #[test]
    fn an_announcement_on_a_negotiation_subject_is_refused() {
        let text = "@ <murdoch.u.4.1> <idle> 0\ntask name look id 4 negotiation murdoch.u.4.1 deadline_ms 100 length_s 3 announcer u\n";
        let e = Announcement::decode(&Packet::parse(text.as_bytes()).unwrap()).unwrap_err();
        assert!(
            e.to_string().contains("not to the negotiation subject"),
            "{e}"
        );
    }

    #[test]
    fn a_task_needing_nothing_is_addressed_to_idle_alone() {
        let a = ann(TaskSpec::new("think", ResourceSet::new()));
        assert_eq!(a.subjects(), ["idle"]);
        let bytes = a.encode().unwrap();
        assert!(bytes.starts_with(b"@ <idle> 0\n"));
        assert_eq!(Announcement::decode(&Packet::parse(&bytes).unwrap()), Ok(a));
    }

    #[test]
    fn the_subjects_are_the_sorted_resources_then_idle() {
        let a = ann(TaskSpec::new("t", "mobile camera laser".parse().unwrap()));
        assert_eq!(a.subjects(), ["camera", "laser", "mobile", "idle"]);
    }

    #[test]
    fn a_task_can_need_fifteen_resources_and_still_be_read() {
        let names: Vec<String> = (0..MAX_TASK_RESOURCES)
            .map(|i| format!("r{i:02}"))
            .collect();
        let a = ann(TaskSpec::new(
            "big",
            ResourceSet::from_names(&names).unwrap(),
        ));
        let bytes = a.encode().unwrap();
        assert_eq!(Announcement::decode(&Packet::parse(&bytes).unwrap()), Ok(a));
    }

    #[test]
    fn a_deadline_under_a_millisecond_is_written_as_one() {
        let mut a = ann(look());
        a.deadline = Duration::from_micros(300);
        let text = String::from_utf8(a.encode().unwrap()).unwrap();
        assert!(text.contains(" deadline_ms 1 "), "{text}");
    }

    #[test]
    fn a_deadline_no_reader_accepts_is_not_written() {
        let mut a = ann(look());
        a.deadline = MAX_DEADLINE;
        assert!(a.encode().is_ok());
        a.deadline = MAX_DEADLINE + Duration::from_millis(1);
        let e = a.encode().unwrap_err();
        assert!(
            matches!(
                &e,
                EncodeError::Field {
                    field: "deadline_ms",
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn a_task_number_no_reader_accepts_is_not_written() {
        let mut a = ann(look());
        a.id = i64::MAX as u64 + 1;
        assert!(matches!(
            a.encode(),
            Err(EncodeError::Field { field: "id", .. })
        ));
    }

    #[test]
    fn an_announcement_naming_a_plain_subject_for_negotiation_is_not_written() {
        let mut a = ann(look());
        a.negotiation = Subject::new("camera").unwrap();
        assert!(matches!(
            a.encode(),
            Err(EncodeError::Field {
                field: "negotiation",
                ..
            })
        ));
    }

    #[test]
    fn an_invalid_spec_is_not_written() {
        let a = ann(look().length(-1.0));
        assert!(matches!(
            a.encode(),
            Err(EncodeError::Spec(SpecError::Range { .. }))
        ));
    }
}
