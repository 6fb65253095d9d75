//! The battlefield in the simulator, as a part of the game: it steps the
//! physics, publishes every robot's sensors and pose, drives each robot by
//! the newest wheel command for it, and takes destroyed robots out of play
//! when the game logic's state says so.
//!
//! As a [`Node`] its control step is its timer: one step every pace period,
//! which is the simulated control period in a fast-forwarded match and that
//! period divided by the speed-up live.

use std::collections::{BTreeSet, VecDeque};
use std::time::Duration;

use colony_node::{Node, Time};
use colony_proto::CommandHold;
use colony_sim::field::{
    Field, FieldConfig, FieldRobotId, RobotSpec, Terrain as SimTerrain, TileMap,
};
use colony_sim::SimError;
use colony_wire::{Packet, Subject};

use crate::logic::RobotEntry;
use crate::map::{Battlefield, Terrain};
use crate::protocol::{self, GameState, RobotPose, Sense, WorldFrame};
use crate::rules::KindRules;

/// A robot whose newest command is older than 10 steps stops (a dead controller must not leave
/// its robot driving): a command holds for 11 steps, the one it arrived at and 10 more.
const HOLD_STEPS: u64 = 11;
/// A world restarted into a running game adopts its state only this early.
const SYNC_WINDOW_STEPS: u64 = 10;

/// The world's side of the game.
pub struct GameWorld {
    field: Field,
    commands: CommandHold,
    /// Game time when this world started: a restarted world takes the
    /// game's clock and poses from the first game state it hears.
    time_offset: f64,
    synced: bool,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
    /// Time between two steps on the node's clock.
    period: Duration,
    /// When pacing started, on the node's clock, and the steps taken since:
    /// step `n` is due at `paced_from + n · period`, so a late step does not
    /// push back the ones after it.
    paced_from: Time,
    paced_steps: u64,
}

/// The simulator's tile map for a battlefield: trees and out-of-bounds are
/// walls, water is water, the rest open ground.
pub fn tile_map(field: &Battlefield) -> Result<TileMap, SimError> {
    let g = &field.grid;
    TileMap::from_fn(
        g.width() as usize,
        g.height() as usize,
        field.cell_cm,
        |x, y| match g.get(x as u32, y as u32) {
            Some(Terrain::Open | Terrain::Swamp) => SimTerrain::Open,
            Some(Terrain::Water) => SimTerrain::Water,
            _ => SimTerrain::Blocked,
        },
    )
}

impl GameWorld {
    /// The battlefield with the roster's robots at their spawn points.
    pub fn new(field: &Battlefield, roster: &[RobotEntry]) -> Result<GameWorld, SimError> {
        let mut sim = Field::new(tile_map(field)?, FieldConfig::default())?;
        for e in roster {
            let s = e.build.kind.stats();
            sim.add_robot(
                RobotSpec {
                    radius: s.radius_cm,
                    max_speed: s.speed_cm_s,
                    max_turn: s.turn_rad_s,
                    amphibious: s.amphibious,
                },
                e.spawn,
            )?;
        }
        let period = Duration::from_secs_f64(sim.config().control_step);
        Ok(GameWorld {
            commands: CommandHold::new(roster.len(), HOLD_STEPS),
            field: sim,
            time_offset: 0.0,
            synced: false,
            subs: protocol::subjects([protocol::RADIO, protocol::STATE]),
            outbox: VecDeque::new(),
            period,
            paced_from: Time::ZERO,
            paced_steps: 0,
        })
    }

    /// Steps every `period` from `from` on, on the node's clock. A new world
    /// steps every simulated control period from [`Time::ZERO`]: fast-forwarded,
    /// simulated time is the node's clock. Live, the period is the control
    /// period divided by the speed-up.
    pub fn set_pace(&mut self, period: Duration, from: Time) {
        self.period = period;
        self.paced_from = from;
        self.paced_steps = 0;
    }

    /// When the next control step is due.
    fn next_step(&self) -> Time {
        self.paced_from + self.period.mul_f64(self.paced_steps as f64)
    }

    /// The simulator.
    pub fn field(&self) -> &Field {
        &self.field
    }

    /// Game time, s.
    pub fn time(&self) -> f64 {
        self.field.time() + self.time_offset
    }

    /// Picks up a game already under way: a world that was restarted puts
    /// every robot where the game logic last saw it and takes up its clock.
    /// Only in the first second; after that the world is the authority.
    fn sync(&mut self, state: &GameState) {
        if self.synced || self.field.step_count() > SYNC_WINDOW_STEPS {
            self.synced = true;
            return;
        }
        self.synced = true;
        if state.time <= self.time() {
            return;
        }
        self.time_offset = state.time - self.field.time();
        // Out of play first, so nobody is refused a place someone else left.
        for r in &state.robots {
            let _ = self.field.set_active(FieldRobotId(r.id as usize), false);
        }
        for r in state.robots.iter().filter(|r| r.alive) {
            let id = FieldRobotId(r.id as usize);
            if self.field.respawn(id, r.pose).is_err() {
                let _ = self.field.set_active(id, true);
            }
        }
        tracing::info!(time = state.time, "joined a game under way");
    }

    /// One control step; pushes the sensor packets and the world frame.
    pub fn step(&mut self, out: &mut Vec<Vec<u8>>) {
        let cmds = self.commands.for_step(self.field.step_count());
        self.field.step(&cmds);
        let (step, time) = (self.field.step_count(), self.time());
        let mut frame = WorldFrame {
            step,
            time,
            robots: Vec::with_capacity(cmds.len()),
        };
        for r in self.field.robots() {
            frame.robots.push(RobotPose {
                id: r.id.0 as u32,
                pose: r.pose,
                active: r.active,
            });
            if !r.active {
                continue;
            }
            if let Some(s) = self.field.sense(r.id) {
                let sense = Sense {
                    step,
                    time,
                    pose: s.pose,
                    bump_front: s.bump_front,
                    bump_rear: s.bump_rear,
                    contact: s.contact_bearing,
                    sonar: s.sonar.map(|e| (e.distance, e.bearing)),
                    border: s.border_ahead,
                };
                if let Ok(p) = sense.encode(r.id.0 as u32) {
                    out.push(p);
                }
            }
        }
        match frame.encode() {
            Ok(p) => out.push(p),
            Err(e) => tracing::warn!(error = %e, "world frame too large to send"),
        }
    }
}

impl GameWorld {
    /// Takes in one packet: a wheel command or the game's state.
    fn handle(&mut self, packet: &Packet<'_>) {
        if packet.has_subject(protocol::RADIO) {
            // One of lower priority than a fresh one in force (an operator's) is
            // ignored until that one lapses.
            let step = self.field.step_count();
            if let Err(e) = self.commands.offer_radio(packet, step) {
                tracing::debug!(error = %e, "ignored a bad radio packet");
            }
        } else if packet.has_subject(protocol::STATE) {
            // The game logic decides who is destroyed; the world only obeys.
            // Reading it from the state (not an event) means a lost packet or a
            // restarted world catches up with the next state.
            match GameState::decode(packet) {
                Ok(state) => {
                    self.sync(&state);
                    for r in state.robots.iter().filter(|r| !r.alive) {
                        let _ = self.field.set_active(FieldRobotId(r.id as usize), false);
                    }
                }
                Err(e) => tracing::debug!(error = %e, "ignored a bad game state"),
            }
        }
    }
}

impl Node for GameWorld {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, _now: Time, packet: &Packet<'_>) {
        self.handle(packet);
    }

    /// One control step if it is due; a world that fell behind catches up
    /// one step per call, taking in what arrived in between.
    fn handle_timeout(&mut self, now: Time) {
        if self.next_step() <= now {
            let mut out = Vec::new();
            self.step(&mut out);
            self.outbox.extend(out);
            self.paced_steps += 1;
        }
    }

    fn poll_timeout(&self) -> Option<Time> {
        Some(self.next_step())
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::logic::roster;
    use crate::protocol::{RobotState, Status};
    use crate::rules::{Mode, Rules, TeamSetup};
    use colony_wire::Packet;

    fn world() -> (GameWorld, Vec<RobotEntry>) {
        let mut text = format!(
            "type octile\nheight 10\nwidth 20\nmap\n{}\n",
            "@".repeat(20)
        );
        for _ in 0..8 {
            text.push_str(&format!("@{}@\n", ".".repeat(18)));
        }
        text.push_str(&"@".repeat(20));
        text.push_str("\ncell 25\nteam red base 3 3 flag 2 2 spawn 4 4\nteam blue base 16 6 flag 17 7 spawn 15 5\n");
        let field = Battlefield::parse(&text).unwrap();
        let teams = [
            TeamSetup::parse("red", "a:tank").unwrap(),
            TeamSetup::parse("blue", "a:scout").unwrap(),
        ];
        let entries = roster(&field, &Rules::new(Mode::DeathMatch), &teams).unwrap();
        (GameWorld::new(&field, &entries).unwrap(), entries)
    }

    fn feed(w: &mut GameWorld, bytes: &[u8]) {
        w.handle_packet(Time::ZERO, &Packet::parse(bytes).unwrap());
    }

    fn pose(w: &GameWorld, id: usize) -> colony_sim::Pose {
        w.field().robot_pose(FieldRobotId(id)).unwrap()
    }

    #[test]
    fn an_operator_command_holds_a_robot_against_its_intelligence() {
        let (mut w, _) = world();
        let mut out = Vec::new();
        let start = pose(&w, 0).theta;
        feed(&mut w, b"@ <radio> 10\ncmd id 0 forward 0 turn 1\n");
        feed(&mut w, b"@ <radio> 0\ncmd id 0 forward 0 turn -1\n");
        for _ in 0..3 {
            w.step(&mut out);
        }
        assert!(
            pose(&w, 0).theta > start + 0.1,
            "turned left, as the operator said"
        );
        // Every robot is sensed and the frame lists both.
        let frame = out
            .iter()
            .rev()
            .find_map(|p| WorldFrame::decode(&Packet::parse(p).ok()?).ok())
            .unwrap();
        assert_eq!(frame.robots.len(), 2);
        assert!(out.iter().any(|p| p.starts_with(b"@ <game.sense.1>")));
    }

    fn state(
        time: f64,
        entries: &[RobotEntry],
        dead: &[u32],
        moved: Option<(u32, f64, f64)>,
    ) -> Vec<u8> {
        GameState {
            mode: "dm".into(),
            status: Status::Running,
            time,
            winner: None,
            reason: String::new(),
            teams: Vec::new(),
            flags: Vec::new(),
            robots: entries
                .iter()
                .map(|e| {
                    let mut pose = e.spawn;
                    if let Some((_, x, y)) = moved.filter(|m| m.0 == e.id) {
                        pose.x = x;
                        pose.y = y;
                    }
                    RobotState {
                        id: e.id,
                        team: e.team.clone(),
                        squad: e.squad.clone(),
                        kind: e.build.kind,
                        pose,
                        health: 1.0,
                        max_health: 1.0,
                        power: 0.0,
                        alive: !dead.contains(&e.id),
                        behaviour: String::new(),
                        reason: String::new(),
                    }
                })
                .collect(),
            squads: Vec::new(),
        }
        .encode()
        .unwrap()
    }

    #[test]
    fn a_robot_the_game_logic_destroyed_leaves_the_world() {
        let (mut w, entries) = world();
        let mut out = Vec::new();
        w.step(&mut out);
        feed(&mut w, &state(0.0, &entries, &[1], None));
        out.clear();
        w.step(&mut out);
        assert_eq!(w.field().is_active(FieldRobotId(1)), Some(false));
        assert!(
            !out.iter().any(|p| p.starts_with(b"@ <game.sense.1>")),
            "no sensing for the dead"
        );
    }

    #[test]
    fn a_restarted_world_takes_up_the_games_clock_and_poses() {
        let (mut w, entries) = world();
        feed(
            &mut w,
            &state(120.0, &entries, &[], Some((0, 200.0, 100.0))),
        );
        assert!((w.time() - 120.0).abs() < 1e-9);
        assert_eq!((pose(&w, 0).x, pose(&w, 0).y), (200.0, 100.0));
        // Later states don't move anyone: the world is the authority again.
        let mut out = Vec::new();
        for _ in 0..2 {
            w.step(&mut out);
        }
        feed(
            &mut w,
            &state(200.0, &entries, &[], Some((0, 300.0, 100.0))),
        );
        assert!((pose(&w, 0).x - 200.0).abs() < 1.0);
    }

    fn steps_sent(w: &mut GameWorld) -> usize {
        std::iter::from_fn(|| w.poll_transmit())
            .filter(|p| Packet::parse(p).unwrap().has_subject(protocol::WORLD))
            .count()
    }

    #[test]
    fn the_control_step_is_the_worlds_timer() {
        let (mut w, _) = world();
        assert_eq!(
            w.poll_timeout(),
            Some(Time::ZERO),
            "the first step is at once"
        );
        w.handle_timeout(Time::ZERO);
        assert_eq!((w.field().step_count(), steps_sent(&mut w)), (1, 1));
        // Fast-forwarded, the node's clock is simulated time: one control period later.
        let next = Time::from_secs_f64(w.field().config().control_step);
        assert_eq!(w.poll_timeout(), Some(next));
        w.handle_timeout(Time::from_micros(next.as_micros() - 1));
        assert_eq!(w.field().step_count(), 1, "not yet due");
    }

    #[test]
    fn a_paced_world_that_fell_behind_catches_up_one_step_a_call_on_its_grid() {
        let (mut w, _) = world();
        // Live at 4x: a 25 ms period, from 1 s on the node's clock.
        w.set_pace(Duration::from_millis(25), Time::from_secs_f64(1.0));
        assert_eq!(w.poll_timeout(), Some(Time::from_secs_f64(1.0)));
        let late = Time::from_secs_f64(1.06);
        for (steps, next) in [(1, 1.025), (2, 1.05), (3, 1.075)] {
            w.handle_timeout(late);
            assert_eq!(w.field().step_count(), steps);
            assert_eq!(w.poll_timeout(), Some(Time::from_secs_f64(next)));
        }
        w.handle_timeout(late);
        assert_eq!(w.field().step_count(), 3, "caught up: the next is not due");
        assert_eq!(steps_sent(&mut w), 3);
    }
}
