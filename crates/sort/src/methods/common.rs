//! Pieces the state machines share: a step clock, the random turn, wandering,
//! and choosing and tracking targets.

use std::f64::consts::PI;

use colony_sim::{Observation, Vec2, WheelCommand};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::cluster::{extreme, Cluster, Extreme};
use crate::deneubourg::{p_drop, p_pick};
use crate::params::{SortParams, TimingParams};
use crate::perception::{freer_side, is_reachable, vfh_obstacles, LocalMap, PuckObstacles};
use crate::vfh::{steer, Vfh};

/// Counts control steps and the steps spent in the current state.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Clock {
    step: u64,
    entered: u64,
}

impl Clock {
    /// Called once at the start of every control step.
    pub fn tick(&mut self) {
        self.step += 1;
    }
    /// A new state starts this step.
    pub fn enter(&mut self) {
        self.entered = self.step;
    }
    /// Steps since the current state was entered (0 on its first step).
    pub fn elapsed(&self) -> u64 {
        self.step - self.entered
    }
}

/// An on-the-spot turn by a random angle in [pi/2, pi] toward the freer side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RandomTurn {
    /// +1 counter-clockwise (left), -1 clockwise.
    pub side: f64,
    pub steps: u64,
}

impl RandomTurn {
    pub const NONE: RandomTurn = RandomTurn {
        side: 1.0,
        steps: 0,
    };

    pub fn draw(obs: &Observation, timing: &TimingParams, rng: &mut ChaCha8Rng) -> RandomTurn {
        let angle = rng.random_range(PI / 2.0..=PI);
        let steps = (angle / PI * f64::from(timing.half_turn_steps))
            .round()
            .max(1.0);
        RandomTurn {
            side: freer_side(obs),
            steps: steps as u64,
        }
    }

    pub fn command(&self) -> WheelCommand {
        WheelCommand {
            forward: 0.0,
            turn: self.side,
        }
    }
}

/// A Gaussian angle with the wander standard deviation.
pub(crate) fn gaussian_angle(params: &SortParams, rng: &mut ChaCha8Rng) -> f64 {
    params.seek.wander_sigma_rad * rng.sample::<f64, _>(StandardNormal)
}

/// VFH+ driving with the steering law, remembering which way to turn while
/// boxed in.
#[derive(Debug, Clone)]
pub(crate) struct Driver {
    vfh: Vfh,
    blocked_side: Option<f64>,
}

impl Driver {
    pub fn new(params: &SortParams) -> Driver {
        Driver {
            vfh: Vfh::new(&params.vfh, &params.robot),
            blocked_side: None,
        }
    }

    /// Drives toward `goal` (radians, robot frame) with VFH+ avoiding `which`
    /// pucks. With no free direction it turns hard toward the freer side,
    /// kept from the first blocked step while `steering.hold_blocked_side`.
    pub fn drive(
        &mut self,
        obs: &Observation,
        which: PuckObstacles,
        goal: f64,
        params: &SortParams,
    ) -> WheelCommand {
        let obstacles = vfh_obstacles(obs, which, params.perception.puck_radius_cm);
        let dir = self.vfh.direction(&obstacles, goal);
        let side = match (dir, params.steering.hold_blocked_side) {
            (Some(_), _) => {
                self.blocked_side = None;
                1.0
            }
            (None, true) => *self.blocked_side.get_or_insert_with(|| freer_side(obs)),
            (None, false) => freer_side(obs),
        };
        steer(dir, side, &params.steering)
    }

    /// Wandering: a random forward goal, altered by VFH+ (pucks avoided).
    pub fn wander(
        &mut self,
        obs: &Observation,
        params: &SortParams,
        rng: &mut ChaCha8Rng,
    ) -> WheelCommand {
        let goal = gaussian_angle(params, rng);
        self.drive(obs, PuckObstacles::All, goal, params)
    }
}

/// Index of the extreme candidate cluster accepted by `allow`.
fn extreme_candidate(
    map: &LocalMap,
    allow: impl Fn(usize, &Cluster) -> bool,
    which: Extreme,
) -> Option<usize> {
    let chosen = extreme(
        map.candidates()
            .filter(|(i, c)| allow(*i, c))
            .map(|(_, c)| c),
        which,
    )?;
    map.clusters.iter().position(|c| std::ptr::eq(c, chosen))
}

/// PU_SCAN's draw: S among the allowed candidate clusters is targeted with
/// probability p_pick(size); the target is its end puck if reachable.
/// Returns the puck's position and its cluster's index.
pub(crate) fn select_pick_up(
    map: &LocalMap,
    allow: impl Fn(usize, &Cluster) -> bool,
    params: &SortParams,
    rng: &mut ChaCha8Rng,
) -> Option<(Vec2, usize)> {
    let ci = extreme_candidate(map, allow, Extreme::Smallest)?;
    let cluster = &map.clusters[ci];
    let draw: f64 = rng.random();
    if draw >= p_pick(cluster.size() as f64, params.deneubourg.k1) {
        return None;
    }
    let puck = cluster.end_puck()?;
    is_reachable(puck.pos, &params.robot).then_some((puck.pos, ci))
}

/// DE_SCAN's draw: L_j of the carried kind among the candidates (clusters
/// touching another kind excluded) is targeted with probability p_drop(size).
/// Returns the cluster's centroid and index.
pub(crate) fn select_deposit(
    map: &LocalMap,
    params: &SortParams,
    rng: &mut ChaCha8Rng,
) -> Option<(Vec2, usize)> {
    let kind = map.carried_kind()?;
    let ci = extreme_candidate(
        map,
        |i, c| c.kind == kind && !map.touches_other_kind(i),
        Extreme::Largest,
    )?;
    let cluster = &map.clusters[ci];
    let draw: f64 = rng.random();
    (draw < p_drop(cluster.size() as f64, params.deneubourg.k2)).then_some((cluster.centroid, ci))
}

/// PU_TARGET's tracking: the candidate-cluster puck nearest `last`, if within
/// `target_lost_cm` and reachable. Returns its position and cluster index.
pub(crate) fn track_puck(map: &LocalMap, last: Vec2, params: &SortParams) -> Option<(Vec2, usize)> {
    let mut best: Option<(f64, Vec2, usize)> = None;
    for (ci, c) in map.candidates() {
        for m in &c.members {
            let d = m.pos.distance(last);
            if best.is_none_or(|(bd, _, _)| d < bd) {
                best = Some((d, m.pos, ci));
            }
        }
    }
    let (d, pos, ci) = best?;
    (d <= params.seek.target_lost_cm && is_reachable(pos, &params.robot)).then_some((pos, ci))
}

/// DE_TARGET's tracking: the candidate cluster of the carried kind whose
/// centroid is nearest `last`, if within `target_lost_cm`.
pub(crate) fn track_cluster(
    map: &LocalMap,
    last: Vec2,
    params: &SortParams,
) -> Option<(Vec2, usize)> {
    let kind = map.carried_kind()?;
    let mut best: Option<(f64, Vec2, usize)> = None;
    for (ci, c) in map.candidates().filter(|(_, c)| c.kind == kind) {
        let d = c.centroid.distance(last);
        if best.is_none_or(|(bd, _, _)| d < bd) {
            best = Some((d, c.centroid, ci));
        }
    }
    let (d, pos, ci) = best?;
    (d <= params.seek.target_lost_cm).then_some((pos, ci))
}

pub(crate) const FORWARD: WheelCommand = WheelCommand {
    forward: 1.0,
    turn: 0.0,
};

pub(crate) const REVERSE: WheelCommand = WheelCommand {
    forward: -1.0,
    turn: 0.0,
};
