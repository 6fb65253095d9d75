//! A whole match in one process, fast-forwarded: the world, the game server,
//! every robot and the scripted players exchange the same packets they would
//! over the hub, through colony-node's in-memory [`Bus`] (the real sans-IO
//! hub, with no latency) on simulated time, as fast as the machine goes.
//!
//! The world's control step is its timer, so one [`Match::step`] is one run of
//! the bus up to the world's next step: the world steps, and its packets and
//! everything they set off are delivered, in the order they were sent, until
//! nothing is left; then the next step.

use std::collections::{BTreeSet, VecDeque};
use std::sync::Arc;
use std::time::Duration;

use colony_node::{Bus, Node, Time};
use colony_sim::SimError;
use colony_wire::{Packet, Subject};

use crate::bot::Bot;
use crate::logic::{roster, RobotEntry, SetupError};
use crate::map::Battlefield;
use crate::protocol::{self, Event, GameState, EVENT, STATE};
use crate::robot_node::RobotNode;
use crate::rules::{Rules, TeamSetup};
use crate::server::Server;
use crate::world::GameWorld;

/// Why a match can't start.
#[derive(Debug, thiserror::Error)]
pub enum MatchError {
    /// The teams don't fit the rules or the map.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The simulator refused the battlefield.
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// Collects events and the newest state from the bus, for reports and tests.
struct Recorder {
    subs: BTreeSet<Subject>,
    events: Vec<Event>,
    state: Option<GameState>,
}

impl Recorder {
    fn new() -> Recorder {
        Recorder {
            subs: protocol::subjects([STATE, EVENT]),
            events: Vec::new(),
            state: None,
        }
    }
}

/// It only listens.
impl Node for Recorder {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }
    fn handle_packet(&mut self, _now: Time, packet: &Packet<'_>) {
        if packet.has_subject(STATE) {
            if let Ok(s) = GameState::decode(packet) {
                self.state = Some(s);
            }
        } else if let Ok(e) = Event::decode(packet) {
            self.events.push(e);
        }
    }
    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        None
    }
}

/// Packets from outside the match (a player's command), held until the
/// world's next step and sent right after it: the first place on the bus, so
/// they go before the step's own packets and each part hears them after the
/// world has stepped, as a player's command sent between two steps would be.
#[derive(Default)]
struct Outside {
    subs: BTreeSet<Subject>,
    held: VecDeque<Vec<u8>>,
    /// The world's next step, while packets are held.
    due: Option<Time>,
    ready: VecDeque<Vec<u8>>,
}

impl Node for Outside {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }
    fn handle_packet(&mut self, _now: Time, _packet: &Packet<'_>) {}
    fn handle_timeout(&mut self, now: Time) {
        if self.due.is_some_and(|d| d <= now) {
            self.ready.append(&mut self.held);
            self.due = None;
        }
    }
    fn poll_timeout(&self) -> Option<Time> {
        self.due
    }
    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.ready.pop_front()
    }
}

/// A match being played.
pub struct Match {
    outside: Outside,
    world: GameWorld,
    server: Server,
    robots: Vec<RobotNode>,
    bots: Vec<Bot>,
    recorder: Recorder,
    bus: Bus,
}

impl Match {
    /// Sets up a match; `bots` names the teams the scripted player plays.
    pub fn new(
        field: Arc<Battlefield>,
        rules: Rules,
        teams: &[TeamSetup],
        bots: &[&str],
    ) -> Result<Match, MatchError> {
        let entries = roster(&field, &rules, teams)?;
        Ok(Match::with_roster(field, rules, entries, bots)?)
    }

    /// Sets up a match with a roster already made (by [`roster`], its poses perhaps moved
    /// within their cells, as the learning environment does to make its seed matter); `bots`
    /// names the teams the scripted player plays.
    pub fn with_roster(
        field: Arc<Battlefield>,
        rules: Rules,
        entries: Vec<RobotEntry>,
        bots: &[&str],
    ) -> Result<Match, SimError> {
        // No latency: a step and everything it sets off happen at the step's time.
        let mut bus = Bus::new(Duration::ZERO);
        // Every packet is shown to the caller's tap.
        bus.record();
        Ok(Match {
            outside: Outside::default(),
            world: GameWorld::new(&field, &entries)?,
            robots: entries
                .iter()
                .map(|e| RobotNode::new(e.id, e.build.kind))
                .collect(),
            server: Server::new(field, rules, entries),
            bots: bots.iter().map(|t| Bot::new(t)).collect(),
            recorder: Recorder::new(),
            bus,
        })
    }

    /// The robots of the match.
    pub fn roster(&self) -> &[RobotEntry] {
        self.server.roster()
    }

    /// The world.
    pub fn world(&self) -> &GameWorld {
        &self.world
    }

    /// The game server.
    pub fn server(&self) -> &Server {
        &self.server
    }

    /// Puts a packet on the bus (a player's command, say), delivered with the
    /// next step: after the world steps, before the step's own packets.
    pub fn send(&mut self, packet: Vec<u8>) {
        self.outside.held.push_back(packet);
        self.outside.due = self.world.poll_timeout();
    }

    /// One control step of the world and everything it sets off; every
    /// packet is shown to `tap` with the game time (malformed ones are
    /// dropped by the hub unseen, and counted in [`Match::traffic`]).
    pub fn step(&mut self, tap: &mut dyn FnMut(f64, &[u8])) {
        let Some(at) = self.world.poll_timeout() else {
            return;
        };
        let mut nodes: Vec<&mut dyn Node> = Vec::with_capacity(self.robots.len() + 5);
        nodes.push(&mut self.outside);
        nodes.push(&mut self.world);
        nodes.push(&mut self.server);
        for r in &mut self.robots {
            nodes.push(r);
        }
        for b in &mut self.bots {
            nodes.push(b);
        }
        nodes.push(&mut self.recorder);
        self.bus.run_until(&mut nodes, at);
        let time = self.world.time();
        for (_, p) in self.bus.take_recorded() {
            tap(time, &p);
        }
    }

    /// Whether the game is over.
    pub fn is_over(&self) -> bool {
        self.server.referee().is_over()
    }

    /// Steps until the game ends or `max_steps` pass.
    pub fn run(&mut self, max_steps: u64, tap: &mut dyn FnMut(f64, &[u8])) {
        for _ in 0..max_steps {
            if self.is_over() {
                break;
            }
            self.step(tap);
        }
        // One more so the final state and events reach everyone.
        self.step(tap);
    }

    /// Every event so far (since the last [`Match::clear_events`]).
    pub fn events(&self) -> &[Event] {
        &self.recorder.events
    }

    /// Forgets the events so far: a long run that reads them as they come keeps no history.
    pub fn clear_events(&mut self) {
        self.recorder.events.clear();
    }

    /// The newest game state published.
    pub fn state(&self) -> Option<&GameState> {
        self.recorder.state.as_ref()
    }

    /// The packets the bus carried: how many reached at least one part, and
    /// how many were malformed (dropped by the hub).
    pub fn traffic(&self) -> (u64, u64) {
        let s = self.bus.stats();
        // `delivered` counts copies, one per part; a packet that reached
        // anyone is one that was sent, well formed, not lost and routed.
        // (Nothing here cuts a link or sets a minimum priority.)
        (
            s.sent.saturating_sub(s.malformed + s.lost + s.unrouted),
            s.malformed,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::Battlefield;
    use crate::rules::Mode;

    fn small_match() -> Match {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/ctf.map");
        let field = Arc::new(Battlefield::from_file(&path).unwrap());
        let teams = [
            TeamSetup::parse("red", "alpha:tank").unwrap(),
            TeamSetup::parse("blue", "alpha:scout").unwrap(),
        ];
        Match::new(field, Rules::new(Mode::CaptureTheFlag), &teams, &[]).unwrap()
    }

    fn first_subject(p: &[u8]) -> String {
        Packet::parse(p)
            .unwrap()
            .subjects()
            .next()
            .unwrap()
            .to_string()
    }

    #[test]
    fn a_step_delivers_all_it_sets_off_and_an_outside_packet_goes_out_with_it_first() {
        let mut m = small_match();
        let mut shown: Vec<String> = Vec::new();
        m.step(&mut |_, p| shown.push(first_subject(p)));
        m.send(b"@ <game.player.red> 0\nsquad name alpha do dance\n".to_vec());
        m.send(b"not a packet".to_vec());
        let mut seen: Vec<(f64, Vec<u8>)> = Vec::new();
        m.step(&mut |t, p| seen.push((t, p.to_vec())));
        assert_eq!(m.world().field().step_count(), 2, "one step per call");
        let order: Vec<String> = seen.iter().map(|(_, p)| first_subject(p)).collect();
        assert_eq!(order[0], "game.player.red", "the player's command first");
        assert!(
            order[1].starts_with("game.sense."),
            "then the world's step: {order:?}"
        );
        assert!(seen.iter().all(|(t, _)| *t == m.world().time()));
        // The refusal, and the state the second frame called for, reached the
        // recorder within the step: the cascade ran until nothing was left.
        assert!(m.events().iter().any(|e| e.kind == "refused"));
        assert!(m.state().is_some());
        // The malformed packet is counted, not shown; every other packet was
        // shown once, and all but the map (no part here reads it) reached a part.
        shown.extend(order);
        let maps = shown.iter().filter(|s| s.as_str() == protocol::MAP).count() as u64;
        assert!(maps > 0);
        assert_eq!(m.traffic(), (shown.len() as u64 - maps, 1));
    }
}
