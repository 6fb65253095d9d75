//! Short trials in the real simulator: the controllers drive `colony_sim::World`
//! and the pucks get sorted.

use colony_sim::{RobotId, SceneConfig, World};
use colony_sort::methods::{build, Method};
use colony_sort::metrics::{cache_variance, percentage_completion};
use colony_sort::params::SortParams;
use colony_sort::Controller;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

struct Trial {
    world: World,
    robots: Vec<Box<dyn Controller>>,
    rngs: Vec<ChaCha8Rng>,
}

impl Trial {
    fn new(method: Method, seed: u64) -> Trial {
        let params = SortParams::default();
        let scene = SceneConfig::default();
        let world = World::new(&scene, seed).unwrap();
        let n = world.robot_count();
        Trial {
            robots: (0..n)
                .map(|_| build(method, &params, scene.pucks.kinds, scene.arena.width))
                .collect(),
            rngs: (0..n)
                .map(|i| ChaCha8Rng::seed_from_u64(seed * 1000 + i as u64))
                .collect(),
            world,
        }
    }

    fn run(&mut self, steps: u64) {
        for _ in 0..steps {
            let commands: Vec<_> = (0..self.robots.len())
                .map(|i| {
                    let obs = self.world.observe(RobotId(i));
                    self.robots[i].step(&obs, &mut self.rngs[i])
                })
                .collect();
            self.world.step(&commands);
        }
    }

    fn pc(&self) -> f64 {
        percentage_completion(
            &self.world.pucks(),
            SortParams::default().perception.cluster_threshold_cm,
        )
    }
}

#[test]
fn cachecons_informed_sorts_most_pucks_within_a_thousand_steps() {
    for seed in 0..2 {
        let mut t = Trial::new(Method::CacheConsInformed, seed);
        let start = t.pc();
        t.run(1000);
        assert!(t.pc() >= 80.0, "seed {seed}: PC {start} -> {}", t.pc());
    }
}

#[test]
fn cachecons_robots_agree_on_caches_and_sort_within_two_thousand_steps() {
    for seed in 0..2 {
        let mut t = Trial::new(Method::CacheCons, seed);
        t.run(2000);
        assert!(t.pc() >= 60.0, "seed {seed}: PC {}", t.pc());
        let caches: Vec<_> = t.robots.iter().map(|r| r.cache_points()).collect();
        assert!(
            caches.iter().all(|c| !c.is_empty()),
            "seed {seed}: {caches:?}"
        );
        let v = cache_variance(&caches).unwrap();
        // Spread of cache points about their centroid: a few cm^2 once they agree.
        assert!(v < 50.0, "seed {seed}: cache variance {v}");
    }
}
