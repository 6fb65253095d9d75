//! One viewer's connection: the loop that runs a [`Session`] on a WebSocket, fed by the
//! [`Viewers`] end of the feed, pinged ([`crate::liveness`]), with what the viewer publishes
//! handed to the application's [`Operator`].

use std::future::Future;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::{Message, WebSocket};
use tokio::sync::{broadcast, watch};

use crate::feed::{Counters, Event, Payload, Viewers, FEED_CAPACITY};
use crate::liveness::{ping_if_due, ready, send_within, End, Pinger, MAX_READY};
use crate::protocol::{self, Level};
use crate::session::{Out, Request, Session};
use crate::{MAX_CHANNELS, MAX_VIEWERS, SINGLE_SUBJECT_RESERVE};

/// What a viewer's override means, and who carries it out: the application the endpoint
/// serves implements it (the monitor: its page's commands, carried out by its hub link for
/// this connection), one per connection, so the endpoint needs none of its types.
pub trait Operator: Send + Sync + 'static {
    /// One command of the operator's override.
    type Command: Send;

    /// Reads what the viewer published as commands, or says why not (told to the viewer).
    fn read(&self, request: Request) -> Result<Vec<Self::Command>, String>;

    /// Carries out one command for this connection; answers what was done, or why not (told
    /// to the viewer).
    fn carry_out(
        &self,
        command: Self::Command,
    ) -> impl Future<Output = Result<String, String>> + Send;

    /// The connection has ended, however it ended: what it held is let go.
    fn gone(&self);
}

/// What a connection needs from the web server.
pub struct Link<O> {
    /// What the viewer's override means, and who carries it out.
    pub operator: O,
    /// This connection's number among the server's pages, for the log.
    pub page: u64,
    /// Whether the monitor is stopping.
    pub shutdown: watch::Receiver<bool>,
    /// When a viewer that stopped answering is dropped.
    pub liveness: crate::Liveness,
}

/// Tells the operator the connection has gone, however it ends.
struct Gone<O: Operator> {
    operator: O,
    counters: Arc<Counters>,
    /// Whether this connection is subscribed to the arena's scene, and the battlefield's.
    scenes: [bool; 2],
}

impl<O: Operator> Gone<O> {
    /// Counts this connection's scene subscriptions as `now`.
    fn scenes(&mut self, now: [bool; 2]) {
        let subscribers = [
            &self.counters.arena_subscribers,
            &self.counters.battlefield_subscribers,
        ];
        for ((was, now), count) in self.scenes.iter_mut().zip(now).zip(subscribers) {
            match (*was, now) {
                (false, true) => count.fetch_add(1, Ordering::Relaxed),
                (true, false) => count.fetch_sub(1, Ordering::Relaxed),
                _ => 0,
            };
            *was = now;
        }
    }
}

impl<O: Operator> Drop for Gone<O> {
    fn drop(&mut self) {
        self.operator.gone();
        self.counters.viewers.fetch_sub(1, Ordering::Relaxed);
        self.scenes([false, false]);
    }
}

/// Runs one viewer's connection until it closes or the monitor stops.
pub async fn run<O: Operator>(mut socket: WebSocket, viewers: Viewers, link: Link<O>) {
    let Link {
        operator,
        page,
        mut shutdown,
        liveness,
    } = link;
    if viewers.counters.viewers.fetch_add(1, Ordering::Relaxed) >= MAX_VIEWERS {
        viewers.counters.viewers.fetch_sub(1, Ordering::Relaxed);
        viewers
            .counters
            .refused_viewers
            .fetch_add(1, Ordering::Relaxed);
        tracing::warn!(
            refused = viewers.refused(),
            "a Foxglove viewer was refused: {MAX_VIEWERS} are connected"
        );
        operator.gone();
        let close = Message::Close(Some(axum::extract::ws::CloseFrame {
            code: 1013,
            reason: format!("too many Foxglove viewers: at most {MAX_VIEWERS} at once").into(),
        }));
        let within = Pinger::new(liveness, std::time::Instant::now()).deadline();
        let _ = send_within(&mut socket, close, within).await;
        return;
    }
    let mut gone = Gone {
        operator,
        counters: viewers.counters.clone(),
        scenes: [false, false],
    };
    let mut rx = viewers.tx.subscribe();
    let mut s: Session<Payload> = Session::new("colony monitor", &viewers.session_id);
    // Each scene is a whole frame: a slow viewer gets the newest, older ones dropped, counted.
    for c in viewers.scenes {
        s.newest_only(c);
    }
    s.on_channels(&viewers.channels());
    let mut tick = tokio::time::interval(Duration::from_millis(500));
    let mut reported = 0;
    let mut refused_told = 0;
    let mut pinger = Pinger::new(liveness, std::time::Instant::now());
    let within = pinger.deadline();
    let mut end = None;
    'conn: loop {
        // Take in what the feed has, then send what waits, newest first per channel.
        loop {
            drain(&mut rx, &mut s, &viewers);
            let Some(out) = s.poll_transmit() else { break };
            let msg = match out {
                Out::Text(t) => Message::Text(t.into()),
                Out::Message {
                    subscription,
                    receive_ns,
                    payload,
                } => Message::Binary(
                    protocol::message_data(subscription, receive_ns, &payload.to_json()).into(),
                ),
            };
            if let Err(e) = send_within(&mut socket, msg, within).await {
                end = Some(End::from(e));
                break 'conn;
            }
        }
        if s.dropped() > reported {
            viewers
                .counters
                .dropped
                .fetch_add(s.dropped() - reported, Ordering::Relaxed);
            reported = s.dropped();
        }
        tokio::select! {
            incoming = socket.recv() => {
                let flow = take_in(incoming, &mut s, &viewers, &mut gone, &mut pinger);
                if let Err(e) = flow.await {
                    end = Some(e);
                    break;
                }
            }
            event = rx.recv() => match event {
                Ok(e) => on_event(e, &mut s, &viewers),
                Err(broadcast::error::RecvError::Lagged(n)) => lagged(n, &mut s, &viewers),
                Err(broadcast::error::RecvError::Closed) => break,
            },
            _ = tick.tick() => {
                s.poll_timeout(std::time::Instant::now());
                let refused = viewers.not_advertised();
                if refused > refused_told {
                    refused_told = refused;
                    s.status(Level::Warning, &not_advertised_status(refused));
                }
            }
            _ = pinger.sleep() => {
                let mut flow = Ok(());
                if pinger.overdue(std::time::Instant::now()) {
                    for _ in 0..MAX_READY {
                        let Some(incoming) = ready(&mut socket).await else { break };
                        flow = take_in(incoming, &mut s, &viewers, &mut gone, &mut pinger)
                            .await;
                        if flow.is_err() {
                            break;
                        }
                    }
                }
                if flow.is_ok() {
                    flow = ping_if_due(&mut pinger, &mut socket).await.map_err(End::from);
                }
                if let Err(e) = flow {
                    end = Some(e);
                    break;
                }
            }
            changed = shutdown.changed() => {
                if changed.is_err() || *shutdown.borrow_and_update() {
                    let _ = send_within(&mut socket, Message::Close(None), within).await;
                    break;
                }
            }
        }
    }
    if let Some(why) = end.and_then(End::frozen) {
        tracing::info!(
            page,
            "a Foxglove viewer was dropped because {why}: what it held is let go"
        );
    }
    if s.dropped() > 0 {
        tracing::info!(
            page,
            dropped = s.dropped(),
            "a Foxglove viewer left; it was sent the newest of each channel and missed the rest"
        );
    }
}

/// Takes in one frame from a viewer: its requests are handled (the override's read and carried
/// out by the operator), a pong goes to `pinger`.
async fn take_in<O: Operator>(
    incoming: Option<Result<Message, axum::Error>>,
    s: &mut Session<Payload>,
    viewers: &Viewers,
    gone: &mut Gone<O>,
    pinger: &mut Pinger,
) -> Result<(), End> {
    let requests = match incoming {
        None | Some(Err(_)) | Some(Ok(Message::Close(_))) => return Err(End::Closed),
        Some(Ok(Message::Text(t))) => {
            let before = subscribed_latched(s, viewers);
            let requests = s.handle_text(t.as_str());
            let [arena, field, terrain] = viewers.scenes.map(|c| s.is_subscribed(c));
            gone.scenes([arena, field || terrain]);
            for (channel, ns, payload) in viewers.latched() {
                if s.is_subscribed(channel) && !before.contains(&channel) {
                    s.on_message(channel, ns, payload);
                }
            }
            requests
        }
        Some(Ok(Message::Binary(b))) => s.handle_binary(&b),
        Some(Ok(Message::Pong(p))) => {
            pinger.on_pong(&p, std::time::Instant::now());
            return Ok(());
        }
        Some(Ok(_)) => return Ok(()),
    };
    let operator = &gone.operator;
    for c in s.read(requests, |r| operator.read(r)) {
        if let Err(e) = operator.carry_out(c).await {
            s.status(Level::Error, &e);
        }
    }
    Ok(())
}

fn subscribed_latched(s: &Session<Payload>, viewers: &Viewers) -> Vec<u32> {
    viewers
        .latched()
        .into_iter()
        .map(|(c, _, _)| c)
        .filter(|c| s.is_subscribed(*c))
        .collect()
}

fn drain(rx: &mut broadcast::Receiver<Event>, s: &mut Session<Payload>, viewers: &Viewers) {
    // Bounded: at most what the broadcast holds.
    for _ in 0..FEED_CAPACITY {
        match rx.try_recv() {
            Ok(e) => on_event(e, s, viewers),
            Err(broadcast::error::TryRecvError::Lagged(n)) => lagged(n, s, viewers),
            Err(_) => return,
        }
    }
}

/// The viewer fell behind the feed by `n` events: channels announced among them are offered
/// now, and the missed messages are counted only if it subscribed to anything (a viewer
/// subscribed to nothing missed nothing it asked for).
fn lagged(n: u64, s: &mut Session<Payload>, viewers: &Viewers) {
    s.on_channels(&viewers.channels());
    if s.has_subscriptions() {
        s.on_missed(n);
    }
}

/// What a viewer is told when topics found no room in the channel list.
pub(crate) fn not_advertised_status(n: u64) -> String {
    format!(
        "the channel list is full ({MAX_CHANNELS} channels, {SINGLE_SUBJECT_RESERVE} of them \
         kept for single subjects): {n} packets of further topics were not advertised"
    )
}

fn on_event(e: Event, s: &mut Session<Payload>, viewers: &Viewers) {
    match e {
        Event::Channels => s.on_channels(&viewers.channels()),
        Event::Message {
            channel,
            receive_ns,
            payload,
        } => s.on_message(channel, receive_ns, payload),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::feed::feed;
    use colony_wire::Packet;

    fn packet(text: &str) -> Packet<'_> {
        Packet::parse(text.as_bytes()).unwrap()
    }

    #[test]
    fn a_lagged_viewer_hears_of_new_channels_and_is_not_blamed_for_what_it_never_asked() {
        let (mut feed, viewers) = feed();
        let mut s: Session<Payload> = Session::new("t", "1");
        s.on_channels(&viewers.channels());
        while s.poll_transmit().is_some() {}
        feed.on_packet(&packet("@ <vision> 0\nx\n"), 0);
        lagged(7, &mut s, &viewers);
        assert_eq!(s.dropped(), 0);
        let mut advertised = false;
        while let Some(out) = s.poll_transmit() {
            if let Out::Text(t) = out {
                advertised |= t.contains("\"advertise\"") && t.contains("\"vision\"");
            }
        }
        assert!(advertised);
        // Subscribed to something: what it missed is counted.
        let id = viewers.channels()[0].id;
        s.handle_text(&format!(
            r#"{{"op":"subscribe","subscriptions":[{{"id":1,"channelId":{id}}}]}}"#
        ));
        lagged(3, &mut s, &viewers);
        assert_eq!(s.dropped(), 3);
    }
}
