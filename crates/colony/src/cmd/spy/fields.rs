//! A packet decoded field by field, with the wire format's structure and nothing more: a row
//! per field, named by its path, with its value as text and, for a number, as a number to plot.
//!
//! A path names a field by its line's label, the line's place among the lines with that label
//! (lines with one label form an array), the field's name and the names of the groups it sits
//! in: `robot[3].pose.xh` is field `xh` of group `pose` on the fourth `robot` line. Every path
//! is kept with its index (`ball[0].x`); it is shown without `[0]` where the packet has one
//! line with that label, as most labels are (`ball.x`).

use std::collections::HashMap;

use colony_wire::{Fields, Packet, Value};

/// Rows listed at most for one packet (a 64 KiB packet can hold ten thousand fields).
pub const MAX_ROWS: usize = 4096;

/// One field of a packet (or a line without fields, or a group), as the channel view lists it.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldRow {
    /// The full path, every label with its index: the key of the field's plot.
    pub key: String,
    /// The path as shown.
    pub shown: String,
    /// The value as written (a quoted string unescaped), safe to print.
    pub value: String,
    /// The value as a finite number, when it is one.
    pub number: Option<f64>,
}

/// The rows of a packet, at most [`MAX_ROWS`] of them, and how many were left out.
pub fn rows(packet: &Packet<'_>) -> (Vec<FieldRow>, usize) {
    let mut count: HashMap<&str, usize> = HashMap::new();
    for line in packet.lines() {
        *count.entry(line.label()).or_default() += 1;
    }
    let mut seen: HashMap<&str, usize> = HashMap::new();
    let mut out = Vec::new();
    let mut left_off = 0;
    for line in packet.lines() {
        let label = line.label();
        let i = seen.entry(label).or_default();
        let index = *i;
        *i += 1;
        let label_text = printable(label);
        let key = format!("{label_text}[{index}]");
        let shown = if count[label] > 1 {
            key.clone()
        } else {
            label_text
        };
        if line.fields().next().is_some() {
            walk(line.fields(), &key, &shown, &mut out, &mut left_off);
        } else {
            push(
                &mut out,
                &mut left_off,
                FieldRow {
                    key,
                    shown,
                    value: String::new(),
                    number: None,
                },
            );
        }
    }
    (out, left_off)
}

fn push(out: &mut Vec<FieldRow>, left_off: &mut usize, row: FieldRow) {
    if out.len() < MAX_ROWS {
        out.push(row);
    } else {
        *left_off += 1;
    }
}

fn walk(fields: Fields<'_>, key: &str, shown: &str, out: &mut Vec<FieldRow>, left_off: &mut usize) {
    for f in fields {
        let name = printable(f.name);
        let key = format!("{key}.{name}");
        let shown = format!("{shown}.{name}");
        match f.value {
            Value::Group(g) => {
                let n = g.fields().count();
                push(
                    out,
                    left_off,
                    FieldRow {
                        key: key.clone(),
                        shown: shown.clone(),
                        value: format!("({n} field{})", if n == 1 { "" } else { "s" }),
                        number: None,
                    },
                );
                walk(g.fields(), &key, &shown, out, left_off);
            }
            Value::Bare(t) => push(
                out,
                left_off,
                FieldRow {
                    key,
                    shown,
                    value: printable(t),
                    number: f.value.as_f64().filter(|v| v.is_finite()),
                },
            ),
            Value::Quoted(q) => push(
                out,
                left_off,
                FieldRow {
                    key,
                    shown,
                    value: format!("\"{}\"", printable(&q.unescape())),
                    number: None,
                },
            ),
        }
    }
}

/// Every finite number in a packet, by path, in the packet's order (at most [`MAX_ROWS`]).
pub fn numbers(packet: &Packet<'_>) -> Vec<(String, f64)> {
    rows(packet)
        .0
        .into_iter()
        .filter_map(|r| r.number.map(|n| (r.key, n)))
        .collect()
}

/// Text from the network made safe for one line of the screen: the rule
/// `colony sub` and `colony log` follow too ([`colony_wire::terminal_line`]).
pub fn printable(text: &str) -> String {
    colony_wire::terminal_line(text).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Packet<'_> {
        Packet::parse(text.as_bytes()).unwrap()
    }

    #[test]
    fn repeated_labels_are_arrays_and_a_single_label_shows_without_its_index() {
        let p = parse(
            "@ <vision_out> 0\nball x 5.3 y -2.5\nblue id 0 x 15.2\nblue id 4 x 98.4 pose (xh 1.0 yh 0.0)\n",
        );
        let (rows, left_off) = rows(&p);
        assert_eq!(left_off, 0);
        let shown: Vec<(&str, &str)> = rows
            .iter()
            .map(|r| (r.shown.as_str(), r.value.as_str()))
            .collect();
        assert_eq!(
            shown,
            [
                ("ball.x", "5.3"),
                ("ball.y", "-2.5"),
                ("blue[0].id", "0"),
                ("blue[0].x", "15.2"),
                ("blue[1].id", "4"),
                ("blue[1].x", "98.4"),
                ("blue[1].pose", "(2 fields)"),
                ("blue[1].pose.xh", "1.0"),
                ("blue[1].pose.yh", "0.0"),
            ]
        );
        assert_eq!(rows[0].key, "ball[0].x");
        assert_eq!(rows[7].number, Some(1.0));
        assert_eq!(rows[6].number, None);
    }

    #[test]
    fn strings_are_unescaped_and_words_are_not_numbers() {
        let p = parse("@ <a> 0\nnote text \"kick \\\"off\\\"\" mode idle n 12\nstatus\n");
        let (rows, _) = rows(&p);
        assert_eq!(rows[0].value, "\"kick \"off\"\"");
        assert_eq!(rows[0].number, None);
        assert_eq!(rows[1].number, None);
        assert_eq!(rows[2].number, Some(12.0));
        // A line without fields is a row of its own.
        assert_eq!(rows[3].shown, "status");
        assert_eq!(rows[3].value, "");
    }

    #[test]
    fn huge_and_non_finite_numbers_never_reach_a_plot() {
        let p = parse("@ <a> 0\nv a 1e308 b NaN c inf d -1e999 e 123456789012345678901234567890\n");
        let n = numbers(&p);
        let keys: Vec<&str> = n.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(keys, ["v[0].a", "v[0].e"]);
        assert!(n.iter().all(|(_, v)| v.is_finite()));
    }

    #[test]
    fn escape_sequences_from_the_network_never_reach_the_terminal() {
        let p =
            parse("@ <a> 0\nx\u{9b}2J t \"\u{9b}]0;owned\\n\ttab\" u \"\u{202e}abc\" w\u{9b}1 2\n");
        let (rows, _) = rows(&p);
        assert_eq!(rows.len(), 3);
        for r in &rows {
            for text in [&r.value, &r.shown, &r.key] {
                assert!(!text.chars().any(|c| c.is_control()), "{r:?}");
                assert!(!text.contains('\u{202e}'), "{r:?}");
            }
        }
        assert_eq!(printable("a\u{1b}[2Jb\u{9b}c"), "a\\u{1b}[2Jb\\u{9b}c");
    }

    #[test]
    fn a_packet_of_many_fields_is_listed_up_to_the_cap() {
        let mut text = String::from("@ <a> 0\n");
        for i in 0..(MAX_ROWS + 10) {
            text.push_str(&format!("p i {i}\n"));
        }
        let p = parse(&text);
        let (rows, left_off) = rows(&p);
        assert_eq!(rows.len(), MAX_ROWS);
        assert_eq!(left_off, 10);
        assert_eq!(rows[5].shown, "p[5].i");
    }
}
