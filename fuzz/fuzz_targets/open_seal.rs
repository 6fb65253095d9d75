//! Opens arbitrary datagrams as sealed packets (`colony_wire::seal`): whatever
//! opens must open to a body that, sealed again under any key, opens once more.
//!
//! `cargo +nightly fuzz run open_seal` (from the repository root); the seeds
//! in `fuzz/corpus/open_seal/` also run in plain `cargo test -p colony-wire`.

#![no_main]

use colony_wire::seal::{self, Identity};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let stripped = seal::strip(data);
    if let Ok(opened) = seal::open(data) {
        assert_eq!(opened.body, stripped);
        let mut id = Identity::from_seed([1; 32]);
        let again = id.sealed(opened.body.to_vec());
        assert_eq!(seal::open(&again).map(|o| o.body), Ok(opened.body));
    }
});
