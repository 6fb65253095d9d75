//! What a player may tell the game, checked by the referee's rules and carried out: squad
//! commands, single-robot orders, splitting and merging squads, and direct control of one
//! robot. A refusal is a sentence for the player, published as a `refused` event.

use colony_node::Time;

use super::{Pending, Server, MAX_TIMINGS, SPACING_CM};
use crate::nav::Nav;
use crate::protocol::{Command, PlayerCommand, SquadCommand, Target, Verb, DRIVE_HOLD_S};
use crate::squad::Squad;
use colony_sim::Vec2;

impl Server {
    /// Carries out one player command, or says why not.
    pub(super) fn obey(
        &mut self,
        now: Time,
        c: PlayerCommand,
        out: &mut Vec<Vec<u8>>,
    ) -> Result<(), String> {
        if self.referee.is_over() {
            return Err(format!("{}: the game is over", c.team()));
        }
        match c {
            PlayerCommand::Squad(c) => {
                let i = self
                    .check_squad(&c)
                    .map_err(|why| format!("{} squad {}: {why}", c.team, c.squad))?;
                self.command(now, i, c.verb, c.formation);
            }
            PlayerCommand::Robot { team, robot, verb } => {
                let who = format!("{team} robot {robot}");
                self.own_living(&team, robot)
                    .map_err(|why| format!("{who}: {why}"))?;
                if self.driven.contains_key(&robot) {
                    return Err(format!("{who}: you are driving it; release it first"));
                }
                let now_in = self
                    .squad_of(robot)
                    .ok_or_else(|| format!("{who}: it is in no squad"))?;
                // The order is checked before the robot leaves its squad, so a refused one
                // changes nothing.
                let check = SquadCommand {
                    team,
                    squad: self.squads[now_in].name().to_string(),
                    verb,
                    formation: None,
                };
                self.check_squad(&check)
                    .map_err(|why| format!("{who}: {why}"))?;
                let solo = self.solo(&check.team, robot);
                self.command(now, solo, check.verb, None);
            }
            PlayerCommand::Split {
                team,
                squad,
                robots,
                into,
            } => self
                .split(&team, &squad, &robots, &into)
                .map_err(|why| format!("{team} split of {squad}: {why}"))?,
            PlayerCommand::Merge { team, squad, into } => self
                .merge(&team, &squad, &into)
                .map_err(|why| format!("{team} merge of {squad} into {into}: {why}"))?,
            PlayerCommand::Drive {
                team,
                robot,
                forward,
                turn,
            } => {
                self.own_living(&team, robot)
                    .map_err(|why| format!("{team} robot {robot}: {why}"))?;
                self.driven.insert(robot, now);
                let drive = Command::Drive {
                    forward,
                    turn,
                    secs: DRIVE_HOLD_S,
                };
                self.send(robot, vec![drive], out);
                // Nothing to repeat: a drive lapses on its own.
                self.last_orders[robot as usize] = None;
            }
            PlayerCommand::Setup { team, .. } | PlayerCommand::Ready { team, .. } => {
                return Err(format!(
                    "{team}: the match has started; teams are set up before it"
                ));
            }
            PlayerCommand::Release { team, robot } => {
                self.own_living(&team, robot)
                    .map_err(|why| format!("{team} robot {robot}: {why}"))?;
                if self.driven.remove(&robot).is_none() {
                    return Err(format!("{team} robot {robot}: it is not being driven"));
                }
                if let Some(i) = self.squad_of(robot) {
                    self.squads[i].refresh();
                }
            }
        }
        Ok(())
    }

    /// Gives squad `i` the command; its orders go out at the next think.
    fn command(
        &mut self,
        now: Time,
        i: usize,
        verb: Verb,
        formation: Option<crate::protocol::Formation>,
    ) {
        if self.pending.len() == MAX_TIMINGS {
            self.pending.pop_front();
        }
        self.pending.push_back(Pending {
            team: self.squads[i].team().to_string(),
            squad: self.squads[i].name().to_string(),
            order: verb.to_string(),
            received: now,
        });
        self.squads[i].command(verb, formation);
    }

    /// The robot is on `team` and standing.
    fn own_living(&self, team: &str, robot: u32) -> Result<(), String> {
        match self.referee.team_of(robot) {
            None => Err("there is no such robot".into()),
            Some(t) if t != team => Err(format!("it is not yours (it plays for {t})")),
            _ => match self.referee.robot(robot) {
                Some((_, true)) => Ok(()),
                _ => Err("it is destroyed".into()),
            },
        }
    }

    /// The squad robot `robot` is in.
    fn squad_of(&self, robot: u32) -> Option<usize> {
        self.squads
            .iter()
            .position(|s| s.members().contains(&robot))
    }

    fn find(&self, team: &str, name: &str) -> Option<usize> {
        self.squads
            .iter()
            .position(|s| s.team() == team && s.name() == name)
    }

    /// A squad of `team` holding only `robot`: its own, when it is alone in it; else a new one
    /// (`robot-N`) it moves to, leaving the rest of its squad to their command.
    fn solo(&mut self, team: &str, robot: u32) -> usize {
        let from = self.squad_of(robot);
        if let Some(i) = from {
            if self.squads[i].members() == [robot] {
                return i;
            }
        }
        let base = format!("robot-{robot}");
        let name = std::iter::once(base.clone())
            .chain((2..).map(|k| format!("{base}-{k}")))
            .find(|n| self.find(team, n).is_none())
            .unwrap_or(base);
        let formation = from.map(|i| self.squads[i].formation());
        if let Some(i) = from {
            self.squads[i].remove_members(&[robot]);
        }
        self.new_squad(team, &name, vec![robot], formation)
    }

    fn new_squad(
        &mut self,
        team: &str,
        name: &str,
        members: Vec<u32>,
        formation: Option<crate::protocol::Formation>,
    ) -> usize {
        for &id in &members {
            self.referee.set_squad(id, name);
        }
        let mut squad = Squad::new(
            team,
            name,
            members,
            SPACING_CM,
            Nav::new(self.field.clone()),
        );
        if let Some(f) = formation {
            squad.set_formation(f);
        }
        self.squads.push(squad);
        self.squads.len() - 1
    }

    fn split(&mut self, team: &str, squad: &str, robots: &[u32], into: &str) -> Result<(), String> {
        let i = self
            .find(team, squad)
            .ok_or_else(|| format!("team {team} has no squad {squad}"))?;
        if self.find(team, into).is_some() {
            return Err(format!("there is a squad {into} already"));
        }
        let members = self.squads[i].members().to_vec();
        for (k, &id) in robots.iter().enumerate() {
            if !members.contains(&id) {
                return Err(format!("robot {id} is not in {squad}"));
            }
            if robots[..k].contains(&id) {
                return Err(format!("robot {id} is named twice"));
            }
            if !matches!(self.referee.robot(id), Some((_, true))) {
                return Err(format!("robot {id} is destroyed"));
            }
        }
        if robots.len() == members.len() {
            return Err(format!("keep at least one robot in {squad}"));
        }
        let verb = self.squads[i].verb().cloned();
        let formation = self.squads[i].formation();
        self.squads[i].remove_members(robots);
        self.squads[i].refresh();
        let j = self.new_squad(team, into, robots.to_vec(), Some(formation));
        // Both halves carry on with what the squad was doing, each in its own formation, until
        // the player tells them otherwise.
        if let Some(verb) = verb {
            self.squads[j].command(verb, None);
        }
        Ok(())
    }

    fn merge(&mut self, team: &str, squad: &str, into: &str) -> Result<(), String> {
        if squad == into {
            return Err("a squad cannot merge into itself".into());
        }
        let from = self
            .find(team, squad)
            .ok_or_else(|| format!("team {team} has no squad {squad}"))?;
        let to = self
            .find(team, into)
            .ok_or_else(|| format!("team {team} has no squad {into}"))?;
        let members = self.squads[from].members().to_vec();
        for &id in &members {
            self.referee.set_squad(id, into);
        }
        self.squads[to].add_members(&members);
        self.squads[to].refresh();
        self.squads.remove(from);
        self.pending
            .retain(|p| !(p.team == team && p.squad == squad));
        Ok(())
    }

    /// Checks a player's command against the rules; the reason when refused.
    fn check_squad(&self, c: &SquadCommand) -> Result<usize, String> {
        let squad = self
            .squads
            .iter()
            .position(|s| s.team() == c.team && s.name() == c.squad)
            .ok_or_else(|| format!("team {} has no squad {}", c.team, c.squad))?;
        if self.referee.is_over() {
            return Err("the game is over".into());
        }
        let on_map = |p: &Vec2| self.field.cell_at(p.x, p.y).is_some();
        let team_exists = |t: &str| self.field.teams.iter().any(|s| s.name == t);
        match &c.verb {
            Verb::Path(points) if points.iter().any(|p| !on_map(p)) => {
                Err("the drawn path leaves the map".into())
            }
            Verb::GoTo(p) | Verb::Gather(Some(p)) if !on_map(p) => {
                Err(format!("({:.0}, {:.0}) is off the map", p.x, p.y))
            }
            Verb::Attack(Target::Robot(id)) => match self.referee.team_of(*id) {
                None => Err(format!("there is no robot {id}")),
                Some(t) if t == c.team => Err(format!("robot {id} is on your own team")),
                _ => Ok(squad),
            },
            Verb::Defend(Target::Robot(id)) => match self.referee.team_of(*id) {
                None => Err(format!("there is no robot {id}")),
                Some(t) if t != c.team => Err(format!("robot {id} is an enemy")),
                _ => Ok(squad),
            },
            Verb::Capture(flag) if flag == &c.team => Err("that is your own flag".into()),
            Verb::Capture(flag) if self.referee.flag_at(flag).is_none() => {
                Err(format!("there is no {flag} flag in this game"))
            }
            Verb::Defend(Target::Flag(t) | Target::Base(t))
            | Verb::Attack(Target::Flag(t) | Target::Base(t))
                if !team_exists(t) =>
            {
                Err(format!("there is no team {t}"))
            }
            Verb::Defend(Target::Point(p)) | Verb::Attack(Target::Point(p)) if !on_map(p) => {
                Err(format!("({:.0}, {:.0}) is off the map", p.x, p.y))
            }
            _ => Ok(squad),
        }
    }
}
