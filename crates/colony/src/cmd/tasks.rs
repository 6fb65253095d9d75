//! `colony tasks`: MURDOCH task allocation. `demo` runs it live over a hub;
//! `longterm` and `boxpush` are the paper's two experiments on simulated time;
//! `compare` sets its greedy auctions against the optimal assignment.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use colony_hub::{HubSite, HubSpec};
use colony_lab::tasks::{boxpush, longterm, optimal};

use super::Bounds;

/// The live demo's length: up to ten days of wall time.
const DEMO_SECONDS: Bounds = Bounds::new(0.001, 864_000.0, "seconds");
/// The long-term experiment's hours of task introductions, as its settings allow (30 days).
const HOURS: Bounds = Bounds::new(0.001, 720.0, "hours");
/// The box-pushing experiment's simulated time: up to a week, as its settings allow.
const SIM_TIME: Bounds = Bounds::new(0.0, 604_800.0, "seconds");
const MAX_SECONDS: Bounds = Bounds::new(0.1, 604_800.0, "seconds");
/// A live run's speed-up over the wall clock.
const SPEED: Bounds = Bounds::new(0.01, 1000.0, "times real time");

#[derive(clap::Subcommand, Debug)]
pub enum TasksCommand {
    /// Run agents and a user agent live over a hub, printing every allocation.
    Demo(DemoArgs),
    /// Run one robot's agent over a hub, as its own process (the same
    /// program on every robot, each with its own resources).
    Agent(AgentArgs),
    /// Introduce one task into a running system and follow it to its end
    /// (exit 0 when done, 1 when no robot could before the deadline).
    Announce(AnnounceArgs),
    /// A room of robot bodies in the physics field, over a hub: agents started
    /// with `--body N` drive one each, seeing the room on `vision`.
    Room(RoomArgs),
    /// The long-term experiment: 7 agents, 4 task types, batteries, failures.
    Longterm(LongtermArgs),
    /// The box-pushing experiment: a watcher and two pushers in the physics field.
    Boxpush(BoxpushArgs),
    /// MURDOCH's greedy auctions against the optimal assignment, over seeds.
    Compare(CompareArgs),
}

#[derive(clap::Args, Debug)]
pub struct DemoArgs {
    /// How long to run, seconds.
    #[arg(long, default_value_t = 20.0, value_parser = DEMO_SECONDS)]
    pub seconds: f64,
    /// Seeds the tasks.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Use this running hub instead of starting one in this process.
    #[arg(long, value_name = "HOST:PORT")]
    pub hub: Option<String>,
}

/// A battery level.
const LEVEL: Bounds = Bounds::new(0.0, 1.0, "of a full battery");
/// A task's length, or a time into a run.
const TASK_SECONDS: Bounds = Bounds::new(0.0, 604_800.0, "seconds");

#[derive(clap::Args, Debug)]
pub struct AgentArgs {
    #[command(flatten)]
    pub hub: super::HubAddr,
    /// The robot's name, unique in the system [default: robot-XXXX, random].
    #[arg(long)]
    pub name: Option<String>,
    /// What the robot has, comma-separated: `mobile,laser,camera`.
    #[arg(long, value_name = "LIST")]
    pub resources: String,
    /// The battery at the start.
    #[arg(long, default_value_t = 1.0, value_parser = LEVEL)]
    pub battery: f64,
    /// Battery each task costs.
    #[arg(long, default_value_t = 0.1, value_parser = LEVEL)]
    pub drain: f64,
    /// A resource that fails during the run (repeatable; each with an `--at`).
    #[arg(long, value_name = "RESOURCE")]
    pub fail: Vec<String>,
    /// When the matching `--fail` happens, seconds after the start.
    #[arg(long, value_name = "SECONDS", value_parser = TASK_SECONDS)]
    pub at: Vec<f64>,
    /// Drive robot N of the world on `vision` and `radio` (such as `colony
    /// tasks room`) to each task's place, instead of an abstract body.
    #[arg(long, value_name = "N")]
    pub body: Option<u32>,
}

#[derive(clap::Args, Debug)]
pub struct RoomArgs {
    #[command(flatten)]
    pub hub: super::HubAddr,
    /// How many bodies (robots 0 to N-1 on `vision` and `radio`).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u16).range(1..=64))]
    pub bodies: u16,
    /// The room's side, cm (it is square, centred on the origin).
    #[arg(long, default_value_t = 1000.0, value_parser = ROOM_SIDE)]
    pub side: f64,
    /// The bodies' top speed, cm/s.
    #[arg(long, default_value_t = 30.0, value_parser = BODY_SPEED)]
    pub speed: f64,
}

/// A room's side: from a few bodies' width to 80 m (the field's largest map).
const ROOM_SIDE: Bounds = Bounds::new(200.0, 8_000.0, "cm");
/// A body's top speed.
const BODY_SPEED: Bounds = Bounds::new(1.0, 500.0, "cm/s");

#[derive(clap::Args, Debug)]
pub struct AnnounceArgs {
    #[command(flatten)]
    pub hub: super::HubAddr,
    /// The task's name in the shared vocabulary.
    #[arg(long)]
    pub name: String,
    /// What a robot needs to do it, comma-separated.
    #[arg(long, value_name = "LIST")]
    pub needs: String,
    /// How long it takes, seconds.
    #[arg(long, default_value_t = 5.0, value_parser = TASK_SECONDS)]
    pub length: f64,
    /// Give up if no robot has taken it this long after it was introduced.
    #[arg(long, default_value_t = 60.0, value_parser = MAX_SECONDS)]
    pub deadline: f64,
    /// Where it is to be done, `X,Y` in cm: robots bid by their distance to it,
    /// and one with a body drives there first (an agent with no body knows no
    /// distance, and does not bid).
    #[arg(long = "at", value_name = "X,Y")]
    pub place: Option<String>,
    /// Who announces it (bids and awards name it) [default: user-XXXX, random].
    #[arg(long = "as", value_name = "NAME")]
    pub announcer: Option<String>,
}

#[derive(clap::Args, Debug)]
pub struct LongtermArgs {
    /// Simulated hours of task introductions.
    #[arg(long, default_value_t = 3.0, value_parser = HOURS)]
    pub hours: f64,
    /// Seeds every random choice.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write longterm-summary.json and longterm-events.csv here.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
pub struct BoxpushArgs {
    /// Switch one pusher off at this simulated time, s.
    #[arg(long = "off-at", value_name = "S", value_parser = SIM_TIME)]
    pub off_at: Option<f64>,
    /// Switch it on again at this simulated time, s.
    #[arg(long = "on-at", value_name = "S", value_parser = SIM_TIME)]
    pub on_at: Option<f64>,
    /// The goal, `X,Y` in cm (the field is 700 x 600 cm).
    #[arg(long, value_name = "X,Y")]
    pub goal: Option<String>,
    /// Move the goal at this simulated time, s (to --moved-goal); the watcher follows it.
    #[arg(long = "move-goal-at", value_name = "S", value_parser = SIM_TIME, requires = "moved_goal")]
    pub move_goal_at: Option<f64>,
    /// Where the goal moves to, `X,Y` in cm.
    #[arg(long = "moved-goal", value_name = "X,Y", requires = "move_goal_at")]
    pub moved_goal: Option<String>,
    /// Run live over this hub, paced to the wall clock: the monitor draws the
    /// field and its task board shows the pushing auctions.
    #[arg(long, value_name = "HOST:PORT")]
    pub hub: Option<String>,
    /// How much faster than real time a live run goes.
    #[arg(long, default_value_t = 1.0, value_parser = SPEED, requires = "hub")]
    pub speed: f64,
    /// Give up after this many simulated seconds.
    #[arg(long, default_value_t = 900.0, value_parser = MAX_SECONDS)]
    pub max_seconds: f64,
    /// Write boxpush-summary.json and boxpush-track.csv here.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
pub struct CompareArgs {
    /// How many seeds (0 to N-1).
    #[arg(long, default_value_t = 20)]
    pub seeds: u64,
    /// Robots per stream.
    #[arg(long, default_value_t = 12)]
    pub robots: usize,
    /// Tasks per stream.
    #[arg(long, default_value_t = 10)]
    pub tasks: usize,
}

pub fn run(cmd: TasksCommand) -> anyhow::Result<()> {
    match cmd {
        TasksCommand::Demo(a) => demo(a),
        TasksCommand::Longterm(a) => longterm(a),
        TasksCommand::Agent(a) => agent(a),
        TasksCommand::Announce(a) => announce(a),
        TasksCommand::Room(a) => room(a),
        TasksCommand::Boxpush(a) => boxpush(a),
        TasksCommand::Compare(a) => compare(a),
    }
}

fn demo(args: DemoArgs) -> anyhow::Result<()> {
    let duration = super::seconds("--seconds", args.seconds)?;
    let stop = super::stop_flag()?;
    let site = HubSite::here_or_elsewhere(args.hub.as_deref(), &HubSpec::new("127.0.0.1:0"), &stop)
        .context("cannot start a hub on loopback")?;
    let addr = match &site {
        HubSite::Elsewhere(a) => super::HubAddr::at(a).connect()?.hub_addr(),
        HubSite::Here(h) => {
            println!("hub on {}", h.addr());
            h.addr()
        }
    };
    let config = colony_lab::tasks::demo::DemoConfig {
        duration,
        seed: args.seed,
        ..Default::default()
    };
    let summary = colony_lab::tasks::demo::run(addr, &config, &stop, |line| println!("{line}"))
        .context("the demo's hub clients failed")?;
    println!(
        "introduced {}, allocated {}, completed {}, unachievable reports {}, recharges {}",
        summary.introduced,
        summary.allocated,
        summary.completed,
        summary.unachievable,
        summary.recharges
    );
    let _ = site.stop();
    Ok(())
}

fn token(given: Option<String>, prefix: &str) -> anyhow::Result<colony_tasks::protocol::Token> {
    let name = given.unwrap_or_else(|| format!("{prefix}-{:04x}", rand::random::<u16>()));
    colony_tasks::protocol::Token::new(&name).map_err(|e| anyhow::anyhow!("`{name}`: {e}"))
}

fn agent(args: AgentArgs) -> anyhow::Result<()> {
    use colony_tasks::robot::{Fault, RobotConfig};
    let resources = args
        .resources
        .parse()
        .map_err(|e| anyhow::anyhow!("--resources {}: {e}", args.resources))?;
    if args.fail.len() != args.at.len() {
        anyhow::bail!(
            "each --fail needs its --at (got {} --fail and {} --at)",
            args.fail.len(),
            args.at.len()
        );
    }
    let mut config = RobotConfig::new(token(args.name, "robot")?, resources);
    config.body = args.body;
    config.battery = args.battery;
    config.drain_per_task = args.drain;
    for (resource, at) in args.fail.iter().zip(&args.at) {
        config.faults.push(Fault {
            at: super::seconds("--at", *at)?,
            resource: resource.clone(),
            fails: true,
        });
    }
    config.key = args.hub.read_key()?;
    let hub = args.hub.connect()?.hub_addr();
    let stop = super::stop_flag()?;
    let summary = colony_tasks::robot::run(hub, config, &stop, |line| println!("{line}"))
        .context("the agent's hub client failed")?;
    println!(
        "started {}, finished {}, stopped {}, charged {} time(s)",
        summary.started, summary.finished, summary.stopped, summary.charges
    );
    Ok(())
}

fn room(args: RoomArgs) -> anyhow::Result<()> {
    let mut room =
        colony_lab::tasks::room::Room::new(args.side, usize::from(args.bodies), args.speed)
            .map_err(anyhow::Error::msg)?;
    args.hub.no_key("colony tasks room")?;
    let hub = args.hub.connect()?.hub_addr();
    let stop = super::stop_flag()?;
    println!(
        "room {} cm across with {} bodies on the hub at {hub}: robots 0 to {} on vision and radio",
        args.side,
        args.bodies,
        args.bodies - 1
    );
    colony_lab::tasks::room::serve(&mut room, hub, &stop)
        .context("the room's hub client failed")?;
    Ok(())
}

fn announce(args: AnnounceArgs) -> anyhow::Result<()> {
    use colony_tasks::request::Outcome;
    let needs = args
        .needs
        .parse()
        .map_err(|e| anyhow::anyhow!("--needs {}: {e}", args.needs))?;
    let mut spec = colony_tasks::protocol::TaskSpec::new(&args.name, needs).length(args.length);
    if let Some(place) = &args.place {
        let at = parse_goal("--at", place)?;
        spec = spec
            .param("x", at.x)
            .param("y", at.y)
            .metric("distance", 1.0);
    }
    let hub = args.hub.connect()?.hub_addr();
    let stop = super::stop_flag()?;
    let outcome = colony_tasks::request::introduce(
        hub,
        args.hub.read_key()?.as_ref(),
        token(args.announcer, "user")?,
        spec,
        colony_tasks::AuctionConfig::default(),
        super::seconds("--deadline", args.deadline)?,
        &stop,
        |line| println!("{line}"),
    )
    .context("the announcer's hub client failed")?;
    match outcome {
        Outcome::Done { .. } => Ok(()),
        Outcome::GaveUp { reason } => {
            eprintln!("colony: task {} not done: {reason}", args.name);
            std::process::exit(1)
        }
        Outcome::Interrupted => std::process::exit(130),
    }
}

fn write(dir: &Path, name: &str, text: &str) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let path = dir.join(name);
    std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

fn longterm(args: LongtermArgs) -> anyhow::Result<()> {
    let cfg = longterm::LongtermConfig {
        hours: args.hours,
        seed: args.seed,
        ..Default::default()
    };
    let out = longterm::run(&cfg).map_err(anyhow::Error::msg)?;
    let r = &out.report;
    println!(
        "MURDOCH long-term run: {} agents on bodies in the field, {} h exactly, seed {}",
        r.agents, r.hours, r.seed
    );
    println!(
        "  tasks introduced           {:>6} ({} achievable by the roster)",
        r.introduced, r.achievable
    );
    println!("  auctions announced         {:>6}", r.announced);
    println!("  allocated (started)        {:>6}", r.allocated);
    println!(
        "  completed                  {:>6} ({} of the achievable)",
        r.completed, r.completed_achievable
    );
    println!(
        "  re-allocated after failure {:>6}",
        r.reallocated_after_failure
    );
    println!("  unachievable reports       {:>6}", r.unachievable_reports);
    println!(
        "    no robot has what it needs {:>4}",
        r.unachievable_no_robot
    );
    println!("    every capable robot busy   {:>4}", r.unachievable_busy);
    println!(
        "    every capable one charging {:>4}",
        r.unachievable_charging
    );
    println!(
        "    every capable one failed   {:>4}",
        r.unachievable_failed
    );
    println!(
        "  given up by the user agent {:>6} ({} achievable)",
        r.gave_up, r.gave_up_achievable
    );
    println!("  still open at the end      {:>6}", r.open_at_end);
    println!("  recharges                  {:>6}", r.recharges);
    println!("  trips ended short (jammed) {:>6}", r.stuck_arrivals);
    println!(
        "  failures injected          {:>6} ({} at work)",
        r.failures, r.failures_at_work
    );
    println!("  messages                   {:>6}", r.messages);
    println!(
        "  messages per allocation    {:>9.1} ({:.1} without renewals)",
        r.messages_per_allocation, r.negotiation_per_allocation
    );
    println!("  mean wait for a robot      {:>9.1} s", r.mean_wait_s);
    for (name, k) in &r.by_task {
        println!(
            "    {name:<16} introduced {:>3}  completed {:>3}  given up {:>3}",
            k.introduced, k.completed, k.gave_up
        );
    }
    if let Some(dir) = &args.out {
        write(dir, "longterm-summary.json", &r.to_json())?;
        write(dir, "longterm-events.csv", &out.log_csv())?;
    }
    Ok(())
}

fn parse_goal(flag: &str, s: &str) -> anyhow::Result<colony_sim::Vec2> {
    let (x, y) = s
        .split_once(',')
        .with_context(|| format!("{flag} `{s}` is not X,Y"))?;
    let num = |v: &str| {
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .with_context(|| format!("{flag} `{s}`: `{v}` is not a number"))
    };
    Ok(colony_sim::Vec2::new(num(x)?, num(y)?))
}

fn boxpush(args: BoxpushArgs) -> anyhow::Result<()> {
    let mut cfg = boxpush::BoxPushConfig {
        off_at: args.off_at,
        on_at: args.on_at,
        max_s: args.max_seconds,
        ..Default::default()
    };
    if let Some(g) = &args.goal {
        cfg.goal = parse_goal("--goal", g)?;
    }
    if let (Some(at), Some(to)) = (args.move_goal_at, &args.moved_goal) {
        cfg.move_goal = Some((at, parse_goal("--moved-goal", to)?));
    }
    let out = match &args.hub {
        Some(hub) => {
            let hub = super::HubAddr::at(hub).connect()?.hub_addr();
            let stop = super::stop_flag()?;
            println!(
                "box pushing live on the hub at {hub}, {}x real time",
                args.speed
            );
            boxpush::run_live(hub, &cfg, args.speed, &stop, |t, e| {
                println!("{t:7.1} s  {e}")
            })
            .map_err(anyhow::Error::msg)?
        }
        None => {
            let out = boxpush::run(&cfg).map_err(anyhow::Error::msg)?;
            for (t, e) in &out.events {
                println!("{t:7.1} s  {e}");
            }
            out
        }
    };
    let r = &out.report;
    println!(
        "box {} after {:.1} s ({:.1} cm from the goal); {} push tasks announced, {} left and {} right pushes done, by pusher {:?}; {} unachievable, {} re-allocated, {} role swaps, {} messages",
        if r.reached { "at the goal" } else { "NOT at the goal" },
        r.time_s,
        r.final_distance_cm,
        r.announced,
        r.pushes_left,
        r.pushes_right,
        r.pushes_by,
        r.unachievable,
        r.reallocated,
        r.role_swaps,
        r.messages
    );
    if let Some(dir) = &args.out {
        write(dir, "boxpush-summary.json", &r.to_json())?;
        write(dir, "boxpush-track.csv", &out.track_csv())?;
    }
    if !r.reached {
        anyhow::bail!("the box did not reach the goal in {} s", cfg.max_s);
    }
    Ok(())
}

fn compare(args: CompareArgs) -> anyhow::Result<()> {
    if args.seeds == 0 || args.seeds > 10_000 {
        anyhow::bail!("--seeds must be between 1 and 10000");
    }
    println!(
        "seed  metrics           greedy tasks  greedy cost  optimal tasks  optimal cost  ratio"
    );
    for resources_term in [false, true] {
        let mut summary = optimal::CompareSummary::default();
        for seed in 0..args.seeds {
            let c = optimal::compare(&optimal::CompareConfig {
                seed,
                robots: args.robots,
                tasks: args.tasks,
                resources_term,
            })?;
            summary.add(&c);
            println!(
                "{seed:>4}  {:<16}  {:>12}  {:>11.0}  {:>13}  {:>12.0}  {}",
                if resources_term {
                    "dist+batt+res"
                } else {
                    "dist+batt"
                },
                c.greedy_allocated,
                c.greedy_cost,
                c.optimal_allocated,
                c.optimal_cost,
                c.cost_ratio()
                    .map_or("-".to_string(), |r| format!("{r:.3}"))
            );
        }
        println!(
            "{}: tasks allocated greedy {} / optimal {}; cost ratio greedy/optimal mean {:.3}, median {:.3}, worst {:.3} (over {} seeds where both allocated as many)",
            if resources_term { "distance + battery + resources" } else { "distance + battery" },
            summary.greedy_allocated,
            summary.optimal_allocated,
            summary.mean_ratio(),
            summary.median_ratio(),
            summary.worst_ratio(),
            summary.seeds_compared()
        );
    }
    Ok(())
}
