//! Resources and state as subjects: the whole of MURDOCH's addressing.

use std::collections::BTreeSet;
use std::fmt;

use colony_wire::{Subject, SubjectError};

/// The state subject of an agent that is free to take a task. Every task
/// announcement is addressed to it as well as to the task's resources, so a busy
/// or charging robot never hears one.
pub const IDLE: &str = "idle";

/// The prefix of every negotiation subject; resource names may not start with it.
pub const NEGOTIATION_PREFIX: &str = "murdoch.";

/// The most resources a task may need: a header holds 16 subjects and one is [`IDLE`].
pub const MAX_TASK_RESOURCES: usize = colony_wire::MAX_SUBJECTS - 1;

/// A set of resources (`camera`, `laser`, `mobile`, ...), kept sorted so that it
/// prints and compares the same way everywhere.
///
/// ```
/// use colony_tasks::ResourceSet;
/// let need: ResourceSet = "mobile camera".parse().unwrap();
/// let have: ResourceSet = "camera laser mobile".parse().unwrap();
/// assert!(need.is_subset(&have));
/// assert_eq!(need.to_string(), "{camera mobile}");
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Hash, Default, PartialOrd, Ord)]
pub struct ResourceSet(BTreeSet<Subject>);

/// A name that cannot be a resource.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ResourceError {
    /// Not a valid subject name.
    #[error(transparent)]
    Subject(#[from] SubjectError),
    /// A name the protocol keeps for itself.
    #[error("`{0}` is reserved by the protocol and cannot be a resource")]
    Reserved(String),
    /// More than a header can address.
    #[error("{0} resources are more than the {MAX_TASK_RESOURCES} one announcement can address")]
    TooMany(usize),
}

impl ResourceSet {
    /// The empty set.
    pub fn new() -> ResourceSet {
        ResourceSet::default()
    }

    /// Checks one resource name.
    pub fn check(name: &str) -> Result<Subject, ResourceError> {
        let s = Subject::new(name)?;
        if s.as_str() == IDLE || s.as_str() == "hub" || s.as_str().starts_with(NEGOTIATION_PREFIX) {
            return Err(ResourceError::Reserved(s.to_string()));
        }
        Ok(s)
    }

    /// The set of these names, each checked.
    pub fn from_names<S: AsRef<str>>(
        names: impl IntoIterator<Item = S>,
    ) -> Result<ResourceSet, ResourceError> {
        let mut set = ResourceSet::new();
        for n in names {
            set.0.insert(ResourceSet::check(n.as_ref())?);
        }
        Ok(set)
    }

    /// Adds a resource.
    pub fn insert(&mut self, name: &str) -> Result<(), ResourceError> {
        self.0.insert(ResourceSet::check(name)?);
        Ok(())
    }

    /// Whether every resource of `self` is in `other`.
    pub fn is_subset(&self, other: &ResourceSet) -> bool {
        self.0.is_subset(&other.0)
    }

    /// Whether the set holds `name`.
    pub fn contains(&self, name: &str) -> bool {
        self.0.contains(name)
    }

    /// How many resources.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The resources, sorted.
    pub fn iter(&self) -> impl Iterator<Item = &Subject> {
        self.0.iter()
    }
}

impl std::str::FromStr for ResourceSet {
    type Err = ResourceError;
    /// Names separated by blanks or commas, with or without `{}` or `<>` around them.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim().trim_start_matches('{').trim_end_matches('}');
        ResourceSet::from_names(
            s.split(|c: char| c.is_whitespace() || c == ',')
                .filter(|n| !n.is_empty()),
        )
    }
}

impl fmt::Display for ResourceSet {
    /// `{camera laser mobile}`, as the paper writes a subject set.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("{")?;
        for (i, s) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str(" ")?;
            }
            f.write_str(s.as_str())?;
        }
        f.write_str("}")
    }
}

/// A short name for an agent or an announcer, used in bids to say who bid (never
/// to address anyone): 1 to 24 characters of `A-Z a-z 0-9 _ -`.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Token(Box<str>);

/// The most characters a [`Token`] may have, so that a negotiation subject
/// built from one stays within a subject's 64.
pub const MAX_TOKEN_LEN: usize = 24;

/// A name that cannot be a token.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not a token: use 1 to {MAX_TOKEN_LEN} characters of A-Z a-z 0-9 _ -")]
pub struct TokenError(pub String);

impl Token {
    /// Checks `s`.
    pub fn new(s: &str) -> Result<Token, TokenError> {
        let ok = !s.is_empty()
            && s.len() <= MAX_TOKEN_LEN
            && s.bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
        if ok {
            Ok(Token(s.into()))
        } else {
            Err(TokenError(s.chars().take(80).collect()))
        }
    }

    /// The token's text.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::str::FromStr for Token {
    type Err = TokenError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Token::new(s)
    }
}

impl fmt::Display for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// The fresh subject an announcer negotiates task `task`'s `attempt` on:
/// `murdoch.<announcer>.<task>.<attempt>`.
pub fn negotiation_subject(announcer: &Token, task: u64, attempt: u32) -> Subject {
    // A token is at most 24 characters of subject-safe ASCII and the numbers at
    // most 20 + 10 digits: the name is always a subject of at most 64 characters.
    Subject::new(&format!("{NEGOTIATION_PREFIX}{announcer}.{task}.{attempt}"))
        .expect("a token and two numbers always make a valid subject")
}
