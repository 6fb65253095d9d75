//! Cuts arbitrary datagrams into the packets of a batch (several packets in
//! one datagram, `colony_wire::batch`), checks the pieces, and walks each.
//!
//! `cargo +nightly fuzz run split_batch` (from the repository root); the seeds
//! in `fuzz/corpus/split_batch/` also run in plain `cargo test -p colony-wire`.

#![no_main]

use libfuzzer_sys::fuzz_target;

// The walk of whole packets is the `parse_packet` target's; this one uses its batch part.
#[allow(dead_code)]
#[path = "../walk.rs"]
mod walk;

fuzz_target!(|data: &[u8]| {
    walk::walk_batch(data);
});
