//! Simulated scenes, wandering robots, and what compares runs to the last bit.

use colony_sim::{Pose, PuckKind, SceneConfig, Vec2, WheelCommand, World};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random commands for `n` robots, each held for a few steps, like a wandering controller.
pub struct RandomDriver {
    rng: ChaCha8Rng,
    commands: Vec<WheelCommand>,
}

impl RandomDriver {
    pub fn new(seed: u64, n: usize) -> RandomDriver {
        RandomDriver {
            rng: ChaCha8Rng::seed_from_u64(seed),
            commands: vec![WheelCommand::STOP; n],
        }
    }

    // Not an Iterator: each step's commands borrow the driver, which `next` cannot return.
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> &[WheelCommand] {
        for c in &mut self.commands {
            if self.rng.random_bool(0.2) {
                *c = WheelCommand {
                    forward: self.rng.random_range(-1.0..1.0),
                    turn: self.rng.random_range(-1.0..1.0),
                };
            }
        }
        &self.commands
    }
}

pub fn pose(x: f64, y: f64, theta: f64) -> Pose {
    Pose { x, y, theta }
}

/// A pose's bits, so runs compare to the last bit.
pub fn bits(p: Pose) -> [u64; 3] {
    [p.x.to_bits(), p.y.to_bits(), p.theta.to_bits()]
}

/// One robot at `robot` and pucks of type 0 at `pucks`, standard configuration otherwise.
pub fn scene(robot: Pose, pucks: &[Vec2]) -> World {
    let pucks: Vec<(PuckKind, Vec2)> = pucks.iter().map(|&p| (PuckKind(0), p)).collect();
    World::with_layout(&SceneConfig::default(), &[robot], &pucks).unwrap()
}

pub const FORWARD: WheelCommand = WheelCommand {
    forward: 1.0,
    turn: 0.0,
};
pub const BACK: WheelCommand = WheelCommand {
    forward: -1.0,
    turn: 0.0,
};
pub const LEFT: WheelCommand = WheelCommand {
    forward: 0.0,
    turn: 1.0,
};

/// Smallest signed difference between two angles.
pub fn angle_diff(a: f64, b: f64) -> f64 {
    let mut d = (a - b) % std::f64::consts::TAU;
    if d > std::f64::consts::PI {
        d -= std::f64::consts::TAU;
    }
    if d < -std::f64::consts::PI {
        d += std::f64::consts::TAU;
    }
    d
}

/// A digest of every coordinate's bits, so a change in the last bit shows.
pub fn digest(world: &World) -> u64 {
    let s = world.snapshot();
    let mut h: u64 = 0xcbf29ce484222325;
    let mut eat = |x: f64| {
        for b in x.to_bits().to_le_bytes() {
            h = (h ^ b as u64).wrapping_mul(0x100000001b3);
        }
    };
    for r in &s.robots {
        eat(r.pose.x);
        eat(r.pose.y);
        eat(r.pose.theta);
    }
    for p in &s.pucks {
        eat(p.pos.x);
        eat(p.pos.y);
    }
    h
}
