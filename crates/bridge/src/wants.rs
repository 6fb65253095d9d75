//! Other sites' wants, held within bounds, and the channels exported for them.
//!
//! Any Zenoh peer may declare want tokens, for any site name. So the table
//! of wants is bounded per site (a real bridge asks for at most
//! [`PER_SITE`] channels) and in all ([`MAX_WANTS`]); when it is full, a
//! new want takes the place of one of the site holding the most, as long as
//! that site would still hold more, so every site keeps an equal share of
//! the table (or all it asks for, if less). The channels exported are picked
//! in turn, site by site and name by name, so each site gets an equal share
//! of them too, and the same wants always pick the same channels.
//!
//! A want refused, or let go for another site's, is not forgotten by Zenoh:
//! when room frees, [`Wants::relook_due`] says to ask Zenoh for the live
//! tokens again.

use std::collections::{BTreeMap, BTreeSet};

use colony_wire::Subject;

use crate::keys::Site;

/// The most wants one site may hold: as many channels as a bridge asks for.
pub const PER_SITE: usize = crate::interest::MAX_CHANNELS;
/// The most wants held in all.
pub const MAX_WANTS: usize = 8_192;

/// What became of a want offered to the table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Offer {
    /// Held already.
    Known,
    /// Now held.
    Held,
    /// Now held, in place of this want of the site that held the most.
    HeldInstead(Site, Subject),
    /// No room: the site holds its share, or [`PER_SITE`].
    Refused,
}

/// Other sites' wants: site -> the channels it wants.
#[derive(Debug, Default)]
pub struct Wants {
    sites: BTreeMap<Site, BTreeSet<Subject>>,
    /// (wants held, site), to find the site holding the most.
    sizes: BTreeSet<(usize, Site)>,
    held: usize,
    /// A want was refused or let go since Zenoh was last asked for them all.
    refused: bool,
    /// A want was withdrawn since: one refused may fit now.
    room: bool,
}

impl Wants {
    /// Offers a want of `site` for `subject`.
    pub fn offer(&mut self, site: &Site, subject: &Subject) -> Offer {
        let mine = self.sites.get(site).map_or(0, BTreeSet::len);
        if self
            .sites
            .get(site)
            .is_some_and(|subjects| subjects.contains(subject))
        {
            return Offer::Known;
        }
        if mine >= PER_SITE {
            self.refused = true;
            return Offer::Refused;
        }
        let mut instead = None;
        if self.held >= MAX_WANTS {
            let most = self.sizes.last().cloned();
            match most {
                // Only while the other site would still hold more than this
                // one: otherwise two sites would take turns at one place.
                Some((n, other)) if n > mine + 1 => {
                    let Some(gone) = self.sites.get(&other).and_then(|s| s.last()).cloned() else {
                        self.refused = true;
                        return Offer::Refused;
                    };
                    self.withdraw_held(&other, &gone);
                    instead = Some((other, gone));
                }
                _ => {
                    self.refused = true;
                    return Offer::Refused;
                }
            }
        }
        self.resize(site, mine, mine + 1);
        self.sites
            .entry(site.clone())
            .or_default()
            .insert(subject.clone());
        self.held += 1;
        match instead {
            Some((other, gone)) => {
                self.refused = true;
                Offer::HeldInstead(other, gone)
            }
            None => Offer::Held,
        }
    }

    /// Withdraws a want; `true` if it was held.
    pub fn withdraw(&mut self, site: &Site, subject: &Subject) -> bool {
        let held = self.withdraw_held(site, subject);
        self.room |= held;
        held
    }

    fn withdraw_held(&mut self, site: &Site, subject: &Subject) -> bool {
        let Some(subjects) = self.sites.get_mut(site) else {
            return false;
        };
        if !subjects.remove(subject) {
            return false;
        }
        let left = subjects.len();
        if left == 0 {
            self.sites.remove(site);
        }
        self.resize(site, left + 1, left);
        self.held -= 1;
        true
    }

    fn resize(&mut self, site: &Site, from: usize, to: usize) {
        if from > 0 {
            self.sizes.remove(&(from, site.clone()));
        }
        if to > 0 {
            self.sizes.insert((to, site.clone()));
        }
    }

    /// Forgets every want (Zenoh is about to list them all again).
    pub fn clear(&mut self) {
        *self = Wants::default();
    }

    /// Whether to ask Zenoh for the live tokens again, now that a want was
    /// refused and room has freed since; answers `true` once for each such
    /// pair.
    pub fn relook_due(&mut self) -> bool {
        if self.refused && self.room {
            self.refused = false;
            self.room = false;
            return true;
        }
        false
    }

    /// Whether [`relook_due`](Self::relook_due) would answer `true`.
    pub fn relook_pending(&self) -> bool {
        self.refused && self.room
    }

    /// How many wants are held.
    pub fn len(&self) -> usize {
        self.held
    }

    /// Whether no want is held.
    pub fn is_empty(&self) -> bool {
        self.held == 0
    }

    /// Every channel some site wants that `allowed` lets out.
    pub fn wanted(&self, allowed: impl Fn(&Subject) -> bool) -> BTreeSet<Subject> {
        self.sites
            .values()
            .flatten()
            .filter(|s| allowed(s))
            .cloned()
            .collect()
    }

    /// At most `max` channels that `allowed` lets out, picked in turns: each
    /// site in name order takes its first channel (by name) not picked yet.
    /// The same wants always pick the same channels, and a site that asks
    /// for many takes no more than its share from one that asks for few.
    pub fn choose(&self, allowed: impl Fn(&Subject) -> bool, max: usize) -> BTreeSet<Subject> {
        let allowed = &allowed;
        let mut turns: Vec<_> = self
            .sites
            .values()
            .map(|subjects| subjects.iter().filter(move |s| allowed(s)))
            .collect();
        let mut chosen = BTreeSet::new();
        while chosen.len() < max {
            let mut took = false;
            for turn in &mut turns {
                if chosen.len() >= max {
                    break;
                }
                if let Some(s) = turn.find(|s| !chosen.contains(*s)) {
                    chosen.insert(s.clone());
                    took = true;
                }
            }
            if !took {
                break;
            }
        }
        chosen
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn site(name: &str) -> Site {
        Site::new(name).unwrap()
    }

    fn subject(name: &str) -> Subject {
        Subject::new(name).unwrap()
    }

    fn junk(i: usize) -> Subject {
        subject(&format!("junk{i:05}"))
    }

    #[test]
    fn a_site_holds_at_most_its_bound_and_others_still_get_in() {
        let mut w = Wants::default();
        let x = site("x");
        for i in 0..PER_SITE {
            assert_eq!(w.offer(&x, &junk(i)), Offer::Held);
        }
        assert_eq!(w.offer(&x, &junk(PER_SITE)), Offer::Refused);
        assert_eq!(w.offer(&x, &junk(0)), Offer::Known);
        assert_eq!(w.offer(&site("b"), &subject("vision")), Offer::Held);
        assert_eq!(w.len(), PER_SITE + 1);
    }

    /// The review's attack: junk wants filling the table shut a real site
    /// out for good. Now a full table makes room for a site holding less
    /// than the one holding the most.
    #[test]
    fn a_full_table_makes_room_for_a_site_holding_less() {
        let mut w = Wants::default();
        let per = MAX_WANTS / PER_SITE;
        let junk_sites: Vec<Site> = (0..per).map(|i| site(&format!("x{i}"))).collect();
        for (k, s) in junk_sites.iter().enumerate() {
            for i in 0..PER_SITE {
                assert_eq!(w.offer(s, &junk(k * PER_SITE + i)), Offer::Held);
            }
        }
        assert_eq!(w.len(), MAX_WANTS);
        let b = site("b");
        match w.offer(&b, &subject("vision")) {
            Offer::HeldInstead(other, _) => assert!(junk_sites.contains(&other)),
            o => panic!("{o:?}"),
        }
        assert_eq!(w.len(), MAX_WANTS);
        // Sites holding the same share take no place from one another.
        let mut small = Wants::default();
        for i in 0..MAX_WANTS {
            let s = site(&format!("s{i}"));
            assert_eq!(small.offer(&s, &subject("a")), Offer::Held);
        }
        assert_eq!(small.offer(&site("s0"), &subject("b")), Offer::Refused);
        assert_eq!(small.offer(&site("new"), &subject("a")), Offer::Refused);
    }

    #[test]
    fn a_refused_want_is_looked_at_again_once_room_frees() {
        let mut w = Wants::default();
        let x = site("x");
        for i in 0..PER_SITE {
            w.offer(&x, &junk(i));
        }
        assert!(!w.relook_due());
        assert_eq!(w.offer(&x, &subject("alpha")), Offer::Refused);
        assert!(!w.relook_due(), "no room has freed");
        assert!(!w.withdraw(&x, &subject("alpha")), "never held");
        assert!(!w.relook_due());
        assert!(w.withdraw(&x, &junk(3)));
        assert!(w.relook_pending());
        assert!(w.relook_due());
        assert!(!w.relook_pending());
        assert!(!w.relook_due(), "once");
        assert_eq!(w.offer(&x, &subject("alpha")), Offer::Held);
    }

    #[test]
    fn exports_are_shared_between_sites_and_the_same_wants_pick_the_same() {
        let mut w = Wants::default();
        for i in 0..PER_SITE {
            w.offer(&site("x"), &junk(i));
        }
        w.offer(&site("y"), &subject("vision"));
        w.offer(&site("y"), &subject("radio"));
        w.offer(&site("z"), &subject("vision"));
        let all = |_: &Subject| true;
        let chosen = w.choose(all, 255);
        assert_eq!(chosen.len(), 255);
        assert!(chosen.contains(&subject("vision")) && chosen.contains(&subject("radio")));
        for _ in 0..3 {
            assert_eq!(w.choose(all, 255), chosen);
        }
        // The export rules leave channels out before any is picked.
        let no_radio = |s: &Subject| s.as_str() != "radio";
        let chosen = w.choose(no_radio, 3);
        let names: Vec<&str> = chosen.iter().map(Subject::as_str).collect();
        assert_eq!(names, ["junk00000", "junk00001", "vision"]);
        assert_eq!(w.wanted(no_radio).len(), PER_SITE + 1);
    }

    #[test]
    fn withdrawing_every_want_empties_the_table() {
        let mut w = Wants::default();
        let (x, y) = (site("x"), site("y"));
        for i in 0..10 {
            w.offer(&x, &junk(i));
            w.offer(&y, &junk(i));
        }
        for i in 0..10 {
            assert!(w.withdraw(&x, &junk(i)));
            assert!(w.withdraw(&y, &junk(i)));
        }
        assert!(w.is_empty() && w.sites.is_empty() && w.sizes.is_empty());
    }
}
