//! `colony sort`: swarm-sorting experiments, the paper's reproduction, and live mode.

use std::path::PathBuf;
use std::process::Command;
use std::str::FromStr as _;

use anyhow::Context as _;
use colony_env::sort::{check_counts, check_robots};
use colony_lab::sort::experiment::{run_trials, write_csv, Disturbance, TrialSpec};
use colony_lab::sort::launch::{self, Swarm, SwarmSpec};
use colony_lab::sort::report;
use colony_lab::sort::supplementary::{self, Experiment};
use colony_sim::{Engine, SceneConfig};
use colony_sort::methods::Method;
use colony_sort::params::SortParams;

use super::progress::Progress;
use super::HubAddr;

#[derive(clap::Subcommand, Debug)]
pub enum SortCommand {
    /// Run trials of one method and write per-trial CSV files.
    Run(RunArgs),
    /// Run the paper's experiments and write plots, tables and statistics.
    Reproduce(ReproduceArgs),
    /// Run the paper's other experiments (k2, physical robots, pucks, arena size,
    /// robots, cluster shifts, re-insertion) and write a report section for each.
    Supplementary(SupplementaryArgs),
    /// Compare two runs of `reproduce` (say, under two contact engines): each mean
    /// against the first run's 95 % confidence interval, the methods' order, the tests.
    Compare(CompareArgs),
    /// Run the simulator live over the hub, each robot's controller a hub client.
    Live(LiveArgs),
    /// Run one robot's controller over the hub (started by `colony sort live`).
    Robot(RobotArgs),
}

/// Scene and controller settings shared by the commands.
#[derive(clap::Args, Debug, Clone)]
pub struct Setup {
    /// Scene file (TOML); default: the paper's standard configuration (see configs/scene.toml).
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// Sorting parameters (TOML); default: configs/sort.toml's values.
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    /// Scale the standard scene to this many robots, with 10 pucks per robot
    /// and the arena grown to keep the paper's densities (live mode).
    #[arg(long = "scale-robots", value_name = "N")]
    pub scale_robots: Option<usize>,
    /// The contact engine that steps the arena: rapier (the reference) or disc;
    /// default: the scene's (`physics.engine`).
    #[arg(long, value_name = "NAME", value_parser = Engine::from_str)]
    pub engine: Option<Engine>,
}

impl Setup {
    fn load(&self) -> anyhow::Result<(SceneConfig, SortParams)> {
        let mut scene = match &self.scene {
            Some(p) => SceneConfig::from_file(p)?,
            None => SceneConfig::default(),
        };
        if let Some(n) = self.scale_robots {
            if n == 0 {
                anyhow::bail!("--scale-robots must be at least 1");
            }
            check_robots(n).context("--scale-robots")?;
            // Scaling replaces the scene; its puck kinds and engine carry over.
            let (kinds, engine) = (scene.pucks.kinds, scene.physics.engine);
            scene = SceneConfig::scaled(n);
            scene.pucks.kinds = kinds;
            scene.physics.engine = engine;
        }
        if let Some(engine) = self.engine {
            scene.physics.engine = engine;
        }
        check_counts(&scene).context("invalid scene")?;
        let params = match &self.params {
            Some(p) => SortParams::load(p)?,
            None => SortParams::default(),
        };
        Ok((scene, params))
    }
}

#[derive(clap::Args, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    pub setup: Setup,
    /// bhd, probseek, cachecons, cachecons-informed, cachecons-ignore or cachecons-erase.
    #[arg(long)]
    pub method: String,
    /// Puck types (default: the scene's).
    #[arg(long)]
    pub types: Option<usize>,
    /// Robots (default: the scene's).
    #[arg(long)]
    pub robots: Option<usize>,
    /// Pucks (default: the scene's).
    #[arg(long)]
    pub pucks: Option<usize>,
    #[arg(long, default_value_t = 5)]
    pub trials: u64,
    /// Control steps per trial (the paper: 100,000).
    #[arg(long, default_value_t = 100_000)]
    pub steps: u64,
    /// Trial t uses seed + t.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Where the CSV files go.
    #[arg(long, default_value = "sort-results")]
    pub out: PathBuf,
    /// At this step, move the largest cluster to the other side of the arena.
    #[arg(long, value_name = "STEP")]
    pub shift_at: Vec<u64>,
    /// At this step, put every puck at a new random place.
    #[arg(long, value_name = "STEP")]
    pub reinsert_at: Vec<u64>,
}

#[derive(clap::Args, Debug)]
pub struct CompareArgs {
    /// The reference run's CSV directory (its `summary.csv` is enough).
    pub reference: PathBuf,
    /// The run compared with it.
    pub candidate: PathBuf,
    /// What to call the two runs in the tables.
    #[arg(long, value_name = "A,B", default_value = "reference,candidate")]
    pub names: String,
    /// Write the comparison here (Markdown) instead of to standard output.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

fn compare(a: CompareArgs) -> anyhow::Result<()> {
    let read = |dir: &PathBuf| {
        colony_lab::sort::experiment::read_summary(dir)
            .with_context(|| format!("cannot read the run in {}", dir.display()))
    };
    let (reference, candidate) = (read(&a.reference)?, read(&a.candidate)?);
    let Some((first, second)) = a.names.split_once(',') else {
        anyhow::bail!(
            "--names takes two names with a comma between, not {:?}",
            a.names
        );
    };
    let (md, tally) = colony_lab::sort::compare::compare(&reference, &candidate, (first, second));
    if tally.means == 0 {
        anyhow::bail!("the two runs share no method and puck-type count: nothing to compare");
    }
    match &a.out {
        Some(path) => {
            std::fs::write(path, &md)
                .with_context(|| format!("cannot write {}", path.display()))?;
            eprintln!(
                "colony: wrote {} ({} of {} means inside the reference's intervals, {} of {} orders and {} of {} tests agree)",
                path.display(),
                tally.means_inside,
                tally.means,
                tally.orders_same,
                tally.orders,
                tally.tests_same,
                tally.tests
            );
        }
        None => print!("{md}"),
    }
    Ok(())
}

#[derive(clap::Args, Debug)]
pub struct ReproduceArgs {
    #[command(flatten)]
    pub setup: Setup,
    #[arg(long, default_value_t = 100_000)]
    pub steps: u64,
    #[arg(long, default_value_t = 20)]
    pub trials: u64,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Where the report, figures and CSV files go.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct SupplementaryArgs {
    #[command(flatten)]
    pub setup: Setup,
    /// Control steps per trial (the paper: 100,000; the physical robots' trials run
    /// at most 5,000).
    #[arg(long, default_value_t = 100_000)]
    pub steps: u64,
    /// Trials per method and condition (the paper: 20; the physical robots' at most 3).
    #[arg(long, default_value_t = 20)]
    pub trials: u64,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Only these experiments (comma-separated: k2, physical, pucks, arena, robots,
    /// shift, reinsert); sections already in the directory are kept.
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<Experiment>,
    /// Write the report again from the CSV files a run with the same settings left in
    /// --out, without running any trial.
    #[arg(long)]
    pub report_only: bool,
    /// Where the report, figures and CSV files go.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct LiveArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    #[command(flatten)]
    pub setup: Setup,
    #[arg(long, default_value = "cachecons")]
    pub method: String,
    /// How many times faster than real time.
    #[arg(long, default_value_t = 1.0, value_parser = super::SPEED)]
    pub speed: f64,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Stop after this many steps (default: until Ctrl-C).
    #[arg(long)]
    pub steps: Option<u64>,
    /// Where the robots' controllers run: one child process per robot, threads of this
    /// process (in the world's own step above 1,024 robots), in the world's step, or
    /// nowhere (`external`: start them with `colony sort robot`). `auto`: a process each
    /// up to 64 robots, threads above.
    #[arg(long, value_enum, default_value_t = Controllers::Auto)]
    pub controllers: Controllers,
}

#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Controllers {
    Auto,
    Process,
    Thread,
    InWorld,
    External,
}

/// The most robots `auto` gives a process each.
const AUTO_PROCESSES: usize = 64;

/// The most robots `process` will start a process for.
const MAX_PROCESSES: usize = 1024;

#[derive(clap::Args, Debug)]
pub struct RobotArgs {
    #[command(flatten)]
    pub hub: HubAddr,
    #[command(flatten)]
    pub setup: Setup,
    /// Which robot this controller drives.
    #[arg(long)]
    pub id: usize,
    #[arg(long, default_value = "cachecons")]
    pub method: String,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(cmd: SortCommand) -> anyhow::Result<()> {
    match cmd {
        SortCommand::Run(a) => run_cmd(a),
        SortCommand::Reproduce(a) => reproduce(a),
        SortCommand::Supplementary(a) => supplementary(a),
        SortCommand::Compare(a) => compare(a),
        SortCommand::Live(a) => live(a),
        SortCommand::Robot(a) => robot(a),
    }
}

/// More trials than this are surely a slip of the keyboard: each is planned up front.
const MAX_TRIALS: u64 = 10_000;

fn check_scale(trials: u64, steps: u64) -> anyhow::Result<()> {
    if trials == 0 || steps == 0 {
        anyhow::bail!("--trials and --steps must be at least 1");
    }
    if trials > MAX_TRIALS {
        anyhow::bail!("--trials {trials} is more than {MAX_TRIALS}");
    }
    Ok(())
}

fn method(name: &str) -> anyhow::Result<Method> {
    Ok(name.parse::<Method>()?)
}

/// Runs specs in parallel, showing progress (`label`: `sort run`): first a line
/// saying what is built (a world of thousands of robots takes a while), then a bar
/// on a terminal, or a line at least every 10 s otherwise.
fn execute(
    label: &str,
    specs: &[TrialSpec],
) -> anyhow::Result<Vec<colony_lab::sort::experiment::TrialResult>> {
    let total: u64 = specs.iter().map(|s| s.steps).sum();
    eprintln!("colony: {label}: {}", plan_text(specs, total));
    let progress = Progress::start(label, total);
    let results = run_trials(specs, &|n| progress.add(n))?;
    drop(progress);
    Ok(results)
}

/// `building 5 worlds of 4,096 robots and 40,960 pucks for 5 trials (500,000
/// control steps in all) on 2 threads…`
fn plan_text(specs: &[TrialSpec], total: u64) -> String {
    use super::progress::grouped;
    let range = |f: fn(&TrialSpec) -> usize| {
        let lo = specs.iter().map(f).min().unwrap_or(0) as u64;
        let hi = specs.iter().map(f).max().unwrap_or(0) as u64;
        if lo == hi {
            grouped(lo)
        } else {
            format!("{} to {}", grouped(lo), grouped(hi))
        }
    };
    let plural = |n: usize, one: &str, many: &str| {
        format!("{} {}", grouped(n as u64), if n == 1 { one } else { many })
    };
    format!(
        "building {} of {} robots and {} pucks for {} ({} control steps in all) on {}\u{2026}",
        plural(specs.len(), "world", "worlds"),
        range(|s| s.scene.robots.count),
        range(|s| s.scene.pucks.count),
        plural(specs.len(), "trial", "trials"),
        grouped(total),
        plural(rayon::current_num_threads(), "thread", "threads"),
    )
}

fn run_cmd(a: RunArgs) -> anyhow::Result<()> {
    let method = method(&a.method)?;
    let (mut scene, params) = a.setup.load()?;
    if let Some(t) = a.types {
        scene.pucks.kinds = t;
    }
    if let Some(r) = a.robots {
        scene.robots.count = r;
    }
    if let Some(p) = a.pucks {
        scene.pucks.count = p;
    }
    check_counts(&scene).context("invalid scene (--robots, --pucks)")?;
    scene.validate().context("invalid scene")?;
    check_scale(a.trials, a.steps)?;
    if method == Method::Bhd && scene.pucks.kinds > 1 {
        anyhow::bail!(
            "BHD only clusters; it cannot sort {} puck types (use --types 1)",
            scene.pucks.kinds
        );
    }
    let specs: Vec<TrialSpec> = (0..a.trials)
        .map(|t| TrialSpec {
            method,
            scene: scene.clone(),
            params: params.clone(),
            steps: a.steps,
            seed: a.seed + t,
            sample_every: 100.min(a.steps),
            snapshot_at: Vec::new(),
            disturbances: a
                .shift_at
                .iter()
                .map(|&at| (at, Disturbance::ShiftLargestCluster))
                .chain(
                    a.reinsert_at
                        .iter()
                        .map(|&at| (at, Disturbance::ReinsertPucks)),
                )
                .collect(),
        })
        .collect();
    let results = execute("sort run", &specs)?;
    write_csv(&a.out, &results)?;
    for (t, r) in results.iter().enumerate() {
        let stc = r.stc.map_or("not reached".to_string(), |s| s.to_string());
        println!(
            "trial {t:>2} seed {:>4}: STC {stc:>11}  TWC {:.4}  final PC {:5.1} %",
            r.seed,
            r.twc,
            r.final_pc()
        );
    }
    println!("CSV files in {}", a.out.display());
    Ok(())
}

fn reproduce(a: ReproduceArgs) -> anyhow::Result<()> {
    let (scene, params) = a.setup.load()?;
    check_scale(a.trials, a.steps)?;
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let specs = report::specs(&scene, &params, a.steps, a.trials, a.seed);
    let results = execute("sort reproduce", &specs)?;
    let command = format!(
        "colony sort reproduce{} --steps {} --trials {} --seed {} --out {}",
        setup_text(&a.setup),
        a.steps,
        a.trials,
        a.seed,
        a.out.display()
    );
    report::write(&a.out, &results, &scene, &command)?;
    println!("report: {}", a.out.join("report.md").display());
    Ok(())
}

fn supplementary(a: SupplementaryArgs) -> anyhow::Result<()> {
    let (scene, params) = a.setup.load()?;
    check_scale(a.trials, a.steps)?;
    let experiments = if a.only.is_empty() {
        Experiment::ALL.to_vec()
    } else {
        a.only.clone()
    };
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let scale = supplementary::Scale {
        trials: a.trials,
        steps: a.steps,
        seed: a.seed,
    };
    let plan = supplementary::plan(&experiments, &scene, &params, scale);
    let results = if a.report_only {
        supplementary::report::read_results(&a.out, &plan)?
    } else {
        execute("sort supplementary", &plan.specs)?
    };
    let only = if a.only.is_empty() {
        String::new()
    } else {
        let names: Vec<&str> = a.only.iter().map(|e| e.name()).collect();
        format!(" --only {}", names.join(","))
    };
    let command = format!(
        "colony sort supplementary{} --steps {} --trials {} --seed {}{only} --out {}",
        setup_text(&a.setup),
        a.steps,
        a.trials,
        a.seed,
        a.out.display()
    );
    supplementary::report::write(&a.out, &plan, &results, &command)?;
    println!("report: {}", a.out.join("report.md").display());
    Ok(())
}

/// The scene flags as they were given, each with a space before it, for a report's
/// "made by" line.
fn setup_text(setup: &Setup) -> String {
    setup_args(setup).iter().map(|a| format!(" {a}")).collect()
}

fn setup_args(setup: &Setup) -> Vec<String> {
    let mut v = Vec::new();
    if let Some(p) = &setup.scene {
        v.extend(["--scene".to_string(), p.display().to_string()]);
    }
    if let Some(p) = &setup.params {
        v.extend(["--params".to_string(), p.display().to_string()]);
    }
    if let Some(n) = setup.scale_robots {
        v.extend(["--scale-robots".to_string(), n.to_string()]);
    }
    if let Some(e) = setup.engine {
        v.extend(["--engine".to_string(), e.name().to_string()]);
    }
    v
}

fn swarm_spec(hub: &HubAddr, setup: &Setup, method: &str, seed: u64) -> anyhow::Result<SwarmSpec> {
    hub.no_key("a live swarm")?;
    let method = self::method(method)?;
    let (scene, params) = setup.load()?;
    Ok(SwarmSpec {
        hub: hub.addr.clone(),
        scene,
        params,
        method,
        seed,
    })
}

fn live(a: LiveArgs) -> anyhow::Result<()> {
    let spec = swarm_spec(&a.hub, &a.setup, &a.method, a.seed)?;
    let stop = super::stop_flag()?;
    let robots = spec.scene.robots.count;
    let choice = match a.controllers {
        Controllers::Auto if robots <= AUTO_PROCESSES => Controllers::Process,
        Controllers::Auto => Controllers::Thread,
        Controllers::Process if robots > MAX_PROCESSES => anyhow::bail!(
            "--controllers process would start {robots} processes, more than the {MAX_PROCESSES} it allows: use --controllers thread or in-world"
        ),
        other => other,
    };
    let controllers = match choice {
        Controllers::Thread => launch::Controllers::Threads,
        Controllers::InWorld => launch::Controllers::InWorld,
        Controllers::External => launch::Controllers::External,
        Controllers::Auto | Controllers::Process => {
            let exe = std::env::current_exe()
                .context("cannot find the colony executable to start robot processes")?;
            let (hub, method, seed) = (a.hub.addr.clone(), a.method.clone(), a.seed);
            let setup = setup_args(&a.setup);
            launch::Controllers::Processes(Box::new(move |id| {
                let mut c = Command::new(&exe);
                c.args([
                    "sort",
                    "robot",
                    "--hub",
                    &hub,
                    "--id",
                    &id.to_string(),
                    "--method",
                    &method,
                    "--seed",
                    &seed.to_string(),
                ])
                .args(&setup);
                c
            }))
        }
    };
    let swarm = Swarm::launch(&spec, controllers, &stop)?;
    eprintln!(
        "colony: live {} with {} robots on the hub at {} ({}x real time)",
        spec.method,
        swarm.robot_count(),
        a.hub.addr,
        a.speed
    );
    let threshold = spec.params.perception.cluster_threshold_cm;
    swarm.run(a.speed, a.steps, |w| {
        if w.step_count() % 500 == 0 {
            let pc = colony_sort::metrics::percentage_completion(&w.pucks(), threshold);
            eprintln!("colony: step {} PC {pc:.1} %", w.step_count());
        }
    })?;
    Ok(())
}

fn robot(a: RobotArgs) -> anyhow::Result<()> {
    let spec = swarm_spec(&a.hub, &a.setup, &a.method, a.seed)?;
    let stop = super::stop_flag()?;
    launch::run_controller(&spec, a.id, &stop)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::Parser as _;

    use super::*;

    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        setup: Setup,
    }

    fn setup(args: &[&str]) -> Setup {
        Cli::parse_from(std::iter::once("colony").chain(args.iter().copied())).setup
    }

    #[test]
    fn the_engine_is_applied_after_scaling_and_forwarded_to_robot_processes() {
        let s = setup(&["--scale-robots", "8", "--engine", "rapier"]);
        assert_eq!(
            setup_args(&s),
            ["--scale-robots", "8", "--engine", "rapier"]
        );
        let (scene, _) = s.load().unwrap();
        assert_eq!(
            (scene.robots.count, scene.physics.engine),
            (8, Engine::Rapier)
        );
        // Without --engine, a scene file's engine holds, scaled or not.
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("scene.toml");
        std::fs::write(&file, "[physics]\nengine = \"disc\"\n").unwrap();
        let path = file.to_str().unwrap();
        for args in [
            &["--scene", path][..],
            &["--scene", path, "--scale-robots", "8"],
        ] {
            let (scene, _) = setup(args).load().unwrap();
            assert_eq!(scene.physics.engine, Engine::Disc, "{args:?}");
        }
        let (scene, _) = setup(&["--scene", path, "--engine", "rapier"])
            .load()
            .unwrap();
        assert_eq!(scene.physics.engine, Engine::Rapier);
        assert!(Cli::try_parse_from(["colony", "--engine", "warp"]).is_err());
    }
}
