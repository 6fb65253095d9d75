//! Packet text made safe to show on a terminal.
//!
//! A packet may hold any Unicode character but the C0 controls: C1 controls
//! (U+009B is a one-byte CSI: it can clear the screen, move the cursor or
//! retitle the window), and the marks that reorder text (U+202E shows
//! `cmd id 3` as anything its sender likes). Whatever prints network text to
//! a person shows it through [`terminal_text`] or [`terminal_line`].

use std::borrow::Cow;
use std::fmt::Write as _;

/// Whether `c` must not reach a terminal as it is: a control character (but
/// the line feed and the tab, which only lay text out), or a mark that
/// reorders or separates text.
pub fn is_unsafe_for_terminal(c: char) -> bool {
    (c.is_control() && c != '\n' && c != '\t')
        || matches!(
            c,
            '\u{061c}'
                | '\u{200e}'
                | '\u{200f}'
                | '\u{2028}'
                | '\u{2029}'
                | '\u{202a}'..='\u{202e}'
                | '\u{2066}'..='\u{2069}'
        )
}

/// `text` with each character [`is_unsafe_for_terminal`] shown as `\u{9b}`
/// (its code point in hex); line feeds and tabs are kept, so a packet keeps
/// its lines. Borrowed when there is nothing to escape.
///
/// ```
/// use colony_wire::terminal_text;
/// assert_eq!(terminal_text("x\u{9b}2J y 1\n"), "x\\u{9b}2J y 1\n");
/// assert_eq!(terminal_text("ball x 1\n"), "ball x 1\n");
/// ```
pub fn terminal_text(text: &str) -> Cow<'_, str> {
    escape(text, is_unsafe_for_terminal)
}

/// [`terminal_text`] for text that must stay on one line (a note, a table's
/// cell): line feeds and tabs are escaped too.
///
/// ```
/// assert_eq!(colony_wire::terminal_line("a\nb\u{202e}"), "a\\u{a}b\\u{202e}");
/// ```
pub fn terminal_line(text: &str) -> Cow<'_, str> {
    escape(text, |c| {
        c == '\n' || c == '\t' || is_unsafe_for_terminal(c)
    })
}

fn escape(text: &str, unsafe_char: impl Fn(char) -> bool) -> Cow<'_, str> {
    if !text.chars().any(&unsafe_char) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if unsafe_char(c) {
            let _ = write!(out, "\\u{{{:x}}}", u32::from(c));
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn c1_controls_and_bidirectional_marks_are_escaped() {
        assert_eq!(
            terminal_text("a\u{9b}2Jb\u{85}c\u{202e}d\u{1b}[0m\r\u{7f}"),
            "a\\u{9b}2Jb\\u{85}c\\u{202e}d\\u{1b}[0m\\u{d}\\u{7f}"
        );
        assert_eq!(terminal_text("tab\there\nnext"), "tab\there\nnext");
        assert_eq!(terminal_line("tab\there\nnext"), "tab\\u{9}here\\u{a}next");
        assert!(matches!(terminal_text("plain ünïcödé"), Cow::Borrowed(_)));
    }

    proptest! {
        #[test]
        fn nothing_unsafe_is_left_and_safe_text_is_untouched(text in any::<String>()) {
            let shown = terminal_text(&text);
            prop_assert!(!shown.chars().any(is_unsafe_for_terminal));
            // The lines stay where they were.
            prop_assert_eq!(shown.matches('\n').count(), text.matches('\n').count());
            let line = terminal_line(&text);
            prop_assert!(!line.chars().any(|c| c == '\n' || c == '\t' || is_unsafe_for_terminal(c)));
            if !text.chars().any(is_unsafe_for_terminal) {
                prop_assert_eq!(shown.as_ref(), text.as_str());
            }
        }
    }
}
