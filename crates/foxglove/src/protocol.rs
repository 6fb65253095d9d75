//! The `foxglove.websocket.v1` messages colony's endpoint speaks, read and written with no
//! socket: what a viewer sends is untrusted input, read into [`ClientOp`] or refused with a
//! [`ProtocolError`] whose message goes back in a `status`; what the server sends is written by
//! the functions below.
//!
//! The specification is foxglove/ws-protocol's `docs/spec.md`. colony implements the server's
//! side of `serverInfo`, `status`, `advertise`, `unadvertise` and binary message data, and the
//! client's `subscribe`, `unsubscribe`, and (capability `clientPublish`) client `advertise`,
//! `unadvertise` and binary client message data. Parameters, services, the connection graph,
//! assets and time are not offered, and asking for them is answered with a `status`.

use serde::{Deserialize, Serialize};

/// The WebSocket subprotocol this endpoint speaks.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";
/// Opcode of a binary message-data frame (server to client) and of a client message-data frame.
pub const OP_MESSAGE_DATA: u8 = 1;
/// Subscriptions (or client channels) one request may name, at most.
pub const MAX_PER_REQUEST: usize = 1024;
/// A topic, encoding or schema name longer than this is refused.
const MAX_NAME: usize = 256;

/// A `status` message's level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// For the viewer's information.
    Info = 0,
    /// Something the viewer should know went wrong, such as data it missed.
    Warning = 1,
    /// A request refused.
    Error = 2,
}

/// A channel the server offers: one hub topic, or one of colony's scene topics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Channel {
    /// The server's id for it.
    pub id: u32,
    /// Its topic (`vision`, `game.sense.3`, `/colony/arena`).
    pub topic: String,
    /// How each message is encoded (`json`).
    pub encoding: String,
    /// The schema's name.
    #[serde(rename = "schemaName")]
    pub schema_name: String,
    /// The schema itself, as text.
    pub schema: String,
    /// How the schema is written (`jsonschema`).
    #[serde(rename = "schemaEncoding")]
    pub schema_encoding: String,
}

/// A channel a viewer advertises to publish on.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct ClientChannel {
    /// The viewer's id for it.
    pub id: u32,
    /// Its topic.
    pub topic: String,
    /// How its messages are encoded.
    pub encoding: String,
    /// The schema's name, if given.
    #[serde(rename = "schemaName", default)]
    pub schema_name: Option<String>,
}

/// One subscription: the viewer's id for it and the server's channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
pub struct Subscription {
    /// The viewer's id.
    pub id: u32,
    /// The channel.
    #[serde(rename = "channelId")]
    pub channel_id: u32,
}

/// What a viewer asked, already read.
#[derive(Debug, Clone, PartialEq)]
pub enum ClientOp {
    /// Start streaming these channels.
    Subscribe(Vec<Subscription>),
    /// Stop these subscriptions.
    Unsubscribe(Vec<u32>),
    /// The viewer will publish on these channels.
    Advertise(Vec<ClientChannel>),
    /// The viewer no longer publishes on these channels.
    Unadvertise(Vec<u32>),
    /// A message on one of the viewer's channels (binary opcode 1).
    MessageData {
        /// The viewer's channel.
        channel: u32,
        /// The payload, as sent.
        payload: Vec<u8>,
    },
}

/// Why a viewer's message was refused: the text of the `status` it is answered with.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ProtocolError {
    /// Not a JSON object with a string `op`, or fields of the wrong shape.
    #[error("cannot read the message: {0}")]
    Malformed(String),
    /// An `op` this server does not implement (or does not know).
    #[error("`{0}` is not supported by this server (capabilities: clientPublish)")]
    Unsupported(String),
    /// A binary frame with an opcode other than client message data, or too short.
    #[error("binary message: {0}")]
    Binary(String),
}

#[derive(Deserialize)]
struct Op<'a> {
    #[serde(borrow)]
    op: std::borrow::Cow<'a, str>,
}

#[derive(Deserialize)]
struct SubscribeMsg {
    subscriptions: Vec<Subscription>,
}

#[derive(Deserialize)]
struct UnsubscribeMsg {
    #[serde(rename = "subscriptionIds")]
    subscription_ids: Vec<u32>,
}

#[derive(Deserialize)]
struct AdvertiseMsg {
    channels: Vec<ClientChannel>,
}

#[derive(Deserialize)]
struct UnadvertiseMsg {
    #[serde(rename = "channelIds")]
    channel_ids: Vec<u32>,
}

/// Reads one text frame from a viewer.
pub fn parse_text(text: &str) -> Result<ClientOp, ProtocolError> {
    let malformed = |e: serde_json::Error| ProtocolError::Malformed(e.to_string());
    let op: Op<'_> = serde_json::from_str(text).map_err(malformed)?;
    let too_many = |n: usize| {
        if n > MAX_PER_REQUEST {
            Err(ProtocolError::Malformed(format!(
                "{n} entries in one request; at most {MAX_PER_REQUEST}"
            )))
        } else {
            Ok(())
        }
    };
    match op.op.as_ref() {
        "subscribe" => {
            let m: SubscribeMsg = serde_json::from_str(text).map_err(malformed)?;
            too_many(m.subscriptions.len())?;
            Ok(ClientOp::Subscribe(m.subscriptions))
        }
        "unsubscribe" => {
            let m: UnsubscribeMsg = serde_json::from_str(text).map_err(malformed)?;
            too_many(m.subscription_ids.len())?;
            Ok(ClientOp::Unsubscribe(m.subscription_ids))
        }
        "advertise" => {
            let m: AdvertiseMsg = serde_json::from_str(text).map_err(malformed)?;
            too_many(m.channels.len())?;
            for c in &m.channels {
                let long = [Some(&c.topic), Some(&c.encoding), c.schema_name.as_ref()]
                    .into_iter()
                    .flatten()
                    .any(|s| s.len() > MAX_NAME);
                if long {
                    return Err(ProtocolError::Malformed(format!(
                        "a topic, encoding or schema name over {MAX_NAME} bytes"
                    )));
                }
            }
            Ok(ClientOp::Advertise(m.channels))
        }
        "unadvertise" => {
            let m: UnadvertiseMsg = serde_json::from_str(text).map_err(malformed)?;
            too_many(m.channel_ids.len())?;
            Ok(ClientOp::Unadvertise(m.channel_ids))
        }
        other => Err(ProtocolError::Unsupported(printable(other))),
    }
}

/// Reads one binary frame from a viewer: only client message data (opcode 1) is known.
pub fn parse_binary(frame: &[u8]) -> Result<ClientOp, ProtocolError> {
    match frame.first() {
        Some(&OP_MESSAGE_DATA) if frame.len() >= 5 => {
            let channel = u32::from_le_bytes([frame[1], frame[2], frame[3], frame[4]]);
            Ok(ClientOp::MessageData {
                channel,
                payload: frame[5..].to_vec(),
            })
        }
        Some(&OP_MESSAGE_DATA) => Err(ProtocolError::Binary(format!(
            "client message data needs 5 bytes before its payload; got {}",
            frame.len()
        ))),
        Some(op) => Err(ProtocolError::Binary(format!(
            "opcode {op} is not supported (only 1, client message data)"
        ))),
        None => Err(ProtocolError::Binary("an empty frame".into())),
    }
}

/// A name from the network as it may go in a status message: short, printable ASCII.
fn printable(text: &str) -> String {
    text.chars()
        .take(64)
        .map(|c| if c.is_ascii_graphic() { c } else { '?' })
        .collect()
}

/// The `serverInfo` message: `name`, capability `clientPublish`, client encoding `json`.
pub fn server_info(name: &str, session_id: &str) -> String {
    serde_json::json!({
        "op": "serverInfo",
        "name": name,
        "capabilities": ["clientPublish"],
        "supportedEncodings": ["json"],
        "metadata": {},
        "sessionId": session_id,
    })
    .to_string()
}

/// An `advertise` message for `channels`.
pub fn advertise(channels: &[&Channel]) -> String {
    serde_json::json!({ "op": "advertise", "channels": channels }).to_string()
}

/// An `unadvertise` message for the channels `ids`.
pub fn unadvertise(ids: &[u32]) -> String {
    serde_json::json!({ "op": "unadvertise", "channelIds": ids }).to_string()
}

/// A `status` message.
pub fn status(level: Level, message: &str) -> String {
    serde_json::json!({ "op": "status", "level": level as u8, "message": message }).to_string()
}

/// A binary message-data frame: opcode 1, the subscription id (u32 LE), the receive time in
/// nanoseconds (u64 LE), then the payload.
pub fn message_data(subscription: u32, receive_ns: u64, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(13 + payload.len());
    out.push(OP_MESSAGE_DATA);
    out.extend_from_slice(&subscription.to_le_bytes());
    out.extend_from_slice(&receive_ns.to_le_bytes());
    out.extend_from_slice(payload);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subscribe_and_unsubscribe_are_read_with_their_ids() {
        let op = parse_text(
            r#"{"op":"subscribe","subscriptions":[{"id":0,"channelId":3},{"id":1,"channelId":5}]}"#,
        )
        .unwrap();
        assert_eq!(
            op,
            ClientOp::Subscribe(vec![
                Subscription {
                    id: 0,
                    channel_id: 3
                },
                Subscription {
                    id: 1,
                    channel_id: 5
                }
            ])
        );
        assert_eq!(
            parse_text(r#"{"op":"unsubscribe","subscriptionIds":[0,1]}"#).unwrap(),
            ClientOp::Unsubscribe(vec![0, 1])
        );
    }

    #[test]
    fn a_client_advertisement_is_read() {
        let op = parse_text(
            r#"{"op":"advertise","channels":[{"id":1,"topic":"/colony/override","encoding":"json","schemaName":"colony.Override"}]}"#,
        )
        .unwrap();
        let ClientOp::Advertise(c) = op else {
            panic!("{op:?}")
        };
        assert_eq!(c[0].topic, "/colony/override");
        assert_eq!(c[0].schema_name.as_deref(), Some("colony.Override"));
    }

    #[test]
    fn hostile_text_is_refused_with_a_reason_never_a_panic() {
        for bad in [
            "",
            "null",
            "[]",
            "{",
            r#"{"op":7}"#,
            r#"{"op":"subscribe"}"#,
            r#"{"op":"subscribe","subscriptions":[{"id":-1,"channelId":3}]}"#,
            r#"{"op":"subscribe","subscriptions":[{"id":4294967296,"channelId":3}]}"#,
            r#"{"op":"unsubscribe","subscriptionIds":"x"}"#,
            "\u{0}\u{1}binary junk",
        ] {
            assert!(
                matches!(parse_text(bad), Err(ProtocolError::Malformed(_))),
                "{bad:?}"
            );
        }
        let e = parse_text(r#"{"op":"getParameters","parameterNames":[]}"#).unwrap_err();
        assert!(e.to_string().contains("getParameters"), "{e}");
        let e = parse_text(r#"{"op":"\u0007evil\n"}"#).unwrap_err();
        assert!(e.to_string().contains("?evil?"), "{e}");
        let many: Vec<String> = (0..2000).map(|i| i.to_string()).collect();
        let text = format!(
            r#"{{"op":"unsubscribe","subscriptionIds":[{}]}}"#,
            many.join(",")
        );
        assert!(parse_text(&text).is_err());
        let long = "x".repeat(300);
        let text = format!(
            r#"{{"op":"advertise","channels":[{{"id":1,"topic":"{long}","encoding":"json"}}]}}"#
        );
        assert!(parse_text(&text).is_err());
    }

    #[test]
    fn binary_frames_other_than_client_message_data_are_refused() {
        assert_eq!(
            parse_binary(&[1, 7, 0, 0, 0, b'{', b'}']).unwrap(),
            ClientOp::MessageData {
                channel: 7,
                payload: b"{}".to_vec()
            }
        );
        assert!(parse_binary(&[]).is_err());
        assert!(parse_binary(&[1, 2, 3]).is_err());
        assert!(parse_binary(&[2, 0, 0, 0, 0, 0, 0, 0, 0]).is_err());
    }

    #[test]
    fn message_data_is_laid_out_as_the_specification_says() {
        let frame = message_data(0x0403_0201, 0x0807_0605_0403_0201, b"xy");
        assert_eq!(
            frame,
            [1, 1, 2, 3, 4, 1, 2, 3, 4, 5, 6, 7, 8, b'x', b'y'].to_vec()
        );
    }

    #[test]
    fn server_messages_are_json_with_their_op() {
        let info: serde_json::Value =
            serde_json::from_str(&server_info("colony monitor", "1")).unwrap();
        assert_eq!(info["op"], "serverInfo");
        assert_eq!(info["capabilities"][0], "clientPublish");
        let ch = Channel {
            id: 3,
            topic: "vision".into(),
            encoding: "json".into(),
            schema_name: "colony.vision".into(),
            schema: "{}".into(),
            schema_encoding: "jsonschema".into(),
        };
        let adv: serde_json::Value = serde_json::from_str(&advertise(&[&ch])).unwrap();
        assert_eq!(adv["channels"][0]["schemaName"], "colony.vision");
        assert_eq!(adv["channels"][0]["schemaEncoding"], "jsonschema");
        let st: serde_json::Value = serde_json::from_str(&status(Level::Error, "no")).unwrap();
        assert_eq!(st["level"], 2);
    }
}
