//! Running trials: a world, one controller per robot, metrics sampled as the
//! authors did (every 100 steps), in parallel across trials and
//! deterministic per trial seed.

use std::io::Write as _;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use colony_sim::{RobotId, SceneConfig, SimError, World};
use colony_sort::methods::{build, Method};
use colony_sort::metrics;
use colony_sort::params::SortParams;
use colony_sort::swarm::{robot_rng, ROBOTS_PER_TASK};
use colony_sort::Controller;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// One trial to run.
#[derive(Debug, Clone)]
pub struct TrialSpec {
    /// Which sorting method every robot runs.
    pub method: Method,
    /// The arena, robots and pucks.
    pub scene: SceneConfig,
    /// The controllers' parameters.
    pub params: SortParams,
    /// Control steps to run.
    pub steps: u64,
    /// Fixes the initial layout (the same for every method: trials are paired)
    /// and every random choice.
    pub seed: u64,
    /// Metrics are sampled every this many steps (the authors saved every 100).
    pub sample_every: u64,
    /// Steps at which to keep a picture of the arena.
    pub snapshot_at: Vec<u64>,
    /// Disturbances from the paper's supplementary experiments, each at a step.
    pub disturbances: Vec<(u64, Disturbance)>,
}

/// Something done to the pucks from outside the swarm (the paper's
/// supplementary experiments: other agents working on the same materials).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Disturbance {
    /// Move the largest established cluster to the mirror image of its
    /// place through the arena's centre, keeping its shape.
    ShiftLargestCluster,
    /// Put every puck at a new uniformly random place.
    ReinsertPucks,
}

/// Applies a disturbance to the world; `rng` is the trial's own disturbance stream.
fn disturb(
    world: &mut World,
    what: Disturbance,
    threshold: f64,
    rng: &mut ChaCha8Rng,
) -> Result<(), ExperimentError> {
    match what {
        Disturbance::ShiftLargestCluster => {
            let pucks = world.pucks();
            let Some(largest) = colony_sort::perception::global_clusters(&pucks, threshold)
                .into_iter()
                .max_by_key(|c| c.size())
            else {
                return Ok(());
            };
            let ids: Vec<_> = largest.members.iter().map(|m| pucks[m.index].id).collect();
            world.shift_cluster(&ids, largest.centroid * -2.0);
        }
        Disturbance::ReinsertPucks => world.reinsert_pucks(rng)?,
    }
    Ok(())
}

/// The metrics at one sampled step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// The control step it was taken at.
    pub step: u64,
    /// Percentage completion (eq. 6).
    pub pc: f64,
    /// Variance of cache-point distances from their centroid (Fig. 11), for methods with caches.
    pub cache_variance: Option<f64>,
}

/// The arena at one step, for figures.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// The control step it was taken at.
    pub step: u64,
    /// (x, y, kind)
    pub pucks: Vec<(f64, f64, u8)>,
    /// (x, y, heading)
    pub robots: Vec<(f64, f64, f64)>,
    /// Every robot's cache points, (x, y, kind).
    pub caches: Vec<(f64, f64, u8)>,
}

/// What one trial produced.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialResult {
    /// The method the robots ran.
    pub method: Method,
    /// How many puck kinds there were.
    pub types: usize,
    /// The trial's seed.
    pub seed: u64,
    /// Control steps run.
    pub steps: u64,
    /// The metrics, sampled every few steps.
    pub samples: Vec<Sample>,
    /// First sampled step with PC at or above 50 %, if any.
    pub stc: Option<u64>,
    /// Time-weighted completion (eq. 7) over the samples.
    pub twc: f64,
    /// Arena snapshots for figures.
    pub snapshots: Vec<Snapshot>,
}

impl TrialResult {
    /// STC, counting a trial that never reached 50 % as taking all its steps
    /// (a censored value, which the report says it used).
    pub fn stc_or_steps(&self) -> f64 {
        self.stc.unwrap_or(self.steps) as f64
    }

    /// The percentage completion at the last sample (0 with no samples).
    pub fn final_pc(&self) -> f64 {
        self.samples.last().map_or(0.0, |s| s.pc)
    }
}

/// Why an experiment could not run.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// The world could not be built.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The experiment's settings make no sense.
    #[error("{0}")]
    Invalid(String),
    /// A result file could not be read.
    #[error("cannot read {path}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// A result file could not be written.
    #[error("cannot write {path}")]
    Write {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
}

fn snapshot(world: &World, caches: &[Vec<(colony_sim::PuckKind, colony_sim::Vec2)>]) -> Snapshot {
    Snapshot {
        step: world.step_count(),
        pucks: world
            .pucks()
            .iter()
            .map(|p| (p.pos.x, p.pos.y, p.kind.0))
            .collect(),
        robots: world
            .robots()
            .iter()
            .map(|r| (r.pose.x, r.pose.y, r.pose.theta))
            .collect(),
        caches: caches
            .iter()
            .flatten()
            .map(|(k, p)| (p.x, p.y, k.0))
            .collect(),
    }
}

/// Runs one trial; `progress` is called with the number of steps just done.
pub fn run_trial(
    spec: &TrialSpec,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<TrialResult, ExperimentError> {
    run_trial_then(spec, progress, |_| {})
}

/// [`run_trial`], handing the world as it ends to `last` (benchmarks read its engine's
/// figures there).
pub fn run_trial_then(
    spec: &TrialSpec,
    progress: &(dyn Fn(u64) + Sync),
    last: impl FnOnce(&World),
) -> Result<TrialResult, ExperimentError> {
    if spec.sample_every == 0 {
        return Err(ExperimentError::Invalid(
            "the sampling interval must be at least one step".into(),
        ));
    }
    let mut world = World::new(&spec.scene, spec.seed)?;
    let types = spec.scene.pucks.kinds;
    let width = spec.scene.arena.width;
    let n = world.robot_count();
    let mut controllers: Vec<_> = (0..n)
        .map(|_| build(spec.method, &spec.params, types, width))
        .collect();
    let mut rngs: Vec<ChaCha8Rng> = (0..n).map(|i| robot_rng(spec.seed, i)).collect();
    let threshold = spec.params.perception.cluster_threshold_cm;
    let has_caches = !matches!(spec.method, Method::Bhd | Method::ProbSeek);

    // Reserved up front for ordinary trials only: `steps` may be any number a user typed.
    let mut samples =
        Vec::with_capacity((spec.steps / spec.sample_every).min(1 << 16) as usize + 1);
    let mut snapshots = Vec::new();
    let mut commands = Vec::with_capacity(n);
    let mut reported = 0;
    let report_every = report_interval(n + spec.scene.pucks.count);
    let mut disturbance_rng = robot_rng(spec.seed, usize::MAX - 1);
    for step in 0..=spec.steps {
        for (_, what) in spec.disturbances.iter().filter(|(at, _)| *at == step) {
            disturb(&mut world, *what, threshold, &mut disturbance_rng)?;
        }
        if step % spec.sample_every == 0 || step == spec.steps || spec.snapshot_at.contains(&step) {
            let caches: Vec<_> = controllers.iter().map(|c| c.cache_points()).collect();
            if step % spec.sample_every == 0 || step == spec.steps {
                let pc = metrics::percentage_completion(&world.pucks(), threshold);
                let cache_variance = if has_caches {
                    metrics::cache_variance(&caches)
                } else {
                    None
                };
                samples.push(Sample {
                    step,
                    pc,
                    cache_variance,
                });
            }
            if spec.snapshot_at.contains(&step) {
                snapshots.push(snapshot(&world, &caches));
            }
        }
        if step == spec.steps {
            break;
        }
        // Robots sense and decide independently (each with its own random stream), so
        // spreading them over threads cannot change a command.
        let seen = &world;
        let decide = |(i, (c, rng)): (usize, (&mut Box<dyn Controller>, &mut ChaCha8Rng))| {
            c.step(&seen.observe(RobotId(i)), rng)
        };
        if n > ROBOTS_PER_TASK {
            controllers
                .par_iter_mut()
                .zip(rngs.par_iter_mut())
                .enumerate()
                .with_min_len(ROBOTS_PER_TASK)
                .map(decide)
                .collect_into_vec(&mut commands);
        } else {
            // A handful of robots: handing them to rayon costs more than deciding for them.
            commands.clear();
            commands.extend(
                controllers
                    .iter_mut()
                    .zip(&mut rngs)
                    .enumerate()
                    .map(decide),
            );
        }
        world.step(&commands);
        if (step + 1) % report_every == 0 {
            progress(step + 1 - reported);
            reported = step + 1;
        }
    }
    progress(spec.steps - reported);
    last(&world);
    let series: Vec<(u64, f64)> = samples.iter().map(|s| (s.step, s.pc)).collect();
    Ok(TrialResult {
        method: spec.method,
        types,
        seed: spec.seed,
        steps: spec.steps,
        stc: metrics::steps_to_completion(&series, metrics::STC_LEVEL),
        twc: metrics::time_weighted_completion(&series).unwrap_or(0.0),
        samples,
        snapshots,
    })
}

/// How many steps a trial takes between two calls of its `progress`: 1,000 for
/// the standard world's 44 bodies, down to every step for worlds of 100,000
/// bodies or more, whose steps take long enough to be counted one by one.
fn report_interval(bodies: usize) -> u64 {
    (100_000 / bodies.max(1)).clamp(1, 1000) as u64
}

/// Runs every trial, in parallel on rayon's pool; results come back in the
/// order of `specs`, identical whatever the thread count.
pub fn run_trials(
    specs: &[TrialSpec],
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Vec<TrialResult>, ExperimentError> {
    specs.par_iter().map(|s| run_trial(s, progress)).collect()
}

/// Counts steps done across threads, for a progress bar.
#[derive(Debug, Default)]
pub struct StepCounter(pub AtomicU64);

impl StepCounter {
    /// Counts `n` more steps done.
    pub fn add(&self, n: u64) {
        self.0.fetch_add(n, Ordering::Relaxed);
    }
}

/// The error for a file that could not be written, to hand to `map_err`.
pub(crate) fn write_error(path: &Path) -> impl FnOnce(std::io::Error) -> ExperimentError + '_ {
    move |source| ExperimentError::Write {
        path: path.display().to_string(),
        source,
    }
}

fn create(path: &Path) -> Result<std::io::BufWriter<std::fs::File>, ExperimentError> {
    std::fs::File::create(path)
        .map(std::io::BufWriter::new)
        .map_err(write_error(path))
}

/// Writes one CSV per trial (`step,pc,cache_variance`) and a summary
/// (`method,types,trial,seed,steps,stc,twc,final_pc`) into `dir`.
pub fn write_csv(dir: &Path, results: &[TrialResult]) -> Result<(), ExperimentError> {
    std::fs::create_dir_all(dir).map_err(write_error(dir))?;
    let summary_path = dir.join("summary.csv");
    let mut summary = create(&summary_path)?;
    writeln!(summary, "method,types,trial,seed,steps,stc,twc,final_pc")
        .map_err(write_error(&summary_path))?;
    let mut trial_of: std::collections::HashMap<(Method, usize), usize> = Default::default();
    for r in results {
        let trial = trial_of.entry((r.method, r.types)).or_insert(0);
        let path = dir.join(format!(
            "{}-types{}-trial{:02}.csv",
            r.method, r.types, trial
        ));
        let mut f = create(&path)?;
        writeln!(f, "step,pc,cache_variance").map_err(write_error(&path))?;
        for s in &r.samples {
            let cv = s
                .cache_variance
                .map(|v| format!("{v:.4}"))
                .unwrap_or_default();
            writeln!(f, "{},{:.4},{}", s.step, s.pc, cv).map_err(write_error(&path))?;
        }
        f.flush().map_err(write_error(&path))?;
        let stc = r.stc.map(|s| s.to_string()).unwrap_or_default();
        writeln!(
            summary,
            "{},{},{},{},{},{},{:.6},{:.4}",
            r.method,
            r.types,
            trial,
            r.seed,
            r.steps,
            stc,
            r.twc,
            r.final_pc()
        )
        .map_err(write_error(&summary_path))?;
        *trial += 1;
    }
    summary.flush().map_err(write_error(&summary_path))
}

/// Reads back what [`write_csv`] wrote into `dir`: every trial in the summary's order,
/// with its samples (snapshots are not kept in CSV files, so there are none).
pub fn read_csv(dir: &Path) -> Result<Vec<TrialResult>, ExperimentError> {
    read_results(dir, true)
}

/// The trials of `summary.csv` in `dir` alone, without their samples (what a committed
/// report keeps: enough for STC, TWC and the tests).
pub fn read_summary(dir: &Path) -> Result<Vec<TrialResult>, ExperimentError> {
    read_results(dir, false)
}

fn read_results(dir: &Path, with_samples: bool) -> Result<Vec<TrialResult>, ExperimentError> {
    let bad = |path: &Path, line: usize, what: &str| {
        ExperimentError::Invalid(format!("{}:{line}: {what}", path.display()))
    };
    let read = |path: &Path| {
        std::fs::read_to_string(path).map_err(|source| ExperimentError::Read {
            path: path.display().to_string(),
            source,
        })
    };
    let summary_path = dir.join("summary.csv");
    let summary = read(&summary_path)?;
    let mut out = Vec::new();
    for (n, line) in summary.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let [method, types, trial, seed, steps, stc, twc, _final_pc] = f[..] else {
            return Err(bad(&summary_path, n + 1, "expected 8 fields"));
        };
        let number = |s: &str| {
            s.parse::<u64>()
                .map_err(|_| bad(&summary_path, n + 1, "not a whole number"))
        };
        let method: Method = method
            .parse()
            .map_err(|e: colony_sort::methods::UnknownMethod| {
                bad(&summary_path, n + 1, &e.to_string())
            })?;
        let types = number(types)? as usize;
        let trial = number(trial)?;
        let stc = if stc.is_empty() {
            None
        } else {
            Some(number(stc)?)
        };
        let twc: f64 = twc
            .parse()
            .ok()
            .filter(|t: &f64| t.is_finite())
            .ok_or_else(|| bad(&summary_path, n + 1, "TWC is not a finite number"))?;
        let path = dir.join(format!("{method}-types{types}-trial{trial:02}.csv"));
        let text = if with_samples {
            read(&path)?
        } else {
            String::new()
        };
        let mut samples = Vec::new();
        for (k, row) in text.lines().enumerate().skip(1) {
            let mut cells = row.split(',');
            let (Some(step), Some(pc), Some(cv)) = (cells.next(), cells.next(), cells.next())
            else {
                return Err(bad(&path, k + 1, "expected step,pc,cache_variance"));
            };
            let number = |s: &str| {
                s.parse::<f64>()
                    .map_err(|_| bad(&path, k + 1, "not a number"))
            };
            samples.push(Sample {
                step: step
                    .parse()
                    .map_err(|_| bad(&path, k + 1, "step is not a whole number"))?,
                pc: number(pc)?,
                cache_variance: if cv.is_empty() {
                    None
                } else {
                    Some(number(cv)?)
                },
            });
        }
        out.push(TrialResult {
            method,
            types,
            seed: number(seed)?,
            steps: number(steps)?,
            samples,
            stc,
            twc,
            snapshots: Vec::new(),
        });
    }
    Ok(out)
}
