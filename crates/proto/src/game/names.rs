//! The game's words: the names, robot types and formations its messages carry.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

pub use crate::fields::{valid_plain_name as valid_name, MAX_NAME};

/// The four robot types of the paper (their numbers are the game's rules, not the message's).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RobotKind {
    /// Fast, fragile, short range.
    Scout,
    /// Slow, armoured, long range, hard-hitting.
    Tank,
    /// The all-rounder.
    Infantry,
    /// Crosses water, which stops every other type.
    Amphibian,
}

impl RobotKind {
    /// Every type, in a fixed order.
    pub const ALL: [RobotKind; 4] = [
        RobotKind::Scout,
        RobotKind::Tank,
        RobotKind::Infantry,
        RobotKind::Amphibian,
    ];

    /// The name used in packets and configs.
    pub fn name(self) -> &'static str {
        match self {
            RobotKind::Scout => "scout",
            RobotKind::Tank => "tank",
            RobotKind::Infantry => "infantry",
            RobotKind::Amphibian => "amphibian",
        }
    }
}

impl fmt::Display for RobotKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A robot type name that is not one of [`RobotKind::ALL`]'s.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown robot type {0:?} (expected scout, tank, infantry or amphibian)")]
pub struct UnknownKind(pub String);

impl FromStr for RobotKind {
    type Err = UnknownKind;
    fn from_str(s: &str) -> Result<RobotKind, UnknownKind> {
        RobotKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| UnknownKind(s.to_string()))
    }
}

/// A squad formation from the paper (sec. 4.2).
///
/// Slots are computed in the paper's frame, where the squad faces +y (the
/// paper's horizontal line is across the direction of travel), then rotated
/// so that +y points along the requested facing. With `facing = π/2` the line
/// and the circle are therefore exactly the paper's formulas.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Formation {
    /// Side by side across the facing, `d` apart, centred on the destination:
    /// Robot_i = D + d(i − (n−1)/2) measured towards the squad's right, so
    /// slot 0 is on the left.
    Line,
    /// Around the destination, for defending it: radius R = n·d, Robot_i at
    /// angle i·360°/n. A single robot stands on the destination itself.
    Circle,
    /// An arc around the destination on the approach side, for attacking it.
    ///
    /// As the paper writes it: radius R = n·d and consecutive robots i·270°/n
    /// apart. That literal step spans 270°·(n−1)/n, which is a true half circle
    /// only for n = 3 and opens towards 270° as n grows; it is kept as written
    /// so squads match the paper's. The paper starts the arc at +x; here it is
    /// rotated to be symmetric about the approach direction (its middle lies
    /// at `centre − R·facing`), so the squad wraps around the target from the
    /// side it comes from and never has to pass the target to take its place.
    /// A single robot stands `d` short of the target.
    HalfCircle,
    /// Two diagonal lines forming a V whose point leads along the facing; arms
    /// at 45° to the facing with robots `d` apart along each arm. For odd n the
    /// leader (slot 0) stands at the apex; for even n the apex is left empty
    /// (two robots either side of it would stand closer than `d`).
    Wedge,
    /// The [`Wedge`](Formation::Wedge) mirrored: the V's point trails, and
    /// for odd n the leader stands at the rear apex.
    InverseWedge,
}

impl Formation {
    /// Every formation, in a stable order for menus and tests.
    pub const ALL: [Formation; 5] = [
        Formation::Line,
        Formation::Circle,
        Formation::HalfCircle,
        Formation::Wedge,
        Formation::InverseWedge,
    ];

    /// The name [`FromStr`] accepts and [`Display`](fmt::Display) writes.
    pub fn name(self) -> &'static str {
        match self {
            Formation::Line => "line",
            Formation::Circle => "circle",
            Formation::HalfCircle => "half-circle",
            Formation::Wedge => "wedge",
            Formation::InverseWedge => "inverse-wedge",
        }
    }
}

impl fmt::Display for Formation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A formation name that is not one of [`Formation::ALL`]'s.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownFormation {
    /// The name as given.
    pub name: String,
}

impl fmt::Display for UnknownFormation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown formation {:?}; expected one of: ", self.name)?;
        for (i, formation) in Formation::ALL.iter().enumerate() {
            let sep = if i == 0 { "" } else { ", " };
            write!(f, "{sep}{formation}")?;
        }
        Ok(())
    }
}

impl std::error::Error for UnknownFormation {}

impl FromStr for Formation {
    type Err = UnknownFormation;

    /// Parses a name such as `"half-circle"`, ignoring ASCII case and
    /// surrounding whitespace.
    fn from_str(s: &str) -> Result<Formation, UnknownFormation> {
        let wanted = s.trim();
        Formation::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(wanted))
            .ok_or_else(|| UnknownFormation { name: s.to_owned() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_and_formations_round_trip_by_name() {
        for k in RobotKind::ALL {
            assert_eq!(k.name().parse::<RobotKind>(), Ok(k));
        }
        for f in Formation::ALL {
            assert_eq!(f.name().parse::<Formation>(), Ok(f));
            assert_eq!(f.name().to_uppercase().parse::<Formation>(), Ok(f));
        }
        assert!("square".parse::<Formation>().is_err());
        assert_eq!(
            "robot".parse::<RobotKind>(),
            Err(UnknownKind("robot".into()))
        );
    }

    #[test]
    fn names_are_short_plain_tokens() {
        assert!(valid_name("alpha_1-b"));
        assert!(!valid_name(""));
        assert!(!valid_name("red team"));
        assert!(!valid_name(&"a".repeat(33)));
        assert!(valid_name(&"a".repeat(32)));
    }
}
