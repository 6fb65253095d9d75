//! The JSON Schema of each channel colony itself publishes on.
//!
//! Written from the encoders in `colony-proto` (one line per label there);
//! a test checks every field of packets those encoders wrote against it.

use serde_json::{json, Map, Value as Json};

/// A channel's schema: its name, as viewers show it, and its JSON Schema text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Schema {
    /// `colony.vision`, or `colony.packet` for a channel colony does not know.
    pub name: String,
    /// The JSON Schema, as text.
    pub data: Vec<u8>,
}

#[derive(Clone, Copy)]
enum Kind {
    Int,
    Num,
    Str,
}

use Kind::{Int, Num, Str};

/// A label and its fields.
type Line = (&'static str, &'static [(&'static str, Kind)]);

/// Channels, by exact name or by prefix (ending in `.`), with their lines.
const CHANNELS: &[(&str, &str, &[Line])] = &[
    (
        "vision",
        "colony.vision",
        &[
            ("step", &[("n", Int), ("part", Int), ("parts", Int)]),
            ("arena", &[("width", Num), ("height", Num), ("corner", Num)]),
            (
                "sizes",
                &[
                    ("robot_length", Num),
                    ("robot_width", Num),
                    ("gripper_radius", Num),
                    ("puck_diameter", Num),
                ],
            ),
            (
                "robot",
                &[
                    ("id", Int),
                    ("x", Num),
                    ("y", Num),
                    ("theta", Num),
                    ("carrying", Int),
                ],
            ),
            (
                "puck",
                &[("id", Int), ("kind", Int), ("x", Num), ("y", Num)],
            ),
            (
                "box",
                &[
                    ("id", Int),
                    ("x", Num),
                    ("y", Num),
                    ("theta", Num),
                    ("length", Num),
                    ("width", Num),
                ],
            ),
            ("goal", &[("x", Num), ("y", Num)]),
        ],
    ),
    (
        "radio",
        "colony.radio",
        &[("cmd", &[("id", Int), ("forward", Num), ("turn", Num)])],
    ),
    (
        "debug",
        "colony.debug",
        &[
            (
                "robot",
                &[("id", Int), ("state", Str), ("tx", Num), ("ty", Num)],
            ),
            (
                "cache",
                &[("id", Int), ("kind", Int), ("x", Num), ("y", Num)],
            ),
        ],
    ),
    (
        "metrics",
        "colony.metrics",
        &[("sort", &[("step", Int), ("pc", Num)])],
    ),
    (
        "camera.",
        "colony.camera",
        &[
            ("step", &[("n", Int)]),
            ("pose", &[("x", Num), ("y", Num), ("theta", Num)]),
            ("gripper", &[("kind", Int), ("x", Num), ("y", Num)]),
            (
                "puck",
                &[("kind", Int), ("x", Num), ("y", Num), ("held", Int)],
            ),
            ("robot", &[("x", Num), ("y", Num)]),
            ("obstacle", &[("x", Num), ("y", Num)]),
        ],
    ),
    (
        "game.world",
        "colony.game.world",
        &[
            ("step", &[("n", Int), ("time", Num)]),
            (
                "robot",
                &[
                    ("id", Int),
                    ("x", Num),
                    ("y", Num),
                    ("theta", Num),
                    ("active", Int),
                ],
            ),
        ],
    ),
    (
        "game.sense.",
        "colony.game.sense",
        &[(
            "sense",
            &[
                ("step", Int),
                ("time", Num),
                ("x", Num),
                ("y", Num),
                ("theta", Num),
                ("bump_front", Int),
                ("bump_rear", Int),
                ("border", Int),
            ],
        )],
    ),
    (
        "game.state",
        "colony.game.state",
        &[
            (
                "game",
                &[
                    ("mode", Str),
                    ("status", Str),
                    ("time", Num),
                    ("winner", Str),
                    ("reason", Str),
                ],
            ),
            ("team", &[("name", Str), ("score", Int), ("kills", Int)]),
            (
                "flag",
                &[("team", Str), ("x", Num), ("y", Num), ("home", Int)],
            ),
            (
                "robot",
                &[
                    ("id", Int),
                    ("team", Str),
                    ("squad", Str),
                    ("kind", Str),
                    ("x", Num),
                    ("y", Num),
                    ("theta", Num),
                    ("health", Num),
                    ("max_health", Num),
                    ("power", Num),
                    ("alive", Int),
                    ("behaviour", Str),
                    ("reason", Str),
                ],
            ),
            (
                "squad",
                &[
                    ("team", Str),
                    ("name", Str),
                    ("formation", Str),
                    ("order", Str),
                    ("behaviour", Str),
                    ("path", Str),
                ],
            ),
        ],
    ),
    (
        "game.debug",
        "colony.game.debug",
        &[("robot", &[("id", Int), ("behaviour", Str), ("reason", Str)])],
    ),
    (
        "game.map",
        "colony.game.map",
        &[
            (
                "map",
                &[
                    ("width", Int),
                    ("height", Int),
                    ("cell", Num),
                    ("part", Int),
                    ("parts", Int),
                ],
            ),
            (
                "site",
                &[
                    ("team", Str),
                    ("base_x", Num),
                    ("base_y", Num),
                    ("flag_x", Num),
                    ("flag_y", Num),
                ],
            ),
            ("row", &[("y", Int), ("cells", Str)]),
        ],
    ),
    (
        "murdoch.robots",
        "colony.murdoch.robots",
        &[(
            "robot",
            &[
                ("name", Str),
                ("mode", Str),
                ("battery", Num),
                ("resources", Str),
            ],
        )],
    ),
];

fn kind(k: Kind) -> Json {
    match k {
        Int => json!({"type": "integer"}),
        Num => json!({"type": "number"}),
        Str => json!({"type": "string"}),
    }
}

/// The schema of the envelope every message shares, with `lines` as given.
fn envelope(name: &str, lines: Json) -> Json {
    json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": name,
        "description": "A colony packet: its exact text, its header, and its lines as data (each label an array of its lines, in order).",
        "type": "object",
        "properties": {
            "packet": {"type": "string", "description": "the packet exactly as received"},
            "subjects": {"type": "array", "items": {"type": "string"}},
            "priority": {"type": "integer"},
            "source": {"type": "string", "description": "the sender's address, as the hub saw it"},
            "lines": lines,
        },
        "required": ["packet", "subjects", "priority", "lines"],
    })
}

/// Lines of labels no schema names: any fields, any values.
fn any_lines() -> Json {
    json!({"type": "object", "additionalProperties": {"type": "array", "items": {"type": "object"}}})
}

/// The schema for a topic (see [`crate::topic`]): a known channel's, or the
/// generic one (every packet fits it). Subject sets and unknown channels
/// get the generic one.
pub fn schema_for(topic: &str) -> Schema {
    let known = CHANNELS
        .iter()
        .find(|(channel, _, _)| match channel.strip_suffix('.') {
            // A family: `camera.` names `camera.0`, `camera.1`, ... (one subject each).
            Some(_) => topic
                .strip_prefix(channel)
                .is_some_and(|rest| !rest.is_empty() && !rest.contains('+')),
            None => topic == *channel,
        });
    let (name, schema) = match known {
        Some((_, name, lines)) => {
            let mut properties = Map::new();
            for (label, fields) in lines.iter() {
                let fields: Map<String, Json> = fields
                    .iter()
                    .map(|(f, k)| ((*f).to_owned(), kind(*k)))
                    .collect();
                properties.insert(
                    (*label).to_owned(),
                    json!({"type": "array", "items": {"type": "object", "properties": fields}}),
                );
            }
            let lines = json!({
                "type": "object",
                "properties": properties,
                "additionalProperties": {"type": "array", "items": {"type": "object"}},
            });
            ((*name).to_owned(), envelope(name, lines))
        }
        None => (
            "colony.packet".to_owned(),
            envelope("colony.packet", any_lines()),
        ),
    };
    Schema {
        name,
        data: serde_json::to_vec_pretty(&schema).unwrap_or_default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn properties(topic: &str) -> Json {
        let s = schema_for(topic);
        let j: Json = serde_json::from_slice(&s.data).unwrap();
        j["properties"]["lines"]["properties"].clone()
    }

    #[test]
    fn known_channels_and_families_have_their_own_schemas() {
        assert_eq!(schema_for("vision").name, "colony.vision");
        assert_eq!(schema_for("camera.3").name, "colony.camera");
        assert_eq!(schema_for("game.sense.12").name, "colony.game.sense");
        assert_eq!(schema_for("camera.").name, "colony.packet");
        assert_eq!(schema_for("camera.1+radio").name, "colony.packet");
        assert_eq!(schema_for("whatever").name, "colony.packet");
        assert_eq!(
            properties("vision")["robot"]["items"]["properties"]["x"]["type"],
            "number"
        );
        assert_eq!(
            properties("vision")["robot"]["items"]["properties"]["id"]["type"],
            "integer"
        );
    }

    #[test]
    fn every_schema_is_valid_json_with_the_envelope() {
        for (channel, _, _) in CHANNELS {
            let topic = format!("{channel}{}", if channel.ends_with('.') { "0" } else { "" });
            let j: Json = serde_json::from_slice(&schema_for(&topic).data).unwrap();
            assert_eq!(
                j["required"],
                json!(["packet", "subjects", "priority", "lines"])
            );
        }
    }
}
