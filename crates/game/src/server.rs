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
use crate::protocol::{
    self, Action, Command, Event, Order, RobotDebug, SquadCommand, Target, Verb, WorldFrame,
};
use crate::rules::{KindRules, Rules};
use crate::squad::{SeenRobot, Squad, SquadMotion, View};

/// The squad arbitrators run every this many world frames (0.2 s at 10 Hz):
/// like the paper's swarm intelligence, which batches player commands.
const THINK_EVERY: u64 = 2;
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
    /// How long each squad command took to turn into robot commands.
    pub command_times: Vec<Duration>,
    pending: Vec<usize>,
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
            command_times: Vec::new(),
            pending: Vec::new(),
        }
    }

    /// The referee.
    pub fn referee(&self) -> &Referee {
        &self.referee
    }

    /// Checks a player's command against the rules; the reason when refused.
    fn check(&self, c: &SquadCommand) -> Result<usize, String> {
        let squad = self
            .squads
            .iter()
            .position(|s| s.team() == c.team && s.name() == c.squad)
            .ok_or_else(|| format!("team {} has no squad {}", c.team, c.squad))?;
        if self.referee.is_over() {
            return Err("the game is over".into());
        }
        let on_map = |p: &Vec2| self.field.cell_at(p.x, p.y).is_some();
        let team_exists = |t: &str| self.field.teams.iter().any(|s| s.name == t);
        match &c.verb {
            Verb::GoTo(p) | Verb::Gather(Some(p)) if !on_map(p) => {
                Err(format!("({:.0}, {:.0}) is off the map", p.x, p.y))
            }
            Verb::Attack(Target::Robot(id)) => match self.referee.team_of(*id) {
                None => Err(format!("there is no robot {id}")),
                Some(t) if t == c.team => Err(format!("robot {id} is on your own team")),
                _ => Ok(squad),
            },
            Verb::Defend(Target::Robot(id)) => match self.referee.team_of(*id) {
                None => Err(format!("there is no robot {id}")),
                Some(t) if t != c.team => Err(format!("robot {id} is an enemy")),
                _ => Ok(squad),
            },
            Verb::Capture(flag) if flag == &c.team => Err("that is your own flag".into()),
            Verb::Capture(flag) if self.referee.flag_at(flag).is_none() => {
                Err(format!("there is no {flag} flag in this game"))
            }
            Verb::Defend(Target::Flag(t) | Target::Base(t))
            | Verb::Attack(Target::Flag(t) | Target::Base(t))
                if !team_exists(t) =>
            {
                Err(format!("there is no team {t}"))
            }
            Verb::Defend(Target::Point(p)) | Verb::Attack(Target::Point(p)) if !on_map(p) => {
                Err(format!("({:.0}, {:.0}) is off the map", p.x, p.y))
            }
            _ => Ok(squad),
        }
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

    fn think(&mut self, out: &mut Vec<Vec<u8>>) {
        let view = self.view();
        for i in 0..self.squads.len() {
            let t0 = std::time::Instant::now();
            let orders = self.squads[i].tick(view.clone());
            if let Some(k) = self.pending.iter().position(|&p| p == i) {
                self.pending.remove(k);
                self.command_times.push(t0.elapsed());
            }
            for (robot, commands) in orders {
                let Some(seq) = self.seq.get_mut(robot as usize) else {
                    continue;
                };
                *seq += 1;
                let order = Order {
                    robot,
                    seq: *seq,
                    commands,
                };
                match order.encode() {
                    Ok(p) => out.push(p),
                    Err(e) => tracing::warn!(robot, error = %e, "an order too large to send"),
                }
                self.last_orders[robot as usize] = Some(order);
            }
        }
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
    fn handle(&mut self, packet: &Packet<'_>, out: &mut Vec<Vec<u8>>) {
        if packet.has_subject(protocol::WORLD) {
            match WorldFrame::decode(packet) {
                Ok(frame) => {
                    self.referee.on_world(&frame);
                    self.frames += 1;
                    if !self.referee.is_over() && self.frames % THINK_EVERY == 0 {
                        self.think(out);
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
            match SquadCommand::decode(team, packet) {
                Ok(cmds) => {
                    for c in cmds {
                        match self.check(&c) {
                            Ok(i) => {
                                self.squads[i].command(c.verb, c.formation);
                                if !self.pending.contains(&i) {
                                    self.pending.push(i);
                                }
                            }
                            Err(why) => {
                                self.refuse(format!("{} squad {}: {why}", c.team, c.squad), out)
                            }
                        }
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

    fn handle_packet(&mut self, _now: Time, packet: &Packet<'_>) {
        let mut out = Vec::new();
        self.handle(packet, &mut out);
        self.outbox.extend(out);
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}
