//! Typed readers for the fields messages share, each with its range rule written once.

use colony_wire::Line;

use crate::DecodeError;

/// Coordinates beyond this (cm) are refused: the largest map is 4096 cells of a metre.
pub const MAX_COORD: f64 = 1.0e6;

/// A [`DecodeError::Bad`] on `line`.
pub(crate) fn bad(line: &Line<'_>, what: impl Into<String>) -> DecodeError {
    DecodeError::Bad {
        line: line.number(),
        what: what.into(),
    }
}

/// A finite number.
pub(crate) fn finite(line: &Line<'_>, name: &str) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(bad(
            line,
            format!("{name} must be a finite number, not {v}"),
        ))
    }
}

/// A coordinate within [`MAX_COORD`] of the origin.
pub(crate) fn coord(line: &Line<'_>, name: &str) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if v.is_finite() && v.abs() <= MAX_COORD {
        Ok(v)
    } else {
        Err(bad(line, format!("{name} {v} is out of range")))
    }
}

/// A robot id (0 to `u32::MAX`): every message writes robot ids as `u32`.
pub(crate) fn robot_id(line: &Line<'_>, name: &str) -> Result<u32, DecodeError> {
    id(line, name, "robot")
}

/// A puck id (0 to `u32::MAX`), the same rule as a robot's.
pub(crate) fn puck_id(line: &Line<'_>, name: &str) -> Result<u32, DecodeError> {
    id(line, name, "puck")
}

fn id(line: &Line<'_>, name: &str, what: &str) -> Result<u32, DecodeError> {
    let v = line.i64(name)?;
    u32::try_from(v).map_err(|_| bad(line, format!("{name} {v} is not a {what} id")))
}

/// A count or a step number: a non-negative integer.
pub(crate) fn count(line: &Line<'_>, name: &str) -> Result<u64, DecodeError> {
    let v = line.i64(name)?;
    u64::try_from(v).map_err(|_| bad(line, format!("{name} {v} is negative")))
}

/// A flag written `0` or `1`.
pub(crate) fn flag(line: &Line<'_>, name: &str) -> Result<bool, DecodeError> {
    match line.i64(name)? {
        0 => Ok(false),
        1 => Ok(true),
        v => Err(bad(line, format!("{name} {v} is neither 0 nor 1"))),
    }
}

/// A number within `range`, such as a body size.
pub(crate) fn within(
    line: &Line<'_>,
    name: &str,
    range: impl std::ops::RangeBounds<f64> + std::fmt::Debug,
) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if v.is_finite() && range.contains(&v) {
        Ok(v)
    } else {
        Err(bad(line, format!("{name} {v} is not within {range:?}")))
    }
}

/// Rounds to 0.01 (cm or rad): finer than any sensor, and keeps packets short.
pub(crate) fn r(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}
