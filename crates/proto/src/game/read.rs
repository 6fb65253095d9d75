//! Field readers only the game's messages use, each with its rule written once.

use colony_wire::Line;

use super::names::valid_name;
use crate::fields::bad;
use crate::DecodeError;

/// A name usable as a packet token ([`valid_name`]).
pub(crate) fn name(line: &Line<'_>, field: &str) -> Result<String, DecodeError> {
    let s = line.str(field)?;
    if valid_name(&s) {
        Ok(s.into_owned())
    } else {
        Err(bad(line, format!("{field} {s:?} is not a name")))
    }
}

/// A text for people; absent reads as empty (a robot without a reason is still a robot).
pub(crate) fn text(line: &Line<'_>, field: &str) -> Result<String, DecodeError> {
    match line.get(field) {
        None => Ok(String::new()),
        Some(_) => Ok(line.str(field)?.into_owned()),
    }
}

/// A score or tally that fits a `u32`.
pub(crate) fn tally(line: &Line<'_>, field: &str) -> Result<u32, DecodeError> {
    let v = line.i64(field)?;
    u32::try_from(v).map_err(|_| bad(line, format!("bad {field} {v}")))
}

/// `b` as the 0/1 a packet carries.
pub(crate) fn b(v: bool) -> i64 {
    i64::from(v)
}
