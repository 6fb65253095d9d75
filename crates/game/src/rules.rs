//! The data model: robot types, the rules a player sets at the start, and
//! the checks that refuse illegal operations.
//!
//! The paper names the robot types (scout, tank, infantry, amphibian) and the
//! player's choices (a budget that buys health and power, the division into
//! squads) but gives no numbers; the ones here are ours, picked so each type
//! has a reason to exist: scouts are fast and fragile, tanks slow and strong,
//! infantry in between, and only amphibians cross water.

use std::fmt;
use std::str::FromStr;

pub use colony_proto::game::{valid_name, RobotKind, UnknownKind};
use serde::Serialize;

/// What a robot type can do.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct KindStats {
    /// Budget points it costs.
    pub cost: u32,
    /// Health it starts with.
    pub health: f64,
    /// Damage one shot does.
    pub damage: f64,
    /// Seconds between two shots (the shooting rate).
    pub reload_s: f64,
    /// How far it shoots, centre to centre, cm.
    pub range_cm: f64,
    /// Top speed, cm/s.
    pub speed_cm_s: f64,
    /// Top turn rate, rad/s.
    pub turn_rad_s: f64,
    /// Body radius, cm.
    pub radius_cm: f64,
    /// Whether water is passable for it.
    pub amphibious: bool,
}

/// The rules' numbers for a robot type (the type itself is a word of the game's messages).
pub trait KindRules {
    /// The type's numbers.
    fn stats(self) -> KindStats;
}

impl KindRules for RobotKind {
    fn stats(self) -> KindStats {
        match self {
            RobotKind::Scout => KindStats {
                cost: 2,
                health: 40.0,
                damage: 4.0,
                reload_s: 0.5,
                range_cm: 70.0,
                speed_cm_s: 30.0,
                turn_rad_s: 3.0,
                radius_cm: 5.0,
                amphibious: false,
            },
            RobotKind::Tank => KindStats {
                cost: 5,
                health: 120.0,
                damage: 15.0,
                reload_s: 1.2,
                range_cm: 100.0,
                speed_cm_s: 14.0,
                turn_rad_s: 1.5,
                radius_cm: 6.5,
                amphibious: false,
            },
            RobotKind::Infantry => KindStats {
                cost: 3,
                health: 60.0,
                damage: 6.0,
                reload_s: 0.6,
                range_cm: 80.0,
                speed_cm_s: 20.0,
                turn_rad_s: 2.5,
                radius_cm: 5.5,
                amphibious: false,
            },
            RobotKind::Amphibian => KindStats {
                cost: 4,
                health: 60.0,
                damage: 5.0,
                reload_s: 0.8,
                range_cm: 70.0,
                speed_cm_s: 18.0,
                turn_rad_s: 2.5,
                radius_cm: 5.5,
                amphibious: true,
            },
        }
    }
}

/// Which game is played.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Take the enemy flag to your own base.
    CaptureTheFlag,
    /// Destroy the enemy.
    DeathMatch,
}

impl FromStr for Mode {
    type Err = RuleError;
    fn from_str(s: &str) -> Result<Mode, RuleError> {
        match s {
            "ctf" | "capture-the-flag" => Ok(Mode::CaptureTheFlag),
            "dm" | "death-match" => Ok(Mode::DeathMatch),
            other => Err(RuleError::UnknownMode(other.to_string())),
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Mode::CaptureTheFlag => "ctf",
            Mode::DeathMatch => "dm",
        })
    }
}

/// The rules set at the start of a game.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rules {
    /// Which game.
    pub mode: Mode,
    /// Budget points per team.
    pub budget: u32,
    /// The game ends after this many seconds of game time.
    pub time_limit_s: f64,
    /// Capture the Flag: captures that win the game.
    pub captures_to_win: u32,
    /// Squads per team, at most.
    pub max_squads: usize,
}

impl Rules {
    /// The defaults for a mode.
    pub fn new(mode: Mode) -> Rules {
        Rules {
            mode,
            budget: 30,
            time_limit_s: 600.0,
            captures_to_win: 1,
            max_squads: 4,
        }
    }
}

/// The most points of health or of power one robot may buy.
pub const MAX_UPGRADE: u32 = 5;
/// What one point of health (of power) adds to the type's health (damage per shot), as a
/// fraction of it.
pub const UPGRADE_STEP: f64 = 0.2;

/// One robot as a player buys it: its type, and the budget points spent on its health and on
/// its power (the paper's budget "buys each robot's health and power"), one point each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct RobotBuild {
    /// Its type.
    pub kind: RobotKind,
    /// Points bought for health, 0 to [`MAX_UPGRADE`].
    pub health: u32,
    /// Points bought for power (damage per shot), 0 to [`MAX_UPGRADE`].
    pub power: u32,
}

impl RobotBuild {
    /// A robot of the type as it comes.
    pub fn plain(kind: RobotKind) -> RobotBuild {
        RobotBuild {
            kind,
            health: 0,
            power: 0,
        }
    }

    /// Budget points it costs.
    pub fn cost(&self) -> u32 {
        self.kind.stats().cost + self.health + self.power
    }

    /// The health it starts with (to a tenth).
    pub fn max_health(&self) -> f64 {
        upgraded(self.kind.stats().health, self.health)
    }

    /// The damage one of its shots does (to a tenth).
    pub fn damage(&self) -> f64 {
        upgraded(self.kind.stats().damage, self.power)
    }
}

/// `base` with `points` bought, to a tenth so a log reads `18`, not `17.999999999999996`.
fn upgraded(base: f64, points: u32) -> f64 {
    (base * (1.0 + UPGRADE_STEP * f64::from(points)) * 10.0).round() / 10.0
}

impl fmt::Display for RobotBuild {
    /// As a setup writes it: `tank`, `tank+h2`, `scout+h1+p3`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.kind.name())?;
        if self.health > 0 {
            write!(f, "+h{}", self.health)?;
        }
        if self.power > 0 {
            write!(f, "+p{}", self.power)?;
        }
        Ok(())
    }
}

impl FromStr for RobotBuild {
    type Err = RuleError;
    fn from_str(s: &str) -> Result<RobotBuild, RuleError> {
        let mut parts = s.split('+');
        let kind: RobotKind = parts.next().unwrap_or_default().parse()?;
        let mut build = RobotBuild::plain(kind);
        for p in parts {
            let (slot, points) = match p.split_at_checked(1) {
                Some(("h", n)) => (&mut build.health, n),
                Some(("p", n)) => (&mut build.power, n),
                _ => return Err(RuleError::BadBuild(s.to_string())),
            };
            *slot = points
                .parse::<u32>()
                .ok()
                .filter(|n| *n <= MAX_UPGRADE)
                .ok_or_else(|| RuleError::BadBuild(s.to_string()))?;
        }
        Ok(build)
    }
}

/// A squad as a player sets it up: a name and its robots.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SquadSetup {
    /// Unique within the team; used in commands.
    pub name: String,
    /// One entry per robot.
    pub robots: Vec<RobotBuild>,
}

/// A team as a player sets it up.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TeamSetup {
    /// Must match a team of the map.
    pub name: String,
    /// Its squads.
    pub squads: Vec<SquadSetup>,
}

impl fmt::Display for TeamSetup {
    /// As [`TeamSetup::parse`] reads it: `alpha:tank+h1,infantry bravo:scout`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.squads.iter().enumerate() {
            if i > 0 {
                f.write_str(" ")?;
            }
            write!(f, "{}:", s.name)?;
            for (k, r) in s.robots.iter().enumerate() {
                if k > 0 {
                    f.write_str(",")?;
                }
                write!(f, "{r}")?;
            }
        }
        Ok(())
    }
}

impl TeamSetup {
    /// Budget points the team spends.
    pub fn cost(&self) -> u32 {
        self.squads
            .iter()
            .flat_map(|s| &s.robots)
            .map(RobotBuild::cost)
            .sum()
    }

    /// Refuses a team the rules don't allow.
    pub fn check(&self, rules: &Rules) -> Result<(), RuleError> {
        if self.squads.is_empty() {
            return Err(RuleError::NoSquads(self.name.clone()));
        }
        if self.squads.len() > rules.max_squads {
            return Err(RuleError::TooManySquads {
                team: self.name.clone(),
                squads: self.squads.len(),
                max: rules.max_squads,
            });
        }
        for (i, s) in self.squads.iter().enumerate() {
            if s.robots.is_empty() {
                return Err(RuleError::EmptySquad(s.name.clone()));
            }
            if !valid_name(&s.name) {
                return Err(RuleError::BadName(s.name.clone()));
            }
            if self.squads[..i].iter().any(|o| o.name == s.name) {
                return Err(RuleError::DuplicateSquad(s.name.clone()));
            }
        }
        let cost = self.cost();
        if cost > rules.budget {
            return Err(RuleError::OverBudget {
                team: self.name.clone(),
                cost,
                budget: rules.budget,
            });
        }
        Ok(())
    }

    /// Parses `alpha:tank,infantry,infantry beta:scout,amphibian`.
    pub fn parse(name: &str, text: &str) -> Result<TeamSetup, RuleError> {
        let mut squads = Vec::new();
        for part in text.split_whitespace() {
            let (squad, kinds) = part
                .split_once(':')
                .ok_or_else(|| RuleError::BadSetup(part.to_string()))?;
            let robots = kinds
                .split(',')
                .map(str::parse)
                .collect::<Result<Vec<RobotBuild>, _>>()?;
            squads.push(SquadSetup {
                name: squad.to_string(),
                robots,
            });
        }
        Ok(TeamSetup {
            name: name.to_string(),
            squads,
        })
    }
}

/// Why a setup or an operation was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RuleError {
    /// Not one of the four types.
    #[error("unknown robot type {0:?} (expected scout, tank, infantry or amphibian)")]
    UnknownKind(String),
    /// Not a game mode.
    #[error("unknown game {0:?} (expected ctf or dm)")]
    UnknownMode(String),
    /// A team with nothing in it.
    #[error("team {0} has no squads")]
    NoSquads(String),
    /// More squads than the rules allow.
    #[error("team {team} has {squads} squads; the rules allow {max}")]
    TooManySquads {
        /// Which team.
        team: String,
        /// How many it asked for.
        squads: usize,
        /// The limit.
        max: usize,
    },
    /// A squad with no robots.
    #[error("squad {0} has no robots")]
    EmptySquad(String),
    /// Two squads of one name.
    #[error("two squads are called {0}")]
    DuplicateSquad(String),
    /// A name that isn't a plain token.
    #[error("{0:?} is not a usable name (letters, digits, - and _, at most 32)")]
    BadName(String),
    /// The robots cost more than the budget.
    #[error("team {team} costs {cost} points; the budget is {budget}")]
    OverBudget {
        /// Which team.
        team: String,
        /// What it costs.
        cost: u32,
        /// What it may spend.
        budget: u32,
    },
    /// A setup string that isn't `squad:kind,kind ...`.
    #[error("{0:?}: expected squad:kind,kind,... (e.g. alpha:tank,infantry)")]
    BadSetup(String),
    /// A robot's build does not read.
    #[error("{0:?}: expected a robot type with +hN health and +pN power points, N 0 to 5 (e.g. tank+h2+p1)")]
    BadBuild(String),
}

impl From<UnknownKind> for RuleError {
    fn from(e: UnknownKind) -> RuleError {
        RuleError::UnknownKind(e.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robots_health_and_power_are_bought_with_the_budget() {
        let t = TeamSetup::parse("red", "alpha:tank+h2+p1,scout bravo:infantry+p5").unwrap();
        assert_eq!(t.to_string(), "alpha:tank+h2+p1,scout bravo:infantry+p5");
        assert_eq!(t.cost(), 5 + 3 + 2 + 3 + 5);
        let tank = t.squads[0].robots[0];
        assert_eq!(tank.max_health(), 168.0);
        assert_eq!(tank.damage(), 18.0);
        assert_eq!(t.squads[0].robots[1], RobotBuild::plain(RobotKind::Scout));
        let rules = Rules::new(Mode::CaptureTheFlag);
        let even = TeamSetup::parse("red", "a:tank+h5+p5,tank+h5+p5").unwrap();
        assert_eq!(even.check(&rules), Ok(()));
        let rich = TeamSetup::parse("red", "a:tank+h5+p5,tank+h5+p5,scout").unwrap();
        assert_eq!(
            rich.check(&rules).unwrap_err().to_string(),
            "team red costs 32 points; the budget is 30"
        );
        for bad in [
            "a:tank+h6",
            "a:tank+x1",
            "a:tank+h",
            "a:tank+h-1",
            "a:tank++",
        ] {
            let e = TeamSetup::parse("red", bad).unwrap_err();
            assert!(matches!(e, RuleError::BadBuild(_)), "{bad}: {e}");
        }
    }

    #[test]
    fn a_team_over_budget_is_refused_with_its_cost() {
        let rules = Rules::new(Mode::CaptureTheFlag);
        let t = TeamSetup::parse("red", "a:tank,tank,tank,tank,tank,tank,tank").unwrap();
        assert_eq!(
            t.check(&rules).unwrap_err().to_string(),
            "team red costs 35 points; the budget is 30"
        );
        let ok = TeamSetup::parse("red", "a:tank,infantry b:scout,amphibian").unwrap();
        assert_eq!(ok.check(&rules), Ok(()));
    }

    #[test]
    fn bad_setups_name_the_problem() {
        let rules = Rules::new(Mode::DeathMatch);
        assert!(matches!(
            TeamSetup::parse("red", "a:tank,robot"),
            Err(RuleError::UnknownKind(k)) if k == "robot"
        ));
        assert!(matches!(
            TeamSetup::parse("red", "tank"),
            Err(RuleError::BadSetup(_))
        ));
        let dup = TeamSetup::parse("red", "a:tank a:scout").unwrap();
        assert_eq!(
            dup.check(&rules),
            Err(RuleError::DuplicateSquad("a".into()))
        );
        let none = TeamSetup::parse("red", "").unwrap();
        assert_eq!(none.check(&rules), Err(RuleError::NoSquads("red".into())));
    }

    #[test]
    fn only_the_amphibian_crosses_water_and_kinds_round_trip() {
        for k in RobotKind::ALL {
            assert_eq!(k.stats().amphibious, k == RobotKind::Amphibian);
            assert_eq!(k.name().parse::<RobotKind>(), Ok(k));
        }
    }
}
