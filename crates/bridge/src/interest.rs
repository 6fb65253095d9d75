//! What this site's clients want from other sites, read from the hub's status report.
//!
//! A packet crosses to a site only if some client there is subscribed to
//! every one of its subjects. Zenoh sends a sample only where a subscriber's
//! key expression matches, so the bridge declares one key expression per
//! wanted channel (`colony/*/ch/vision`) and one per subject set its clients
//! could receive: every subset of two or more of a client's subscriptions,
//! as long as a client holds at most [`MAX_ENUMERATED`]; a client with more
//! takes every set (`colony/*/ch/*/*/**`) and its hub sorts out who gets
//! what. The expressions never overlap, so no sample arrives twice.

use std::collections::BTreeSet;

use colony_wire::{StatusReport, Subject};

use crate::config::{any_matches, Pattern};
use crate::keys;

/// A client with more subscriptions than this takes every subject set.
pub const MAX_ENUMERATED: usize = 6;
/// With more distinct sets than this, the bridge takes every set: each is a
/// declaration sent to every Zenoh peer.
pub const MAX_SETS: usize = 256;
/// The most channels a site asks for; more are left out, and counted.
pub const MAX_CHANNELS: usize = 1024;
/// How every bridge's about text starts.
pub const BRIDGE_ABOUT: &str = "bridge ";

/// What the clients of this site want from other sites.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LocalInterest {
    /// Every channel some client subscribes to (and the import rules let in).
    pub channels: BTreeSet<Subject>,
    /// Subject sets of two or more that some client could receive.
    pub sets: BTreeSet<Vec<Subject>>,
    /// Some client holds so many subscriptions, or the clients so many
    /// sets, that every set is taken.
    pub all_sets: bool,
    /// Channels left out beyond [`MAX_CHANNELS`].
    pub left_out: usize,
    /// Other bridges on this hub (their subscriptions are other networks'
    /// wants, never this site's: taking them would loop).
    pub other_bridges: usize,
}

impl LocalInterest {
    /// Reads the report's clients, leaving out every bridge (whose about text
    /// starts with [`BRIDGE_ABOUT`]; this one's starts with `me`): a bridge's
    /// subscriptions are other sites' wants.
    pub fn from_report(report: &StatusReport, me: &str, import: &[Pattern]) -> LocalInterest {
        let mut interest = LocalInterest::default();
        for client in &report.clients {
            if client.about.starts_with(BRIDGE_ABOUT) {
                if !client.about.starts_with(me) {
                    interest.other_bridges += 1;
                }
                continue;
            }
            let mut subs: Vec<Subject> = client
                .subscriptions
                .iter()
                .filter(|(name, _)| any_matches(import, name))
                .filter_map(|(name, _)| Subject::new(name).ok())
                .collect();
            subs.sort();
            subs.dedup();
            if subs.len() > MAX_ENUMERATED {
                interest.all_sets = true;
            } else if subs.len() >= 2 && !interest.all_sets {
                add_subsets(&subs, &mut interest.sets);
            }
            for s in subs {
                if interest.channels.len() < MAX_CHANNELS || interest.channels.contains(&s) {
                    interest.channels.insert(s);
                } else {
                    interest.left_out += 1;
                }
            }
        }
        if interest.sets.len() > MAX_SETS {
            interest.all_sets = true;
        }
        if interest.all_sets {
            interest.sets.clear();
        }
        interest
    }

    /// What a truncated report adds to what was known: a report cut short
    /// leaves clients out, and must not withdraw what they want.
    pub fn widen(&mut self, seen: LocalInterest) {
        self.channels.extend(seen.channels);
        self.all_sets |= seen.all_sets;
        if self.all_sets {
            self.sets.clear();
        } else {
            self.sets.extend(seen.sets);
        }
        self.left_out = self.left_out.max(seen.left_out);
        self.other_bridges = self.other_bridges.max(seen.other_bridges);
    }

    /// The Zenoh key expressions to subscribe to, each matching a disjoint part of the key space.
    pub fn key_exprs(&self) -> BTreeSet<String> {
        let mut exprs: BTreeSet<String> = self
            .channels
            .iter()
            .map(|c| keys::set_expr([c.as_str()]))
            .collect();
        if self.all_sets {
            exprs.insert(keys::all_sets_expr());
        } else {
            exprs.extend(
                self.sets
                    .iter()
                    .map(|s| keys::set_expr(s.iter().map(Subject::as_str))),
            );
        }
        exprs
    }
}

/// Every subset of two or more of `subs` (at most [`MAX_ENUMERATED`] of them).
fn add_subsets(subs: &[Subject], out: &mut BTreeSet<Vec<Subject>>) {
    debug_assert!(subs.len() <= MAX_ENUMERATED);
    for mask in 1u32..(1 << subs.len()) {
        if mask.count_ones() >= 2 {
            out.insert(
                (0..subs.len())
                    .filter(|i| mask & (1 << i) != 0)
                    .map(|i| subs[i].clone())
                    .collect(),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{client, report};
    use colony_wire::ClientInfo;

    #[test]
    fn each_client_brings_its_channels_and_the_sets_it_could_receive() {
        let r = report(vec![
            client("", &["mobile", "camera"]),
            client("", &["vision"]),
            client("bridge lab run 1:", &["radio", "debug"]),
            client("bridge other run 2:", &["cmd"]),
        ]);
        let i = LocalInterest::from_report(&r, "bridge lab run 1:", &[Pattern::new("*")]);
        assert_eq!(i.other_bridges, 1);
        let exprs: Vec<String> = i.key_exprs().into_iter().collect();
        assert_eq!(
            exprs,
            [
                "colony/*/ch/camera",
                "colony/*/ch/camera/mobile",
                "colony/*/ch/mobile",
                "colony/*/ch/vision"
            ]
        );
    }

    #[test]
    fn import_rules_leave_channels_out() {
        let r = report(vec![client("", &["vision", "radio", "game.world"])]);
        let i =
            LocalInterest::from_report(&r, "me", &[Pattern::new("game.*"), Pattern::new("vision")]);
        let names: Vec<&str> = i.channels.iter().map(Subject::as_str).collect();
        assert_eq!(names, ["game.world", "vision"]);
        assert_eq!(i.sets.len(), 1);
    }

    #[test]
    fn a_client_of_many_channels_takes_every_set_in_one_expression() {
        let many: Vec<String> = (0..7).map(|i| format!("c{i}")).collect();
        let many: Vec<&str> = many.iter().map(String::as_str).collect();
        let r = report(vec![client("", &["a", "b"]), client("", &many)]);
        let i = LocalInterest::from_report(&r, "me", &[Pattern::new("*")]);
        assert!(i.all_sets && i.sets.is_empty());
        let exprs = i.key_exprs();
        assert!(exprs.contains("colony/*/ch/*/*/**"));
        assert_eq!(exprs.len(), 2 + 7 + 1);
    }

    #[test]
    fn many_clients_of_small_sets_make_the_bridge_take_every_set() {
        let clients: Vec<ClientInfo> = (0..100)
            .map(|i| {
                let names = [format!("a{i}"), format!("b{i}"), format!("c{i}")];
                let names: Vec<&str> = names.iter().map(String::as_str).collect();
                client("", &names)
            })
            .collect();
        let i = LocalInterest::from_report(&report(clients), "me", &[Pattern::new("*")]);
        assert!(i.all_sets && i.sets.is_empty());
        assert_eq!(i.key_exprs().len(), 300 + 1);
    }

    #[test]
    fn a_truncated_report_only_widens() {
        let r = report(vec![client("", &["a", "b"])]);
        let mut i = LocalInterest::from_report(&r, "me", &[Pattern::new("*")]);
        i.widen(LocalInterest::from_report(
            &report(vec![client("", &["c"])]),
            "me",
            &[Pattern::new("*")],
        ));
        let names: Vec<&str> = i.channels.iter().map(Subject::as_str).collect();
        assert_eq!(names, ["a", "b", "c"]);
        assert_eq!(i.sets.len(), 1);
    }

    #[test]
    fn six_subscriptions_make_57_sets() {
        let r = report(vec![client("", &["a", "b", "c", "d", "e", "f"])]);
        let i = LocalInterest::from_report(&r, "me", &[Pattern::new("*")]);
        assert_eq!(i.sets.len(), 64 - 1 - 6);
    }
}
