use colony_lab::sort::experiment::{run_trial, TrialSpec};
use colony_proto::swarm::vision;
use colony_sim::{SceneConfig, WheelCommand};
use colony_sort::SortParams;
use colony_wire::Packet;
use rand::{Rng, SeedableRng};

use super::*;

fn small(robots: usize, pucks: usize, kinds: usize) -> EnvConfig {
    EnvConfig::default().with_counts(Some(robots), Some(pucks), Some(kinds))
}

struct Buffers {
    map: Vec<f32>,
    gripper: Vec<f32>,
    pose: Vec<f32>,
}

impl Buffers {
    fn of(env: &SortEnv) -> Buffers {
        let l = env.layout();
        Buffers {
            map: vec![f32::NAN; l.map_total()],
            gripper: vec![f32::NAN; l.gripper_total()],
            pose: vec![f32::NAN; l.pose_total()],
        }
    }

    fn fill(&mut self, env: &SortEnv) {
        env.observe(&mut self.map, &mut self.gripper, &mut self.pose)
            .unwrap();
    }

    fn all_finite(&self) -> bool {
        self.map
            .iter()
            .chain(&self.gripper)
            .chain(&self.pose)
            .all(|v| v.is_finite())
    }
}

/// Drives a fresh environment with `method`'s reference commands for `steps`
/// steps and checks it ends where `run_trial` does, bit for bit.
fn reproduces_run_trial(config: EnvConfig, method: Method, seed: u64, steps: u64) {
    let spec = TrialSpec {
        method,
        scene: config.scene.clone(),
        params: config.params.clone(),
        steps,
        seed,
        sample_every: 1,
        snapshot_at: vec![steps],
        disturbances: Vec::new(),
    };
    let trial = run_trial(&spec, &|_| {}).unwrap();
    let mut env = SortEnv::new(
        EnvConfig {
            reward: RewardKind::TwcChange,
            max_steps: steps,
            ..config
        },
        seed,
    )
    .unwrap();
    let mut commands = Vec::new();
    let mut rewards = 0.0;
    for t in 1..=steps {
        env.reference_commands(method, &mut commands);
        let info = env.step(&commands).unwrap();
        assert_eq!(info.pc, trial.samples[t as usize].pc, "PC at step {t}");
        rewards += info.reward;
    }
    assert_eq!(env.pc(), trial.final_pc());
    assert_eq!(env.twc_so_far(), trial.twc, "TWC bit-identical");
    assert!(
        (rewards - trial.twc).abs() < 1e-9,
        "TWC-change rewards sum to the trial's TWC: {rewards} vs {}",
        trial.twc
    );
    let last = &trial.snapshots[0];
    let robots: Vec<_> = env
        .world()
        .robots()
        .iter()
        .map(|r| (r.pose.x, r.pose.y, r.pose.theta))
        .collect();
    assert_eq!(robots, last.robots);
    let pucks: Vec<_> = env
        .world()
        .pucks()
        .iter()
        .map(|p| (p.pos.x, p.pos.y, p.kind.0))
        .collect();
    assert_eq!(pucks, last.pucks);
}

#[test]
fn env_reference_cachecons_reproduces_run_trial() {
    reproduces_run_trial(small(4, 20, 2), Method::CacheCons, 11, 300);
}

#[test]
fn env_reference_bhd_reproduces_run_trial() {
    reproduces_run_trial(small(4, 20, 1), Method::Bhd, 12, 300);
}

#[test]
fn env_reference_reproduces_run_trial_with_robots_decided_on_threads() {
    // More robots than ROBOTS_PER_TASK: both sides decide on rayon.
    let config = EnvConfig::default().with_scaled_robots(ROBOTS_PER_TASK + 8);
    reproduces_run_trial(config, Method::ProbSeek, 13, 40);
}

#[test]
fn env_reset_starts_the_same_episode_with_fresh_reference_controllers() {
    let mut env = SortEnv::new(small(4, 20, 2), 5).unwrap();
    let mut first = Vec::new();
    let mut commands = Vec::new();
    for _ in 0..50 {
        env.reference_commands(Method::CacheCons, &mut commands);
        first.push(env.step(&commands).unwrap());
    }
    let end = env.world().snapshot();
    env.reset(6).unwrap();
    assert_ne!(env.world().snapshot().robots, end.robots);
    env.reset(5).unwrap();
    assert_eq!(env.steps(), 0);
    assert_eq!(env.twc_so_far(), 0.0);
    assert!(env.reference_states(Method::CacheCons).is_none());
    for want in &first {
        env.reference_commands(Method::CacheCons, &mut commands);
        assert_eq!(env.step(&commands).unwrap(), *want);
    }
    assert_eq!(env.world().snapshot(), end);
}

/// Steps `env` with random continuous commands from `rng` and returns every
/// observation and step result.
fn random_episode(
    env: &mut SortEnv,
    rng: &mut ChaCha8Rng,
    steps: usize,
) -> Vec<(Vec<f32>, StepInfo)> {
    let mut b = Buffers::of(env);
    let n = env.agents();
    (0..steps)
        .map(|_| {
            let commands: Vec<WheelCommand> = (0..n)
                .map(|_| WheelCommand {
                    forward: rng.random_range(-1.0..1.0),
                    turn: rng.random_range(-1.0..1.0),
                })
                .collect();
            let info = env.step(&commands).unwrap();
            b.fill(env);
            assert!(b.all_finite());
            let mut all = b.map.clone();
            all.extend(&b.gripper);
            all.extend(&b.pose);
            (all, info)
        })
        .collect()
}

#[test]
fn env_same_seed_same_episode_other_seed_other_episode() {
    let run = |seed| {
        let mut env = SortEnv::new(small(6, 30, 3), seed).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(99);
        random_episode(&mut env, &mut rng, 200)
    };
    let a = run(1);
    assert_eq!(a, run(1));
    assert_ne!(a, run(2));
    // Something was seen: the grids are not all empty.
    assert!(a
        .iter()
        .any(|(obs, _)| obs.iter().take(6 * 5 * 16 * 16).any(|v| *v > 0.0)));
}

#[test]
fn env_observations_do_not_depend_on_the_thread_count() {
    let env = SortEnv::new(
        EnvConfig::default().with_scaled_robots(3 * ROBOTS_PER_TASK),
        4,
    )
    .unwrap();
    let observe_on = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut b = Buffers::of(&env);
            b.fill(&env);
            assert!(b.all_finite());
            (b.map, b.gripper, b.pose)
        })
    };
    assert_eq!(observe_on(1), observe_on(3));
}

#[test]
fn env_observation_is_each_robots_own_view() {
    let env = SortEnv::new(small(5, 40, 2), 8).unwrap();
    let l = env.layout();
    assert_eq!(
        (l.agents, l.kinds, l.channels, l.grid, l.gripper, l.pose),
        (5, 2, 4, 16, 3, 4)
    );
    let mut b = Buffers::of(&env);
    b.fill(&env);
    let encoder = Encoder::new(env.world(), 16);
    for i in 0..5 {
        let (mut m, mut g, mut p) = (vec![0.0; l.map_len()], vec![0.0; 3], vec![0.0; 4]);
        encoder.write(&env.world().observe(RobotId(i)), &mut m, &mut g, &mut p);
        assert_eq!(&b.map[i * l.map_len()..][..l.map_len()], &m[..]);
        assert_eq!(&b.gripper[i * 3..][..3], &g[..]);
        assert_eq!(&b.pose[i * 4..][..4], &p[..]);
        assert_eq!(g[0], 1.0, "nobody carries at the start");
        let pose = env.world().robots()[i].pose;
        assert!((f64::from(p[2]) - pose.theta.cos()).abs() < 1e-6);
        assert!(p[0].abs() <= 1.0 && p[1].abs() <= 1.0);
    }
}

#[test]
fn env_discrete_actions_are_the_table_and_a_bad_index_is_refused() {
    let mut a = SortEnv::new(small(3, 9, 1), 2).unwrap();
    let mut b = SortEnv::new(small(3, 9, 1), 2).unwrap();
    let table: Vec<WheelCommand> = [1, 4, 6].iter().map(|&i| DISCRETE_ACTIONS[i].1).collect();
    assert_eq!(
        a.step_discrete(&[1, 4, 6]).unwrap(),
        b.step(&table).unwrap()
    );
    assert_eq!(a.last_commands(), &table[..]);
    assert_eq!(a.world().snapshot(), b.world().snapshot());
    let refused = a.step_discrete(&[0, 7, 0]);
    assert!(
        matches!(
            refused,
            Err(EnvError::Action {
                agent: 1,
                action: 7
            })
        ),
        "{refused:?}"
    );
    assert_eq!(a.steps(), 1, "no step taken");
}

#[test]
fn env_wrong_lengths_are_errors_and_take_no_step() {
    let mut env = SortEnv::new(small(3, 9, 1), 2).unwrap();
    let l = env.layout();
    let go = WheelCommand {
        forward: 1.0,
        turn: 0.0,
    };
    for n in [0, 2, 4] {
        let e = env.step(&vec![go; n]).unwrap_err();
        assert!(matches!(e, EnvError::Length { what: "commands", expected: 3, got } if got == n));
        assert!(env.step_discrete(&vec![0; n]).is_err());
    }
    assert_eq!(env.steps(), 0);
    let (mut m, mut g, mut p) = (
        vec![0.0; l.map_total()],
        vec![0.0; l.gripper_total()],
        vec![0.0; l.pose_total()],
    );
    assert!(env.observe(&mut m[1..], &mut g, &mut p).is_err());
    assert!(env.observe(&mut m, &mut g, &mut []).is_err());
    assert!(env.observe(&mut m, &mut g[..1], &mut p).is_err());
    assert!(env.observe(&mut m, &mut g, &mut p).is_ok());
}

#[test]
fn env_non_finite_commands_are_clamped_and_never_poison_the_world() {
    let mut env = SortEnv::new(small(3, 9, 1), 2).unwrap();
    let wild = [
        WheelCommand {
            forward: f64::NAN,
            turn: f64::NAN,
        },
        WheelCommand {
            forward: f64::INFINITY,
            turn: f64::NEG_INFINITY,
        },
        WheelCommand {
            forward: -1e300,
            turn: 1e-300,
        },
    ];
    let mut b = Buffers::of(&env);
    for _ in 0..30 {
        env.step(&wild).unwrap();
        b.fill(&env);
        assert!(b.all_finite());
    }
    assert_eq!(
        env.last_commands(),
        [
            WheelCommand {
                forward: 0.0,
                turn: 0.0
            },
            WheelCommand {
                forward: 1.0,
                turn: -1.0
            },
            WheelCommand {
                forward: -1.0,
                turn: 1e-300
            },
        ]
    );
    assert!(env.pc().is_finite());
    assert!(env
        .world()
        .robots()
        .iter()
        .all(|r| r.pose.x.is_finite() && r.pose.theta.is_finite()));
}

#[test]
fn env_bad_configurations_are_clear_errors() {
    let refused = |c: EnvConfig| SortEnv::new(c, 1).unwrap_err().to_string();
    assert!(refused(small(0, 10, 1)).contains("robots.count"));
    assert!(refused(small(usize::MAX, 10, 1)).contains("robots"));
    assert!(refused(small(2, 1 << 30, 1)).contains("pucks"));
    assert!(refused(small(2, 4, 5)).contains("pucks.kinds"));
    assert!(refused(small(2, 4, 0)).contains("pucks.kinds"));
    assert!(refused(EnvConfig {
        grid: 0,
        ..EnvConfig::default()
    })
    .contains("grid"));
    assert!(refused(EnvConfig {
        grid: MAX_GRID + 1,
        ..EnvConfig::default()
    })
    .contains("grid"));
    assert!(refused(EnvConfig {
        max_steps: 0,
        ..EnvConfig::default()
    })
    .contains("max_steps"));
    for t in [f64::NAN, f64::INFINITY, -1.0, 100.5] {
        assert!(refused(EnvConfig {
            pc_target: Some(t),
            ..EnvConfig::default()
        })
        .contains("pc_target"));
    }
    let mut wide = EnvConfig::default();
    wide.scene.arena.width = f64::INFINITY;
    assert!(refused(wide).contains("arena.width"));
    let mut params = EnvConfig::default();
    params.params.perception.cluster_threshold_cm = f64::NAN;
    assert!(refused(params).contains("cluster_threshold_cm"));
    // An impossible layout (too many robots for the arena) is an error too.
    let crowded = small(2000, 10, 1);
    assert!(matches!(SortEnv::new(crowded, 1), Err(EnvError::Sim(_))));
    let missing = EnvConfig::from_files(Some(std::path::Path::new("/no/such/scene.toml")), None);
    assert!(matches!(missing, Err(EnvError::Sim(_))));
}

#[test]
fn env_from_files_reads_what_colony_sort_run_reads() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let c = EnvConfig::from_files(
        Some(&root.join("configs/scene.toml")),
        Some(&root.join("configs/sort.toml")),
    )
    .unwrap();
    assert_eq!(
        c.scene,
        SceneConfig::from_file(root.join("configs/scene.toml")).unwrap()
    );
    assert_eq!(
        c.params,
        SortParams::load(root.join("configs/sort.toml")).unwrap()
    );
    let d = EnvConfig::from_files(None, None).unwrap();
    assert_eq!(
        (d.scene, d.params),
        (SceneConfig::default(), SortParams::default())
    );
    let scaled = EnvConfig::default()
        .with_counts(None, None, Some(3))
        .with_scaled_robots(16);
    assert_eq!(scaled.scene.robots.count, 16);
    assert_eq!(scaled.scene.pucks.count, 160);
    assert_eq!(scaled.scene.pucks.kinds, 3);
}

#[test]
fn env_episode_ends_by_target_or_by_max_steps() {
    let mut env = SortEnv::new(
        EnvConfig {
            pc_target: Some(0.0),
            max_steps: 2,
            reward: RewardKind::Pc,
            ..small(2, 10, 1)
        },
        3,
    )
    .unwrap();
    let stop = [WheelCommand::STOP; 2];
    let first = env.step(&stop).unwrap();
    assert!(first.terminated && !first.truncated);
    assert_eq!(first.reward, first.pc / 100.0);
    let second = env.step(&stop).unwrap();
    assert!(second.truncated && second.step == 2);
    // Stepping on after the end is allowed.
    assert_eq!(env.step(&stop).unwrap().step, 3);
}

#[test]
fn env_pc_change_rewards_sum_to_the_change_of_pc() {
    let mut env = SortEnv::new(
        EnvConfig {
            reward: RewardKind::PcChange,
            ..small(4, 20, 2)
        },
        9,
    )
    .unwrap();
    let start = env.pc();
    let mut sum = 0.0;
    let mut commands = Vec::new();
    for _ in 0..100 {
        env.reference_commands(Method::CacheCons, &mut commands);
        sum += env.step(&commands).unwrap().reward;
    }
    assert!((sum - (env.pc() - start) / 100.0).abs() < 1e-12);
}

#[test]
fn env_vision_packets_hold_every_robot_and_puck() {
    let env = SortEnv::new(small(4, 40, 2), 1).unwrap();
    let packets = env.vision_packets().unwrap();
    let (mut robots, mut pucks) = (0, 0);
    for bytes in &packets {
        let part = vision::decode(&Packet::parse(bytes).unwrap()).unwrap();
        assert_eq!(part.frame.step, 0);
        robots += part.frame.robots.len();
        pucks += part.frame.pucks.len();
    }
    assert_eq!((robots, pucks), (4, 40));
    let metrics = env.metrics_packet().unwrap();
    let progress = colony_proto::swarm::metrics::decode(&Packet::parse(&metrics).unwrap()).unwrap();
    assert_eq!(progress.step, 0);
    assert!((progress.pc - env.pc()).abs() < 0.01);
}

#[test]
fn env_render_is_the_arena() {
    let env = SortEnv::new(small(4, 40, 2), 1).unwrap();
    let rgb = env.render_rgb(64, 48).unwrap();
    assert_eq!(rgb.len(), 64 * 48 * 3);
    assert!(env.render_rgb(MAX_RENDER_SIDE + 1, 2).is_err());
}

#[test]
fn env_is_send_and_sync() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<SortEnv>();
}

#[test]
fn env_engine_is_chosen_by_name_and_kept_through_scaling() {
    use colony_sim::Engine;
    let kept = EnvConfig::default().with_engine(None).unwrap();
    assert_eq!(kept.scene.physics.engine, Engine::default());
    let disc = EnvConfig::default()
        .with_engine(Some("disc"))
        .unwrap()
        .with_scaled_robots(16);
    assert_eq!(disc.scene.physics.engine, Engine::Disc);
    assert_eq!(disc.scene.robots.count, 16);
    let e = EnvConfig::default()
        .with_engine(Some("warp"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("\"warp\"") && e.contains("rapier") && e.contains("disc"),
        "{e}"
    );
}

#[test]
fn a_hundred_thousand_robots_with_ten_pucks_each_pass_the_count_checks() {
    // Checked, not built: the scene `--scale-robots 100000` makes.
    let scene = SceneConfig::scaled(100_000);
    assert_eq!(scene.pucks.count, 1_000_000);
    check_counts(&scene).unwrap();
    scene.validate().unwrap();
    assert!(check_robots(MAX_ROBOTS + 1)
        .unwrap_err()
        .to_string()
        .contains("100001 robots is more than the 100000"));
}
