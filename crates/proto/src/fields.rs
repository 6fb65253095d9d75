//! Typed readers for the fields messages share, each with its range rule written once.

use colony_wire::{FieldError, Line, Picked};

use crate::DecodeError;

/// What the rules read a field from: a whole line, or the fields picked from one
/// ([`Line::pick`], for readers of many lines).
pub(crate) trait Source {
    fn f64(&self, name: &str) -> Result<f64, FieldError>;
    fn i64(&self, name: &str) -> Result<i64, FieldError>;
    /// The line's number in its packet, for errors.
    fn number(&self) -> u32;
}

impl Source for Line<'_> {
    fn f64(&self, name: &str) -> Result<f64, FieldError> {
        Line::f64(self, name)
    }
    fn i64(&self, name: &str) -> Result<i64, FieldError> {
        Line::i64(self, name)
    }
    fn number(&self) -> u32 {
        Line::number(self)
    }
}

impl<const N: usize> Source for Picked<'_, N> {
    fn f64(&self, name: &str) -> Result<f64, FieldError> {
        Picked::f64(self, name)
    }
    fn i64(&self, name: &str) -> Result<i64, FieldError> {
        Picked::i64(self, name)
    }
    fn number(&self) -> u32 {
        self.line().number()
    }
}

/// Coordinates beyond this (cm) are refused: the largest map is 4096 cells of a metre.
pub const MAX_COORD: f64 = 1.0e6;

/// A [`DecodeError::Bad`] on `line`.
pub(crate) fn bad(line: &impl Source, what: impl Into<String>) -> DecodeError {
    DecodeError::Bad {
        line: line.number(),
        what: what.into(),
    }
}

/// A finite number.
pub(crate) fn finite(line: &impl Source, name: &str) -> Result<f64, DecodeError> {
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
pub(crate) fn coord(line: &impl Source, name: &str) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if v.is_finite() && v.abs() <= MAX_COORD {
        Ok(v)
    } else {
        Err(bad(line, format!("{name} {v} is out of range")))
    }
}

/// A robot id (0 to `u32::MAX`): every message writes robot ids as `u32`.
pub(crate) fn robot_id(line: &impl Source, name: &str) -> Result<u32, DecodeError> {
    id(line, name, "robot")
}

/// A puck id (0 to `u32::MAX`), the same rule as a robot's.
pub(crate) fn puck_id(line: &impl Source, name: &str) -> Result<u32, DecodeError> {
    id(line, name, "puck")
}

fn id(line: &impl Source, name: &str, what: &str) -> Result<u32, DecodeError> {
    let v = line.i64(name)?;
    u32::try_from(v).map_err(|_| bad(line, format!("{name} {v} is not a {what} id")))
}

/// A count or a step number: a non-negative integer.
pub(crate) fn count(line: &impl Source, name: &str) -> Result<u64, DecodeError> {
    let v = line.i64(name)?;
    u64::try_from(v).map_err(|_| bad(line, format!("{name} {v} is negative")))
}

/// A flag written `0` or `1`.
pub(crate) fn flag(line: &impl Source, name: &str) -> Result<bool, DecodeError> {
    match line.i64(name)? {
        0 => Ok(false),
        1 => Ok(true),
        v => Err(bad(line, format!("{name} {v} is neither 0 nor 1"))),
    }
}

/// A number within `range`, such as a body size.
pub(crate) fn within(
    line: &impl Source,
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

/// Appends `r(v)` as `format!("{}", r(v))` writes it, without the float formatter: a swarm's
/// vision writes some 400,000 such numbers a frame. `r(v)` is the double nearest to
/// `cents / 100`, and below 10^13 a double's spacing is under 0.002, so no shorter decimal
/// reads back as it: its shortest form is the cents written out, trailing zeros dropped.
pub(crate) fn push_r(out: &mut String, v: f64) {
    use std::fmt::Write;
    let cents = (v * 100.0).round();
    if cents.is_nan() || cents.abs() >= 1e15 || (cents == 0.0 && cents.is_sign_negative()) {
        // Out of range, not a number, or -0: the formatter's own spelling.
        let _ = write!(out, "{}", r(v));
        return;
    }
    let cents = cents as i64;
    if cents < 0 {
        out.push('-');
    }
    let a = cents.unsigned_abs();
    let _ = write!(out, "{}", a / 100);
    let (tenths, hundredths) = ((a / 10 % 10) as u8, (a % 10) as u8);
    if tenths != 0 || hundredths != 0 {
        out.push('.');
        out.push(char::from(b'0' + tenths));
        if hundredths != 0 {
            out.push(char::from(b'0' + hundredths));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pushed(v: f64) -> String {
        let mut s = String::new();
        push_r(&mut s, v);
        s
    }

    #[test]
    fn push_r_spells_the_edges_as_the_formatter() {
        for v in [
            0.0,
            -0.0,
            -0.001,
            0.004,
            0.005,
            -0.005,
            0.5,
            -0.5,
            12.5,
            -40.1,
            1.57,
            100.0,
            0.1,
            0.07,
            1e12,
            -1e13 + 0.01,
            9.99e12,
            1e13,
            1e15,
            1e300,
            -1e300,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ] {
            assert_eq!(pushed(v), format!("{}", r(v)), "{v:e}");
        }
    }

    proptest! {
        #[test]
        fn push_r_spells_any_number_as_the_formatter(
            v in prop_oneof![-2.0e6..2.0e6, -1.0e14..1.0e14, -1.0..1.0, any::<f64>()],
        ) {
            prop_assert_eq!(pushed(v), format!("{}", r(v)));
        }
    }
}
