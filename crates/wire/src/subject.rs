//! Subjects and priorities: the two things a hub reads in a header.

use std::borrow::Borrow;
use std::fmt;

use crate::scan;

/// A validated subject name (without its angle brackets), such as `vision_out`.
///
/// ```
/// use colony_wire::Subject;
/// assert!(Subject::new("overhead-camera").is_ok());
/// assert!(Subject::new("no spaces").is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Subject(Box<str>);

/// A name that cannot be a subject.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SubjectError(pub String);

impl fmt::Display for SubjectError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "`{}` is not a subject: use 1 to {} characters of A-Z a-z 0-9 _ - . : /",
            self.0,
            crate::MAX_SUBJECT_LEN
        )
    }
}

impl std::error::Error for SubjectError {}

impl Subject {
    /// A subject from its name, with or without the `<...>` around it.
    pub fn new(name: &str) -> Result<Subject, SubjectError> {
        let name = name
            .strip_prefix('<')
            .and_then(|n| n.strip_suffix('>'))
            .unwrap_or(name);
        if scan::is_subject(name) {
            Ok(Subject(name.into()))
        } else {
            Err(SubjectError(name.to_owned()))
        }
    }

    /// The name, without `<...>`.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::str::FromStr for Subject {
    type Err = SubjectError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Subject::new(s)
    }
}

impl Borrow<str> for Subject {
    fn borrow(&self) -> &str {
        &self.0
    }
}

impl AsRef<str> for Subject {
    fn as_ref(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for Subject {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// A packet's priority; the hub can be told to drop everything below a minimum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Priority(pub i32);

impl fmt::Display for Priority {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}
