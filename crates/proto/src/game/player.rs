//! `game.player.TEAM`: everything a player tells the game, one line each, read in order:
//! squad commands ([`super::squad`]), orders for single robots, splitting and merging squads,
//! and direct control of one robot.
//!
//! ```text
//! @ <game.player.red> 0
//! squad name alpha do path points "100,80 300,80 300,400" formation line
//! robot id 3 do attack robot 9
//! split name alpha robots "4 5" into bravo
//! merge name bravo into alpha
//! drive robot 3 forward 0.8 turn -0.5
//! release robot 3
//! setup squads "alpha:tank+h2+p1,scout bravo:infantry" ready 1     before the match (game.lobby)
//! ready value 1
//! ```
//!
//! `drive` takes the robot out of its squad's hands until `release` gives it back; each `drive`
//! holds the wheels for [`DRIVE_HOLD_S`], so a player who stops sending (a closed page, a lost
//! packet) leaves a robot standing, not running off.

use colony_wire::{Line, Packet, PacketBuilder, ParseError, Priority};

use super::player_channel;
use super::squad::{read_verb, write_verb, SquadCommand, Verb};
use crate::fields::{bad, plain_name, robot_id, within};
use crate::table::{int, line, num, text, MessageTable};
use crate::DecodeError;

/// What a player's packet holds, on every `game.player.TEAM`: one line per command.
pub const TABLE: MessageTable = MessageTable {
    channel: "game.player.",
    lines: &[
        super::squad::LINE,
        line(
            "robot",
            &[
                int("id"),
                text("do"),
                num("x").varies(),
                num("y").varies(),
                int("robot").varies(),
                text("flag").varies(),
                text("base").varies(),
            ],
        ),
        line("split", &[text("name"), text("robots"), text("into")]),
        line("merge", &[text("name"), text("into")]),
        line("drive", &[int("robot"), num("forward"), num("turn")]),
        line("release", &[int("robot")]),
        line("setup", &[text("squads"), int("ready").optional()]),
        line("ready", &[int("value")]),
    ],
};

/// How long one `drive` holds the wheels, s: a page repeats it faster while a key is held.
pub const DRIVE_HOLD_S: f64 = 0.5;
/// The most robots one `split` may name.
pub const MAX_SPLIT: usize = 256;

/// One thing a player tells the game.
#[derive(Debug, Clone, PartialEq)]
pub enum PlayerCommand {
    /// A command for a whole squad.
    Squad(SquadCommand),
    /// A command for one robot: it leaves its squad and carries it out alone.
    Robot {
        /// The player's team.
        team: String,
        /// The robot.
        robot: u32,
        /// What to do.
        verb: Verb,
    },
    /// These robots of `squad` form a new squad `into`.
    Split {
        /// The player's team.
        team: String,
        /// The squad they leave.
        squad: String,
        /// Its robots that leave.
        robots: Vec<u32>,
        /// The new squad's name.
        into: String,
    },
    /// Every robot of `squad` joins `into`; `squad` is no more.
    Merge {
        /// The player's team.
        team: String,
        /// The squad that joins.
        squad: String,
        /// The squad it joins.
        into: String,
    },
    /// Direct control: drive the robot with these wheel fractions for [`DRIVE_HOLD_S`].
    Drive {
        /// The player's team.
        team: String,
        /// The robot.
        robot: u32,
        /// Forward, -1 (full reverse) to 1 (full ahead).
        forward: f64,
        /// Turn, -1 (full right) to 1 (full left).
        turn: f64,
    },
    /// Gives a driven robot back to its squad.
    Release {
        /// The player's team.
        team: String,
        /// The robot.
        robot: u32,
    },
    /// Before the match: the team's squads and robots, as `--red` takes them.
    Setup {
        /// The player's team.
        team: String,
        /// `alpha:tank+h2+p1,scout bravo:infantry` (at most [`super::lobby::MAX_SETUP`] bytes).
        squads: String,
        /// Ready to play with it, if the rules take it (a refused setup is never ready).
        ready: bool,
    },
    /// Before the match: the player is (or is no longer) ready to play with the setup.
    Ready {
        /// The player's team.
        team: String,
        /// Ready or not.
        ready: bool,
    },
}

impl PlayerCommand {
    /// The team whose player sent it.
    pub fn team(&self) -> &str {
        match self {
            PlayerCommand::Squad(c) => &c.team,
            PlayerCommand::Robot { team, .. }
            | PlayerCommand::Split { team, .. }
            | PlayerCommand::Merge { team, .. }
            | PlayerCommand::Drive { team, .. }
            | PlayerCommand::Release { team, .. }
            | PlayerCommand::Setup { team, .. }
            | PlayerCommand::Ready { team, .. } => team,
        }
    }

    /// The packet, on the team's player channel.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        if let PlayerCommand::Squad(c) = self {
            return c.encode();
        }
        let mut p = PacketBuilder::new([player_channel(self.team())], Priority(0));
        match self {
            PlayerCommand::Squad(_) => unreachable!("encoded above"),
            PlayerCommand::Robot { robot, verb, .. } => {
                let mut l = p.line("robot");
                l.field("id", *robot);
                write_verb(&mut l, verb);
            }
            PlayerCommand::Split {
                squad,
                robots,
                into,
                ..
            } => {
                let ids: Vec<String> = robots.iter().map(u32::to_string).collect();
                p.line("split")
                    .bare("name", squad)
                    .field("robots", ids.join(" ").as_str())
                    .bare("into", into);
            }
            PlayerCommand::Merge { squad, into, .. } => {
                p.line("merge").bare("name", squad).bare("into", into);
            }
            PlayerCommand::Drive {
                robot,
                forward,
                turn,
                ..
            } => {
                p.line("drive")
                    .field("robot", *robot)
                    .field("forward", crate::fields::r(*forward))
                    .field("turn", crate::fields::r(*turn));
            }
            PlayerCommand::Release { robot, .. } => {
                p.line("release").field("robot", *robot);
            }
            PlayerCommand::Setup { squads, ready, .. } => {
                p.line("setup")
                    .field("squads", squads.as_str())
                    .field("ready", i64::from(*ready));
            }
            PlayerCommand::Ready { ready, .. } => {
                p.line("ready").field("value", i64::from(*ready));
            }
        }
        p.finish()
    }

    /// Reads every line of a packet that came on `team`'s player channel, in order; the first
    /// line it cannot read refuses the packet.
    pub fn decode(team: &str, packet: &Packet<'_>) -> Result<Vec<PlayerCommand>, DecodeError> {
        packet.lines().map(|l| read(team, &l)).collect()
    }
}

/// The one refusal a packet gets, however many of its lines were refused: the first reason, and
/// how many more (a forged packet of many bad lines cannot multiply the answers).
pub fn one_refusal(reasons: &[String]) -> Option<String> {
    let first = reasons.first()?;
    Some(match reasons.len() {
        1 => first.clone(),
        n => format!("{first} (and {} more lines refused)", n - 1),
    })
}

/// The commands with only the last `drive` of each robot kept: a packet of many drives for
/// one robot is one drive, not as many orders.
pub fn latest_drives(commands: Vec<PlayerCommand>) -> Vec<PlayerCommand> {
    let mut last = std::collections::BTreeMap::new();
    for (k, c) in commands.iter().enumerate() {
        if let PlayerCommand::Drive { robot, .. } = c {
            last.insert(*robot, k);
        }
    }
    commands
        .into_iter()
        .enumerate()
        .filter(|(k, c)| match c {
            PlayerCommand::Drive { robot, .. } => last.get(robot) == Some(k),
            _ => true,
        })
        .map(|(_, c)| c)
        .collect()
}

fn read(team: &str, l: &Line<'_>) -> Result<PlayerCommand, DecodeError> {
    let team = team.to_string();
    Ok(match l.label() {
        "squad" => PlayerCommand::Squad(SquadCommand::read(team, l)?),
        "robot" => PlayerCommand::Robot {
            team,
            robot: robot_id(l, "id")?,
            verb: match read_verb(l)? {
                Verb::Gather(_) | Verb::Path(_) => {
                    return Err(bad(
                        l,
                        "one robot takes goto, attack, defend, capture or stop",
                    ))
                }
                v => v,
            },
        },
        "split" => {
            let text = l.str("robots")?;
            let robots = text
                .split_whitespace()
                .map(|t| {
                    t.parse::<u32>()
                        .map_err(|_| bad(l, format!("robots: {t:?} is not a robot id")))
                })
                .collect::<Result<Vec<u32>, _>>()?;
            if robots.is_empty() || robots.len() > MAX_SPLIT {
                return Err(bad(
                    l,
                    format!(
                        "a split names 1 to {MAX_SPLIT} robots, not {}",
                        robots.len()
                    ),
                ));
            }
            PlayerCommand::Split {
                team,
                squad: plain_name(l, "name")?,
                robots,
                into: plain_name(l, "into")?,
            }
        }
        "merge" => PlayerCommand::Merge {
            team,
            squad: plain_name(l, "name")?,
            into: plain_name(l, "into")?,
        },
        "drive" => PlayerCommand::Drive {
            team,
            robot: robot_id(l, "robot")?,
            forward: within(l, "forward", -1.0..=1.0)?,
            turn: within(l, "turn", -1.0..=1.0)?,
        },
        "release" => PlayerCommand::Release {
            team,
            robot: robot_id(l, "robot")?,
        },
        "setup" => {
            let squads = l.str("squads")?.into_owned();
            if squads.len() > super::lobby::MAX_SETUP {
                return Err(bad(
                    l,
                    format!("a setup is at most {} bytes", super::lobby::MAX_SETUP),
                ));
            }
            PlayerCommand::Setup {
                team,
                squads,
                ready: match l.get("ready") {
                    Some(_) => crate::fields::flag(l, "ready")?,
                    None => false,
                },
            }
        }
        "ready" => PlayerCommand::Ready {
            team,
            ready: crate::fields::flag(l, "value")?,
        },
        other => {
            return Err(bad(
                l,
                format!(
                    "unknown player command {other:?} (expected squad, robot, split, merge, drive, release, setup or ready)"
                ),
            ))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::game::squad::Target;
    use crate::Vec2;
    use proptest::prelude::*;

    fn every_kind() -> Vec<PlayerCommand> {
        let team = || "red".to_string();
        vec![
            PlayerCommand::Squad(SquadCommand {
                team: team(),
                squad: "alpha".into(),
                verb: Verb::Path(vec![Vec2::new(100.0, 80.0), Vec2::new(300.0, 400.0)]),
                formation: None,
            }),
            PlayerCommand::Robot {
                team: team(),
                robot: 3,
                verb: Verb::Attack(Target::Robot(9)),
            },
            PlayerCommand::Robot {
                team: team(),
                robot: 3,
                verb: Verb::GoTo(Vec2::new(12.5, 40.0)),
            },
            PlayerCommand::Split {
                team: team(),
                squad: "alpha".into(),
                robots: vec![4, 5],
                into: "bravo".into(),
            },
            PlayerCommand::Merge {
                team: team(),
                squad: "bravo".into(),
                into: "alpha".into(),
            },
            PlayerCommand::Drive {
                team: team(),
                robot: 3,
                forward: 0.8,
                turn: -0.5,
            },
            PlayerCommand::Release {
                team: team(),
                robot: 3,
            },
            PlayerCommand::Setup {
                team: team(),
                squads: "alpha:tank+h2+p1,scout bravo:infantry".into(),
                ready: true,
            },
            PlayerCommand::Ready {
                team: team(),
                ready: true,
            },
        ]
    }

    #[test]
    fn every_kind_of_command_is_read_as_sent() {
        for c in every_kind() {
            let bytes = c.encode().unwrap();
            let read = PlayerCommand::decode("red", &Packet::parse(&bytes).unwrap()).unwrap();
            assert_eq!(read, vec![c], "{}", String::from_utf8_lossy(&bytes));
        }
    }

    #[test]
    fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
        use crate::game::Formation;
        let verbs = [
            Verb::Attack(Target::Robot(9)),
            Verb::Attack(Target::Flag("blue".into())),
            Verb::Defend(Target::Base("red".into())),
            Verb::GoTo(Vec2::new(12.5, 40.0)),
            Verb::Capture("blue".into()),
            Verb::Stop,
        ];
        let mut commands = every_kind();
        for verb in verbs {
            commands.push(PlayerCommand::Robot {
                team: "red".into(),
                robot: 4,
                verb: verb.clone(),
            });
            commands.push(PlayerCommand::Squad(SquadCommand {
                team: "red".into(),
                squad: "alpha".into(),
                verb,
                formation: Some(Formation::Wedge),
            }));
        }
        let samples: Vec<Vec<u8>> = commands.iter().map(|c| c.encode().unwrap()).collect();
        crate::table::check::codec(&TABLE, &samples, |p| {
            PlayerCommand::decode("red", p).is_ok()
        });
    }

    #[test]
    fn bad_lines_are_refused_with_a_reason() {
        for (text, why) in [
            ("drive robot 3 forward 2 turn 0", "forward 2 is not within"),
            ("drive robot 3 forward nan turn 0", "forward"),
            ("split name alpha robots \"\" into b", "1 to 256 robots"),
            (
                "split name alpha robots \"3 x\" into b",
                "\"x\" is not a robot id",
            ),
            (
                "merge name alpha into \"a b\"",
                "into \"a b\" is not a name",
            ),
            ("robot id -1 do stop", "not a robot id"),
            ("squad name a do path points \"\"", "1 to 64 points"),
            ("squad name a do path points \"1,2 3\"", "path point \"3\""),
            ("dance robot 3", "unknown player command \"dance\""),
        ] {
            let bytes = format!("@ <game.player.red> 0\n{text}\n");
            let e = PlayerCommand::decode("red", &Packet::parse(bytes.as_bytes()).unwrap())
                .expect_err(text);
            assert!(e.to_string().contains(why), "{text}: {e}");
        }
    }

    proptest! {
        #[test]
        fn any_packet_on_a_player_channel_is_read_or_refused(body in "[ -~\n]{0,200}") {
            let bytes = format!("@ <game.player.red> 0\n{body}");
            if let Ok(p) = Packet::parse(bytes.as_bytes()) {
                let _ = PlayerCommand::decode("red", &p);
            }
        }
    }
}
