//! `game.state`: the game logic's view of the game, several times a second; everything a player
//! (and the monitor's game page) sees.
//!
//! ```text
//! @ <game.state> 0
//! game mode ctf status running time 12 winner - reason ""
//! team name red score 0 kills 1
//! flag team blue x 800 y 900 home 0 carrier 3
//! robot id 3 team red squad alpha kind tank x 310.5 y 88.2 theta 1.57 health 120 max_health 144 power 15 alive 1 behaviour goto reason "..."
//! squad team red name alpha formation wedge order "attack robot 9" behaviour shoot path "310,88 400,120"
//! ```
//!
//! Texts (`reason`, `behaviour`, `order`, `path`) may be left out and read as empty. A node
//! reads a state with [`GameState::decode`], which refuses the packet at its first bad line; a
//! viewer reads it with [`GameState::decode_lenient`], which skips and counts bad lines.

use colony_wire::{Line, Packet, PacketBuilder, ParseError, Priority};
use serde::Serialize;

use super::{Formation, RobotKind, STATE};
use crate::fields::{
    b, bad, coord, finite, flag, parse_path, path_text, plain_name, r, robot_id, tally,
    text_or_empty,
};
use crate::table::{int, line, num, text, MessageTable};
use crate::Skimmed;
use crate::{DecodeError, Pose, Vec2};

/// What a game state holds.
pub const TABLE: MessageTable = MessageTable {
    channel: STATE,
    lines: &[
        line(
            "game",
            &[
                text("mode"),
                text("status"),
                num("time"),
                text("winner"),
                text("reason").optional(),
            ],
        ),
        line("team", &[text("name"), int("score"), int("kills")]),
        line(
            "flag",
            &[
                text("team"),
                num("x"),
                num("y"),
                int("home"),
                int("carrier").optional(),
            ],
        ),
        line(
            "robot",
            &[
                int("id"),
                text("team"),
                text("squad"),
                text("kind"),
                num("x"),
                num("y"),
                num("theta"),
                num("health"),
                num("max_health").optional(),
                num("power").optional(),
                int("alive"),
                text("behaviour").optional(),
                text("reason").optional(),
            ],
        ),
        line(
            "squad",
            &[
                text("team"),
                text("name"),
                text("formation"),
                text("order").optional(),
                text("behaviour").optional(),
                text("path").optional(),
            ],
        ),
    ],
};

/// Where a game stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Being played.
    Running,
    /// Finished.
    Over,
}

/// A team's standing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TeamState {
    /// Its name.
    pub name: String,
    /// Flags captured (CTF) or robots destroyed (DM).
    pub score: u32,
    /// Enemy robots destroyed.
    pub kills: u32,
}

/// A flag as the game logic knows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlagState {
    /// Whose flag.
    pub team: String,
    /// Where it is, cm.
    #[serde(flatten)]
    pub at: Vec2,
    /// It is on its stand at its base.
    pub home: bool,
    /// The robot carrying it.
    pub carrier: Option<u32>,
}

/// A robot as the game logic knows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RobotState {
    /// Its id.
    pub id: u32,
    /// Its team.
    pub team: String,
    /// Its squad.
    pub squad: String,
    /// Its type.
    pub kind: RobotKind,
    /// Where it is.
    #[serde(flatten)]
    pub pose: Pose,
    /// Health left.
    pub health: f64,
    /// The health it started with (its type's, with what its player bought).
    pub max_health: f64,
    /// The damage one of its shots does.
    pub power: f64,
    /// Not destroyed.
    pub alive: bool,
    /// Its active behaviour and why.
    pub behaviour: String,
    /// Why that behaviour has control.
    pub reason: String,
}

/// A squad as the game logic knows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SquadState {
    /// Its team.
    pub team: String,
    /// Its name.
    pub name: String,
    /// Its formation.
    pub formation: Formation,
    /// The player's command it carries out (text).
    pub order: String,
    /// The squad behaviour in control and why.
    pub behaviour: String,
    /// The planned path's turn points, cm.
    #[serde(serialize_with = "crate::geometry::points_as_pairs")]
    pub path: Vec<Vec2>,
}

/// The whole game as a player sees it.
///
/// As JSON (the monitor's game page reads it so) a pose or a flag's place is written as its
/// `x`, `y` (and `theta`) beside the other fields, and a path as `[x, y]` pairs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GameState {
    /// The mode (`ctf` or `dm`).
    pub mode: String,
    /// Running or over.
    pub status: Status,
    /// Game time, s.
    pub time: f64,
    /// The winner, when over (None: a draw).
    pub winner: Option<String>,
    /// Why it ended.
    pub reason: String,
    /// The teams.
    pub teams: Vec<TeamState>,
    /// The flags.
    pub flags: Vec<FlagState>,
    /// The robots.
    pub robots: Vec<RobotState>,
    /// The squads.
    pub squads: Vec<SquadState>,
}

impl Status {
    /// The word a packet carries.
    pub fn name(self) -> &'static str {
        match self {
            Status::Running => "running",
            Status::Over => "over",
        }
    }
}

/// The `game` line: everything but the lists.
fn head(g: &Line<'_>) -> Result<GameState, DecodeError> {
    let status = match &*g.str("status")? {
        "running" => Status::Running,
        "over" => Status::Over,
        other => return Err(bad(g, format!("unknown status {other:?}"))),
    };
    let winner = match plain_name(g, "winner")?.as_str() {
        "-" => None,
        w => Some(w.to_string()),
    };
    Ok(GameState {
        mode: plain_name(g, "mode")?,
        status,
        time: finite(g, "time")?,
        winner,
        reason: text_or_empty(g, "reason")?,
        teams: Vec::new(),
        flags: Vec::new(),
        robots: Vec::new(),
        squads: Vec::new(),
    })
}

/// Adds one line of a state to `state`; lines of other labels are ignored (a newer game may
/// say more).
fn add_line(state: &mut GameState, l: &Line<'_>) -> Result<(), DecodeError> {
    match l.label() {
        "team" => state.teams.push(TeamState {
            name: plain_name(l, "name")?,
            score: tally(l, "score")?,
            kills: tally(l, "kills")?,
        }),
        "flag" => state.flags.push(FlagState {
            team: plain_name(l, "team")?,
            at: Vec2::new(coord(l, "x")?, coord(l, "y")?),
            home: flag(l, "home")?,
            carrier: match l.get("carrier") {
                Some(_) => Some(robot_id(l, "carrier")?),
                None => None,
            },
        }),
        "robot" => state.robots.push(RobotState {
            id: robot_id(l, "id")?,
            team: plain_name(l, "team")?,
            squad: plain_name(l, "squad")?,
            kind: l
                .str("kind")?
                .parse::<RobotKind>()
                .map_err(|e| bad(l, e.to_string()))?,
            pose: Pose {
                x: coord(l, "x")?,
                y: coord(l, "y")?,
                theta: finite(l, "theta")?,
            },
            health: finite(l, "health")?,
            // Left out by older servers: read as the health it has and no known power.
            max_health: match l.get("max_health") {
                Some(_) => finite(l, "max_health")?,
                None => finite(l, "health")?,
            },
            power: match l.get("power") {
                Some(_) => finite(l, "power")?,
                None => 0.0,
            },
            alive: flag(l, "alive")?,
            behaviour: text_or_empty(l, "behaviour")?,
            reason: text_or_empty(l, "reason")?,
        }),
        "squad" => state.squads.push(SquadState {
            team: plain_name(l, "team")?,
            name: plain_name(l, "name")?,
            formation: l
                .str("formation")?
                .parse::<Formation>()
                .map_err(|e| bad(l, e.to_string()))?,
            order: text_or_empty(l, "order")?,
            behaviour: text_or_empty(l, "behaviour")?,
            path: parse_path(l, &text_or_empty(l, "path")?)?,
        }),
        _ => {}
    }
    Ok(())
}

impl GameState {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([STATE], Priority(0));
        p.line("game")
            .bare("mode", &self.mode)
            .bare("status", self.status.name())
            .field("time", r(self.time))
            .bare("winner", self.winner.as_deref().unwrap_or("-"))
            .field("reason", self.reason.as_str());
        for t in &self.teams {
            p.line("team")
                .bare("name", &t.name)
                .field("score", t.score)
                .field("kills", t.kills);
        }
        for f in &self.flags {
            let mut l = p.line("flag");
            l.bare("team", &f.team)
                .field("x", r(f.at.x))
                .field("y", r(f.at.y))
                .field("home", b(f.home));
            if let Some(c) = f.carrier {
                l.field("carrier", c);
            }
        }
        for rb in &self.robots {
            p.line("robot")
                .field("id", rb.id)
                .bare("team", &rb.team)
                .bare("squad", &rb.squad)
                .bare("kind", rb.kind.name())
                .field("x", r(rb.pose.x))
                .field("y", r(rb.pose.y))
                .field("theta", r(rb.pose.theta))
                .field("health", r(rb.health))
                .field("max_health", r(rb.max_health))
                .field("power", r(rb.power))
                .field("alive", b(rb.alive))
                .field("behaviour", rb.behaviour.as_str())
                .field("reason", rb.reason.as_str());
        }
        for s in &self.squads {
            p.line("squad")
                .bare("team", &s.team)
                .bare("name", &s.name)
                .bare("formation", s.formation.name())
                .field("order", s.order.as_str())
                .field("behaviour", s.behaviour.as_str())
                .field("path", path_text(&s.path).as_str());
        }
        p.finish()
    }

    /// Reads a game state; any line that does not read refuses the whole packet.
    pub fn decode(packet: &Packet<'_>) -> Result<GameState, DecodeError> {
        let g = packet.line("game").ok_or(DecodeError::Missing("game"))?;
        let mut state = head(&g)?;
        for l in packet.lines() {
            if l.label() != "game" {
                add_line(&mut state, &l)?;
            }
        }
        Ok(state)
    }

    /// Reads a game state for a viewer: a `team`, `flag`, `robot` or `squad` line that does not
    /// read is skipped and counted. Without a readable `game` line there is no state.
    pub fn decode_lenient(packet: &Packet<'_>) -> Result<Skimmed<GameState>, DecodeError> {
        let g = packet.line("game").ok_or(DecodeError::Missing("game"))?;
        let mut state = head(&g)?;
        let mut skipped = 0;
        for l in packet.lines() {
            if l.label() != "game" && add_line(&mut state, &l).is_err() {
                skipped += 1;
            }
        }
        Ok(Skimmed {
            message: state,
            bad_lines: skipped,
        })
    }
}

#[cfg(test)]
mod tests;
