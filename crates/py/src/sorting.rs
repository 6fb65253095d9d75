//! `SortCore` (one sorting world) and `SortBatch` (many, stepped on rayon) over
//! `colony_env::sort::SortEnv`.

use std::path::PathBuf;

use colony_env::sort::{EnvConfig, EnvError, RewardKind, SortEnv, DISCRETE_ACTIONS, MAX_ROBOTS};
use colony_sim::WheelCommand;
use colony_sort::Method;
use numpy::{
    PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArrayDyn, PyReadwriteArrayDyn,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::arrays::{read, write};
use crate::seeds::{autoreset, check_budget, firsts, restart};

pub fn error(e: EnvError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// A sorting environment's configuration, checked once (see `colony.sorting.SortingEnv`
/// for what each value means); one world or a batch is made from it.
#[pyclass(module = "colony._native", frozen)]
pub struct SortConfig {
    config: EnvConfig,
}

#[pymethods]
impl SortConfig {
    #[new]
    #[pyo3(signature = (*, scene=None, params=None, robots=None, pucks=None, kinds=None,
        scale_robots=None, max_steps=2000, pc_target=None, reward="pc_change", grid=16,
        engine=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        scene: Option<PathBuf>,
        params: Option<PathBuf>,
        robots: Option<usize>,
        pucks: Option<usize>,
        kinds: Option<usize>,
        scale_robots: Option<usize>,
        max_steps: u64,
        pc_target: Option<f64>,
        reward: &str,
        grid: usize,
        engine: Option<&str>,
    ) -> PyResult<SortConfig> {
        let reward = match reward {
            "pc" => RewardKind::Pc,
            "pc_change" => RewardKind::PcChange,
            "twc_change" => RewardKind::TwcChange,
            other => {
                return Err(PyValueError::new_err(format!(
                    "reward must be pc, pc_change or twc_change, not {other:?}"
                )))
            }
        };
        let mut config =
            EnvConfig::from_files(scene.as_deref(), params.as_deref()).map_err(error)?;
        if let Some(n) = scale_robots {
            // Checked before scaling, which multiplies it (10 pucks a robot).
            if n == 0 || n > MAX_ROBOTS {
                return Err(PyValueError::new_err(format!(
                    "scale_robots must be 1 to {MAX_ROBOTS}, not {n}"
                )));
            }
            config = config.with_scaled_robots(n);
        }
        config = config
            .with_counts(robots, pucks, kinds)
            .with_engine(engine)
            .map_err(error)?;
        config.max_steps = max_steps;
        config.pc_target = pc_target;
        config.reward = reward;
        config.grid = grid;
        config.validate().map_err(error)?;
        Ok(SortConfig { config })
    }
}

/// The first world of `worlds` with `config`, once they are known to fit the
/// budgets: the bodies are checked before a world is built, the observation's
/// size (which a built world gives) after.
fn sized(config: &EnvConfig, worlds: usize, seed: u64) -> PyResult<SortEnv> {
    let scene = &config.scene;
    let bodies = (scene.robots.count + scene.pucks.count) as u64;
    check_budget(worlds, bodies, 0).map_err(PyValueError::new_err)?;
    let first = SortEnv::new(config.clone(), seed).map_err(error)?;
    check_budget(worlds, bodies, first.layout().map_total() as u64)
        .map_err(PyValueError::new_err)?;
    Ok(first)
}

fn method(name: &str) -> PyResult<Method> {
    name.parse::<Method>()
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Pairs of (forward, turn) as wheel commands, into `out`.
fn to_commands(pairs: &[f64], out: &mut Vec<WheelCommand>) {
    out.clear();
    out.extend(pairs.chunks_exact(2).map(|c| WheelCommand {
        forward: c[0],
        turn: c[1],
    }));
}

/// One sorting world (see `colony.sorting.SortingEnv`, which wraps it).
#[pyclass(module = "colony._native")]
pub struct SortCore {
    env: SortEnv,
    commands: Vec<WheelCommand>,
}

#[pymethods]
impl SortCore {
    #[new]
    #[pyo3(signature = (config, seed=0))]
    fn new(config: &SortConfig, seed: u64) -> PyResult<SortCore> {
        Ok(SortCore {
            env: sized(&config.config, 1, seed)?,
            commands: Vec::new(),
        })
    }

    fn reset(&mut self, py: Python<'_>, seed: u64) -> PyResult<()> {
        py.detach(|| self.env.reset(seed)).map_err(error)
    }

    #[getter]
    fn agents(&self) -> usize {
        self.env.agents()
    }

    #[getter]
    fn kinds(&self) -> usize {
        self.env.layout().kinds
    }

    /// The pucks in the world: no cell of the map can count more of one kind.
    #[getter]
    fn pucks(&self) -> usize {
        self.env.config().scene.pucks.count
    }

    /// (map channels, grid cells per side, gripper length, pose length).
    #[getter]
    fn layout(&self) -> (usize, usize, usize, usize) {
        let l = self.env.layout();
        (l.channels, l.grid, l.gripper, l.pose)
    }

    fn observe(
        &self,
        mut map: PyReadwriteArrayDyn<'_, f32>,
        mut gripper: PyReadwriteArrayDyn<'_, f32>,
        mut pose: PyReadwriteArrayDyn<'_, f32>,
    ) -> PyResult<()> {
        let l = self.env.layout();
        let map = write(&mut map, "map", &[l.agents, l.channels, l.grid, l.grid])?;
        let gripper = write(&mut gripper, "gripper", &[l.agents, l.gripper])?;
        let pose = write(&mut pose, "pose", &[l.agents, l.pose])?;
        self.env.observe(map, gripper, pose).map_err(error)
    }

    /// Steps with one (forward, turn) row per robot: (reward, pc, terminated, truncated).
    fn step(
        &mut self,
        py: Python<'_>,
        actions: PyReadonlyArrayDyn<'_, f64>,
    ) -> PyResult<(f64, f64, bool, bool)> {
        let pairs = read(&actions, "actions", &[self.env.agents(), 2])?;
        to_commands(pairs, &mut self.commands);
        let (env, commands) = (&mut self.env, &self.commands);
        let info = py.detach(|| env.step(commands)).map_err(error)?;
        Ok((info.reward, info.pc, info.terminated, info.truncated))
    }

    /// Steps with one index into the discrete table per robot.
    fn step_discrete(
        &mut self,
        py: Python<'_>,
        actions: PyReadonlyArrayDyn<'_, u32>,
    ) -> PyResult<(f64, f64, bool, bool)> {
        let actions = read(&actions, "actions", &[self.env.agents()])?;
        let env = &mut self.env;
        let info = py.detach(|| env.step_discrete(actions)).map_err(error)?;
        Ok((info.reward, info.pc, info.terminated, info.truncated))
    }

    /// The built-in method's (forward, turn) per robot for this step.
    fn reference<'py>(
        &mut self,
        py: Python<'py>,
        method_name: &str,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let m = method(method_name)?;
        let (env, out) = (&mut self.env, &mut self.commands);
        py.detach(|| env.reference_commands(m, out));
        let rows: Vec<Vec<f64>> = out.iter().map(|c| vec![c.forward, c.turn]).collect();
        PyArray2::from_vec2(py, &rows).map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// Percentage completion now, 0 to 100.
    #[getter]
    fn pc(&self) -> f64 {
        self.env.pc()
    }

    /// The time-weighted completion of this episode so far (PC sampled every step).
    #[getter]
    fn twc(&self) -> f64 {
        self.env.twc_so_far()
    }

    #[getter]
    fn steps(&self) -> u64 {
        self.env.steps()
    }

    /// Simulated seconds of one control step (the scene's physics step times its substeps).
    #[getter]
    fn step_seconds(&self) -> f64 {
        self.env.config().scene.control_step_seconds()
    }

    /// The arena as an image, (height, width, 3) uint8.
    fn render<'py>(
        &self,
        py: Python<'py>,
        width: usize,
        height: usize,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        let rgb = py
            .detach(|| self.env.render_rgb(width, height))
            .map_err(error)?;
        PyArray1::from_vec(py, rgb)
            .reshape([height, width, 3])
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// The live mode's `vision` packets for this state, then its `metrics` packet.
    fn vision_packets(&self) -> PyResult<Vec<Vec<u8>>> {
        let mut packets = self.env.vision_packets().map_err(error)?;
        packets.push(self.env.metrics_packet().map_err(error)?);
        Ok(packets)
    }

    /// The discrete actions' (forward, turn), one row per index.
    #[staticmethod]
    fn discrete_actions<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let rows: Vec<Vec<f64>> = DISCRETE_ACTIONS
            .iter()
            .map(|(_, c)| vec![c.forward, c.turn])
            .collect();
        PyArray2::from_vec2(py, &rows).map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// The discrete actions' names, by index.
    #[staticmethod]
    fn discrete_action_names() -> Vec<&'static str> {
        DISCRETE_ACTIONS.iter().map(|(n, _)| *n).collect()
    }
}

/// Many sorting worlds with one configuration, stepped together on every core.
#[pyclass(module = "colony._native")]
pub struct SortBatch {
    envs: Vec<SortEnv>,
    /// The seed each world's episode started from.
    seeds: Vec<u64>,
    commands: Vec<Vec<WheelCommand>>,
}

#[pymethods]
impl SortBatch {
    #[new]
    #[pyo3(signature = (config, worlds, seed=0))]
    fn new(py: Python<'_>, config: &SortConfig, worlds: usize, seed: u64) -> PyResult<SortBatch> {
        let config = &config.config;
        let first = sized(config, worlds, seed)?;
        let seeds = firsts(seed, worlds);
        let rest = py
            .detach(|| {
                seeds[1..]
                    .par_iter()
                    .map(|&s| SortEnv::new(config.clone(), s))
                    .collect::<Result<Vec<_>, _>>()
            })
            .map_err(error)?;
        let envs: Vec<SortEnv> = std::iter::once(first).chain(rest).collect();
        Ok(SortBatch {
            commands: vec![Vec::new(); envs.len()],
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
        self.envs[0].agents()
    }

    #[getter]
    fn layout(&self) -> (usize, usize, usize, usize) {
        let l = self.envs[0].layout();
        (l.channels, l.grid, l.gripper, l.pose)
    }

    /// Starts every world again: with `seeds[b]`, or `seed + b`, or (neither)
    /// the seed after its last.
    #[pyo3(signature = (seed=None, seeds=None))]
    fn reset(
        &mut self,
        py: Python<'_>,
        seed: Option<u64>,
        seeds: Option<Vec<u64>>,
    ) -> PyResult<()> {
        let seeds = restart(seed, seeds, &self.seeds).map_err(PyValueError::new_err)?;
        let envs = &mut self.envs;
        py.detach(|| {
            envs.par_iter_mut()
                .zip(&seeds)
                .try_for_each(|(e, &s)| e.reset(s))
        })
        .map_err(error)?;
        self.seeds = seeds;
        Ok(())
    }

    fn observe(
        &self,
        py: Python<'_>,
        mut map: PyReadwriteArrayDyn<'_, f32>,
        mut gripper: PyReadwriteArrayDyn<'_, f32>,
        mut pose: PyReadwriteArrayDyn<'_, f32>,
    ) -> PyResult<()> {
        let (b, l) = (self.envs.len(), self.envs[0].layout());
        let map = write(&mut map, "map", &[b, l.agents, l.channels, l.grid, l.grid])?;
        let gripper = write(&mut gripper, "gripper", &[b, l.agents, l.gripper])?;
        let pose = write(&mut pose, "pose", &[b, l.agents, l.pose])?;
        let envs = &self.envs;
        py.detach(|| {
            envs.par_iter()
                .zip(map.par_chunks_mut(l.map_total()))
                .zip(gripper.par_chunks_mut(l.gripper_total()))
                .zip(pose.par_chunks_mut(l.pose_total()))
                .try_for_each(|(((e, m), g), p)| e.observe(m, g, p))
        })
        .map_err(error)
    }

    /// Steps every world with `actions` (worlds, robots, 2), resets the worlds
    /// whose episode ended, and writes into the arrays given: observations (a
    /// reset world's first), rewards, the flags, and each world's PC after the
    /// step and before any reset (for a world that ended, what it ended with).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        py: Python<'_>,
        actions: PyReadonlyArrayDyn<'_, f64>,
        mut map: PyReadwriteArrayDyn<'_, f32>,
        mut gripper: PyReadwriteArrayDyn<'_, f32>,
        mut pose: PyReadwriteArrayDyn<'_, f32>,
        mut reward: PyReadwriteArrayDyn<'_, f64>,
        mut terminated: PyReadwriteArrayDyn<'_, bool>,
        mut truncated: PyReadwriteArrayDyn<'_, bool>,
        mut last: PyReadwriteArrayDyn<'_, f64>,
    ) -> PyResult<()> {
        let (b, l) = (self.envs.len(), self.envs[0].layout());
        let actions = read(&actions, "actions", &[b, l.agents, 2])?;
        let map = write(&mut map, "map", &[b, l.agents, l.channels, l.grid, l.grid])?;
        let gripper = write(&mut gripper, "gripper", &[b, l.agents, l.gripper])?;
        let pose = write(&mut pose, "pose", &[b, l.agents, l.pose])?;
        let reward = write(&mut reward, "reward", &[b, l.agents])?;
        let terminated = write(&mut terminated, "terminated", &[b])?;
        let truncated = write(&mut truncated, "truncated", &[b])?;
        let last = write(&mut last, "final", &[b])?;
        let (envs, commands, seeds) = (&mut self.envs, &mut self.commands, &mut self.seeds);
        py.detach(|| {
            envs.par_iter_mut()
                .zip(commands.par_iter_mut())
                .zip(seeds.par_iter_mut())
                .zip(actions.par_chunks(l.agents * 2))
                .zip(map.par_chunks_mut(l.map_total()))
                .zip(gripper.par_chunks_mut(l.gripper_total()))
                .zip(pose.par_chunks_mut(l.pose_total()))
                .zip(reward.par_chunks_mut(l.agents))
                .zip(terminated.par_iter_mut())
                .zip(truncated.par_iter_mut())
                .zip(last.par_iter_mut())
                .try_for_each(
                    |((((((((((env, cmds), seed), a), m), g), p), r), term), trunc), fin)| {
                        to_commands(a, cmds);
                        let info = env.step(cmds)?;
                        r.fill(info.reward);
                        (*term, *trunc) = (info.terminated, info.truncated);
                        *fin = info.pc;
                        if info.terminated || info.truncated {
                            autoreset(seed, |s| env.reset(s))?;
                        }
                        env.observe(m, g, p)
                    },
                )
        })
        .map_err(error)
    }

    /// Every world's built-in controllers' (forward, turn), (worlds, robots, 2).
    fn reference<'py>(
        &mut self,
        py: Python<'py>,
        method_name: &str,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let m = method(method_name)?;
        let (b, n) = (self.envs.len(), self.envs[0].agents());
        let (envs, commands) = (&mut self.envs, &mut self.commands);
        let flat: Vec<f64> = py.detach(|| {
            envs.par_iter_mut()
                .zip(commands.par_iter_mut())
                .for_each(|(e, out)| e.reference_commands(m, out));
            commands
                .iter()
                .flatten()
                .flat_map(|c| [c.forward, c.turn])
                .collect()
        });
        PyArray1::from_vec(py, flat)
            .reshape([b, n, 2])
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// Each world's percentage completion now.
    fn pc<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.envs.iter().map(|e| e.pc()).collect())
    }
}
