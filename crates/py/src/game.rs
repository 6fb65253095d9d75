//! `GameCore` (one Capture the Flag or Death Match match) and `GameBatch` (many,
//! stepped on rayon) over `colony_env::game::GameEnv`.

use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard, PoisonError};

use colony_env::game::{
    Control, EnvError, Fire, GameEnv, GameEnvConfig, Opponent, RewardWeights, RobotAction,
    SquadOrder, StepInfo,
};
use colony_game::protocol;
use colony_game::rules::{KindRules, Mode, TeamSetup};
use colony_wire::Packet;
use numpy::{PyArray1, PyArray3, PyArrayMethods, PyReadonlyArrayDyn, PyReadwriteArrayDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

use crate::arrays::{read, write};
use crate::seeds::{autoreset, check_budget, firsts, restart};

fn error(e: EnvError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn invalid(what: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(what.to_string())
}

/// Reads the reward weights a Python dict names; unknown names are an error.
fn weights(dict: &Bound<'_, PyDict>) -> PyResult<RewardWeights> {
    let mut w = RewardWeights::default();
    for (key, value) in dict.iter() {
        let name: String = key.extract()?;
        let v: f64 = value.extract()?;
        if !v.is_finite() {
            return Err(invalid(format!(
                "reward weight {name} must be finite, not {v}"
            )));
        }
        *match name.as_str() {
            "score" => &mut w.score,
            "outcome" => &mut w.outcome,
            "damage_dealt" => &mut w.damage_dealt,
            "damage_taken" => &mut w.damage_taken,
            "destroyed" => &mut w.destroyed,
            "flag_taken" => &mut w.flag_taken,
            "refused" => &mut w.refused,
            other => {
                return Err(invalid(format!(
                    "no reward weight {other:?} (score, outcome, damage_dealt, damage_taken, \
                     destroyed, flag_taken, refused)"
                )))
            }
        } = v;
    }
    Ok(w)
}

/// A game environment's configuration, checked once (see `colony.game.GameEnv` for
/// what each value means); one match or a batch is made from it.
#[pyclass(module = "colony._native", frozen)]
pub struct GameConfig {
    config: GameEnvConfig,
}

#[pymethods]
impl GameConfig {
    #[new]
    #[pyo3(signature = (*, mode="ctf", map=None, learner=None, opponent=None,
        opponent_policy="scripted", control="robot", max_steps=3000, nearby=8, patch=11,
        rewards=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        mode: &str,
        map: Option<PathBuf>,
        learner: Option<&str>,
        opponent: Option<&str>,
        opponent_policy: &str,
        control: &str,
        max_steps: u64,
        nearby: usize,
        patch: usize,
        rewards: Option<Bound<'_, PyDict>>,
    ) -> PyResult<GameConfig> {
        let mode: Mode = mode.parse().map_err(invalid)?;
        let mut config = match &map {
            Some(path) => GameEnvConfig::from_path(mode, path),
            None => GameEnvConfig::shipped(mode),
        }
        .map_err(error)?;
        let team = |text: Option<&str>, default: &TeamSetup| match text {
            Some(t) => TeamSetup::parse(&default.name, t).map_err(invalid),
            None => Ok(default.clone()),
        };
        config.learner = team(learner, &config.learner)?;
        config.opponent = team(opponent, &config.opponent)?;
        config.opponent_policy = match opponent_policy {
            "scripted" => Opponent::Scripted,
            "idle" => Opponent::Idle,
            other => {
                return Err(invalid(format!(
                    "opponent must be scripted or idle, not {other:?}"
                )))
            }
        };
        config.control = match control {
            "robot" => Control::Robot,
            "squad" => Control::Squad,
            other => {
                return Err(invalid(format!(
                    "control must be robot or squad, not {other:?}"
                )))
            }
        };
        if max_steps == 0 {
            return Err(invalid("max_steps must be at least 1"));
        }
        // At least one each: a part of no values is no observation, and a batch cuts
        // its buffers in pieces of each part's size.
        if !(1..=MAX_NEARBY).contains(&nearby) || !(1..=MAX_PATCH).contains(&patch) {
            return Err(invalid(format!(
                "nearby must be 1 to {MAX_NEARBY} and patch 1 to {MAX_PATCH}"
            )));
        }
        config.max_steps = max_steps;
        config.nearby = nearby;
        config.patch = patch;
        if let Some(d) = rewards {
            config.rewards = weights(&d)?;
        }
        Ok(GameConfig { config })
    }
}

/// The most robots `nearby` lists and the widest patch: far past a battlefield's
/// robots and a map's cells, there so a typo cannot ask for gigabytes.
const MAX_NEARBY: usize = 256;
const MAX_PATCH: usize = 255;

fn build(config: &GameConfig, seed: u64) -> PyResult<GameEnv> {
    GameEnv::new(config.config.clone(), seed).map_err(error)
}

/// Each agent's action from the arrays: wheels (forward, turn), a fire code, a pick-up.
fn actions(
    wheels: &[f64],
    fire: &[i64],
    pickup: &[bool],
    nearby: usize,
    out: &mut Vec<RobotAction>,
) {
    out.clear();
    out.extend(
        wheels
            .chunks_exact(2)
            .zip(fire)
            .zip(pickup)
            .map(|((w, &f), &p)| RobotAction {
                forward: w[0],
                turn: w[1],
                fire: Fire::from_code(f, nearby),
                pickup: p,
            }),
    );
}

/// Names for the observation's four parts and their shapes per agent.
fn layout(env: &GameEnv) -> Vec<(&'static str, Vec<usize>)> {
    let l = env.layout();
    vec![
        ("own", vec![l.own]),
        ("nearby", vec![l.nearby, l.nearby_features]),
        ("flags", vec![l.flag_teams, l.flag_features]),
        ("patch", vec![l.patch, l.patch, l.patch_channels]),
    ]
}

/// The shape of a part for `lead` (agents, or worlds and agents) in front.
fn shape(lead: &[usize], part: &[usize]) -> Vec<usize> {
    lead.iter().chain(part).copied().collect()
}

type Step = (
    Vec<f64>,
    bool,
    bool,
    (u32, u32),
    Option<String>,
    u32,
    u32,
    u32,
);

fn step_tuple(info: StepInfo) -> Step {
    (
        info.rewards,
        info.terminated,
        info.truncated,
        (info.score[0], info.score[1]),
        info.winner,
        info.refused,
        info.refused_orders,
        info.invalid,
    )
}

/// A match behind a lock: Python may share an object between threads, so a
/// class must be `Sync`, and the game's behaviours are `Send` only. Every
/// method that changes the match has `&mut self` and reaches it without
/// locking; the lock is taken only to read (observe, render), never contended.
struct Locked(Mutex<GameEnv>);

impl Locked {
    fn get(&mut self) -> &mut GameEnv {
        // A panic inside the game would have been a bug there; the state it left is
        // still the best there is to read.
        self.0.get_mut().unwrap_or_else(PoisonError::into_inner)
    }

    fn read(&self) -> MutexGuard<'_, GameEnv> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// One match (see `colony.game.GameEnv`, which wraps it).
#[pyclass(module = "colony._native")]
pub struct GameCore {
    env: Locked,
    actions: Vec<RobotAction>,
}

#[pymethods]
impl GameCore {
    #[new]
    #[pyo3(signature = (config, seed=0))]
    fn new(config: &GameConfig, seed: u64) -> PyResult<GameCore> {
        Ok(GameCore {
            env: Locked(Mutex::new(build(config, seed)?)),
            actions: Vec::new(),
        })
    }

    fn reset(&mut self, py: Python<'_>, seed: u64) -> PyResult<()> {
        let env = self.env.get();
        py.detach(|| env.reset(seed)).map_err(error)
    }

    /// One (robot id, type, squad) per agent, in the order of every per-agent array.
    #[getter]
    fn agents(&self) -> Vec<(u32, String, String)> {
        self.env
            .read()
            .agents()
            .iter()
            .map(|a| (a.robot, a.kind.to_string(), a.squad.clone()))
            .collect()
    }

    /// The learner's squads, in the order of `step_squads`' orders.
    #[getter]
    fn squads(&self) -> Vec<String> {
        self.env.read().squads().map(str::to_string).collect()
    }

    /// The learner's and the opponent's team names.
    #[getter]
    fn teams(&self) -> (String, String) {
        let env = self.env.read();
        let c = env.config();
        (c.learner.name.clone(), c.opponent.name.clone())
    }

    /// Each observation part's name and shape per agent, in `observe`'s order.
    #[getter]
    fn layout(&self) -> Vec<(&'static str, Vec<usize>)> {
        layout(&self.env.read())
    }

    /// The largest |velocity| / top speed and |turn rate| / top turn rate `own` can
    /// hold. They are measured from the pose one control step apart, so a shove or a
    /// respawn can take a robot past its top speed; but its centre stays on the map,
    /// inside the walls round it, and a heading change is wrapped to at most a half turn,
    /// so the map's diagonal and π per control step, over the slowest of the agents'
    /// types, bound them.
    #[getter]
    fn motion_bounds(&self) -> (f64, f64) {
        let env = self.env.read();
        let (w, h) = env.config().map.size_cm();
        let dt = env.game().world().field().config().control_step;
        let (mut speed, mut turn) = (f64::INFINITY, f64::INFINITY);
        for a in env.agents() {
            let s = a.kind.stats();
            speed = speed.min(s.speed_cm_s);
            turn = turn.min(s.turn_rad_s);
        }
        (
            w.hypot(h) / (dt * speed),
            std::f64::consts::PI / (dt * turn),
        )
    }

    /// Whether each agent's robot still stands.
    fn alive(&self) -> Vec<bool> {
        self.env.read().alive().collect()
    }

    fn observe(
        &self,
        mut own: PyReadwriteArrayDyn<'_, f32>,
        mut nearby: PyReadwriteArrayDyn<'_, f32>,
        mut flags: PyReadwriteArrayDyn<'_, f32>,
        mut patch: PyReadwriteArrayDyn<'_, f32>,
    ) -> PyResult<()> {
        let env = self.env.read();
        let n = env.agents().len();
        let parts = layout(&env);
        let own = write(&mut own, "own", &shape(&[n], &parts[0].1))?;
        let nearby = write(&mut nearby, "nearby", &shape(&[n], &parts[1].1))?;
        let flags = write(&mut flags, "flags", &shape(&[n], &parts[2].1))?;
        let patch = write(&mut patch, "patch", &shape(&[n], &parts[3].1))?;
        env.observe(own, nearby, flags, patch).map_err(error)
    }

    /// Robot-level step: wheels (agents, 2), fire codes (agents,) (0 holds, 1 the
    /// nearest enemy, 2 + k the k-th nearby robot), pick-ups (agents,).
    /// Returns (rewards, terminated, truncated, score, winner, refused,
    /// refused orders, invalid shots).
    fn step(
        &mut self,
        py: Python<'_>,
        wheels: PyReadonlyArrayDyn<'_, f64>,
        fire: PyReadonlyArrayDyn<'_, i64>,
        pickup: PyReadonlyArrayDyn<'_, bool>,
    ) -> PyResult<Step> {
        let env = self.env.get();
        let n = env.agents().len();
        let wheels = read(&wheels, "wheels", &[n, 2])?;
        let fire = read(&fire, "fire", &[n])?;
        let pickup = read(&pickup, "pickup", &[n])?;
        actions(wheels, fire, pickup, env.config().nearby, &mut self.actions);
        let acts = &self.actions;
        let info = py.detach(|| env.step_robots(acts)).map_err(error)?;
        Ok(step_tuple(info))
    }

    /// Squad-level step: one order code per learner squad (see `SQUAD_ORDERS`).
    fn step_squads(&mut self, py: Python<'_>, orders: Vec<i64>) -> PyResult<Step> {
        let orders: Vec<SquadOrder> = orders.into_iter().map(SquadOrder::from_code).collect();
        let env = self.env.get();
        let info = py.detach(|| env.step_squads(&orders)).map_err(error)?;
        Ok(step_tuple(info))
    }

    /// The battlefield as an image, (height, width, 3) uint8.
    fn render<'py>(
        &self,
        py: Python<'py>,
        width: usize,
        height: usize,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        if width > MAX_RENDER_SIDE || height > MAX_RENDER_SIDE {
            return Err(invalid(format!(
                "an image is at most {MAX_RENDER_SIDE} pixels a side"
            )));
        }
        // Drawn holding the lock, with Python's: a few hundred microseconds.
        let rgb = self.env.read().render_rgb(width, height);
        PyArray1::from_vec(py, rgb)
            .reshape([height, width, 3])
            .map_err(invalid)
    }

    /// Keeps every packet the match carries, for `take_packets` (the "human" view).
    fn set_record(&mut self, on: bool) {
        self.env.get().set_record(on);
    }

    /// What the match showed since the last call: its map, states, world frames
    /// and events, the channels colony's monitor draws a match from. Commands (a
    /// player's drives, the server's orders, the robots' senses) stay inside: on a
    /// hub where a live game also runs, they would drive its robots.
    fn take_packets(&mut self) -> Vec<Vec<u8>> {
        let mut packets = self.env.get().take_packets();
        packets.retain(|p| {
            Packet::parse(p).is_ok_and(|p| {
                p.subjects().all(|s| {
                    [
                        protocol::MAP,
                        protocol::STATE,
                        protocol::WORLD,
                        protocol::EVENT,
                    ]
                    .contains(&s)
                })
            })
        });
        packets
    }

    /// The squad orders' names, by code.
    #[staticmethod]
    fn squad_orders() -> Vec<String> {
        SquadOrder::ALL.iter().map(|o| format!("{o:?}")).collect()
    }
}

/// The largest image side: the sorting core's limit, one rule for both.
const MAX_RENDER_SIDE: usize = colony_env::sort::MAX_RENDER_SIDE;

/// Many matches with one configuration, stepped together on every core.
#[pyclass(module = "colony._native")]
pub struct GameBatch {
    envs: Vec<Locked>,
    seeds: Vec<u64>,
    actions: Vec<Vec<RobotAction>>,
}

#[pymethods]
impl GameBatch {
    #[new]
    #[pyo3(signature = (config, worlds, seed=0))]
    fn new(config: &GameConfig, worlds: usize, seed: u64) -> PyResult<GameBatch> {
        if config.config.control != Control::Robot {
            return Err(invalid("a batch of matches takes robot-level control"));
        }
        let first = build(config, seed)?;
        let l = first.layout();
        let values = l.agents * (l.own_len() + l.nearby_len() + l.flags_len() + l.patch_len());
        // A battlefield's cells weigh as much as bodies: the walls are the simulator's.
        let bodies = first.game().roster().len() + first.config().map.grid.cells().len();
        check_budget(worlds, bodies as u64, values as u64).map_err(PyValueError::new_err)?;
        let seeds = firsts(seed, worlds);
        // The first match, built to size the batch, is world 0.
        let envs = std::iter::once(Ok(first))
            .chain(seeds[1..].iter().map(|&s| build(config, s)))
            .map(|env| Ok(Locked(Mutex::new(env?))))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(GameBatch {
            actions: vec![Vec::new(); envs.len()],
            envs,
            seeds,
        })
    }

    #[getter]
    fn worlds(&self) -> usize {
        self.envs.len()
    }

    #[getter]
    fn agents(&self) -> usize {
        self.envs[0].read().agents().len()
    }

    /// Each observation part's name and shape per agent, in `observe`'s order.
    #[getter]
    fn layout<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, shape) in layout(&self.envs[0].read()) {
            d.set_item(name, shape)?;
        }
        Ok(d)
    }

    /// Starts every match again: with `seeds[b]`, or `seed + b`, or (neither)
    /// the seed after its last.
    #[pyo3(signature = (seed=None, seeds=None))]
    fn reset(
        &mut self,
        py: Python<'_>,
        seed: Option<u64>,
        seeds: Option<Vec<u64>>,
    ) -> PyResult<()> {
        let seeds = restart(seed, seeds, &self.seeds).map_err(invalid)?;
        let envs = &mut self.envs;
        py.detach(|| {
            envs.par_iter_mut()
                .zip(&seeds)
                .try_for_each(|(e, &s)| e.get().reset(s))
        })
        .map_err(error)?;
        self.seeds = seeds;
        Ok(())
    }

    fn observe(
        &self,
        py: Python<'_>,
        mut own: PyReadwriteArrayDyn<'_, f32>,
        mut nearby: PyReadwriteArrayDyn<'_, f32>,
        mut flags: PyReadwriteArrayDyn<'_, f32>,
        mut patch: PyReadwriteArrayDyn<'_, f32>,
    ) -> PyResult<()> {
        let first = self.envs[0].read();
        let (lead, parts) = ([self.envs.len(), first.agents().len()], layout(&first));
        drop(first);
        let own = write(&mut own, "own", &shape(&lead, &parts[0].1))?;
        let nearby = write(&mut nearby, "nearby", &shape(&lead, &parts[1].1))?;
        let flags = write(&mut flags, "flags", &shape(&lead, &parts[2].1))?;
        let patch = write(&mut patch, "patch", &shape(&lead, &parts[3].1))?;
        let per = |i: usize| lead[1] * parts[i].1.iter().product::<usize>();
        let envs = &self.envs;
        py.detach(|| {
            envs.par_iter()
                .zip(own.par_chunks_mut(per(0)))
                .zip(nearby.par_chunks_mut(per(1)))
                .zip(flags.par_chunks_mut(per(2)))
                .zip(patch.par_chunks_mut(per(3)))
                .try_for_each(|((((e, o), n), f), p)| e.read().observe(o, n, f, p))
        })
        .map_err(error)
    }

    /// Steps every match, resets those that ended, and writes into the arrays
    /// given: observations (a reset match's first), rewards, the flags, and each
    /// match's score difference (learner's less opponent's) after the step and
    /// before any reset (for a match that ended, what it ended with).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        py: Python<'_>,
        wheels: PyReadonlyArrayDyn<'_, f64>,
        fire: PyReadonlyArrayDyn<'_, i64>,
        pickup: PyReadonlyArrayDyn<'_, bool>,
        mut own: PyReadwriteArrayDyn<'_, f32>,
        mut nearby: PyReadwriteArrayDyn<'_, f32>,
        mut flags: PyReadwriteArrayDyn<'_, f32>,
        mut patch: PyReadwriteArrayDyn<'_, f32>,
        mut reward: PyReadwriteArrayDyn<'_, f64>,
        mut terminated: PyReadwriteArrayDyn<'_, bool>,
        mut truncated: PyReadwriteArrayDyn<'_, bool>,
        mut last: PyReadwriteArrayDyn<'_, f64>,
    ) -> PyResult<()> {
        let first = self.envs[0].read();
        let (b, n, parts) = (self.envs.len(), first.agents().len(), layout(&first));
        let k = first.config().nearby;
        drop(first);
        let lead = [b, n];
        let wheels = read(&wheels, "wheels", &[b, n, 2])?;
        let fire = read(&fire, "fire", &[b, n])?;
        let pickup = read(&pickup, "pickup", &[b, n])?;
        let own = write(&mut own, "own", &shape(&lead, &parts[0].1))?;
        let nearby = write(&mut nearby, "nearby", &shape(&lead, &parts[1].1))?;
        let flags = write(&mut flags, "flags", &shape(&lead, &parts[2].1))?;
        let patch = write(&mut patch, "patch", &shape(&lead, &parts[3].1))?;
        let reward = write(&mut reward, "reward", &[b, n])?;
        let terminated = write(&mut terminated, "terminated", &[b])?;
        let truncated = write(&mut truncated, "truncated", &[b])?;
        let last = write(&mut last, "final", &[b])?;
        let per = |i: usize| n * parts[i].1.iter().product::<usize>();
        let (envs, acts, seeds) = (&mut self.envs, &mut self.actions, &mut self.seeds);
        py.detach(|| {
            let inputs = wheels
                .par_chunks(n * 2)
                .zip(fire.par_chunks(n))
                .zip(pickup.par_chunks(n));
            let observations = own
                .par_chunks_mut(per(0))
                .zip(nearby.par_chunks_mut(per(1)))
                .zip(flags.par_chunks_mut(per(2)))
                .zip(patch.par_chunks_mut(per(3)));
            let ends = reward
                .par_chunks_mut(n)
                .zip(terminated.par_iter_mut())
                .zip(truncated.par_iter_mut())
                .zip(last.par_iter_mut());
            envs.par_iter_mut()
                .zip(acts.par_iter_mut())
                .zip(seeds.par_iter_mut())
                .zip(inputs)
                .zip(observations)
                .zip(ends)
                .try_for_each(
                    |(
                        ((((env, a), seed), ((w, f), p)), (((o, nb), fl), pa)),
                        (((r, term), trunc), fin),
                    )| {
                        let env = env.get();
                        actions(w, f, p, k, a);
                        let info = env.step_robots(a)?;
                        r.copy_from_slice(&info.rewards);
                        (*term, *trunc) = (info.terminated, info.truncated);
                        *fin = f64::from(info.score[0]) - f64::from(info.score[1]);
                        if info.terminated || info.truncated {
                            autoreset(seed, |s| env.reset(s))?;
                        }
                        env.observe(o, nb, fl, pa)
                    },
                )
        })
        .map_err(error)
    }
}
