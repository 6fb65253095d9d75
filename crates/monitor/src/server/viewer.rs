//! A Foxglove viewer's WebSocket: the endpoint ([`colony_foxglove`]) run on it, and the
//! monitor's side of their seam, [`Viewer`]: what a viewer publishes is read as its page's own
//! override commands, with the page's parser and limits, and carried out by the hub link for
//! this connection exactly as a page's, let go when the connection ends.

use std::sync::atomic::Ordering;
use std::sync::mpsc::{Sender, SyncSender};

use axum::extract::ws::WebSocketUpgrade;
use axum::extract::State;
use axum::response::Response;
use colony_foxglove::session::{Request, OVERRIDE_TOPIC};
use colony_foxglove::{Link, Operator};

use super::App;
use crate::protocol::parse_message;
use crate::request::Envelope;
use crate::state::{Command, PageId, MAX_HELD};

/// The Foxglove WebSocket: `foxglove.websocket.v1` (see [`colony_foxglove`]).
pub(super) async fn foxglove_ws(upgrade: WebSocketUpgrade, State(app): State<App>) -> Response {
    use colony_foxglove::{protocol::SUBPROTOCOL, MAX_VIEWER_MESSAGE};
    upgrade
        .protocols([SUBPROTOCOL])
        .max_message_size(MAX_VIEWER_MESSAGE)
        .max_frame_size(MAX_VIEWER_MESSAGE)
        .on_upgrade(move |socket| {
            let page = PageId(app.pages.fetch_add(1, Ordering::Relaxed));
            let link = Link {
                operator: Viewer {
                    requests: app.requests.clone(),
                    closed: app.closed.clone(),
                    page,
                },
                page: page.0,
                shutdown: app.shutdown.clone(),
                liveness: app.liveness,
            };
            colony_foxglove::run(socket, app.viewers.clone(), link)
        })
}

/// One viewer's connection as the monitor sees it: a page, whose override requests go to the
/// hub link and whose holds are let go when it has gone.
struct Viewer {
    /// The hub link's request queue.
    requests: SyncSender<Envelope>,
    /// Where a closed connection's page id goes.
    closed: Sender<PageId>,
    page: PageId,
}

impl Operator for Viewer {
    type Command = Command;

    fn read(&self, request: Request) -> Result<Vec<Command>, String> {
        read(request)
    }

    async fn carry_out(&self, command: Command) -> Result<String, String> {
        crate::request::carry_out(&self.requests, self.page, command).await
    }

    fn gone(&self) {
        let _ = self.closed.send(self.page);
    }
}

/// A viewer's override message read as the page's commands, or why not.
fn read(request: Request) -> Result<Vec<Command>, String> {
    match request {
        Request::Override(text) => {
            let command = parse_message(&text).map_err(|e| e.message)?;
            match command {
                Command::Take(_)
                | Command::TakeAll
                | Command::Release(_)
                | Command::ReleaseAll
                | Command::Drive { .. }
                | Command::Goto { .. } => Ok(vec![command]),
                _ => Err(format!(
                    "`{OVERRIDE_TOPIC}` takes the override's requests only (take, take_all, \
                     release, release_all, drive, goto)"
                )),
            }
        }
        Request::Radio(commands) => {
            if commands.len() > MAX_HELD {
                return Err(format!("at most {MAX_HELD} robots can be held"));
            }
            let mut out = vec![Command::Take(commands.iter().map(|c| c.robot).collect())];
            out.extend(commands.iter().map(|c| Command::Drive {
                ids: Some(vec![c.robot]),
                forward: c.wheels.forward,
                turn: c.wheels.turn,
            }));
            Ok(out)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_foxglove::protocol::Channel;
    use colony_foxglove::session::{Out, Session};

    fn channel(id: u32, topic: &str) -> Channel {
        Channel {
            id,
            topic: topic.into(),
            encoding: "json".into(),
            schema_name: topic.into(),
            schema: "{}".into(),
            schema_encoding: "jsonschema".into(),
        }
    }

    fn texts(s: &mut Session<u32>) -> Vec<serde_json::Value> {
        let mut out = Vec::new();
        while let Some(Out::Text(t)) = s.poll_transmit() {
            out.push(serde_json::from_str(&t).unwrap());
        }
        out
    }

    fn session() -> Session<u32> {
        let mut s = Session::new("colony monitor", "1");
        s.on_channels(&[channel(1, "vision"), channel(2, "debug")]);
        s
    }

    /// A viewer's binary frame as the endpoint's loop takes it in: its requests read here.
    fn handle_binary(s: &mut Session<u32>, frame: &[u8]) -> Vec<Command> {
        let requests = s.handle_binary(frame);
        s.read(requests, read)
    }

    #[test]
    fn the_override_topic_becomes_the_pages_override_commands() {
        let mut s = session();
        texts(&mut s);
        s.handle_text(
            r#"{"op":"advertise","channels":[{"id":4,"topic":"/colony/override","encoding":"json","schemaName":"colony.Override"}]}"#,
        );
        let mut frame = vec![1, 4, 0, 0, 0];
        frame.extend_from_slice(br#"{"t":"take","ids":[3]}"#);
        assert_eq!(handle_binary(&mut s, &frame), [Command::Take(vec![3])]);
        let mut frame = vec![1, 4, 0, 0, 0];
        frame.extend_from_slice(br#"{"t":"drive","ids":[3],"forward":0.5,"turn":0}"#);
        assert_eq!(
            handle_binary(&mut s, &frame),
            [Command::Drive {
                ids: Some(vec![3]),
                forward: 0.5,
                turn: 0.0
            }]
        );
        // Forging a packet is the page's, not the override's.
        let mut frame = vec![1, 4, 0, 0, 0];
        frame.extend_from_slice(
            br#"{"t":"publish","text":"@ <radio> 99\ncmd id 0 forward 1 turn 0\n"}"#,
        );
        assert!(handle_binary(&mut s, &frame).is_empty());
        let t = texts(&mut s);
        assert!(
            t[0]["message"].as_str().unwrap().contains("override"),
            "{t:?}"
        );
    }

    #[test]
    fn a_radio_packet_takes_and_drives_its_robots() {
        let mut s = session();
        texts(&mut s);
        s.handle_text(
            r#"{"op":"advertise","channels":[{"id":1,"topic":"radio","encoding":"json"}]}"#,
        );
        let mut frame = vec![1, 1, 0, 0, 0];
        frame.extend_from_slice(br#"{"packet":"@ <radio> 10\ncmd id 2 forward 2 turn -0.5\n"}"#);
        assert_eq!(
            handle_binary(&mut s, &frame),
            [
                Command::Take(vec![2]),
                Command::Drive {
                    ids: Some(vec![2]),
                    forward: 1.0,
                    turn: -0.5
                }
            ]
        );
        for junk in [
            &b"{\"packet\":\"@ <vision> 0\\nx\\n\"}"[..],
            b"\xff\xfe",
            b"[]",
        ] {
            let mut frame = vec![1, 1, 0, 0, 0];
            frame.extend_from_slice(junk);
            assert!(handle_binary(&mut s, &frame).is_empty());
        }
        assert_eq!(texts(&mut s).len(), 3);
    }
}
