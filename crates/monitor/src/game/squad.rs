//! A player's squad command from the game page: read as untrusted JSON,
//! checked, and written as the packet the game server reads on
//! `game.player.<team>`.
//!
//! ```text
//! {"t":"squad","team":"red","squad":"alpha","do":"attack","robot":7,"formation":"wedge"}
//!   becomes
//! @ <game.player.red> 0
//! squad name alpha do attack robot 7 formation wedge
//! ```
//!
//! The packet, its verbs and formations are [`colony_proto::game::squad`]'s: this module only
//! checks what the page sent (a sentence for the player when it is wrong) and words the reply.
//! The game server still has the last word and answers with a `refused` event when the rules
//! say no.

use std::fmt;

use colony_proto::fields::MAX_COORD;
use colony_proto::game::{valid_name, Formation, SquadCommand, Target, Verb, MAX_NAME};
use colony_proto::Vec2;
use serde::Deserialize;

/// A checked squad command, ready to publish; it displays as the reply the player reads.
#[derive(Debug, Clone, PartialEq)]
pub struct SquadOrder(pub SquadCommand);

/// The browser's message, before it is checked. Numbers arrive as JSON
/// numbers; ids as whole numbers.
#[derive(Debug, Deserialize)]
pub struct SquadMsg {
    team: String,
    squad: String,
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
    formation: Option<String>,
}

/// Why the page's squad order was refused: a sentence for the player.
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

impl SquadMsg {
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
        ];
        for (name, is) in present {
            if is && !allowed.contains(&name) {
                return Err(format!("{verb} takes no {name}"));
            }
        }
        Ok(())
    }

    /// Checks every field.
    pub fn check(&self) -> Result<SquadOrder, OrderRefused> {
        self.checked().map_err(OrderRefused)
    }

    fn checked(&self) -> Result<SquadOrder, String> {
        let team = token("team", &self.team)?;
        let squad = token("squad", &self.squad)?;
        let verb = match self.verb.as_str() {
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
            "stop" => {
                self.only("stop", &[])?;
                Verb::Stop
            }
            other => {
                let shown: String = other.chars().take(40).collect();
                return Err(format!(
                    "unknown squad command {shown:?} (expected gather, goto, attack, defend, capture or stop)"
                ));
            }
        };
        let formation = match self.formation.as_deref() {
            None | Some("") => None,
            Some(f) => Some(f.parse::<Formation>().map_err(|_| {
                let shown: String = f.chars().take(40).collect();
                format!(
                    "unknown formation {shown:?} (expected line, circle, half-circle, wedge or inverse-wedge)"
                )
            })?),
        };
        Ok(SquadOrder(SquadCommand {
            team,
            squad,
            verb,
            formation,
        }))
    }
}

impl SquadOrder {
    /// The channel this order is published on.
    pub fn channel(&self) -> String {
        colony_proto::game::player_channel(&self.0.team)
    }

    /// The packet for the game server.
    pub fn packet(&self) -> Result<Vec<u8>, colony_wire::ParseError> {
        self.0.encode()
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

impl fmt::Display for SquadOrder {
    /// The reply the player reads: `red alpha: attack robot 7 in wedge`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = &self.0;
        write!(f, "{} {}: ", c.team, c.squad)?;
        match &c.verb {
            Verb::Gather(None) => f.write_str("gather")?,
            Verb::Gather(Some(p)) => write!(f, "gather at ({:.0}, {:.0})", p.x, p.y)?,
            Verb::GoTo(p) => write!(f, "go to ({:.0}, {:.0})", p.x, p.y)?,
            Verb::Attack(t) => write!(f, "attack {}", Shown(t))?,
            Verb::Defend(t) => write!(f, "defend {}", Shown(t))?,
            Verb::Capture(t) => write!(f, "capture {t}'s flag")?,
            Verb::Stop => f.write_str("stop")?,
        }
        if let Some(form) = c.formation {
            write!(f, " in {}", form.name())?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(json: &str) -> Result<SquadOrder, String> {
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
