//! PC, STC, TWC and cache convergence against hand-computed values.

use colony_sim::{Puck, PuckId, PuckKind, Vec2};
use colony_sort::metrics::{
    cache_variance, percentage_completion, steps_to_completion, time_weighted_completion, STC_LEVEL,
};

fn pucks(list: &[(u8, f64, f64)]) -> Vec<Puck> {
    list.iter()
        .enumerate()
        .map(|(i, (k, x, y))| Puck {
            id: PuckId(i),
            kind: PuckKind(*k),
            pos: Vec2::new(*x, *y),
        })
        .collect()
}

#[test]
fn percentage_completion_counts_the_largest_cluster_of_each_type() {
    // Type 0: a cluster of 3 and a single; type 1: a pair and two singles. n = 8.
    let world = pucks(&[
        (0, 0.0, 0.0),
        (0, 6.3, 0.0),
        (0, 12.6, 0.0),
        (0, 80.0, 80.0),
        (1, -50.0, 0.0),
        (1, -50.0, 7.0),
        (1, 50.0, -50.0),
        (1, -50.0, -60.0),
    ]);
    assert!((percentage_completion(&world, 9.45) - 62.5).abs() < 1e-12);
}

#[test]
fn percentage_completion_is_full_when_each_type_is_one_cluster() {
    let world = pucks(&[(0, 0.0, 0.0), (0, 7.0, 0.0), (1, 60.0, 0.0), (1, 60.0, 7.0)]);
    assert_eq!(percentage_completion(&world, 9.45), 100.0);
    // Scattered: every cluster is a single puck, so PC = types / n.
    let scattered = pucks(&[
        (0, 0.0, 0.0),
        (0, 30.0, 0.0),
        (1, 60.0, 0.0),
        (1, 90.0, 0.0),
    ]);
    assert_eq!(percentage_completion(&scattered, 9.45), 50.0);
    assert_eq!(percentage_completion(&[], 9.45), 0.0);
}

#[test]
fn steps_to_completion_is_the_first_sample_reaching_fifty_percent() {
    let series = [
        (0, 5.0),
        (100, 30.0),
        (200, 49.99),
        (300, 50.0),
        (400, 20.0),
        (500, 90.0),
    ];
    assert_eq!(steps_to_completion(&series, STC_LEVEL), Some(300));
    assert_eq!(steps_to_completion(&series[..3], STC_LEVEL), None);
    assert_eq!(steps_to_completion(&[], STC_LEVEL), None);
}

#[test]
fn time_weighted_completion_weights_late_samples_more() {
    // sum t = 100 + 200 + 300 + 400 = 1000;
    // sum t * PC / 100 = 100*0.2 + 200*0.5 + 300*0.5 + 400*1.0 = 670.
    let series = [
        (0, 0.0),
        (100, 20.0),
        (200, 50.0),
        (300, 50.0),
        (400, 100.0),
    ];
    let twc = time_weighted_completion(&series).unwrap();
    assert!((twc - 0.67).abs() < 1e-12, "{twc}");
    // A method that finishes early and then degrades scores below one that holds.
    let degrades = [(100, 100.0), (200, 100.0), (300, 0.0)];
    let holds = [(100, 0.0), (200, 100.0), (300, 100.0)];
    assert!(
        time_weighted_completion(&degrades).unwrap() < time_weighted_completion(&holds).unwrap()
    );
    assert_eq!(time_weighted_completion(&[(0, 50.0)]), None);
}

#[test]
fn cache_variance_is_zero_once_every_robot_agrees() {
    let k0 = PuckKind(0);
    let k1 = PuckKind(1);
    let agreed = vec![
        vec![(k0, Vec2::new(10.0, 10.0)), (k1, Vec2::new(-40.0, 0.0))],
        vec![(k0, Vec2::new(10.0, 10.0)), (k1, Vec2::new(-40.0, 0.0))],
    ];
    assert_eq!(cache_variance(&agreed), Some(0.0));
    assert_eq!(cache_variance(&[vec![], vec![]]), None);
}

#[test]
fn cache_variance_averages_the_variance_of_distances_over_types() {
    let k0 = PuckKind(0);
    let k1 = PuckKind(1);
    // Type 0: points at (0,0), (4,0), (0,4), (4,4): centroid (2,2), every distance sqrt 8,
    // variance 0. Type 1: (0,0), (6,0), (30,0): centroid (12,0), distances 12, 6, 18,
    // mean 12, variance (0 + 36 + 36) / 3 = 24. Average = 12.
    let robots = vec![
        vec![(k0, Vec2::new(0.0, 0.0)), (k1, Vec2::new(0.0, 0.0))],
        vec![(k0, Vec2::new(4.0, 0.0)), (k1, Vec2::new(6.0, 0.0))],
        vec![(k0, Vec2::new(0.0, 4.0)), (k1, Vec2::new(30.0, 0.0))],
        vec![(k0, Vec2::new(4.0, 4.0))],
    ];
    let v = cache_variance(&robots).unwrap();
    assert!((v - 12.0).abs() < 1e-9, "{v}");
}
