//! The built-in scripted player: it reads the game state and commands its
//! team's squads as a simple opponent would. The same player stands in for
//! a person in tests and in matches with no human.
//!
//! Capture the Flag: the first squad goes for the enemy flag, the others
//! defend their own; when the enemy carries our flag, everyone still
//! standing attacks the carrier. Death Match: every squad attacks the
//! nearest enemy robot.

use colony_wire::Packet;

use crate::node::Node;
use crate::protocol::{self, GameState, SquadCommand, Status, Target, Verb};

/// Seconds of game time between two looks at the game.
const THINK_S: f64 = 2.0;

/// A scripted player for one team.
pub struct Bot {
    team: String,
    last: f64,
    /// What each squad was last told, to send only changes.
    told: Vec<(String, Verb)>,
}

impl Bot {
    /// A player for `team`.
    pub fn new(team: &str) -> Bot {
        Bot {
            team: team.to_string(),
            last: f64::NEG_INFINITY,
            told: Vec::new(),
        }
    }

    /// The commands this state calls for.
    pub fn decide(&self, state: &GameState) -> Vec<SquadCommand> {
        let mut squads: Vec<&str> = Vec::new();
        for r in state
            .robots
            .iter()
            .filter(|r| r.team == self.team && r.alive)
        {
            if !squads.contains(&r.squad.as_str()) {
                squads.push(&r.squad);
            }
        }
        let enemy_flag = state.flags.iter().find(|f| f.team != self.team);
        let own_flag = state.flags.iter().find(|f| f.team == self.team);
        let ctf = state.mode == "ctf";
        squads
            .iter()
            .enumerate()
            .map(|(i, squad)| {
                let verb = if !ctf {
                    let ours: Vec<_> = state
                        .robots
                        .iter()
                        .filter(|r| r.alive && r.team == self.team && r.squad == *squad)
                        .collect();
                    let c = ours
                        .iter()
                        .fold(colony_sim::Vec2::ZERO, |a, r| a + r.pose.position())
                        * (1.0 / ours.len().max(1) as f64);
                    state
                        .robots
                        .iter()
                        .filter(|r| r.alive && r.team != self.team)
                        .min_by(|a, b| {
                            a.pose
                                .position()
                                .distance(c)
                                .total_cmp(&b.pose.position().distance(c))
                        })
                        .map_or(Verb::Stop, |e| Verb::Attack(Target::Robot(e.id)))
                } else if let Some(carrier) = own_flag.and_then(|f| f.carrier) {
                    Verb::Attack(Target::Robot(carrier))
                } else if i == 0 {
                    enemy_flag.map_or(Verb::Stop, |f| Verb::Capture(f.team.clone()))
                } else {
                    Verb::Defend(Target::Flag(self.team.clone()))
                };
                SquadCommand {
                    team: self.team.clone(),
                    squad: squad.to_string(),
                    verb,
                    formation: None,
                }
            })
            .collect()
    }
}

impl Node for Bot {
    fn subscriptions(&self) -> Vec<String> {
        vec![protocol::STATE.to_string()]
    }

    fn handle(&mut self, packet: &Packet<'_>, out: &mut Vec<Vec<u8>>) {
        let Ok(state) = GameState::decode(packet) else {
            return;
        };
        if state.status == Status::Over || state.time - self.last < THINK_S {
            return;
        }
        self.last = state.time;
        for c in self.decide(&state) {
            if self.told.iter().any(|(s, v)| *s == c.squad && *v == c.verb) {
                continue;
            }
            self.told.retain(|(s, _)| *s != c.squad);
            self.told.push((c.squad.clone(), c.verb.clone()));
            if let Ok(p) = c.encode() {
                out.push(p);
            }
        }
    }
}
