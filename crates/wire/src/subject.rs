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

/// Why text is no subject set ([`parse_subject_set`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SubjectSetError {
    /// No name at all, or names apart by blanks outside `<...>`: the text as given.
    Malformed(String),
    /// A name that cannot be a subject.
    Subject(SubjectError),
    /// A subject named twice.
    Twice(Subject),
    /// More subjects than a header may name: how many.
    TooMany(usize),
}

impl fmt::Display for SubjectSetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SubjectSetError::Malformed(t) => write!(
                f,
                "`{t}` is no subject set: write one subject (`radio`), several comma-separated (`a,b`) or as a header does (`<a> <b>`)"
            ),
            SubjectSetError::Subject(e) => e.fmt(f),
            SubjectSetError::Twice(s) => write!(f, "subject `{s}` is named twice"),
            SubjectSetError::TooMany(n) => write!(
                f,
                "{n} subjects: a header names at most {}",
                crate::MAX_SUBJECTS
            ),
        }
    }
}

impl std::error::Error for SubjectSetError {}

/// A subject set as a person writes it in one argument: a subject (`radio`),
/// several comma-separated (`mobile,camera`) or as a header writes them
/// (`<mobile> <camera>`). Nothing is guessed: blanks outside `<...>`, an empty
/// name, a name given twice are refused.
///
/// ```
/// use colony_wire::parse_subject_set;
/// let names = |t| parse_subject_set(t).unwrap().iter().map(|s| s.to_string()).collect::<Vec<_>>();
/// assert_eq!(names("mobile,camera"), ["mobile", "camera"]);
/// assert_eq!(names("<mobile> <camera>"), ["mobile", "camera"]);
/// assert!(parse_subject_set("radio stop").is_err());
/// ```
pub fn parse_subject_set(text: &str) -> Result<Vec<Subject>, SubjectSetError> {
    let malformed = || SubjectSetError::Malformed(text.to_owned());
    let names: Vec<&str> = if text.trim_start().starts_with('<') {
        text.split_whitespace()
            .map(|t| t.strip_prefix('<').and_then(|t| t.strip_suffix('>')))
            .collect::<Option<_>>()
            .ok_or_else(malformed)?
    } else if text.is_empty() || text.contains(char::is_whitespace) {
        return Err(malformed());
    } else {
        text.split(',').collect()
    };
    if names.len() > crate::MAX_SUBJECTS {
        return Err(SubjectSetError::TooMany(names.len()));
    }
    let mut set: Vec<Subject> = Vec::with_capacity(names.len());
    for name in names {
        // `new` would take `<a>` inside a comma-separated list too; a set is one spelling or the other.
        if name.contains(['<', '>']) {
            return Err(malformed());
        }
        let s = Subject::new(name).map_err(SubjectSetError::Subject)?;
        if set.contains(&s) {
            return Err(SubjectSetError::Twice(s));
        }
        set.push(s);
    }
    Ok(set)
}

/// A packet's priority; the hub can be told to drop everything below a minimum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Priority(pub i32);

impl fmt::Display for Priority {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn names(set: &[Subject]) -> Vec<&str> {
        set.iter().map(Subject::as_str).collect()
    }

    #[test]
    fn a_subject_set_is_one_argument_in_either_spelling() {
        assert_eq!(names(&parse_subject_set("radio").unwrap()), ["radio"]);
        assert_eq!(names(&parse_subject_set("a,b").unwrap()), ["a", "b"]);
        assert_eq!(names(&parse_subject_set("<a> <b>").unwrap()), ["a", "b"]);
        assert_eq!(names(&parse_subject_set(" <a>\t<b> ").unwrap()), ["a", "b"]);
    }

    #[test]
    fn what_is_no_subject_set_is_refused_not_guessed() {
        use SubjectSetError::*;
        for bad in ["radio stop", "", " ", "<a> b", "<a", "<a><b>", "a,<b>"] {
            assert_eq!(
                parse_subject_set(bad),
                Err(Malformed(bad.into())),
                "{bad:?}"
            );
        }
        for bad in ["a,,b", "a,", "<>", "<a,b>", "bad!subject"] {
            assert!(matches!(parse_subject_set(bad), Err(Subject(_))), "{bad:?}");
        }
        assert_eq!(
            parse_subject_set("a,b,a"),
            Err(Twice(super::Subject::new("a").unwrap()))
        );
        let many = vec!["s"; crate::MAX_SUBJECTS + 1].join(",");
        assert_eq!(
            parse_subject_set(&many),
            Err(TooMany(crate::MAX_SUBJECTS + 1))
        );
        for e in [Malformed("x y".into()), TooMany(20)] {
            assert!(!e.to_string().is_empty());
        }
    }

    proptest! {
        #[test]
        fn any_argument_is_a_set_a_header_may_name_or_is_refused(text in "[a-z<>, \t!]{0,40}") {
            if let Ok(set) = parse_subject_set(&text) {
                let header = format!("@ <{}> 0\n", names(&set).join("> <"));
                prop_assert!(crate::Packet::parse(header.as_bytes()).is_ok(), "{}", header);
            }
        }

        #[test]
        fn comma_and_header_spellings_name_the_same_set(
            set in proptest::collection::btree_set("[a-z][a-z0-9_.]{0,6}", 1..=crate::MAX_SUBJECTS)
        ) {
            let set: Vec<String> = set.into_iter().collect();
            let commas = parse_subject_set(&set.join(",")).unwrap();
            let header = parse_subject_set(&format!("<{}>", set.join("> <"))).unwrap();
            prop_assert_eq!(names(&commas), names(&header));
            prop_assert_eq!(names(&commas), set.iter().map(String::as_str).collect::<Vec<_>>());
        }
    }
}
