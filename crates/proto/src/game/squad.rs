//! `game.player.TEAM`: a player's commands to the team's squads (the paper's Squad Behaviours),
//! from a player program, the built-in bot or the monitor's game page.
//!
//! ```text
//! @ <game.player.red> 0
//! squad name alpha do attack robot 9 formation half-circle
//! ```

use std::fmt;

use colony_wire::{Line, LineBuilder, Packet, PacketBuilder, ParseError, Priority};

use super::{player_channel, Formation};
use crate::fields::{bad, coord, parse_path, path_text, plain_name, r, robot_id};
use crate::table::{int, line, num, text, LineTable};
use crate::{DecodeError, Vec2};

/// A squad command's line, one of a player's ([`super::player::TABLE`]): its name, its verb
/// (`do`) with what the verb needs, and its formation.
pub const LINE: LineTable = line(
    "squad",
    &[
        text("name"),
        text("do"),
        num("x").varies(),
        num("y").varies(),
        int("robot").varies(),
        text("flag").varies(),
        text("base").varies(),
        text("points").varies(),
        text("formation").optional(),
    ],
);

/// What a squad command is about.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// A robot (to attack or defend).
    Robot(u32),
    /// A team's flag.
    Flag(String),
    /// A team's base.
    Base(String),
    /// A point on the map, cm.
    Point(Vec2),
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Target::Robot(id) => write!(f, "robot {id}"),
            Target::Flag(t) => write!(f, "flag {t}"),
            Target::Base(t) => write!(f, "base {t}"),
            Target::Point(p) => write!(f, "point {:.0} {:.0}", p.x, p.y),
        }
    }
}

/// A player's squad command (the paper's Squad Behaviours).
#[derive(Debug, Clone, PartialEq)]
pub enum Verb {
    /// Gather in formation at a point, or at the squad's centroid.
    Gather(Option<Vec2>),
    /// Move there in formation.
    GoTo(Vec2),
    /// Surround the object in a circle (half circle if it moves) and hold.
    Defend(Target),
    /// Close in on the object in a half circle, following it as it moves.
    Attack(Target),
    /// Take the flag and bring it to the squad's own base.
    Capture(String),
    /// Follow these points in formation, as the player drew them (the game makes each leg
    /// passable).
    Path(Vec<Vec2>),
    /// Stop where you are.
    Stop,
}

/// The most points a drawn path may have: a page thins a longer stroke before sending it.
pub const MAX_DRAWN_POINTS: usize = 64;

impl fmt::Display for Verb {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Verb::Gather(None) => f.write_str("gather"),
            Verb::Gather(Some(p)) => write!(f, "gather {:.0} {:.0}", p.x, p.y),
            Verb::GoTo(p) => write!(f, "goto {:.0} {:.0}", p.x, p.y),
            Verb::Defend(t) => write!(f, "defend {t}"),
            Verb::Attack(t) => write!(f, "attack {t}"),
            Verb::Capture(t) => write!(f, "capture flag {t}"),
            Verb::Path(points) => match points.last() {
                Some(p) => write!(
                    f,
                    "path of {} points to {:.0} {:.0}",
                    points.len(),
                    p.x,
                    p.y
                ),
                None => f.write_str("path of no points"),
            },
            Verb::Stop => f.write_str("stop"),
        }
    }
}

/// A player's command to one of their squads.
#[derive(Debug, Clone, PartialEq)]
pub struct SquadCommand {
    /// The player's team (from the channel it came on).
    pub team: String,
    /// The squad.
    pub squad: String,
    /// What to do.
    pub verb: Verb,
    /// In which formation (the squad keeps its current one when absent).
    pub formation: Option<Formation>,
}

impl SquadCommand {
    /// The packet, on the team's player channel.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([player_channel(&self.team)], Priority(0));
        let mut l = p.line("squad");
        l.bare("name", &self.squad);
        write_verb(&mut l, &self.verb);
        if let Some(f) = self.formation {
            l.bare("formation", f.name());
        }
        p.finish()
    }

    /// Reads the squad commands of a packet that came on `team`'s channel.
    pub fn decode(team: &str, packet: &Packet<'_>) -> Result<Vec<SquadCommand>, DecodeError> {
        packet
            .lines_labelled("squad")
            .map(|l| SquadCommand::read(team.to_string(), &l))
            .collect()
    }

    /// Reads one `squad` line from `team`'s player.
    pub(crate) fn read(team: String, l: &Line<'_>) -> Result<SquadCommand, DecodeError> {
        let verb = read_verb(l)?;
        let formation = match l.get("formation") {
            Some(_) => Some(
                l.str("formation")?
                    .parse::<Formation>()
                    .map_err(|e| bad(l, e.to_string()))?,
            ),
            None => None,
        };
        Ok(SquadCommand {
            team,
            squad: plain_name(l, "name")?,
            verb,
            formation,
        })
    }
}

/// Writes a verb's fields (`do` and its target) onto a squad's or a robot's line.
pub(crate) fn write_verb(l: &mut LineBuilder<'_>, verb: &Verb) {
    match verb {
        Verb::Gather(at) => {
            l.bare("do", "gather");
            if let Some(at) = at {
                l.field("x", r(at.x)).field("y", r(at.y));
            }
        }
        Verb::GoTo(at) => {
            l.bare("do", "goto").field("x", r(at.x)).field("y", r(at.y));
        }
        Verb::Defend(t) | Verb::Attack(t) => {
            l.bare(
                "do",
                if matches!(verb, Verb::Defend(_)) {
                    "defend"
                } else {
                    "attack"
                },
            );
            match t {
                Target::Robot(id) => {
                    l.field("robot", *id);
                }
                Target::Flag(team) => {
                    l.bare("flag", team);
                }
                Target::Base(team) => {
                    l.bare("base", team);
                }
                Target::Point(at) => {
                    l.field("x", r(at.x)).field("y", r(at.y));
                }
            }
        }
        Verb::Capture(team) => {
            l.bare("do", "capture").bare("flag", team);
        }
        Verb::Path(points) => {
            l.bare("do", "path")
                .field("points", path_text(points).as_str());
        }
        Verb::Stop => {
            l.bare("do", "stop");
        }
    }
}

/// Reads a verb from a squad's or a robot's line.
pub(crate) fn read_verb(l: &Line<'_>) -> Result<Verb, DecodeError> {
    Ok(match &*l.str("do")? {
        "gather" => Verb::Gather(match l.get("x") {
            Some(_) => Some(Vec2::new(coord(l, "x")?, coord(l, "y")?)),
            None => None,
        }),
        "goto" => Verb::GoTo(Vec2::new(coord(l, "x")?, coord(l, "y")?)),
        v @ ("defend" | "attack") => {
            let target = if l.get("robot").is_some() {
                Target::Robot(robot_id(l, "robot")?)
            } else if l.get("flag").is_some() {
                Target::Flag(plain_name(l, "flag")?)
            } else if l.get("base").is_some() {
                Target::Base(plain_name(l, "base")?)
            } else if l.get("x").is_some() {
                Target::Point(Vec2::new(coord(l, "x")?, coord(l, "y")?))
            } else {
                return Err(bad(l, format!("{v} needs robot, flag, base or x y")));
            };
            if v == "defend" {
                Verb::Defend(target)
            } else {
                Verb::Attack(target)
            }
        }
        "capture" => Verb::Capture(plain_name(l, "flag")?),
        "path" => {
            let points = parse_path(l, &l.str("points")?)?;
            if points.is_empty() || points.len() > MAX_DRAWN_POINTS {
                return Err(bad(
                    l,
                    format!(
                        "a drawn path has 1 to {MAX_DRAWN_POINTS} points, not {}",
                        points.len()
                    ),
                ));
            }
            Verb::Path(points)
        }
        "stop" => Verb::Stop,
        other => {
            return Err(bad(
                l,
                format!(
                    "unknown squad command {other:?} (expected gather, goto, defend, attack, capture, path or stop)"
                ),
            ))
        }
    })
}

#[cfg(test)]
mod tests;
