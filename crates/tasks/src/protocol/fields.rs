//! Typed field readers shared by every message, each refusing out-of-range values
//! with the line and field named.

use std::time::Duration;

use colony_wire::{Line, Subject};

use super::error::{bad, DecodeError};
use crate::resource::Token;

/// Scores, weights and parameters beyond this are refused: no metric needs them
/// and they keep sums far from overflow.
pub const MAX_MAGNITUDE: f64 = 1e12;

/// The longest auction window an announcement may ask for.
pub const MAX_DEADLINE: Duration = Duration::from_secs(600);

/// The longest task length, s (a week).
pub const MAX_LENGTH_S: f64 = 7.0 * 24.0 * 3600.0;

/// The longest reason or text parameter kept, in characters.
pub const MAX_TEXT: usize = 512;

pub(crate) fn finite(line: &Line<'_>, name: &str) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if v.is_finite() && v.abs() <= MAX_MAGNITUDE {
        Ok(v)
    } else {
        Err(bad(
            line,
            name,
            format!("{v} is not a finite number within ±{MAX_MAGNITUDE:e}"),
        ))
    }
}

pub(crate) fn task_number(line: &Line<'_>, name: &str) -> Result<u64, DecodeError> {
    let v = line.i64(name)?;
    u64::try_from(v).map_err(|_| bad(line, name, format!("{v} is not a task number (0 or more)")))
}

pub(crate) fn count(line: &Line<'_>, name: &str) -> Result<u32, DecodeError> {
    let v = line.i64(name)?;
    u32::try_from(v).map_err(|_| bad(line, name, format!("{v} is not a count")))
}

pub(crate) fn token(line: &Line<'_>, name: &str) -> Result<Token, DecodeError> {
    let s = line.str(name)?;
    Token::new(&s).map_err(|e| bad(line, name, e.to_string()))
}

pub(crate) fn subject(line: &Line<'_>, name: &str) -> Result<Subject, DecodeError> {
    let s = line.str(name)?;
    Subject::new(&s).map_err(|e| bad(line, name, e.to_string()))
}

pub(crate) fn text(line: &Line<'_>, name: &str) -> Result<String, DecodeError> {
    let s = line.str(name)?;
    Ok(clip(&s))
}

pub(crate) fn fraction(line: &Line<'_>, name: &str) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(bad(line, name, format!("{v} is not between 0 and 1")))
    }
}

pub(crate) fn millis(line: &Line<'_>, name: &str) -> Result<Duration, DecodeError> {
    let v = line.i64(name)?;
    match u64::try_from(v) {
        Ok(ms) if ms >= 1 && Duration::from_millis(ms) <= MAX_DEADLINE => {
            Ok(Duration::from_millis(ms))
        }
        _ => Err(bad(
            line,
            name,
            format!(
                "{v} is not between 1 and {} milliseconds",
                MAX_DEADLINE.as_millis()
            ),
        )),
    }
}

/// At most [`MAX_TEXT`] characters of `s`.
pub(crate) fn clip(s: &str) -> String {
    s.chars().take(MAX_TEXT).collect()
}

/// Whether `s` can name a task, a parameter or a metric: 1 to 64 characters of
/// `A-Z a-z 0-9 _ - . : /`, the characters of a subject.
pub fn valid_name(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= colony_wire::MAX_SUBJECT_LEN
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'-' | b'.' | b':' | b'/'))
}

pub(crate) fn name(line: &Line<'_>, field: &str) -> Result<String, DecodeError> {
    let s = line.str(field)?;
    if valid_name(&s) {
        Ok(s.into_owned())
    } else {
        Err(bad(
            line,
            field,
            format!(
                "`{}` is not a name: use 1 to 64 characters of A-Z a-z 0-9 _ - . : /",
                clip(&s)
            ),
        ))
    }
}
