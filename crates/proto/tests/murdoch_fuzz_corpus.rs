//! The `tasks_decode` fuzz target's seed corpus as plain regression tests:
//! every file in `fuzz/corpus/tasks_decode/` goes through what the target does
//! (read; if it reads, write it back and read it again to the same message).
//!
//! Files named `ok-*` must read; files named `bad-<kind>[--detail]*` must be
//! refused with that [`DecodeError`] variant (kebab case: `bad-unknown-message`
//! is `UnknownMessage`). Other files (what a fuzzing run adds) must only not panic.

use std::path::PathBuf;

use colony_proto::murdoch::Message;
use colony_proto::DecodeError;

fn corpus_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/tasks_decode")
}

/// The fuzz target's body.
fn walk(bytes: &[u8]) -> Result<Message, DecodeError> {
    // A seal that checks out reads as the message without it.
    if let Ok(packet) = colony_wire::Packet::parse(bytes) {
        if let Ok(signed) = Message::open(&packet) {
            assert_eq!(Message::decode(&packet).as_ref(), Ok(&signed.message));
        }
    }
    let message = Message::decode_bytes(bytes)?;
    let again = message
        .encode()
        .expect("a message that reads can be written");
    assert_eq!(Message::decode_bytes(&again).as_ref(), Ok(&message));
    Ok(message)
}

fn variant(e: &DecodeError) -> &'static str {
    match e {
        DecodeError::Packet(_) => "packet",
        DecodeError::Field(_) => "field",
        DecodeError::Empty => "empty",
        DecodeError::Missing(_) => "missing",
        DecodeError::UnknownMessage { .. } => "unknown-message",
        DecodeError::Bad { .. } | DecodeError::BadField { .. } => "bad",
        DecodeError::Header(_) => "header",
        DecodeError::Seal(_) => "seal",
    }
}

#[test]
fn every_corpus_file_survives_the_walk_and_meets_its_name() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(corpus_dir())
        .expect("the seed corpus exists")
        .map(|e| e.expect("a readable directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    let (mut ok, mut bad) = (0, 0);
    let mut kinds = std::collections::BTreeSet::new();
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let stem = name.split('.').next().unwrap();
        let result = walk(&std::fs::read(path).unwrap());
        if stem.starts_with("ok-") {
            if let Err(e) = &result {
                panic!("{name} should read: {e}");
            }
            ok += 1;
        } else if let Some(rest) = stem.strip_prefix("bad-") {
            let want = rest.split("--").next().unwrap();
            match &result {
                Ok(m) => panic!("{name} should be refused, read as {m:?}"),
                Err(e) => {
                    assert_eq!(variant(e), want, "{name}: {e}");
                    // Every refusal says where, except a packet with no body line.
                    assert!(
                        e.to_string().contains("line ") || matches!(e, DecodeError::Empty),
                        "{name}: {e}"
                    );
                }
            }
            kinds.insert(want.to_owned());
            bad += 1;
        }
    }
    assert!(
        ok >= 10 && bad >= 15,
        "{ok} valid and {bad} malformed seeds"
    );
    for k in [
        "packet",
        "field",
        "empty",
        "unknown-message",
        "bad",
        "header",
    ] {
        assert!(kinds.contains(k), "no seed for {k}");
    }
}
