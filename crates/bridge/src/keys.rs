//! How hub channels are named in Zenoh, and how a colony priority travels there.
//!
//! A packet published on site `lab` with the subjects `<mobile> <camera>` is
//! put on the key `colony/lab/ch/camera/mobile`: the prefix, the site, `ch`,
//! then its subjects sorted, one chunk each, so the same set always has the
//! same key. A subject may hold `/`, which Zenoh reads as a separator, so it
//! travels as `%2F` (`%` is no subject character, so nothing else can
//! be read back as one).
//!
//! A site says which channels its clients want with liveliness tokens
//! `colony/<site>/want/<subject>`: Zenoh removes them when the site's bridge
//! goes away, however it goes.

use std::fmt;

use colony_wire::{Packet, Priority, Subject, HUB_SUBJECT};
use zenoh::qos::{CongestionControl, Priority as ZPriority};

/// The first chunk of every key colony uses.
pub const PREFIX: &str = "colony";

/// The longest site name.
pub const MAX_SITE: usize = 64;

/// A site's name: 1 to [`MAX_SITE`] of `A-Z a-z 0-9 _ -`.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Site(String);

/// A name that cannot be a site.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not a site name: use 1 to 64 characters of A-Z a-z 0-9 _ -")]
pub struct SiteError(pub String);

impl Site {
    /// A site from its name.
    pub fn new(name: &str) -> Result<Site, SiteError> {
        let ok = !name.is_empty()
            && name.len() <= MAX_SITE
            && name
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
        if ok {
            Ok(Site(name.to_owned()))
        } else {
            Err(SiteError(name.to_owned()))
        }
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for Site {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::str::FromStr for Site {
    type Err = SiteError;
    fn from_str(s: &str) -> Result<Site, SiteError> {
        Site::new(s)
    }
}

/// A subject as one key chunk.
pub fn chunk(subject: &str) -> String {
    subject.replace('/', "%2F")
}

fn unchunk(chunk: &str) -> Option<Subject> {
    Subject::new(&chunk.replace("%2F", "/")).ok()
}

/// The key a packet with these subjects, published on `site`, is put on.
pub fn data_key<'s>(site: &Site, subjects: impl IntoIterator<Item = &'s str>) -> String {
    let mut sorted: Vec<&str> = subjects.into_iter().collect();
    sorted.sort_unstable();
    sorted.dedup();
    let mut key = format!("{PREFIX}/{site}/ch");
    for s in sorted {
        key.push('/');
        key.push_str(&chunk(s));
    }
    key
}

/// The key expression that takes, from every site, the packets of exactly
/// this subject set (sorted and deduplicated here).
pub fn set_expr<'s>(subjects: impl IntoIterator<Item = &'s str>) -> String {
    data_key(&Site("*".into()), subjects)
}

/// The key expression of every packet of two subjects or more, from every site.
pub fn all_sets_expr() -> String {
    format!("{PREFIX}/*/ch/*/*/**")
}

/// The liveliness token by which `site` says one of its clients wants `subject`.
pub fn want_key(site: &Site, subject: &str) -> String {
    format!("{PREFIX}/{site}/want/{}", chunk(subject))
}

/// Every site's wants.
pub fn all_wants_expr() -> String {
    format!("{PREFIX}/*/want/*")
}

/// A data key read back: the site it came from and its subjects, sorted. `None`
/// for a key that is not one (from a Zenoh application that is not colony,
/// or forged).
pub fn parse_data_key(key: &str) -> Option<(Site, Vec<Subject>)> {
    let mut parts = key.split('/');
    if parts.next()? != PREFIX {
        return None;
    }
    let site = Site::new(parts.next()?).ok()?;
    if parts.next()? != "ch" {
        return None;
    }
    let subjects: Option<Vec<Subject>> = parts.map(unchunk).collect();
    let subjects = subjects?;
    let sorted = subjects.windows(2).all(|w| w[0] < w[1]);
    (!subjects.is_empty() && sorted).then_some((site, subjects))
}

/// A want token read back: the site and the subject it wants.
pub fn parse_want_key(key: &str) -> Option<(Site, Subject)> {
    let mut parts = key.split('/');
    if parts.next()? != PREFIX {
        return None;
    }
    let site = Site::new(parts.next()?).ok()?;
    if parts.next()? != "want" {
        return None;
    }
    let subject = unchunk(parts.next()?)?;
    // `<hub>` is no channel: a want for it would have the bridge ask its hub
    // for the hub's own replies.
    (parts.next().is_none() && subject.as_str() != HUB_SUBJECT).then_some((site, subject))
}

/// The site a sample came from and its subjects (sorted), if it is a
/// colony packet published on exactly the subjects its key names, and no
/// request to the hub (which, published into the hub by the bridge, would
/// act for the bridge).
pub fn read_sample(key: &str, payload: &[u8]) -> Option<(Site, Vec<Subject>)> {
    let (site, subjects) = parse_data_key(key)?;
    let packet = Packet::parse(payload).ok()?;
    let exact = !packet.has_subject(HUB_SUBJECT)
        && packet.subject_count() == subjects.len()
        && subjects.iter().all(|s| packet.has_subject(s.as_str()));
    exact.then_some((site, subjects))
}

/// How a packet of this colony priority crosses Zenoh: its Zenoh priority,
/// and whether Zenoh may drop it when the link is congested (always: a
/// bridge that blocked would stop serving its hub; drops show as `lost`). The table is
/// the one in `docs/ARCHITECTURE.md`.
pub fn zenoh_qos(p: Priority) -> (ZPriority, CongestionControl) {
    match p.0 {
        // The operator's override (10): ahead of everything. Not `Block`:
        // anyone may publish at 10, and a flood must not stall the bridge.
        10.. => (ZPriority::RealTime, CongestionControl::Drop),
        5..=9 => (ZPriority::InteractiveHigh, CongestionControl::Drop),
        1..=4 => (ZPriority::InteractiveLow, CongestionControl::Drop),
        0 => (ZPriority::Data, CongestionControl::Drop),
        -9..=-1 => (ZPriority::DataLow, CongestionControl::Drop),
        _ => (ZPriority::Background, CongestionControl::Drop),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn lab() -> Site {
        Site::new("lab").unwrap()
    }

    #[test]
    fn a_set_has_one_key_whatever_the_order_of_its_subjects() {
        assert_eq!(
            data_key(&lab(), ["mobile", "camera"]),
            "colony/lab/ch/camera/mobile"
        );
        assert_eq!(
            data_key(&lab(), ["camera", "mobile"]),
            "colony/lab/ch/camera/mobile"
        );
        assert_eq!(data_key(&lab(), ["vision"]), "colony/lab/ch/vision");
        assert_eq!(data_key(&lab(), ["a/b"]), "colony/lab/ch/a%2Fb");
        assert_eq!(set_expr(["b", "a"]), "colony/*/ch/a/b");
    }

    #[test]
    fn keys_that_are_not_colonys_are_refused() {
        for bad in [
            "colony/lab/ch",
            "colony/lab/want/x",
            "other/lab/ch/x",
            "colony/l@b/ch/x",
            "colony/lab/ch/b/a",
            "colony/lab/ch/a/a",
            "colony/lab/ch/no space",
            "colony/lab/ch/%2",
            "",
        ] {
            assert_eq!(parse_data_key(bad), None, "{bad}");
        }
        assert_eq!(parse_want_key("colony/lab/want/a/b"), None);
        assert_eq!(parse_want_key("colony/lab/want/hub"), None);
        assert_eq!(
            parse_want_key("colony/lab/want/a%2Fb"),
            Some((lab(), Subject::new("a/b").unwrap()))
        );
    }

    #[test]
    fn an_import_must_be_the_packet_its_key_names() {
        let key = "colony/a/ch/camera/mobile";
        assert_eq!(
            read_sample(key, b"@ <mobile> <camera> 0\nt x 1\n").map(|(site, _)| site),
            Some(Site::new("a").unwrap())
        );
        assert_eq!(read_sample(key, b"@ <mobile> 0\nt x 1\n"), None);
        assert_eq!(
            read_sample(key, b"@ <mobile> <camera> <laser> 0\nt x 1\n"),
            None
        );
        assert_eq!(read_sample(key, b"not a packet"), None);
        assert_eq!(read_sample("colony/a/ch/x", &[0xff, 0xfe]), None);
        // A request to the hub, under any key, would act for the bridge.
        assert_eq!(
            read_sample("colony/a/ch/hub", b"@ <hub> 0\nunsubscribe_all\n"),
            None
        );
    }

    #[test]
    fn the_operators_override_crosses_first() {
        assert_eq!(
            zenoh_qos(Priority(10)),
            (ZPriority::RealTime, CongestionControl::Drop)
        );
        assert_eq!(zenoh_qos(Priority(i32::MAX)).0, ZPriority::RealTime);
        assert_eq!(zenoh_qos(Priority(0)).0, ZPriority::Data);
        assert_eq!(zenoh_qos(Priority(i32::MIN)).0, ZPriority::Background);
        // Higher colony priority, never a lower Zenoh one (lower numbers go first).
        let mut last = ZPriority::Background as u8;
        for p in -20..=20 {
            let z = zenoh_qos(Priority(p)).0 as u8;
            assert!(z <= last, "{p}");
            last = z;
        }
    }

    proptest! {
        #[test]
        fn every_subject_set_reads_back_from_its_key(
            subjects in proptest::collection::btree_set("[A-Za-z0-9_.:/-]{1,12}", 1..5),
            site in "[A-Za-z0-9_-]{1,10}",
        ) {
            let site = Site::new(&site).unwrap();
            let names: Vec<&str> = subjects.iter().map(String::as_str).collect();
            let key = data_key(&site, names.iter().copied());
            let (s, back) = parse_data_key(&key).unwrap();
            prop_assert_eq!(s, site);
            let back: std::collections::BTreeSet<String> =
                back.iter().map(|s| s.as_str().to_owned()).collect();
            prop_assert_eq!(back, subjects);
            prop_assert!(zenoh::key_expr::KeyExpr::try_from(key.as_str()).is_ok(), "{}", key);
        }

        #[test]
        fn any_text_as_a_key_is_read_without_panic(key in "\\\\PC{0,80}") {
            let _ = parse_data_key(&key);
            let _ = parse_want_key(&key);
        }
    }
}
