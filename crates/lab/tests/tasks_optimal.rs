//! Greedy auctions against the optimal assignment on the same streams.

use colony_lab::tasks::optimal::{compare, CompareConfig};

#[test]
fn the_optimum_is_never_worse_and_greedy_is_close() {
    let mut ratios = Vec::new();
    for seed in 0..10 {
        for resources_term in [false, true] {
            let c = compare(&CompareConfig {
                seed,
                robots: 12,
                tasks: 10,
                resources_term,
            })
            .unwrap();
            println!("{c:?} ratio {:?}", c.cost_ratio());
            assert!(c.optimal_allocated >= c.greedy_allocated, "{c:?}");
            if let Some(r) = c.cost_ratio() {
                assert!(r >= 1.0 - 1e-9, "greedy beat the optimum: {c:?}");
                ratios.push(r);
            }
        }
    }
    assert!(ratios.len() >= 10);
}

#[test]
fn bad_sizes_are_refused() {
    let e = compare(&CompareConfig {
        seed: 1,
        robots: 0,
        tasks: 3,
        resources_term: false,
    })
    .unwrap_err()
    .to_string();
    assert!(e.contains("robots"), "{e}");
}
