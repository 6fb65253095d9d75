//! Typed field readers shared by every message, each refusing out-of-range values
//! with the line and field named.

use std::time::Duration;

use colony_wire::{Line, Subject};

use super::error::{unwritable, EncodeError};
use super::Token;
use crate::DecodeError;

/// Scores, weights and parameters beyond this are refused: no metric needs them
/// and they keep sums far from overflow.
pub const MAX_MAGNITUDE: f64 = 1e12;

/// The longest auction window an announcement may ask for.
pub const MAX_DEADLINE: Duration = Duration::from_secs(600);

/// The longest task length, s (a week).
pub const MAX_LENGTH_S: f64 = 7.0 * 24.0 * 3600.0;

/// The longest reason or text parameter kept, in characters.
pub const MAX_TEXT: usize = 512;

/// A [`DecodeError::BadField`]: `field` on `line` reads, but its value is wrong.
pub(crate) fn bad(line: &Line<'_>, field: &str, what: impl Into<String>) -> DecodeError {
    DecodeError::BadField {
        line: line.number(),
        field: field.to_owned(),
        what: what.into(),
    }
}

/// A finite number within [`MAX_MAGNITUDE`] (scores, weights, parameters).
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

/// What a writer checks before it writes a number [`finite`] will read.
pub(crate) fn writable_finite(field: &'static str, v: f64) -> Result<(), EncodeError> {
    if v.is_finite() && v.abs() <= MAX_MAGNITUDE {
        Ok(())
    } else {
        Err(unwritable(
            field,
            format!("{v} is not a finite number within ±{MAX_MAGNITUDE:e}"),
        ))
    }
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

#[cfg(test)]
mod tests {
    use colony_wire::Packet;

    use super::*;

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
        assert_eq!(on("x v 1e12", |l| finite(l, "v")), Ok(1e12));
        assert_eq!(on("x v -1e12", |l| finite(l, "v")), Ok(-1e12));
        assert_eq!(on("x v -0.5", |l| finite(l, "v")), Ok(-0.5));
    }

    #[test]
    fn finite_refuses_beyond_the_limit_and_non_finite_numbers() {
        for v in ["1.0000001e12", "-2e12", "inf", "-inf", "NaN", "1e400"] {
            let e = err(&format!("x v {v}"), |l| finite(l, "v"));
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
            on(&format!("x n {}", u32::MAX), |l| count(l, "n")),
            Ok(u32::MAX)
        );
        for v in [-1i64, u32::MAX as i64 + 1] {
            let e = err(&format!("x n {v}"), |l| count(l, "n"));
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
            on(r#"x t "a \"b\"\nc""#, |l| text(l, "t")),
            Ok("a \"b\"\nc".to_owned())
        );
        let long = format!("x t \"{}\"", "é".repeat(MAX_TEXT + 10));
        let got = on(&long, |l| text(l, "t")).unwrap();
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
            assert!(valid_name(ok), "{ok:?}");
        }
        for bad in [
            "",
            "two words",
            "quote\"",
            "caf\u{e9}",
            "(x)",
            &"n".repeat(65),
        ] {
            assert!(!valid_name(bad), "{bad:?}");
        }
    }

    #[test]
    fn a_bad_name_is_quoted_back_clipped() {
        let long = format!("x n \"{}\"", " ".repeat(2 * MAX_TEXT));
        let e = err(&long, |l| name(l, "n"));
        assert!(e.contains("is not a name"), "{e}");
        assert!(e.len() < MAX_TEXT + 200, "{} characters", e.len());
        assert_eq!(on("x n goto", |l| name(l, "n")), Ok("goto".to_owned()));
    }

    #[test]
    fn a_missing_field_is_named() {
        let e = err("x other 1", |l| finite(l, "score"));
        assert!(e.contains("score") && e.contains("missing"), "{e}");
    }
}
