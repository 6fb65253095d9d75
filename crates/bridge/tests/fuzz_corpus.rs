//! The `bridge_sample` fuzz target's seed corpus as plain regression tests:
//! every file in `fuzz/corpus/bridge_sample/` goes through what the target
//! does. Files named `ok-*` must be taken, `bad-*` refused; others (what a
//! fuzzing run adds) must only not panic.

use std::path::PathBuf;

include!("../../../fuzz/bridge_walk.rs");

#[test]
fn every_corpus_file_survives_the_walk_and_meets_its_name() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/bridge_sample");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("the seed corpus exists")
        .map(|e| e.expect("a readable directory entry").path())
        .collect();
    files.sort();
    let (mut ok, mut bad) = (0, 0);
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let taken = walk(&std::fs::read(path).unwrap());
        if name.starts_with("ok-") {
            assert!(taken, "{name} should be taken");
            ok += 1;
        } else if name.starts_with("bad-") {
            assert!(!taken, "{name} should be refused");
            bad += 1;
        }
    }
    assert!(ok >= 3 && bad >= 6, "{ok} taken and {bad} refused seeds");
}
