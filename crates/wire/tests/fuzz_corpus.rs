//! The fuzz target's seed corpus as plain regression tests: every file in
//! `fuzz/corpus/parse_packet/` goes through the same walk as the fuzz target.
//!
//! Files named `ok-*` must parse; files named `bad-<kind>[--detail]*` must be
//! rejected with that `ErrorKind` (kebab-case, so `bad-duplicate-name.txt` is
//! `DuplicateName`). Other files (what a fuzzing run adds) must only not panic.

use std::path::PathBuf;

#[path = "../../../fuzz/walk.rs"]
mod walk;

fn corpus_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/parse_packet")
}

fn kind_name(kebab: &str) -> String {
    kebab
        .split('-')
        .map(|word| {
            let mut chars = word.chars();
            match chars.next() {
                Some(first) => first.to_ascii_uppercase().to_string() + chars.as_str(),
                None => String::new(),
            }
        })
        .collect()
}

#[test]
fn every_corpus_file_survives_the_walk_and_meets_its_name() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(corpus_dir())
        .expect("the seed corpus exists")
        .map(|e| e.expect("a readable directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(
        files.len() >= 20,
        "the seed corpus has {} files",
        files.len()
    );
    let (mut ok, mut bad) = (0, 0);
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let stem = name.split('.').next().unwrap();
        let bytes = std::fs::read(path).unwrap();
        let result = walk::walk(&bytes);
        if stem.starts_with("ok-") {
            if let Err(e) = &result {
                panic!("{name} should parse: {e}");
            }
            ok += 1;
        } else if let Some(rest) = stem.strip_prefix("bad-") {
            let want = kind_name(rest.split("--").next().unwrap());
            match &result {
                Ok(()) => panic!("{name} should be rejected"),
                Err(e) => {
                    let got = format!("{:?}", e.kind);
                    assert!(
                        got.starts_with(&want)
                            && !got[want.len()..].starts_with(char::is_alphanumeric),
                        "{name}: expected {want}, got {got} ({e})"
                    );
                }
            }
            bad += 1;
        }
    }
    assert!(ok >= 5 && bad >= 10, "{ok} valid and {bad} malformed seeds");
}

#[test]
fn every_error_kind_has_a_seed() {
    let names: Vec<String> = std::fs::read_dir(corpus_dir())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    for kind in [
        "too-large",
        "empty",
        "not-utf8",
        "bad-header",
        "bad-subject",
        "duplicate-subject",
        "bad-priority",
        "control-char",
        "expected-label",
        "expected-name",
        "missing-value",
        "duplicate-name",
        "unclosed-group",
        "unmatched-close",
        "unterminated-string",
        "bad-escape",
        "too-deep",
    ] {
        assert!(
            names.iter().any(|n| n.starts_with(&format!("bad-{kind}"))),
            "no seed for {kind}"
        );
    }
}

/// The `split_batch` target's seeds: `ok-*` must split (each piece then
/// walked as a packet), `bad-*` must be refused, anything else must only
/// not panic.
#[test]
fn every_batch_seed_survives_the_walk_and_meets_its_name() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/split_batch");
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("the batch seed corpus exists")
        .map(|e| e.expect("a readable directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(
        files.len() >= 8,
        "the batch corpus has {} files",
        files.len()
    );
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let bytes = std::fs::read(path).unwrap();
        walk::walk_batch(&bytes);
        let split = colony_wire::batch::split(&bytes);
        if name.starts_with("ok-") {
            for r in split.unwrap_or_else(|e| panic!("{name} should split: {e}")) {
                colony_wire::Packet::parse(&bytes[r])
                    .unwrap_or_else(|e| panic!("{name}: a piece does not parse: {e}"));
            }
        } else if name.starts_with("bad-") {
            assert!(split.is_err(), "{name} should be refused");
        }
    }
}
