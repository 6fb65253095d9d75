//! Whole trials: the simulator, the controllers and the metrics together.

use colony_lab::sort::experiment::{
    read_csv, run_trial, run_trials, write_csv, Disturbance, TrialSpec,
};
use colony_sim::{Engine, SceneConfig, World};
use colony_sort::methods::Method;
use colony_sort::params::SortParams;

fn spec(method: Method, seed: u64, steps: u64) -> TrialSpec {
    TrialSpec {
        method,
        scene: SceneConfig::default(),
        params: SortParams::default(),
        steps,
        seed,
        sample_every: 100,
        snapshot_at: vec![0, steps],
        disturbances: Vec::new(),
    }
}

#[test]
fn the_same_seed_gives_the_same_trial_and_identical_csv() {
    let a = run_trial(&spec(Method::CacheCons, 7, 400), &|_| {}).unwrap();
    let b = run_trial(&spec(Method::CacheCons, 7, 400), &|_| {}).unwrap();
    assert_eq!(a, b);
    let dir = tempfile::tempdir().unwrap();
    write_csv(&dir.path().join("a"), &[a]).unwrap();
    write_csv(&dir.path().join("b"), &[b]).unwrap();
    for f in ["summary.csv", "cachecons-types2-trial00.csv"] {
        let x = std::fs::read(dir.path().join("a").join(f)).unwrap();
        let y = std::fs::read(dir.path().join("b").join(f)).unwrap();
        assert_eq!(x, y, "{f}");
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let specs: Vec<TrialSpec> = (0..3).map(|s| spec(Method::ProbSeek, s, 200)).collect();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| run_trials(&specs, &|_| {}))
        .unwrap();
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(|| run_trials(&specs, &|_| {}))
        .unwrap();
    assert_eq!(one, two);
}

#[test]
fn a_large_swarm_steps_the_same_on_one_thread_and_on_two() {
    // Each engine: rapier (its own threads in the `parallel-physics` build) and the disc
    // engine (contacts and strips of the solver on rayon's).
    for engine in Engine::ALL {
        a_large_swarm_on(engine);
    }
}

fn a_large_swarm_on(engine: Engine) {
    // Enough robots that sensing and control are spread over both threads of one world.
    let mut s = spec(Method::CacheCons, 9, 60);
    s.scene = SceneConfig::scaled(150);
    s.scene.physics.engine = engine;
    s.sample_every = 20;
    s.snapshot_at = vec![60];
    let on = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run_trial(&s, &|_| {}))
            .unwrap()
    };
    let (one, two) = (on(1), on(2));
    assert_eq!(one, two, "{engine}");
    // The robots did move: the comparison is of a trial, not of a frozen world.
    let start = World::new(&s.scene, 9).unwrap().robots();
    let moved = one.snapshots[0]
        .robots
        .iter()
        .zip(&start)
        .filter(|((x, y, _), r)| (x - r.pose.x).hypot(y - r.pose.y) > 5.0)
        .count();
    assert!(moved > 100, "{engine}: only {moved} robots moved");
}

#[test]
fn every_method_runs_a_short_trial_with_sane_metrics() {
    for method in Method::ALL {
        let mut s = spec(method, 3, 300);
        if method == Method::Bhd {
            s.scene.pucks.kinds = 1;
        }
        let r = run_trial(&s, &|_| {}).unwrap();
        assert_eq!(r.samples.len(), 4, "{method}");
        assert!(
            r.samples.iter().all(|x| (0.0..=100.0).contains(&x.pc)),
            "{method}"
        );
        assert!((0.0..=1.0).contains(&r.twc), "{method}");
        assert_eq!(r.snapshots.len(), 2);
    }
}

#[test]
fn reinserting_the_pucks_undoes_the_sorting_and_the_swarm_recovers() {
    let mut s = spec(Method::CacheCons, 11, 3_000);
    s.disturbances = vec![(2_000, Disturbance::ReinsertPucks)];
    let r = run_trial(&s, &|_| {}).unwrap();
    let pc_at = |step: u64| r.samples.iter().find(|x| x.step == step).unwrap().pc;
    assert!(
        pc_at(2_000) < pc_at(1_900),
        "PC {} before, {} after the reinsertion",
        pc_at(1_900),
        pc_at(2_000)
    );
    assert!(pc_at(3_000) > pc_at(2_000), "the swarm sorts again");
}

#[test]
fn shifting_the_largest_cluster_moves_it_whole() {
    let mut s = spec(Method::CacheCons, 12, 1_500);
    s.disturbances = vec![(1_500, Disturbance::ShiftLargestCluster)];
    s.snapshot_at = vec![1_500];
    let before = run_trial(&spec(Method::CacheCons, 12, 1_500), &|_| {}).unwrap();
    let after = run_trial(&s, &|_| {}).unwrap();
    // The shift happens at the last step: PC (the clusters' sizes) is unchanged, places are not.
    assert_eq!(before.final_pc(), after.final_pc());
    assert_ne!(
        before.snapshots.last().unwrap().pucks,
        after.snapshots.last().unwrap().pucks
    );
}

#[test]
fn trials_read_back_from_their_csv_files_and_bad_files_are_refused() {
    let mut s = spec(Method::CacheCons, 4, 300);
    s.snapshot_at.clear();
    let r = run_trial(&s, &|_| {}).unwrap();
    let dir = tempfile::tempdir().unwrap();
    write_csv(dir.path(), std::slice::from_ref(&r)).unwrap();
    let back = read_csv(dir.path()).unwrap();
    assert_eq!(back.len(), 1);
    assert_eq!(
        (
            back[0].method,
            back[0].seed,
            back[0].steps,
            back[0].stc,
            back[0].types
        ),
        (r.method, r.seed, r.steps, r.stc, r.types)
    );
    for (a, b) in back[0].samples.iter().zip(&r.samples) {
        assert_eq!(a.step, b.step);
        assert!((a.pc - b.pc).abs() < 1e-4);
    }
    for summary in [
        "header\ncachecons,2,0,4,300,,0.5",
        "header\nquicksort,2,0,4,300,,0.5,1",
        "header\ncachecons,2,0,4,300,,x,1",
        "header\ncachecons,-2,0,4,300,,0.5,1",
        "header\ncachecons,2,7,4,300,,0.5,1",
    ] {
        std::fs::write(dir.path().join("summary.csv"), summary).unwrap();
        assert!(read_csv(dir.path()).is_err(), "{summary}");
    }
    std::fs::write(
        dir.path().join("summary.csv"),
        "h\ncachecons,2,0,4,300,,0.5,1",
    )
    .unwrap();
    std::fs::write(dir.path().join("cachecons-types2-trial00.csv"), "h\n1,2\n").unwrap();
    let e = read_csv(dir.path()).unwrap_err().to_string();
    assert!(e.contains("trial00.csv:2"), "{e}");
}

#[test]
fn progress_counts_every_step_once_and_more_often_in_larger_worlds() {
    use std::sync::Mutex;
    let calls = |s: &TrialSpec| {
        let seen = Mutex::new(Vec::new());
        run_trial(s, &|n| seen.lock().unwrap().push(n)).unwrap();
        seen.into_inner().unwrap()
    };
    // The standard world (44 bodies): every 1,000 steps, and the rest at the end.
    assert_eq!(calls(&spec(Method::ProbSeek, 3, 2_500)), [1000, 1000, 500]);
    // 1,100 bodies: every 90 steps (100,000 / 1,100).
    let mut big = spec(Method::ProbSeek, 3, 100);
    big.scene = SceneConfig::scaled(100);
    big.snapshot_at.clear();
    assert_eq!(calls(&big), [90, 10]);
}
