//! The game server: the game logic and the server-side swarm intelligence as
//! one part of the game. It hears the world's poses, the robots' actions and
//! behaviours and the players' squad commands; it publishes each robot's
//! sequence command, the game state and events.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;
use std::time::Duration;

use colony_node::{Node, Time};
use colony_sim::Vec2;
use colony_wire::{Packet, Subject};

use crate::logic::{Referee, RobotEntry};
use crate::map::Battlefield;
use crate::nav::Nav;
use crate::protocol::{self, Action, Command, Event, Order, PlayerCommand, RobotDebug, WorldFrame};
use crate::rules::{KindRules, Rules};
use crate::squad::{SeenRobot, Squad, SquadMotion, View};

mod player;

/// The squad arbitrators run every this many world frames (0.2 s at 10 Hz):
/// like the paper's swarm intelligence, which batches player commands (it waits 300 ms).
pub const THINK_EVERY: u64 = 2;
/// The timings of this many of the latest commands are kept.
const MAX_TIMINGS: usize = 1024;
/// A driven robot its player has not driven for this long goes back to its squad, s.
const DRIVE_LAPSE_S: f64 = 4.0 * protocol::DRIVE_HOLD_S;
/// The game state goes out every this many world frames.
const STATE_EVERY: u64 = 2;
/// Each robot's order is repeated every this many world frames, so a robot
/// that restarted (or lost the packet) picks up where its squad is; a robot
/// that already holds it ignores the repeat (same sequence number).
const RESEND_EVERY: u64 = 20;
/// The map goes out every this many world frames (new players need it).
const MAP_EVERY: u64 = 30;
/// Spacing of robots in formation (the paper's d), cm: a body and a half.
pub const SPACING_CM: f64 = 22.0;

/// How one player command went through the server (the paper's Tables 3 and 4).
#[derive(Debug, Clone, PartialEq)]
pub struct CommandTiming {
    /// The squad's team.
    pub team: String,
    /// The squad commanded.
    pub squad: String,
    /// When the command came (the server's clock).
    pub received: Time,
    /// The command, as the game words it (`goto 310 88`).
    pub order: String,
    /// When the squad's orders went out.
    pub answered: Time,
    /// How long the squad's arbitrator computed them.
    pub compute: Duration,
    /// The orders sent: robot and sequence number.
    pub orders: Vec<(u32, u64)>,
}

/// A command taken and not yet turned into orders.
#[derive(Debug, Clone)]
struct Pending {
    team: String,
    squad: String,
    order: String,
    received: Time,
}

/// The game logic and swarm intelligence.
pub struct Server {
    field: Arc<Battlefield>,
    roster: Vec<RobotEntry>,
    referee: Referee,
    squads: Vec<Squad>,
    seq: Vec<u64>,
    last_orders: Vec<Option<Order>>,
    frames: u64,
    last_centroids: BTreeMap<(String, String), (f64, Vec2)>,
    velocities: BTreeMap<(String, String), Vec2>,
    think_every: u64,
    timings: VecDeque<CommandTiming>,
    /// Commands taken and not yet turned into orders, oldest first (at most [`MAX_TIMINGS`]).
    pending: VecDeque<Pending>,
    /// Robots their player drives directly, and when each was last driven.
    driven: BTreeMap<u32, Time>,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
}

impl Server {
    /// A server for this game.
    pub fn new(field: Arc<Battlefield>, rules: Rules, roster: Vec<RobotEntry>) -> Server {
        let referee = Referee::new(&field, rules, &roster);
        let mut squads: Vec<Squad> = Vec::new();
        for e in &roster {
            match squads
                .iter_mut()
                .find(|s| s.team() == e.team && s.name() == e.squad)
            {
                Some(_) => {}
                None => {
                    let members = roster
                        .iter()
                        .filter(|o| o.team == e.team && o.squad == e.squad)
                        .map(|o| o.id)
                        .collect();
                    squads.push(Squad::new(
                        &e.team,
                        &e.squad,
                        members,
                        SPACING_CM,
                        Nav::new(field.clone()),
                    ));
                }
            }
        }
        let subs = protocol::subjects(
            [
                protocol::WORLD.to_string(),
                protocol::ACTION.to_string(),
                protocol::DEBUG.to_string(),
            ]
            .into_iter()
            .chain(
                field
                    .teams
                    .iter()
                    .map(|t| protocol::player_channel(&t.name)),
            ),
        );
        Server {
            subs,
            outbox: VecDeque::new(),
            seq: vec![0; roster.len()],
            last_orders: vec![None; roster.len()],
            field,
            roster,
            referee,
            squads,
            frames: 0,
            last_centroids: BTreeMap::new(),
            velocities: BTreeMap::new(),
            think_every: THINK_EVERY,
            timings: VecDeque::new(),
            pending: VecDeque::new(),
            driven: BTreeMap::new(),
        }
    }

    /// Runs the squad arbitrators every `frames` world frames instead of [`THINK_EVERY`]: the
    /// paper's server waited 300 ms (3 frames) before turning commands into orders.
    pub fn with_think_every(mut self, frames: u64) -> Server {
        self.think_every = frames.max(1);
        self
    }

    /// How the latest commands (up to 1024) went: when each came, when its orders left and how
    /// long the squad's arbitrator took over them.
    pub fn timings(&self) -> impl Iterator<Item = &CommandTiming> {
        self.timings.iter()
    }

    /// The referee.
    pub fn referee(&self) -> &Referee {
        &self.referee
    }

    fn refuse(&mut self, text: String, out: &mut Vec<Vec<u8>>) {
        let e = Event {
            time: self.referee.time(),
            kind: "refused".into(),
            text,
        };
        if let Ok(p) = e.encode() {
            out.push(p);
        }
    }

    /// Robots whose player stopped driving them (a closed page, a lost packet, a team changed
    /// on the page) go back to their squads: no robot is out of their hands for good.
    fn lapse_drives(&mut self, now: Time) {
        let lapse = Duration::from_secs_f64(DRIVE_LAPSE_S);
        let lapsed: Vec<u32> = self
            .driven
            .iter()
            .filter(|(_, &at)| now - at > lapse)
            .map(|(&id, _)| id)
            .collect();
        for id in lapsed {
            self.driven.remove(&id);
            if let Some(i) = self.squads.iter().position(|s| s.members().contains(&id)) {
                self.squads[i].refresh();
            }
        }
    }

    fn view(&mut self) -> Arc<View> {
        let state = self.referee.state(Vec::new());
        let time = state.time;
        let robots: Vec<SeenRobot> = state
            .robots
            .iter()
            .map(|r| SeenRobot {
                id: r.id,
                team: r.team.clone(),
                kind: r.kind,
                at: r.pose.position(),
                alive: r.alive,
                driven: self.driven.contains_key(&r.id),
            })
            .collect();
        let mut squads = Vec::new();
        for s in &self.squads {
            let alive: Vec<&SeenRobot> = s
                .members()
                .iter()
                .filter_map(|&id| robots.get(id as usize))
                .filter(|r| r.alive)
                .collect();
            if alive.is_empty() {
                continue;
            }
            let c = alive.iter().fold(Vec2::ZERO, |a, r| a + r.at) * (1.0 / alive.len() as f64);
            let radius = alive
                .iter()
                .map(|r| r.at.distance(c) + r.kind.stats().radius_cm)
                .fold(0.0, f64::max);
            let key = (s.team().to_string(), s.name().to_string());
            let v = match self.last_centroids.get(&key) {
                Some(&(t0, c0)) if time > t0 => {
                    let raw = (c - c0) * (1.0 / (time - t0));
                    let old = self.velocities.get(&key).copied().unwrap_or(raw);
                    // Smoothed: one frame's jitter must not look like a charge.
                    old * 0.5 + raw * 0.5
                }
                _ => Vec2::ZERO,
            };
            self.last_centroids.insert(key.clone(), (time, c));
            self.velocities.insert(key, v);
            squads.push(SquadMotion {
                team: s.team().to_string(),
                name: s.name().to_string(),
                centroid: c,
                velocity: v,
                radius,
            });
        }
        // Squads merged away or emptied leave no motion behind.
        let live: BTreeSet<(String, String)> = squads
            .iter()
            .map(|m| (m.team.clone(), m.name.clone()))
            .collect();
        self.last_centroids.retain(|k, _| live.contains(k));
        self.velocities.retain(|k, _| live.contains(k));
        Arc::new(View {
            time,
            robots,
            flags: state
                .flags
                .iter()
                .map(|f| (f.team.clone(), f.at, f.carrier))
                .collect(),
            bases: self
                .field
                .teams
                .iter()
                .filter_map(|t| self.referee.base(&t.name).map(|b| (t.name.clone(), b)))
                .collect(),
            squads,
        })
    }

    fn think(&mut self, now: Time, out: &mut Vec<Vec<u8>>) {
        self.lapse_drives(now);
        let view = self.view();
        for i in 0..self.squads.len() {
            let t0 = std::time::Instant::now();
            let orders = self.squads[i].tick(view.clone());
            let compute = t0.elapsed();
            let mut sent = Vec::new();
            for (robot, commands) in orders {
                if self.driven.contains_key(&robot) {
                    continue;
                }
                if let Some(seq) = self.send(robot, commands, out) {
                    sent.push((robot, seq));
                }
            }
            // The squad's newest command since its last think was answered now; the ones before
            // it were superseded (answered with no orders of their own).
            let (team, name) = (self.squads[i].team(), self.squads[i].name());
            let mine: Vec<usize> = (0..self.pending.len())
                .filter(|&k| self.pending[k].team == team && self.pending[k].squad == name)
                .collect();
            let newest = mine.last().copied();
            for &k in mine.iter().rev() {
                let Some(p) = self.pending.remove(k) else {
                    continue;
                };
                if self.timings.len() == MAX_TIMINGS {
                    self.timings.pop_front();
                }
                self.timings.push_back(CommandTiming {
                    team: p.team,
                    squad: p.squad,
                    order: p.order,
                    received: p.received,
                    // The orders leave once the arbitration is done.
                    answered: now + compute,
                    compute,
                    orders: if Some(k) == newest {
                        sent.clone()
                    } else {
                        Vec::new()
                    },
                });
            }
        }
    }

    /// Sends robot `robot` a new order; its sequence number, when it could be sent.
    fn send(&mut self, robot: u32, commands: Vec<Command>, out: &mut Vec<Vec<u8>>) -> Option<u64> {
        let seq = self.seq.get_mut(robot as usize)?;
        *seq += 1;
        let order = Order {
            robot,
            seq: *seq,
            commands,
        };
        let seq = order.seq;
        match order.encode() {
            Ok(p) => out.push(p),
            Err(e) => tracing::warn!(robot, error = %e, "an order too large to send"),
        }
        self.last_orders[robot as usize] = Some(order);
        Some(seq)
    }

    /// Repeats every living robot's order from the leg it is on: the GoTo
    /// nearest to it and what follows.
    fn resend(&mut self, out: &mut Vec<Vec<u8>>) {
        for (id, order) in self.last_orders.iter().enumerate() {
            let Some(order) = order else { continue };
            let Some((pose, true)) = self.referee.robot(id as u32) else {
                continue;
            };
            let here = pose.position();
            let nearest = order
                .commands
                .iter()
                .enumerate()
                .filter_map(|(k, c)| match c {
                    Command::GoTo { to, .. } => Some((k, to.distance(here))),
                    _ => None,
                })
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map_or(0, |(k, _)| k);
            let rest = Order {
                robot: order.robot,
                seq: order.seq,
                commands: order.commands[nearest..].to_vec(),
            };
            if let Ok(p) = rest.encode() {
                out.push(p);
            }
        }
    }

    fn publish_state(&mut self, out: &mut Vec<Vec<u8>>) {
        let squads = self.squads.iter().map(Squad::state).collect();
        match self.referee.state(squads).encode() {
            Ok(p) => out.push(p),
            Err(e) => tracing::warn!(error = %e, "game state too large to send"),
        }
    }

    fn flush_events(&mut self, out: &mut Vec<Vec<u8>>) {
        for e in self.referee.take_events() {
            if let Ok(p) = e.encode() {
                out.push(p);
            }
        }
    }

    /// The robots of the game.
    pub fn roster(&self) -> &[RobotEntry] {
        &self.roster
    }
}

impl Server {
    /// Takes in one packet; pushes what it answers.
    fn handle(&mut self, now: Time, packet: &Packet<'_>, out: &mut Vec<Vec<u8>>) {
        if packet.has_subject(protocol::WORLD) {
            match WorldFrame::decode(packet) {
                Ok(frame) => {
                    self.referee.on_world(&frame);
                    self.frames += 1;
                    if !self.referee.is_over() && self.frames % self.think_every == 0 {
                        self.think(now, out);
                    }
                    self.flush_events(out);
                    if self.frames % STATE_EVERY == 0 || self.referee.is_over() {
                        self.publish_state(out);
                    }
                    if self.frames % RESEND_EVERY == 0 && !self.referee.is_over() {
                        self.resend(out);
                    }
                    if self.frames % MAP_EVERY == 1 {
                        match protocol::map_message(&self.field).encode() {
                            Ok(parts) => out.extend(parts),
                            Err(e) => tracing::warn!(error = %e, "cannot send the map"),
                        }
                    }
                }
                Err(e) => tracing::debug!(error = %e, "ignored a bad world frame"),
            }
        } else if packet.has_subject(protocol::ACTION) {
            match Action::decode(packet) {
                Ok(actions) => {
                    for a in &actions {
                        self.referee.on_action(a);
                    }
                    self.flush_events(out);
                }
                Err(e) => self.refuse(format!("a bad action packet: {e}"), out),
            }
        } else if packet.has_subject(protocol::DEBUG) {
            if let Ok(d) = RobotDebug::decode(packet) {
                self.referee.set_behaviour(d.robot, d.behaviour, d.reason);
            }
        } else if let Some(team) = packet
            .subjects()
            .find_map(|s| s.strip_prefix("game.player."))
        {
            match PlayerCommand::decode(team, packet) {
                Ok(cmds) => {
                    // However many lines a packet has, it gets at most one refusal and one
                    // order per driven robot: a forged packet cannot multiply the traffic.
                    let mut refused = Vec::new();
                    let cmds = protocol::player::latest_drives(cmds);
                    for c in cmds {
                        if let Err(why) = self.obey(now, c, out) {
                            refused.push(why);
                        }
                    }
                    if let Some(text) = protocol::player::one_refusal(&refused) {
                        self.refuse(text, out);
                    }
                }
                Err(e) => self.refuse(format!("a bad command from {team}: {e}"), out),
            }
        }
    }
}

impl Node for Server {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
        let mut out = Vec::new();
        self.handle(now, packet, &mut out);
        self.outbox.extend(out);
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}
