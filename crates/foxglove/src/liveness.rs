//! Whether a page or a viewer is still there: WebSocket pings with a deadline.
//!
//! Here, below the monitor, because both of its WebSockets use it: a Foxglove viewer's (this
//! crate's [`run`](crate::run)) and a monitor page's (colony-monitor's `server::page`).
//!
//! A connection's holds last as long as the connection (the monitor's override), so a
//! peer that froze with its connection open (a hung tab, a viewer stopped in a debugger, a
//! script that stopped reading) would otherwise hold its robots, and with "take control of
//! all" the hub's minimum priority, for as long as the operating system keeps the connection.
//! Each connection is therefore pinged, and dropped, letting go what it held, when
//!
//! - a ping goes unanswered for [`Liveness::deadline`] (a peer that reads nothing never sees
//!   the ping), or
//! - one message cannot be handed to the connection within the same deadline (a peer that
//!   stopped reading, once the kernel's buffers are full: nothing else would ever end the
//!   send).
//!
//! Only the pong of the ping in flight counts, with a payload drawn at random: a peer that
//! writes but never reads cannot keep itself alive with pongs of its own. A browser answers
//! pings itself, whether or not the page's script is running, as long as it reads the socket.

use std::time::{Duration, Instant};

use axum::extract::ws::{Message, WebSocket};

/// How often pages and viewers are pinged and how long they have to answer: the bound on how
/// long a frozen peer keeps what it holds (about `ping_every + deadline`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Liveness {
    /// A ping goes out this long after the last one was answered.
    pub ping_every: Duration,
    /// A ping unanswered, or a message not taken by the connection, for this long drops it.
    pub deadline: Duration,
}

impl Default for Liveness {
    /// Ping every 2 s, 5 s to answer: a slow Wi-Fi link answers well within that, and a frozen
    /// peer lets go within about 7 s.
    fn default() -> Self {
        Liveness {
            ping_every: Duration::from_secs(2),
            deadline: Duration::from_secs(5),
        }
    }
}

/// Why a connection was found dead.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dead {
    /// A ping went unanswered past the deadline.
    Unanswered,
    /// A message could not be sent within the deadline.
    Stuck,
    /// The connection failed or was closed under a send.
    Closed,
}

impl Dead {
    /// Whether the peer went quiet (worth a line in the log), rather than away.
    pub fn frozen(self) -> bool {
        self != Dead::Closed
    }

    /// Why, as a line for the log.
    pub fn as_str(self) -> &'static str {
        match self {
            Dead::Unanswered => "it did not answer a ping in time",
            Dead::Stuck => "it took no message in time",
            Dead::Closed => "its connection failed",
        }
    }
}

/// Why a connection's loop ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// The peer closed it, or the monitor is stopping.
    Closed,
    /// The peer was found dead.
    Dead(Dead),
}

impl From<Dead> for End {
    fn from(d: Dead) -> End {
        End::Dead(d)
    }
}

impl End {
    /// A line for the log when the peer froze, rather than went away.
    pub fn frozen(self) -> Option<&'static str> {
        match self {
            End::Dead(d) if d.frozen() => Some(d.as_str()),
            _ => None,
        }
    }
}

/// Frames taken in at most, without waiting, before a peer is judged (see [`ready`]).
pub const MAX_READY: usize = 256;

/// One connection's pings: when the next one is due, and the one in flight.
#[derive(Debug)]
pub struct Pinger {
    liveness: Liveness,
    /// The ping in flight: its payload and when it went.
    waiting: Option<([u8; 8], Instant)>,
    next_ping: Instant,
}

impl Pinger {
    /// A connection's pings from `now`, the first due `liveness.ping_every` later.
    pub fn new(liveness: Liveness, now: Instant) -> Pinger {
        // Kept where `Instant` arithmetic cannot overflow and a deadline can be met at all.
        let bound = |d: Duration| d.clamp(Duration::from_millis(1), Duration::from_secs(86_400));
        let liveness = Liveness {
            ping_every: bound(liveness.ping_every),
            deadline: bound(liveness.deadline),
        };
        Pinger {
            liveness,
            waiting: None,
            next_ping: now + liveness.ping_every,
        }
    }

    /// When [`on_due`](Self::on_due) has something to do.
    pub fn due(&self) -> Instant {
        match self.waiting {
            Some((_, sent)) => sent + self.liveness.deadline,
            None => self.next_ping,
        }
    }

    /// Time passed to `now`: the payload of a ping to send, nothing yet, or the peer is dead.
    pub fn on_due(&mut self, now: Instant) -> Result<Option<[u8; 8]>, Dead> {
        match self.waiting {
            Some((_, sent)) if now >= sent + self.liveness.deadline => Err(Dead::Unanswered),
            Some(_) => Ok(None),
            None if now >= self.next_ping => {
                let payload = rand::random::<u64>().to_le_bytes();
                self.waiting = Some((payload, now));
                Ok(Some(payload))
            }
            None => Ok(None),
        }
    }

    /// A pong came at `now`: the next ping is due a while after it, if it answers ours.
    pub fn on_pong(&mut self, payload: &[u8], now: Instant) {
        if self.waiting.is_some_and(|(p, _)| p[..] == *payload) {
            self.waiting = None;
            self.next_ping = now + self.liveness.ping_every;
        }
    }

    /// Whether the ping in flight is past its deadline at `now`.
    pub fn overdue(&self, now: Instant) -> bool {
        self.waiting
            .is_some_and(|(_, sent)| now >= sent + self.liveness.deadline)
    }

    /// Sleeps until [`due`](Self::due), holding no borrow of the pinger.
    pub fn sleep(&self) -> tokio::time::Sleep {
        tokio::time::sleep_until(tokio::time::Instant::from_std(self.due()))
    }

    /// The bound on one send.
    pub fn deadline(&self) -> Duration {
        self.liveness.deadline
    }
}

/// Sends `msg`, giving up after `within`: a peer that stopped reading leaves a send waiting for
/// room in its buffers forever.
pub async fn send_within(
    socket: &mut WebSocket,
    msg: Message,
    within: Duration,
) -> Result<(), Dead> {
    match tokio::time::timeout(within, socket.send(msg)).await {
        Ok(Ok(())) => Ok(()),
        Ok(Err(_)) => Err(Dead::Closed),
        Err(_) => Err(Dead::Stuck),
    }
}

/// A frame the peer has sent already, if one is there (`Some(None)`: the connection ended),
/// without waiting. A connection's loop may have been busy (a long send) while the peer's pong
/// came; what came is taken in before the peer is judged overdue, so a slow loop does not drop
/// a live peer.
pub async fn ready(socket: &mut WebSocket) -> Option<Option<Result<Message, axum::Error>>> {
    // A zero timeout still polls the receive once (tokio polls the future before the timer).
    tokio::time::timeout(Duration::ZERO, socket.recv())
        .await
        .ok()
}

/// Sends the ping that is due at `now`, if one is, or says the peer is dead. Called once
/// [`Pinger::sleep`] is over, from a branch's body rather than inside a `select!`, so a ping is
/// never half sent when another branch wins.
pub async fn ping_if_due(pinger: &mut Pinger, socket: &mut WebSocket) -> Result<(), Dead> {
    if let Some(payload) = pinger.on_due(Instant::now())? {
        let within = pinger.deadline();
        send_within(socket, Message::Ping(payload.to_vec().into()), within).await?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(t0: Instant, ms: u64) -> Instant {
        t0 + Duration::from_millis(ms)
    }

    const L: Liveness = Liveness {
        ping_every: Duration::from_millis(100),
        deadline: Duration::from_millis(300),
    };

    #[test]
    fn an_answered_ping_keeps_the_peer_and_the_next_follows_the_answer() {
        let t0 = Instant::now();
        let mut p = Pinger::new(L, t0);
        assert_eq!(p.due(), ms(t0, 100));
        assert_eq!(p.on_due(ms(t0, 50)), Ok(None));
        let payload = p.on_due(ms(t0, 100)).unwrap().expect("a ping");
        assert_eq!(p.due(), ms(t0, 400));
        assert_eq!(p.on_due(ms(t0, 200)), Ok(None), "no second ping in flight");
        p.on_pong(&payload, ms(t0, 250));
        assert_eq!(p.due(), ms(t0, 350));
        assert_eq!(p.on_due(ms(t0, 1000)).map(|o| o.is_some()), Ok(true));
    }

    #[test]
    fn an_unanswered_ping_or_a_pong_of_the_peers_own_is_death_at_the_deadline() {
        let t0 = Instant::now();
        let mut p = Pinger::new(L, t0);
        let payload = p.on_due(ms(t0, 100)).unwrap().expect("a ping");
        // Unsolicited pongs, or one of another payload, prove nothing.
        p.on_pong(b"", ms(t0, 150));
        let mut other = payload;
        other[0] ^= 1;
        p.on_pong(&other, ms(t0, 160));
        assert_eq!(p.on_due(ms(t0, 399)), Ok(None));
        assert_eq!(p.on_due(ms(t0, 400)), Err(Dead::Unanswered));
        // A late pong after the deadline was found does not matter: the caller has dropped it.
    }

    #[test]
    fn each_ping_has_its_own_payload() {
        let t0 = Instant::now();
        let mut p = Pinger::new(L, t0);
        let a = p.on_due(ms(t0, 100)).unwrap().unwrap();
        p.on_pong(&a, ms(t0, 110));
        let b = p.on_due(ms(t0, 210)).unwrap().unwrap();
        assert_ne!(a, b);
        p.on_pong(&a, ms(t0, 220));
        assert_eq!(p.on_due(ms(t0, 510)), Err(Dead::Unanswered), "an old pong");
    }

    #[test]
    fn any_setting_is_taken_without_overflow() {
        let t0 = Instant::now();
        let mut p = Pinger::new(
            Liveness {
                ping_every: Duration::MAX,
                deadline: Duration::ZERO,
            },
            t0,
        );
        assert_eq!(p.on_due(t0), Ok(None));
        assert!(p.deadline() > Duration::ZERO);
    }
}
