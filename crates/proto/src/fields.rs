//! Typed readers for the fields every message carries, each with its range rule written once,
//! and the spellings writers use so that what they write reads back.
//!
//! The game's and the swarm's messages name a bad field inside a [`DecodeError::Bad`];
//! MURDOCH's name it in a [`DecodeError::BadField`]. Where two families read a field to
//! different rules, the rules have different names here: `finite` (any finite number) and
//! `finite_within_magnitude` (within [`MAX_MAGNITUDE`]), [`valid_plain_name`] (the game's
//! names) and [`valid_subject_name`] (MURDOCH's), `text_or_empty` (the game's texts, which may
//! be left out) and `clipped_text` (MURDOCH's, which must be there and are kept to
//! [`MAX_TEXT`] characters).

use std::time::Duration;

use colony_wire::{FieldError, Line, Picked, Subject};

use crate::murdoch::error::{unwritable, EncodeError};
use crate::murdoch::Token;
use crate::{DecodeError, Vec2};

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

/// Scores, weights and parameters beyond this are refused: no metric needs them
/// and they keep sums far from overflow.
pub const MAX_MAGNITUDE: f64 = 1e12;

/// The longest auction window an announcement may ask for.
pub const MAX_DEADLINE: Duration = Duration::from_secs(600);

/// The longest reason or text parameter kept, in characters.
pub const MAX_TEXT: usize = 512;

/// The longest team, squad or formation name, bytes.
pub const MAX_NAME: usize = 32;

/// A [`DecodeError::Bad`] on `line`.
pub(crate) fn bad(line: &impl Source, what: impl Into<String>) -> DecodeError {
    DecodeError::Bad {
        line: line.number(),
        what: what.into(),
    }
}

/// A [`DecodeError::BadField`]: `field` on `line` reads, but its value is wrong.
pub(crate) fn bad_field(line: &impl Source, field: &str, what: impl Into<String>) -> DecodeError {
    DecodeError::BadField {
        line: line.number(),
        field: field.to_owned(),
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

fn is_within_magnitude(v: f64) -> bool {
    v.is_finite() && v.abs() <= MAX_MAGNITUDE
}

fn not_within_magnitude(v: f64) -> String {
    format!("{v} is not a finite number within ±{MAX_MAGNITUDE:e}")
}

/// A finite number within [`MAX_MAGNITUDE`] (scores, weights, parameters).
pub(crate) fn finite_within_magnitude(line: &impl Source, name: &str) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if is_within_magnitude(v) {
        Ok(v)
    } else {
        Err(bad_field(line, name, not_within_magnitude(v)))
    }
}

/// What a writer checks before it writes a number [`finite_within_magnitude`] will read.
pub(crate) fn writable_finite(field: &'static str, v: f64) -> Result<(), EncodeError> {
    if is_within_magnitude(v) {
        Ok(())
    } else {
        Err(unwritable(field, not_within_magnitude(v)))
    }
}

fn is_coord(v: f64) -> bool {
    v.is_finite() && v.abs() <= MAX_COORD
}

/// A coordinate within [`MAX_COORD`] of the origin.
pub(crate) fn coord(line: &impl Source, name: &str) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if is_coord(v) {
        Ok(v)
    } else {
        Err(bad(line, format!("{name} {v} is out of range")))
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

/// A number from 0 to 1, both included (a battery's charge, a task's progress).
pub(crate) fn fraction(line: &impl Source, name: &str) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(bad_field(line, name, format!("{v} is not between 0 and 1")))
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

/// A score, a tally or a number of bids: a count that fits a `u32`.
pub(crate) fn tally(line: &impl Source, name: &str) -> Result<u32, DecodeError> {
    let v = line.i64(name)?;
    u32::try_from(v).map_err(|_| bad_field(line, name, format!("{v} is not a count")))
}

/// A MURDOCH task number: 0 or more, as a packet's signed 64-bit integer can carry it.
pub(crate) fn task_number(line: &impl Source, name: &str) -> Result<u64, DecodeError> {
    let v = line.i64(name)?;
    u64::try_from(v)
        .map_err(|_| bad_field(line, name, format!("{v} is not a task number (0 or more)")))
}

/// What a writer checks before it writes a number [`task_number`] will read:
/// a packet's integers are signed 64-bit.
pub(crate) fn writable_task_number(field: &'static str, v: u64) -> Result<(), EncodeError> {
    if i64::try_from(v).is_ok() {
        Ok(())
    } else {
        Err(unwritable(
            field,
            format!("{v} is more than the largest task number, {}", i64::MAX),
        ))
    }
}

/// A flag written `0` or `1`.
pub(crate) fn flag(line: &impl Source, name: &str) -> Result<bool, DecodeError> {
    match line.i64(name)? {
        0 => Ok(false),
        1 => Ok(true),
        v => Err(bad(line, format!("{name} {v} is neither 0 nor 1"))),
    }
}

/// `v` as the 0/1 a packet carries ([`flag`]).
pub(crate) fn b(v: bool) -> i64 {
    i64::from(v)
}

/// A whole number of milliseconds from 1 to [`MAX_DEADLINE`] (an auction window).
pub(crate) fn millis(line: &impl Source, name: &str) -> Result<Duration, DecodeError> {
    let v = line.i64(name)?;
    match u64::try_from(v) {
        Ok(ms) if ms >= 1 && Duration::from_millis(ms) <= MAX_DEADLINE => {
            Ok(Duration::from_millis(ms))
        }
        _ => Err(bad_field(
            line,
            name,
            format!(
                "{v} is not between 1 and {} milliseconds",
                MAX_DEADLINE.as_millis()
            ),
        )),
    }
}

/// Whether `s` can name a team, a squad, a flag or a formation: 1 to [`MAX_NAME`] characters
/// of `A-Z a-z 0-9 _ -`, so it is a token in packets and in channel names.
pub fn valid_plain_name(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= MAX_NAME
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_')
}

/// Whether `s` can name a task, a parameter or a metric: 1 to 64 characters of
/// `A-Z a-z 0-9 _ - . : /`, the characters of a subject.
pub fn valid_subject_name(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= colony_wire::MAX_SUBJECT_LEN
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'-' | b'.' | b':' | b'/'))
}

/// A game name ([`valid_plain_name`]).
pub(crate) fn plain_name(line: &Line<'_>, field: &str) -> Result<String, DecodeError> {
    let s = line.str(field)?;
    if valid_plain_name(&s) {
        Ok(s.into_owned())
    } else {
        Err(bad(line, format!("{field} {s:?} is not a name")))
    }
}

/// A MURDOCH name ([`valid_subject_name`]), quoted back clipped when refused.
pub(crate) fn subject_name(line: &Line<'_>, field: &str) -> Result<String, DecodeError> {
    let s = line.str(field)?;
    if valid_subject_name(&s) {
        Ok(s.into_owned())
    } else {
        Err(bad_field(
            line,
            field,
            format!(
                "`{}` is not a name: use 1 to 64 characters of A-Z a-z 0-9 _ - . : /",
                clip(&s)
            ),
        ))
    }
}

/// A MURDOCH token ([`Token`]).
pub(crate) fn token(line: &Line<'_>, name: &str) -> Result<Token, DecodeError> {
    let s = line.str(name)?;
    Token::new(&s).map_err(|e| bad_field(line, name, e.to_string()))
}

/// A subject ([`Subject`]).
pub(crate) fn subject(line: &Line<'_>, name: &str) -> Result<Subject, DecodeError> {
    let s = line.str(name)?;
    Subject::new(&s).map_err(|e| bad_field(line, name, e.to_string()))
}

/// A text for people that must be there, kept to [`MAX_TEXT`] characters (MURDOCH's reasons).
pub(crate) fn clipped_text(line: &Line<'_>, name: &str) -> Result<String, DecodeError> {
    let s = line.str(name)?;
    Ok(clip(&s))
}

/// A text for people that may be left out: absent reads as empty (a robot without a reason is
/// still a robot).
pub(crate) fn text_or_empty(line: &Line<'_>, field: &str) -> Result<String, DecodeError> {
    match line.get(field) {
        None => Ok(String::new()),
        Some(_) => Ok(line.str(field)?.into_owned()),
    }
}

/// At most [`MAX_TEXT`] characters of `s`.
pub(crate) fn clip(s: &str) -> String {
    s.chars().take(MAX_TEXT).collect()
}

/// A path as a packet carries it: `x,y` points, whole centimetres, space-separated (a squad's
/// planned path in the game's state, a player's drawn one in a command).
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

/// The points of a path's text ([`path_text`]); a point that is not `x,y` with both
/// coordinates within [`MAX_COORD`] is an error naming the line.
pub(crate) fn parse_path(l: &Line<'_>, text: &str) -> Result<Vec<Vec2>, DecodeError> {
    text.split_whitespace()
        .map(|pt| {
            let point = pt.split_once(',').and_then(|(x, y)| {
                let (x, y) = (x.parse::<f64>().ok()?, y.parse::<f64>().ok()?);
                (is_coord(x) && is_coord(y)).then(|| Vec2::new(x, y))
            });
            point.ok_or_else(|| bad(l, format!("path point {pt:?} is not x,y")))
        })
        .collect()
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
    use colony_wire::Packet;
    use proptest::prelude::*;

    use super::*;

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

    /// Runs `f` on the first body line of a packet whose line is `line`.
    fn on<T>(line: &str, f: impl FnOnce(&Line<'_>) -> T) -> T {
        let text = format!("@ <murdoch.u.1.1> 0\n{line}\n");
        let packet = Packet::parse(text.as_bytes()).unwrap();
        let first = packet.lines().next().unwrap();
        f(&first)
    }

    fn err<T: std::fmt::Debug>(
        line: &str,
        f: impl FnOnce(&Line<'_>) -> Result<T, DecodeError>,
    ) -> String {
        match on(line, f) {
            Ok(v) => panic!("{line:?} should be refused, read {v:?}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn finite_takes_the_whole_range_up_to_the_magnitude_limit() {
        assert_eq!(
            on("x v 1e12", |l| finite_within_magnitude(l, "v")),
            Ok(1e12)
        );
        assert_eq!(
            on("x v -1e12", |l| finite_within_magnitude(l, "v")),
            Ok(-1e12)
        );
        assert_eq!(
            on("x v -0.5", |l| finite_within_magnitude(l, "v")),
            Ok(-0.5)
        );
    }

    #[test]
    fn finite_refuses_beyond_the_limit_and_non_finite_numbers() {
        for v in ["1.0000001e12", "-2e12", "inf", "-inf", "NaN", "1e400"] {
            let e = err(&format!("x v {v}"), |l| finite_within_magnitude(l, "v"));
            assert!(
                e.contains("line 2, field `v`") && e.contains("not a finite number"),
                "{v}: {e}"
            );
        }
    }

    #[test]
    fn a_task_number_is_zero_or_more() {
        assert_eq!(on("x task 0", |l| task_number(l, "task")), Ok(0));
        assert_eq!(
            on(&format!("x task {}", i64::MAX), |l| task_number(l, "task")),
            Ok(i64::MAX as u64)
        );
        let e = err("x task -1", |l| task_number(l, "task"));
        assert!(e.contains("-1 is not a task number"), "{e}");
    }

    #[test]
    fn a_count_fits_in_32_bits() {
        assert_eq!(
            on(&format!("x n {}", u32::MAX), |l| tally(l, "n")),
            Ok(u32::MAX)
        );
        for v in [-1i64, u32::MAX as i64 + 1] {
            let e = err(&format!("x n {v}"), |l| tally(l, "n"));
            assert!(e.contains(&format!("{v} is not a count")), "{e}");
        }
    }

    #[test]
    fn a_token_field_is_checked_as_a_token() {
        assert_eq!(on("x who r2", |l| token(l, "who")).unwrap().as_str(), "r2");
        assert_eq!(
            on("x who \"r2\"", |l| token(l, "who")).unwrap().as_str(),
            "r2"
        );
        let e = err("x who a.b", |l| token(l, "who"));
        assert!(
            e.contains("field `who`") && e.contains("not a token"),
            "{e}"
        );
    }

    #[test]
    fn a_subject_field_is_checked_as_a_subject() {
        assert_eq!(
            on("x s murdoch.u.1.1", |l| subject(l, "s"))
                .unwrap()
                .as_str(),
            "murdoch.u.1.1"
        );
        let e = err("x s \"two words\"", |l| subject(l, "s"));
        assert!(
            e.contains("field `s`") && e.contains("not a subject"),
            "{e}"
        );
    }

    #[test]
    fn text_is_unescaped_and_clipped_to_max_text_characters() {
        assert_eq!(
            on(r#"x t "a \"b\"\nc""#, |l| clipped_text(l, "t")),
            Ok("a \"b\"\nc".to_owned())
        );
        let long = format!("x t \"{}\"", "é".repeat(MAX_TEXT + 10));
        let got = on(&long, |l| clipped_text(l, "t")).unwrap();
        assert_eq!(got.chars().count(), MAX_TEXT);
    }

    #[test]
    fn clip_counts_characters_not_bytes() {
        assert_eq!(clip("short"), "short");
        let s = "ü".repeat(MAX_TEXT);
        assert_eq!(clip(&s), s);
        assert_eq!(clip(&format!("{s}x")), s);
    }

    #[test]
    fn a_fraction_is_between_zero_and_one_inclusive() {
        assert_eq!(on("x p 0", |l| fraction(l, "p")), Ok(0.0));
        assert_eq!(on("x p 1", |l| fraction(l, "p")), Ok(1.0));
        for v in ["-0.001", "1.001", "NaN", "inf"] {
            let e = err(&format!("x p {v}"), |l| fraction(l, "p"));
            assert!(e.contains("not between 0 and 1"), "{v}: {e}");
        }
    }

    #[test]
    fn millis_is_one_millisecond_to_the_longest_deadline() {
        assert_eq!(
            on("x ms 1", |l| millis(l, "ms")),
            Ok(Duration::from_millis(1))
        );
        let max = MAX_DEADLINE.as_millis();
        assert_eq!(
            on(&format!("x ms {max}"), |l| millis(l, "ms")),
            Ok(MAX_DEADLINE)
        );
        for v in ["0".to_string(), "-5".into(), (max + 1).to_string()] {
            let e = err(&format!("x ms {v}"), |l| millis(l, "ms"));
            assert!(
                e.contains("is not between 1 and 600000 milliseconds"),
                "{v}: {e}"
            );
        }
    }

    #[test]
    fn millis_refuses_a_fraction() {
        let e = err("x ms 1.5", |l| millis(l, "ms"));
        assert!(e.contains("`ms`"), "{e}");
    }

    #[test]
    fn valid_names_use_the_subject_alphabet_up_to_64_characters() {
        for ok in ["a", "push-left.end", "x/y:z_1", &"n".repeat(64)] {
            assert!(valid_subject_name(ok), "{ok:?}");
        }
        for bad in [
            "",
            "two words",
            "quote\"",
            "caf\u{e9}",
            "(x)",
            &"n".repeat(65),
        ] {
            assert!(!valid_subject_name(bad), "{bad:?}");
        }
    }

    #[test]
    fn a_bad_name_is_quoted_back_clipped() {
        let long = format!("x n \"{}\"", " ".repeat(2 * MAX_TEXT));
        let e = err(&long, |l| subject_name(l, "n"));
        assert!(e.contains("is not a name"), "{e}");
        assert!(e.len() < MAX_TEXT + 200, "{} characters", e.len());
        assert_eq!(
            on("x n goto", |l| subject_name(l, "n")),
            Ok("goto".to_owned())
        );
    }

    #[test]
    fn a_missing_field_is_named() {
        let e = err("x other 1", |l| finite_within_magnitude(l, "score"));
        assert!(e.contains("score") && e.contains("missing"), "{e}");
    }
}
