//! The `open_seal` fuzz target's seeds as plain regression tests: `ok-*` must
//! open, `bad-*` must be refused, anything else must only not panic.

use std::path::PathBuf;

use colony_wire::seal::{self, Identity};

/// The fuzz target's body.
fn walk(data: &[u8]) -> bool {
    let stripped = seal::strip(data);
    match seal::open(data) {
        Ok(opened) => {
            assert_eq!(opened.body, stripped);
            let mut id = Identity::from_seed([1; 32]);
            let again = id.sealed(opened.body.to_vec());
            assert_eq!(seal::open(&again).map(|o| o.body), Ok(opened.body));
            true
        }
        Err(_) => false,
    }
}

#[test]
fn every_seal_seed_survives_the_walk_and_meets_its_name() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/open_seal");
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("the seal seed corpus exists")
        .map(|e| e.expect("a readable directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(
        files.len() >= 8,
        "the seal corpus has {} files",
        files.len()
    );
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let opened = walk(&std::fs::read(path).unwrap());
        if name.starts_with("ok-") {
            assert!(opened, "{name} should open");
        } else if name.starts_with("bad-") {
            assert!(!opened, "{name} should be refused");
        }
    }
}
