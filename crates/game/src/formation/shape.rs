//! The formation shapes and their slot positions.

pub use colony_proto::game::{Formation, UnknownFormation};
use colony_sim::Vec2;
use std::f64::consts::{FRAC_1_SQRT_2, FRAC_PI_2, PI, TAU};

/// Where each robot of a squad stands: the geometry behind the [`Formation`] a message names.
///
/// Slots are computed in the paper's frame, where the squad faces +y (the
/// paper's horizontal line is across the direction of travel), then rotated
/// so that +y points along the requested facing. With `facing = π/2` the line
/// and the circle are therefore exactly the paper's formulas.
pub trait Slots {
    /// The `n` slot positions of this formation around `centre`, facing
    /// `facing` (radians from +x), with robots spaced `d` cm.
    ///
    /// Line, circle and the wedges are centred on `centre` (the mean of their
    /// slots is `centre`); the half circle surrounds it. Spacing is at least
    /// `d` between any two slots. `n = 0` gives no slots; `d <= 0` (or not
    /// finite) puts every slot on `centre`; a non-finite facing counts as 0.
    fn slots(&self, centre: Vec2, facing: f64, n: usize, d: f64) -> Vec<Vec2>;
}

impl Slots for Formation {
    fn slots(&self, centre: Vec2, facing: f64, n: usize, d: f64) -> Vec<Vec2> {
        let d = if d.is_finite() && d > 0.0 { d } else { 0.0 };
        let facing = if facing.is_finite() { facing } else { 0.0 };
        let forward = Vec2::new(facing.cos(), facing.sin());
        let right = Vec2::new(facing.sin(), -facing.cos());
        local_slots(*self, n, d)
            .into_iter()
            .map(|p| centre + right * p.x + forward * p.y)
            .collect()
    }
}

/// Slots relative to the destination in the paper's frame (facing +y).
fn local_slots(formation: Formation, n: usize, d: f64) -> Vec<Vec2> {
    let nf = n as f64;
    match formation {
        Formation::Line => (0..n)
            .map(|i| Vec2::new(d * (i as f64 - (nf - 1.0) / 2.0), 0.0))
            .collect(),
        Formation::Circle if n == 1 => vec![Vec2::ZERO],
        Formation::Circle => (0..n).map(|i| polar(nf * d, i as f64 * TAU / nf)).collect(),
        Formation::HalfCircle => {
            let step = 1.5 * PI / nf;
            (0..n)
                .map(|i| polar(nf * d, -FRAC_PI_2 + (i as f64 - (nf - 1.0) / 2.0) * step))
                .collect()
        }
        Formation::Wedge => wedge(n, d),
        Formation::InverseWedge => wedge(n, d)
            .into_iter()
            .map(|p| Vec2::new(p.x, -p.y))
            .collect(),
    }
}

fn polar(r: f64, angle: f64) -> Vec2 {
    Vec2::new(r * angle.cos(), r * angle.sin())
}

/// A forward-pointing V centred on the origin: apex first (odd n), then the
/// arms outward, right before left.
fn wedge(n: usize, d: f64) -> Vec<Vec2> {
    let a = d * FRAC_1_SQRT_2;
    let mut slots = Vec::with_capacity(n);
    if n % 2 == 1 {
        slots.push(Vec2::ZERO);
    }
    let mut k = 1.0;
    while slots.len() < n {
        slots.push(Vec2::new(k * a, -k * a));
        slots.push(Vec2::new(-k * a, -k * a));
        k += 1.0;
    }
    // Centre on the mean so the squad's centre is where it was sent; the
    // arms are symmetric, so only the forward axis needs shifting.
    let mean = slots.iter().map(|p| p.y).sum::<f64>() / n.max(1) as f64;
    slots.iter_mut().for_each(|p| p.y -= mean);
    slots
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const EPS: f64 = 1e-9;

    fn close(a: Vec2, b: Vec2, tol: f64) -> bool {
        a.distance(b) <= tol
    }

    fn mean(points: &[Vec2]) -> Vec2 {
        let sum = points.iter().fold(Vec2::ZERO, |acc, &p| acc + p);
        sum * (1.0 / points.len() as f64)
    }

    #[test]
    fn names_round_trip_and_unknown_names_list_the_valid_ones() {
        for f in Formation::ALL {
            assert_eq!(f.to_string().parse::<Formation>(), Ok(f));
        }
        assert_eq!(
            " Half-Circle ".parse::<Formation>(),
            Ok(Formation::HalfCircle)
        );
        let err = "square".parse::<Formation>().unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown formation \"square\"; expected one of: line, circle, half-circle, wedge, inverse-wedge"
        );
    }

    #[test]
    fn serde_names_match_the_parsed_names() {
        for f in Formation::ALL {
            assert_eq!(serde_json::to_string(&f).unwrap(), format!("\"{f}\""));
        }
    }

    #[test]
    fn line_facing_up_is_the_papers_formula() {
        let (dx, dy, d, n) = (40.0, -10.0, 25.0, 4);
        let slots = Formation::Line.slots(Vec2::new(dx, dy), FRAC_PI_2, n, d);
        for (i, s) in slots.iter().enumerate() {
            let paper = Vec2::new(dx + d * (i as f64 - (n as f64 - 1.0) / 2.0), dy);
            assert!(close(*s, paper, EPS), "slot {i}: {s:?} vs {paper:?}");
        }
    }

    #[test]
    fn line_lies_across_the_direction_of_travel() {
        let slots = Formation::Line.slots(Vec2::ZERO, 0.0, 3, 10.0);
        // Facing +x: the line runs along y, from the squad's left (+y) to its right.
        assert!(close(slots[0], Vec2::new(0.0, 10.0), EPS));
        assert!(close(slots[2], Vec2::new(0.0, -10.0), EPS));
    }

    #[test]
    fn circle_facing_up_is_the_papers_formula() {
        let (centre, d, n) = (Vec2::new(5.0, 7.0), 20.0, 6);
        let slots = Formation::Circle.slots(centre, FRAC_PI_2, n, d);
        let r = n as f64 * d;
        for (i, s) in slots.iter().enumerate() {
            let angle = (i as f64 * 360.0 / n as f64).to_radians();
            let paper = centre + Vec2::new(r * angle.cos(), r * angle.sin());
            assert!(close(*s, paper, 1e-9), "slot {i}");
        }
    }

    #[test]
    fn circle_of_one_is_the_destination_itself() {
        let c = Vec2::new(3.0, 4.0);
        assert_eq!(Formation::Circle.slots(c, 1.0, 1, 30.0), [c]);
    }

    #[test]
    fn half_circle_keeps_the_papers_step_and_faces_the_approach() {
        let centre = Vec2::new(100.0, 100.0);
        let (n, d, facing) = (4, 10.0, 0.3);
        let slots = Formation::HalfCircle.slots(centre, facing, n, d);
        let angles: Vec<f64> = slots.iter().map(|&s| (s - centre).angle()).collect();
        for s in &slots {
            assert!((s.distance(centre) - n as f64 * d).abs() < 1e-9);
        }
        for pair in angles.windows(2) {
            let step = (pair[1] - pair[0]).rem_euclid(TAU);
            assert!((step - (270.0 / n as f64).to_radians()).abs() < 1e-9);
        }
        // The arc's middle is on the side the squad comes from.
        let towards_arc = mean(&slots) - centre;
        let approach = Vec2::new(-facing.cos(), -facing.sin());
        assert!((towards_arc.angle() - approach.angle()).abs() < 1e-9);
        // Three robots make the exact half circle.
        let three = Formation::HalfCircle.slots(Vec2::ZERO, FRAC_PI_2, 3, 10.0);
        assert!(close(three[0], Vec2::new(-30.0, 0.0), 1e-9));
        assert!(close(three[1], Vec2::new(0.0, -30.0), 1e-9));
        assert!(close(three[2], Vec2::new(30.0, 0.0), 1e-9));
    }

    #[test]
    fn wedge_points_forward_with_the_leader_at_the_apex() {
        let facing = 0.0;
        let slots = Formation::Wedge.slots(Vec2::ZERO, facing, 5, 10.0);
        let leader = slots[0];
        assert!(slots[1..].iter().all(|s| s.x < leader.x - 1.0));
        assert!(leader.y.abs() < EPS);
        assert!((slots[1].distance(leader) - 10.0).abs() < EPS);
        assert!((slots[3].distance(slots[1]) - 10.0).abs() < EPS);
        // Arms at 45°, one on each side.
        assert!(slots[1].y < 0.0 && slots[2].y > 0.0);
        assert!(((leader - slots[1]).angle() - PI / 4.0).abs() < EPS);
    }

    #[test]
    fn inverse_wedge_trails_its_apex() {
        let slots = Formation::InverseWedge.slots(Vec2::ZERO, FRAC_PI_2, 3, 10.0);
        assert!(slots[1].y > slots[0].y && slots[2].y > slots[0].y);
        let even = Formation::InverseWedge.slots(Vec2::ZERO, FRAC_PI_2, 4, 10.0);
        assert!(close(mean(&even), Vec2::ZERO, EPS));
    }

    #[test]
    fn degenerate_inputs_give_empty_or_centred_slots() {
        let c = Vec2::new(1.0, 2.0);
        for f in Formation::ALL {
            assert!(f.slots(c, 0.0, 0, 10.0).is_empty());
            for d in [0.0, -5.0, f64::NAN, f64::INFINITY] {
                assert_eq!(f.slots(c, 0.0, 3, d), [c, c, c], "{f} with d = {d}");
            }
            let one = f.slots(c, f64::NAN, 1, 10.0);
            assert_eq!(one.len(), 1);
            assert!(one[0].x.is_finite() && one[0].y.is_finite());
        }
    }

    fn pairwise(points: &[Vec2]) -> Vec<f64> {
        let mut out = Vec::new();
        for (i, a) in points.iter().enumerate() {
            for b in &points[i + 1..] {
                out.push(a.distance(*b));
            }
        }
        out
    }

    proptest! {
        #[test]
        fn slots_are_n_finite_and_at_least_d_apart(
            f in prop::sample::select(Formation::ALL.to_vec()),
            n in 0usize..40,
            d in 1.0f64..100.0,
            facing in -10.0f64..10.0,
            cx in -1000.0f64..1000.0,
            cy in -1000.0f64..1000.0,
        ) {
            let slots = f.slots(Vec2::new(cx, cy), facing, n, d);
            prop_assert_eq!(slots.len(), n);
            prop_assert!(slots.iter().all(|s| s.x.is_finite() && s.y.is_finite()));
            for gap in pairwise(&slots) {
                prop_assert!(gap >= d * (1.0 - 1e-9), "{} slots {} apart, d = {}", f, gap, d);
            }
        }

        #[test]
        fn rotating_the_facing_rotates_the_shape_rigidly(
            f in prop::sample::select(Formation::ALL.to_vec()),
            n in 1usize..20,
            d in 1.0f64..100.0,
            facing in -10.0f64..10.0,
        ) {
            let centre = Vec2::new(50.0, -20.0);
            let base = f.slots(centre, 0.0, n, d);
            let turned = f.slots(centre, facing, n, d);
            let (s, c) = facing.sin_cos();
            for (b, t) in base.iter().zip(&turned) {
                let o = *b - centre;
                let rotated = centre + Vec2::new(c * o.x - s * o.y, s * o.x + c * o.y);
                prop_assert!(close(rotated, *t, 1e-6));
            }
        }

        #[test]
        fn centred_formations_are_centred(
            f in prop::sample::select(vec![
                Formation::Line, Formation::Circle, Formation::Wedge, Formation::InverseWedge,
            ]),
            n in 1usize..40,
            d in 1.0f64..100.0,
            facing in -10.0f64..10.0,
        ) {
            let centre = Vec2::new(-300.0, 200.0);
            let slots = f.slots(centre, facing, n, d);
            prop_assert!(close(mean(&slots), centre, 1e-6));
        }
    }
}
