//! `colony sort supplementary`: the experiments of the paper's Sect. 4.1, 4.3 and 4.4
//! beyond the main comparisons. Each [`Experiment`] is a list of [`Condition`]s (a
//! scene, parameters, disturbances) run under a few methods; [`report`] turns the
//! results into a section per experiment that states the paper's finding, ours, and
//! whether they agree.
//!
//! Trial `t` of every condition uses seed `seed + t`, so methods under one condition
//! start from the same layouts and are compared pairwise. A condition that two
//! experiments share (the standard configuration is a level of several) runs once.

pub mod report;

use std::collections::HashMap;
use std::fmt;
use std::str::FromStr;

use colony_sim::SceneConfig;
use colony_sort::methods::Method;
use colony_sort::params::SortParams;

use crate::sort::experiment::{Disturbance, TrialSpec};

/// One supplementary experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Experiment {
    /// Sect. 4.1: PROBSEEK's deposit constant k2 in {1, 2, 4, 8, 16}.
    K2,
    /// Sect. 4.3: the physical robots' trials (3 of 5,000 steps, commands held 75 ms).
    Physical,
    /// Sect. 4.4: the number of pucks varied.
    Pucks,
    /// Sect. 4.4: the arena's size varied.
    Arena,
    /// Sect. 4.4: the number of robots varied.
    Robots,
    /// Sect. 4.4: established clusters shifted by an outside agent.
    Shift,
    /// Sect. 4.4: every puck re-inserted at a random place.
    Reinsert,
}

impl Experiment {
    /// Every experiment, in the report's order.
    pub const ALL: [Experiment; 7] = [
        Experiment::K2,
        Experiment::Physical,
        Experiment::Pucks,
        Experiment::Arena,
        Experiment::Robots,
        Experiment::Shift,
        Experiment::Reinsert,
    ];

    /// The name on the command line and in file names.
    pub fn name(self) -> &'static str {
        match self {
            Experiment::K2 => "k2",
            Experiment::Physical => "physical",
            Experiment::Pucks => "pucks",
            Experiment::Arena => "arena",
            Experiment::Robots => "robots",
            Experiment::Shift => "shift",
            Experiment::Reinsert => "reinsert",
        }
    }

    /// The methods compared.
    pub fn methods(self) -> Vec<Method> {
        match self {
            Experiment::K2 => vec![Method::ProbSeek],
            Experiment::Physical | Experiment::Pucks | Experiment::Arena | Experiment::Robots => {
                vec![Method::ProbSeek, Method::CacheCons]
            }
            Experiment::Shift | Experiment::Reinsert => {
                vec![Method::ProbSeek, Method::CacheCons, Method::CacheConsErase]
            }
        }
    }
}

impl fmt::Display for Experiment {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An experiment name that is not one of [`Experiment::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown experiment `{0}`; valid: k2, physical, pucks, arena, robots, shift, reinsert")]
pub struct UnknownExperiment(String);

impl FromStr for Experiment {
    type Err = UnknownExperiment;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Experiment::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| UnknownExperiment(s.to_owned()))
    }
}

/// How much to run: the paper's blocks are 20 trials of 100,000 steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Scale {
    /// Trials per method and condition.
    pub trials: u64,
    /// Control steps per trial.
    pub steps: u64,
    /// Trial `t` uses seed `seed + t`.
    pub seed: u64,
}

/// Steps between samples of the metrics (the authors saved positions every 100 steps).
pub const SAMPLE_EVERY: u64 = 100;

/// The physical robots' trials (Sect. 4.3).
pub const PHYSICAL_TRIALS: u64 = 3;
/// Steps of a physical trial (Sect. 4.3).
pub const PHYSICAL_STEPS: u64 = 5_000;
/// How long the physical robots held each command, s (Sect. 3.1).
pub const PHYSICAL_COMMAND_S: f64 = 0.075;

/// Puck counts of the puck experiment (the standard configuration has 40).
pub const PUCK_COUNTS: [usize; 4] = [20, 40, 80, 120];
/// Arena scale factors (side lengths times this; the standard is 1).
pub const ARENA_SCALES: [f64; 3] = [1.0, 1.5, 2.0];
/// Robot counts (the standard configuration has 4).
pub const ROBOT_COUNTS: [usize; 5] = [1, 2, 4, 8, 16];
/// The k2 values of Sect. 4.1.
pub const K2_VALUES: [f64; 5] = [1.0, 2.0, 4.0, 8.0, 16.0];

/// One setting an experiment runs its methods under.
#[derive(Debug, Clone)]
pub struct Condition {
    /// The varied quantity's value (x of the experiment's plots).
    pub level: f64,
    /// How the level reads in tables and file names (`80 pucks`).
    pub label: String,
    /// The scene.
    pub scene: SceneConfig,
    /// The controllers' parameters.
    pub params: SortParams,
    /// Disturbances, each at a step.
    pub disturbances: Vec<(u64, Disturbance)>,
    /// Trials per method.
    pub trials: u64,
    /// Steps per trial.
    pub steps: u64,
}

impl Condition {
    fn standard(scene: &SceneConfig, params: &SortParams, scale: Scale, level: f64) -> Condition {
        Condition {
            level,
            label: String::new(),
            scene: scene.clone(),
            params: params.clone(),
            disturbances: Vec::new(),
            trials: scale.trials,
            steps: scale.steps,
        }
    }

    /// A name for the condition's directory of CSV files.
    pub fn slug(&self) -> String {
        self.label
            .replace(|c: char| !c.is_ascii_alphanumeric(), "_")
    }
}

/// The steps at which the disturbance experiments act: a quarter, half and three
/// quarters of the way through, so each has a quarter of the trial to recover in;
/// rounded down to a sampled step, so the first sample after each is taken right after it.
pub fn disturbance_steps(steps: u64) -> Vec<u64> {
    let mut at: Vec<u64> = (1..=3)
        .map(|k| steps * k / 4 / SAMPLE_EVERY * SAMPLE_EVERY)
        .filter(|&s| s > 0)
        .collect();
    at.dedup();
    at
}

/// The conditions of `experiment`, built on the standard `scene` and `params`.
pub fn conditions(
    experiment: Experiment,
    scene: &SceneConfig,
    params: &SortParams,
    scale: Scale,
) -> Vec<Condition> {
    let base = |level| Condition::standard(scene, params, scale, level);
    match experiment {
        Experiment::K2 => K2_VALUES
            .iter()
            .map(|&k2| {
                let mut c = base(k2);
                c.params.deneubourg.k2 = k2;
                c.label = format!("k2 = {k2}");
                c
            })
            .collect(),
        Experiment::Physical => {
            let mut c = base(1.0);
            c.scene.robots.command_duration = Some(PHYSICAL_COMMAND_S);
            c.trials = scale.trials.min(PHYSICAL_TRIALS);
            c.steps = scale.steps.min(PHYSICAL_STEPS);
            c.label = "commands held 75 ms".into();
            vec![c]
        }
        Experiment::Pucks => PUCK_COUNTS
            .iter()
            .map(|&n| {
                let mut c = base(n as f64);
                c.scene.pucks.count = n;
                c.label = format!("{n} pucks");
                c
            })
            .collect(),
        Experiment::Arena => ARENA_SCALES
            .iter()
            .map(|&k| {
                let mut c = base(k);
                c.scene.arena.width *= k;
                c.scene.arena.height *= k;
                c.label = format!("scale {k}");
                c
            })
            .collect(),
        Experiment::Robots => ROBOT_COUNTS
            .iter()
            .map(|&n| {
                let mut c = base(n as f64);
                c.scene.robots.count = n;
                c.label = format!("{n} robots");
                c
            })
            .collect(),
        Experiment::Shift | Experiment::Reinsert => {
            let what = if experiment == Experiment::Shift {
                Disturbance::ShiftLargestCluster
            } else {
                Disturbance::ReinsertPucks
            };
            // The same trials undisturbed are the control each disturbed trial is
            // compared with.
            let mut calm = base(0.0);
            calm.label = "undisturbed".into();
            let mut c = base(1.0);
            c.disturbances = disturbance_steps(scale.steps)
                .into_iter()
                .map(|at| (at, what))
                .collect();
            c.label = format!("{experiment} at {:?}", disturbance_steps(scale.steps));
            vec![calm, c]
        }
    }
}

/// The trial of `method` number `t` under `condition`.
pub fn spec(condition: &Condition, method: Method, t: u64, seed: u64) -> TrialSpec {
    TrialSpec {
        method,
        scene: condition.scene.clone(),
        params: condition.params.clone(),
        steps: condition.steps,
        seed: seed + t,
        sample_every: SAMPLE_EVERY.min(condition.steps.max(1)),
        snapshot_at: Vec::new(),
        disturbances: condition.disturbances.clone(),
    }
}

/// Every trial of `experiments`, each distinct trial once, and for each experiment,
/// condition and method the indices of its trials in that list (in trial order).
pub struct Plan {
    /// The trials to run.
    pub specs: Vec<TrialSpec>,
    /// Per experiment: its conditions and, per condition and method, indices into `specs`.
    pub experiments: Vec<PlannedExperiment>,
}

/// One experiment of a [`Plan`].
pub struct PlannedExperiment {
    /// Which.
    pub experiment: Experiment,
    /// Its conditions.
    pub conditions: Vec<Condition>,
    /// `trials[c][m]`: indices into [`Plan::specs`] of condition `c`, method `m` of
    /// [`Experiment::methods`].
    pub trials: Vec<Vec<Vec<usize>>>,
}

/// Plans `experiments` at `scale`.
pub fn plan(
    experiments: &[Experiment],
    scene: &SceneConfig,
    params: &SortParams,
    scale: Scale,
) -> Plan {
    let mut specs: Vec<TrialSpec> = Vec::new();
    // A trial is known by its whole description: equal descriptions run once.
    let mut known: HashMap<String, usize> = HashMap::new();
    let mut planned = Vec::new();
    for &experiment in experiments {
        let conditions = conditions(experiment, scene, params, scale);
        let trials = conditions
            .iter()
            .map(|c| {
                experiment
                    .methods()
                    .into_iter()
                    .map(|m| {
                        (0..c.trials)
                            .map(|t| {
                                let s = spec(c, m, t, scale.seed);
                                *known.entry(format!("{s:?}")).or_insert_with(|| {
                                    specs.push(s);
                                    specs.len() - 1
                                })
                            })
                            .collect()
                    })
                    .collect()
            })
            .collect();
        planned.push(PlannedExperiment {
            experiment,
            conditions,
            trials,
        });
    }
    Plan {
        specs,
        experiments: planned,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for e in Experiment::ALL {
            assert_eq!(e.name().parse::<Experiment>(), Ok(e));
        }
        let err = "pucs".parse::<Experiment>().unwrap_err().to_string();
        assert!(err.contains("pucks"), "{err}");
    }

    #[test]
    fn shared_conditions_run_once() {
        let scale = Scale {
            trials: 2,
            steps: 400,
            seed: 1,
        };
        let scene = SceneConfig::default();
        let params = SortParams::default();
        let all = plan(
            &[Experiment::Pucks, Experiment::Robots],
            &scene,
            &params,
            scale,
        );
        // 4 puck counts and 5 robot counts, 2 methods, 2 trials; 40 pucks with 4 robots
        // is the standard configuration in both.
        assert_eq!(all.specs.len(), (4 + 5 - 1) * 2 * 2);
        let pucks = &all.experiments[0];
        let robots = &all.experiments[1];
        assert_eq!(pucks.trials[1], robots.trials[2]);
        assert_ne!(pucks.trials[0], robots.trials[2]);
        // Methods under one condition share seeds (paired), trials within one differ.
        let seeds = |ix: &[usize]| ix.iter().map(|&i| all.specs[i].seed).collect::<Vec<_>>();
        assert_eq!(seeds(&pucks.trials[0][0]), seeds(&pucks.trials[0][1]));
        assert_eq!(seeds(&pucks.trials[0][0]), vec![1, 2]);
    }

    #[test]
    fn the_physical_trials_hold_commands_75_ms_and_run_at_most_the_papers_length() {
        let scale = Scale {
            trials: 20,
            steps: 100_000,
            seed: 1,
        };
        let c = &conditions(
            Experiment::Physical,
            &SceneConfig::default(),
            &SortParams::default(),
            scale,
        )[0];
        assert_eq!((c.trials, c.steps), (3, 5_000));
        assert_eq!(c.scene.robots.command_duration, Some(0.075));
        assert!(c.scene.validate().is_ok());
    }

    #[test]
    fn disturbances_leave_a_quarter_of_the_trial_after_each() {
        assert_eq!(disturbance_steps(100_000), vec![25_000, 50_000, 75_000]);
        assert_eq!(disturbance_steps(1_000), vec![200, 500, 700]);
        assert_eq!(disturbance_steps(150), vec![100]);
        assert!(disturbance_steps(99).is_empty());
        assert!(disturbance_steps(0).is_empty());
    }

    #[test]
    fn every_condition_is_a_valid_scene() {
        let scale = Scale {
            trials: 1,
            steps: 100,
            seed: 1,
        };
        for e in Experiment::ALL {
            for c in conditions(e, &SceneConfig::default(), &SortParams::default(), scale) {
                c.scene
                    .validate()
                    .unwrap_or_else(|err| panic!("{e} {}: {err}", c.label));
            }
        }
    }
}
