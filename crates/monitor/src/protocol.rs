//! What the browser may send, read as untrusted input.
//!
//! Every message is one JSON object with a `t` field naming it:
//!
//! ```text
//! {"t":"publish","text":"@ <test> 0\nhello x 1\n"}   forge a packet
//! {"t":"take","ids":[0,3]}    {"t":"take_all"}         take control
//! {"t":"release","ids":[0]}   {"t":"release_all"}      hand back to the AI
//! {"t":"drive","ids":[0],"forward":0.8,"turn":-0.2}    keys (ids optional: all held)
//! {"t":"goto","ids":[0],"x":40.5,"y":-12}              a point on the arena, cm
//! {"t":"squad","team":"red","squad":"alpha","do":"attack","robot":7,"formation":"wedge"}
//!                                                      a game squad command
//! {"t":"robot",...} {"t":"split",...} {"t":"merge",...} {"t":"robot_drive",...}
//! {"t":"robot_release",...} {"t":"chat",...}           the game's other orders, and chat
//! {"t":"setup","team":"red","squads":"alpha:tank+h1"} {"t":"ready","team":"red","ready":true}
//! ```
//!
//! The game's messages' fields are in [`crate::game::orders`]; `"type"` is
//! read as `"t"` when `"t"` is missing, since that is how the game's
//! documentation writes it.
//!
//! Anything else (bad JSON, unknown `t`, values out of range) is refused
//! with a message for the operator; nothing the browser sends can panic the
//! server.

use serde::{Deserialize, Serialize};

use crate::game::orders::{
    ChatMsg, FreeMsg, MergeMsg, ReadyMsg, RobotMsg, SetupMsg, SplitMsg, SquadMsg, SteerMsg,
};
use crate::state::{check_forged, Command, MAX_COORD, MAX_HELD};

/// The longest message the server reads from a browser (a forged packet at
/// most one datagram, written out as JSON).
pub const MAX_MESSAGE: usize = 256 * 1024;

#[derive(Deserialize)]
#[serde(tag = "t", rename_all = "snake_case")]
enum ClientMsg {
    Publish {
        text: String,
    },
    Take {
        ids: Vec<u32>,
    },
    TakeAll,
    Release {
        ids: Vec<u32>,
    },
    ReleaseAll,
    Drive {
        #[serde(default)]
        ids: Option<Vec<u32>>,
        forward: f64,
        turn: f64,
    },
    Goto {
        #[serde(default)]
        ids: Option<Vec<u32>>,
        x: f64,
        y: f64,
    },
    Squad(SquadMsg),
    Robot(RobotMsg),
    Split(SplitMsg),
    Merge(MergeMsg),
    RobotDrive(SteerMsg),
    RobotRelease(FreeMsg),
    Chat(ChatMsg),
    Setup(SetupMsg),
    Ready(ReadyMsg),
}

/// Why a browser message was refused; `line` and `column` point into a forged packet.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Refusal {
    /// Why, for the operator to read.
    pub message: String,
    /// The forged packet's line at fault.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub line: Option<u32>,
    /// The column in that line.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub column: Option<u32>,
}

impl Refusal {
    fn new(message: impl Into<String>) -> Refusal {
        Refusal {
            message: message.into(),
            line: None,
            column: None,
        }
    }
}

/// The server's answer to one browser message.
#[derive(Debug, Serialize)]
pub struct ReplyJson<'a> {
    /// Always `"reply"`.
    pub t: &'static str,
    /// Whether the request was carried out.
    pub ok: bool,
    /// The request's `t`, when it could be read.
    pub to: Option<&'a str>,
    /// What was done, or why not.
    pub msg: &'a str,
    /// A refused forged packet's line at fault.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub line: Option<u32>,
    /// The column in that line.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub column: Option<u32>,
}

fn refused(e: crate::game::orders::OrderRefused) -> Refusal {
    Refusal::new(e.to_string())
}

/// Reads the `t` of a message, for the reply, without trusting the rest.
pub fn kind_of(text: &str) -> Option<String> {
    #[derive(Deserialize)]
    struct Kind {
        t: Option<String>,
        #[serde(rename = "type")]
        kind: Option<String>,
    }
    serde_json::from_str::<Kind>(text)
        .ok()
        .and_then(|k| k.t.or(k.kind))
        .map(|t| t.chars().take(20).collect())
}

/// Reads a message named by `"type"` instead of `"t"`; None when it isn't one.
fn with_type_as_t(text: &str) -> Option<ClientMsg> {
    let mut map: serde_json::Map<String, serde_json::Value> = serde_json::from_str(text).ok()?;
    if map.contains_key("t") {
        return None;
    }
    let kind = map.remove("type")?;
    map.insert("t".into(), kind);
    serde_json::from_value(serde_json::Value::Object(map)).ok()
}

fn unit(name: &str, v: f64) -> Result<f64, Refusal> {
    if v.is_finite() && (-1.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(Refusal::new(format!(
            "{name} must be between -1 and 1, not {v}"
        )))
    }
}

fn coord(name: &str, v: f64) -> Result<f64, Refusal> {
    if v.is_finite() && v.abs() <= MAX_COORD {
        Ok(v)
    } else {
        Err(Refusal::new(format!(
            "{name} must be a position in cm within ±{MAX_COORD}, not {v}"
        )))
    }
}

fn ids(ids: Vec<u32>) -> Result<Vec<u32>, Refusal> {
    if ids.len() > MAX_HELD {
        return Err(Refusal::new(format!(
            "{} robot ids: at most {MAX_HELD} at once",
            ids.len()
        )));
    }
    Ok(ids)
}

/// Reads and checks one message from the browser.
pub fn parse_message(text: &str) -> Result<Command, Refusal> {
    if text.len() > MAX_MESSAGE {
        return Err(Refusal::new(format!(
            "message of {} bytes is larger than {MAX_MESSAGE}",
            text.len()
        )));
    }
    let msg: ClientMsg = match serde_json::from_str(text) {
        Ok(m) => m,
        Err(e) => with_type_as_t(text).ok_or_else(|| {
            Refusal::new(format!(
                "cannot read the request: {e} (expected JSON like {{\"t\":\"take\",\"ids\":[0]}})"
            ))
        })?,
    };
    Ok(match msg {
        ClientMsg::Publish { text } => {
            if text.len() > colony_wire::MAX_PACKET {
                return Err(Refusal::new(format!(
                    "packet is {} bytes, more than the {} a datagram carries",
                    text.len(),
                    colony_wire::MAX_PACKET
                )));
            }
            match check_forged(&text) {
                Ok(bytes) => Command::Publish(bytes),
                Err(e) => {
                    return Err(Refusal {
                        message: format!("line {}, column {}: {}", e.line, e.column, e.message),
                        line: Some(e.line),
                        column: Some(e.column),
                    })
                }
            }
        }
        ClientMsg::Take { ids: i } => Command::Take(ids(i)?),
        ClientMsg::TakeAll => Command::TakeAll,
        ClientMsg::Release { ids: i } => Command::Release(ids(i)?),
        ClientMsg::ReleaseAll => Command::ReleaseAll,
        ClientMsg::Drive {
            ids: i,
            forward,
            turn,
        } => Command::Drive {
            ids: i.map(ids).transpose()?,
            forward: unit("forward", forward)?,
            turn: unit("turn", turn)?,
        },
        ClientMsg::Goto { ids: i, x, y } => Command::Goto {
            ids: i.map(ids).transpose()?,
            x: coord("x", x)?,
            y: coord("y", y)?,
        },
        ClientMsg::Squad(m) => Command::Game(m.check().map_err(refused)?),
        ClientMsg::Robot(m) => Command::Game(m.check().map_err(refused)?),
        ClientMsg::Split(m) => Command::Game(m.check().map_err(refused)?),
        ClientMsg::Merge(m) => Command::Game(m.check().map_err(refused)?),
        ClientMsg::RobotDrive(m) => Command::Game(m.check().map_err(refused)?),
        ClientMsg::RobotRelease(m) => Command::Game(m.check().map_err(refused)?),
        ClientMsg::Chat(m) => Command::Game(m.check().map_err(refused)?),
        ClientMsg::Setup(m) => Command::Game(m.check().map_err(refused)?),
        ClientMsg::Ready(m) => Command::Game(m.check().map_err(refused)?),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn good_messages_become_commands() {
        assert_eq!(
            parse_message(r#"{"t":"take","ids":[0,3]}"#).unwrap(),
            Command::Take(vec![0, 3])
        );
        assert_eq!(
            parse_message(r#"{"t":"take_all"}"#).unwrap(),
            Command::TakeAll
        );
        assert_eq!(
            parse_message(r#"{"t":"drive","forward":0.5,"turn":-1}"#).unwrap(),
            Command::Drive {
                ids: None,
                forward: 0.5,
                turn: -1.0
            }
        );
        assert_eq!(
            parse_message(r#"{"t":"goto","ids":[1],"x":10.5,"y":-3}"#).unwrap(),
            Command::Goto {
                ids: Some(vec![1]),
                x: 10.5,
                y: -3.0
            }
        );
        assert_eq!(
            parse_message(r#"{"t":"publish","text":"@ <t> 0\nhi x 1\n"}"#).unwrap(),
            Command::Publish(b"@ <t> 0\nhi x 1\n".to_vec())
        );
    }

    #[test]
    fn a_bad_forged_packet_is_refused_with_its_line_and_column() {
        let r = parse_message(r#"{"t":"publish","text":"@ <t> 0\nhi x \"open\n"}"#).unwrap_err();
        assert_eq!(r.line, Some(2));
        assert!(r.column.is_some());
        assert!(r.message.starts_with("line 2, column"), "{}", r.message);
    }

    #[test]
    fn malformed_or_out_of_range_input_is_refused_not_a_panic() {
        for bad in [
            "",
            "null",
            "[]",
            "{",
            r#"{"t":"explode"}"#,
            r#"{"t":"take"}"#,
            r#"{"t":"take","ids":[-1]}"#,
            r#"{"t":"take","ids":[1.5]}"#,
            r#"{"t":"take","ids":[4294967296]}"#,
            r#"{"t":"drive","forward":2,"turn":0}"#,
            r#"{"t":"drive","forward":"fast","turn":0}"#,
            r#"{"t":"goto","x":1e308,"y":0}"#,
            r#"{"t":"goto","x":1e999,"y":0}"#,
            r#"{"t":"publish","text":7}"#,
            r#"{"t":"publish","text":""}"#,
            "\u{0}\u{ffff}",
        ] {
            let r = parse_message(bad);
            assert!(r.is_err(), "{bad:?} was accepted");
            assert!(!r.unwrap_err().message.is_empty());
        }
        let many = format!(
            r#"{{"t":"take","ids":[{}]}}"#,
            vec!["1"; MAX_HELD + 1].join(",")
        );
        assert!(parse_message(&many).is_err());
        let huge = format!(
            r#"{{"t":"publish","text":"@ <t> 0\nx v {}\n"}}"#,
            "a".repeat(MAX_MESSAGE)
        );
        assert!(parse_message(&huge).is_err());
    }

    #[test]
    fn the_kind_of_a_request_is_read_for_the_reply() {
        assert_eq!(kind_of(r#"{"t":"goto","x":"no"}"#).as_deref(), Some("goto"));
        assert_eq!(kind_of(r#"{"type":"squad"}"#).as_deref(), Some("squad"));
        assert_eq!(kind_of("nonsense"), None);
    }

    #[test]
    fn a_squad_command_is_checked_whether_named_by_t_or_type() {
        for text in [
            r#"{"t":"squad","team":"red","squad":"alpha","do":"attack","robot":7,"formation":"wedge"}"#,
            r#"{"type":"squad","team":"red","squad":"alpha","do":"attack","robot":7,"formation":"wedge"}"#,
        ] {
            let Command::Game(order) = parse_message(text).unwrap() else {
                panic!("{text} is not a squad command");
            };
            assert_eq!(
                order.packet().unwrap(),
                b"@ <game.player.red> 0\nsquad name alpha do attack robot 7 formation wedge\n"
            );
        }
        for (bad, says) in [
            (
                r#"{"t":"squad","team":"red","squad":"alpha","do":"fly"}"#,
                "unknown squad command",
            ),
            (
                r#"{"t":"squad","team":"red","do":"stop"}"#,
                "missing field `squad`",
            ),
            (
                r#"{"t":"squad","team":"red","squad":"a","do":"attack","robot":-7}"#,
                "cannot read",
            ),
            (
                r#"{"t":"squad","team":"red","squad":"a","do":"goto","x":1e999,"y":0}"#,
                "cannot read",
            ),
            (
                r#"{"t":"squad","team":"red","squad":"a","do":"goto","x":"1","y":0}"#,
                "cannot read",
            ),
            (
                r#"{"t":"squad","team":"../x","squad":"a","do":"stop"}"#,
                "is not a name",
            ),
            (r#"{"type":"squad","t":"explode"}"#, "cannot read"),
        ] {
            let e = parse_message(bad).unwrap_err();
            assert!(e.message.contains(says), "{bad}: {}", e.message);
        }
    }

    #[test]
    fn arbitrary_bytes_and_mangled_json_are_refused_never_a_panic() {
        let seed = r#"{"t":"squad","team":"red","squad":"alpha","do":"goto","x":12.5,"y":-3,"robot":7,"flag":"blue","formation":"wedge"}"#;
        let alphabet = br#"{}[]":,.-+eE0123456789 tnulrsqadgoxyfbw"#;
        let mut state = 99u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as usize
        };
        for _ in 0..20_000 {
            let mut bytes = seed.as_bytes().to_vec();
            for _ in 0..(1 + next() % 8) {
                let at = next() % bytes.len().max(1);
                match next() % 3 {
                    0 if !bytes.is_empty() => bytes[at] = alphabet[next() % alphabet.len()],
                    1 if !bytes.is_empty() => {
                        bytes.remove(at);
                    }
                    _ => bytes.insert(at.min(bytes.len()), alphabet[next() % alphabet.len()]),
                }
            }
            let text = String::from_utf8_lossy(&bytes);
            let _ = kind_of(&text);
            if let Ok(Command::Game(o)) = parse_message(&text) {
                o.packet().expect("a checked order always makes a packet");
            }
        }
    }
}
