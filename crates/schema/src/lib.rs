//! colony's packets as typed JSON, for the tools a robotics lab already has.
//!
//! MCAP logs and the Foxglove WebSocket protocol both carry a message with an
//! encoding and a schema; their viewers (Foxglove, Lichtblick, PlotJuggler)
//! read JSON described by a JSON Schema without any plug-in. So a colony
//! packet becomes one JSON object that keeps the packet's text exactly and
//! lays its lines out as data:
//!
//! ```text
//! @ <vision> 20                       {"packet": "@ <vision> 20\nstep n 7 ...",
//! step n 7 part 0 parts 1              "subjects": ["vision"], "priority": 20,
//! robot id 3 x 1.5 y -2 theta 0.1      "source": "127.0.0.1:5000",
//!                                      "lines": {"step": [{"n": 7, "part": 0, "parts": 1}],
//!                                                "robot": [{"id": 3, "x": 1.5, "y": -2, "theta": 0.1}]}}
//! ```
//!
//! Each label is an array (a label may repeat: the format's arrays), so a
//! viewer plots robot 3's `x` as `"vision".lines.robot[:]{id==3}.x` (Foxglove's
//! message-path syntax, the topic quoted since colony's topics carry no leading
//! slash and may hold dots: `"game.state".lines.flag[:]{team=="red"}.x`). A bare
//! token that reads as an integer is an integer, one that reads as a finite
//! number is a number, anything else (and every quoted string) a string; a
//! group is an object. [`schema_for`] gives the JSON Schema of a channel:
//! precise for colony's own channels, generic for any other.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod channels;

use std::collections::HashMap;
use std::io::Write as _;

use colony_wire::{Fields, Packet, Value};

pub use channels::{schema_for, Schema};

/// The message encoding, as MCAP and Foxglove name it.
pub const MESSAGE_ENCODING: &str = "json";
/// The schema encoding, as MCAP and Foxglove name it.
pub const SCHEMA_ENCODING: &str = "jsonschema";

/// The topic a packet goes under: its channel, or for a subject set its
/// subjects joined by `+` (a character no subject holds, so no two sets share a topic).
pub fn topic(packet: &Packet<'_>) -> String {
    packet.subjects().collect::<Vec<_>>().join("+")
}

/// The packet as a JSON message (see the crate's documentation), with the
/// address it came from when known.
///
/// Written straight into one buffer, labels in the order they first appear:
/// a hub logging every packet to MCAP calls this once per packet.
pub fn to_json(packet: &Packet<'_>, source: Option<&str>) -> Vec<u8> {
    // Each label's lines, as JSON objects joined by commas, in first-seen order.
    let mut labels: Vec<(&str, Vec<u8>)> = Vec::new();
    let mut index: HashMap<&str, usize> = HashMap::new();
    for line in packet.lines() {
        let i = match index.get(line.label()) {
            Some(&i) => i,
            None => {
                index.insert(line.label(), labels.len());
                labels.push((line.label(), Vec::new()));
                labels.len() - 1
            }
        };
        let out = &mut labels[i].1;
        if !out.is_empty() {
            out.push(b',');
        }
        object(out, line.fields());
    }
    let mut out = Vec::with_capacity(packet.as_str().len() * 3 + 64);
    out.extend_from_slice(b"{\"packet\":");
    string(&mut out, packet.as_str());
    out.extend_from_slice(b",\"subjects\":[");
    for (i, s) in packet.subjects().enumerate() {
        if i > 0 {
            out.push(b',');
        }
        string(&mut out, s);
    }
    out.extend_from_slice(format!("],\"priority\":{}", packet.priority().0).as_bytes());
    if let Some(source) = source {
        out.extend_from_slice(b",\"source\":");
        string(&mut out, source);
    }
    out.extend_from_slice(b",\"lines\":{");
    for (i, (label, lines)) in labels.iter().enumerate() {
        if i > 0 {
            out.push(b',');
        }
        string(&mut out, label);
        out.extend_from_slice(b":[");
        out.extend_from_slice(lines);
        out.push(b']');
    }
    out.extend_from_slice(b"}}");
    out
}

/// A JSON string, escaped as JSON requires.
fn string(out: &mut Vec<u8>, s: &str) {
    if s.bytes().all(|b| b >= 0x20 && b != b'"' && b != b'\\') {
        // Most labels, names and words need no escape at all.
        out.push(b'"');
        out.extend_from_slice(s.as_bytes());
        out.push(b'"');
    } else {
        // Writing a &str into a Vec cannot fail.
        let _ = serde_json::to_writer(&mut *out, s);
    }
}

/// Whether `token` is written as JSON writes a number: `-?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?`.
fn is_json_number(token: &str) -> bool {
    let b = token.as_bytes();
    let mut i = usize::from(b.first() == Some(&b'-'));
    let digits = |i: &mut usize| {
        let start = *i;
        while b.get(*i).is_some_and(u8::is_ascii_digit) {
            *i += 1;
        }
        *i - start
    };
    match b.get(i) {
        Some(b'0') => i += 1,
        Some(b'1'..=b'9') => {
            digits(&mut i);
        }
        _ => return false,
    }
    if b.get(i) == Some(&b'.') {
        i += 1;
        if digits(&mut i) == 0 {
            return false;
        }
    }
    if matches!(b.get(i), Some(b'e' | b'E')) {
        i += 1;
        if matches!(b.get(i), Some(b'+' | b'-')) {
            i += 1;
        }
        if digits(&mut i) == 0 {
            return false;
        }
    }
    i == b.len()
}

/// The fields as a JSON object. A name repeated within one line or group is
/// refused by the parser, so keys never repeat.
fn object(out: &mut Vec<u8>, fields: Fields<'_>) {
    out.push(b'{');
    for (i, f) in fields.enumerate() {
        if i > 0 {
            out.push(b',');
        }
        string(out, f.name);
        out.push(b':');
        value(out, &f.value);
    }
    out.push(b'}');
}

fn value(out: &mut Vec<u8>, v: &Value<'_>) {
    match v {
        Value::Bare(token) => {
            let finite = |t: &str| t.parse::<f64>().ok().filter(|x| x.is_finite());
            // Without an exponent, fewer than 300 digits cannot overflow an f64.
            let short = token.len() < 300 && !token.contains(['e', 'E']);
            if is_json_number(token) && (short || finite(token).is_some()) {
                // The commonest case by far (`-18.24`, `3`): the token as written.
                out.extend_from_slice(token.as_bytes());
            } else if let Ok(i) = token.parse::<i64>() {
                // `007`, `+5`: integers JSON would not take as written.
                let _ = write!(out, "{i}");
            } else if let Some(x) = finite(token) {
                // `.5`, `5.`, `1E+3`.
                let _ = serde_json::to_writer(&mut *out, &x);
            } else {
                // JSON has no NaN or infinity, and a word is a word.
                string(out, token);
            }
        }
        Value::Quoted(q) => string(out, &q.unescape()),
        Value::Group(g) => object(out, g.fields()),
    }
}

/// The packet's exact text and its source back from a message [`to_json`]
/// made (or any JSON object with a string `packet`, and a string `source` if
/// any); `None` for anything else.
///
/// Only those two fields are kept: every other field (the typed `lines`,
/// which a forged message can make as large as it likes) is skipped as it is
/// read, not built, so this takes little memory beyond `json` itself.
pub fn packet_text(json: &[u8]) -> Option<(String, Option<String>)> {
    #[derive(serde::Deserialize)]
    struct Message {
        packet: String,
        #[serde(default)]
        source: Option<String>,
    }
    let m: Message = serde_json::from_slice(json).ok()?;
    Some((m.packet, m.source))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::Value as Json;

    fn json(text: &str) -> Json {
        let p = Packet::parse(text.as_bytes()).unwrap();
        serde_json::from_slice(&to_json(&p, Some("127.0.0.1:5000"))).unwrap()
    }

    #[test]
    fn lines_become_arrays_of_objects_with_typed_values() {
        let j = json(concat!(
            "@ <vision> 20\n",
            "step n 7 part 0 parts 1\n",
            "robot id 3 x 1.5 y -2 theta 0.1\n",
            "robot id 4 x 1e3 y nan theta inf note \"a \\\"b\\\"\" g (k 1 s -)\n",
        ));
        assert_eq!(j["subjects"], serde_json::json!(["vision"]));
        assert_eq!(j["priority"], 20);
        assert_eq!(j["source"], "127.0.0.1:5000");
        assert_eq!(j["lines"]["step"][0]["n"], 7);
        let robots = j["lines"]["robot"].as_array().unwrap();
        assert_eq!(robots.len(), 2);
        assert_eq!(robots[0]["id"], 3);
        assert_eq!(robots[0]["x"], 1.5);
        assert_eq!(robots[0]["y"], -2);
        assert_eq!(robots[1]["x"], 1000.0);
        // JSON has no NaN or infinity: they stay the words they were.
        assert_eq!(robots[1]["y"], "nan");
        assert_eq!(robots[1]["theta"], "inf");
        assert_eq!(robots[1]["note"], "a \"b\"");
        assert_eq!(robots[1]["g"], serde_json::json!({"k": 1, "s": "-"}));
    }

    #[test]
    fn the_packet_text_comes_back_exactly() {
        // Not canonical on purpose: blanks, CRLF, a blank line.
        let text = "@  <a> <b>   -3\r\nx  y 1\n\nz w \"q\"\n";
        let p = Packet::parse(text.as_bytes()).unwrap();
        assert_eq!(topic(&p), "a+b");
        let back = packet_text(&to_json(&p, None)).unwrap();
        assert_eq!(back, (text.to_owned(), None));
        assert_eq!(packet_text(b"{\"packet\": 5}"), None);
        assert_eq!(packet_text(b"not json"), None);
    }

    #[test]
    fn numbers_json_would_not_take_as_written_are_rewritten() {
        let j = json("@ <a> 0\nl a .5 b 5. c +5 d -0 e 1E+3 f 0x10 g 1.5e-3 h -\n");
        let l = &j["lines"]["l"][0];
        assert_eq!(l["a"], 0.5);
        assert_eq!(l["b"], 5.0);
        assert_eq!(l["c"], 5);
        assert_eq!(l["d"].as_f64(), Some(0.0));
        assert_eq!(l["e"], 1000.0);
        assert_eq!(l["f"], "0x10");
        assert_eq!(l["g"], 0.0015);
        assert_eq!(l["h"], "-");
        for ok in ["0", "-0", "1.5", "-1e5", "2E-3", "10"] {
            assert!(is_json_number(ok), "{ok}");
        }
        for bad in ["", "-", "01", ".5", "5.", "1e", "+1", "1.e5", "0x1", "1e5x"] {
            assert!(!is_json_number(bad), "{bad}");
        }
    }

    #[test]
    fn names_that_need_escapes_are_escaped() {
        let j = json("@ <a> 0\nl\\x k\\y v\\z\n");
        assert_eq!(j["lines"]["l\\x"][0]["k\\y"], "v\\z");
    }

    #[test]
    fn integers_past_i64_are_numbers_and_huge_ones_stay_words() {
        let j = json("@ <a> 0\nl a 9223372036854775808 b 1e400 c 007\n");
        assert_eq!(j["lines"]["l"][0]["a"], 9223372036854775808.0);
        assert_eq!(j["lines"]["l"][0]["b"], "1e400");
        assert_eq!(j["lines"]["l"][0]["c"], 7);
    }

    proptest::proptest! {
        #[test]
        fn any_packet_makes_json_that_gives_its_text_back(body in "[a-z]{1,3}( [a-z]{1,3} ([0-9.e-]{1,6}|\"[ -~&&[^\"\\\\]]{0,6}\")){0,4}") {
            let text = format!("@ <t> 1\n{body}\n");
            if let Ok(p) = Packet::parse(text.as_bytes()) {
                let back = packet_text(&to_json(&p, Some("s"))).unwrap();
                proptest::prop_assert_eq!(back, (text.clone(), Some("s".to_owned())));
            }
        }
    }
}
