//! A CACHECONS robot's memory: one cache point per puck type (world frame)
//! and the remembered size m_j of its cluster (Sect. 2.6.1, 2.6.2).
//!
//! Every step the robot refreshes m_j from the visible cache cluster C_j
//! (eq. 5) and considers adopting the centroid of the largest visible
//! cluster as a new cache point when it is larger than m_j. Cache separation
//! keeps caches of different types apart: a candidate within the separation
//! distance of other types' caches is adopted only if it is larger than all
//! of them, and they are then forgotten.

use std::collections::BTreeMap;

use colony_sim::{Pose, PuckKind, Vec2};

use crate::cluster::Cluster;
use crate::perception::LocalMap;

/// One remembered cache.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CachePoint {
    /// World frame.
    pub pos: Vec2,
    /// m_j: the largest size this robot has seen the cache cluster reach.
    pub size: f64,
}

/// How caches of different types are kept apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Separation {
    /// No rule (CacheCons_Ignore).
    Ignore,
    /// A candidate closer than `distance_cm` to other types' caches is adopted
    /// only if larger than each of them, and they are forgotten.
    AcceptLarger {
        /// How close counts as too close (cm).
        distance_cm: f64,
    },
}

/// The cache points of one robot (m_j = 0 for a type without one).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CacheMemory {
    caches: BTreeMap<PuckKind, CachePoint>,
}

impl CacheMemory {
    /// A memory with no cache points.
    pub fn new() -> CacheMemory {
        CacheMemory::default()
    }

    /// A memory holding the given caches, each remembered at `size`.
    pub fn preset(points: impl IntoIterator<Item = (PuckKind, Vec2)>, size: f64) -> CacheMemory {
        CacheMemory {
            caches: points
                .into_iter()
                .map(|(k, pos)| (k, CachePoint { pos, size }))
                .collect(),
        }
    }

    /// The cache point for `kind`, if there is one.
    pub fn get(&self, kind: PuckKind) -> Option<&CachePoint> {
        self.caches.get(&kind)
    }

    /// m_j: the remembered size (0 without a cache).
    pub fn remembered(&self, kind: PuckKind) -> f64 {
        self.get(kind).map_or(0.0, |c| c.size)
    }

    /// Every cache point, in kind order.
    pub fn points(&self) -> Vec<(PuckKind, Vec2)> {
        self.caches.iter().map(|(k, c)| (*k, c.pos)).collect()
    }

    /// Forgets every cache (the memory-erasing variant).
    pub fn clear(&mut self) {
        self.caches.clear();
    }

    /// C_j: the index of the visible cluster of `kind` with a member nearest
    /// the cache point, if that member is closer than `match_cm`.
    pub fn cache_cluster(
        &self,
        map: &LocalMap,
        pose: &Pose,
        kind: PuckKind,
        match_cm: f64,
    ) -> Option<usize> {
        let cache = pose.to_local(self.get(kind)?.pos);
        map.clusters
            .iter()
            .enumerate()
            .filter(|(_, c)| c.kind == kind)
            .map(|(i, c)| (i, c.nearest_member_distance(cache)))
            .filter(|(_, d)| *d < match_cm)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }

    /// Whether `cluster` (robot frame) is, or is visibly joined to, the cache
    /// cluster of its kind: a member lies closer than `match_cm` to the cache point.
    pub fn holds(&self, cluster: &Cluster, pose: &Pose, match_cm: f64) -> bool {
        self.get(cluster.kind)
            .is_some_and(|c| cluster.nearest_member_distance(pose.to_local(c.pos)) < match_cm)
    }

    /// Eq. 5: m_j = max(m_j, size(C_j)) for every type whose cache cluster is in view.
    pub fn update_sizes(&mut self, map: &LocalMap, pose: &Pose, match_cm: f64) {
        let kinds: Vec<PuckKind> = self.caches.keys().copied().collect();
        for kind in kinds {
            if let Some(ci) = self.cache_cluster(map, pose, kind, match_cm) {
                let size = map.clusters[ci].size() as f64;
                if let Some(c) = self.caches.get_mut(&kind) {
                    c.size = c.size.max(size);
                }
            }
        }
    }

    /// Considers `candidate` (robot frame) as the new cache of its kind:
    /// adopted if its size exceeds m_j and the separation rule allows it.
    /// Returns whether it was adopted.
    pub fn consider(&mut self, candidate: &Cluster, pose: &Pose, separation: Separation) -> bool {
        let size = candidate.size() as f64;
        if size <= self.remembered(candidate.kind) {
            return false;
        }
        let world = pose.to_world(candidate.centroid);
        if let Separation::AcceptLarger { distance_cm } = separation {
            let conflicts: Vec<PuckKind> = self
                .caches
                .iter()
                .filter(|(k, c)| **k != candidate.kind && c.pos.distance(world) < distance_cm)
                .map(|(k, _)| *k)
                .collect();
            if conflicts.iter().any(|k| size <= self.remembered(*k)) {
                return false;
            }
            for k in conflicts {
                self.caches.remove(&k);
            }
        }
        self.caches
            .insert(candidate.kind, CachePoint { pos: world, size });
        true
    }
}
