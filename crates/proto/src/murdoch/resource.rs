//! Resources and state as subjects: the whole of MURDOCH's addressing.

use std::collections::BTreeSet;
use std::fmt;

use colony_wire::{Subject, SubjectError};

use super::Token;

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
/// use colony_proto::murdoch::ResourceSet;
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

/// The fresh subject an announcer negotiates task `task`'s `attempt` on:
/// `murdoch.<announcer>.<task>.<attempt>`.
pub fn negotiation_subject(announcer: &Token, task: u64, attempt: u32) -> Subject {
    // A token is at most 24 characters of subject-safe ASCII and the numbers at
    // most 20 + 10 digits: the name is always a subject of at most 64 characters.
    Subject::new(&format!("{NEGOTIATION_PREFIX}{announcer}.{task}.{attempt}"))
        .expect("a token and two numbers always make a valid subject")
}

/// The announcer, task number and attempt a negotiation subject names: the inverse of
/// [`negotiation_subject`]. A viewer reads subjects it did not make, so the announcer is
/// whatever non-empty text precedes the two numbers, token or not.
pub fn parse_negotiation_subject(subject: &str) -> Option<(&str, u64, u32)> {
    let rest = subject.strip_prefix(NEGOTIATION_PREFIX)?;
    let mut parts = rest.rsplitn(3, '.');
    let attempt = parts.next()?.parse().ok()?;
    let task = parts.next()?.parse().ok()?;
    let announcer = parts.next().filter(|a| !a.is_empty())?;
    Some((announcer, task, attempt))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::murdoch::MAX_TOKEN_LEN;

    fn set(s: &str) -> ResourceSet {
        s.parse().unwrap()
    }

    #[test]
    fn a_set_reads_blanks_commas_braces_and_angle_brackets_alike() {
        let want = ResourceSet::from_names(["camera", "laser", "mobile"]).unwrap();
        for text in [
            "camera laser mobile",
            "mobile,camera,laser",
            " {camera, laser mobile} ",
            "<laser> <camera> <mobile>",
            "camera\tlaser\nmobile",
        ] {
            assert_eq!(set(text), want, "{text:?}");
        }
    }

    #[test]
    fn an_empty_or_braces_only_text_is_the_empty_set() {
        assert!(set("").is_empty());
        assert!(set("{}").is_empty());
        assert!(set(" , ,").is_empty());
        assert_eq!(set("{}").to_string(), "{}");
    }

    #[test]
    fn a_set_prints_sorted_whatever_the_order_it_was_built_in() {
        let mut s = ResourceSet::new();
        for n in ["mobile", "camera", "laser", "camera"] {
            s.insert(n).unwrap();
        }
        assert_eq!(s.len(), 3);
        assert_eq!(s.to_string(), "{camera laser mobile}");
        let names: Vec<&str> = s.iter().map(|r| r.as_str()).collect();
        assert_eq!(names, ["camera", "laser", "mobile"]);
    }

    #[test]
    fn subset_needs_every_resource() {
        let have = set("camera laser mobile");
        assert!(set("camera mobile").is_subset(&have));
        assert!(ResourceSet::new().is_subset(&have));
        assert!(have.is_subset(&have));
        assert!(!set("camera gripper").is_subset(&have));
        assert!(!have.is_subset(&set("camera mobile")));
    }

    #[test]
    fn contains_looks_names_up_by_text() {
        let s = set("camera laser");
        assert!(s.contains("laser"));
        assert!(!s.contains("las"));
        assert!(!s.contains("<laser>"));
    }

    #[test]
    fn the_protocols_own_names_are_reserved() {
        for name in ["idle", "<idle>", "hub", "murdoch.user.1.1", "murdoch."] {
            assert!(
                matches!(ResourceSet::check(name), Err(ResourceError::Reserved(_))),
                "{name}"
            );
        }
        // Only the exact prefix is reserved.
        assert!(ResourceSet::check("murdoch").is_ok());
        assert!(ResourceSet::check("idler").is_ok());
        assert!(ResourceSet::check("hubcap").is_ok());
    }

    #[test]
    fn a_name_that_is_not_a_subject_is_refused_with_the_name() {
        for name in ["has space", "", "x\u{e9}", "a".repeat(65).as_str()] {
            let e = ResourceSet::check(name).unwrap_err();
            assert!(matches!(e, ResourceError::Subject(_)), "{name:?}: {e:?}");
        }
        let e = ResourceSet::check("café").unwrap_err().to_string();
        assert!(e.contains("café"), "{e}");
    }

    #[test]
    fn one_bad_name_spoils_the_whole_set_and_insert_leaves_the_set_alone() {
        assert!("camera idle laser".parse::<ResourceSet>().is_err());
        assert!(ResourceSet::from_names(["camera", "not ok"]).is_err());
        let mut s = set("camera");
        assert!(s.insert("hub").is_err());
        assert_eq!(s, set("camera"));
    }

    #[test]
    fn the_reserved_error_names_the_resource() {
        let e = "camera idle".parse::<ResourceSet>().unwrap_err();
        assert_eq!(e, ResourceError::Reserved("idle".into()));
        assert!(e.to_string().contains("`idle` is reserved"), "{e}");
    }

    #[test]
    fn a_negotiation_subject_names_announcer_task_and_attempt() {
        let s = negotiation_subject(&Token::new("user").unwrap(), 17, 2);
        assert_eq!(s.as_str(), "murdoch.user.17.2");
        assert!(s.as_str().starts_with(NEGOTIATION_PREFIX));
    }

    #[test]
    fn a_subject_that_is_not_a_negotiation_reads_as_none() {
        for s in [
            "idle",
            "murdoch.",
            "murdoch..1.1",
            "murdoch.u.1",
            "murdoch.u.x.1",
            "murdoch.u.1.-1",
        ] {
            assert_eq!(parse_negotiation_subject(s), None, "{s}");
        }
    }

    #[test]
    fn the_longest_negotiation_subject_still_fits_a_subject() {
        let longest = Token::new(&"z".repeat(MAX_TOKEN_LEN)).unwrap();
        let s = negotiation_subject(&longest, u64::MAX, u32::MAX);
        assert_eq!(s.as_str().len(), colony_wire::MAX_SUBJECT_LEN);
    }

    proptest::proptest! {
        #[test]
        fn any_text_reads_as_a_set_or_an_error_and_a_set_reads_back_from_its_print(
            text in "[ -~\t\n]{0,80}",
        ) {
            if let Ok(set) = text.parse::<ResourceSet>() {
                proptest::prop_assert_eq!(set.to_string().parse::<ResourceSet>(), Ok(set.clone()));
                proptest::prop_assert!(set.iter().all(|r| ResourceSet::check(r.as_str()).is_ok()));
            }
        }

        #[test]
        fn a_negotiation_subject_is_always_one(
            who in "[A-Za-z0-9_-]{1,24}", task in proptest::num::u64::ANY, attempt in proptest::num::u32::ANY,
        ) {
            let s = negotiation_subject(&Token::new(&who).unwrap(), task, attempt);
            proptest::prop_assert!(s.as_str().starts_with(NEGOTIATION_PREFIX));
            proptest::prop_assert!(ResourceSet::check(s.as_str()).is_err());
        }

        #[test]
        fn a_negotiation_subject_reads_back_as_what_made_it(
            who in "[A-Za-z0-9_-]{1,24}", task in proptest::num::u64::ANY, attempt in proptest::num::u32::ANY,
        ) {
            let s = negotiation_subject(&Token::new(&who).unwrap(), task, attempt);
            proptest::prop_assert_eq!(
                parse_negotiation_subject(s.as_str()),
                Some((who.as_str(), task, attempt))
            );
        }
    }
}
