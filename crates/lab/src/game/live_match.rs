//! A whole match as one library call: the checked plan every part agrees on
//! ([`MatchPlan`]), the parts started as threads over a hub, each with a hub
//! client of its own, and a supervisor that watches the match's events until
//! it is stopped ([`LiveMatch`]); one part on its own ([`run_part`], so the
//! parts can be separate processes); and the same match fast-forwarded in
//! memory ([`fast_forward`]). `colony game` is argument parsing around these.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use colony_client::{ConnectError, UdpClient};
use colony_game::bot::Bot;
use colony_game::live::{self, LiveError};
use colony_game::lobby::Lobby;
use colony_game::logic::{roster, RobotEntry, SetupError};
use colony_game::map::{shipped_map, Battlefield, MapError};
use colony_game::matches::{Match, MatchError};
use colony_game::protocol::{self, Event, GameState, Status};
use colony_game::robot_node::RobotNode;
use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_game::server::Server;
use colony_game::world::GameWorld;
use colony_sim::field::FieldConfig;
use colony_sim::SimError;

/// Why a match could not be set up, run or finished.
#[derive(Debug, thiserror::Error)]
pub enum LiveMatchError {
    /// The map cannot be read.
    #[error("cannot use the map `{path}`", path = .path.display())]
    Map {
        /// The map file.
        path: PathBuf,
        /// What is wrong with it.
        source: MapError,
    },
    /// The teams do not fit the rules or the map.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The simulator refused the battlefield.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The in-memory match could not start.
    #[error(transparent)]
    Match(#[from] MatchError),
    /// A hub client could not be made.
    #[error(transparent)]
    Connect(#[from] ConnectError),
    /// A part failed.
    #[error(transparent)]
    Live(#[from] LiveError),
    /// A part's thread could not be started.
    #[error("cannot start a thread for a part of the match")]
    Thread(#[source] std::io::Error),
    /// A part's thread ended while the match ran.
    #[error("a part of the match (thread {0}) stopped")]
    PartStopped(usize),
    /// A part's thread panicked.
    #[error("a part panicked")]
    PartPanicked,
    /// Something the match ran with (such as the monitor) stopped.
    #[error("{0} stopped")]
    CompanionStopped(String),
    /// The fast-forwarded match ended without publishing its state.
    #[error("the match published no state")]
    NoState,
}

/// Everything the parts of a match must agree on, checked.
#[derive(Debug, Clone)]
pub struct MatchPlan {
    /// Where the map came from: its file, or the one built in, for people to read.
    pub map: String,
    /// The battlefield read from it.
    pub field: Arc<Battlefield>,
    /// The rules.
    pub rules: Rules,
    /// Every robot, with the id all parts give it.
    pub roster: Vec<RobotEntry>,
    /// The teams' names, in order.
    pub teams: Vec<String>,
}

impl MatchPlan {
    /// Reads the map at `map` and places the teams' robots on it.
    pub fn new(map: &Path, rules: Rules, teams: &[TeamSetup]) -> Result<MatchPlan, LiveMatchError> {
        let field = Battlefield::from_file(map).map_err(|source| LiveMatchError::Map {
            path: map.to_path_buf(),
            source,
        })?;
        MatchPlan::on(map.display().to_string(), field, rules, teams)
    }

    /// A match on the map built in for its mode ([`shipped_map`]), so an
    /// installed binary plays from any directory.
    pub fn shipped(rules: Rules, teams: &[TeamSetup]) -> Result<MatchPlan, LiveMatchError> {
        let name = shipped_map_name(rules.mode);
        let field =
            Battlefield::parse(shipped_map(rules.mode)).map_err(|source| LiveMatchError::Map {
                path: PathBuf::from(name),
                source,
            })?;
        MatchPlan::on(format!("{name} (built in)"), field, rules, teams)
    }

    fn on(
        map: String,
        field: Battlefield,
        rules: Rules,
        teams: &[TeamSetup],
    ) -> Result<MatchPlan, LiveMatchError> {
        let roster = roster(&field, &rules, teams)?;
        Ok(MatchPlan {
            map,
            field: Arc::new(field),
            rules,
            roster,
            teams: teams.iter().map(|t| t.name.clone()).collect(),
        })
    }
}

/// The name of the map a mode plays on unless told otherwise.
pub fn shipped_map_name(mode: Mode) -> &'static str {
    match mode {
        Mode::CaptureTheFlag => "maps/ctf.map",
        Mode::DeathMatch => "maps/dm.map",
    }
}

/// Whether an event is worth a line on a terminal: not every hit, and not
/// the shots robots fire in the moment before they learn their target is gone.
pub fn worth_printing(e: &Event) -> bool {
    match e.kind.as_str() {
        "hit" | "beep" => false,
        "refused" => !e.text.contains(" fires at "),
        _ => true,
    }
}

/// An event as a terminal line.
pub fn event_line(e: &Event) -> String {
    format!("{:>7.1} s  {}: {}", e.time, e.kind, e.text)
}

/// The outcome of a finished match as one line: winner, reason, score.
pub fn result_line(s: &GameState) -> String {
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

fn connect(hub: &str) -> Result<UdpClient, LiveMatchError> {
    Ok(UdpClient::connect_to(hub)?)
}

/// A part's thread.
type Part = JoinHandle<Result<(), LiveError>>;
/// A part's loop, given its own hub client and the stop flag.
type PartLoop = Box<dyn FnOnce(&mut UdpClient, &AtomicBool) -> Result<(), LiveError> + Send>;

fn spawn(
    hub: &str,
    name: String,
    stop: &Arc<AtomicBool>,
    f: PartLoop,
) -> Result<Part, LiveMatchError> {
    let mut client = connect(hub)?;
    let stop = stop.clone();
    std::thread::Builder::new()
        .name(name)
        .spawn(move || f(&mut client, &stop))
        .map_err(LiveMatchError::Thread)
}

/// Starts every robot's intelligence as a thread, each with its own hub client.
fn spawn_robots(
    plan: &MatchPlan,
    hub: &str,
    stop: &Arc<AtomicBool>,
) -> Result<Vec<Part>, LiveMatchError> {
    let mut parts = Vec::new();
    for e in &plan.roster {
        let mut node = RobotNode::new(e.id, e.build.kind);
        parts.push(spawn(
            hub,
            format!("robot-{}", e.id),
            stop,
            Box::new(move |c, s| live::run_node(&mut node, c, s)),
        )?);
    }
    Ok(parts)
}

/// Runs the pre-match over the hub at `hub` until every team is ready (the plan the match is
/// then played with, its robots placed anew) or `stop` (None). The plan's teams are where the
/// players start from; `bots` are ready from the start.
pub fn run_lobby(
    plan: &MatchPlan,
    setups: Vec<TeamSetup>,
    hub: &str,
    bots: &[String],
    stop: &AtomicBool,
) -> Result<Option<MatchPlan>, LiveMatchError> {
    let mut lobby = Lobby::new(plan.field.clone(), plan.rules.clone(), setups, bots);
    let mut client = connect(hub)?;
    let mut link = colony_node::Link::new(&mut client, Instant::now());
    colony_node::run(&mut lobby, &mut link, stop, |l, _| {
        if l.is_done() {
            std::ops::ControlFlow::Break(())
        } else {
            std::ops::ControlFlow::Continue(())
        }
    })
    .map_err(LiveError::from)?;
    if !lobby.is_done() {
        return Ok(None);
    }
    let teams = lobby.setups();
    let roster = roster(&plan.field, &plan.rules, &teams)?;
    Ok(Some(MatchPlan {
        roster,
        teams: teams.iter().map(|t| t.name.clone()).collect(),
        ..plan.clone()
    }))
}

/// Which part of a match to run on its own.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PartKind {
    /// The simulated battlefield.
    World,
    /// Game logic and swarm intelligence.
    Server,
    /// Every robot's intelligence, one hub client each.
    Robots,
    /// The scripted player for this team.
    Bot(String),
}

/// Runs one part of the match over the hub at `hub` until `stop` is set.
pub fn run_part(
    plan: &MatchPlan,
    part: &PartKind,
    hub: &str,
    speed: f64,
    stop: &Arc<AtomicBool>,
) -> Result<(), LiveMatchError> {
    match part {
        PartKind::World => {
            let mut client = connect(hub)?;
            let mut world = GameWorld::new(&plan.field, &plan.roster)?;
            let step = FieldConfig::default().control_step;
            live::run_world(&mut world, &mut client, step, speed, None, stop)?;
        }
        PartKind::Server => {
            let mut client = connect(hub)?;
            let mut server =
                Server::new(plan.field.clone(), plan.rules.clone(), plan.roster.clone());
            live::run_node(&mut server, &mut client, stop)?;
        }
        PartKind::Robots => {
            for p in spawn_robots(plan, hub, stop)? {
                p.join().map_err(|_| LiveMatchError::PartPanicked)??;
            }
        }
        PartKind::Bot(team) => {
            let mut client = connect(hub)?;
            live::run_node(&mut Bot::new(team), &mut client, stop)?;
        }
    }
    Ok(())
}

/// A match running over a hub: world, server, robots and bots, each a thread
/// with a hub client of its own.
pub struct LiveMatch {
    hub: String,
    parts: Vec<Part>,
}

impl LiveMatch {
    /// Starts every part of the match over the hub at `hub`, the world at
    /// `speed` times real time, with scripted players for the teams in `bots`.
    pub fn start(
        plan: &MatchPlan,
        hub: &str,
        speed: f64,
        bots: &[String],
        stop: &Arc<AtomicBool>,
    ) -> Result<LiveMatch, LiveMatchError> {
        let mut parts = Vec::new();
        let mut world = GameWorld::new(&plan.field, &plan.roster)?;
        let step = FieldConfig::default().control_step;
        parts.push(spawn(
            hub,
            "game-world".into(),
            stop,
            Box::new(move |c, s| live::run_world(&mut world, c, step, speed, None, s)),
        )?);
        let mut server = Server::new(plan.field.clone(), plan.rules.clone(), plan.roster.clone());
        parts.push(spawn(
            hub,
            "game-server".into(),
            stop,
            Box::new(move |c, s| live::run_node(&mut server, c, s)),
        )?);
        parts.extend(spawn_robots(plan, hub, stop)?);
        for team in bots {
            let mut bot = Bot::new(team);
            parts.push(spawn(
                hub,
                format!("bot-{team}"),
                stop,
                Box::new(move |c, s| live::run_node(&mut bot, c, s)),
            )?);
        }
        Ok(LiveMatch {
            hub: hub.to_string(),
            parts,
        })
    }

    /// Watches the match until `stop` is set, `deadline` passes, a part
    /// ends, or `companion` names something the match needs that stopped.
    /// Each event worth a line, and the result once the match is over, go to
    /// `line`. Then stops every part and waits for them; the first failure
    /// is the error.
    pub fn supervise(
        self,
        stop: &AtomicBool,
        deadline: Option<Instant>,
        mut companion: impl FnMut() -> Option<String>,
        mut line: impl FnMut(&str),
    ) -> Result<(), LiveMatchError> {
        let mut outcome = self.watch(stop, deadline, &mut companion, &mut line);
        stop.store(true, Ordering::Relaxed);
        for p in self.parts {
            match p.join() {
                Ok(Err(e)) if outcome.is_ok() => outcome = Err(e.into()),
                Err(_) if outcome.is_ok() => outcome = Err(LiveMatchError::PartPanicked),
                _ => {}
            }
        }
        outcome
    }

    fn watch(
        &self,
        stop: &AtomicBool,
        deadline: Option<Instant>,
        companion: &mut dyn FnMut() -> Option<String>,
        line: &mut dyn FnMut(&str),
    ) -> Result<(), LiveMatchError> {
        let mut watcher = connect(&self.hub)?;
        watcher
            .subscribe(protocol::STATE)
            .and_then(|()| watcher.subscribe(protocol::EVENT))
            .map_err(LiveError::from)?;
        let mut over = false;
        while !stop.load(Ordering::Relaxed) && deadline.is_none_or(|d| Instant::now() < d) {
            watcher
                .wait(Some(Instant::now() + Duration::from_millis(100)))
                .map_err(LiveError::from)?;
            watcher.poll(Instant::now()).map_err(LiveError::from)?;
            while let Some(packet) = watcher.recv().map_err(LiveError::from)? {
                if let Ok(e) = Event::decode(&packet) {
                    if worth_printing(&e) {
                        line(&event_line(&e));
                    }
                } else if let Ok(s) = GameState::decode(&packet) {
                    if s.status == Status::Over && !over {
                        over = true;
                        line(&result_line(&s));
                    }
                }
            }
            if let Some(i) = self.parts.iter().position(|p| p.is_finished()) {
                return Err(LiveMatchError::PartStopped(i));
            }
            if let Some(what) = companion() {
                return Err(LiveMatchError::CompanionStopped(what));
            }
        }
        Ok(())
    }
}

/// What a fast-forwarded match did.
#[derive(Debug, Clone)]
pub struct FastOutcome {
    /// The final state's [`result_line`].
    pub result: String,
    /// Control steps simulated.
    pub steps: u64,
    /// Seconds of game time.
    pub game_time: f64,
    /// Packets that crossed the in-memory bus.
    pub packets: u64,
}

/// Plays the whole match in this process with every team scripted, as fast
/// as it computes, until it is over or its time limit passes. Every packet
/// goes to `tap` with its game time; each event worth a line goes to `line`.
pub fn fast_forward(
    plan: &MatchPlan,
    teams: &[TeamSetup],
    tap: &mut dyn FnMut(f64, &[u8]),
    line: &mut dyn FnMut(&str),
) -> Result<FastOutcome, LiveMatchError> {
    let bots: Vec<&str> = plan.teams.iter().map(String::as_str).collect();
    let mut m = Match::new(plan.field.clone(), plan.rules.clone(), teams, &bots)?;
    // `as u64` saturates on a time limit too long to count; the sum must too.
    let steps = ((plan.rules.time_limit_s / FieldConfig::default().control_step).ceil() as u64)
        .saturating_add(1);
    let mut shown = 0;
    while !m.is_over() && m.world().field().step_count() < steps {
        m.step(tap);
        for e in &m.events()[shown..] {
            if worth_printing(e) {
                line(&event_line(e));
            }
        }
        shown = m.events().len();
    }
    m.step(tap);
    let state = m.state().ok_or(LiveMatchError::NoState)?;
    Ok(FastOutcome {
        result: result_line(state),
        steps: m.world().field().step_count(),
        game_time: m.world().time(),
        packets: m.traffic().0,
    })
}
