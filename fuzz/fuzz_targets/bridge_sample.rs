//! Reads arbitrary bytes as a Zenoh sample reaching a bridge: its key (up to
//! the first NUL), its payload (up to the next) and its attachment (the
//! rest). Nothing may panic; a sample the bridge would publish into its hub
//! must be a packet on exactly the subjects of its key.
//!
//! `cargo +nightly fuzz run bridge_sample` (from the repository root); the
//! seeds in `fuzz/corpus/bridge_sample/` also run in plain `cargo test -p
//! colony-bridge` (`crates/bridge/tests/fuzz_corpus.rs`).

#![no_main]

use libfuzzer_sys::fuzz_target;

include!("../bridge_walk.rs");

fuzz_target!(|data: &[u8]| {
    walk(data);
});
