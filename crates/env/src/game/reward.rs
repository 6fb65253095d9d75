//! Rewards: see [`RewardWeights`].

use super::{GameEnv, RobotTally, StepInfo};

/// What each part of the reward weighs.
///
/// Rewards: differences, step to step, of what the referee counts, so a reward can never
/// disagree with the rules. Each agent's reward for a step is
///
/// ```text
///   score    × (Δ learner's score − Δ opponent's score)       every agent, alive or not
/// + outcome  × (+1 learner won, −1 opponent won, 0 draw)       every agent, on the last step
/// + dealt    × Δ health its shots took from enemies
/// − taken    × Δ health it lost to shots
/// − destroyed                                                   on the step it is destroyed
/// + flag     × Δ enemy flags it picked up
/// − refused  × Δ its shots and pick-ups the referee refused
/// ```
///
/// The score is captures in Capture the Flag and kills in Death Match (the referee's). A
/// capture wins a default Capture the Flag game, so it pays `score + outcome`. A truncated
/// episode has no outcome.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RewardWeights {
    /// Per point of the team's score, less per point of the opponent's.
    pub score: f64,
    /// For winning (lost: its negative) when the game ends.
    pub outcome: f64,
    /// Per point of health the agent's shots took.
    pub damage_dealt: f64,
    /// Per point of health the agent lost (subtracted).
    pub damage_taken: f64,
    /// For being destroyed (subtracted).
    pub destroyed: f64,
    /// Per enemy flag the agent picked up.
    pub flag_taken: f64,
    /// Per shot or pick-up of the agent's the referee refused (subtracted).
    pub refused: f64,
}

/// Score and outcome 1, damage 0.01 a point (a plain tank's shot: 0.15), destroyed 0.5, a flag
/// picked up 0.25, refusals free.
impl Default for RewardWeights {
    fn default() -> RewardWeights {
        RewardWeights {
            score: 1.0,
            outcome: 1.0,
            damage_dealt: 0.01,
            damage_taken: 0.01,
            destroyed: 0.5,
            flag_taken: 0.25,
            refused: 0.0,
        }
    }
}

impl GameEnv {
    /// Each agent's reward for the step just taken; `before` is every robot's tally and life
    /// before it, `scores` the teams' scores.
    pub(super) fn rewards(
        &self,
        before: &[(RobotTally, bool)],
        scores: [u32; 2],
        info: &StepInfo,
    ) -> Vec<f64> {
        let w = &self.config.rewards;
        let delta = |t: usize| f64::from(self.scores[t]) - f64::from(scores[t]);
        let mut team = w.score * (delta(0) - delta(1));
        if info.terminated {
            team += match info.winner.as_deref() {
                Some(t) if t == self.teams[0] => w.outcome,
                Some(_) => -w.outcome,
                None => 0.0,
            };
        }
        self.agents
            .iter()
            .map(|a| {
                let id = a.robot as usize;
                let (old, was_alive) = before[id];
                let now = &self.seen[id];
                let t = now.tally;
                let mut r = team;
                r += w.damage_dealt * (t.damage_dealt - old.damage_dealt);
                r -= w.damage_taken * (t.damage_taken - old.damage_taken);
                if was_alive && !now.alive {
                    r -= w.destroyed;
                }
                r += w.flag_taken * f64::from(t.flags_taken - old.flags_taken);
                r -= w.refused * f64::from(t.refused - old.refused);
                r
            })
            .collect()
    }
}
