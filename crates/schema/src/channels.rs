//! The JSON Schema of each channel colony itself publishes on.
//!
//! Generated from the field tables in `colony-proto` (`colony_proto::table`), which tests
//! there tie to each message's writer and reader; a test here checks every field of packets
//! colony's processes wrote against the result.

use colony_proto::table::{Kind, MessageTable};
use colony_proto::{game, murdoch, radio, swarm};
use serde_json::{json, Map, Value as Json};

/// A channel's schema: its name, as viewers show it, and its JSON Schema text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Schema {
    /// `colony.vision`, or `colony.packet` for a channel colony does not know.
    pub name: String,
    /// The JSON Schema, as text.
    pub data: Vec<u8>,
}

/// The channels with a schema of their own: those colony's processes publish on, each
/// described by its message's field table in `colony-proto`.
const TABLES: &[&MessageTable] = &[
    &swarm::vision::TABLE,
    &radio::TABLE,
    &swarm::debug::TABLE,
    &swarm::metrics::TABLE,
    &swarm::camera::TABLE,
    &game::world::TABLE,
    &game::sense::TABLE,
    &game::state::TABLE,
    &game::debug::TABLE,
    &game::map::TABLE,
    &murdoch::robot::TABLE,
];

fn kind(k: Kind) -> Json {
    match k {
        Kind::Int => json!({"type": "integer"}),
        Kind::Num => json!({"type": "number"}),
        Kind::Text => json!({"type": "string"}),
        Kind::NumOrText => json!({"type": ["number", "string"]}),
    }
}

/// `colony.vision` for `vision`, `colony.camera` for the `camera.` family.
fn schema_name(table: &MessageTable) -> String {
    format!("colony.{}", table.channel.trim_end_matches('.'))
}

/// The `lines` of a message the table describes: each label an array of objects with the
/// table's fields; labels it does not name (a newer writer's) still fit.
fn table_lines(table: &MessageTable) -> Json {
    let mut properties = Map::new();
    for line in table.lines {
        let fields: Map<String, Json> = line
            .fields
            .iter()
            .map(|f| (f.name.to_owned(), kind(f.kind)))
            .collect();
        properties.insert(
            line.label.to_owned(),
            json!({"type": "array", "items": {"type": "object", "properties": fields}}),
        );
    }
    json!({
        "type": "object",
        "properties": properties,
        "additionalProperties": {"type": "array", "items": {"type": "object"}},
    })
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
    // A subject set's topic joins its subjects with `+`: no single channel's.
    let known = TABLES
        .iter()
        .find(|t| !topic.contains('+') && t.names(topic));
    let (name, schema) = match known {
        Some(table) => {
            let name = schema_name(table);
            let schema = envelope(&name, table_lines(table));
            (name, schema)
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
    fn optional_fields_proto_writes_are_in_their_schemas() {
        // The hand-kept schemas left these out; proto writes each when it applies.
        let field = |topic: &str, label: &str, name: &str| {
            properties(topic)[label]["items"]["properties"][name]["type"].clone()
        };
        assert_eq!(field("game.state", "flag", "carrier"), "integer");
        assert_eq!(field("game.sense.0", "sense", "sonar"), "number");
        assert_eq!(field("murdoch.robots", "robot", "task_name"), "string");
    }

    #[test]
    fn every_schema_is_valid_json_with_the_envelope() {
        for table in TABLES {
            let channel = table.channel;
            let topic = format!("{channel}{}", if channel.ends_with('.') { "0" } else { "" });
            let j: Json = serde_json::from_slice(&schema_for(&topic).data).unwrap();
            assert_eq!(
                j["required"],
                json!(["packet", "subjects", "priority", "lines"])
            );
        }
    }
}
