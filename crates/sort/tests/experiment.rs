//! Whole trials: the simulator, the controllers and the metrics together.

use colony_sim::SceneConfig;
use colony_sort::experiment::{run_trial, run_trials, write_csv, TrialSpec};
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
