//! Deneubourg et al.'s (1990) pick-up and deposit probabilities (the paper's Fig. 3).
//!
//! `f` is the size of the candidate cluster in pucks. Picking up favours small
//! clusters, depositing favours large ones:
//!
//! ```
//! use colony_sort::deneubourg::{p_drop, p_pick};
//! assert_eq!(p_pick(1.0, 1.0), 0.25);
//! assert_eq!(p_drop(8.0, 8.0), 0.25);
//! ```

/// Probability of targeting a cluster of size `f` for pick-up: (k1 / (k1 + f))^2.
pub fn p_pick(f: f64, k1: f64) -> f64 {
    let p = k1 / (k1 + f);
    if p.is_finite() {
        (p * p).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Probability of targeting a cluster of size `f` for deposit: (f / (k2 + f))^2.
pub fn p_drop(f: f64, k2: f64) -> f64 {
    let p = f / (k2 + f);
    if p.is_finite() {
        (p * p).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pick_up_falls_and_deposit_rises_with_cluster_size() {
        assert!((p_pick(1.0, 1.0) - 0.25).abs() < 1e-12);
        assert!((p_pick(3.0, 1.0) - 1.0 / 16.0).abs() < 1e-12);
        assert!((p_pick(20.0, 1.0) - 1.0 / 441.0).abs() < 1e-12);
        assert!((p_drop(1.0, 8.0) - 1.0 / 81.0).abs() < 1e-12);
        assert!((p_drop(8.0, 8.0) - 0.25).abs() < 1e-12);
        assert!((p_drop(24.0, 8.0) - 0.5625).abs() < 1e-12);
        for f in 1..40 {
            let f = f as f64;
            assert!(p_pick(f + 1.0, 1.0) < p_pick(f, 1.0));
            assert!(p_drop(f + 1.0, 8.0) > p_drop(f, 8.0));
        }
    }

    #[test]
    fn degenerate_inputs_give_probabilities() {
        assert_eq!(p_pick(0.0, 0.0), 0.0);
        assert_eq!(p_drop(0.0, 0.0), 0.0);
        assert_eq!(p_drop(0.0, 8.0), 0.0);
        assert_eq!(p_pick(0.0, 1.0), 1.0);
    }
}
