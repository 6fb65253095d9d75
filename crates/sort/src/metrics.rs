//! How well a swarm has sorted: percentage completion (PC, eq. 6), steps to
//! completion (STC), time-weighted completion (TWC, eq. 7) and the
//! convergence of cache points (Fig. 11).
//!
//! PC is computed on the global map (world pucks, [`global_clusters`]). STC
//! and TWC read a series of `(step, PC)` samples, as the authors did with
//! positions saved every 100 steps.
//!
//! ```
//! use colony_sort::metrics::{steps_to_completion, time_weighted_completion};
//! let series = [(0, 10.0), (100, 40.0), (200, 60.0), (300, 100.0)];
//! assert_eq!(steps_to_completion(&series, 50.0), Some(200));
//! let twc = time_weighted_completion(&series).unwrap(); // (40 + 120 + 300) / 600
//! assert!((twc - 460.0 / 600.0).abs() < 1e-12);
//! ```

use std::collections::BTreeMap;

use colony_sim::{Puck, PuckKind, Vec2};

use crate::perception::global_clusters;

/// The completion level STC waits for, in percent.
pub const STC_LEVEL: f64 = 50.0;

/// PC (eq. 6): 100 * sum over types of the largest global cluster's size,
/// divided by the number of pucks. 0 when there are no pucks.
pub fn percentage_completion(pucks: &[Puck], threshold: f64) -> f64 {
    if pucks.is_empty() {
        return 0.0;
    }
    let mut largest: BTreeMap<PuckKind, usize> = BTreeMap::new();
    for c in global_clusters(pucks, threshold) {
        let e = largest.entry(c.kind).or_insert(0);
        *e = (*e).max(c.size());
    }
    100.0 * largest.values().sum::<usize>() as f64 / pucks.len() as f64
}

/// STC: the step of the first sample whose PC reaches `level` percent
/// ([`STC_LEVEL`] in the paper), or `None` if none does.
pub fn steps_to_completion(series: &[(u64, f64)], level: f64) -> Option<u64> {
    series.iter().find(|(_, pc)| *pc >= level).map(|(t, _)| *t)
}

/// TWC (eq. 7) over the samples: sum(t * PC / 100) / sum(t), in [0, 1].
/// `None` when the steps sum to zero.
pub fn time_weighted_completion(series: &[(u64, f64)]) -> Option<f64> {
    let weights: f64 = series.iter().map(|(t, _)| *t as f64).sum();
    if weights <= 0.0 {
        return None;
    }
    let weighted: f64 = series.iter().map(|(t, pc)| *t as f64 * pc / 100.0).sum();
    Some(weighted / weights)
}

/// Cache-point convergence (Fig. 11): for each type, the centroid of every
/// robot's cache point of that type and the (population) variance of the
/// points' distances from it; averaged over the types that have a cache
/// point. `robots` holds each robot's cache points. `None` when no robot has one.
pub fn cache_variance(robots: &[Vec<(PuckKind, Vec2)>]) -> Option<f64> {
    let mut by_kind: BTreeMap<PuckKind, Vec<Vec2>> = BTreeMap::new();
    for (kind, p) in robots.iter().flatten() {
        if p.x.is_finite() && p.y.is_finite() {
            by_kind.entry(*kind).or_default().push(*p);
        }
    }
    if by_kind.is_empty() {
        return None;
    }
    let per_kind: Vec<f64> = by_kind
        .values()
        .map(|pts| {
            let n = pts.len() as f64;
            let centroid = pts.iter().fold(Vec2::ZERO, |s, p| s + *p) * (1.0 / n);
            let d: Vec<f64> = pts.iter().map(|p| p.distance(centroid)).collect();
            let mean = d.iter().sum::<f64>() / n;
            d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n
        })
        .collect();
    Some(per_kind.iter().sum::<f64>() / per_kind.len() as f64)
}
