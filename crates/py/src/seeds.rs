//! Seeds for batched worlds: world `b` starts from `seed + b`, and a world whose
//! episode ended starts its next from a seed drawn from its last, so a batch is
//! reproducible from its first seeds alone, whatever the order worlds end in.

/// The most worlds one batch holds.
pub const MAX_WORLDS: usize = 65_536;

/// The most bodies (robots and pucks, or a battlefield's cells, over every
/// world) a batch is built with: about 1.3 KB each in the simulator (a cell
/// about 0.25 KB), so some 5 GB at most. A batch past it is refused with an
/// error, where building it would abort the process when memory ran out.
pub const MAX_BATCH_BODIES: u64 = 4_000_000;

/// The most observation values (over every world and agent) a batch is built
/// with: 8 GB of float32.
pub const MAX_BATCH_VALUES: u64 = 1 << 31;

/// Refuses a batch of no worlds, or of `worlds` worlds of `bodies` bodies and
/// `values` observation values each past the budgets above.
pub fn check_budget(worlds: usize, bodies: u64, values: u64) -> Result<(), String> {
    if worlds == 0 || worlds > MAX_WORLDS {
        return Err(format!("worlds must be 1 to {MAX_WORLDS}, not {worlds}"));
    }
    let worlds = worlds as u64;
    if worlds.saturating_mul(bodies) > MAX_BATCH_BODIES {
        return Err(format!(
            "{worlds} worlds of {bodies} bodies is more than the {MAX_BATCH_BODIES} bodies a batch takes"
        ));
    }
    if worlds.saturating_mul(values) > MAX_BATCH_VALUES {
        return Err(format!(
            "{worlds} worlds of {values} observation values is more than the {MAX_BATCH_VALUES} a batch takes"
        ));
    }
    Ok(())
}

/// The seed after `seed` (SplitMix64's mix of `seed` plus its increment): well
/// spread, so consecutive worlds' follow-on seeds do not collide.
pub fn next_seed(seed: u64) -> u64 {
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seeds a batch's worlds start again with: those given, one per world;
/// or `seed + b` for world `b`; or (neither) the seed after each world's last.
pub fn restart(
    seed: Option<u64>,
    given: Option<Vec<u64>>,
    last: &[u64],
) -> Result<Vec<u64>, String> {
    match (seed, given) {
        (Some(_), Some(_)) => Err("give seed or seeds, not both".to_string()),
        (None, Some(s)) if s.len() != last.len() => {
            Err(format!("{} seeds for {} worlds", s.len(), last.len()))
        }
        (None, Some(s)) => Ok(s),
        (Some(first), None) => Ok(firsts(first, last.len())),
        (None, None) => Ok(last.iter().map(|&s| next_seed(s)).collect()),
    }
}

/// World `b`'s first seed, `seed + b` (wrapping at 2^64).
pub fn firsts(seed: u64, worlds: usize) -> Vec<u64> {
    (0..worlds as u64).map(|b| seed.wrapping_add(b)).collect()
}

/// How many seeds a world that ended tries before its reset fails: a crowded
/// scene cannot be laid out from every seed.
pub const RESET_TRIES: usize = 16;

/// Starts a world that ended again from the seed after `*seed`, or from the
/// seeds after that while its world cannot be laid out; `*seed` becomes the seed
/// it started from (or the last one tried), so a failure is not retried forever
/// from the same seed and a batch stays reproducible from its first seeds.
pub fn autoreset<E>(seed: &mut u64, mut reset: impl FnMut(u64) -> Result<(), E>) -> Result<(), E> {
    let mut tries = 1;
    loop {
        *seed = next_seed(*seed);
        match reset(*seed) {
            Err(_) if tries < RESET_TRIES => tries += 1,
            done => return done,
        }
    }
}
