//! `colony game`: the strategy game. `ctf` and `dm` start a whole match
//! (hub, monitor, world, game server, one hub client per robot, scripted
//! players), live or fast-forwarded; `part` runs one part of a match on its
//! own, so the parts can be separate processes that restart independently.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant, UNIX_EPOCH};

use anyhow::Context as _;
use colony_client::UdpClient;
use colony_game::bot::Bot;
use colony_game::live;
use colony_game::logic::{roster, RobotEntry};
use colony_game::map::Battlefield;
use colony_game::matches::Match;
use colony_game::protocol::{self, Event, GameState, Status};
use colony_game::robot_node::RobotNode;
use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_game::server::Server as GameServer;
use colony_game::world::GameWorld;
use colony_hub::log::LogWriter;
use colony_hub::{HubConfig, Server as HubServer};
use colony_monitor::{Monitor, MonitorConfig};
use colony_sim::field::FieldConfig;

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
    #[arg(long, default_value_t = 600.0)]
    pub time_limit: f64,
}

#[derive(clap::Args, Debug)]
pub struct MatchArgs {
    #[command(flatten)]
    pub setup: Setup,
    /// The team a person plays from the monitor's game page against the
    /// built-in scripted opponent; `none` to watch two scripted teams.
    /// (With --fast every team is scripted.)
    #[arg(long, default_value = "red")]
    pub player: String,
    /// Fast-forward the whole match in this process, with no hub, and print the result.
    #[arg(long)]
    pub fast: bool,
    /// Write every packet of the match to this traffic log (`colony replay` shows it).
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// How many times faster than real time the world runs (live).
    #[arg(long, default_value_t = 1.0)]
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
    #[arg(long)]
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
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    #[command(flatten)]
    pub hub: super::HubAddr,
}

pub fn run(cmd: GameCommand) -> anyhow::Result<()> {
    match cmd {
        GameCommand::Ctf(a) => play(Mode::CaptureTheFlag, a),
        GameCommand::Dm(a) => play(Mode::DeathMatch, a),
        GameCommand::Part(a) => part(a),
    }
}

/// The map a mode plays on by default: the repository's, from wherever we run.
fn default_map(mode: Mode) -> PathBuf {
    let name = match mode {
        Mode::CaptureTheFlag => "ctf.map",
        Mode::DeathMatch => "dm.map",
    };
    let here = Path::new("maps").join(name);
    if here.exists() {
        return here;
    }
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../maps")
        .join(name)
}

/// Everything a part needs, checked.
struct Game {
    map: PathBuf,
    field: Arc<Battlefield>,
    rules: Rules,
    roster: Vec<RobotEntry>,
    teams: Vec<String>,
}

fn load(mode: Mode, setup: &Setup) -> anyhow::Result<Game> {
    let path = setup.map.clone().unwrap_or_else(|| default_map(mode));
    let field = Battlefield::from_file(&path)
        .with_context(|| format!("cannot use the map `{}`", path.display()))?;
    if !(setup.time_limit.is_finite() && setup.time_limit > 0.0) {
        anyhow::bail!("--time-limit must be a positive number of seconds");
    }
    let mut rules = Rules::new(mode);
    rules.budget = setup.budget;
    rules.time_limit_s = setup.time_limit;
    let teams = vec![
        TeamSetup::parse("red", &setup.red).context("--red")?,
        TeamSetup::parse("blue", &setup.blue).context("--blue")?,
    ];
    let roster = roster(&field, &rules, &teams)?;
    Ok(Game {
        map: path,
        field: Arc::new(field),
        rules,
        roster,
        teams: teams.into_iter().map(|t| t.name).collect(),
    })
}

fn play(mode: Mode, args: MatchArgs) -> anyhow::Result<()> {
    let game = load(mode, &args.setup)?;
    let p = &args.player;
    if p != "none" && !game.teams.contains(p) {
        anyhow::bail!(
            "--player {p}: no such team (teams: {}, or none)",
            game.teams.join(", ")
        );
    }
    if args.fast {
        return fast(game, &args);
    }
    if !(args.speed.is_finite() && args.speed > 0.0) {
        anyhow::bail!("--speed must be a positive number, not {}", args.speed);
    }
    let stop = super::stop_flag()?;
    let mut hub_thread = None;
    let hub_addr = match &args.hub {
        Some(a) => a.clone(),
        None => {
            let mut server = HubServer::bind(args.hub_bind.as_str(), HubConfig::default())
                .with_context(|| {
                    format!(
                        "cannot start the match's hub on `{}` (is one running there? choose another port with --hub-bind, or join it with --hub)",
                        args.hub_bind
                    )
                })?;
            if let Some(path) = &args.record {
                let (log, _) = LogWriter::open(path)?;
                server = server.with_log(log);
            }
            let addr = server.local_addr()?.to_string();
            let s = stop.clone();
            hub_thread = Some(
                std::thread::Builder::new()
                    .name("game-hub".into())
                    .spawn(move || server.run(&s))?,
            );
            addr
        }
    };
    let result = live_match(&game, &args, &hub_addr, &stop);
    stop.store(true, Ordering::Relaxed);
    if let Some(h) = hub_thread {
        h.join()
            .map_err(|_| anyhow::anyhow!("the hub thread panicked"))?
            .context("the match's hub failed")?;
    }
    result
}

fn connect(hub: &str) -> anyhow::Result<UdpClient> {
    UdpClient::connect(hub).with_context(|| format!("cannot reach a hub at `{hub}`"))
}

type Parts = Vec<std::thread::JoinHandle<anyhow::Result<()>>>;
/// A part's loop, given its own hub client and the stop flag.
type PartLoop = Box<dyn FnOnce(&mut UdpClient, &AtomicBool) -> anyhow::Result<()> + Send>;

/// Starts the parts of a match as threads, each with its own hub client.
fn spawn_parts(
    game: &Game,
    bots: &[String],
    hub: &str,
    speed: f64,
    stop: &Arc<AtomicBool>,
) -> anyhow::Result<Parts> {
    let mut parts: Parts = Vec::new();
    let spawn = |name: String, parts: &mut Parts, f: PartLoop| -> anyhow::Result<()> {
        let mut client = connect(hub)?;
        let stop = stop.clone();
        parts.push(
            std::thread::Builder::new()
                .name(name)
                .spawn(move || f(&mut client, &stop))?,
        );
        Ok(())
    };
    let mut world = GameWorld::new(&game.field, &game.roster)?;
    let step = FieldConfig::default().control_step;
    spawn(
        "game-world".into(),
        &mut parts,
        Box::new(move |c, s| Ok(live::run_world(&mut world, c, step, speed, None, s)?)),
    )?;
    let mut server = GameServer::new(game.field.clone(), game.rules.clone(), game.roster.clone());
    spawn(
        "game-server".into(),
        &mut parts,
        Box::new(move |c, s| Ok(live::run_node(&mut server, c, s)?)),
    )?;
    parts.extend(spawn_robots(game, hub, stop)?);
    for team in bots {
        let mut bot = Bot::new(team);
        spawn(
            format!("bot-{team}"),
            &mut parts,
            Box::new(move |c, s| Ok(live::run_node(&mut bot, c, s)?)),
        )?;
    }
    Ok(parts)
}

fn live_match(
    game: &Game,
    args: &MatchArgs,
    hub: &str,
    stop: &Arc<AtomicBool>,
) -> anyhow::Result<()> {
    let monitor = if args.no_monitor {
        None
    } else {
        Some(
            Monitor::start(&MonitorConfig {
                hub: hub.to_string(),
                bind: args.monitor_bind.clone(),
            })
            .map_err(|e| match e {
                colony_monitor::MonitorError::Bind { addr, source } => anyhow::anyhow!(
                    "cannot serve the monitor on `{addr}`: {source} (choose another port with --monitor-bind, or --no-monitor)"
                ),
                e => e.into(),
            })?,
        )
    };
    let bots: Vec<String> = game
        .teams
        .iter()
        .filter(|t| **t != args.player)
        .cloned()
        .collect();
    let parts = spawn_parts(game, &bots, hub, args.speed, stop)?;
    match &monitor {
        Some(m) => println!(
            "colony game: {} on {} ({} x {} cells); open {}/game{} (hub {hub}); Ctrl-C stops",
            game.rules.mode,
            game.map.display(),
            game.field.grid.width(),
            game.field.grid.height(),
            m.url().trim_end_matches('/'),
            if args.player == "none" {
                String::new()
            } else {
                format!("?team={}", args.player)
            }
        ),
        None => println!(
            "colony game: {} running (hub {hub}); Ctrl-C stops",
            game.rules.mode
        ),
    }
    let mut watcher = connect(hub)?;
    watcher.subscribe(protocol::STATE)?;
    watcher.subscribe(protocol::EVENT)?;
    let deadline = args
        .seconds
        .map(|s| Instant::now() + Duration::from_secs_f64(s.max(0.0)));
    let mut over = false;
    let mut outcome = Ok(());
    while !stop.load(Ordering::Relaxed) && deadline.is_none_or(|d| Instant::now() < d) {
        watcher.wait(Some(Instant::now() + Duration::from_millis(100)))?;
        watcher.poll(Instant::now())?;
        while let Some(packet) = watcher.recv()? {
            if let Ok(e) = Event::decode(&packet) {
                if worth_printing(&e) {
                    println!("{:>7.1} s  {}: {}", e.time, e.kind, e.text);
                }
            } else if let Ok(s) = GameState::decode(&packet) {
                if s.status == Status::Over && !over {
                    over = true;
                    println!("{}", result_line(&s));
                }
            }
        }
        if let Some(i) = parts.iter().position(|p| p.is_finished()) {
            outcome = Err(anyhow::anyhow!("a part of the match (thread {i}) stopped"));
            break;
        }
        if monitor.as_ref().is_some_and(|m| !m.is_running()) {
            outcome = Err(anyhow::anyhow!("the monitor stopped"));
            break;
        }
    }
    stop.store(true, Ordering::Relaxed);
    for p in parts {
        match p.join() {
            Ok(Err(e)) if outcome.is_ok() => outcome = Err(e),
            Err(_) if outcome.is_ok() => outcome = Err(anyhow::anyhow!("a part panicked")),
            _ => {}
        }
    }
    if let Some(m) = monitor {
        m.shutdown()?;
    }
    outcome
}

/// Whether an event is worth a line on the terminal: not every hit, and not
/// the shots robots fire in the moment before they learn their target is gone.
fn worth_printing(e: &Event) -> bool {
    match e.kind.as_str() {
        "hit" | "beep" => false,
        "refused" => !e.text.contains(" fires at "),
        _ => true,
    }
}

fn result_line(s: &GameState) -> String {
    let score: Vec<String> = s
        .teams
        .iter()
        .map(|t| format!("{} {} (kills {})", t.name, t.score, t.kills))
        .collect();
    format!(
        "result: {} ({}) after {:.1} s of game time; score {}",
        s.winner
            .as_ref()
            .map_or("a draw".to_string(), |w| format!("{w} wins")),
        s.reason,
        s.time,
        score.join(", ")
    )
}

fn fast(game: Game, args: &MatchArgs) -> anyhow::Result<()> {
    let bots: Vec<&str> = game.teams.iter().map(String::as_str).collect();
    let teams: Vec<TeamSetup> = vec![
        TeamSetup::parse("red", &args.setup.red)?,
        TeamSetup::parse("blue", &args.setup.blue)?,
    ];
    let mut m = Match::new(game.field.clone(), game.rules.clone(), &teams, &bots)?;
    let mut log = match &args.record {
        Some(path) => Some(LogWriter::open(path)?.0),
        None => None,
    };
    let source: std::net::SocketAddr = ([127, 0, 0, 1], 0).into();
    let mut log_error = None;
    let mut tap = |t: f64, p: &[u8]| {
        if let Some(w) = &mut log {
            let at = UNIX_EPOCH + Duration::from_secs_f64(t.max(0.0));
            if let Err(e) = w.append(at, source, p) {
                log_error.get_or_insert(e);
            }
        }
    };
    let steps = (game.rules.time_limit_s / FieldConfig::default().control_step).ceil() as u64 + 1;
    let t0 = Instant::now();
    let mut shown = 0;
    while !m.is_over() && m.world().field().step_count() < steps {
        m.step(&mut tap);
        for e in &m.events()[shown..] {
            if worth_printing(e) {
                println!("{:>7.1} s  {}: {}", e.time, e.kind, e.text);
            }
        }
        shown = m.events().len();
    }
    m.step(&mut tap);
    let wall = t0.elapsed().as_secs_f64();
    if let Some(e) = log_error {
        return Err(e).context("cannot write the traffic log");
    }
    if let Some(w) = &mut log {
        w.flush().context("cannot write the traffic log")?;
    }
    let state = m.state().context("the match published no state")?;
    println!("{}", result_line(state));
    let game_time = m.world().time();
    println!(
        "{} steps, {:.1} s of game time in {:.2} s ({:.0}x real time); {} packets",
        m.world().field().step_count(),
        game_time,
        wall,
        game_time / wall.max(1e-9),
        m.traffic().0
    );
    Ok(())
}

fn part(args: PartArgs) -> anyhow::Result<()> {
    let mode: Mode = args.mode.parse()?;
    let game = load(mode, &args.setup)?;
    let stop = super::stop_flag()?;
    let mut client = args.hub.connect()?;
    match args.part {
        PartKind::World => {
            let mut world = GameWorld::new(&game.field, &game.roster)?;
            let step = FieldConfig::default().control_step;
            live::run_world(&mut world, &mut client, step, args.speed, None, &stop)?;
        }
        PartKind::Server => {
            let mut server = GameServer::new(game.field.clone(), game.rules, game.roster);
            live::run_node(&mut server, &mut client, &stop)?;
        }
        PartKind::Robots => {
            drop(client);
            let parts = spawn_robots(&game, &args.hub.addr, &stop)?;
            for p in parts {
                p.join()
                    .map_err(|_| anyhow::anyhow!("a robot thread panicked"))??;
            }
        }
        PartKind::Bot => {
            let team = args
                .team
                .context("the bot needs --team (which team it plays)")?;
            if !game.teams.contains(&team) {
                anyhow::bail!("--team {team}: no such team");
            }
            live::run_node(&mut Bot::new(&team), &mut client, &stop)?;
        }
    }
    Ok(())
}

fn spawn_robots(game: &Game, hub: &str, stop: &Arc<AtomicBool>) -> anyhow::Result<Parts> {
    let mut parts: Parts = Vec::new();
    for e in &game.roster {
        let mut client = connect(hub)?;
        let mut node = RobotNode::new(e.id, e.kind);
        let stop = stop.clone();
        parts.push(
            std::thread::Builder::new()
                .name(format!("robot-{}", e.id))
                .spawn(move || Ok(live::run_node(&mut node, &mut client, &stop)?))?,
        );
    }
    Ok(parts)
}
