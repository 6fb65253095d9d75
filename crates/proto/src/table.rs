//! Field tables: each message's lines and fields, written once beside its writer and reader, so
//! that whoever describes a message to the outside (the JSON schemas of `colony-schema`) reads
//! it from here instead of restating it.
//!
//! A table says what a packet may hold, not how to read it: each label, each field's name, the
//! kind of token it is written as, and whether a reader needs it. Every table is tied to its
//! codec by a test in its module (`table::check::codec`): the writer writes nothing the table
//! leaves out and every field the table says it needs, every field the table names is written by
//! some sample, and the reader refuses a line without a field the table says it needs and takes
//! one without a field the table calls optional.

/// How a field's value is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A bare integer token: an id, a count, a step, a `0`/`1` flag.
    Int,
    /// A bare finite number: a coordinate (cm), an angle (rad), a time (s), a fraction.
    Num,
    /// A word or a quoted text: a name, a mode, a reason.
    Text,
    /// A bare number, or a text (a task's parameter).
    NumOrText,
}

/// When a line carries a field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Presence {
    /// Always: a reader refuses the line without it.
    Required,
    /// When the writer has it: a reader takes the line without it.
    Optional,
    /// Whenever the named field is there (`ty` with `tx`, `bearing` with `sonar`).
    With(&'static str),
    /// When another field's value calls for it: a squad command's `x` and `y` go with
    /// `do goto`, its `points` with `do path`.
    Varies,
}

/// One field of a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldTable {
    /// Its name.
    pub name: &'static str,
    /// How its value is written.
    pub kind: Kind,
    /// When a line carries it.
    pub presence: Presence,
}

/// A required integer field.
pub const fn int(name: &'static str) -> FieldTable {
    FieldTable {
        name,
        kind: Kind::Int,
        presence: Presence::Required,
    }
}

/// A required number field.
pub const fn num(name: &'static str) -> FieldTable {
    FieldTable {
        name,
        kind: Kind::Num,
        presence: Presence::Required,
    }
}

/// A required text field.
pub const fn text(name: &'static str) -> FieldTable {
    FieldTable {
        name,
        kind: Kind::Text,
        presence: Presence::Required,
    }
}

/// A required field that holds a number or a text.
pub const fn num_or_text(name: &'static str) -> FieldTable {
    FieldTable {
        name,
        kind: Kind::NumOrText,
        presence: Presence::Required,
    }
}

impl FieldTable {
    /// The field, optional.
    pub const fn optional(self) -> FieldTable {
        FieldTable {
            presence: Presence::Optional,
            ..self
        }
    }

    /// The field, there whenever `other` is.
    pub const fn with(self, other: &'static str) -> FieldTable {
        FieldTable {
            presence: Presence::With(other),
            ..self
        }
    }

    /// The field, there when another field's value calls for it.
    pub const fn varies(self) -> FieldTable {
        FieldTable {
            presence: Presence::Varies,
            ..self
        }
    }
}

/// One label's lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineTable {
    /// The label.
    pub label: &'static str,
    /// Its fields, in the order the writer writes them.
    pub fields: &'static [FieldTable],
}

impl LineTable {
    /// The field called `name`.
    pub fn field(&self, name: &str) -> Option<&FieldTable> {
        self.fields.iter().find(|f| f.name == name)
    }
}

/// A shorter [`LineTable`] literal.
pub const fn line(label: &'static str, fields: &'static [FieldTable]) -> LineTable {
    LineTable { label, fields }
}

/// One message: the channel it goes on and the lines it holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MessageTable {
    /// The channel, or for a family of channels (`camera.0`, `camera.1`, ...) their common
    /// prefix, ending in `.`. A message addressed to a subject set (a MURDOCH announcement, to
    /// its resources and `idle`) names the one subject every such set holds.
    pub channel: &'static str,
    /// Its lines, one entry per label.
    pub lines: &'static [LineTable],
}

impl MessageTable {
    /// The lines labelled `label`.
    pub fn line(&self, label: &str) -> Option<&LineTable> {
        self.lines.iter().find(|l| l.label == label)
    }

    /// Whether `subject` is this message's channel, or one of its family.
    pub fn names(&self, subject: &str) -> bool {
        match self.channel.strip_suffix('.') {
            Some(_) => subject
                .strip_prefix(self.channel)
                .is_some_and(|rest| !rest.is_empty()),
            None => subject == self.channel,
        }
    }
}

/// The checks that tie a table to its writer and reader, for each message module's tests.
#[cfg(test)]
pub(crate) mod check {
    use std::collections::BTreeSet;

    use colony_wire::{Line, Packet, PacketBuilder, Value};

    use super::{Kind, MessageTable, Presence};

    /// Ties `table` to a codec: `samples` are packets its writer wrote (between them, every
    /// line and every field the table names), `accepts` its reader, true when it takes a
    /// packet whole.
    pub(crate) fn codec(
        table: &MessageTable,
        samples: &[Vec<u8>],
        accepts: impl Fn(&Packet<'_>) -> bool,
    ) {
        let mut seen = BTreeSet::new();
        for bytes in samples {
            let packet = Packet::parse(bytes).expect("a writer writes packets that parse");
            written(table, &packet, &mut seen);
            read(table, &packet, &accepts);
        }
        for l in table.lines {
            for f in l.fields {
                assert!(
                    seen.contains(&(l.label, f.name)),
                    "{}: no sample wrote `{} {}`: is it still written?",
                    table.channel,
                    l.label,
                    f.name
                );
            }
        }
    }

    /// What the writer wrote is what the table says.
    fn written(
        table: &MessageTable,
        packet: &Packet<'_>,
        seen: &mut BTreeSet<(&'static str, &'static str)>,
    ) {
        let channel = table.channel;
        let subjects: Vec<&str> = packet.subjects().collect();
        assert!(
            subjects.iter().any(|s| table.names(s)),
            "{channel}: written to {subjects:?}"
        );
        for l in packet.lines() {
            let lt = table
                .line(l.label())
                .unwrap_or_else(|| panic!("{channel}: label `{}` is not in the table", l.label()));
            for f in l.fields() {
                let ft = lt.field(f.name).unwrap_or_else(|| {
                    panic!("{channel}: `{} {}` is not in the table", lt.label, f.name)
                });
                let fits = match (ft.kind, &f.value) {
                    (Kind::Int, Value::Bare(t)) => t.parse::<i64>().is_ok(),
                    (Kind::Num, Value::Bare(t)) => t.parse::<f64>().is_ok_and(f64::is_finite),
                    (Kind::Text, Value::Bare(_) | Value::Quoted(_)) => true,
                    // A bare word is a text; a bare number must be one a reader takes.
                    (Kind::NumOrText, Value::Bare(t)) => {
                        t.parse::<f64>().is_ok_and(f64::is_finite) || t.parse::<f64>().is_err()
                    }
                    (Kind::NumOrText, Value::Quoted(_)) => true,
                    _ => false,
                };
                assert!(
                    fits,
                    "{channel}: `{} {}` was written as {:?}, not {:?}",
                    lt.label, f.name, f.value, ft.kind
                );
                seen.insert((lt.label, ft.name));
            }
            for ft in lt.fields {
                let needed = match ft.presence {
                    Presence::Required => true,
                    Presence::Optional | Presence::Varies => false,
                    Presence::With(other) => l.get(other).is_some(),
                };
                assert!(
                    !needed || l.get(ft.name).is_some(),
                    "{channel}: `{}` written without `{}`: {:?}",
                    lt.label,
                    ft.name,
                    l.as_str()
                );
            }
        }
    }

    /// The reader needs what the table says it needs, and no more.
    fn read(table: &MessageTable, packet: &Packet<'_>, accepts: &impl Fn(&Packet<'_>) -> bool) {
        let channel = table.channel;
        assert!(accepts(packet), "{channel}: its reader refuses {packet}");
        for (i, l) in packet.lines().enumerate() {
            let Some(lt) = table.line(l.label()) else {
                continue;
            };
            for ft in lt.fields {
                // Whether a varying field may go depends on values this check does not read.
                if l.get(ft.name).is_none() || ft.presence == Presence::Varies {
                    continue;
                }
                // A field goes with the fields that need it.
                let mut gone = vec![ft.name];
                gone.extend(
                    lt.fields
                        .iter()
                        .filter(|o| o.presence == Presence::With(ft.name))
                        .map(|o| o.name),
                );
                let refused = match ft.presence {
                    Presence::Required => true,
                    Presence::Optional | Presence::Varies => false,
                    Presence::With(other) => {
                        // Alone, it is needed exactly when its partner is there.
                        gone = vec![ft.name];
                        l.get(other).is_some()
                    }
                };
                let bytes = without(packet, i, &gone);
                let p = Packet::parse(&bytes).expect("a line less still parses");
                assert_eq!(
                    accepts(&p),
                    !refused,
                    "{channel}: `{} {}` is {:?} in the table, but its reader {} {p}",
                    lt.label,
                    ft.name,
                    ft.presence,
                    if refused { "takes" } else { "refuses" },
                );
            }
        }
    }

    /// `packet` with the fields `gone` taken out of its line `index`.
    fn without(packet: &Packet<'_>, index: usize, gone: &[&str]) -> Vec<u8> {
        let mut p = PacketBuilder::new(packet.subjects(), packet.priority());
        for (i, l) in packet.lines().enumerate() {
            if i == index {
                p.raw_line(&line_without(&l, gone));
            } else {
                p.raw_line(l.as_str());
            }
        }
        p.finish().expect("a line less is still a packet")
    }

    fn line_without(l: &Line<'_>, gone: &[&str]) -> String {
        let mut out = l.label().to_owned();
        for f in l.fields().filter(|f| !gone.contains(&f.name)) {
            out.push(' ');
            out.push_str(f.name);
            out.push(' ');
            match f.value {
                Value::Bare(t) => out.push_str(t),
                Value::Quoted(q) => {
                    out.push('"');
                    out.push_str(q.raw());
                    out.push('"');
                }
                Value::Group(_) => panic!("no message writes a group"),
            }
        }
        out
    }
}
