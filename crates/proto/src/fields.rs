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

/// A robot id (0 to `u32::MAX`).
pub(crate) fn robot_id(line: &Line<'_>, name: &str) -> Result<u32, DecodeError> {
    let v = line.i64(name)?;
    u32::try_from(v).map_err(|_| bad(line, format!("{name} {v} is not a robot id")))
}

/// Rounds to 0.01 (cm or rad): finer than any sensor, and keeps packets short.
pub(crate) fn r(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}
