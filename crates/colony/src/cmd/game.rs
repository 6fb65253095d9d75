//! `colony game`: the strategy game. `ctf` and `dm` start a whole match
//! (hub, monitor, world, game server, one hub client per robot, scripted
//! players), live or fast-forwarded; `part` runs one part of a match on its
//! own, so the parts can be separate processes that restart independently.

use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime};

use anyhow::Context as _;
use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_hub::log::{LogSink, LogWriter};
use colony_hub::{HubSite, HubSpec, HubThread};
use colony_lab::game::live_match::{self, LiveMatch, MatchPlan};
use colony_mcap::McapLogWriter;
use colony_monitor::{Monitor, MonitorConfig};

mod measure;

/// A match's game time: a tenth of a second (one control step and more) to a
/// day, so the number of steps it makes always fits.
const TIME_LIMIT: super::Bounds = super::Bounds::new(0.1, 86_400.0, "seconds");

/// The squads each team gets unless told otherwise: 19 of the 30 points.
const DEFAULT_TEAM: &str = "alpha:tank,infantry,infantry bravo:scout,scout,amphibian";

#[derive(clap::Subcommand, Debug)]
pub enum GameCommand {
    /// Capture the Flag: take the enemy flag to your base.
    Ctf(MatchArgs),
    /// Death Match: destroy the enemy.
    Dm(MatchArgs),
    /// Run one part of a match over a running hub (world, server, robots or bot).
    Part(PartArgs),
    /// Measure the paper's Tables 3 and 4 on a live match: each hop of a player's command.
    Measure(measure::MeasureArgs),
}

/// What every part of a match must agree on.
#[derive(clap::Args, Debug, Clone)]
pub struct Setup {
    /// The battlefield (Moving AI grid with our team lines).
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Red's squads: `NAME:KIND,KIND,... NAME:...` (kinds: scout, tank, infantry, amphibian).
    #[arg(long, default_value = DEFAULT_TEAM)]
    pub red: String,
    /// Blue's squads, as for --red.
    #[arg(long, default_value = DEFAULT_TEAM)]
    pub blue: String,
    /// Budget points per team.
    #[arg(long, default_value_t = 30)]
    pub budget: u32,
    /// Game time limit, seconds.
    #[arg(long, default_value_t = 600.0, value_parser = TIME_LIMIT)]
    pub time_limit: f64,
}

#[derive(clap::Args, Debug)]
pub struct MatchArgs {
    #[command(flatten)]
    pub setup: Setup,
    /// The team a person plays from the monitor's game page against the
    /// built-in scripted opponent; several, comma-separated (`red,blue`), for people
    /// on every side; `none` to watch two scripted teams. (With --fast every team is
    /// scripted.)
    #[arg(long, default_value = "red")]
    pub player: String,
    /// Fast-forward the whole match in this process, with no hub, and print the result.
    #[arg(long)]
    pub fast: bool,
    /// Let the players set up their teams on the game page first (budget, types, health and
    /// power, squads); --red and --blue are where they start. The match starts when every
    /// team is ready.
    #[arg(long, conflicts_with = "fast")]
    pub lobby: bool,
    /// Write every packet of the match to this traffic log (`colony replay` shows it): a new
    /// MCAP for a name ending in `.mcap` (never appended to), a `.clog` otherwise (appended
    /// to). The match's own hub writes it, so not with --hub (that hub's --log records it).
    #[arg(long, conflicts_with = "hub")]
    pub record: Option<PathBuf>,
    /// How many times faster than real time the world runs (live).
    #[arg(long, default_value_t = 1.0, value_parser = super::SPEED)]
    pub speed: f64,
    /// Use this running hub instead of starting one.
    #[arg(long, value_name = "HOST:PORT")]
    pub hub: Option<String>,
    /// Where the match's own hub listens.
    #[arg(long, default_value = "127.0.0.1:7400", value_name = "HOST:PORT")]
    pub hub_bind: String,
    /// Where the monitor serves the game page.
    #[arg(long, default_value = "127.0.0.1:8080", value_name = "HOST:PORT")]
    pub monitor_bind: String,
    /// Don't serve the monitor.
    #[arg(long)]
    pub no_monitor: bool,
    /// Stop after this many seconds of wall time (live).
    #[arg(long, value_parser = super::RUN_SECONDS)]
    pub seconds: Option<f64>,
}

#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum PartKind {
    /// The simulated battlefield.
    World,
    /// Game logic and swarm intelligence.
    Server,
    /// Every robot's intelligence, one hub client each.
    Robots,
    /// The scripted player for --team.
    Bot,
}

impl PartKind {
    /// What a person calls it.
    fn name(self) -> &'static str {
        match self {
            PartKind::World => "world",
            PartKind::Server => "game server",
            PartKind::Robots => "robots",
            PartKind::Bot => "scripted player",
        }
    }
}

#[derive(clap::Args, Debug)]
pub struct PartArgs {
    /// Which part.
    #[arg(value_enum)]
    pub part: PartKind,
    /// The game: ctf or dm.
    #[arg(long, default_value = "ctf")]
    pub mode: String,
    #[command(flatten)]
    pub setup: Setup,
    /// The team the bot plays.
    #[arg(long)]
    pub team: Option<String>,
    /// How many times faster than real time the world runs.
    #[arg(long, default_value_t = 1.0, value_parser = super::SPEED)]
    pub speed: f64,
    #[command(flatten)]
    pub hub: super::HubAddr,
}

pub fn run(cmd: GameCommand) -> anyhow::Result<()> {
    match cmd {
        GameCommand::Ctf(a) => play(Mode::CaptureTheFlag, a),
        GameCommand::Dm(a) => play(Mode::DeathMatch, a),
        GameCommand::Part(a) => part(a),
        GameCommand::Measure(a) => measure::run(a),
    }
}

/// The teams as the flags give them.
fn teams(setup: &Setup) -> anyhow::Result<Vec<TeamSetup>> {
    Ok(vec![
        TeamSetup::parse("red", &setup.red).context("--red")?,
        TeamSetup::parse("blue", &setup.blue).context("--blue")?,
    ])
}

fn load(mode: Mode, setup: &Setup) -> anyhow::Result<MatchPlan> {
    let mut rules = Rules::new(mode);
    rules.budget = setup.budget;
    rules.time_limit_s = setup.time_limit;
    Ok(match &setup.map {
        Some(path) => MatchPlan::new(path, rules, &teams(setup)?)?,
        None => MatchPlan::shipped(rules, &teams(setup)?)?,
    })
}

fn play(mode: Mode, args: MatchArgs) -> anyhow::Result<()> {
    let plan = load(mode, &args.setup)?;
    for p in players(&args.player) {
        if !plan.teams.iter().any(|t| t == p) {
            anyhow::bail!(
                "--player {}: no such team as {p:?} (teams: {}, comma-separated, or none)",
                args.player,
                plan.teams.join(", ")
            );
        }
    }
    if args.fast {
        return fast(&plan, &args);
    }
    let stop = super::stop_flag()?;
    let spec = HubSpec {
        log: args.record.clone(),
        ..HubSpec::new(args.hub_bind.as_str())
    };
    let hub = match args.hub.as_deref() {
        Some(addr) => HubSite::Elsewhere(addr.to_string()),
        // Started as `colony hub` starts one, so the record is MCAP for a `.mcap` name.
        None => {
            let server = super::hub::start(&spec, |addr| {
                format!("cannot start the match's hub on `{addr}` (is one running there? choose another port with --hub-bind, or join it with --hub)")
            })?;
            HubSite::Here(HubThread::spawn(server, &stop)?)
        }
    };
    let result = live(&plan, &args, &hub.addr(), &stop);
    hub.stop().context("the match's hub failed")?;
    result
}

fn live(
    plan: &MatchPlan,
    args: &MatchArgs,
    hub: &str,
    stop: &std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> anyhow::Result<()> {
    let monitor = if args.no_monitor {
        None
    } else {
        Some(
            Monitor::start(&MonitorConfig {
                hub: hub.to_string(),
                bind: args.monitor_bind.clone(),
                ..MonitorConfig::default()
            })
            .map_err(|e| match e {
                colony_monitor::MonitorError::Bind { addr, source } => anyhow::anyhow!(
                    "cannot serve the monitor on `{addr}`: {source} (choose another port with --monitor-bind, or --no-monitor)"
                ),
                e => e.into(),
            })?,
        )
    };
    let people = players(&args.player);
    let bots: Vec<String> = plan
        .teams
        .iter()
        .filter(|t| !people.contains(&t.as_str()))
        .cloned()
        .collect();
    let drafted;
    let plan = if args.lobby {
        if let Some(m) = &monitor {
            println!(
                "colony game: pre-match; set up your team at {} (hub {hub}); the match starts when every team is ready; Ctrl-C stops",
                m.page_url(
                    "/game",
                    &people
                        .first()
                        .map_or(String::new(), |t| format!("team={t}"))
                ),
            );
        }
        match live_match::run_lobby(plan, teams(&args.setup)?, hub, &bots, stop)? {
            Some(p) => {
                drafted = p;
                &drafted
            }
            None => return Ok(()),
        }
    } else {
        plan
    };
    let running = LiveMatch::start(plan, hub, args.speed, &bots, stop)?;
    match &monitor {
        Some(m) => println!(
            "colony game: {} on {} ({} x {} cells); open {} (hub {hub}); Ctrl-C stops",
            plan.rules.mode,
            plan.map,
            plan.field.grid.width(),
            plan.field.grid.height(),
            m.page_url(
                "/game",
                &people
                    .first()
                    .map_or(String::new(), |t| format!("team={t}"))
            ),
        ),
        None => println!(
            "colony game: {} running (hub {hub}); Ctrl-C stops",
            plan.rules.mode
        ),
    }
    let deadline = super::deadline("--seconds", args.seconds)?;
    let monitor_gone = || {
        monitor
            .as_ref()
            .is_some_and(|m| !m.is_running())
            .then(|| "the monitor".to_string())
    };
    let outcome = running.supervise(stop, deadline, monitor_gone, |l| println!("{l}"));
    if let Some(m) = monitor {
        m.shutdown()?;
    }
    Ok(outcome?)
}

/// The teams people play, from `--player` (`none`: no one).
fn players(arg: &str) -> Vec<&str> {
    if arg == "none" {
        return Vec::new();
    }
    arg.split(',').map(str::trim).collect()
}

fn fast(plan: &MatchPlan, args: &MatchArgs) -> anyhow::Result<()> {
    // As the hub writes it: MCAP for a name ending in `.mcap`, a `.clog` otherwise.
    let mut latest = None;
    let mut log: Option<Box<dyn LogSink>> = match &args.record {
        Some(path) if super::hub::writes_mcap(path) => Some(Box::new(McapLogWriter::create(path)?)),
        Some(path) => {
            let writer = LogWriter::open_warning(path)?;
            latest = writer.latest();
            Some(Box::new(writer))
        }
        None => None,
    };
    let source: std::net::SocketAddr = ([127, 0, 0, 1], 0).into();
    let mut log_error = None;
    // Records are stamped with the game's clock from the moment the run starts, or
    // just after the latest record of a log it appends to (an earlier fast run's
    // stamps run ahead of the wall clock), so the log keeps its times in order and a
    // replay paces the match as it was played. (They were stamped from the epoch, so
    // an appended match went back to 1970.)
    let now = SystemTime::now();
    let started = latest.map_or(now, |l| now.max(l + Duration::from_micros(1)));
    let mut tap = |t: f64, p: &[u8]| {
        if let Some(w) = &mut log {
            // Game time is bounded by --time-limit; a value out of range (it cannot
            // be) would be logged at the start rather than panic.
            let at = started + Duration::try_from_secs_f64(t).unwrap_or_default();
            if let Err(e) = w.append(at, source, p) {
                log_error.get_or_insert(e);
            }
        }
    };
    println!(
        "colony game: {} on {}, fast-forwarded",
        plan.rules.mode, plan.map
    );
    let t0 = Instant::now();
    let outcome = live_match::fast_forward(plan, &teams(&args.setup)?, &mut tap, &mut |l| {
        println!("{l}")
    });
    let wall = t0.elapsed().as_secs_f64();
    if let Some(e) = log_error {
        return Err(e).context("cannot write the traffic log");
    }
    if let Some(w) = &mut log {
        w.finish().context("cannot write the traffic log")?;
    }
    let outcome = outcome?;
    println!("{}", outcome.result);
    println!(
        "{} steps, {:.1} s of game time in {:.2} s ({:.0}x real time); {} packets",
        outcome.steps,
        outcome.game_time,
        wall,
        outcome.game_time / wall.max(1e-9),
        outcome.packets
    );
    Ok(())
}

fn part(args: PartArgs) -> anyhow::Result<()> {
    args.hub.no_key("colony game part")?;
    let mode: Mode = args.mode.parse()?;
    let plan = load(mode, &args.setup)?;
    let part = match args.part {
        PartKind::World => live_match::PartKind::World,
        PartKind::Server => live_match::PartKind::Server,
        PartKind::Robots => live_match::PartKind::Robots,
        PartKind::Bot => {
            let team = args
                .team
                .context("the bot needs --team (which team it plays)")?;
            if !plan.teams.contains(&team) {
                anyhow::bail!("--team {team}: no such team");
            }
            live_match::PartKind::Bot(team)
        }
    };
    let stop = super::stop_flag()?;
    // A part runs for as long as the match: say what it is, so a terminal
    // of several parts tells which is which.
    println!(
        "colony game: the {} of a {} match on {}, through the hub at {}; Ctrl-C stops",
        args.part.name(),
        plan.rules.mode,
        plan.map,
        args.hub.addr
    );
    live_match::run_part(&plan, &part, &args.hub.addr, args.speed, &stop)?;
    println!("colony game: the {} stopped", args.part.name());
    Ok(())
}
