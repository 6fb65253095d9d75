//! PROBSEEK: Deneubourg's probabilistic rules with seeking (Sect. 2.5, Fig. 5a).
//!
//! An unladen robot wanders (PU_SCAN) and each step targets S, the smallest
//! visible cluster, with probability p_pick(size); it then steers straight at
//! S's end puck of lower degree (PU_TARGET, no VFH+) until the puck is in
//! the gripper, the target is lost or time runs out. A laden robot wanders
//! (DE_SCAN) and targets L_j of its puck's type with probability
//! p_drop(size) (DE_TARGET) until contact, then pushes, backs up and turns
//! (DE_PUSH, DE_BACKUP, DE_TURN).

use colony_sim::{Observation, Pose, Vec2, WheelCommand};
use rand_chacha::ChaCha8Rng;

use super::common::{
    select_deposit, select_pick_up, track_cluster, track_puck, Clock, Driver, RandomTurn, FORWARD,
    REVERSE,
};
use crate::params::SortParams;
use crate::perception::LocalMap;
use crate::vfh::steer_toward;
use crate::Controller;

/// The states of Fig. 5a.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProbSeekState {
    /// PU_SCAN: wandering, looking for a puck to pick up.
    PuScan,
    /// PU_TARGET: driving to a chosen puck.
    PuTarget,
    /// DE_SCAN: carrying a puck, looking for a cluster of its kind.
    DeScan,
    /// DE_TARGET: driving to the chosen deposit point.
    DeTarget,
    /// DE_PUSH: pushing the puck into place.
    DePush,
    /// DE_BACKUP: backing away after depositing.
    DeBackup,
    /// DE_TURN: turning away before scanning again.
    DeTurn,
}

impl ProbSeekState {
    /// The paper's name.
    pub fn name(self) -> &'static str {
        match self {
            ProbSeekState::PuScan => "PU_SCAN",
            ProbSeekState::PuTarget => "PU_TARGET",
            ProbSeekState::DeScan => "DE_SCAN",
            ProbSeekState::DeTarget => "DE_TARGET",
            ProbSeekState::DePush => "DE_PUSH",
            ProbSeekState::DeBackup => "DE_BACKUP",
            ProbSeekState::DeTurn => "DE_TURN",
        }
    }
}

/// The PROBSEEK controller.
#[derive(Debug, Clone)]
pub struct ProbSeek {
    params: SortParams,
    driver: Driver,
    state: ProbSeekState,
    clock: Clock,
    turn: RandomTurn,
    /// Where the target was last seen (robot frame of the last step).
    target: Option<Vec2>,
    pose: Pose,
}

impl ProbSeek {
    /// A PROBSEEK controller with these parameters.
    pub fn new(params: &SortParams) -> ProbSeek {
        ProbSeek {
            params: params.clone(),
            driver: Driver::new(params),
            state: ProbSeekState::PuScan,
            clock: Clock::default(),
            turn: RandomTurn::NONE,
            target: None,
            pose: Pose::default(),
        }
    }

    /// The current state.
    pub fn current(&self) -> ProbSeekState {
        self.state
    }

    /// The target as last seen, in the robot frame.
    pub fn local_target(&self) -> Option<Vec2> {
        self.target
    }

    fn enter(&mut self, s: ProbSeekState) {
        self.state = s;
        self.clock.enter();
        if !matches!(s, ProbSeekState::PuTarget | ProbSeekState::DeTarget) {
            self.target = None;
        }
    }

    fn transition(&mut self, obs: &Observation, map: &LocalMap, rng: &mut ChaCha8Rng) {
        use ProbSeekState::*;
        let carrying = map.carried.is_some();
        let elapsed = self.clock.elapsed();
        let p = &self.params;
        match self.state {
            PuScan => {
                if carrying {
                    self.enter(DeScan);
                } else if let Some((pos, _)) = select_pick_up(map, |_, _| true, p, rng) {
                    self.target = Some(pos);
                    self.enter(PuTarget);
                }
            }
            PuTarget => {
                if carrying {
                    self.enter(DeScan);
                } else {
                    let last = self.target.unwrap_or_default();
                    match track_puck(map, last, p) {
                        None => self.enter(PuScan),
                        Some(_) if elapsed > u64::from(p.timing.pick_up_timeout_steps) => {
                            self.enter(PuScan)
                        }
                        Some((pos, _)) => self.target = Some(pos),
                    }
                }
            }
            DeScan => {
                if !carrying {
                    self.enter(PuScan);
                } else if let Some((pos, _)) = select_deposit(map, p, rng) {
                    self.target = Some(pos);
                    self.enter(DeTarget);
                }
            }
            DeTarget => {
                if !carrying {
                    self.enter(PuScan);
                } else if map.in_contact() {
                    self.enter(DePush);
                } else {
                    let last = self.target.unwrap_or_default();
                    match track_cluster(map, last, p) {
                        None => self.enter(DeScan),
                        Some(_) if elapsed > u64::from(p.timing.placement_timeout_steps) => {
                            self.enter(DeScan)
                        }
                        Some((pos, _)) => self.target = Some(pos),
                    }
                }
            }
            DePush => {
                if elapsed >= u64::from(p.timing.push_steps) {
                    self.enter(DeBackup);
                }
            }
            DeBackup => {
                if elapsed >= u64::from(p.timing.backup_steps) {
                    self.turn = RandomTurn::draw(obs, &p.timing, rng);
                    self.enter(DeTurn);
                }
            }
            DeTurn => {
                if elapsed >= self.turn.steps {
                    self.enter(PuScan);
                }
            }
        }
    }
}

impl Controller for ProbSeek {
    fn step(&mut self, obs: &Observation, rng: &mut ChaCha8Rng) -> WheelCommand {
        use ProbSeekState::*;
        self.clock.tick();
        self.pose = obs.pose;
        let map = LocalMap::new(obs, &self.params);
        self.transition(obs, &map, rng);
        match self.state {
            PuScan | DeScan => self.driver.wander(obs, &self.params, rng),
            PuTarget | DeTarget => {
                let t = self.target.unwrap_or_default();
                steer_toward(t.angle(), &self.params.steering)
            }
            DePush => FORWARD,
            DeBackup => REVERSE,
            DeTurn => self.turn.command(),
        }
    }

    fn state(&self) -> &'static str {
        self.state.name()
    }

    fn target(&self) -> Option<Vec2> {
        self.target.map(|t| self.pose.to_world(t))
    }
}
