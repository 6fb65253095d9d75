//! Which robot takes which slot.

use colony_sim::Vec2;
use pathfinding::kuhn_munkres::kuhn_munkres;
use pathfinding::matrix::Matrix;

/// Kuhn-Munkres needs totally ordered weights, so distances are compared in
/// whole micrometres: far finer than any robot can position itself.
const UNITS_PER_CM: f64 = 1e4;

/// Distances beyond this (cm) all cost the same; it keeps the sum of `n`
/// costs far from `i64` overflow for any squad that fits in memory.
const MAX_COST_CM: f64 = 1e9;

/// For each robot, the index of the slot it should take so that the total
/// straight-line distance travelled is as small as possible (the gather step:
/// "each robot is assigned a point in the final formation based on minimal
/// distance").
///
/// `result[r]` is robot `r`'s slot, and no two robots share one. Optimal to
/// within a micrometre per robot; ties are broken deterministically. A
/// position that is not finite counts as infinitely far from every slot. Slots
/// beyond the number of robots are left free.
///
/// # Panics
///
/// If there are more robots than slots, since some robot would have nowhere
/// to go. Pass `formation.slots(.., robots.len(), ..)`.
///
/// # Example
///
/// ```
/// use colony_game::formation::assign;
/// use colony_sim::Vec2;
///
/// let robots = [Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0)];
/// let slots = [Vec2::new(11.0, 5.0), Vec2::new(-1.0, 5.0)];
/// assert_eq!(assign(&robots, &slots), [1, 0]);
/// ```
pub fn assign(robots: &[Vec2], slots: &[Vec2]) -> Vec<usize> {
    assert!(
        robots.len() <= slots.len(),
        "{} robots cannot take {} slots",
        robots.len(),
        slots.len()
    );
    if robots.is_empty() {
        return Vec::new();
    }
    // kuhn_munkres maximises, so the weights are negated costs.
    let weights = Matrix::from_fn(robots.len(), slots.len(), |(r, s)| {
        let cm = robots[r].distance(slots[s]);
        let cm = if cm.is_finite() {
            cm.min(MAX_COST_CM)
        } else {
            MAX_COST_CM
        };
        -((cm * UNITS_PER_CM).round() as i64)
    });
    kuhn_munkres(&weights).1
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn total(robots: &[Vec2], slots: &[Vec2], slot_of: &[usize]) -> f64 {
        robots
            .iter()
            .zip(slot_of)
            .map(|(r, &s)| r.distance(slots[s]))
            .sum()
    }

    /// The cheapest total over every permutation, by exhaustive search.
    fn brute_force(robots: &[Vec2], slots: &[Vec2]) -> f64 {
        fn go(robots: &[Vec2], slots: &[Vec2], used: &mut Vec<bool>) -> f64 {
            let Some((first, rest)) = robots.split_first() else {
                return 0.0;
            };
            let mut best = f64::INFINITY;
            for s in 0..slots.len() {
                if !used[s] {
                    used[s] = true;
                    best = best.min(first.distance(slots[s]) + go(rest, slots, used));
                    used[s] = false;
                }
            }
            best
        }
        go(robots, slots, &mut vec![false; slots.len()])
    }

    fn points(max: usize) -> impl Strategy<Value = Vec<Vec2>> {
        prop::collection::vec(
            (-500.0f64..500.0, -500.0f64..500.0).prop_map(|(x, y)| Vec2::new(x, y)),
            max,
        )
    }

    #[test]
    fn no_robots_need_no_slots() {
        assert!(assign(&[], &[]).is_empty());
        assert!(assign(&[], &[Vec2::ZERO]).is_empty());
    }

    #[test]
    fn one_robot_takes_the_nearest_of_several_slots() {
        let slots = [
            Vec2::new(50.0, 0.0),
            Vec2::new(2.0, 1.0),
            Vec2::new(-9.0, 0.0),
        ];
        assert_eq!(assign(&[Vec2::ZERO], &slots), [1]);
    }

    #[test]
    fn robot_gives_up_its_nearest_slot_when_that_is_cheaper_overall() {
        // Taking slots robot by robot, robot 0 would grab slot 0 (1 cm away)
        // and send robot 1 3 cm the other way; swapping costs 2 cm in all.
        let robots = [Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0)];
        let slots = [Vec2::new(1.0, 0.0), Vec2::new(-1.0, 0.0)];
        assert_eq!(assign(&robots, &slots), [1, 0]);
    }

    #[test]
    fn robots_that_are_not_finite_still_get_a_slot() {
        let robots = [Vec2::new(f64::NAN, 0.0), Vec2::new(1.0, 1.0)];
        let slots = [Vec2::new(1.0, 1.0), Vec2::new(500.0, 0.0)];
        assert_eq!(assign(&robots, &slots), [1, 0]);
    }

    #[test]
    #[should_panic(expected = "3 robots cannot take 2 slots")]
    fn more_robots_than_slots_is_a_caller_error() {
        assign(&[Vec2::ZERO; 3], &[Vec2::ZERO; 2]);
    }

    proptest! {
        #[test]
        fn assignment_is_a_permutation_as_cheap_as_brute_force(
            (robots, slots) in (0usize..=6).prop_flat_map(|n| (points(n), points(n)))
        ) {
            let slot_of = assign(&robots, &slots);
            let mut sorted = slot_of.clone();
            sorted.sort_unstable();
            prop_assert_eq!(sorted, (0..robots.len()).collect::<Vec<_>>());
            let best = brute_force(&robots, &slots);
            // Micrometre rounding can cost at most a micrometre per robot.
            prop_assert!(total(&robots, &slots, &slot_of) <= best + 1e-4 * robots.len() as f64 + 1e-9);
        }

        #[test]
        fn extra_slots_are_left_free_optimally(
            (robots, slots) in (0usize..=4).prop_flat_map(|n| (points(n), points(n + 2)))
        ) {
            let slot_of = assign(&robots, &slots);
            let best = brute_force(&robots, &slots);
            prop_assert!(total(&robots, &slots, &slot_of) <= best + 1e-4 * robots.len() as f64 + 1e-9);
        }
    }
}
