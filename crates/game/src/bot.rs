//! The built-in scripted player: it reads the game state and commands its
//! team's squads as a simple opponent would. The same player stands in for
//! a person in tests and in matches with no human.
//!
//! Capture the Flag: the first squad goes for the enemy flag, the others
//! defend their own; when the enemy carries our flag, everyone still
//! standing attacks the carrier. Death Match: every squad attacks the
//! nearest enemy robot.

use std::collections::{BTreeSet, VecDeque};

use colony_node::{Node, Time};
use colony_wire::{Packet, Subject};

use crate::protocol::{self, GameState, SquadCommand, Status, Target, Verb};

/// Seconds of game time between two looks at the game.
const THINK_S: f64 = 2.0;

/// A scripted player for one team.
pub struct Bot {
    team: String,
    last: f64,
    /// What each squad was last told, to send only changes.
    told: Vec<(String, Verb)>,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
}

impl Bot {
    /// A player for `team`.
    pub fn new(team: &str) -> Bot {
        Bot {
            team: team.to_string(),
            last: f64::NEG_INFINITY,
            told: Vec::new(),
            subs: protocol::subjects([protocol::STATE]),
            outbox: VecDeque::new(),
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

impl Bot {
    /// Takes in one game state; pushes the commands it calls for.
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

impl Node for Bot {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, _now: Time, packet: &Packet<'_>) {
        let mut out = Vec::new();
        self.handle(packet, &mut out);
        self.outbox.extend(out);
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{FlagState, RobotState};
    use crate::rules::RobotKind;
    use colony_sim::{Pose, Vec2};

    fn robot(id: u32, team: &str, squad: &str, x: f64) -> RobotState {
        RobotState {
            id,
            team: team.into(),
            squad: squad.into(),
            kind: RobotKind::Infantry,
            pose: Pose {
                x,
                y: 0.0,
                theta: 0.0,
            },
            health: 60.0,
            max_health: 60.0,
            power: 6.0,
            alive: true,
            behaviour: String::new(),
            reason: String::new(),
        }
    }

    fn state(mode: &str, carrier: Option<u32>) -> GameState {
        GameState {
            mode: mode.into(),
            status: Status::Running,
            time: 10.0,
            winner: None,
            reason: String::new(),
            teams: Vec::new(),
            flags: ["red", "blue"]
                .map(|t| FlagState {
                    team: t.into(),
                    at: Vec2::ZERO,
                    carrier: if t == "red" { carrier } else { None },
                    home: carrier.is_none(),
                })
                .to_vec(),
            robots: vec![
                robot(0, "red", "a", 0.0),
                robot(1, "red", "b", 10.0),
                robot(2, "blue", "x", 500.0),
                robot(3, "blue", "x", 100.0),
            ],
            squads: Vec::new(),
        }
    }

    fn verbs(bot: &Bot, s: &GameState) -> Vec<(String, Verb)> {
        bot.decide(s)
            .into_iter()
            .map(|c| (c.squad, c.verb))
            .collect()
    }

    #[test]
    fn in_capture_the_flag_the_first_squad_attacks_the_flag_and_the_rest_defend() {
        let bot = Bot::new("red");
        assert_eq!(
            verbs(&bot, &state("ctf", None)),
            [
                ("a".to_string(), Verb::Capture("blue".into())),
                ("b".to_string(), Verb::Defend(Target::Flag("red".into()))),
            ]
        );
        // Our flag is carried off: everyone goes after the carrier.
        assert!(verbs(&bot, &state("ctf", Some(3)))
            .iter()
            .all(|(_, v)| *v == Verb::Attack(Target::Robot(3))));
    }

    #[test]
    fn in_death_match_every_squad_attacks_the_nearest_enemy() {
        let bot = Bot::new("red");
        assert!(verbs(&bot, &state("dm", None))
            .iter()
            .all(|(_, v)| *v == Verb::Attack(Target::Robot(3))));
    }

    #[test]
    fn the_bot_repeats_nothing_and_stops_when_the_game_is_over() {
        let mut bot = Bot::new("red");
        let hear = |bot: &mut Bot, s: &GameState| {
            bot.handle_packet(Time::ZERO, &Packet::parse(&s.encode().unwrap()).unwrap());
            std::iter::from_fn(|| bot.poll_transmit()).count()
        };
        assert_eq!(hear(&mut bot, &state("ctf", None)), 2);
        let mut later = state("ctf", None);
        later.time = 20.0;
        assert_eq!(
            hear(&mut bot, &later),
            0,
            "the same orders are not sent again"
        );
        later.status = Status::Over;
        later.time = 30.0;
        later.flags[0].carrier = Some(3);
        assert_eq!(hear(&mut bot, &later), 0, "no orders after the end");
        assert_eq!(bot.poll_timeout(), None);
    }
}
