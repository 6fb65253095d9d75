//! `cargo +nightly fuzz run swarm_messages` (from `fuzz/`); the seeds in
//! `fuzz/corpus/swarm_messages/` also run in plain `cargo test -p colony-proto`.

#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../swarm_walk.rs"]
mod swarm_walk;

fuzz_target!(|data: &[u8]| {
    swarm_walk::walk(data);
});
