//! Field readers only the game's messages use, each with its rule written once.

use colony_wire::Line;

use super::names::valid_name;
use crate::fields::{bad, MAX_COORD};
use crate::{DecodeError, Vec2};

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

/// A path as a packet carries it: `x,y` points, whole centimetres, space-separated (a squad's
/// planned path in the state, a player's drawn one in a command).
pub(crate) fn path_text(path: &[Vec2]) -> String {
    let mut s = String::new();
    for (i, p) in path.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        s.push_str(&format!("{:.0},{:.0}", p.x, p.y));
    }
    s
}

/// The points of a path's text ([`path_text`]); a point that is not `x,y` within the map's
/// coordinate range is an error naming the line.
pub(crate) fn parse_path(l: &Line<'_>, text: &str) -> Result<Vec<Vec2>, DecodeError> {
    text.split_whitespace()
        .map(|pt| {
            let point = pt.split_once(',').and_then(|(x, y)| {
                let (x, y) = (x.parse::<f64>().ok()?, y.parse::<f64>().ok()?);
                let ok = |v: f64| v.is_finite() && v.abs() <= MAX_COORD;
                (ok(x) && ok(y)).then(|| Vec2::new(x, y))
            });
            point.ok_or_else(|| bad(l, format!("path point {pt:?} is not x,y")))
        })
        .collect()
}
