//! The game's fuzz targets' seed corpora as plain regression tests, and the
//! same walks over arbitrary bytes with proptest: no decoder or parser of
//! outside input may panic.

#[path = "../../../fuzz/game_walk.rs"]
mod game_walk;

use std::path::PathBuf;

use proptest::prelude::*;

fn corpus(name: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/corpus")
        .join(name);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("the seed corpus exists")
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert!(
        files.len() >= 3,
        "{} has {} seeds",
        dir.display(),
        files.len()
    );
    files
        .into_iter()
        .map(|f| {
            let bytes = std::fs::read(&f).unwrap();
            (f, bytes)
        })
        .collect()
}

#[test]
fn every_message_seed_survives_the_walk() {
    for (_, bytes) in corpus("game_messages") {
        game_walk::walk_messages(&bytes);
    }
}

#[test]
fn every_map_seed_survives_the_walk() {
    for (_, bytes) in corpus("parse_map") {
        game_walk::walk_map(&bytes);
    }
}

fn packetish() -> impl Strategy<Value = Vec<u8>> {
    let words = prop::sample::select(vec![
        "@ <game.robot.1> 0\n", "@ <game.player.red> 0\n", "@ <game.state> 0\n", "order robot 1 seq 2\n",
        "goto x 1 y 2\n", "squad name a do ", "attack robot 3", "game mode ctf status over time 1 winner - reason \"\"\n",
        "robot id 0 team red squad a kind tank x 0 y 0 theta 0 health 1 alive 1 behaviour b reason r\n",
        " formation wedge\n", "flag team red x 0 y 0 home 1\n", "-1", "1e999", "\"", "(", ")", " ", "\n",
    ]);
    prop::collection::vec(words, 0..24).prop_map(|w| w.concat().into_bytes())
}

proptest! {
    #[test]
    fn arbitrary_bytes_never_panic_a_decoder(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        game_walk::walk_messages(&bytes);
        game_walk::walk_map(&bytes);
    }

    #[test]
    fn packet_like_text_never_panics_a_decoder(bytes in packetish()) {
        game_walk::walk_messages(&bytes);
    }
}
