//! Reads arbitrary datagrams as MURDOCH messages, sealed or not; whatever reads
//! must write back and read again to the same message.
//!
//! `cargo +nightly fuzz run tasks_decode` (from the repository root); the seeds
//! in `fuzz/corpus/tasks_decode/` also run in plain `cargo test -p colony-proto`
//! (`crates/proto/tests/murdoch_fuzz_corpus.rs`).

#![no_main]

use colony_proto::murdoch::Message;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // A seal that checks out reads as the message without it.
    if let Ok(packet) = colony_wire::Packet::parse(data) {
        if let Ok(signed) = Message::open(&packet) {
            assert_eq!(Message::decode(&packet), Ok(signed.message));
        }
    }
    if let Ok(message) = Message::decode_bytes(data) {
        let bytes = message
            .encode()
            .expect("a message that reads can be written");
        assert_eq!(Message::decode_bytes(&bytes), Ok(message));
    }
});
