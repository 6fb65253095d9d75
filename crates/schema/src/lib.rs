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
//! viewer plots robot 3's `x` as `/vision.lines.robot[:]{id==3}.x`. A bare
//! token that reads as an integer is an integer, one that reads as a finite
//! number is a number, anything else (and every quoted string) a string; a
//! group is an object. [`schema_for`] gives the JSON Schema of a channel:
//! precise for colony's own channels, generic for any other.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod channels;

use colony_wire::{Fields, Packet, Value};
use serde_json::{Map, Number, Value as Json};

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
pub fn to_json(packet: &Packet<'_>, source: Option<&str>) -> Vec<u8> {
    let mut lines: Map<String, Json> = Map::new();
    for line in packet.lines() {
        let entry = lines
            .entry(line.label().to_owned())
            .or_insert_with(|| Json::Array(Vec::new()));
        if let Json::Array(all) = entry {
            all.push(Json::Object(object(line.fields())));
        }
    }
    let mut message = Map::new();
    message.insert("packet".into(), Json::String(packet.as_str().to_owned()));
    message.insert(
        "subjects".into(),
        Json::Array(packet.subjects().map(|s| Json::String(s.into())).collect()),
    );
    message.insert("priority".into(), Json::from(packet.priority().0));
    if let Some(source) = source {
        message.insert("source".into(), Json::String(source.to_owned()));
    }
    message.insert("lines".into(), Json::Object(lines));
    serde_json::to_vec(&Json::Object(message)).unwrap_or_default()
}

fn object(fields: Fields<'_>) -> Map<String, Json> {
    fields
        .map(|f| (f.name.to_owned(), value(&f.value)))
        .collect()
}

fn value(v: &Value<'_>) -> Json {
    match v {
        Value::Bare(token) => token
            .parse::<i64>()
            .map(Json::from)
            .ok()
            .or_else(|| {
                token
                    .parse::<f64>()
                    .ok()
                    .and_then(Number::from_f64)
                    .map(Json::Number)
            })
            .unwrap_or_else(|| Json::String((*token).to_owned())),
        Value::Quoted(q) => Json::String(q.unescape().into_owned()),
        Value::Group(g) => Json::Object(object(g.fields())),
    }
}

/// The packet's exact text and its source back from a message [`to_json`]
/// made (or any JSON object with a string `packet`); `None` for anything else.
pub fn packet_text(json: &[u8]) -> Option<(String, Option<String>)> {
    let Json::Object(mut message) = serde_json::from_slice(json).ok()? else {
        return None;
    };
    let Some(Json::String(packet)) = message.remove("packet") else {
        return None;
    };
    let source = match message.remove("source") {
        Some(Json::String(s)) => Some(s),
        _ => None,
    };
    Some((packet, source))
}

#[cfg(test)]
mod tests {
    use super::*;

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
