//! `cargo +nightly fuzz run parse_map` (from the repository root); the seeds in
//! `fuzz/corpus/parse_map/` also run in plain `cargo test -p colony-game`.

#![no_main]

use libfuzzer_sys::fuzz_target;

// Each target uses one of the two walks.
#[allow(dead_code)]
#[path = "../game_walk.rs"]
mod game_walk;

fuzz_target!(|data: &[u8]| {
    game_walk::walk_map(data);
});
