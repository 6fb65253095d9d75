//! Errors for malformed packets, each pinned to a line and column.

use std::fmt;

/// What was wrong with a packet's text.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The datagram is larger than one UDP payload can be.
    TooLarge {
        /// Its length in bytes.
        len: usize,
    },
    /// The datagram holds no header.
    Empty,
    /// The bytes are not UTF-8.
    NotUtf8,
    /// The first line is not `@ <subject>... priority`; the text says what was expected.
    BadHeader(&'static str),
    /// A `<subject>` token holds a character or length that subjects may not have.
    BadSubject(String),
    /// The same subject appears twice in the header.
    DuplicateSubject(String),
    /// The priority is not an integer that fits in 32 bits.
    BadPriority(String),
    /// A raw control character (other than tab and the line end).
    ControlChar(u8),
    /// A line starts with something other than a bare label.
    ExpectedLabel(char),
    /// A name was expected (a bare token) and something else was found.
    ExpectedName(char),
    /// A name at the end of its line or group, with no value after it.
    MissingValue {
        /// The name.
        name: String,
    },
    /// A name appears twice on one line or in one group.
    DuplicateName {
        /// The name.
        name: String,
    },
    /// A `(` was not closed before the end of its line.
    UnclosedGroup,
    /// A `)` with no `(` to close.
    UnmatchedClose,
    /// A quoted string runs to the end of its line.
    UnterminatedString,
    /// A backslash followed by a character that is not a known escape.
    BadEscape(char),
    /// Groups nested deeper than [`MAX_DEPTH`](crate::MAX_DEPTH).
    TooDeep,
}

/// A malformed packet: what was wrong and where (1-based line and byte column).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseError {
    /// What was wrong.
    pub kind: ErrorKind,
    /// 1-based line of the packet (the header is line 1).
    pub line: u32,
    /// 1-based byte column within that line.
    pub column: u32,
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ErrorKind::TooLarge { len } => write!(
                f,
                "packet is {len} bytes, more than the {} a UDP datagram can carry",
                crate::MAX_PACKET
            ),
            ErrorKind::Empty => {
                f.write_str("empty packet: expected a header `@ <subject> priority`")
            }
            ErrorKind::NotUtf8 => f.write_str("packet is not valid UTF-8"),
            ErrorKind::BadHeader(what) => write!(f, "bad header: expected {what}"),
            ErrorKind::BadSubject(s) => write!(
                f,
                "bad subject `{s}`: subjects are 1 to {} characters of A-Z a-z 0-9 _ - . : /",
                crate::MAX_SUBJECT_LEN
            ),
            ErrorKind::DuplicateSubject(s) => {
                write!(f, "subject `<{s}>` appears twice in the header")
            }
            ErrorKind::BadPriority(s) => write!(f, "priority `{s}` is not a 32-bit integer"),
            ErrorKind::ControlChar(c) => write!(f, "control character 0x{c:02x} is not allowed"),
            ErrorKind::ExpectedLabel(c) => write!(f, "expected a line label, found `{c}`"),
            ErrorKind::ExpectedName(c) => write!(f, "expected a field name, found `{c}`"),
            ErrorKind::MissingValue { name } => write!(f, "field `{name}` has no value"),
            ErrorKind::DuplicateName { name } => {
                write!(
                    f,
                    "duplicate name `{name}`: a name may appear once per line or group"
                )
            }
            ErrorKind::UnclosedGroup => {
                f.write_str("unbalanced parentheses: `(` not closed before the end of the line")
            }
            ErrorKind::UnmatchedClose => {
                f.write_str("unbalanced parentheses: `)` without a matching `(`")
            }
            ErrorKind::UnterminatedString => {
                f.write_str("unterminated string: no closing `\"` before the end of the line")
            }
            ErrorKind::BadEscape(c) => {
                write!(f, "unknown escape `\\{c}` (known: \\\" \\\\ \\n \\r \\t)")
            }
            ErrorKind::TooDeep => write!(f, "groups nested deeper than {}", crate::MAX_DEPTH),
        }
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "line {}, column {}: {}",
            self.line, self.column, self.kind
        )
    }
}

impl std::error::Error for ParseError {}

/// Why a typed getter could not give a field's value.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum FieldErrorKind {
    /// No field of that name on the line or in the group.
    Missing,
    /// The value is not a number (the text is the value as written).
    NotANumber(String),
    /// The value is not an integer that fits in 64 bits.
    NotAnInteger(String),
    /// A string was wanted and a group was found.
    NotAString,
    /// A group was wanted and a scalar was found.
    NotAGroup,
}

/// A typed getter's failure, naming the line's label, the field and where it stands.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldError {
    /// The label of the line the field belongs to.
    pub label: String,
    /// The field's name.
    pub field: String,
    /// 1-based line of the packet the field (or, when missing, its line) is on.
    pub line: u32,
    /// 1-based byte column of the field's value, or of the line's label when missing.
    pub column: u32,
    /// What was wrong with it.
    pub kind: FieldErrorKind,
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (line, column, label, field) = (self.line, self.column, &self.label, &self.field);
        write!(
            f,
            "line {line}, column {column}: `{label}` field `{field}`: "
        )?;
        match &self.kind {
            FieldErrorKind::Missing => f.write_str("missing"),
            FieldErrorKind::NotANumber(v) => write!(f, "`{v}` is not a number"),
            FieldErrorKind::NotAnInteger(v) => write!(f, "`{v}` is not a 64-bit integer"),
            FieldErrorKind::NotAString => f.write_str("expected a string, found a group"),
            FieldErrorKind::NotAGroup => f.write_str("expected a group `( ... )`"),
        }
    }
}

impl std::error::Error for FieldError {}
