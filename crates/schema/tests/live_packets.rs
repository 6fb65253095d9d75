//! Packets colony's own processes published (captured from `colony sort live`,
//! `colony game ctf` and `colony tasks demo` on a hub), checked against the
//! schemas: every label is described, and every field has the described type.

use colony_schema::{schema_for, to_json, topic};
use colony_wire::{split_packets, Packet};
use serde_json::Value;

const LIVE: &str = include_str!("live_packets.txt");

fn fits(kind: &str, value: &Value) -> bool {
    match kind {
        "integer" => value.is_i64() || value.is_u64(),
        "number" => value.is_number(),
        "string" => value.is_string(),
        _ => false,
    }
}

#[test]
fn every_field_colony_publishes_has_the_type_its_schema_says() {
    let mut checked = 0;
    for text in split_packets(LIVE) {
        let packet = Packet::parse(text.as_bytes()).unwrap();
        let topic = topic(&packet);
        let schema = schema_for(&topic);
        assert_ne!(
            schema.name, "colony.packet",
            "{topic} has no schema of its own"
        );
        let schema: Value = serde_json::from_slice(&schema.data).unwrap();
        let message: Value = serde_json::from_slice(&to_json(&packet, None)).unwrap();
        let labels = &schema["properties"]["lines"]["properties"];
        for (label, lines) in message["lines"].as_object().unwrap() {
            let fields = &labels[label]["items"]["properties"];
            assert!(
                fields.is_object(),
                "{topic}: label `{label}` is not in the schema"
            );
            for line in lines.as_array().unwrap() {
                for (name, value) in line.as_object().unwrap() {
                    let kind = fields[name]["type"].as_str().unwrap_or_else(|| {
                        panic!("{topic}: `{label} {name}` is not in the schema")
                    });
                    assert!(
                        fits(kind, value),
                        "{topic}: `{label} {name}` is {value}, not {kind}"
                    );
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 100, "only {checked} fields checked");
}
