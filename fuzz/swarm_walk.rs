//! What the `swarm_messages` fuzz target does with arbitrary bytes: every decoder of the `radio`
//! and swarm channels (`camera.N`, `vision`, `debug`, `metrics`), strict and skimming, and the
//! vision assembler; whatever decodes strictly must encode and decode again to the same message.
//! Shared with `crates/proto/tests/swarm_fuzz_corpus.rs`, which runs the seed corpus in plain
//! `cargo test`.

use colony_proto::radio;
use colony_proto::swarm::{camera, debug, metrics, vision, VisionAssembler};
use colony_wire::{Packet, Priority};

/// Feeds a datagram to every swarm decoder.
pub fn walk(data: &[u8]) {
    let Ok(p) = Packet::parse(data) else { return };
    if let Ok(cmds) = radio::decode(&p) {
        let b = radio::encode(&cmds, Priority(0)).unwrap();
        let again = radio::decode(&Packet::parse(&b).unwrap()).unwrap();
        assert_eq!(again.len(), cmds.len());
    }
    if let Ok(view) = camera::decode(&p) {
        if let Ok(b) = camera::encode(0, view.step, &view.observation) {
            let again = camera::decode(&Packet::parse(&b).unwrap()).unwrap();
            assert_eq!(again.step, view.step);
            assert_eq!(again.observation.pucks.len(), view.observation.pucks.len());
        }
    }
    if let Ok(i) = debug::decode(&p) {
        let b = debug::encode(&i).unwrap();
        let again = debug::decode(&Packet::parse(&b).unwrap()).unwrap();
        assert_eq!(again.intents.len(), i.intents.len());
    }
    let _ = debug::skim(&p);
    if let Ok(m) = metrics::decode(&p) {
        let b = metrics::encode(m).unwrap();
        let again = metrics::decode(&Packet::parse(&b).unwrap()).unwrap();
        assert_eq!(again.step, m.step);
    }
    let _ = metrics::skim(&p);
    if let Ok(part) = vision::decode(&p) {
        let mut a = VisionAssembler::new();
        if let Some(frame) = a.offer(part) {
            for b in vision::encode(&frame).unwrap() {
                vision::decode(&Packet::parse(&b).unwrap()).unwrap();
            }
        }
    }
    let _ = vision::skim(&p);
}
