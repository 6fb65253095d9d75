//! BHD: Beckers, Holland and Deneubourg's clustering robots as the paper
//! re-implements them (Sect. 2.4, Fig. 4).
//!
//! FORWARD drives straight ahead. Contact (the gripper's puck joins a
//! cluster) starts PUSH, then BACKUP, which leaves the puck behind, then
//! TURN. An obstacle ahead (VFH+ with pucks invisible finds no direction, or
//! one more than `obstacle_ahead_deg` off straight) starts TURN directly,
//! keeping any carried puck. TURN rotates on the spot by a random angle in
//! [pi/2, pi] toward the side with fewer obstacles.

use colony_sim::{Observation, WheelCommand};
use rand_chacha::ChaCha8Rng;

use super::common::{Clock, RandomTurn, FORWARD, REVERSE};
use crate::params::SortParams;
use crate::perception::{vfh_obstacles, LocalMap, PuckObstacles};
use crate::vfh::Vfh;
use crate::Controller;

/// The states of Fig. 4.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BhdState {
    /// Driving forward, looking for pucks.
    Forward,
    /// Pushing a puck forward.
    Push,
    /// Backing away from a deposited puck.
    Backup,
    /// Turning on the spot by a random angle.
    Turn,
}

impl BhdState {
    /// The paper's name.
    pub fn name(self) -> &'static str {
        match self {
            BhdState::Forward => "FORWARD",
            BhdState::Push => "PUSH",
            BhdState::Backup => "BACKUP",
            BhdState::Turn => "TURN",
        }
    }
}

/// The BHD controller.
#[derive(Debug, Clone)]
pub struct Bhd {
    params: SortParams,
    vfh: Vfh,
    state: BhdState,
    clock: Clock,
    turn: RandomTurn,
}

impl Bhd {
    /// A BHD controller with these parameters.
    pub fn new(params: &SortParams) -> Bhd {
        Bhd {
            params: params.clone(),
            vfh: Vfh::new(&params.vfh, &params.robot),
            state: BhdState::Forward,
            clock: Clock::default(),
            turn: RandomTurn::NONE,
        }
    }

    /// The current state.
    pub fn current(&self) -> BhdState {
        self.state
    }

    fn enter(&mut self, s: BhdState) {
        self.state = s;
        self.clock.enter();
    }

    fn obstacle_ahead(&mut self, obs: &Observation) -> bool {
        let obstacles = vfh_obstacles(obs, PuckObstacles::Ignore, 0.0);
        let limit = self.params.vfh.obstacle_ahead_deg.to_radians();
        self.vfh
            .direction(&obstacles, 0.0)
            .is_none_or(|d| d.abs() > limit)
    }
}

impl Controller for Bhd {
    fn step(&mut self, obs: &Observation, rng: &mut ChaCha8Rng) -> WheelCommand {
        self.clock.tick();
        let elapsed = self.clock.elapsed();
        let timing = &self.params.timing;
        match self.state {
            BhdState::Forward => {
                if LocalMap::new(obs, &self.params).in_contact() {
                    self.enter(BhdState::Push);
                } else if self.obstacle_ahead(obs) {
                    self.turn = RandomTurn::draw(obs, &self.params.timing, rng);
                    self.enter(BhdState::Turn);
                }
            }
            BhdState::Push => {
                if elapsed >= u64::from(timing.push_steps) {
                    self.enter(BhdState::Backup);
                }
            }
            BhdState::Backup => {
                if elapsed >= u64::from(timing.backup_steps) {
                    self.turn = RandomTurn::draw(obs, &self.params.timing, rng);
                    self.enter(BhdState::Turn);
                }
            }
            BhdState::Turn => {
                if elapsed >= self.turn.steps {
                    self.enter(BhdState::Forward);
                }
            }
        }
        match self.state {
            BhdState::Forward | BhdState::Push => FORWARD,
            BhdState::Backup => REVERSE,
            BhdState::Turn => self.turn.command(),
        }
    }

    fn state(&self) -> &'static str {
        self.state.name()
    }
}
