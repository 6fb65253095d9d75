//! The team reward: PC, its change, or the change of the time-weighted
//! completion, all as fractions (PC / 100) so that they share TWC's scale.
//!
//! TWC is kept as the two running sums `metrics::time_weighted_completion`
//! adds up, in the same order and with the same arithmetic, so that
//! [`Progress::twc`] is bit-identical to that function over the PC of every
//! step so far.

use super::RewardKind;

/// PC and the TWC sums of the episode so far.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Progress {
    /// PC (percent) at the last step.
    pc: f64,
    /// Σ t·PC(t)/100.
    weighted: f64,
    /// Σ t.
    weights: f64,
}

impl Progress {
    /// An episode at step 0 with PC `pc` (its weight is 0: it adds nothing to TWC).
    pub fn start(pc: f64) -> Progress {
        Progress {
            pc,
            weighted: 0.0,
            weights: 0.0,
        }
    }

    /// PC (percent) now.
    pub fn pc(&self) -> f64 {
        self.pc
    }

    /// TWC of every step so far, 0 before the first step.
    pub fn twc(&self) -> f64 {
        if self.weights <= 0.0 {
            0.0
        } else {
            self.weighted / self.weights
        }
    }

    /// Records PC `pc` at step `step` and returns the reward of that step.
    pub fn advance(&mut self, step: u64, pc: f64, kind: RewardKind) -> f64 {
        let (before_pc, before_twc) = (self.pc, self.twc());
        self.pc = pc;
        // Written as metrics::time_weighted_completion writes it, for bit-identical sums.
        self.weights += step as f64;
        self.weighted += step as f64 * pc / 100.0;
        match kind {
            RewardKind::Pc => pc / 100.0,
            RewardKind::PcChange => (pc - before_pc) / 100.0,
            RewardKind::TwcChange => self.twc() - before_twc,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_sort::metrics::time_weighted_completion;

    #[test]
    fn env_reward_twc_matches_the_metric_and_its_changes_sum_to_it() {
        let series = [
            (0, 12.5),
            (1, 20.0),
            (2, 20.0),
            (3, 55.0),
            (4, 40.0),
            (5, 90.0),
        ];
        let mut p = Progress::start(series[0].1);
        let mut sum = 0.0;
        for &(t, pc) in &series[1..] {
            sum += p.advance(t, pc, RewardKind::TwcChange);
            let so_far = time_weighted_completion(&series[..=t as usize]).unwrap();
            assert_eq!(p.twc(), so_far, "bit-identical at step {t}");
        }
        assert!((sum - p.twc()).abs() < 1e-12);
    }

    #[test]
    fn env_reward_pc_and_pc_change_are_fractions() {
        let mut p = Progress::start(10.0);
        assert_eq!(p.twc(), 0.0);
        assert_eq!(p.advance(1, 30.0, RewardKind::Pc), 0.3);
        assert!((p.advance(2, 25.0, RewardKind::PcChange) + 0.05).abs() < 1e-12);
        assert_eq!(p.pc(), 25.0);
    }
}
