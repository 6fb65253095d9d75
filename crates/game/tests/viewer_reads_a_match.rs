//! Everything a real match publishes on the channels a viewer watches (`game.state`,
//! `game.map`, `game.event`) reads with the lenient decoders the monitor uses, with no line
//! skipped, and says what the strict decoders say. (This held the monitor's own codec to the
//! game's once; both now read with `colony_proto::game`.)

use std::sync::Arc;

use colony_game::map::Battlefield;
use colony_game::matches::Match;
use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_proto::game::{Event, GameState, MapAssembler, EVENT, MAP, STATE};
use colony_wire::Packet;

fn ctf_map() -> Arc<Battlefield> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/ctf.map");
    Arc::new(Battlefield::from_file(&path).expect("maps/ctf.map"))
}

#[test]
fn everything_a_real_match_publishes_reads_for_a_viewer_with_no_skipped_line() {
    let setup = "alpha:tank,infantry,infantry bravo:scout,scout,amphibian";
    let teams = [
        TeamSetup::parse("red", setup).unwrap(),
        TeamSetup::parse("blue", setup).unwrap(),
    ];
    let mut rules = Rules::new(Mode::CaptureTheFlag);
    rules.time_limit_s = 120.0;
    let field = ctf_map();
    let mut m = Match::new(field.clone(), rules, &teams, &["red", "blue"]).unwrap();

    let mut map = MapAssembler::default();
    let mut last_state: Option<GameState> = None;
    let (mut states, mut maps, mut events, mut skipped) = (0, 0, 0, 0);
    m.run(1300, &mut |_, bytes| {
        let packet = Packet::parse(bytes).expect("the match publishes well-formed packets");
        if packet.has_subject(STATE) {
            states += 1;
            let strict = GameState::decode(&packet).expect("game.state decodes");
            let lenient = GameState::decode_lenient(&packet).expect("game.state has its head");
            skipped += lenient.bad_lines;
            assert_eq!(lenient.message, strict);
            last_state = Some(strict);
        } else if packet.has_subject(MAP) {
            maps += 1;
            map.on_packet(&packet);
        } else if packet.has_subject(EVENT) {
            let read = Event::decode_lenient(&packet);
            skipped += read.bad_lines;
            events += read.message.len();
            assert_eq!(read.message[0], Event::decode(&packet).unwrap());
        }
    });
    assert!(
        states > 100 && maps > 0 && events > 0,
        "{states} {maps} {events}"
    );
    assert_eq!(skipped, 0, "a viewer skipped lines of the game's packets");
    assert_eq!(map.bad_lines(), 0);
    let got = map.map().expect("the map was put together");
    assert_eq!(
        (got.width, got.height),
        (field.grid.width(), field.grid.height())
    );
    assert_eq!(got.sites.len(), 2);
    let state = last_state.expect("a state");
    assert_eq!(state.robots.len(), 12);
}
