//! The methods' state machines driven with hand-made observations.

use colony_sim::{Observation, Pose, PuckKind, SeenPuck, Vec2, WheelCommand};
use colony_sort::methods::{
    build, informed_caches, Bhd, BhdState, CacheCons, CacheConsState, CacheConsVariant,
    CacheMemory, Method, ProbSeek, ProbSeekState, Separation,
};
use colony_sort::params::SortParams;
use colony_sort::perception::LocalMap;
use colony_sort::Controller;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const A: PuckKind = PuckKind(0);
const B: PuckKind = PuckKind(1);

fn seen(kind: PuckKind, x: f64, y: f64) -> SeenPuck {
    SeenPuck {
        kind,
        pos: Vec2::new(x, y),
        held_by_other: false,
    }
}

fn rng() -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(7)
}

fn params() -> SortParams {
    SortParams::default()
}

/// The carried puck touching a cluster of two just ahead.
fn contact(kind: PuckKind) -> Observation {
    Observation {
        gripper: Some(seen(kind, 8.0, 0.0)),
        pucks: vec![seen(kind, 15.0, 0.0), seen(kind, 21.0, 0.0)],
        ..Observation::default()
    }
}

fn carrying(kind: PuckKind) -> Observation {
    Observation {
        gripper: Some(seen(kind, 8.0, 0.0)),
        ..Observation::default()
    }
}

/// Steps `c` with `obs` until `done` holds, at most `max` times; returns the steps taken.
fn step_until(
    c: &mut dyn Controller,
    obs: &Observation,
    rng: &mut ChaCha8Rng,
    max: usize,
    done: impl Fn(&dyn Controller) -> bool,
) -> Option<usize> {
    for i in 1..=max {
        c.step(obs, rng);
        if done(c) {
            return Some(i);
        }
    }
    None
}

// ---------------------------------------------------------------- BHD

#[test]
fn bhd_pushes_on_contact_backs_up_five_steps_turns_and_goes_forward() {
    let mut bhd = Bhd::new(&params());
    let mut r = rng();
    let empty = Observation::default();
    assert_eq!(
        bhd.step(&empty, &mut r),
        WheelCommand {
            forward: 1.0,
            turn: 0.0
        }
    );
    assert_eq!(bhd.current(), BhdState::Forward);

    let c = bhd.step(&contact(A), &mut r);
    assert_eq!((bhd.state(), c.forward), ("PUSH", 1.0));

    for i in 0..5 {
        let c = bhd.step(&empty, &mut r);
        assert_eq!(bhd.state(), "BACKUP", "backup step {i}");
        assert_eq!(
            c,
            WheelCommand {
                forward: -1.0,
                turn: 0.0
            }
        );
    }
    let c = bhd.step(&empty, &mut r);
    assert_eq!(bhd.state(), "TURN");
    assert_eq!((c.forward, c.turn.abs()), (0.0, 1.0));

    let mut turn_steps = 1;
    while bhd.step(&empty, &mut r)
        != (WheelCommand {
            forward: 1.0,
            turn: 0.0,
        })
    {
        turn_steps += 1;
        assert!(turn_steps <= 10, "a turn lasts at most 10 steps");
    }
    assert!(
        turn_steps >= 5,
        "a turn lasts at least 5 steps, took {turn_steps}"
    );
    assert_eq!(bhd.state(), "FORWARD");
}

#[test]
fn bhd_turns_toward_the_freer_side_when_a_wall_is_ahead() {
    let mut obstacles: Vec<Vec2> = (-40..=40).map(|y| Vec2::new(16.0, y as f64)).collect();
    // More wall on the right: turn left.
    obstacles.extend((0..20).map(|i| Vec2::new(10.0, -25.0 - i as f64)));
    let obs = Observation {
        obstacles,
        ..Observation::default()
    };
    let mut bhd = Bhd::new(&params());
    let c = bhd.step(&obs, &mut rng());
    assert_eq!(bhd.current(), BhdState::Turn);
    assert_eq!((c.forward, c.turn), (0.0, 1.0));
}

#[test]
fn bhd_does_not_avoid_pucks() {
    let obs = Observation {
        pucks: (-5..=5).map(|y| seen(A, 16.0, y as f64 * 4.0)).collect(),
        ..Observation::default()
    };
    let mut bhd = Bhd::new(&params());
    let mut r = rng();
    for _ in 0..5 {
        assert_eq!(
            bhd.step(&obs, &mut r),
            WheelCommand {
                forward: 1.0,
                turn: 0.0
            }
        );
    }
    assert_eq!(bhd.state(), "FORWARD");
}

// ---------------------------------------------------------------- PROBSEEK

#[test]
fn probseek_targets_a_lone_puck_then_scans_for_deposit_once_holding_it() {
    let mut ps = ProbSeek::new(&params());
    let mut r = rng();
    let obs = Observation {
        pucks: vec![seen(A, 30.0, 4.0)],
        ..Observation::default()
    };
    assert_eq!(ps.state(), "PU_SCAN");
    // p_pick(1) = 1/4 per step.
    let steps = step_until(&mut ps, &obs, &mut r, 60, |c| c.state() == "PU_TARGET");
    assert!(steps.is_some(), "never targeted the puck");
    assert_eq!(ps.local_target(), Some(Vec2::new(30.0, 4.0)));
    // Steering straight at it, without VFH+.
    let c = ps.step(&obs, &mut r);
    assert!(c.turn > 0.0 && c.forward > 0.5);
    ps.step(&carrying(A), &mut r);
    assert_eq!(ps.current(), ProbSeekState::DeScan);
}

#[test]
fn probseek_is_deterministic_for_a_seed() {
    let obs = Observation {
        pucks: vec![seen(A, 30.0, 4.0), seen(B, 40.0, -10.0)],
        obstacles: (-20..20).map(|y| Vec2::new(35.0, y as f64)).collect(),
        ..Observation::default()
    };
    let run = || {
        let mut ps = ProbSeek::new(&params());
        let mut r = ChaCha8Rng::seed_from_u64(99);
        (0..40)
            .map(|_| (ps.step(&obs, &mut r), ps.state()))
            .collect::<Vec<_>>()
    };
    assert_eq!(run(), run());
}

#[test]
fn probseek_targets_the_lonelier_end_of_the_smallest_cluster() {
    let mut ps = ProbSeek::new(&params());
    let mut r = rng();
    // Smallest cluster: a pair (a triple elsewhere); both ends have degree 1: the left one.
    let obs = Observation {
        pucks: vec![
            seen(A, 30.0, 3.0),
            seen(A, 30.0, -3.0),
            seen(B, 40.0, 30.0),
            seen(B, 45.0, 30.0),
            seen(B, 50.0, 30.0),
        ],
        ..Observation::default()
    };
    step_until(&mut ps, &obs, &mut r, 400, |c| c.state() == "PU_TARGET").unwrap();
    assert_eq!(ps.local_target(), Some(Vec2::new(30.0, 3.0)));
}

#[test]
fn probseek_gives_up_a_lost_target_and_one_that_takes_too_long() {
    let obs = Observation {
        pucks: vec![seen(A, 30.0, 0.0)],
        ..Observation::default()
    };
    let mut r = rng();
    let mut ps = ProbSeek::new(&params());
    step_until(&mut ps, &obs, &mut r, 60, |c| c.state() == "PU_TARGET").unwrap();
    // The puck jumps 15 cm: lost.
    let moved = Observation {
        pucks: vec![seen(A, 30.0, 15.0)],
        ..Observation::default()
    };
    ps.step(&moved, &mut r);
    assert_eq!(ps.state(), "PU_SCAN");

    let mut ps = ProbSeek::new(&params());
    step_until(&mut ps, &obs, &mut r, 60, |c| c.state() == "PU_TARGET").unwrap();
    for _ in 0..20 {
        ps.step(&obs, &mut r);
        assert_eq!(ps.state(), "PU_TARGET");
    }
    ps.step(&obs, &mut r);
    assert_eq!(ps.state(), "PU_SCAN", "pick-up timeout is 20 steps");
}

#[test]
fn probseek_deposits_at_a_large_cluster_then_backs_up_and_turns() {
    let mut ps = ProbSeek::new(&params());
    let mut r = rng();
    ps.step(&carrying(A), &mut r);
    assert_eq!(ps.state(), "DE_SCAN");
    let mut big = carrying(A);
    big.pucks = (0..8)
        .map(|i| seen(A, 40.0 + 5.0 * (i % 4) as f64, 5.0 * (i / 4) as f64))
        .collect();
    step_until(&mut ps, &big, &mut r, 200, |c| c.state() == "DE_TARGET").unwrap();
    ps.step(&contact(A), &mut r);
    assert_eq!(ps.state(), "DE_PUSH");
    let empty = Observation::default();
    let states: Vec<&str> = (0..7)
        .map(|_| {
            ps.step(&empty, &mut r);
            ps.state()
        })
        .collect();
    assert_eq!(states[..5], ["DE_BACKUP"; 5]);
    assert_eq!(states[5], "DE_TURN");
    step_until(&mut ps, &empty, &mut r, 10, |c| c.state() == "PU_SCAN").unwrap();
}

#[test]
fn probseek_never_targets_another_type_for_deposit() {
    let mut ps = ProbSeek::new(&params());
    let mut r = rng();
    let mut obs = carrying(A);
    obs.pucks = (0..8)
        .map(|i| seen(B, 40.0 + 5.0 * i as f64, 0.0))
        .collect();
    assert_eq!(
        step_until(&mut ps, &obs, &mut r, 300, |c| c.state() == "DE_TARGET"),
        None
    );
}

// ---------------------------------------------------------------- CACHECONS

fn at(x: f64, y: f64) -> Pose {
    Pose { x, y, theta: 0.0 }
}

/// Three A pucks around (40, 0) and one B at (30, 25), seen from `pose`.
fn cluster_view(pose: Pose) -> Observation {
    Observation {
        pose,
        pucks: vec![
            seen(A, 40.0, -3.0),
            seen(A, 40.0, 3.0),
            seen(A, 46.0, 0.0),
            seen(B, 30.0, 25.0),
        ],
        ..Observation::default()
    }
}

#[test]
fn cachecons_adopts_the_largest_visible_cluster_as_its_cache() {
    let mut cc = CacheCons::new(&params(), CacheConsVariant::Standard);
    cc.step(&cluster_view(at(10.0, 20.0)), &mut rng());
    let caches = cc.cache_points();
    assert_eq!(caches.len(), 1, "only L is considered: {caches:?}");
    assert_eq!(caches[0].0, A);
    assert!(caches[0].1.distance(Vec2::new(10.0 + 42.0, 20.0)) < 1e-9);
    assert_eq!(cc.memory().remembered(A), 3.0);
}

#[test]
fn cachecons_remembers_the_largest_size_seen_at_its_cache() {
    let mut cc = CacheCons::new(&params(), CacheConsVariant::Standard);
    let mut r = rng();
    let pose = at(0.0, 0.0);
    cc.step(&cluster_view(pose), &mut r);
    let mut bigger = cluster_view(pose);
    bigger.pucks.push(seen(A, 46.0, 6.0));
    bigger.pucks.push(seen(A, 46.0, -6.0));
    cc.step(&bigger, &mut r);
    assert_eq!(cc.memory().remembered(A), 5.0);
    // Partly seen again: the memory keeps the maximum (eq. 5).
    let mut partial = cluster_view(pose);
    partial.pucks.truncate(2);
    cc.step(&partial, &mut r);
    assert_eq!(cc.memory().remembered(A), 5.0);
}

#[test]
fn cachecons_homes_to_its_cache_when_carrying_and_deposits_on_contact() {
    let mut cc = CacheCons::new(&params(), CacheConsVariant::Standard);
    let mut r = rng();
    cc.step(&cluster_view(at(0.0, 0.0)), &mut r);
    let cache = cc.cache_points()[0].1;

    // Carrying an A puck, facing away from the cache: HOMING, turning toward it.
    let away = Observation {
        pose: Pose {
            x: 0.0,
            y: 0.0,
            theta: std::f64::consts::FRAC_PI_2,
        },
        ..carrying(A)
    };
    let c = cc.step(&away, &mut r);
    assert_eq!(cc.current(), CacheConsState::Homing);
    assert_eq!(cc.target(), Some(cache));
    assert!(c.turn < 0.0, "the cache is to the right: {c:?}");

    // Arrived: the carried puck touches the cache cluster.
    let arrived = Observation {
        pose: at(25.0, 0.0),
        gripper: Some(seen(A, 8.0, 0.0)),
        pucks: vec![seen(A, 15.0, -3.0), seen(A, 15.0, 3.0), seen(A, 21.0, 0.0)],
        ..Observation::default()
    };
    cc.step(&arrived, &mut r);
    assert_eq!(cc.state(), "DE_PUSH");
    let empty = Observation {
        pose: at(20.0, 0.0),
        ..Observation::default()
    };
    for _ in 0..5 {
        cc.step(&empty, &mut r);
        assert_eq!(cc.state(), "DE_BACKUP");
    }
    cc.step(&empty, &mut r);
    assert_eq!(cc.state(), "EXILE");
    // EXILE drives away from the cache: the cache is ahead, so turn hard.
    let c = cc.step(&empty, &mut r);
    assert!(c.turn.abs() > 0.9, "{c:?}");
    for _ in 0..19 {
        cc.step(&empty, &mut r);
    }
    assert_eq!(cc.state(), "PU_SCAN", "EXILE lasts 20 steps");
}

#[test]
fn cachecons_spits_out_a_puck_whose_type_has_no_cache() {
    let mut cc = CacheCons::new(&params(), CacheConsVariant::Standard);
    let mut r = rng();
    cc.step(&cluster_view(at(0.0, 0.0)), &mut r);
    let c = cc.step(&carrying(B), &mut r);
    assert_eq!(cc.state(), "SPIT_OUT");
    assert!(c.forward < 0.0);
}

#[test]
fn cachecons_leaves_pucks_of_its_cache_cluster_alone() {
    let mut cc = CacheCons::new(&params(), CacheConsVariant::Standard);
    let mut r = rng();
    // The cache cluster is a pair; p_pick(2) = 1/9 per step, so 300 steps would
    // target it almost surely if it were allowed.
    let pair = Observation {
        pucks: vec![seen(A, 40.0, -3.0), seen(A, 40.0, 3.0)],
        ..Observation::default()
    };
    assert_eq!(
        step_until(&mut cc, &pair, &mut r, 300, |c| c.state() == "PU_TARGET"),
        None
    );
    assert_eq!(cc.cache_points().len(), 1);
    // A lone A puck away from the cache is fair game.
    let mut both = pair.clone();
    both.pucks.push(seen(A, 30.0, -30.0));
    step_until(&mut cc, &both, &mut r, 300, |c| c.state() == "PU_TARGET").unwrap();
}

#[test]
fn separation_rejects_a_smaller_candidate_near_another_types_cache() {
    let params = params();
    let pose = at(0.0, 0.0);
    let sep = Separation::AcceptLarger { distance_cm: 50.0 };
    let map = |obs: &Observation| LocalMap::new(obs, &params);
    let mut memory = CacheMemory::new();

    let a3 = map(&cluster_view(pose));
    assert!(memory.consider(a3.l().unwrap(), &pose, sep));
    // A B pair 20 cm from the A cache: smaller, rejected.
    let b2 = map(&Observation {
        pucks: vec![seen(B, 42.0, 20.0), seen(B, 42.0, 26.0)],
        ..Observation::default()
    });
    assert!(!memory.consider(b2.l().unwrap(), &pose, sep));
    assert!(memory.get(B).is_none());
    // The same pair far away (60 cm) is accepted.
    let far = map(&Observation {
        pucks: vec![seen(B, 42.0, 60.0), seen(B, 42.0, 66.0)],
        ..Observation::default()
    });
    assert!(memory.consider(far.l().unwrap(), &pose, sep));
    // A larger B cluster near the A cache replaces it, and the A cache is forgotten.
    let b4 = map(&Observation {
        pucks: (0..4)
            .map(|i| seen(B, 42.0, 20.0 + 5.0 * i as f64))
            .collect(),
        ..Observation::default()
    });
    assert!(memory.consider(b4.l().unwrap(), &pose, sep));
    assert!(memory.get(A).is_none());
    assert_eq!(memory.remembered(B), 4.0);
}

#[test]
fn ignoring_separation_lets_caches_sit_side_by_side() {
    let params = params();
    let pose = at(0.0, 0.0);
    let mut memory = CacheMemory::new();
    let a3 = LocalMap::new(&cluster_view(pose), &params);
    memory.consider(a3.l().unwrap(), &pose, Separation::Ignore);
    let b2 = LocalMap::new(
        &Observation {
            pucks: vec![seen(B, 42.0, 20.0), seen(B, 42.0, 26.0)],
            ..Observation::default()
        },
        &params,
    );
    assert!(memory.consider(b2.l().unwrap(), &pose, Separation::Ignore));
    assert_eq!(memory.points().len(), 2);
}

#[test]
fn cachecons_rejects_a_smaller_cluster_near_another_types_cache() {
    let mut cc = CacheCons::new(&params(), CacheConsVariant::Standard);
    let mut r = rng();
    cc.step(&cluster_view(at(0.0, 0.0)), &mut r);
    let near_pair = Observation {
        pucks: vec![seen(B, 42.0, 20.0), seen(B, 42.0, 26.0)],
        ..Observation::default()
    };
    cc.step(&near_pair, &mut r);
    assert_eq!(cc.cache_points().len(), 1);

    let mut ignore = CacheCons::new(&params(), CacheConsVariant::IgnoreSeparation);
    ignore.step(&cluster_view(at(0.0, 0.0)), &mut r);
    ignore.step(&near_pair, &mut r);
    assert_eq!(ignore.cache_points().len(), 2);
}

#[test]
fn informed_caches_sit_on_the_circle_and_are_never_reassigned() {
    let p = params();
    let preset = informed_caches(&p, 2, 187.0);
    let r = 0.75 * 187.0 / 2.0;
    let h = r / std::f64::consts::SQRT_2;
    assert!(preset[0].1.distance(Vec2::new(h, h)) < 1e-9);
    assert!(preset[1].1.distance(Vec2::new(-h, -h)) < 1e-9);

    let mut cc = build(Method::CacheConsInformed, &p, 2, 187.0);
    let mut rng = rng();
    let mut huge = cluster_view(at(0.0, 0.0));
    huge.pucks = (0..12)
        .map(|i| seen(A, 30.0 + 5.0 * (i % 4) as f64, 5.0 * (i / 4) as f64))
        .collect();
    for _ in 0..20 {
        cc.step(&huge, &mut rng);
    }
    assert_eq!(cc.cache_points(), preset);
}

#[test]
fn erasing_memory_forgets_every_cache() {
    let mut cc = CacheCons::new(&params(), CacheConsVariant::EraseMemory { p: 1.0 });
    let mut r = rng();
    cc.step(&cluster_view(at(0.0, 0.0)), &mut r);
    assert_eq!(
        cc.cache_points().len(),
        1,
        "erased, then re-adopted from the view"
    );
    cc.step(&Observation::default(), &mut r);
    assert!(cc.cache_points().is_empty());

    let mut never = CacheCons::new(&params(), CacheConsVariant::EraseMemory { p: 0.0 });
    never.step(&cluster_view(at(0.0, 0.0)), &mut r);
    never.step(&Observation::default(), &mut r);
    assert_eq!(never.cache_points().len(), 1);
}

// ---------------------------------------------------------------- Method

#[test]
fn method_names_round_trip_and_unknown_names_list_the_valid_ones() {
    for m in Method::ALL {
        assert_eq!(m.name().parse::<Method>(), Ok(m));
        assert_eq!(m.to_string(), m.name());
    }
    assert_eq!(
        "CacheCons_Ignore".parse::<Method>(),
        Ok(Method::CacheConsIgnore)
    );
    let e = "cachecons-magic".parse::<Method>().unwrap_err();
    assert_eq!(
        e.to_string(),
        "unknown method `cachecons-magic`; valid methods: bhd, probseek, cachecons, \
         cachecons-informed, cachecons-ignore, cachecons-erase"
    );
}

#[test]
fn built_controllers_start_in_their_first_state() {
    let p = params();
    let first: Vec<&str> = Method::ALL
        .iter()
        .map(|m| build(*m, &p, 2, 187.0).state())
        .collect();
    assert_eq!(
        first,
        ["FORWARD", "PU_SCAN", "PU_SCAN", "PU_SCAN", "PU_SCAN", "PU_SCAN"]
    );
}
