//! The game as a multi-agent learning environment (PettingZoo's ParallelEnv shape, for the
//! Python package to wrap): the agents are the robots of one team, the learner; the other team
//! is played by the scripted [`Bot`](colony_game::bot::Bot) or stands idle.
//!
//! **The rules are the game's.** Underneath is a [`Match`]: the world on the simulator's
//! field, the game server with its referee and squad arbitrators, every robot's brain and the
//! scripted player, exchanging their packets through the real sans-IO hub with no latency.
//! The environment only adds packets a player and a robot could send, and reads what the
//! match shows: the world's poses, the referee's health, reloads, flags, scores and its
//! per-robot [`RobotTally`], from which rewards are differences.
//!
//! **How actions reach the game** (never around the referee):
//!
//! - *Wheels* ([`RobotAction::forward`], [`RobotAction::turn`]) go as the player's `drive`
//!   command on `game.player.TEAM`: the server takes the robot out of its squad's hands and
//!   orders its brain to hold the wheels, and the brain's reflexes (bump, border, sonar) still
//!   outrank the drive. The fractions are brought into range by proto's one clamp rule
//!   ([`colony_proto::WheelCommand::clamped`]: [-1, 1], NaN as 0).
//! - *Shots and pick-ups* ([`RobotAction::fire`], [`RobotAction::pickup`]) go as the robot's
//!   own requests on `game.action`, which is where a squad's `shoot` order ends up too (the
//!   squad tells the robot whom to shoot, the robot asks the referee). The referee checks range,
//!   reload, a destroyed shooter or target, the team and the flag's reach, and refuses what
//!   the rules don't allow; refusals are counted ([`StepInfo::refused`]) and change nothing
//!   else. The referee does not look at the shooter's heading, so neither does a learner's shot.
//!   A destroyed agent's actions are dropped (its player can no longer drive it).
//! - *Squad orders* ([`SquadOrder`]) go as the player's squad commands, carried out by the
//!   server's own squad behaviours (shoot > avoid-squads > order > hold), as the scripted
//!   player's are; its members keep shooting enemies in range on their own.
//!
//! **Observations**: see [`ObsLayout`] and the constants named there; every field is listed
//! in [`GameEnv::observe`]. **Rewards**: see [`RewardWeights`].
//!
//! **A step** is one control step of the world (0.1 s of game time). The actions are put on
//! the bus and delivered right after the world's physics step, as a player's command sent
//! between two steps would be: the referee rules on shots at the new poses within the same
//! step, and the wheels the brain then sets move the robot in the next step's physics. So a
//! drive shows in the observation one step later, as it does for a person at the monitor.
//!
//! **Seeds.** A match is deterministic: the same setup and the same actions give the same
//! episode. [`GameEnv::reset`]'s seed moves each robot's start within its spawn cell (up to
//! [`SPAWN_JITTER_CM`] each way) and turns it to a random heading, so different seeds give
//! different episodes and equal seeds equal ones.
//!
//! **Episodes** end when the referee says the game is over (`terminated`: a capture, one team
//! left in Death Match, or the rules' clock) or after `max_steps` steps (`truncated`). Destroyed
//! agents stay listed with zero observations and `alive` 0 until the end.

mod action;
mod observation;
mod render;
mod reward;
#[cfg(test)]
mod tests;

use std::path::Path;
use std::sync::Arc;

use colony_game::logic::{roster, RobotTally, SetupError};
use colony_game::map::{Battlefield, MapError, Terrain};
use colony_game::matches::Match;
use colony_game::protocol::Verb;
use colony_game::rules::{Mode, RobotKind, Rules, TeamSetup};
use colony_sim::field::FieldRobotId;
use colony_sim::{Pose, Vec2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub use action::{Fire, RobotAction, SquadOrder};
pub use colony_game::map::shipped_map;
pub use observation::{
    ObsLayout, FLAG_FEATURES, FLAG_TEAMS, MAX_DAMAGE, NEARBY_FEATURES, OWN_FEATURES, PATCH_CHANNELS,
};
pub use reward::RewardWeights;

/// A start is moved at most this far from its spawn cell's centre along each axis, cm: a
/// robot stays inside its cell, and the roster keeps a free cell around each.
pub const SPAWN_JITTER_CM: f64 = 5.0;
/// The learner's team by default (6 robots, 19 points of the 30-point budget).
pub const DEFAULT_LEARNER: &str = "alpha:tank,infantry,infantry bravo:scout,scout,amphibian";
/// The opponent's team by default: the learner's mirror.
pub const DEFAULT_OPPONENT: &str = DEFAULT_LEARNER;
/// A slot of the neighbour table with no robot in it.
const NO_ROBOT: u32 = u32::MAX;

/// Who plays the other team.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Opponent {
    /// The game's scripted player ([`colony_game::bot::Bot`]).
    #[default]
    Scripted,
    /// No player: its squads hold where they start, though their squad behaviour still shoots
    /// an enemy in range (that is the game's, not a player's, doing).
    Idle,
}

/// How the learner acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Control {
    /// One [`RobotAction`] per agent each step ([`GameEnv::step_robots`]).
    #[default]
    Robot,
    /// One [`SquadOrder`] per learner squad each step ([`GameEnv::step_squads`]).
    Squad,
}

/// How an environment is set up.
#[derive(Debug, Clone)]
pub struct GameEnvConfig {
    /// The battlefield.
    pub map: Arc<Battlefield>,
    /// Which game.
    pub mode: Mode,
    /// The learner's team: its name is a team of the map.
    pub learner: TeamSetup,
    /// The other team.
    pub opponent: TeamSetup,
    /// Who plays the other team.
    pub opponent_policy: Opponent,
    /// How the learner acts.
    pub control: Control,
    /// Steps after which an episode is truncated.
    pub max_steps: u64,
    /// Robots in each agent's `nearby` (K).
    pub nearby: usize,
    /// Cells per side of each agent's `patch` (P).
    pub patch: usize,
    /// What each agent is rewarded for.
    pub rewards: RewardWeights,
}

impl GameEnvConfig {
    /// The defaults for a mode on its shipped map ([`shipped_map`]).
    pub fn shipped(mode: Mode) -> Result<GameEnvConfig, EnvError> {
        GameEnvConfig::new(mode, Arc::new(Battlefield::parse(shipped_map(mode))?))
    }

    /// The defaults for a mode on the map file at `path`.
    pub fn from_path(mode: Mode, path: impl AsRef<Path>) -> Result<GameEnvConfig, EnvError> {
        GameEnvConfig::new(mode, Arc::new(Battlefield::from_file(path)?))
    }

    /// The defaults for a mode on `map`: the map's first team learns against the second's
    /// scripted player, 6 robots each ([`DEFAULT_LEARNER`]), robot-level control, 3000 steps
    /// (5 minutes of game time; the rules' own clock is 10), K = 8, P = 11, the default
    /// rewards.
    pub fn new(mode: Mode, map: Arc<Battlefield>) -> Result<GameEnvConfig, EnvError> {
        let team = |i: usize| {
            map.teams
                .get(i)
                .map(|t| t.name.clone())
                .ok_or(EnvError::Teams)
        };
        let (first, second) = (team(0)?, team(1)?);
        let parse = |name: &str, text: &str| {
            TeamSetup::parse(name, text).map_err(|e| EnvError::Setup(SetupError::Rules(e)))
        };
        Ok(GameEnvConfig {
            learner: parse(&first, DEFAULT_LEARNER)?,
            opponent: parse(&second, DEFAULT_OPPONENT)?,
            map,
            mode,
            opponent_policy: Opponent::Scripted,
            control: Control::Robot,
            max_steps: 3000,
            nearby: 8,
            patch: 11,
            rewards: RewardWeights::default(),
        })
    }
}

/// Why an environment can't be made or stepped.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The map does not read.
    #[error(transparent)]
    Map(#[from] MapError),
    /// The teams don't fit the rules or the map.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The simulator refused the battlefield.
    #[error(transparent)]
    Sim(#[from] colony_sim::SimError),
    /// Learner and opponent must be two different teams of the map.
    #[error("the learner and the opponent must be two different teams of the map")]
    Teams,
    /// A patch of no cells.
    #[error("the patch needs at least one cell per side")]
    Patch,
    /// Actions or orders of the wrong number.
    #[error("{expected} {what} expected, {got} given")]
    ActionCount {
        /// Actions or orders.
        what: &'static str,
        /// How many there must be.
        expected: usize,
        /// How many came.
        got: usize,
    },
    /// An observation buffer of the wrong length.
    #[error("the {part} buffer holds {got} numbers; {expected} expected")]
    BufferLength {
        /// Which part.
        part: &'static str,
        /// Its length for every agent.
        expected: usize,
        /// The buffer's.
        got: usize,
    },
    /// The step called does not match the configured control.
    #[error("this environment is set up for {0:?} control")]
    WrongControl(Control),
    /// The episode ended; reset first.
    #[error("the episode is over; reset it")]
    EpisodeOver,
}

/// One agent: a robot of the learner's team.
#[derive(Debug, Clone, PartialEq)]
pub struct AgentInfo {
    /// Its robot id in the match (the roster's).
    pub robot: u32,
    /// Its type.
    pub kind: RobotKind,
    /// The squad it starts in.
    pub squad: String,
}

/// What one step brought.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StepInfo {
    /// Each agent's reward for the step (see [`RewardWeights`]).
    pub rewards: Vec<f64>,
    /// The game is over.
    pub terminated: bool,
    /// `max_steps` reached with the game still on.
    pub truncated: bool,
    /// Steps taken this episode.
    pub steps: u64,
    /// The learner's and the opponent's scores (captures, or kills in Death Match).
    pub score: [u32; 2],
    /// The winner's team, once the game is over and someone won.
    pub winner: Option<String>,
    /// The learner's shots and pick-ups the referee refused this step.
    pub refused: u32,
    /// The learner's squad commands the server refused this step.
    pub refused_orders: u32,
    /// Shots at an empty `nearby` slot (nothing sent).
    pub invalid: u32,
}

/// One robot as the environment last saw it.
#[derive(Debug, Clone)]
struct Seen {
    /// 0: the learner's; 1: the opponent's.
    team: u8,
    kind: RobotKind,
    pose: Pose,
    /// World frame, cm/s.
    vel: Vec2,
    /// rad/s.
    omega: f64,
    alive: bool,
    health: f64,
    max_health: f64,
    damage: f64,
    reload_left: f64,
    carrying: bool,
    tally: RobotTally,
}

/// A team's flag as last seen.
#[derive(Debug, Clone, Copy)]
struct FlagSeen {
    at: Vec2,
    home: Vec2,
    carrier: Option<u32>,
}

/// A learning environment on one match.
pub struct GameEnv {
    config: GameEnvConfig,
    field: Arc<Battlefield>,
    rules: Rules,
    teams: [String; 2],
    game: Match,
    agents: Vec<AgentInfo>,
    /// The learner's squads, in setup order, and the verb each was last given.
    squads: Vec<(String, Option<Verb>)>,
    steps: u64,
    seen: Vec<Seen>,
    /// Per team (learner, opponent); `None` in Death Match.
    flags: [Option<FlagSeen>; 2],
    bases: [Option<Vec2>; 2],
    scores: [u32; 2],
    /// Agent-major, `nearby` slots each: robot ids, nearest first.
    neighbours: Vec<u32>,
    /// The map's cells, row-major from the top row: OPEN, WALL or WATER.
    cells: Vec<u8>,
    /// The map's longer side, cm: relative positions are divided by it.
    scale: f64,
    record: bool,
    packets: Vec<Vec<u8>>,
    over: bool,
    /// Reused for the packets of one step.
    outbox: Vec<Vec<u8>>,
}

impl GameEnv {
    /// An environment in its first episode, started with `seed`.
    pub fn new(config: GameEnvConfig, seed: u64) -> Result<GameEnv, EnvError> {
        if config.learner.name == config.opponent.name
            || config.map.team(&config.learner.name).is_none()
            || config.map.team(&config.opponent.name).is_none()
        {
            return Err(EnvError::Teams);
        }
        if config.patch == 0 {
            return Err(EnvError::Patch);
        }
        let field = config.map.clone();
        let rules = Rules::new(config.mode);
        let cells = field
            .grid
            .cells()
            .iter()
            .map(|t| match t {
                Terrain::Open | Terrain::Swamp => observation::OPEN,
                Terrain::Water => observation::WATER,
                Terrain::Tree | Terrain::OutOfBounds => observation::WALL,
            })
            .collect();
        let (w, h) = field.size_cm();
        let teams = [config.learner.name.clone(), config.opponent.name.clone()];
        let game = Self::start(&config, &field, &rules, seed)?;
        let agents: Vec<AgentInfo> = game
            .roster()
            .iter()
            .filter(|e| e.team == teams[0])
            .map(|e| AgentInfo {
                robot: e.id,
                kind: e.build.kind,
                squad: e.squad.clone(),
            })
            .collect();
        let mut env = GameEnv {
            squads: config
                .learner
                .squads
                .iter()
                .map(|s| (s.name.clone(), None))
                .collect(),
            neighbours: vec![NO_ROBOT; agents.len() * config.nearby],
            agents,
            config,
            rules,
            teams,
            game,
            steps: 0,
            seen: Vec::new(),
            flags: [None, None],
            bases: [None, None],
            scores: [0, 0],
            cells,
            scale: w.max(h),
            record: false,
            packets: Vec::new(),
            over: false,
            outbox: Vec::new(),
            field,
        };
        env.look(0.0);
        Ok(env)
    }

    /// The match for one episode: the roster with its starts moved by the seed.
    fn start(
        config: &GameEnvConfig,
        field: &Arc<Battlefield>,
        rules: &Rules,
        seed: u64,
    ) -> Result<Match, EnvError> {
        let teams = [config.learner.clone(), config.opponent.clone()];
        let mut entries = roster(field, rules, &teams)?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for e in &mut entries {
            e.spawn.x += rng.random_range(-SPAWN_JITTER_CM..=SPAWN_JITTER_CM);
            e.spawn.y += rng.random_range(-SPAWN_JITTER_CM..=SPAWN_JITTER_CM);
            e.spawn.theta = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        }
        let bots: Vec<&str> = match config.opponent_policy {
            Opponent::Scripted => vec![config.opponent.name.as_str()],
            Opponent::Idle => Vec::new(),
        };
        Ok(Match::with_roster(
            field.clone(),
            rules.clone(),
            entries,
            &bots,
        )?)
    }

    /// Starts a new episode; the same seed gives the same episode for the same actions.
    pub fn reset(&mut self, seed: u64) -> Result<(), EnvError> {
        self.game = Self::start(&self.config, &self.field, &self.rules, seed)?;
        for s in &mut self.squads {
            s.1 = None;
        }
        self.steps = 0;
        self.seen.clear();
        self.scores = [0, 0];
        self.over = false;
        self.packets.clear();
        self.look(0.0);
        Ok(())
    }

    /// The agents, one per learner robot, in roster order (the order of every per-agent array).
    pub fn agents(&self) -> &[AgentInfo] {
        &self.agents
    }

    /// The configuration.
    pub fn config(&self) -> &GameEnvConfig {
        &self.config
    }

    /// The match underneath (its world, server and referee), for reports and tests.
    pub fn game(&self) -> &Match {
        &self.game
    }

    /// Steps taken this episode.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Whether each agent's robot is still standing.
    pub fn alive(&self) -> impl Iterator<Item = bool> + '_ {
        self.agents
            .iter()
            .map(|a| self.seen[a.robot as usize].alive)
    }

    /// The learner's squads, in setup order (the order of [`GameEnv::step_squads`]' orders).
    pub fn squads(&self) -> impl Iterator<Item = &str> {
        self.squads.iter().map(|s| s.0.as_str())
    }

    /// Keeps (or stops keeping) every packet the bus carries, for [`GameEnv::take_packets`].
    pub fn set_record(&mut self, on: bool) {
        self.record = on;
        if !on {
            self.packets.clear();
        }
    }

    /// The packets the bus carried since the last call (while recording), in the order sent:
    /// the map, states, world frames, events, orders... published to a real hub they show
    /// the run on colony's monitor.
    pub fn take_packets(&mut self) -> Vec<Vec<u8>> {
        std::mem::take(&mut self.packets)
    }

    /// One step with one action per agent (robot-level control).
    pub fn step_robots(&mut self, actions: &[RobotAction]) -> Result<StepInfo, EnvError> {
        self.ready(Control::Robot, "actions", actions.len(), self.agents.len())?;
        let mut invalid = 0;
        let k = self.config.nearby;
        let mut out = std::mem::take(&mut self.outbox);
        for (i, (agent, a)) in self.agents.iter().zip(actions).enumerate() {
            // A destroyed robot's player can no longer drive it: its actions go nowhere.
            if !self.seen[agent.robot as usize].alive {
                continue;
            }
            let target = match a.fire {
                Fire::Hold => None,
                Fire::Nearest => {
                    self.nearest_enemy(self.seen[agent.robot as usize].pose.position())
                }
                Fire::Slot(s) => match self.neighbours.get(i * k + s) {
                    Some(&id) if s < k && id != NO_ROBOT => Some(id),
                    _ => {
                        invalid += 1;
                        None
                    }
                },
            };
            action::robot_packets(
                &self.teams[0],
                agent.robot,
                a,
                target,
                &self.teams[1],
                &mut out,
            );
        }
        let info = self.advance(&mut out, invalid);
        self.outbox = out;
        Ok(info)
    }

    /// One step with one order per learner squad, in [`GameEnv::squads`] order (squad-level
    /// control). An order is sent only when its verb changes (re-sending one would make the
    /// squad plan afresh each step); a squad with no robot standing is left alone.
    pub fn step_squads(&mut self, orders: &[SquadOrder]) -> Result<StepInfo, EnvError> {
        self.ready(
            Control::Squad,
            "squad orders",
            orders.len(),
            self.squads.len(),
        )?;
        let mut out = std::mem::take(&mut self.outbox);
        for (i, order) in orders.iter().enumerate() {
            let name = &self.squads[i].0;
            let members = self
                .game
                .roster()
                .iter()
                .filter(|e| e.team == self.teams[0] && &e.squad == name)
                .map(|e| &self.seen[e.id as usize])
                .filter(|s| s.alive)
                .map(|s| s.pose.position());
            let Some(c) = action::centroid(members) else {
                continue;
            };
            let verb = order.verb(&self.teams[0], &self.teams[1], self.nearest_enemy(c));
            if self.squads[i].1.as_ref() == Some(&verb) {
                continue;
            }
            out.extend(action::squad_packet(&self.teams[0], name, verb.clone()));
            self.squads[i].1 = Some(verb);
        }
        let info = self.advance(&mut out, 0);
        self.outbox = out;
        Ok(info)
    }

    fn ready(
        &self,
        control: Control,
        what: &'static str,
        got: usize,
        expected: usize,
    ) -> Result<(), EnvError> {
        if self.config.control != control {
            return Err(EnvError::WrongControl(self.config.control));
        }
        if got != expected {
            return Err(EnvError::ActionCount {
                what,
                expected,
                got,
            });
        }
        if self.over {
            return Err(EnvError::EpisodeOver);
        }
        Ok(())
    }

    /// The living opponent robot nearest `p` (ties by id).
    fn nearest_enemy(&self, p: Vec2) -> Option<u32> {
        self.seen
            .iter()
            .enumerate()
            .filter(|(_, s)| s.alive && s.team == 1)
            .min_by(|a, b| {
                a.1.pose
                    .position()
                    .distance(p)
                    .total_cmp(&b.1.pose.position().distance(p))
            })
            .map(|(id, _)| id as u32)
    }

    /// Sends the step's packets, steps the match, and reads what came of it.
    fn advance(&mut self, out: &mut Vec<Vec<u8>>, invalid: u32) -> StepInfo {
        for p in out.drain(..) {
            self.game.send(p);
        }
        if self.record {
            let packets = &mut self.packets;
            self.game.step(&mut |_, p| packets.push(p.to_vec()));
        } else {
            self.game.step(&mut |_, _| {});
        }
        let learner = format!("{} ", self.teams[0]);
        let refused_orders = self
            .game
            .events()
            .iter()
            .filter(|e| e.kind == "refused" && e.text.starts_with(&learner))
            .count() as u32;
        self.game.clear_events();
        self.steps += 1;
        let before: Vec<(RobotTally, bool)> =
            self.seen.iter().map(|s| (s.tally, s.alive)).collect();
        let scores = self.scores;
        self.look(self.game.world().field().config().control_step);
        let referee = self.game.server().referee();
        self.over = referee.is_over();
        let mut info = StepInfo {
            terminated: self.over,
            truncated: !self.over && self.steps >= self.config.max_steps,
            steps: self.steps,
            score: self.scores,
            winner: referee.winner().map(str::to_string),
            refused_orders,
            invalid,
            ..StepInfo::default()
        };
        info.refused = self
            .agents
            .iter()
            .map(|a| {
                let id = a.robot as usize;
                self.seen[id].tally.refused - before[id].0.refused
            })
            .sum();
        info.rewards = self.rewards(&before, scores, &info);
        if info.truncated {
            self.over = true;
        }
        info
    }

    /// Reads the match: poses from the world, the rest from the referee; then each agent's
    /// nearest robots. `dt` is the time since the last look (0 at a reset: no motion yet).
    fn look(&mut self, dt: f64) {
        let referee = self.game.server().referee();
        let world = self.game.world().field();
        let fresh = self.seen.is_empty();
        for (id, e) in self.game.roster().iter().enumerate() {
            let rid = id as u32;
            let pose = world.robot_pose(FieldRobotId(id)).unwrap_or(e.spawn);
            let (_, alive) = referee.robot(rid).unwrap_or((pose, false));
            let carrying = self
                .teams
                .iter()
                .any(|t| referee.flag_at(t).is_some_and(|f| f.1 == Some(rid)));
            let mut s = Seen {
                team: u8::from(e.team != self.teams[0]),
                kind: e.build.kind,
                pose,
                vel: Vec2::ZERO,
                omega: 0.0,
                alive,
                health: referee.health(rid).unwrap_or(0.0),
                max_health: e.build.max_health(),
                damage: e.build.damage(),
                reload_left: referee.reload_left(rid).unwrap_or(0.0),
                carrying,
                tally: referee.tally(rid).unwrap_or_default(),
            };
            if fresh {
                self.seen.push(s);
            } else {
                let old = &self.seen[id];
                if dt > 0.0 && alive {
                    s.vel = (pose.position() - old.pose.position()) * (1.0 / dt);
                    s.omega = colony_proto::wrap_angle(pose.theta - old.pose.theta) / dt;
                }
                self.seen[id] = s;
            }
        }
        for (t, team) in self.teams.iter().enumerate() {
            let site = self.field.team(team);
            self.bases[t] = referee.base(team);
            self.flags[t] = referee.flag_at(team).and_then(|(at, carrier)| {
                let (x, y) = self.field.cell_center(site?.flag);
                Some(FlagSeen {
                    at,
                    home: Vec2::new(x, y),
                    carrier,
                })
            });
            self.scores[t] = referee
                .teams()
                .iter()
                .find(|s| &s.name == team)
                .map_or(0, |s| s.score);
        }
        self.neighbours.fill(NO_ROBOT);
        let k = self.config.nearby;
        let mut near: Vec<(f64, u32)> = Vec::with_capacity(self.seen.len());
        for (i, agent) in self.agents.iter().enumerate() {
            let me = &self.seen[agent.robot as usize];
            if !me.alive {
                continue;
            }
            near.clear();
            near.extend(
                self.seen
                    .iter()
                    .enumerate()
                    .filter(|(id, s)| *id as u32 != agent.robot && s.alive)
                    .map(|(id, s)| (s.pose.position().distance(me.pose.position()), id as u32)),
            );
            near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            for (slot, (_, id)) in near.iter().take(k).enumerate() {
                self.neighbours[i * k + slot] = *id;
            }
        }
    }
}
