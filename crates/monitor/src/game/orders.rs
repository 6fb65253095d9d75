//! A player's orders from the game page: read as untrusted JSON, checked, and written as the
//! packets the game reads on `game.player.<team>` (and `game.chat.<team>`).
//!
//! ```text
//! {"t":"squad","team":"red","squad":"alpha","do":"attack","robot":7,"formation":"wedge"}
//!   becomes
//! @ <game.player.red> 0
//! squad name alpha do attack robot 7 formation wedge
//!
//! {"t":"squad","team":"red","squad":"alpha","do":"path","points":[[100,80],[300,400]]}
//! {"t":"robot","team":"red","id":3,"do":"goto","x":300,"y":120}    one robot, alone
//! {"t":"split","team":"red","squad":"alpha","robots":[4,5],"into":"bravo"}
//! {"t":"merge","team":"red","squad":"bravo","into":"alpha"}
//! {"t":"robot_drive","team":"red","robot":3,"forward":0.8,"turn":-0.5}
//! {"t":"robot_release","team":"red","robot":3}
//! {"t":"chat","team":"red","from":"ada","text":"hold the bridge"}
//! ```
//!
//! The packets, their verbs and formations are [`colony_proto::game`]'s: this module only
//! checks what the page sent (a sentence for the player when it is wrong) and words the reply.
//! The game server still has the last word and answers with a `refused` event when the rules
//! say no.

use std::fmt;

use colony_proto::fields::MAX_COORD;
use colony_proto::game::chat::MAX_CHAT;
use colony_proto::game::player::MAX_SPLIT;
use colony_proto::game::{
    valid_name, ChatLine, Formation, PlayerCommand, SquadCommand, Target, Verb, MAX_DRAWN_POINTS,
    MAX_NAME,
};
use colony_proto::Vec2;
use serde::Deserialize;

/// A checked order for the game, ready to publish; it displays as the reply the player reads.
#[derive(Debug, Clone, PartialEq)]
pub enum GameOrder {
    /// For the game server.
    Player(PlayerCommand),
    /// For the team's other players.
    Chat(ChatLine),
}

/// What the page wants done, in the fields a squad's and a robot's orders share. Numbers
/// arrive as JSON numbers; ids as whole numbers.
#[derive(Debug, Deserialize)]
pub struct VerbMsg {
    #[serde(rename = "do")]
    verb: String,
    #[serde(default)]
    robot: Option<u32>,
    #[serde(default)]
    flag: Option<String>,
    #[serde(default)]
    base: Option<String>,
    #[serde(default)]
    x: Option<f64>,
    #[serde(default)]
    y: Option<f64>,
    #[serde(default)]
    points: Option<Vec<(f64, f64)>>,
}

/// A squad command from the page.
#[derive(Debug, Deserialize)]
pub struct SquadMsg {
    team: String,
    squad: String,
    #[serde(default)]
    formation: Option<String>,
    #[serde(flatten)]
    verb: VerbMsg,
}

/// One robot's order from the page: it leaves its squad to carry it out.
#[derive(Debug, Deserialize)]
pub struct RobotMsg {
    team: String,
    id: u32,
    #[serde(flatten)]
    verb: VerbMsg,
}

/// Some robots of a squad form a new one.
#[derive(Debug, Deserialize)]
pub struct SplitMsg {
    team: String,
    squad: String,
    robots: Vec<u32>,
    into: String,
}

/// A squad joins another.
#[derive(Debug, Deserialize)]
pub struct MergeMsg {
    team: String,
    squad: String,
    into: String,
}

/// The player's keys on one robot.
#[derive(Debug, Deserialize)]
pub struct SteerMsg {
    team: String,
    robot: u32,
    forward: f64,
    turn: f64,
}

/// The player gives a driven robot back to its squad.
#[derive(Debug, Deserialize)]
pub struct FreeMsg {
    team: String,
    robot: u32,
}

/// Before the match: the team's squads and robots, as `--red` takes them.
#[derive(Debug, Deserialize)]
pub struct SetupMsg {
    team: String,
    squads: String,
    #[serde(default)]
    ready: bool,
}

/// Before the match: the player is ready (or not).
#[derive(Debug, Deserialize)]
pub struct ReadyMsg {
    team: String,
    ready: bool,
}

/// A chat line for the team.
#[derive(Debug, Deserialize)]
pub struct ChatMsg {
    team: String,
    #[serde(default)]
    from: Option<String>,
    text: String,
}

/// Why the page's order was refused: a sentence for the player.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct OrderRefused(String);

fn token(what: &str, s: &str) -> Result<String, String> {
    if valid_name(s) {
        Ok(s.to_owned())
    } else {
        let shown: String = s.chars().take(40).collect();
        Err(format!(
            "{what} {shown:?} is not a name: use 1 to {MAX_NAME} characters of A-Z a-z 0-9 _ -"
        ))
    }
}

fn coord(name: &str, v: f64) -> Result<f64, String> {
    if v.is_finite() && v.abs() <= MAX_COORD {
        Ok(v)
    } else {
        Err(format!(
            "{name} must be a position in cm within ±{MAX_COORD}, not {v}"
        ))
    }
}

fn unit(name: &str, v: f64) -> Result<f64, String> {
    if v.is_finite() && (-1.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{name} must be within -1 and 1, not {v}"))
    }
}

impl VerbMsg {
    /// The point `x y`, when both or neither are given.
    fn point(&self) -> Result<Option<Vec2>, String> {
        match (self.x, self.y) {
            (Some(x), Some(y)) => Ok(Some(Vec2::new(coord("x", x)?, coord("y", y)?))),
            (None, None) => Ok(None),
            _ => Err("give both x and y (cm), or neither".into()),
        }
    }

    /// The one target of an attack or a defence.
    fn target(&self, verb: &str, point_allowed: bool) -> Result<Target, String> {
        self.only(verb, &["robot", "flag", "base", "x", "y"])?;
        let given = [
            self.robot.is_some(),
            self.flag.is_some(),
            self.base.is_some(),
            self.x.is_some() || self.y.is_some(),
        ];
        let choices = if point_allowed {
            "robot, flag, base or x and y"
        } else {
            "robot, flag or base"
        };
        match given.iter().filter(|g| **g).count() {
            0 => return Err(format!("{verb} needs a target: {choices}")),
            1 => {}
            _ => return Err(format!("{verb} takes one target ({choices}), not several")),
        }
        if let Some(id) = self.robot {
            Ok(Target::Robot(id))
        } else if let Some(f) = &self.flag {
            Ok(Target::Flag(token("flag team", f)?))
        } else if let Some(b) = &self.base {
            Ok(Target::Base(token("base team", b)?))
        } else if point_allowed {
            let p = self.point()?.ok_or("give both x and y (cm)")?;
            Ok(Target::Point(p))
        } else {
            Err(format!("{verb} needs a target: {choices}"))
        }
    }

    /// Refuses target fields the verb does not take, so a page bug shows
    /// instead of being half obeyed.
    fn only(&self, verb: &str, allowed: &[&str]) -> Result<(), String> {
        let present = [
            ("robot", self.robot.is_some()),
            ("flag", self.flag.is_some()),
            ("base", self.base.is_some()),
            ("x", self.x.is_some()),
            ("y", self.y.is_some()),
            ("points", self.points.is_some()),
        ];
        for (name, is) in present {
            if is && !allowed.contains(&name) {
                return Err(format!("{verb} takes no {name}"));
            }
        }
        Ok(())
    }

    /// The verb, every field checked.
    fn checked(&self) -> Result<Verb, String> {
        Ok(match self.verb.as_str() {
            "gather" => {
                self.only("gather", &["x", "y"])?;
                Verb::Gather(self.point()?)
            }
            "goto" => {
                self.only("goto", &["x", "y"])?;
                let p = self.point()?.ok_or("goto needs x and y (cm)")?;
                Verb::GoTo(p)
            }
            "attack" => Verb::Attack(self.target("attack", true)?),
            "defend" => Verb::Defend(self.target("defend", false)?),
            "capture" => {
                self.only("capture", &["flag"])?;
                let f = self
                    .flag
                    .as_deref()
                    .ok_or("capture needs the flag's team: flag")?;
                Verb::Capture(token("flag team", f)?)
            }
            "path" => {
                self.only("path", &["points"])?;
                let points = self.points.as_deref().unwrap_or_default();
                if points.is_empty() || points.len() > MAX_DRAWN_POINTS {
                    return Err(format!(
                        "a drawn path needs 1 to {MAX_DRAWN_POINTS} points [x, y], not {}",
                        points.len()
                    ));
                }
                Verb::Path(
                    points
                        .iter()
                        .map(|&(x, y)| Ok(Vec2::new(coord("x", x)?, coord("y", y)?)))
                        .collect::<Result<_, String>>()?,
                )
            }
            "stop" => {
                self.only("stop", &[])?;
                Verb::Stop
            }
            other => {
                let shown: String = other.chars().take(40).collect();
                return Err(format!(
                    "unknown squad command {shown:?} (expected gather, goto, attack, defend, capture, path or stop)"
                ));
            }
        })
    }
}

impl SquadMsg {
    /// Checks every field.
    pub fn check(&self) -> Result<GameOrder, OrderRefused> {
        self.checked().map_err(OrderRefused)
    }

    fn checked(&self) -> Result<GameOrder, String> {
        let team = token("team", &self.team)?;
        let squad = token("squad", &self.squad)?;
        let verb = self.verb.checked()?;
        let formation = match self.formation.as_deref() {
            None | Some("") => None,
            Some(f) => Some(f.parse::<Formation>().map_err(|_| {
                let shown: String = f.chars().take(40).collect();
                format!(
                    "unknown formation {shown:?} (expected line, circle, half-circle, wedge or inverse-wedge)"
                )
            })?),
        };
        Ok(GameOrder::Player(PlayerCommand::Squad(SquadCommand {
            team,
            squad,
            verb,
            formation,
        })))
    }
}

impl RobotMsg {
    /// Checks every field.
    pub fn check(&self) -> Result<GameOrder, OrderRefused> {
        let verb = self.verb.checked().map_err(OrderRefused)?;
        if matches!(verb, Verb::Gather(_) | Verb::Path(_)) {
            return Err(OrderRefused(
                "one robot takes goto, attack, defend, capture or stop".into(),
            ));
        }
        Ok(GameOrder::Player(PlayerCommand::Robot {
            team: token("team", &self.team).map_err(OrderRefused)?,
            robot: self.id,
            verb,
        }))
    }
}

impl SplitMsg {
    /// Checks every field.
    pub fn check(&self) -> Result<GameOrder, OrderRefused> {
        (|| {
            if self.robots.is_empty() || self.robots.len() > MAX_SPLIT {
                return Err(format!(
                    "a split takes 1 to {MAX_SPLIT} robots, not {}",
                    self.robots.len()
                ));
            }
            Ok(GameOrder::Player(PlayerCommand::Split {
                team: token("team", &self.team)?,
                squad: token("squad", &self.squad)?,
                robots: self.robots.clone(),
                into: token("new squad", &self.into)?,
            }))
        })()
        .map_err(OrderRefused)
    }
}

impl MergeMsg {
    /// Checks every field.
    pub fn check(&self) -> Result<GameOrder, OrderRefused> {
        (|| {
            Ok(GameOrder::Player(PlayerCommand::Merge {
                team: token("team", &self.team)?,
                squad: token("squad", &self.squad)?,
                into: token("squad", &self.into)?,
            }))
        })()
        .map_err(OrderRefused)
    }
}

impl SteerMsg {
    /// Checks every field.
    pub fn check(&self) -> Result<GameOrder, OrderRefused> {
        (|| {
            Ok(GameOrder::Player(PlayerCommand::Drive {
                team: token("team", &self.team)?,
                robot: self.robot,
                forward: unit("forward", self.forward)?,
                turn: unit("turn", self.turn)?,
            }))
        })()
        .map_err(OrderRefused)
    }
}

impl FreeMsg {
    /// Checks every field.
    pub fn check(&self) -> Result<GameOrder, OrderRefused> {
        Ok(GameOrder::Player(PlayerCommand::Release {
            team: token("team", &self.team).map_err(OrderRefused)?,
            robot: self.robot,
        }))
    }
}

impl SetupMsg {
    /// Checks the fields the page can get wrong; the rules and the budget are the game's.
    pub fn check(&self) -> Result<GameOrder, OrderRefused> {
        (|| {
            let max = colony_proto::game::lobby::MAX_SETUP;
            if self.squads.len() > max || self.squads.chars().any(char::is_control) {
                return Err(format!("a setup is at most {max} printable characters"));
            }
            Ok(GameOrder::Player(PlayerCommand::Setup {
                team: token("team", &self.team)?,
                squads: self.squads.trim().to_string(),
                ready: self.ready,
            }))
        })()
        .map_err(OrderRefused)
    }
}

impl ReadyMsg {
    /// Checks every field.
    pub fn check(&self) -> Result<GameOrder, OrderRefused> {
        Ok(GameOrder::Player(PlayerCommand::Ready {
            team: token("team", &self.team).map_err(OrderRefused)?,
            ready: self.ready,
        }))
    }
}

impl ChatMsg {
    /// Checks every field: a short line of printable text.
    pub fn check(&self) -> Result<GameOrder, OrderRefused> {
        (|| {
            let text = self.text.trim();
            if text.is_empty() {
                return Err("say something: the chat line is empty".to_string());
            }
            if text.chars().count() > MAX_CHAT || text.chars().any(char::is_control) {
                return Err(format!(
                    "a chat line is at most {MAX_CHAT} printable characters"
                ));
            }
            Ok(GameOrder::Chat(ChatLine {
                team: token("team", &self.team)?,
                from: token("name", self.from.as_deref().unwrap_or("player"))?,
                text: text.to_string(),
            }))
        })()
        .map_err(OrderRefused)
    }
}

impl GameOrder {
    /// The channel this order is published on.
    pub fn channel(&self) -> String {
        match self {
            GameOrder::Player(c) => colony_proto::game::player_channel(c.team()),
            GameOrder::Chat(c) => colony_proto::game::chat_channel(&c.team),
        }
    }

    /// The packet for the game.
    pub fn packet(&self) -> Result<Vec<u8>, colony_wire::ParseError> {
        match self {
            GameOrder::Player(c) => c.encode(),
            GameOrder::Chat(c) => c.encode(),
        }
    }
}

/// A target as the reply words it.
struct Shown<'a>(&'a Target);

impl fmt::Display for Shown<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Target::Robot(id) => write!(f, "robot {id}"),
            Target::Flag(t) => write!(f, "{t}'s flag"),
            Target::Base(t) => write!(f, "{t}'s base"),
            Target::Point(p) => write!(f, "({:.0}, {:.0})", p.x, p.y),
        }
    }
}

/// A verb as the reply words it.
struct Said<'a>(&'a Verb);

impl fmt::Display for Said<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Verb::Gather(None) => f.write_str("gather"),
            Verb::Gather(Some(p)) => write!(f, "gather at ({:.0}, {:.0})", p.x, p.y),
            Verb::GoTo(p) => write!(f, "go to ({:.0}, {:.0})", p.x, p.y),
            Verb::Attack(t) => write!(f, "attack {}", Shown(t)),
            Verb::Defend(t) => write!(f, "defend {}", Shown(t)),
            Verb::Capture(t) => write!(f, "capture {t}'s flag"),
            Verb::Path(points) => write!(f, "follow a drawn path of {} points", points.len()),
            Verb::Stop => f.write_str("stop"),
        }
    }
}

impl fmt::Display for GameOrder {
    /// The reply the player reads: `red alpha: attack robot 7 in wedge`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = match self {
            GameOrder::Chat(c) => return write!(f, "said to team {}: {}", c.team, c.text),
            GameOrder::Player(c) => c,
        };
        match c {
            PlayerCommand::Squad(c) => {
                write!(f, "{} {}: {}", c.team, c.squad, Said(&c.verb))?;
                if let Some(form) = c.formation {
                    write!(f, " in {}", form.name())?;
                }
                Ok(())
            }
            PlayerCommand::Robot { team, robot, verb } => {
                write!(f, "{team} robot {robot}: {}", Said(verb))
            }
            PlayerCommand::Split {
                team,
                squad,
                robots,
                into,
            } => write!(f, "{team} {squad}: robots {robots:?} split off as {into}"),
            PlayerCommand::Merge { team, squad, into } => {
                write!(f, "{team} {squad}: merge into {into}")
            }
            PlayerCommand::Drive {
                team,
                robot,
                forward,
                turn,
            } => write!(
                f,
                "{team} robot {robot}: driven ({forward:.1} ahead, {turn:.1} turn)"
            ),
            PlayerCommand::Release { team, robot } => {
                write!(f, "{team} robot {robot}: back to its squad")
            }
            PlayerCommand::Setup {
                team,
                squads,
                ready,
            } => write!(
                f,
                "{team} set up as {squads}{}",
                if *ready { ", ready" } else { "" }
            ),
            PlayerCommand::Ready { team, ready: true } => write!(f, "{team} is ready"),
            PlayerCommand::Ready { team, ready: false } => write!(f, "{team} is not ready"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(json: &str) -> Result<GameOrder, String> {
        serde_json::from_str::<SquadMsg>(json)
            .map_err(|e| e.to_string())?
            .check()
            .map_err(|e| e.to_string())
    }

    fn packet(json: &str) -> String {
        String::from_utf8(check(json).unwrap().packet().unwrap()).unwrap()
    }

    #[test]
    fn every_verb_becomes_the_line_the_game_reads() {
        let cases = [
            (
                r#"{"team":"red","squad":"alpha","do":"attack","robot":7,"formation":"wedge"}"#,
                "squad name alpha do attack robot 7 formation wedge",
            ),
            (
                r#"{"team":"red","squad":"alpha","do":"gather"}"#,
                "squad name alpha do gather",
            ),
            (
                r#"{"team":"red","squad":"a_1","do":"gather","x":10,"y":-2.5}"#,
                "squad name a_1 do gather x 10.0 y -2.5",
            ),
            (
                r#"{"team":"red","squad":"alpha","do":"goto","x":310.456,"y":88,"formation":"inverse-wedge"}"#,
                "squad name alpha do goto x 310.46 y 88.0 formation inverse-wedge",
            ),
            (
                r#"{"team":"red","squad":"alpha","do":"attack","flag":"blue"}"#,
                "squad name alpha do attack flag blue",
            ),
            (
                r#"{"team":"red","squad":"alpha","do":"attack","x":1,"y":2}"#,
                "squad name alpha do attack x 1.0 y 2.0",
            ),
            (
                r#"{"team":"red","squad":"alpha","do":"defend","flag":"red","formation":"circle"}"#,
                "squad name alpha do defend flag red formation circle",
            ),
            (
                r#"{"team":"red","squad":"alpha","do":"defend","robot":3}"#,
                "squad name alpha do defend robot 3",
            ),
            (
                r#"{"team":"red","squad":"alpha","do":"defend","base":"red","formation":"half-circle"}"#,
                "squad name alpha do defend base red formation half-circle",
            ),
            (
                r#"{"team":"red","squad":"alpha","do":"capture","flag":"blue","formation":"line"}"#,
                "squad name alpha do capture flag blue formation line",
            ),
            (
                r#"{"team":"red","squad":"alpha","do":"stop","formation":""}"#,
                "squad name alpha do stop",
            ),
        ];
        for (json, line) in cases {
            assert_eq!(
                packet(json),
                format!("@ <game.player.red> 0\n{line}\n"),
                "{json}"
            );
        }
    }

    /// Every command the page can send, in every formation, is read by the game's decoder as
    /// the command checked, and re-encodes to the same bytes.
    #[test]
    fn every_squad_command_the_page_can_send_is_read_by_the_game_as_sent() {
        let targets = [
            r#""robot":7"#,
            r#""flag":"blue""#,
            r#""base":"red""#,
            r#""x":120.5,"y":-33.25"#,
        ];
        let mut bodies = vec![
            r#""do":"gather""#.to_string(),
            r#""do":"gather","x":10,"y":20.125"#.to_string(),
            r#""do":"goto","x":1500,"y":0.01"#.to_string(),
            r#""do":"capture","flag":"blue""#.to_string(),
            r#""do":"stop""#.to_string(),
        ];
        for t in targets {
            bodies.push(format!(r#""do":"attack",{t}"#));
            if !t.starts_with(r#""x""#) {
                bodies.push(format!(r#""do":"defend",{t}"#));
            }
        }
        let mut checked = 0;
        for body in &bodies {
            for formation in std::iter::once(String::new())
                .chain(Formation::ALL.map(|f| format!(r#","formation":"{f}""#)))
            {
                let json = format!(r#"{{"team":"red","squad":"alpha",{body}{formation}}}"#);
                let order = check(&json).unwrap_or_else(|e| panic!("{json}: {e}"));
                let sent = order.packet().unwrap();
                let packet = colony_wire::Packet::parse(&sent).unwrap();
                let read = SquadCommand::decode("red", &packet)
                    .unwrap_or_else(|e| panic!("the game refuses {json}: {e}"));
                assert_eq!(read.len(), 1, "{json}");
                assert_eq!(read[0].encode().unwrap(), sent, "{json}");
                assert_eq!(read[0].squad, "alpha");
                checked += 1;
            }
        }
        assert_eq!(checked, 12 * 6);
    }

    #[test]
    fn the_reply_says_what_was_ordered() {
        let o =
            check(r#"{"team":"red","squad":"alpha","do":"attack","robot":7,"formation":"wedge"}"#)
                .unwrap();
        assert_eq!(o.to_string(), "red alpha: attack robot 7 in wedge");
        assert_eq!(o.channel(), "game.player.red");
    }

    #[test]
    fn bad_commands_are_refused_with_a_reason() {
        for (json, says) in [
            (
                r#"{"team":"red team","squad":"a","do":"stop"}"#,
                "team \"red team\" is not a name",
            ),
            (r#"{"team":"","squad":"a","do":"stop"}"#, "is not a name"),
            (r#"{"team":"red","squad":"a\nb","do":"stop"}"#, "squad"),
            (
                &format!(
                    r#"{{"team":"red","squad":"{}","do":"stop"}}"#,
                    "a".repeat(33)
                ),
                "is not a name",
            ),
            (
                r#"{"team":"red","squad":"a","do":"dance"}"#,
                "unknown squad command \"dance\"",
            ),
            (
                r#"{"team":"red","squad":"a","do":"goto"}"#,
                "goto needs x and y",
            ),
            (
                r#"{"team":"red","squad":"a","do":"goto","x":1}"#,
                "both x and y",
            ),
            (
                r#"{"team":"red","squad":"a","do":"goto","x":2e6,"y":0}"#,
                "within ±",
            ),
            (
                r#"{"team":"red","squad":"a","do":"goto","x":1,"y":1,"robot":3}"#,
                "goto takes no robot",
            ),
            (
                r#"{"team":"red","squad":"a","do":"attack"}"#,
                "attack needs a target",
            ),
            (
                r#"{"team":"red","squad":"a","do":"attack","robot":1,"flag":"blue"}"#,
                "one target",
            ),
            (
                r#"{"team":"red","squad":"a","do":"defend","x":1,"y":1}"#,
                "defend needs a target: robot, flag or base",
            ),
            (
                r#"{"team":"red","squad":"a","do":"capture"}"#,
                "capture needs the flag",
            ),
            (
                r#"{"team":"red","squad":"a","do":"capture","flag":"<blue>"}"#,
                "is not a name",
            ),
            (
                r#"{"team":"red","squad":"a","do":"stop","x":1}"#,
                "stop takes no x",
            ),
            (
                r#"{"team":"red","squad":"a","do":"stop","formation":"square"}"#,
                "unknown formation \"square\"",
            ),
        ] {
            let e = check(json).unwrap_err();
            assert!(e.contains(says), "{json}: {e}");
        }
    }
}
