//! The zero-copy view of a valid packet: header, lines, fields, values, groups.

use std::borrow::Cow;
use std::fmt;

use crate::error::{FieldError, FieldErrorKind, ParseError};
use crate::scan::{self, Layout, Scanner, Tok};
use crate::Priority;

/// The typed getters lines and groups share: both are a list of fields
/// with a [`Context`] that places errors.
macro_rules! typed_getters {
    ([$($generics:tt)*] $ty:ty, $what:literal) => {
        impl<'a $($generics)*> $ty {
            #[doc = concat!("The value of the field called `name`, if the ", $what, " has one.")]
            pub fn get(&self, name: &str) -> Option<Value<'a>> {
                self.lookup(name).map(|f| f.value)
            }

            fn field(&self, name: &str) -> Result<Field<'a>, FieldError> {
                self.lookup(name)
                    .ok_or_else(|| self.context().missing(name))
            }

            /// The field as a number (a bare token parsed as `f64`).
            pub fn f64(&self, name: &str) -> Result<f64, FieldError> {
                let f = self.field(name)?;
                self.context().f64(&f)
            }

            /// The field as a 64-bit integer.
            pub fn i64(&self, name: &str) -> Result<i64, FieldError> {
                let f = self.field(name)?;
                self.context().i64(&f)
            }

            /// The field as text: a bare token as written, a quoted string unescaped.
            pub fn str(&self, name: &str) -> Result<Cow<'a, str>, FieldError> {
                let f = self.field(name)?;
                self.context().str(&f)
            }

            /// The field as a nested group.
            pub fn group(&self, name: &str) -> Result<Group<'a>, FieldError> {
                let f = self.field(name)?;
                self.context().group(&f)
            }
        }
    };
}

/// A parsed packet borrowing the datagram it was read from.
///
/// Parsing checks the whole packet once; reading it afterwards never fails
/// except for typed getters asked for the wrong type.
///
/// ```
/// use colony_wire::Packet;
/// let p = Packet::parse(b"@ <vision_out> 0\nball x 5.3 y -2.5\n").unwrap();
/// assert_eq!(p.subjects().collect::<Vec<_>>(), ["vision_out"]);
/// let ball = p.line("ball").unwrap();
/// assert_eq!(ball.f64("x").unwrap(), 5.3);
/// ```
#[derive(Clone, Copy)]
pub struct Packet<'a> {
    src: &'a str,
    layout: Layout,
}

impl<'a> Packet<'a> {
    /// Checks `bytes` and returns a view over them, or the first error with its position.
    pub fn parse(bytes: &'a [u8]) -> Result<Packet<'a>, ParseError> {
        let (src, layout) = scan::validate(bytes)?;
        Ok(Packet { src, layout })
    }

    /// The packet exactly as received.
    pub fn as_str(&self) -> &'a str {
        self.src
    }

    /// The subjects of the header, in the order written.
    pub fn subjects(&self) -> Subjects<'a> {
        let (start, end) = self.layout.subjects;
        Subjects {
            rest: &self.src[start..end],
        }
    }

    /// How many subjects the header names (at least one).
    pub fn subject_count(&self) -> usize {
        self.layout.subject_count as usize
    }

    /// The header's subjects as written, `<a> <b>`.
    pub fn subjects_text(&self) -> &'a str {
        let (start, end) = self.layout.subjects;
        &self.src[start..end]
    }

    /// Whether the header names `subject`.
    pub fn has_subject(&self, subject: &str) -> bool {
        self.subjects().any(|s| s == subject)
    }

    /// The priority from the header.
    pub fn priority(&self) -> Priority {
        Priority(self.layout.priority)
    }

    /// The body's lines, blank lines skipped.
    pub fn lines(&self) -> Lines<'a> {
        Lines {
            scan: Scanner::at(self.src, self.layout.body, 2, self.layout.body),
        }
    }

    /// The first line with this label.
    pub fn line(&self, label: &str) -> Option<Line<'a>> {
        self.lines().find(|l| l.label() == label)
    }

    /// Every line with this label, in order: the packet's way of writing an array.
    pub fn lines_labelled<'l>(&self, label: &'l str) -> impl Iterator<Item = Line<'a>> + 'l
    where
        'a: 'l,
    {
        self.lines().filter(move |l| l.label() == label)
    }
}

impl fmt::Debug for Packet<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Packet").field("text", &self.src).finish()
    }
}

/// Writes the packet in canonical form: single blanks, `\n` line ends, no blank
/// lines. A packet already in that form is written back byte for byte.
impl fmt::Display for Packet<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("@")?;
        for s in self.subjects() {
            write!(f, " <{s}>")?;
        }
        writeln!(f, " {}", self.layout.priority)?;
        for line in self.lines() {
            f.write_str(line.label())?;
            for field in line.fields() {
                f.write_str(" ")?;
                write_field(f, &field)?;
            }
            f.write_str("\n")?;
        }
        Ok(())
    }
}

fn write_field(f: &mut fmt::Formatter<'_>, field: &Field<'_>) -> fmt::Result {
    write!(f, "{} ", field.name)?;
    match field.value {
        Value::Bare(t) => f.write_str(t),
        Value::Quoted(q) => write!(f, "\"{}\"", q.raw()),
        Value::Group(g) => {
            f.write_str("(")?;
            for (i, inner) in g.fields().enumerate() {
                if i > 0 {
                    f.write_str(" ")?;
                }
                write_field(f, &inner)?;
            }
            f.write_str(")")
        }
    }
}

/// Iterator over the subjects of a header.
#[derive(Clone)]
pub struct Subjects<'a> {
    rest: &'a str,
}

impl<'a> Iterator for Subjects<'a> {
    type Item = &'a str;
    fn next(&mut self) -> Option<&'a str> {
        let open = self.rest.find('<')?;
        let close = open + self.rest[open..].find('>')?;
        let name = &self.rest[open + 1..close];
        self.rest = &self.rest[close + 1..];
        Some(name)
    }
}

/// Iterator over the lines of a packet's body.
#[derive(Clone)]
pub struct Lines<'a> {
    scan: Scanner<'a>,
}

impl<'a> Iterator for Lines<'a> {
    type Item = Line<'a>;
    fn next(&mut self) -> Option<Line<'a>> {
        loop {
            let s = &mut self.scan;
            if s.at_end() {
                return None;
            }
            let (line, line_start) = (s.line, s.line_start);
            match s.next() {
                Ok((Tok::Bare(label), at)) => {
                    let rest = at + label.len();
                    s.skip_line();
                    return Some(Line {
                        src: s.source(),
                        label,
                        fields_at: rest,
                        number: line,
                        line_start,
                    });
                }
                Ok((Tok::Eol, _)) => continue,
                // Unreachable for a validated packet; ending beats panicking.
                _ => return None,
            }
        }
    }
}

/// One line of the body: a label and its fields.
#[derive(Clone, Copy)]
pub struct Line<'a> {
    src: &'a str,
    label: &'a str,
    fields_at: usize,
    number: u32,
    line_start: usize,
}

impl<'a> Line<'a> {
    /// The line's label: its first, bare token.
    pub fn label(&self) -> &'a str {
        self.label
    }

    /// The 1-based line number in the packet (the header is line 1).
    pub fn number(&self) -> u32 {
        self.number
    }

    /// The line as written, from its label to its last field, without its line end:
    /// what a program passes on when it forwards a line it does not read.
    pub fn as_str(&self) -> &'a str {
        let rest = &self.src[self.fields_at..];
        let end = self.fields_at + rest.find('\n').unwrap_or(rest.len());
        let start = self.fields_at - self.label.len();
        self.src[start..end].trim_end_matches([' ', '\t', '\r'])
    }

    /// The line's fields after its label, in order.
    pub fn fields(&self) -> Fields<'a> {
        Fields {
            scan: Scanner::at(self.src, self.fields_at, self.number, self.line_start),
            done: false,
        }
    }

    fn lookup(&self, name: &str) -> Option<Field<'a>> {
        self.fields().find(|f| f.name == name)
    }

    /// The fields called `names`, found in one pass over the line, to be read with the same
    /// getters as the line's own. Each getter of a line scans its fields from the start; a
    /// reader of many short lines (a swarm's vision) picks its fields once instead. A name
    /// not picked reads as missing.
    pub fn pick<const N: usize>(&self, names: [&'static str; N]) -> Picked<'a, N> {
        let mut fields = [None; N];
        let mut left = N;
        for f in self.fields() {
            // A valid line names each field once, so the first match is the only one.
            if let Some(i) = names.iter().position(|n| *n == f.name) {
                fields[i] = Some(f);
                left -= 1;
                if left == 0 {
                    break;
                }
            }
        }
        Picked {
            line: *self,
            names,
            fields,
        }
    }

    fn context(&self) -> Context<'a> {
        Context {
            label: self.label,
            line: self.number,
            line_start: self.line_start,
            fallback: self.fields_at - self.label.len(),
        }
    }

    /// An error about a field of this line that reads but is out of range,
    /// placed like a getter's error: at the field's value.
    pub(crate) fn value_error(&self, field: &Field<'a>, kind: FieldErrorKind) -> FieldError {
        self.context().error(field.name, field.value_at, kind)
    }
}

typed_getters!([] Line<'a>, "line");
typed_getters!([, const N: usize] Picked<'a, N>, "line");

impl fmt::Debug for Line<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Line")
            .field("label", &self.label)
            .field("number", &self.number)
            .finish()
    }
}

/// Some of a line's fields, found in one pass: [`Line::pick`].
#[derive(Clone, Copy)]
pub struct Picked<'a, const N: usize> {
    line: Line<'a>,
    names: [&'static str; N],
    fields: [Option<Field<'a>>; N],
}

impl<'a, const N: usize> Picked<'a, N> {
    /// The line the fields were picked from.
    pub fn line(&self) -> &Line<'a> {
        &self.line
    }

    fn lookup(&self, name: &str) -> Option<Field<'a>> {
        let i = self.names.iter().position(|n| *n == name)?;
        self.fields[i]
    }

    fn context(&self) -> Context<'a> {
        self.line.context()
    }
}

impl<const N: usize> fmt::Debug for Picked<'_, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Picked")
            .field("line", &self.line)
            .field("names", &self.names)
            .finish()
    }
}

/// What a typed getter needs to name the place of an error.
#[derive(Clone, Copy)]
struct Context<'a> {
    label: &'a str,
    line: u32,
    line_start: usize,
    /// Where to point when the field is missing: the label, or the group's `(`.
    fallback: usize,
}

impl<'a> Context<'a> {
    fn error(&self, field: &str, at: usize, kind: FieldErrorKind) -> FieldError {
        FieldError {
            label: self.label.to_owned(),
            field: field.to_owned(),
            line: self.line,
            column: (at.saturating_sub(self.line_start) + 1) as u32,
            kind,
        }
    }

    fn missing(&self, name: &str) -> FieldError {
        self.error(name, self.fallback, FieldErrorKind::Missing)
    }

    fn f64(&self, f: &Field<'a>) -> Result<f64, FieldError> {
        f.value.as_f64().ok_or_else(|| {
            self.error(
                f.name,
                f.value_at,
                FieldErrorKind::NotANumber(f.value.text()),
            )
        })
    }

    fn i64(&self, f: &Field<'a>) -> Result<i64, FieldError> {
        f.value.as_i64().ok_or_else(|| {
            self.error(
                f.name,
                f.value_at,
                FieldErrorKind::NotAnInteger(f.value.text()),
            )
        })
    }

    fn str(&self, f: &Field<'a>) -> Result<Cow<'a, str>, FieldError> {
        f.value
            .as_str()
            .ok_or_else(|| self.error(f.name, f.value_at, FieldErrorKind::NotAString))
    }

    fn group(&self, f: &Field<'a>) -> Result<Group<'a>, FieldError> {
        match f.value {
            Value::Group(g) => Ok(g),
            _ => Err(self.error(f.name, f.value_at, FieldErrorKind::NotAGroup)),
        }
    }
}

/// One `name value` pair.
#[derive(Debug, Clone, Copy)]
pub struct Field<'a> {
    /// The field's name.
    pub name: &'a str,
    /// Its value.
    pub value: Value<'a>,
    /// Byte offset of the value in the packet.
    pub value_at: usize,
}

/// A field's value: a bare token, a quoted string or a parenthesised group.
#[derive(Debug, Clone, Copy)]
pub enum Value<'a> {
    /// A token without blanks or quotes, as written.
    Bare(&'a str),
    /// A `"..."` string, still escaped.
    Quoted(Quoted<'a>),
    /// A `( name value ... )` group of fields.
    Group(Group<'a>),
}

impl<'a> Value<'a> {
    /// A bare token read as a number (`NaN` and `inf` included).
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Bare(t) => t.parse().ok(),
            _ => None,
        }
    }

    /// A bare token read as a 64-bit integer.
    pub fn as_i64(&self) -> Option<i64> {
        match self {
            Value::Bare(t) => t.parse().ok(),
            _ => None,
        }
    }

    /// Text: a bare token as written, a quoted string unescaped; `None` for a group.
    pub fn as_str(&self) -> Option<Cow<'a, str>> {
        match self {
            Value::Bare(t) => Some(Cow::Borrowed(t)),
            Value::Quoted(q) => Some(q.unescape()),
            Value::Group(_) => None,
        }
    }

    /// The group, if the value is one.
    pub fn as_group(&self) -> Option<Group<'a>> {
        match self {
            Value::Group(g) => Some(*g),
            _ => None,
        }
    }

    /// The value as written, for error messages.
    fn text(&self) -> String {
        match self {
            Value::Bare(t) => (*t).to_owned(),
            Value::Quoted(q) => format!("\"{}\"", q.raw()),
            Value::Group(_) => "( ... )".to_owned(),
        }
    }
}

/// A quoted string, kept as written until asked for its text.
#[derive(Debug, Clone, Copy)]
pub struct Quoted<'a> {
    raw: &'a str,
}

impl<'a> Quoted<'a> {
    /// The text between the quotes with its escapes still in it.
    pub fn raw(&self) -> &'a str {
        self.raw
    }

    /// The string's text; borrowed unless it had escapes.
    pub fn unescape(&self) -> Cow<'a, str> {
        if !self.raw.contains('\\') {
            return Cow::Borrowed(self.raw);
        }
        let mut out = String::with_capacity(self.raw.len());
        let mut chars = self.raw.chars();
        while let Some(c) = chars.next() {
            if c != '\\' {
                out.push(c);
                continue;
            }
            match chars.next() {
                Some('n') => out.push('\n'),
                Some('r') => out.push('\r'),
                Some('t') => out.push('\t'),
                Some(other) => out.push(other),
                None => {}
            }
        }
        Cow::Owned(out)
    }
}

/// A parenthesised group of `name value` pairs inside a line.
#[derive(Clone, Copy)]
pub struct Group<'a> {
    src: &'a str,
    label: &'a str,
    /// Offset just after the `(`.
    start: usize,
    line: u32,
    line_start: usize,
}

impl<'a> Group<'a> {
    /// The group's fields, in order.
    pub fn fields(&self) -> Fields<'a> {
        Fields {
            scan: Scanner::at(self.src, self.start, self.line, self.line_start),
            done: false,
        }
    }

    fn lookup(&self, name: &str) -> Option<Field<'a>> {
        self.fields().find(|f| f.name == name)
    }

    fn context(&self) -> Context<'a> {
        Context {
            label: self.label,
            line: self.line,
            line_start: self.line_start,
            fallback: self.start - 1,
        }
    }
}

typed_getters!([] Group<'a>, "group");

impl fmt::Debug for Group<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list()
            .entries(self.fields().map(|fd| (fd.name, fd.value)))
            .finish()
    }
}

/// Iterator over the fields of a line or a group (nested groups are single values).
#[derive(Clone)]
pub struct Fields<'a> {
    scan: Scanner<'a>,
    done: bool,
}

impl<'a> Iterator for Fields<'a> {
    type Item = Field<'a>;
    fn next(&mut self) -> Option<Field<'a>> {
        if self.done {
            return None;
        }
        let field = self.advance();
        self.done = field.is_none();
        field
    }
}

impl<'a> Fields<'a> {
    fn advance(&mut self) -> Option<Field<'a>> {
        let s = &mut self.scan;
        let (line, line_start) = (s.line, s.line_start);
        let name = match s.next().ok()? {
            (Tok::Bare(name), _) => name,
            _ => return None,
        };
        let (tok, value_at) = s.next().ok()?;
        let value = match tok {
            Tok::Bare(t) => Value::Bare(t),
            Tok::Quoted(raw) => Value::Quoted(Quoted { raw }),
            Tok::Open => {
                let g = Group {
                    src: s.source(),
                    label: name,
                    start: s.pos,
                    line,
                    line_start,
                };
                s.skip_group().ok()?;
                Value::Group(g)
            }
            Tok::Close | Tok::Eol => return None,
        };
        Some(Field {
            name,
            value,
            value_at,
        })
    }
}
