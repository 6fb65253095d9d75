//! The arena cut into vertical strips, so the solver runs on several threads and still
//! gives the same bits on any number of them.
//!
//! A contact belongs to the strip of its first body (always one that moves). Strips are
//! wider than any two touching bodies reach, so a strip's contacts touch bodies of that
//! strip and its two neighbours only. Strips `k`, `k + 3`, `k + 6`, ... therefore share no
//! body: they are solved side by side, and the three phases (`k` mod 3) one after another.
//! Within a strip, contacts keep the order they were found in. The order of every update
//! to a body is thus fixed by the strips alone, and running a phase's strips one after
//! another, as a small world does, gives what running them at once gives.
//!
//! For the threads to share nothing, the bodies that move in a step are copied, ordered by
//! strip, into a scratch array: a strip's three neighbours are one contiguous slice of it,
//! and the slices of one phase are disjoint (`split_at_mut`, no `unsafe`).

use std::ops::Range;

use rayon::prelude::*;

use super::solver::Contact;
use super::{Bodies, State};

/// Work on one group: its contacts, the states of its strip and their neighbours, and
/// where that slice begins among all the states.
pub(crate) type GroupWork<'a> = dyn Fn(&mut [Contact], &mut [State], usize) + Sync + 'a;

/// A body that does not move in this step (the wall, a sleeping puck).
pub(crate) const STATIC: u32 = u32::MAX;

/// Narrowest strip, cm: more than two robots' reach across (2 x 14 cm and the margin).
const MIN_WIDTH: f64 = 32.0;

/// Strips across the widest arena, at most.
const MAX_STRIPS: usize = 96;

/// A phase with fewer contacts than this runs on the calling thread (the same bits).
const PARALLEL_MIN: usize = 4096;

/// The step's strips: which bodies move, in what order, and which contacts go where.
#[derive(Debug, Default)]
pub(crate) struct Strips {
    x0: f64,
    width: f64,
    count: usize,
    /// The moving bodies, by strip and then id.
    pub order: Vec<u32>,
    /// Where each strip's bodies begin in `order` (`count + 1` entries).
    start: Vec<usize>,
    /// Each body's place in `order`, or [`STATIC`].
    slot: Vec<u32>,
    /// Strips in the order they are solved (phase by phase), each with its contacts.
    groups: Vec<(usize, Range<usize>)>,
    /// Where each phase's groups begin in `groups` (4 entries).
    phase_start: [usize; 4],
    /// The fewest contacts in a phase for its strips to go to rayon's threads.
    parallel_min: usize,
    /// Contacts whose bodies lie more than a strip apart (none, short of a body thrown
    /// out of the arena): solved last, alone, with every state.
    overflow: Range<usize>,
}

impl Strips {
    /// Strips across an arena `half_width` either side of the origin.
    pub fn new(half_width: f64) -> Strips {
        let span = 2.0 * half_width + 2.0;
        let width = MIN_WIDTH.max(span / MAX_STRIPS as f64);
        Strips {
            x0: -half_width - 1.0,
            width,
            count: ((span / width).ceil() as usize).max(1),
            parallel_min: PARALLEL_MIN,
            ..Strips::default()
        }
    }

    fn strip_of(&self, x: f64) -> usize {
        let k = ((x - self.x0) / self.width).floor();
        if k.is_nan() {
            return 0;
        }
        k.clamp(0.0, (self.count - 1) as f64) as usize
    }

    /// Orders `moving` (body ids) by strip, gives each contact its bodies' places and
    /// sorts the contacts into their strips' groups.
    pub fn arrange(&mut self, bodies: &Bodies, moving: &[u32], contacts: &mut Vec<Contact>) {
        for &i in &self.order {
            self.slot[i as usize] = STATIC;
        }
        if self.slot.len() < bodies.pos.len() {
            self.slot.resize(bodies.pos.len(), STATIC);
        }
        let strips: Vec<usize> = moving
            .iter()
            .map(|&i| self.strip_of(bodies.pos[i as usize].x))
            .collect();
        self.start.clear();
        self.start.resize(self.count + 1, 0);
        for &k in &strips {
            self.start[k + 1] += 1;
        }
        for k in 0..self.count {
            self.start[k + 1] += self.start[k];
        }
        let mut cursor = self.start.clone();
        self.order.clear();
        self.order.resize(moving.len(), 0);
        for (&i, &k) in moving.iter().zip(&strips) {
            self.order[cursor[k]] = i;
            cursor[k] += 1;
        }
        for (place, &i) in self.order.iter().enumerate() {
            self.slot[i as usize] = place as u32;
        }

        // Contacts by group: phase 0's strips (0, 3, 6, ...), then phase 1's, then 2's.
        let rank = |k: usize| {
            let phase = k % 3;
            let before: usize = (0..phase).map(|p| (self.count + 2 - p) / 3).sum();
            before + k / 3
        };
        let overflow = self.count;
        let mut counts = vec![0usize; self.count + 2];
        let mut ranks = Vec::with_capacity(contacts.len());
        for c in contacts.iter_mut() {
            c.sa = self.slot[c.a as usize];
            c.sb = self.slot[c.b as usize];
            let strip =
                |slot: u32| (slot != STATIC).then(|| strip_of_slot(&self.start, slot as usize));
            let r = match (strip(c.sa), strip(c.sb)) {
                (Some(k), None) => rank(k),
                (Some(k), Some(l)) if k.abs_diff(l) <= 1 => rank(k),
                _ => overflow,
            };
            ranks.push(r);
            counts[r + 1] += 1;
        }
        for r in 0..=self.count {
            counts[r + 1] += counts[r];
        }
        self.overflow = counts[overflow]..counts[overflow + 1];
        let mut at = counts.clone();
        let mut sorted = vec![None; contacts.len()];
        for (c, &r) in contacts.iter().zip(&ranks) {
            sorted[at[r]] = Some(*c);
            at[r] += 1;
        }
        contacts.clear();
        contacts.extend(sorted.into_iter().flatten());

        self.groups.clear();
        for p in 0..3 {
            self.phase_start[p] = self.groups.len();
            let mut k = p;
            while k < self.count {
                let r = rank(k);
                if counts[r + 1] > counts[r] {
                    self.groups.push((k, counts[r]..counts[r + 1]));
                }
                k += 3;
            }
        }
        self.phase_start[3] = self.groups.len();
    }

    /// The moving bodies' states, in `order`.
    pub fn gather(&self, bodies: &Bodies) -> Vec<State> {
        self.order
            .iter()
            .map(|&i| bodies.state[i as usize])
            .collect()
    }

    /// Runs `f` on every group, phase by phase, with the group's contacts and the states
    /// of its strip and their neighbours (and where that slice begins in `states`).
    pub fn run(&self, contacts: &mut [Contact], states: &mut [State], f: &GroupWork) {
        for p in 0..3 {
            let groups = &self.groups[self.phase_start[p]..self.phase_start[p + 1]];
            let (Some(first), Some(last)) = (groups.first(), groups.last()) else {
                continue;
            };
            let span = first.1.start..last.1.end;
            let mut rest_c = &mut contacts[span.clone()];
            let mut rest_s = &mut *states;
            let mut taken = 0;
            let mut pieces = Vec::with_capacity(groups.len());
            for (k, range) in groups {
                let lo = self.start[k.saturating_sub(1)];
                let hi = self.start[(k + 2).min(self.count)];
                let tail = std::mem::take(&mut rest_s);
                let (_, tail) = tail.split_at_mut(lo - taken);
                let (mine, tail) = tail.split_at_mut(hi - lo);
                rest_s = tail;
                taken = hi;
                let tail = std::mem::take(&mut rest_c);
                let (mine_c, tail) = tail.split_at_mut(range.len());
                rest_c = tail;
                pieces.push((mine_c, mine, lo));
            }
            if span.len() >= self.parallel_min {
                pieces
                    .into_par_iter()
                    .for_each(|(c, s, offset)| f(c, s, offset));
            } else {
                for (c, s, offset) in pieces {
                    f(c, s, offset);
                }
            }
        }
        if !self.overflow.is_empty() {
            f(&mut contacts[self.overflow.clone()], states, 0);
        }
    }
}

/// The strip whose bodies include place `slot` of `order`.
fn strip_of_slot(start: &[usize], slot: usize) -> usize {
    // The last strip beginning at or before `slot` (empty strips begin where the next does).
    start.partition_point(|&s| s <= slot) - 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::disc::solver::{self, Soft};
    use crate::disc::Kind;
    use crate::types::Vec2;
    use std::collections::HashMap;

    /// A row of 3,000 overlapping discs across a 20 m arena, each pressed on the next,
    /// solved for a few passes; returns every state's bits.
    fn solve_row(parallel_min: usize, threads: usize) -> (Vec<u64>, Vec<u64>) {
        let mut bodies = Bodies::default();
        bodies.push(Kind::Wall, Vec2::new(0.0, 0.0), (1.0, 0.0), (0.0, 0.0), 0.2);
        let n = 3000;
        for i in 0..n {
            let x = -900.0 + i as f64 * 0.6;
            bodies.push(Kind::Puck, Vec2::new(x, 0.0), (1.0, 0.0), (0.05, 0.01), 0.2);
            bodies.state[i + 1].vel = Vec2::new(((i * 7) % 11) as f64 - 5.0, 0.0);
        }
        let mut contacts: Vec<Contact> = (1..n as u32)
            .map(|i| {
                let at = Vec2::new(bodies.pos[i as usize].x + 0.3, 0.0);
                let key = solver::key(i as usize, i as usize + 1, 0, 0, 0);
                Contact::new(i, i + 1, key, Vec2::new(1.0, 0.0), at, -0.1)
            })
            .collect();
        solver::prepare(&mut contacts, &bodies, &HashMap::default());
        let mut strips = Strips::new(1000.0);
        strips.parallel_min = parallel_min;
        let moving: Vec<u32> = (1..=n as u32).collect();
        strips.arrange(&bodies, &moving, &mut contacts);
        let mut states = strips.gather(&bodies);
        let bits = |states: &[State]| -> Vec<u64> {
            states
                .iter()
                .flat_map(|s| [s.vel.x.to_bits(), s.vel.y.to_bits(), s.spin.to_bits()])
                .collect()
        };
        let before = bits(&states);
        let soft = Soft::new(1.0 / 56.0);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            for push in [true, false, true] {
                strips.run(&mut contacts, &mut states, &|c, s, o| {
                    solver::solve(c, s, o, &soft, push)
                });
            }
        });
        (before, bits(&states))
    }

    #[test]
    fn strips_solved_side_by_side_give_the_bits_of_strips_solved_in_turn() {
        let (before, serial) = solve_row(usize::MAX, 1);
        assert_eq!(serial, solve_row(0, 2).1);
        assert_eq!(serial, solve_row(0, 1).1);
        assert_ne!(before, serial, "the contacts changed nothing");
    }

    #[test]
    fn a_contact_across_more_than_a_strip_is_solved_last_not_lost() {
        let mut bodies = Bodies::default();
        bodies.push(Kind::Wall, Vec2::new(0.0, 0.0), (1.0, 0.0), (0.0, 0.0), 0.2);
        for x in [-900.0, 900.0] {
            bodies.push(Kind::Puck, Vec2::new(x, 0.0), (1.0, 0.0), (0.05, 0.01), 0.2);
        }
        let mut contacts = vec![Contact::new(
            1,
            2,
            0,
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 0.0),
            -1.0,
        )];
        solver::prepare(&mut contacts, &bodies, &HashMap::default());
        let mut strips = Strips::new(1000.0);
        strips.arrange(&bodies, &[1, 2], &mut contacts);
        assert_eq!(strips.overflow, 0..1);
        let mut states = strips.gather(&bodies);
        let soft = Soft::new(1.0 / 56.0);
        strips.run(&mut contacts, &mut states, &|c, s, o| {
            solver::solve(c, s, o, &soft, true)
        });
        assert!(states[0].vel.x < 0.0 && states[1].vel.x > 0.0, "{states:?}");
    }
}
