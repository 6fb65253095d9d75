//! CACHECONS: cache consensus (Sect. 2.6, Fig. 5b) and its variants.
//!
//! Pick-up is PROBSEEK's (PU_SCAN, PU_TARGET), except that types without a
//! cache point are not targeted and a puck visibly joined to its type's cache
//! cluster is left alone. A laden robot homes (HOMING) to the cache point of
//! its puck's type using the pose from `obs.pose`, VFH+ avoiding everything
//! but pucks of that type, until the carried puck joins the cache cluster;
//! it then pushes, backs up and drives away from the cache (EXILE).
//! SPIT_OUT (from the authors' simulator) backs away from a puck of a type
//! that has no cache. Every step the robot also refreshes and reassigns its
//! caches ([`CacheMemory`]).

use std::f64::consts::PI;

use colony_sim::{Observation, Pose, PuckKind, Vec2, WheelCommand};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::caches::{CacheMemory, Separation};
use super::common::{gaussian_angle, select_pick_up, track_puck, Clock, Driver, FORWARD, REVERSE};
use crate::params::{CacheCandidates, SortParams};
use crate::perception::{LocalMap, PuckObstacles};
use crate::vfh::steer_toward;
use crate::Controller;
use colony_proto::wrap_angle;

/// The states of Fig. 5b, plus SPIT_OUT.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CacheConsState {
    /// PU_SCAN: wandering, looking for a puck to pick up.
    PuScan,
    /// PU_TARGET: driving to a chosen puck.
    PuTarget,
    /// HOMING: carrying a puck to its kind's cache.
    Homing,
    /// DE_PUSH: pushing the puck into the cache.
    DePush,
    /// DE_BACKUP: backing away after depositing.
    DeBackup,
    /// EXILE: driving away from a cache it may not deposit in.
    Exile,
    /// SPIT_OUT: dropping a puck it cannot take home.
    SpitOut,
}

impl CacheConsState {
    /// The paper's name (SPIT_OUT is the authors' simulator's).
    pub fn name(self) -> &'static str {
        match self {
            CacheConsState::PuScan => "PU_SCAN",
            CacheConsState::PuTarget => "PU_TARGET",
            CacheConsState::Homing => "HOMING",
            CacheConsState::DePush => "DE_PUSH",
            CacheConsState::DeBackup => "DE_BACKUP",
            CacheConsState::Exile => "EXILE",
            CacheConsState::SpitOut => "SPIT_OUT",
        }
    }
}

/// Which CACHECONS.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CacheConsVariant {
    /// The paper's method, with cache separation "accept the larger".
    Standard,
    /// CACHECONS_INFORMED: `n_types` caches preset on a circle (diameter
    /// `informed.diameter_fraction` of `arena_width`, centred on the world
    /// origin), never reassigned.
    Informed {
        /// How many puck kinds (and caches).
        n_types: usize,
        /// The arena's side (cm).
        arena_width: f64,
    },
    /// CacheCons_Ignore: no cache separation.
    IgnoreSeparation,
    /// Every step, all caches are forgotten with probability `p`.
    EraseMemory {
        /// The probability per step.
        p: f64,
    },
}

/// The preset cache points of CACHECONS_INFORMED: type k at angle
/// first_angle + k * 2 pi / n on a circle of diameter fraction * arena_width.
pub fn informed_caches(
    params: &SortParams,
    n_types: usize,
    arena_width: f64,
) -> Vec<(PuckKind, Vec2)> {
    let radius = params.informed.diameter_fraction * arena_width / 2.0;
    let first = params.informed.first_angle_deg.to_radians();
    (0..n_types.min(256))
        .map(|k| {
            let a = first + k as f64 * 2.0 * PI / n_types as f64;
            (
                PuckKind(k as u8),
                Vec2::new(radius * a.cos(), radius * a.sin()),
            )
        })
        .collect()
}

/// The CACHECONS controller.
#[derive(Debug, Clone)]
pub struct CacheCons {
    params: SortParams,
    variant: CacheConsVariant,
    driver: Driver,
    state: CacheConsState,
    clock: Clock,
    memory: CacheMemory,
    /// Pick-up target as last seen (robot frame of the last step).
    target: Option<Vec2>,
    last_carried: Option<PuckKind>,
    pose: Pose,
}

impl CacheCons {
    /// A CACHECONS controller of `variant`.
    pub fn new(params: &SortParams, variant: CacheConsVariant) -> CacheCons {
        let memory = match variant {
            CacheConsVariant::Informed {
                n_types,
                arena_width,
            } => CacheMemory::preset(
                informed_caches(params, n_types, arena_width),
                params.informed.remembered_size,
            ),
            _ => CacheMemory::new(),
        };
        CacheCons {
            params: params.clone(),
            variant,
            driver: Driver::new(params),
            state: CacheConsState::PuScan,
            clock: Clock::default(),
            memory,
            target: None,
            last_carried: None,
            pose: Pose::default(),
        }
    }

    /// The current state.
    pub fn current(&self) -> CacheConsState {
        self.state
    }

    /// The cache memory.
    pub fn memory(&self) -> &CacheMemory {
        &self.memory
    }

    /// Which variant this controller runs.
    pub fn variant(&self) -> CacheConsVariant {
        self.variant
    }

    fn enter(&mut self, s: CacheConsState) {
        self.state = s;
        self.clock.enter();
        if s != CacheConsState::PuTarget {
            self.target = None;
        }
    }

    /// Erasing, eq. 5 and cache reassignment, before the state machine runs.
    fn update_memory(&mut self, map: &LocalMap, pose: &Pose, rng: &mut ChaCha8Rng) {
        let separation = match self.variant {
            CacheConsVariant::Informed { .. } => return,
            CacheConsVariant::IgnoreSeparation => Separation::Ignore,
            CacheConsVariant::EraseMemory { p } => {
                if rng.random::<f64>() < p {
                    self.memory.clear();
                }
                self.accept_larger()
            }
            CacheConsVariant::Standard => self.accept_larger(),
        };
        let c = &self.params.cache;
        self.memory.update_sizes(map, pose, c.match_cm);
        match c.candidates {
            CacheCandidates::LargestOverall => {
                if let Some(l) = map.l() {
                    self.memory.consider(l, pose, separation);
                }
            }
            CacheCandidates::LargestPerType => {
                let mut kinds: Vec<PuckKind> = map.clusters.iter().map(|c| c.kind).collect();
                kinds.sort();
                kinds.dedup();
                for kind in kinds {
                    if let Some(l) = map.l_j(kind) {
                        self.memory.consider(l, pose, separation);
                    }
                }
            }
        }
    }

    fn accept_larger(&self) -> Separation {
        Separation::AcceptLarger {
            distance_cm: self.params.cache.separation_cm,
        }
    }

    fn has_cache(&self, kind: Option<PuckKind>) -> bool {
        kind.is_some_and(|k| self.memory.get(k).is_some())
    }

    /// The carried puck's cluster holds the cache point of its kind.
    fn at_cache(&self, map: &LocalMap, pose: &Pose) -> bool {
        map.carried_cluster()
            .is_some_and(|c| self.memory.holds(c, pose, self.params.cache.match_cm))
    }

    fn transition(&mut self, map: &LocalMap, pose: &Pose, rng: &mut ChaCha8Rng) {
        use CacheConsState::*;
        let carried = map.carried_kind();
        if carried.is_some() && !self.has_cache(carried) {
            if self.state != SpitOut {
                self.enter(SpitOut);
            } else if self.clock.elapsed() >= u64::from(self.params.timing.spit_out_steps) {
                self.enter(PuScan);
            }
            return;
        }
        let elapsed = self.clock.elapsed();
        let p = &self.params;
        let match_cm = p.cache.match_cm;
        match self.state {
            PuScan => {
                if carried.is_some() {
                    self.enter(Homing);
                } else {
                    let memory = &self.memory;
                    let allow =
                        |_: usize, c: &crate::cluster::Cluster| memory.get(c.kind).is_some();
                    if let Some((pos, ci)) = select_pick_up(map, allow, p, rng) {
                        if !memory.holds(&map.clusters[ci], pose, match_cm) {
                            self.target = Some(pos);
                            self.enter(PuTarget);
                        }
                    }
                }
            }
            PuTarget => {
                if carried.is_some() {
                    self.enter(Homing);
                } else {
                    let last = self.target.unwrap_or_default();
                    match track_puck(map, last, p) {
                        None => self.enter(PuScan),
                        Some((_, ci)) if !self.has_cache(Some(map.clusters[ci].kind)) => {
                            self.enter(PuScan)
                        }
                        Some((_, ci)) if self.memory.holds(&map.clusters[ci], pose, match_cm) => {
                            self.enter(PuScan)
                        }
                        Some(_) if elapsed > u64::from(p.timing.pick_up_timeout_steps) => {
                            self.enter(PuScan)
                        }
                        Some((pos, _)) => self.target = Some(pos),
                    }
                }
            }
            Homing => {
                if carried.is_none() {
                    self.enter(PuScan);
                } else if self.at_cache(map, pose) {
                    self.enter(DePush);
                }
            }
            DePush => {
                if elapsed >= u64::from(p.timing.push_steps) {
                    self.enter(DeBackup);
                }
            }
            DeBackup => {
                if elapsed >= u64::from(p.timing.backup_steps) {
                    if self.has_cache(self.last_carried) {
                        self.enter(Exile);
                    } else {
                        self.enter(PuScan);
                    }
                }
            }
            Exile => {
                if elapsed >= u64::from(p.timing.exile_steps) || !self.has_cache(self.last_carried)
                {
                    self.enter(PuScan);
                }
            }
            SpitOut => {
                if elapsed >= u64::from(p.timing.spit_out_steps) {
                    self.enter(PuScan);
                }
            }
        }
    }

    /// Angle (robot frame) toward the cache of `kind`.
    fn angle_to_cache(&self, kind: Option<PuckKind>, pose: &Pose) -> Option<f64> {
        let cache = self.memory.get(kind?)?;
        Some(pose.to_local(cache.pos).angle())
    }
}

impl Controller for CacheCons {
    fn step(&mut self, obs: &Observation, rng: &mut ChaCha8Rng) -> WheelCommand {
        use CacheConsState::*;
        self.clock.tick();
        let pose = obs.pose;
        self.pose = pose;
        let map = LocalMap::new(obs, &self.params);
        self.update_memory(&map, &pose, rng);
        self.transition(&map, &pose, rng);
        let carried = map.carried_kind();
        let command = match self.state {
            PuScan => self.driver.wander(obs, &self.params, rng),
            PuTarget => {
                let t = self.target.unwrap_or_default();
                steer_toward(t.angle(), &self.params.steering)
            }
            Homing => match (carried, self.angle_to_cache(carried, &pose)) {
                (Some(kind), Some(goal)) => {
                    self.driver
                        .drive(obs, PuckObstacles::AllBut(kind), goal, &self.params)
                }
                _ => WheelCommand::STOP,
            },
            DePush => FORWARD,
            DeBackup => REVERSE,
            Exile => match self.angle_to_cache(self.last_carried, &pose) {
                Some(toward) => self.driver.drive(
                    obs,
                    PuckObstacles::All,
                    wrap_angle(toward + PI),
                    &self.params,
                ),
                None => WheelCommand::STOP,
            },
            SpitOut => {
                let c = steer_toward(gaussian_angle(&self.params, rng), &self.params.steering);
                WheelCommand {
                    forward: -c.forward,
                    turn: c.turn,
                }
            }
        };
        if carried.is_some() {
            self.last_carried = carried;
        }
        command
    }

    fn state(&self) -> &'static str {
        self.state.name()
    }

    fn cache_points(&self) -> Vec<(PuckKind, Vec2)> {
        self.memory.points()
    }

    fn target(&self) -> Option<Vec2> {
        match self.state {
            CacheConsState::PuTarget => self.target.map(|t| self.pose.to_world(t)),
            CacheConsState::Homing => self
                .last_carried
                .and_then(|k| self.memory.get(k))
                .map(|c| c.pos),
            _ => None,
        }
    }
}
