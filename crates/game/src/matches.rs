//! A whole match in one process, fast-forwarded: the world, the game server,
//! every robot and the scripted players exchange the same packets they would
//! over the hub, through an in-memory bus, as fast as the machine goes.

use std::sync::Arc;

use colony_sim::SimError;
use colony_wire::Packet;

use crate::bot::Bot;
use crate::logic::{roster, RobotEntry, SetupError};
use crate::map::Battlefield;
use crate::node::{Bus, Node};
use crate::protocol::{Event, GameState, EVENT, STATE};
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
#[derive(Default)]
struct Recorder {
    events: Vec<Event>,
    state: Option<GameState>,
}

impl Node for Recorder {
    fn subscriptions(&self) -> Vec<String> {
        vec![STATE.to_string(), EVENT.to_string()]
    }
    fn handle(&mut self, packet: &Packet<'_>, _out: &mut Vec<Vec<u8>>) {
        if packet.has_subject(STATE) {
            if let Ok(s) = GameState::decode(packet) {
                self.state = Some(s);
            }
        } else if let Ok(e) = Event::decode(packet) {
            self.events.push(e);
        }
    }
}

/// A match being played.
pub struct Match {
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
        Ok(Match {
            world: GameWorld::new(&field, &entries)?,
            robots: entries
                .iter()
                .map(|e| RobotNode::new(e.id, e.kind))
                .collect(),
            server: Server::new(field, rules, entries),
            bots: bots.iter().map(|t| Bot::new(t)).collect(),
            recorder: Recorder::default(),
            bus: Bus::default(),
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

    /// Puts a packet on the bus (a player's command, say), delivered with the next step.
    pub fn send(&mut self, packet: Vec<u8>) {
        self.bus.send([packet]);
    }

    /// One control step of the world and everything it sets off; every
    /// packet is shown to `tap` with the game time.
    pub fn step(&mut self, tap: &mut dyn FnMut(f64, &[u8])) {
        let mut out = Vec::new();
        self.world.step(&mut out);
        self.bus.send(out);
        let time = self.world.time();
        let mut nodes: Vec<&mut dyn Node> = Vec::with_capacity(self.robots.len() + 4);
        nodes.push(&mut self.world);
        nodes.push(&mut self.server);
        for r in &mut self.robots {
            nodes.push(r);
        }
        for b in &mut self.bots {
            nodes.push(b);
        }
        nodes.push(&mut self.recorder);
        self.bus.drain(&mut nodes, |p| tap(time, p));
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

    /// Every event so far.
    pub fn events(&self) -> &[Event] {
        &self.recorder.events
    }

    /// The newest game state published.
    pub fn state(&self) -> Option<&GameState> {
        self.recorder.state.as_ref()
    }

    /// Packets delivered and malformed on the bus.
    pub fn traffic(&self) -> (u64, u64) {
        (self.bus.delivered, self.bus.malformed)
    }
}
