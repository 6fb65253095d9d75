//! Parses arbitrary datagrams and reads everything out of whatever parses.
//!
//! `cargo +nightly fuzz run parse_packet` (from the repository root); the seeds
//! in `fuzz/corpus/parse_packet/` also run in plain `cargo test -p colony-wire`.

#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../walk.rs"]
mod walk;

fuzz_target!(|data: &[u8]| {
    let _ = walk::walk(data);
});
