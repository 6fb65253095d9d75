//! What an environment is made from: the scene and parameters `colony sort run`
//! reads, plus the episode's length, its end condition, its reward and the
//! observation grid's size.

use std::path::Path;

use colony_sim::{Engine, SceneConfig};
use colony_sort::params::SortParams;

use super::EnvError;

/// The most robots an environment accepts: 100,000, a swarm the simulator's
/// largest arena (500 m a side) holds at the paper's densities, and few enough
/// that a typo (a robot count of 10^12) is refused before the layout reserves
/// memory for it.
pub const MAX_ROBOTS: usize = 100_000;

/// The most pucks an environment accepts: more than the 10 per robot that
/// `--scale-robots` gives [`MAX_ROBOTS`] robots (1,000,000).
pub const MAX_PUCKS: usize = 1 << 20;

const _: () = assert!(
    MAX_PUCKS >= 10 * MAX_ROBOTS,
    "--scale-robots needs 10 pucks a robot"
);

/// Checks a robot count against [`MAX_ROBOTS`]; for a count a scene is about to be
/// scaled to (`--scale-robots`), this must come first, as scaling multiplies it.
pub fn check_robots(robots: usize) -> Result<(), EnvError> {
    if robots > MAX_ROBOTS {
        return Err(EnvError::Config(format!(
            "{robots} robots is more than the {MAX_ROBOTS} a sorting world takes"
        )));
    }
    Ok(())
}

/// Checks a scene's robot and puck counts against [`MAX_ROBOTS`] and
/// [`MAX_PUCKS`]: every command that builds worlds from a scene calls this
/// before the layout reserves memory for them.
pub fn check_counts(scene: &SceneConfig) -> Result<(), EnvError> {
    check_robots(scene.robots.count)?;
    if scene.pucks.count > MAX_PUCKS {
        return Err(EnvError::Config(format!(
            "{} pucks is more than the {MAX_PUCKS} a sorting world takes",
            scene.pucks.count
        )));
    }
    Ok(())
}

/// The widest observation grid, cells per side: 256 cells over a footprint
/// about 60 cm wide is a quarter of a centimetre, finer than anything sensed.
pub const MAX_GRID: usize = 256;

/// The team reward every agent shares, as a fraction (PC / 100), so that
/// every kind lies on the same scale as TWC.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum RewardKind {
    /// PC / 100 after the step: the level of sorting, paid every step.
    Pc,
    /// (PC after the step − PC before it) / 100: over an episode it sums to the
    /// change of PC from the start.
    PcChange,
    /// This step's increment of the time-weighted completion (eq. 7) of the
    /// PC series sampled every step: `TWC(t) − TWC(t−1)`, with `TWC(0) = 0`.
    /// Over an episode of T steps it sums to `metrics::time_weighted_completion`
    /// of `(0, PC0), (1, PC1), …, (T, PCT)`: `run_trial`'s TWC with
    /// `sample_every = 1` (the CLI samples every 100 steps, a coarser reading
    /// of the same curve). It is positive when PC beats the completion so far.
    #[default]
    TwcChange,
}

/// Which action space the bindings expose. Both [`SortEnv::step`](super::SortEnv::step)
/// and [`SortEnv::step_discrete`](super::SortEnv::step_discrete) work whatever this says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ActionKind {
    /// Two numbers per agent, forward and turn, each in [-1, 1].
    #[default]
    Continuous,
    /// One index per agent into [`DISCRETE_ACTIONS`](super::DISCRETE_ACTIONS).
    Discrete,
}

/// Everything an environment is made from but its seed.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvConfig {
    /// The arena, robots and pucks (`--scene`, configs/scene.toml's format).
    pub scene: SceneConfig,
    /// The controllers' and the metrics' parameters (`--params`, configs/sort.toml's
    /// format); the cluster threshold of PC and the reference controllers read it.
    pub params: SortParams,
    /// Steps after which an episode is truncated (at least 1).
    pub max_steps: u64,
    /// An episode terminates once PC (percent) reaches this; `None` never.
    pub pc_target: Option<f64>,
    /// The team reward.
    pub reward: RewardKind,
    /// Observation grid cells per side (1 to [`MAX_GRID`]).
    pub grid: usize,
    /// The action space the bindings expose.
    pub action: ActionKind,
}

impl Default for EnvConfig {
    /// The paper's standard configuration (what `colony sort run` uses without
    /// files), 10,000 steps, no PC target, the TWC reward, a 16-cell grid.
    fn default() -> EnvConfig {
        EnvConfig {
            scene: SceneConfig::default(),
            params: SortParams::default(),
            max_steps: 10_000,
            pc_target: None,
            reward: RewardKind::default(),
            grid: 16,
            action: ActionKind::default(),
        }
    }
}

impl EnvConfig {
    /// The scene and parameters exactly as `colony sort run --scene --params`
    /// reads them (each file optional: without it, the built-in standard
    /// configuration), everything else as [`EnvConfig::default`].
    pub fn from_files(scene: Option<&Path>, params: Option<&Path>) -> Result<EnvConfig, EnvError> {
        let scene = match scene {
            Some(p) => SceneConfig::from_file(p)?,
            None => SceneConfig::default(),
        };
        let params = match params {
            Some(p) => SortParams::load(p)?,
            None => SortParams::default(),
        };
        Ok(EnvConfig {
            scene,
            params,
            ..EnvConfig::default()
        })
    }

    /// Overrides the robot count, the puck count and the puck kinds, as
    /// `colony sort run --robots --pucks --types` do; `None` keeps the scene's.
    /// Checked when the environment is made.
    pub fn with_counts(
        mut self,
        robots: Option<usize>,
        pucks: Option<usize>,
        kinds: Option<usize>,
    ) -> EnvConfig {
        if let Some(r) = robots {
            self.scene.robots.count = r;
        }
        if let Some(p) = pucks {
            self.scene.pucks.count = p;
        }
        if let Some(k) = kinds {
            self.scene.pucks.kinds = k;
        }
        self
    }

    /// The standard scene scaled to `robots` robots (10 pucks each, the arena
    /// grown to keep the paper's densities), keeping this scene's puck kinds:
    /// `--scale-robots`. Checked when the environment is made.
    pub fn with_scaled_robots(mut self, robots: usize) -> EnvConfig {
        let (kinds, engine) = (self.scene.pucks.kinds, self.scene.physics.engine);
        self.scene = SceneConfig::scaled(robots);
        self.scene.pucks.kinds = kinds;
        self.scene.physics.engine = engine;
        self
    }

    /// The contact engine named `name` (`rapier`, `disc`: `--engine`); `None`
    /// keeps the scene's (`physics.engine`). A name no engine has is refused,
    /// and the error lists the engines there are.
    pub fn with_engine(mut self, name: Option<&str>) -> Result<EnvConfig, EnvError> {
        if let Some(name) = name {
            self.scene.physics.engine = name
                .parse::<Engine>()
                .map_err(|e| EnvError::Config(format!("engine: {e}")))?;
        }
        Ok(self)
    }

    /// Checks every value; the error names the first bad one.
    pub fn validate(&self) -> Result<(), EnvError> {
        let bad = |what: String| Err(EnvError::Config(what));
        let s = &self.scene;
        check_counts(s)?;
        s.validate()?;
        self.params.validate("environment parameters")?;
        if self.max_steps == 0 {
            return bad("max_steps must be at least 1".into());
        }
        if let Some(t) = self.pc_target {
            if !(t.is_finite() && (0.0..=100.0).contains(&t)) {
                return bad(format!("pc_target is a percentage from 0 to 100, not {t}"));
            }
        }
        if self.grid == 0 || self.grid > MAX_GRID {
            return bad(format!(
                "grid must be 1 to {MAX_GRID} cells a side, not {}",
                self.grid
            ));
        }
        Ok(())
    }
}
