//! The referee: health, shots, flags, score and the end of the game. Robots and players ask, it
//! decides, and it refuses what the rules don't allow with a reason.

use colony_sim::{Pose, Vec2};

use super::RobotEntry;
use crate::map::{Battlefield, Cell};
use crate::protocol::{
    Action, Event, FlagState, GameState, RobotState, SquadState, Status, TeamState, WorldFrame,
};
use crate::rules::{KindRules, Mode, Rules};

/// A robot picks up a flag within this distance of it, cm.
pub const FLAG_REACH: f64 = 30.0;
/// A flag brought this close to its captor's base is captured, cm.
pub const BASE_RADIUS: f64 = 45.0;

/// What one robot has done and suffered so far, counted by the referee as it rules: the
/// learning environment's rewards are differences of these, so they follow the rules exactly.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RobotTally {
    /// Health taken from enemies by its shots (at most what each target had left).
    pub damage_dealt: f64,
    /// Health it lost to shots.
    pub damage_taken: f64,
    /// Enemies its shots destroyed.
    pub kills: u32,
    /// Enemy flags it picked up.
    pub flags_taken: u32,
    /// Flags it brought to its base.
    pub captures: u32,
    /// Its shots and pick-ups the referee refused.
    pub refused: u32,
}

#[derive(Debug, Clone)]
struct Robot {
    entry: RobotEntry,
    pose: Pose,
    health: f64,
    alive: bool,
    last_fire: f64,
    behaviour: String,
    reason: String,
    tally: RobotTally,
}

#[derive(Debug, Clone)]
struct Flag {
    team: String,
    home: Vec2,
    at: Vec2,
    carrier: Option<u32>,
}

/// The referee.
pub struct Referee {
    rules: Rules,
    robots: Vec<Robot>,
    flags: Vec<Flag>,
    bases: Vec<(String, Vec2)>,
    teams: Vec<TeamState>,
    time: f64,
    status: Status,
    winner: Option<String>,
    reason: String,
    events: Vec<Event>,
}

impl Referee {
    /// A game on `field` with these robots.
    pub fn new(field: &Battlefield, rules: Rules, roster: &[RobotEntry]) -> Referee {
        let mut teams: Vec<TeamState> = Vec::new();
        for e in roster {
            if !teams.iter().any(|t| t.name == e.team) {
                teams.push(TeamState {
                    name: e.team.clone(),
                    score: 0,
                    kills: 0,
                });
            }
        }
        let at = |c: Cell| {
            let (x, y) = field.cell_center(c);
            Vec2::new(x, y)
        };
        let playing = |name: &str| teams.iter().any(|t| t.name == name);
        let flags = if rules.mode == Mode::CaptureTheFlag {
            field
                .teams
                .iter()
                .filter(|s| playing(&s.name))
                .map(|s| Flag {
                    team: s.name.clone(),
                    home: at(s.flag),
                    at: at(s.flag),
                    carrier: None,
                })
                .collect()
        } else {
            Vec::new()
        };
        let bases = field
            .teams
            .iter()
            .filter(|s| playing(&s.name))
            .map(|s| (s.name.clone(), at(s.base)))
            .collect();
        Referee {
            robots: roster
                .iter()
                .map(|e| Robot {
                    entry: e.clone(),
                    pose: e.spawn,
                    health: e.build.max_health(),
                    alive: true,
                    last_fire: f64::NEG_INFINITY,
                    behaviour: String::new(),
                    reason: String::new(),
                    tally: RobotTally::default(),
                })
                .collect(),
            rules,
            flags,
            bases,
            teams,
            time: 0.0,
            status: Status::Running,
            winner: None,
            reason: String::new(),
            events: Vec::new(),
        }
    }

    fn event(&mut self, kind: &str, text: String) {
        self.events.push(Event {
            time: self.time,
            kind: kind.to_string(),
            text,
        });
    }

    /// Events since the last call.
    pub fn take_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    /// Game time, s.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Whether the game is over.
    pub fn is_over(&self) -> bool {
        self.status == Status::Over
    }

    /// A robot's team, if the robot exists.
    pub fn team_of(&self, id: u32) -> Option<&str> {
        self.robots.get(id as usize).map(|r| r.entry.team.as_str())
    }

    /// A robot's pose and whether it is alive.
    pub fn robot(&self, id: u32) -> Option<(Pose, bool)> {
        self.robots.get(id as usize).map(|r| (r.pose, r.alive))
    }

    /// Where a team's flag is and who carries it.
    pub fn flag_at(&self, team: &str) -> Option<(Vec2, Option<u32>)> {
        self.flags
            .iter()
            .find(|f| f.team == team)
            .map(|f| (f.at, f.carrier))
    }

    /// A team's base.
    pub fn base(&self, team: &str) -> Option<Vec2> {
        self.bases.iter().find(|b| b.0 == team).map(|b| b.1)
    }

    /// A robot's health left, if the robot exists.
    pub fn health(&self, id: u32) -> Option<f64> {
        self.robots.get(id as usize).map(|r| r.health)
    }

    /// Seconds until a robot may fire again (0 when it may now), if the robot exists.
    pub fn reload_left(&self, id: u32) -> Option<f64> {
        self.robots.get(id as usize).map(|r| {
            let reload = r.entry.build.kind.stats().reload_s;
            (r.last_fire + reload - self.time).clamp(0.0, reload)
        })
    }

    /// What a robot has done and suffered so far, if the robot exists.
    pub fn tally(&self, id: u32) -> Option<RobotTally> {
        self.robots.get(id as usize).map(|r| r.tally)
    }

    /// Every team's score and kills, in roster order.
    pub fn teams(&self) -> &[TeamState] {
        &self.teams
    }

    /// The winner, once the game is over and someone won.
    pub fn winner(&self) -> Option<&str> {
        self.winner.as_deref()
    }

    /// Records the squad a robot now belongs to (after a split, a merge or a single-robot order).
    pub fn set_squad(&mut self, id: u32, squad: &str) {
        if let Some(r) = self.robots.get_mut(id as usize) {
            r.entry.squad = squad.to_string();
        }
    }

    /// Records a robot's active behaviour, for the state players see.
    pub fn set_behaviour(&mut self, id: u32, behaviour: String, reason: String) {
        if let Some(r) = self.robots.get_mut(id as usize) {
            r.behaviour = behaviour;
            r.reason = reason;
        }
    }

    /// Takes the world's poses and advances the game to its time.
    pub fn on_world(&mut self, frame: &WorldFrame) {
        // A frame from before our time is a restarted world that hasn't yet
        // taken up the game from our state: its poses are its spawn points.
        if !(frame.time.is_finite() && frame.time >= self.time) {
            return;
        }
        self.time = frame.time;
        for rp in &frame.robots {
            if let Some(r) = self.robots.get_mut(rp.id as usize) {
                r.pose = rp.pose;
            }
        }
        self.advance();
    }

    /// Carries out a robot's request, or refuses it with a `refused` event.
    pub fn on_action(&mut self, action: &Action) {
        if self.is_over() {
            return;
        }
        match action {
            Action::Fire { robot, target } => self.fire(*robot, *target),
            Action::PickUp { robot, flag } => self.pick_up(*robot, flag),
            Action::Beep { robot } => {
                if self.robots.get(*robot as usize).is_some_and(|r| r.alive) {
                    self.event("beep", format!("robot {robot} beeps"));
                }
            }
        }
    }

    fn fire(&mut self, shooter: u32, target: u32) {
        let time = self.time;
        let (Some(s), Some(t)) = (
            self.robots.get(shooter as usize),
            self.robots.get(target as usize),
        ) else {
            return self.event(
                "refused",
                format!("robot {shooter} fires at robot {target}: no such robot"),
            );
        };
        let stats = s.entry.build.kind.stats();
        let damage = s.entry.build.damage();
        let refusal = if !s.alive {
            Some("the shooter is destroyed".to_string())
        } else if !t.alive {
            Some("the target is already destroyed".to_string())
        } else if s.entry.team == t.entry.team {
            Some("the target is on the same team".to_string())
        } else if s.pose.position().distance(t.pose.position()) > stats.range_cm {
            Some(format!(
                "the target is {:.0} cm away; a {}'s range is {:.0} cm",
                s.pose.position().distance(t.pose.position()),
                s.entry.build.kind,
                stats.range_cm
            ))
        } else if time - s.last_fire < stats.reload_s - 1e-6 {
            Some(format!(
                "a {} fires once every {} s",
                s.entry.build.kind, stats.reload_s
            ))
        } else {
            None
        };
        if let Some(why) = refusal {
            self.robots[shooter as usize].tally.refused += 1;
            return self.event(
                "refused",
                format!("robot {shooter} fires at robot {target}: {why}"),
            );
        }
        self.robots[shooter as usize].last_fire = time;
        let t = &mut self.robots[target as usize];
        let before = t.health;
        t.health = (t.health - damage).max(0.0);
        let health = t.health;
        t.tally.damage_taken += before - health;
        self.robots[shooter as usize].tally.damage_dealt += before - health;
        self.event(
            "hit",
            format!("robot {shooter} hits robot {target} for {damage} (health {health})"),
        );
        if health <= 0.0 {
            self.destroy(target, shooter);
        }
    }

    pub(super) fn destroy(&mut self, id: u32, by: u32) {
        let r = &mut self.robots[id as usize];
        r.alive = false;
        let pos = r.pose.position();
        self.robots[by as usize].tally.kills += 1;
        let killer_team = self.robots[by as usize].entry.team.clone();
        if let Some(t) = self.teams.iter_mut().find(|t| t.name == killer_team) {
            t.kills += 1;
            if self.rules.mode == Mode::DeathMatch {
                t.score += 1;
            }
        }
        self.event("destroyed", format!("robot {id} destroyed by robot {by}"));
        let dropped: Vec<String> = self
            .flags
            .iter_mut()
            .filter(|f| f.carrier == Some(id))
            .map(|f| {
                f.carrier = None;
                f.at = pos;
                f.team.clone()
            })
            .collect();
        for team in dropped {
            self.event("flag-dropped", format!("the {team} flag is dropped"));
        }
    }

    fn pick_up(&mut self, robot: u32, flag: &str) {
        let Some(r) = self.robots.get(robot as usize) else {
            return self.event("refused", format!("robot {robot} picks up: no such robot"));
        };
        let (team, pos, alive) = (r.entry.team.clone(), r.pose.position(), r.alive);
        let Some(f) = self.flags.iter().position(|f| f.team == flag) else {
            return self.event(
                "refused",
                format!("robot {robot} picks up the {flag} flag: there is no such flag"),
            );
        };
        let refusal = if !alive {
            Some("it is destroyed".to_string())
        } else if self.flags[f].team == team {
            Some("it is its own team's flag".to_string())
        } else if self.flags[f].carrier.is_some() {
            Some("the flag is already carried".to_string())
        } else if self.flags.iter().any(|f| f.carrier == Some(robot)) {
            Some("it already carries a flag".to_string())
        } else if pos.distance(self.flags[f].at) > FLAG_REACH {
            Some(format!(
                "the flag is {:.0} cm away (reach {FLAG_REACH} cm)",
                pos.distance(self.flags[f].at)
            ))
        } else {
            None
        };
        if let Some(why) = refusal {
            self.robots[robot as usize].tally.refused += 1;
            return self.event(
                "refused",
                format!("robot {robot} picks up the {flag} flag: {why}"),
            );
        }
        self.flags[f].carrier = Some(robot);
        self.robots[robot as usize].tally.flags_taken += 1;
        self.event(
            "flag-taken",
            format!("robot {robot} of {team} takes the {flag} flag"),
        );
    }

    /// Flags follow their carriers, dropped flags touched by their own side
    /// go home, flags brought to a base score, and the game may end.
    fn advance(&mut self) {
        if self.is_over() {
            return;
        }
        for i in 0..self.flags.len() {
            if let Some(c) = self.flags[i].carrier {
                let r = &self.robots[c as usize];
                self.flags[i].at = r.pose.position();
                let carrier = c as usize;
                let captor = r.entry.team.clone();
                if let Some(base) = self.base(&captor) {
                    if self.flags[i].at.distance(base) <= BASE_RADIUS {
                        let team = self.flags[i].team.clone();
                        self.flags[i].carrier = None;
                        self.flags[i].at = self.flags[i].home;
                        if let Some(t) = self.teams.iter_mut().find(|t| t.name == captor) {
                            t.score += 1;
                        }
                        self.robots[carrier].tally.captures += 1;
                        self.event(
                            "captured",
                            format!("robot {c} of {captor} captures the {team} flag"),
                        );
                    }
                }
            } else if self.flags[i].at != self.flags[i].home {
                let f = &self.flags[i];
                let returner = self.robots.iter().find(|r| {
                    r.alive
                        && r.entry.team == f.team
                        && r.pose.position().distance(f.at) <= FLAG_REACH
                });
                if let Some(r) = returner {
                    let (id, team) = (r.entry.id, f.team.clone());
                    self.flags[i].at = self.flags[i].home;
                    self.event(
                        "flag-returned",
                        format!("robot {id} returns the {team} flag home"),
                    );
                }
            }
        }
        self.check_end();
    }

    fn check_end(&mut self) {
        let alive = |team: &str| {
            self.robots
                .iter()
                .filter(|r| r.alive && r.entry.team == team)
                .count()
        };
        let standing: Vec<String> = self
            .teams
            .iter()
            .filter(|t| alive(&t.name) > 0)
            .map(|t| t.name.clone())
            .collect();
        let result = if let Some(t) = self.rules.mode.eq(&Mode::CaptureTheFlag).then(|| {
            self.teams
                .iter()
                .find(|t| t.score >= self.rules.captures_to_win)
        }) {
            t.map(|t| {
                (
                    Some(t.name.clone()),
                    format!("{} captured the flag", t.name),
                )
            })
        } else {
            None
        };
        let result = result.or_else(|| match standing.len() {
            0 => Some((None, "every robot is destroyed".to_string())),
            // In Capture the Flag only a capture (or the clock) ends the game:
            // the last team standing still has to bring the flag home.
            1 if self.teams.len() > 1 && self.rules.mode == Mode::DeathMatch => Some((
                Some(standing[0].clone()),
                format!("{} has the last robots standing", standing[0]),
            )),
            _ => None,
        });
        let result =
            result.or_else(|| (self.time >= self.rules.time_limit_s).then(|| self.time_up()));
        if let Some((winner, reason)) = result {
            self.status = Status::Over;
            self.winner = winner;
            self.reason = reason.clone();
            self.event("over", reason);
        }
    }

    /// At the time limit: the higher score wins, then more kills, then more
    /// health left; equal on all three is a draw.
    fn time_up(&self) -> (Option<String>, String) {
        let health = |team: &str| -> f64 {
            self.robots
                .iter()
                .filter(|r| r.alive && r.entry.team == team)
                .map(|r| r.health)
                .sum()
        };
        let mut ranked: Vec<(&TeamState, f64)> =
            self.teams.iter().map(|t| (t, health(&t.name))).collect();
        ranked.sort_by(|a, b| {
            (b.0.score, b.0.kills)
                .cmp(&(a.0.score, a.0.kills))
                .then(b.1.total_cmp(&a.1))
        });
        match ranked.as_slice() {
            [first, second, ..]
                if (first.0.score, first.0.kills) == (second.0.score, second.0.kills)
                    && first.1 == second.1 =>
            {
                (None, "time is up with the teams level".to_string())
            }
            [first, ..] => (
                Some(first.0.name.clone()),
                format!("time is up; {} leads", first.0.name),
            ),
            [] => (None, "time is up".to_string()),
        }
    }

    /// The game as players see it; `squads` comes from the swarm intelligence.
    pub fn state(&self, squads: Vec<SquadState>) -> GameState {
        GameState {
            mode: self.rules.mode.to_string(),
            status: self.status,
            time: self.time,
            winner: self.winner.clone(),
            reason: self.reason.clone(),
            teams: self.teams.clone(),
            flags: self
                .flags
                .iter()
                .map(|f| FlagState {
                    team: f.team.clone(),
                    at: f.at,
                    carrier: f.carrier,
                    home: f.at == f.home && f.carrier.is_none(),
                })
                .collect(),
            robots: self
                .robots
                .iter()
                .map(|r| RobotState {
                    id: r.entry.id,
                    team: r.entry.team.clone(),
                    squad: r.entry.squad.clone(),
                    kind: r.entry.build.kind,
                    pose: r.pose,
                    health: r.health,
                    max_health: r.entry.build.max_health(),
                    power: r.entry.build.damage(),
                    alive: r.alive,
                    behaviour: r.behaviour.clone(),
                    reason: r.reason.clone(),
                })
                .collect(),
            squads,
        }
    }
}
