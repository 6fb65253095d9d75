//! The `swarm_messages` fuzz target's seed corpus as plain regression tests: every file in
//! `fuzz/corpus/swarm_messages/` goes through what the target does (every swarm decoder, and
//! whatever decodes written back and read again), and must not panic. Files named `ok-*` must
//! be read by the strict decoder of their channel, files named `bad-*` refused by it; other
//! files (what a fuzzing run adds) must only not panic.

use std::path::PathBuf;

use colony_proto::radio;
use colony_proto::swarm::{camera, debug, metrics, vision};
use colony_wire::Packet;

#[path = "../../../fuzz/swarm_walk.rs"]
mod swarm_walk;

fn corpus_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/swarm_messages")
}

/// Whether the strict decoder of the packet's channel reads it.
fn reads(bytes: &[u8]) -> bool {
    let Ok(p) = Packet::parse(bytes) else {
        return false;
    };
    let channel = p.subjects().next().unwrap_or("").to_owned();
    match channel.as_str() {
        "radio" => radio::decode(&p).is_ok(),
        "debug" => debug::decode(&p).is_ok(),
        "metrics" => metrics::decode(&p).is_ok(),
        "vision" => vision::decode(&p).is_ok(),
        c if c.starts_with("camera.") => camera::decode(&p).is_ok(),
        _ => false,
    }
}

#[test]
fn every_seed_goes_through_the_swarm_decoders_as_its_name_says() {
    let mut files: Vec<_> = std::fs::read_dir(corpus_dir())
        .expect("fuzz/corpus/swarm_messages")
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let (mut ok, mut bad) = (0, 0);
    for path in &files {
        let bytes = std::fs::read(path).unwrap();
        swarm_walk::walk(&bytes);
        let name = path.file_name().unwrap().to_string_lossy();
        if name.starts_with("ok-") {
            assert!(reads(&bytes), "{name} should read");
            ok += 1;
        } else if name.starts_with("bad-") {
            assert!(!reads(&bytes), "{name} should be refused");
            bad += 1;
        }
    }
    assert!(ok >= 5 && bad >= 5, "{ok} ok and {bad} bad seeds");
}
