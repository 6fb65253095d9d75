//! The local map a robot builds from one [`Observation`] (the paper's Sect. 2.2).
//!
//! Visible pucks per type, with pucks in other robots' grippers removed and
//! the carried puck added at the gripper; clusters of each type
//! ([`find_clusters`]); which clusters may be targeted (not near another
//! robot, centroid outside the turning circles, not the carried puck's own);
//! S_j, L_j, S and L (eq. 1-4); and whether the carried puck touches a
//! cluster. Also the obstacle points VFH+ reads and, for the metrics, the
//! clusters of the global map.
//!
//! ```
//! use colony_sim::{Observation, PuckKind, SeenPuck, Vec2};
//! use colony_sort::perception::LocalMap;
//! use colony_sort::params::SortParams;
//! let seen = |x, y| SeenPuck { kind: PuckKind(0), pos: Vec2::new(x, y), held_by_other: false };
//! let obs = Observation {
//!     gripper: Some(seen(8.0, 0.0)),
//!     pucks: vec![seen(15.0, 0.0), seen(40.0, 10.0)],
//!     ..Observation::default()
//! };
//! let map = LocalMap::new(&obs, &SortParams::default());
//! assert!(map.in_contact()); // the carried puck joined the puck 7 cm ahead
//! assert_eq!(map.l().unwrap().size(), 2);
//! assert_eq!(map.s().unwrap().size(), 1);
//! ```

use colony_sim::{Observation, Puck, PuckKind, Vec2};

use crate::cluster::{extreme, find_clusters, Cluster, Extreme};
use crate::params::{RobotParams, SortParams};
use crate::vfh::Obstacle;

/// A puck in the local map (robot frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapPuck {
    /// Its kind.
    pub kind: PuckKind,
    /// Its position (robot frame, cm).
    pub pos: Vec2,
    /// This is the puck in the robot's own gripper.
    pub carried: bool,
}

/// One robot's view: pucks, clusters and what may be targeted.
#[derive(Debug, Clone, PartialEq)]
pub struct LocalMap {
    /// Visible pucks (`held_by_other` removed), the carried one last.
    pub pucks: Vec<MapPuck>,
    /// Clusters of every type; member indices point into `pucks`.
    pub clusters: Vec<Cluster>,
    /// Per cluster: a member lies within `robot_proximity_cm` of another robot.
    pub near_robot: Vec<bool>,
    /// Per cluster: the centroid lies outside both turning circles.
    pub reachable: Vec<bool>,
    /// Index in `pucks` of the carried puck.
    pub carried: Option<usize>,
    /// Index in `clusters` of the carried puck's cluster.
    pub carried_cluster: Option<usize>,
    threshold: f64,
}

impl LocalMap {
    /// Builds the local map of `obs` with the perception and robot parameters.
    pub fn new(obs: &Observation, params: &SortParams) -> LocalMap {
        let per = &params.perception;
        let mut pucks: Vec<MapPuck> = obs
            .pucks
            .iter()
            .filter(|p| !p.held_by_other && finite(p.pos))
            .map(|p| MapPuck {
                kind: p.kind,
                pos: p.pos,
                carried: false,
            })
            .collect();
        let carried = match obs.gripper {
            Some(g) if finite(g.pos) => {
                pucks.push(MapPuck {
                    kind: g.kind,
                    pos: g.pos,
                    carried: true,
                });
                Some(pucks.len() - 1)
            }
            _ => None,
        };
        let points: Vec<(PuckKind, Vec2)> = pucks.iter().map(|p| (p.kind, p.pos)).collect();
        let clusters = find_clusters(&points, per.cluster_threshold_cm);
        let carried_cluster = carried.and_then(|i| clusters.iter().position(|c| c.contains(i)));

        let body = robot_body_points(obs, params.robot.body_radius_cm);
        let near_robot = clusters
            .iter()
            .map(|c| {
                c.members.iter().any(|m| {
                    body.iter()
                        .any(|b| b.distance(m.pos) < per.robot_proximity_cm)
                })
            })
            .collect();
        let reachable = clusters
            .iter()
            .map(|c| is_reachable(c.centroid, &params.robot))
            .collect();
        LocalMap {
            pucks,
            clusters,
            near_robot,
            reachable,
            carried,
            carried_cluster,
            threshold: per.cluster_threshold_cm,
        }
    }

    /// The kind of the carried puck.
    pub fn carried_kind(&self) -> Option<PuckKind> {
        self.carried.map(|i| self.pucks[i].kind)
    }

    /// The carried puck's cluster (size 1 when it touches nothing).
    pub fn carried_cluster(&self) -> Option<&Cluster> {
        self.carried_cluster.map(|c| &self.clusters[c])
    }

    /// The carried puck is part of a cluster of two or more: contact.
    pub fn in_contact(&self) -> bool {
        self.carried_cluster().is_some_and(|c| c.size() > 1)
    }

    /// Cluster `ci` may be targeted: no other robot near it, centroid
    /// reachable, and not the carried puck's cluster.
    pub fn is_candidate(&self, ci: usize) -> bool {
        ci < self.clusters.len()
            && !self.near_robot[ci]
            && self.reachable[ci]
            && Some(ci) != self.carried_cluster
    }

    /// The clusters that may be targeted, with their indices.
    pub fn candidates(&self) -> impl Iterator<Item = (usize, &Cluster)> {
        self.clusters
            .iter()
            .enumerate()
            .filter(|(i, _)| self.is_candidate(*i))
    }

    /// Some puck of another kind lies within the cluster threshold of a member of `ci`.
    pub fn touches_other_kind(&self, ci: usize) -> bool {
        let Some(c) = self.clusters.get(ci) else {
            return false;
        };
        self.pucks.iter().any(|p| {
            p.kind != c.kind
                && c.members
                    .iter()
                    .any(|m| m.pos.distance(p.pos) < self.threshold)
        })
    }

    /// S_j (eq. 1): the smallest cluster of `kind`, ties to the mid-line.
    pub fn s_j(&self, kind: PuckKind) -> Option<&Cluster> {
        extreme(
            self.clusters.iter().filter(|c| c.kind == kind),
            Extreme::Smallest,
        )
    }

    /// L_j (eq. 2): the largest cluster of `kind`, ties to the mid-line.
    pub fn l_j(&self, kind: PuckKind) -> Option<&Cluster> {
        extreme(
            self.clusters.iter().filter(|c| c.kind == kind),
            Extreme::Largest,
        )
    }

    /// S (eq. 3): the smallest cluster of any kind.
    pub fn s(&self) -> Option<&Cluster> {
        extreme(&self.clusters, Extreme::Smallest)
    }

    /// L (eq. 4): the largest cluster of any kind.
    pub fn l(&self) -> Option<&Cluster> {
        extreme(&self.clusters, Extreme::Largest)
    }

    /// Index of the cluster holding puck `index`.
    pub fn cluster_of(&self, index: usize) -> Option<usize> {
        self.clusters.iter().position(|c| c.contains(index))
    }
}

fn finite(p: Vec2) -> bool {
    p.x.is_finite() && p.y.is_finite()
}

/// Other robots' centres and the obstacle points within `body_radius` of one.
fn robot_body_points(obs: &Observation, body_radius: f64) -> Vec<Vec2> {
    if obs.robots.is_empty() {
        return Vec::new();
    }
    let mut body: Vec<Vec2> = obs.robots.clone();
    body.extend(
        obs.obstacles
            .iter()
            .filter(|o| obs.robots.iter().any(|r| r.distance(**o) <= body_radius)),
    );
    body
}

/// A robot-frame point is reachable unless it lies inside one of the two
/// turning circles (centres (`turning_centre_x_cm`, +-`turning_radius_cm`)).
pub fn is_reachable(p: Vec2, robot: &RobotParams) -> bool {
    let r = robot.turning_radius_cm;
    let dx = p.x - robot.turning_centre_x_cm;
    let dy = (p.y - r).abs().min((p.y + r).abs());
    dx.hypot(dy) > r
}

/// +1 if the left half of the view holds no more wall and robot points than
/// the right half, else -1 (pucks are ignored).
pub fn freer_side(obs: &Observation) -> f64 {
    let left = obs.obstacles.iter().filter(|o| o.y > 0.0).count();
    let right = obs.obstacles.iter().filter(|o| o.y < 0.0).count();
    if left <= right {
        1.0
    } else {
        -1.0
    }
}

/// Which pucks VFH+ avoids.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PuckObstacles {
    /// None: pucks are invisible to VFH+ (BHD).
    Ignore,
    /// Every visible puck except the carried one.
    All,
    /// Every visible puck except the carried one and those of this kind
    /// (homing into the cache cluster).
    AllBut(PuckKind),
}

/// The obstacles VFH+ reads: every wall and robot point of `obs`, plus pucks
/// as discs of `puck_radius` as `which` says.
pub fn vfh_obstacles(obs: &Observation, which: PuckObstacles, puck_radius: f64) -> Vec<Obstacle> {
    let mut out: Vec<Obstacle> = obs
        .obstacles
        .iter()
        .filter(|p| finite(**p))
        .map(|&p| Obstacle::point(p))
        .collect();
    let keep = |k: PuckKind| match which {
        PuckObstacles::Ignore => false,
        PuckObstacles::All => true,
        PuckObstacles::AllBut(skip) => k != skip,
    };
    out.extend(
        obs.pucks
            .iter()
            .filter(|p| keep(p.kind) && finite(p.pos))
            .map(|p| Obstacle {
                pos: p.pos,
                radius: puck_radius,
            }),
    );
    out
}

/// Clusters of the global map (world frame), defined exactly as in the local map.
pub fn global_clusters(pucks: &[Puck], threshold: f64) -> Vec<Cluster> {
    let points: Vec<(PuckKind, Vec2)> = pucks.iter().map(|p| (p.kind, p.pos)).collect();
    find_clusters(&points, threshold)
}
