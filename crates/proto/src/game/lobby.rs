//! `game.lobby`: the pre-match, as the game publishes it while the players set up their teams:
//! the budget, what each robot type costs and can do, and each team's setup and whether it is
//! ready. The players answer on their `game.player.TEAM` channel with `setup` and `ready`
//! ([`super::player`]); the match starts when every team is ready.
//!
//! ```text
//! @ <game.lobby> 0
//! lobby status drafting budget 30 squads 4 upgrade 0.2 max_upgrade 5
//! kind name tank cost 5 health 120 power 15 speed 14 range 100 amphibious 0
//! team name red ready 0 bot 0 cost 19 setup "alpha:tank+h1,infantry bravo:scout"
//! ```

use colony_wire::{Line, Packet, PacketBuilder, ParseError, Priority};
use serde::Serialize;

use super::{RobotKind, LOBBY};
use crate::fields::{b, bad, finite, flag, plain_name, r, tally, text_or_empty};
use crate::table::{int, line, num, text, MessageTable};
use crate::DecodeError;

/// What a lobby packet holds.
pub const TABLE: MessageTable = MessageTable {
    channel: LOBBY,
    lines: &[
        line(
            "lobby",
            &[
                text("status"),
                int("budget"),
                int("squads"),
                num("upgrade"),
                int("max_upgrade"),
            ],
        ),
        line(
            "kind",
            &[
                text("name"),
                int("cost"),
                num("health"),
                num("power"),
                num("speed"),
                num("range"),
                int("amphibious"),
            ],
        ),
        line(
            "team",
            &[
                text("name"),
                int("ready"),
                int("bot"),
                int("cost"),
                text("setup").optional(),
            ],
        ),
    ],
};

/// The longest setup text a player may send or the lobby publish.
pub const MAX_SETUP: usize = 1000;

/// Where the pre-match stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LobbyStatus {
    /// The players are setting up their teams.
    Drafting,
    /// Every team was ready: the match is starting.
    Started,
}

/// A robot type as the lobby offers it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KindOffer {
    /// The type.
    pub kind: RobotKind,
    /// Budget points it costs as it comes.
    pub cost: u32,
    /// Its health as it comes.
    pub health: f64,
    /// The damage of one of its shots as it comes.
    pub power: f64,
    /// Top speed, cm/s.
    pub speed: f64,
    /// How far it shoots, cm.
    pub range: f64,
    /// Water is passable for it.
    pub amphibious: bool,
}

/// A team in the pre-match.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LobbyTeam {
    /// Its name.
    pub name: String,
    /// Its player said it is ready with this setup.
    pub ready: bool,
    /// Played by the built-in bot (its setup is fixed and ready).
    pub bot: bool,
    /// What its setup costs.
    pub cost: u32,
    /// Its squads and robots, as `--red` takes them: `alpha:tank+h1,infantry bravo:scout`.
    pub setup: String,
}

/// The pre-match.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LobbyState {
    /// Drafting or started.
    pub status: LobbyStatus,
    /// Budget points per team.
    pub budget: u32,
    /// The most squads a team may have.
    pub max_squads: u32,
    /// What one point of health or power adds, as a fraction of the type's.
    pub upgrade: f64,
    /// The most points of health or of power one robot may buy.
    pub max_upgrade: u32,
    /// The robot types.
    pub kinds: Vec<KindOffer>,
    /// The teams.
    pub teams: Vec<LobbyTeam>,
}

impl LobbyStatus {
    fn name(self) -> &'static str {
        match self {
            LobbyStatus::Drafting => "drafting",
            LobbyStatus::Started => "started",
        }
    }
}

impl LobbyState {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([LOBBY], Priority(0));
        p.line("lobby")
            .bare("status", self.status.name())
            .field("budget", self.budget)
            .field("squads", self.max_squads)
            .field("upgrade", r(self.upgrade))
            .field("max_upgrade", self.max_upgrade);
        for k in &self.kinds {
            p.line("kind")
                .bare("name", k.kind.name())
                .field("cost", k.cost)
                .field("health", r(k.health))
                .field("power", r(k.power))
                .field("speed", r(k.speed))
                .field("range", r(k.range))
                .field("amphibious", b(k.amphibious));
        }
        for t in &self.teams {
            p.line("team")
                .bare("name", &t.name)
                .field("ready", b(t.ready))
                .field("bot", b(t.bot))
                .field("cost", t.cost)
                .field("setup", t.setup.as_str());
        }
        p.finish()
    }

    /// Reads a lobby packet; the first line that does not read refuses it.
    pub fn decode(packet: &Packet<'_>) -> Result<LobbyState, DecodeError> {
        let head = packet.line("lobby").ok_or(DecodeError::Missing("lobby"))?;
        let status = match &*head.str("status")? {
            "drafting" => LobbyStatus::Drafting,
            "started" => LobbyStatus::Started,
            other => return Err(bad(&head, format!("unknown lobby status {other:?}"))),
        };
        let mut state = LobbyState {
            status,
            budget: tally(&head, "budget")?,
            max_squads: tally(&head, "squads")?,
            upgrade: finite(&head, "upgrade")?,
            max_upgrade: tally(&head, "max_upgrade")?,
            kinds: Vec::new(),
            teams: Vec::new(),
        };
        for l in packet.lines() {
            match l.label() {
                "kind" => state.kinds.push(kind(&l)?),
                "team" => {
                    let setup = text_or_empty(&l, "setup")?;
                    if setup.len() > MAX_SETUP {
                        return Err(bad(&l, format!("a setup is at most {MAX_SETUP} bytes")));
                    }
                    state.teams.push(LobbyTeam {
                        name: plain_name(&l, "name")?,
                        ready: flag(&l, "ready")?,
                        bot: flag(&l, "bot")?,
                        cost: tally(&l, "cost")?,
                        setup,
                    });
                }
                _ => {}
            }
        }
        Ok(state)
    }
}

fn kind(l: &Line<'_>) -> Result<KindOffer, DecodeError> {
    Ok(KindOffer {
        kind: l
            .str("name")?
            .parse::<RobotKind>()
            .map_err(|e| bad(l, e.to_string()))?,
        cost: tally(l, "cost")?,
        health: finite(l, "health")?,
        power: finite(l, "power")?,
        speed: finite(l, "speed")?,
        range: finite(l, "range")?,
        amphibious: flag(l, "amphibious")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lobby_is_read_as_published() {
        let s = LobbyState {
            status: LobbyStatus::Drafting,
            budget: 30,
            max_squads: 4,
            upgrade: 0.2,
            max_upgrade: 5,
            kinds: vec![KindOffer {
                kind: RobotKind::Tank,
                cost: 5,
                health: 120.0,
                power: 15.0,
                speed: 14.0,
                range: 100.0,
                amphibious: false,
            }],
            teams: vec![LobbyTeam {
                name: "red".into(),
                ready: false,
                bot: false,
                cost: 19,
                setup: "alpha:tank+h1,infantry bravo:scout".into(),
            }],
        };
        let bytes = s.encode().unwrap();
        let read = LobbyState::decode(&Packet::parse(&bytes).unwrap()).unwrap();
        assert_eq!(read, s);
        crate::table::check::codec(&TABLE, std::slice::from_ref(&bytes), |p| {
            LobbyState::decode(p).is_ok()
        });
        let started = LobbyState {
            status: LobbyStatus::Started,
            ..s
        };
        let bytes = started.encode().unwrap();
        assert_eq!(
            LobbyState::decode(&Packet::parse(&bytes).unwrap()).unwrap(),
            started
        );
    }
}
