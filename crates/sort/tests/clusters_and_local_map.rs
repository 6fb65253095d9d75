//! Clusters, S/L, end pucks and the local map on hand-built layouts.

use colony_sim::{Observation, Puck, PuckId, PuckKind, SeenPuck, Vec2};
use colony_sort::cluster::{extreme, find_clusters, Extreme};
use colony_sort::params::SortParams;
use colony_sort::perception::{
    freer_side, global_clusters, is_reachable, vfh_obstacles, LocalMap, PuckObstacles,
};

const A: PuckKind = PuckKind(0);
const B: PuckKind = PuckKind(1);

fn seen(kind: PuckKind, x: f64, y: f64) -> SeenPuck {
    SeenPuck {
        kind,
        pos: Vec2::new(x, y),
        held_by_other: false,
    }
}

fn sizes(points: &[(PuckKind, Vec2)]) -> Vec<usize> {
    find_clusters(points, 9.45)
        .iter()
        .map(|c| c.size())
        .collect()
}

#[test]
fn chain_just_under_the_threshold_is_one_cluster() {
    let chain: Vec<_> = (0..4)
        .map(|i| (A, Vec2::new(i as f64 * 9.44, 0.0)))
        .collect();
    let clusters = find_clusters(&chain, 9.45);
    assert_eq!(clusters.len(), 1);
    let degrees: Vec<usize> = clusters[0].members.iter().map(|m| m.degree).collect();
    assert_eq!(degrees, vec![1, 2, 2, 1]);
    assert!((clusters[0].centroid.x - 1.5 * 9.44).abs() < 1e-9);
}

#[test]
fn chain_just_over_the_threshold_falls_apart() {
    let chain: Vec<_> = (0..4)
        .map(|i| (A, Vec2::new(i as f64 * 9.46, 0.0)))
        .collect();
    assert_eq!(sizes(&chain), vec![1, 1, 1, 1]);
    // Exactly at the threshold is not "closer than" it.
    let pair = [(A, Vec2::new(0.0, 0.0)), (A, Vec2::new(9.45, 0.0))];
    assert_eq!(sizes(&pair), vec![1, 1]);
}

#[test]
fn interleaved_types_form_homogeneous_clusters() {
    // A B A B, 4 cm apart: each type joins its own (8 cm apart), never the other.
    let row: Vec<_> = (0..4)
        .map(|i| {
            (
                if i % 2 == 0 { A } else { B },
                Vec2::new(i as f64 * 4.0, 0.0),
            )
        })
        .collect();
    let clusters = find_clusters(&row, 9.45);
    assert_eq!(clusters.len(), 2);
    for c in &clusters {
        assert_eq!(c.size(), 2);
        assert!(c.members.iter().all(|m| row[m.index].0 == c.kind));
    }
}

#[test]
fn single_pucks_are_clusters_of_size_one() {
    let lone = [(A, Vec2::new(0.0, 0.0)), (B, Vec2::new(50.0, 0.0))];
    let clusters = find_clusters(&lone, 9.45);
    assert_eq!(clusters.len(), 2);
    assert!(clusters
        .iter()
        .all(|c| c.size() == 1 && c.members[0].degree == 0));
    assert!(find_clusters(&[], 9.45).is_empty());
}

#[test]
fn smallest_and_largest_ties_go_to_the_cluster_nearer_the_mid_line() {
    let obs = Observation {
        pucks: vec![
            seen(A, 40.0, 20.0), // single, far off the mid-line
            seen(A, 40.0, -5.0), // single, near the mid-line
            seen(B, 30.0, 30.0), // pair of B, off the mid-line
            seen(B, 30.0, 36.0),
            seen(B, 50.0, -12.0), // pair of B, nearer the mid-line
            seen(B, 50.0, -6.0),
        ],
        ..Observation::default()
    };
    let map = LocalMap::new(&obs, &SortParams::default());
    let s = map.s().unwrap();
    assert_eq!((s.size(), s.centroid), (1, Vec2::new(40.0, -5.0)));
    assert_eq!(map.s_j(A).unwrap().centroid, Vec2::new(40.0, -5.0));
    assert_eq!(map.l_j(A).unwrap().size(), 1);
    let lb = map.l_j(B).unwrap();
    assert_eq!((lb.size(), lb.centroid), (2, Vec2::new(50.0, -9.0)));
    assert_eq!(map.l().unwrap().centroid, Vec2::new(50.0, -9.0));
    assert_eq!(map.s_j(PuckKind(7)), None);
}

#[test]
fn largest_of_any_type_wins_over_ties() {
    let pts = [
        (A, Vec2::new(0.0, 30.0)),
        (A, Vec2::new(5.0, 30.0)),
        (A, Vec2::new(10.0, 30.0)),
        (B, Vec2::new(0.0, 0.0)),
        (B, Vec2::new(5.0, 0.0)),
    ];
    let clusters = find_clusters(&pts, 9.45);
    assert_eq!(extreme(&clusters, Extreme::Largest).unwrap().kind, A);
    assert_eq!(extreme(&clusters, Extreme::Smallest).unwrap().kind, B);
}

#[test]
fn end_puck_is_the_outer_puck_of_lower_degree() {
    // Left end (largest y) has degree 2, right end degree 1: the right end is chosen.
    let pts = [
        (A, Vec2::new(30.0, 10.0)), // left end, near two others
        (A, Vec2::new(34.0, 4.0)),
        (A, Vec2::new(26.0, 4.0)),
        (A, Vec2::new(33.0, -4.0)), // right end, one neighbour
    ];
    let clusters = find_clusters(&pts, 9.45);
    assert_eq!(clusters.len(), 1);
    let end = clusters[0].end_puck().unwrap();
    assert_eq!(end.pos, Vec2::new(33.0, -4.0));
    assert_eq!(end.degree, 1);

    // Mirror it: now the left end is the lonelier one.
    let mirrored: Vec<_> = pts
        .iter()
        .map(|(k, p)| (*k, Vec2::new(p.x, -p.y)))
        .collect();
    let end = find_clusters(&mirrored, 9.45)[0]
        .end_puck()
        .copied()
        .unwrap();
    assert_eq!(end.pos, Vec2::new(33.0, 4.0));

    // Equal degrees: the left-most.
    let pair = [(A, Vec2::new(30.0, -3.0)), (A, Vec2::new(30.0, 3.0))];
    let end = find_clusters(&pair, 9.45)[0].end_puck().copied().unwrap();
    assert_eq!(end.pos, Vec2::new(30.0, 3.0));
}

#[test]
fn pucks_in_other_grippers_vanish_and_the_carried_puck_joins_the_map() {
    let obs = Observation {
        gripper: Some(seen(A, 8.0, 0.0)),
        pucks: vec![
            SeenPuck {
                held_by_other: true,
                ..seen(A, 16.0, 0.0)
            },
            seen(A, 40.0, 0.0),
        ],
        ..Observation::default()
    };
    let map = LocalMap::new(&obs, &SortParams::default());
    assert_eq!(map.pucks.len(), 2);
    assert!(map.pucks[1].carried);
    assert_eq!(map.carried_kind(), Some(A));
    assert_eq!(map.carried_cluster().unwrap().size(), 1);
    assert!(!map.in_contact(), "the held puck must not count as contact");
    // The carried puck's cluster is never a target.
    let ci = map.carried_cluster.unwrap();
    assert!(!map.is_candidate(ci));
}

#[test]
fn carried_puck_touching_a_same_type_puck_is_contact_but_not_another_type() {
    let params = SortParams::default();
    let touching = Observation {
        gripper: Some(seen(A, 8.0, 0.0)),
        pucks: vec![seen(A, 14.0, 2.0), seen(A, 20.0, 2.0)],
        ..Observation::default()
    };
    let map = LocalMap::new(&touching, &params);
    assert!(map.in_contact());
    assert_eq!(map.carried_cluster().unwrap().size(), 3);

    let other_type = Observation {
        gripper: Some(seen(A, 8.0, 0.0)),
        pucks: vec![seen(B, 14.0, 2.0)],
        ..Observation::default()
    };
    assert!(!LocalMap::new(&other_type, &params).in_contact());
}

#[test]
fn clusters_near_another_robot_are_not_targets() {
    let obs = Observation {
        pucks: vec![seen(A, 40.0, 0.0), seen(A, 40.0, 40.0)],
        robots: vec![Vec2::new(60.0, 0.0)],
        // A body point of that robot 9 cm from the first puck.
        obstacles: vec![Vec2::new(49.0, 0.0)],
        ..Observation::default()
    };
    let map = LocalMap::new(&obs, &SortParams::default());
    assert_eq!(map.near_robot, vec![true, false]);
    let targets: Vec<usize> = map.candidates().map(|(i, _)| i).collect();
    assert_eq!(targets, vec![1]);
}

#[test]
fn targets_inside_the_turning_circles_are_unreachable() {
    let robot = SortParams::default().robot;
    assert!(is_reachable(Vec2::new(30.0, 0.0), &robot));
    assert!(is_reachable(Vec2::new(8.0, 0.0), &robot));
    assert!(!is_reachable(Vec2::new(2.0, 10.0), &robot));
    assert!(!is_reachable(Vec2::new(2.0, -10.0), &robot));
    assert!(is_reachable(Vec2::new(2.0, 30.0), &robot));
}

#[test]
fn vfh_sees_walls_always_and_pucks_as_asked() {
    let obs = Observation {
        gripper: Some(seen(A, 8.0, 0.0)),
        pucks: vec![seen(A, 30.0, 0.0), seen(B, 30.0, 10.0)],
        obstacles: vec![Vec2::new(50.0, 0.0)],
        ..Observation::default()
    };
    assert_eq!(vfh_obstacles(&obs, PuckObstacles::Ignore, 3.15).len(), 1);
    let all = vfh_obstacles(&obs, PuckObstacles::All, 3.15);
    assert_eq!(all.len(), 3, "the carried puck is not an obstacle");
    assert!(all[1..].iter().all(|o| o.radius == 3.15));
    let but_a = vfh_obstacles(&obs, PuckObstacles::AllBut(A), 3.15);
    assert_eq!(but_a.len(), 2);
    assert_eq!(but_a[1].pos, Vec2::new(30.0, 10.0));
}

#[test]
fn freer_side_is_the_one_with_fewer_obstacle_points() {
    let mut obs = Observation {
        obstacles: vec![
            Vec2::new(20.0, -5.0),
            Vec2::new(20.0, -6.0),
            Vec2::new(20.0, 4.0),
        ],
        ..Observation::default()
    };
    assert_eq!(freer_side(&obs), 1.0);
    obs.obstacles.push(Vec2::new(20.0, 5.0));
    assert_eq!(freer_side(&obs), 1.0, "a tie turns left");
    obs.obstacles.push(Vec2::new(20.0, 6.0));
    assert_eq!(freer_side(&obs), -1.0);
}

#[test]
fn global_map_clusters_world_pucks_the_same_way() {
    let pucks: Vec<Puck> = [(A, -80.0), (A, -72.0), (B, -64.0), (A, 0.0)]
        .iter()
        .enumerate()
        .map(|(i, (k, x))| Puck {
            id: PuckId(i),
            kind: *k,
            pos: Vec2::new(*x, 50.0),
        })
        .collect();
    let clusters = global_clusters(&pucks, 9.45);
    let shape: Vec<(PuckKind, usize)> = clusters.iter().map(|c| (c.kind, c.size())).collect();
    assert_eq!(shape, vec![(A, 2), (B, 1), (A, 1)]);
}
