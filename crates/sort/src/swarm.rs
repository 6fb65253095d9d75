//! What a swarm stepped in one process shares wherever it is stepped (a batch trial in
//! colony-lab, the live world's in-world controllers, the Python environment in colony-env):
//! the per-robot random streams and the chunk robots decide in on rayon's threads. They are
//! here, beside the controllers, so that every runner makes the same streams and a run is
//! reproduced bit for bit by any of them.

use rand_chacha::rand_core::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The fewest robots one thread senses and decides for in a go (rayon's minimum chunk):
/// smaller chunks make the threads' hand-offs cost more than the work.
pub const ROBOTS_PER_TASK: usize = 32;

/// The per-robot random streams of a trial: independent of each other and
/// of the world's own stream.
pub fn robot_rng(seed: u64, robot: usize) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream((robot as u64).wrapping_add(1));
    rng
}
