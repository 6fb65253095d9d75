//! The sorting swarm as a multi-agent environment (one agent per robot), the
//! core of the Python package's PettingZoo `ParallelEnv`.
//!
//! [`SortEnv`] is sans-IO and deterministic: it owns a [`World`], takes every
//! agent's command at once ([`SortEnv::step`], or indices into
//! [`DISCRETE_ACTIONS`] with [`SortEnv::step_discrete`]), and writes every
//! agent's observation into caller-owned buffers ([`SortEnv::observe`]), so
//! the bindings can hand in NumPy arrays and nothing is allocated per step
//! for them. An episode is fixed by its seed: `reset(seed)` twice gives the
//! same episode bit for bit, whatever the thread count.
//!
//! Choices, and why:
//!
//! - **An agent sees what the paper's robot sees**: its camera footprint as a
//!   grid (see [`observation`](ObsLayout) for the channels), what its gripper
//!   holds, and its pose from the overhead tracker, which CACHECONS reads to
//!   remember cache points. Nothing global, so a learned policy is comparable
//!   to the built-in methods.
//! - **The reward is the team's**, one number shared by every agent, because
//!   the paper's metrics (PC, TWC) are properties of the whole arena; see
//!   [`RewardKind`].
//! - **The built-in methods are available as reference policies**
//!   ([`SortEnv::reference_commands`]), with the controllers and random
//!   streams colony-lab's `sort::experiment::run_trial` uses, so that driving
//!   the environment with them reproduces a trial exactly (tested): learned
//!   and built-in policies are measured on the same world.
//! - **Commands are clamped by proto's rule** (`WheelCommand::clamped`: NaN
//!   is 0, ±∞ is ±1), the rule `World::step` already applies, so a bad number
//!   never poisons the world and there is one clamp rule in colony.
//! - **Bad input is an error, never a panic**: wrong buffer lengths, an
//!   action index past the table, a configuration out of range.
//! - Stepping after an episode ended is allowed (the world goes on and the
//!   flags stay set); the bindings decide whether to reset.
//!
//! ```
//! use colony_sim::WheelCommand;
//! use colony_env::sort::{EnvConfig, SortEnv};
//! use colony_sort::Method;
//! let config = EnvConfig { max_steps: 3, ..EnvConfig::default() }.with_counts(Some(2), Some(10), Some(1));
//! let mut env = SortEnv::new(config, 7).unwrap();
//! let l = env.layout();
//! let (mut map, mut grip, mut pose) = (vec![0.0; l.map_total()], vec![0.0; l.gripper_total()], vec![0.0; l.pose_total()]);
//! let mut commands = Vec::new();
//! loop {
//!     env.observe(&mut map, &mut grip, &mut pose).unwrap();
//!     env.reference_commands(Method::CacheCons, &mut commands);
//!     let info = env.step(&commands).unwrap();
//!     if info.terminated || info.truncated {
//!         assert_eq!(info.step, 3);
//!         break;
//!     }
//! }
//! ```

mod action;
mod config;
mod observation;
mod render;
mod reward;

use std::collections::HashMap;
use std::sync::{Mutex, PoisonError};

use colony_sim::{Observation, RobotId, SimError, WheelCommand, World};
use colony_sort::methods::{build, Method};
use colony_sort::params::ParamsError;
use colony_sort::swarm::{robot_rng, ROBOTS_PER_TASK};
use colony_sort::{metrics, Controller};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

pub use action::{discrete_command, DISCRETE_ACTIONS};
pub use config::{
    check_counts, check_robots, ActionKind, EnvConfig, RewardKind, MAX_GRID, MAX_PUCKS, MAX_ROBOTS,
};
pub use observation::ObsLayout;
pub use render::MAX_RENDER_SIDE;

use observation::Encoder;
use reward::Progress;

/// Why an environment could not be made or could not take an input.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The scene is invalid or its world could not be laid out.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The sorting parameters are invalid or could not be read.
    #[error(transparent)]
    Params(#[from] ParamsError),
    /// A value of the environment's own configuration is out of range.
    #[error("{0}")]
    Config(String),
    /// A buffer or slice of the wrong length.
    #[error("{what}: expected {expected} values, got {got}")]
    Length {
        /// Which input.
        what: &'static str,
        /// The length wanted.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// A discrete action past the table.
    #[error("agent {agent}: action {action} is not one of the {n} discrete actions", n = DISCRETE_ACTIONS.len())]
    Action {
        /// The agent's index.
        agent: usize,
        /// The index it was given.
        action: u32,
    },
    /// The state cannot be written as live-mode packets.
    #[error(transparent)]
    Live(#[from] colony_sort::live::LiveError),
}

/// What one step did, for every agent alike.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepInfo {
    /// The team reward (see [`RewardKind`]).
    pub reward: f64,
    /// Percentage completion (eq. 6) after the step, 0 to 100.
    pub pc: f64,
    /// PC reached the configured target.
    pub terminated: bool,
    /// The episode ran its `max_steps`.
    pub truncated: bool,
    /// Steps since the reset.
    pub step: u64,
}

/// One agent's index and its map, gripper and pose slices, as the zipped chunks give them.
type AgentSlices<'a> = (usize, ((&'a mut [f32], &'a mut [f32]), &'a mut [f32]));

/// One method's controllers and random streams, as `run_trial` makes them.
struct Reference {
    controllers: Vec<Box<dyn Controller>>,
    rngs: Vec<ChaCha8Rng>,
}

/// The sorting swarm as an environment: one agent per robot.
pub struct SortEnv {
    config: EnvConfig,
    seed: u64,
    world: World,
    encoder: Encoder,
    progress: Progress,
    /// The built-in methods' controllers, made on first use in an episode.
    /// Controllers are `Send` but not `Sync`; the mutex (reached through
    /// `get_mut` when stepping, locked only to read the states) makes the environment `Sync`, so a
    /// batch of environments can be observed from rayon's threads by reference.
    reference: Mutex<HashMap<Method, Reference>>,
    /// The commands of the last step, reused.
    commands: Vec<WheelCommand>,
}

impl std::fmt::Debug for SortEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SortEnv")
            .field("seed", &self.seed)
            .field("agents", &self.agents())
            .field("step", &self.world.step_count())
            .field("pc", &self.progress.pc())
            .finish_non_exhaustive()
    }
}

impl SortEnv {
    /// An environment at the start of episode `seed` (the layout `run_trial`
    /// with this seed starts from).
    pub fn new(config: EnvConfig, seed: u64) -> Result<SortEnv, EnvError> {
        config.validate()?;
        let world = World::new(&config.scene, seed)?;
        let encoder = Encoder::new(&world, config.grid);
        let pc = percentage_completion(&world, &config);
        let n = world.robot_count();
        Ok(SortEnv {
            config,
            seed,
            world,
            encoder,
            progress: Progress::start(pc),
            reference: Mutex::default(),
            commands: Vec::with_capacity(n),
        })
    }

    /// Starts episode `seed` again from its first step: a new layout and fresh
    /// reference controllers. The same seed gives the same episode bit for bit.
    pub fn reset(&mut self, seed: u64) -> Result<(), EnvError> {
        self.world = World::new(&self.config.scene, seed)?;
        self.seed = seed;
        self.progress = Progress::start(percentage_completion(&self.world, &self.config));
        self.references().clear();
        Ok(())
    }

    /// The configuration.
    pub fn config(&self) -> &EnvConfig {
        &self.config
    }

    /// The seed of the current episode.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The number of agents (robots).
    pub fn agents(&self) -> usize {
        self.world.robot_count()
    }

    /// The observation's sizes.
    pub fn layout(&self) -> ObsLayout {
        self.encoder.layout()
    }

    /// Writes every agent's observation, agent-major: `map` takes C·G·G
    /// values per agent, `gripper` K+1, `pose` 4 (see [`ObsLayout`]). Buffers
    /// of the wrong length are refused and left alone. Many agents are
    /// observed on rayon's threads; the values do not depend on how many.
    pub fn observe(
        &self,
        map: &mut [f32],
        gripper: &mut [f32],
        pose: &mut [f32],
    ) -> Result<(), EnvError> {
        let l = self.layout();
        check("map", l.map_total(), map.len())?;
        check("gripper", l.gripper_total(), gripper.len())?;
        check("pose", l.pose_total(), pose.len())?;
        let (world, encoder) = (&self.world, &self.encoder);
        let one = |seen: &mut Observation, (i, ((m, g), p)): AgentSlices<'_>| {
            world.observe_into(RobotId(i), seen);
            encoder.write(seen, m, g, p);
        };
        if l.agents > ROBOTS_PER_TASK {
            map.par_chunks_mut(l.map_len())
                .zip(gripper.par_chunks_mut(l.gripper))
                .zip(pose.par_chunks_mut(l.pose))
                .enumerate()
                .with_min_len(ROBOTS_PER_TASK)
                .for_each_init(Observation::default, one);
        } else {
            let mut seen = Observation::default();
            map.chunks_mut(l.map_len())
                .zip(gripper.chunks_mut(l.gripper))
                .zip(pose.chunks_mut(l.pose))
                .enumerate()
                .for_each(|item| one(&mut seen, item));
        }
        Ok(())
    }

    /// Drives robot `i` with `commands[i]` (clamped, see the module's notes)
    /// for one control step; one command per agent, or an error and no step.
    pub fn step(&mut self, commands: &[WheelCommand]) -> Result<StepInfo, EnvError> {
        check("commands", self.agents(), commands.len())?;
        let mut applied = std::mem::take(&mut self.commands);
        applied.clear();
        applied.extend(commands.iter().map(|c| action::clamp(*c)));
        let info = self.advance(&applied);
        self.commands = applied;
        Ok(info)
    }

    /// As [`step`](SortEnv::step), each agent's command an index into
    /// [`DISCRETE_ACTIONS`]; an index past it is an error and no step.
    pub fn step_discrete(&mut self, actions: &[u32]) -> Result<StepInfo, EnvError> {
        check("actions", self.agents(), actions.len())?;
        let mut applied = std::mem::take(&mut self.commands);
        applied.clear();
        for (agent, &action) in actions.iter().enumerate() {
            match discrete_command(action) {
                Some(c) => applied.push(c),
                None => {
                    self.commands = applied;
                    return Err(EnvError::Action { agent, action });
                }
            }
        }
        let info = self.advance(&applied);
        self.commands = applied;
        Ok(info)
    }

    /// The commands the last step drove the robots with, after clamping.
    pub fn last_commands(&self) -> &[WheelCommand] {
        &self.commands
    }

    fn advance(&mut self, commands: &[WheelCommand]) -> StepInfo {
        self.world.step(commands);
        let step = self.world.step_count();
        let pc = percentage_completion(&self.world, &self.config);
        let reward = self.progress.advance(step, pc, self.config.reward);
        StepInfo {
            reward,
            pc,
            terminated: self.config.pc_target.is_some_and(|t| pc >= t),
            truncated: step >= self.config.max_steps,
            step,
        }
    }

    /// The built-in `method`'s command for every robot in this state, into
    /// `out` (replaced). Its controllers and random streams are those
    /// `run_trial` makes for this seed, created on the first call of an
    /// episode: called once before every step from the reset on, and the
    /// commands passed to [`step`](SortEnv::step), the episode is exactly
    /// `run_trial`'s with the same seed, scene and parameters. Each call
    /// advances the controllers (they keep state and draw random numbers),
    /// so call it once a step per method. BHD clusters without regard to
    /// kind: `colony sort run` refuses it with several kinds, this does not.
    pub fn reference_commands(&mut self, method: Method, out: &mut Vec<WheelCommand>) {
        let n = self.world.robot_count();
        let (seed, scene, params) = (self.seed, &self.config.scene, &self.config.params);
        let references = self
            .reference
            .get_mut()
            .unwrap_or_else(PoisonError::into_inner);
        let reference = references.entry(method).or_insert_with(|| Reference {
            controllers: (0..n)
                .map(|_| build(method, params, scene.pucks.kinds, scene.arena.width))
                .collect(),
            rngs: (0..n).map(|i| robot_rng(seed, i)).collect(),
        });
        // As run_trial decides: each robot from the same state with its own stream.
        let seen = &self.world;
        let decide = |(i, (c, rng)): (usize, (&mut Box<dyn Controller>, &mut ChaCha8Rng))| {
            c.step(&seen.observe(RobotId(i)), rng)
        };
        if n > ROBOTS_PER_TASK {
            reference
                .controllers
                .par_iter_mut()
                .zip(reference.rngs.par_iter_mut())
                .enumerate()
                .with_min_len(ROBOTS_PER_TASK)
                .map(decide)
                .collect_into_vec(out);
        } else {
            out.clear();
            out.extend(
                reference
                    .controllers
                    .iter_mut()
                    .zip(&mut reference.rngs)
                    .enumerate()
                    .map(decide),
            );
        }
    }

    /// The finite state machine state of each robot's reference controller for
    /// `method`, if it has been used this episode (for display).
    pub fn reference_states(&self, method: Method) -> Option<Vec<&'static str>> {
        self.reference
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .get(&method)
            .map(|r| r.controllers.iter().map(|c| c.state()).collect())
    }

    fn references(&mut self) -> &mut HashMap<Method, Reference> {
        // A panic while deciding leaves the controllers as they were; nothing to repair.
        self.reference
            .get_mut()
            .unwrap_or_else(PoisonError::into_inner)
    }

    /// Percentage completion (eq. 6) now, 0 to 100.
    pub fn pc(&self) -> f64 {
        self.progress.pc()
    }

    /// TWC (eq. 7) of PC sampled at every step of this episode, 0 before the
    /// first step; bit-identical to `run_trial`'s with `sample_every = 1`.
    pub fn twc_so_far(&self) -> f64 {
        self.progress.twc()
    }

    /// Steps since the reset.
    pub fn steps(&self) -> u64 {
        self.world.step_count()
    }

    /// The world, to read anything the observations leave out.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// A picture of the arena, `width` × `height` RGB8 pixels, row-major, top
    /// row first: the floor, pucks coloured by kind as in colony's figures,
    /// robots with a nose line for the heading (in the carried puck's colour
    /// while they carry one). A side over [`MAX_RENDER_SIDE`] is refused; a
    /// side of 0 gives no pixels.
    pub fn render_rgb(&self, width: usize, height: usize) -> Result<Vec<u8>, EnvError> {
        render::render(&self.world, width, height)
    }

    /// This state as live mode's `vision` packets (the same encoder
    /// `colony sort live`'s world uses), so a hub and colony's monitor can
    /// show an environment's run as it goes.
    pub fn vision_packets(&self) -> Result<Vec<Vec<u8>>, EnvError> {
        let frame = colony_sort::live::vision_frame(&self.world)?;
        Ok(colony_proto::swarm::vision::encode(&frame)
            .map_err(colony_sort::live::LiveError::from)?)
    }

    /// This state's PC as live mode's `metrics` packet, for the monitor's
    /// completion plot.
    pub fn metrics_packet(&self) -> Result<Vec<u8>, EnvError> {
        let progress = colony_proto::swarm::Progress {
            step: self.world.step_count(),
            pc: self.progress.pc(),
        };
        Ok(colony_proto::swarm::metrics::encode(progress)
            .map_err(colony_sort::live::LiveError::from)?)
    }
}

fn percentage_completion(world: &World, config: &EnvConfig) -> f64 {
    metrics::percentage_completion(
        &world.pucks(),
        config.params.perception.cluster_threshold_cm,
    )
}

fn check(what: &'static str, expected: usize, got: usize) -> Result<(), EnvError> {
    if expected == got {
        Ok(())
    } else {
        Err(EnvError::Length {
            what,
            expected,
            got,
        })
    }
}

#[cfg(test)]
mod tests;
