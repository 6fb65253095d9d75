//! Clusters: connected components of the graph that joins same-type pucks
//! closer than a threshold (the paper's Sect. 2.2).
//!
//! The same function serves a robot's local map (robot frame) and the global
//! map the metrics read (world frame). Single pucks are clusters of size 1.
//!
//! ```
//! use colony_sim::{PuckKind, Vec2};
//! use colony_sort::cluster::find_clusters;
//! let a = PuckKind(0);
//! let pucks = [(a, Vec2::new(0.0, 0.0)), (a, Vec2::new(9.0, 0.0)), (a, Vec2::new(30.0, 0.0))];
//! let clusters = find_clusters(&pucks, 9.45);
//! assert_eq!(clusters.iter().map(|c| c.size()).collect::<Vec<_>>(), vec![2, 1]);
//! ```

use colony_sim::{PuckKind, Vec2};

/// One puck of a cluster.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Member {
    /// Index of the puck in the slice the clusters were built from.
    pub index: usize,
    /// Its position (cm).
    pub pos: Vec2,
    /// Number of edges at this puck in the cluster graph.
    pub degree: usize,
}

/// A connected component of one puck type.
#[derive(Debug, Clone, PartialEq)]
pub struct Cluster {
    /// The kind of its pucks.
    pub kind: PuckKind,
    /// Members in increasing `index` order.
    pub members: Vec<Member>,
    /// The mean of its pucks' positions.
    pub centroid: Vec2,
}

impl Cluster {
    /// Number of pucks: the paper's size(G).
    pub fn size(&self) -> usize {
        self.members.len()
    }

    /// Whether the puck at `index` belongs to this cluster.
    pub fn contains(&self, index: usize) -> bool {
        self.members.iter().any(|m| m.index == index)
    }

    /// Distance from `p` to the nearest member (infinite for an empty cluster).
    pub fn nearest_member_distance(&self, p: Vec2) -> f64 {
        self.members
            .iter()
            .map(|m| m.pos.distance(p))
            .fold(f64::INFINITY, f64::min)
    }

    /// The puck to target for pick-up: of the left-most (largest y) and the
    /// right-most (smallest y) member, the one of lower degree, the left-most
    /// on a tie (the paper's Sect. 2.5; frame: robot, y to the left).
    pub fn end_puck(&self) -> Option<&Member> {
        let mut left = self.members.first()?;
        let mut right = left;
        for m in &self.members {
            if m.pos.y > left.pos.y {
                left = m;
            }
            if m.pos.y < right.pos.y {
                right = m;
            }
        }
        Some(if left.degree <= right.degree {
            left
        } else {
            right
        })
    }
}

/// Which end of the size order to pick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Extreme {
    /// The smallest one.
    Smallest,
    /// The largest one.
    Largest,
}

/// The smallest or largest cluster (eq. 1-4); ties go to the cluster whose
/// centroid is nearer the robot's mid-line (smaller |y|), then to the first.
pub fn extreme<'a, I>(clusters: I, which: Extreme) -> Option<&'a Cluster>
where
    I: IntoIterator<Item = &'a Cluster>,
{
    let mut best: Option<&Cluster> = None;
    for c in clusters {
        best = match best {
            None => Some(c),
            Some(b) => {
                let better = match which {
                    Extreme::Smallest => c.size() < b.size(),
                    Extreme::Largest => c.size() > b.size(),
                };
                let tie_nearer = c.size() == b.size() && c.centroid.y.abs() < b.centroid.y.abs();
                if better || tie_nearer {
                    Some(c)
                } else {
                    Some(b)
                }
            }
        };
    }
    best
}

/// Clusters of `pucks` (kind and position): two pucks of the same kind are
/// joined when strictly closer than `threshold` (none when it is 0 or less). Clusters come in order of
/// their first member's index; every puck is in exactly one cluster.
pub fn find_clusters(pucks: &[(PuckKind, Vec2)], threshold: f64) -> Vec<Cluster> {
    let n = pucks.len();
    let mut parent: Vec<usize> = (0..n).collect();
    let mut degree = vec![0usize; n];
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let t2 = threshold * threshold;
    // Sweep along x: only pucks less than `threshold` apart in x can be joined, so a pair is
    // looked at only when it is that close in x, not every pair of the global map of a large
    // swarm. Components, degrees and roots do not depend on the order pairs are met in.
    let mut by_x: Vec<usize> = (0..n).collect();
    by_x.sort_by(|&a, &b| pucks[a].1.x.total_cmp(&pucks[b].1.x).then(a.cmp(&b)));
    for (k, &i) in by_x.iter().enumerate() {
        for &j in &by_x[k + 1..] {
            let d = pucks[i].1 - pucks[j].1;
            if -d.x >= threshold {
                break;
            }
            let close = d.x * d.x + d.y * d.y < t2;
            if pucks[i].0 != pucks[j].0 || !close {
                continue;
            }
            degree[i] += 1;
            degree[j] += 1;
            let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
            if ri != rj {
                // The smaller index becomes the root, so roots are first members.
                parent[ri.max(rj)] = ri.min(rj);
            }
        }
    }
    let mut slot = vec![usize::MAX; n];
    let mut clusters: Vec<Cluster> = Vec::new();
    for i in 0..n {
        let r = root(&mut parent, i);
        if slot[r] == usize::MAX {
            slot[r] = clusters.len();
            clusters.push(Cluster {
                kind: pucks[i].0,
                members: Vec::new(),
                centroid: Vec2::ZERO,
            });
        }
        clusters[slot[r]].members.push(Member {
            index: i,
            pos: pucks[i].1,
            degree: degree[i],
        });
    }
    for c in &mut clusters {
        let sum = c.members.iter().fold(Vec2::ZERO, |s, m| s + m.pos);
        c.centroid = sum * (1.0 / c.members.len() as f64);
    }
    clusters
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Every pair compared: the definition the sweep must match.
    fn brute_force(pucks: &[(PuckKind, Vec2)], threshold: f64) -> Vec<(Vec<usize>, Vec<usize>)> {
        let n = pucks.len();
        let t2 = threshold * threshold;
        let joined = |i: usize, j: usize| {
            let d = pucks[i].1 - pucks[j].1;
            i != j && pucks[i].0 == pucks[j].0 && d.x * d.x + d.y * d.y < t2
        };
        let mut label: Vec<usize> = (0..n).collect();
        let mut changed = true;
        while changed {
            changed = false;
            for i in 0..n {
                for j in 0..n {
                    if joined(i, j) && label[j] < label[i] {
                        label[i] = label[j];
                        changed = true;
                    }
                }
            }
        }
        let mut out: Vec<(Vec<usize>, Vec<usize>)> = Vec::new();
        for first in 0..n {
            let members: Vec<usize> = (0..n).filter(|&i| label[i] == first).collect();
            if !members.is_empty() {
                let degrees = members
                    .iter()
                    .map(|&i| (0..n).filter(|&j| joined(i, j)).count())
                    .collect();
                out.push((members, degrees));
            }
        }
        out
    }

    proptest! {
        #[test]
        fn the_sweep_finds_the_clusters_of_every_pair_compared(
            pts in prop::collection::vec((0u8..3, -60.0..60.0f64, -60.0..60.0f64), 0..80),
            threshold in 0.5..20.0f64,
        ) {
            let pucks: Vec<(PuckKind, Vec2)> =
                pts.iter().map(|&(k, x, y)| (PuckKind(k), Vec2::new(x, y))).collect();
            let got: Vec<(Vec<usize>, Vec<usize>)> = find_clusters(&pucks, threshold)
                .iter()
                .map(|c| (
                    c.members.iter().map(|m| m.index).collect(),
                    c.members.iter().map(|m| m.degree).collect(),
                ))
                .collect();
            prop_assert_eq!(got, brute_force(&pucks, threshold));
        }
    }

    #[test]
    fn pucks_at_the_same_x_and_unusable_positions_are_handled() {
        let a = PuckKind(0);
        let pucks = [
            (a, Vec2::new(0.0, 0.0)),
            (a, Vec2::new(0.0, 5.0)),
            (a, Vec2::new(f64::NAN, 0.0)),
            (a, Vec2::new(0.0, 30.0)),
            (a, Vec2::new(f64::INFINITY, 0.0)),
        ];
        let sizes: Vec<usize> = find_clusters(&pucks, 9.45)
            .iter()
            .map(Cluster::size)
            .collect();
        assert_eq!(sizes, vec![2, 1, 1, 1]);
    }
}
