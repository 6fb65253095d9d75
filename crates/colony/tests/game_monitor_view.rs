//! Everything a real match publishes, shown by the monitor's game view: the game and the monitor
//! read the same packets with `colony-proto`'s decoders, and this holds the monitor's view (what
//! the page draws) to what the game itself decoded.

use std::sync::Arc;
use std::time::Instant;

use colony_game::map::Battlefield;
use colony_game::matches::Match;
use colony_game::protocol::GameState;
use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_monitor::game::GameView;
use colony_wire::Packet;

fn ctf_map() -> Arc<Battlefield> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/ctf.map");
    Arc::new(Battlefield::from_file(&path).expect("maps/ctf.map"))
}

#[test]
fn everything_a_real_match_publishes_is_read_by_the_monitor() {
    let setup = "alpha:tank,infantry,infantry bravo:scout,scout,amphibian";
    let teams = [
        TeamSetup::parse("red", setup).unwrap(),
        TeamSetup::parse("blue", setup).unwrap(),
    ];
    let mut rules = Rules::new(Mode::CaptureTheFlag);
    rules.time_limit_s = 120.0;
    let field = ctf_map();
    let mut m = Match::new(field.clone(), rules, &teams, &["red", "blue"]).unwrap();

    let mut view = GameView::new(Instant::now(), 0);
    let mut last_state: Option<GameState> = None;
    let (mut states, mut maps, mut events) = (0, 0, 0);
    m.run(1300, &mut |_, bytes| {
        let Ok(packet) = Packet::parse(bytes) else {
            panic!("the match published a malformed packet");
        };
        let channel = packet.subjects().next().map(str::to_owned);
        match channel.as_deref() {
            Some("game.state") => {
                states += 1;
                last_state = Some(GameState::decode(&packet).expect("game.state decodes"));
            }
            Some("game.map") => maps += 1,
            Some("game.event") => events += 1,
            _ => return,
        }
        view.on_packet(Instant::now(), &packet);
    });
    assert!(
        states > 100 && maps > 0 && events > 0,
        "{states} {maps} {events}"
    );
    assert_eq!(
        view.bad_lines(),
        0,
        "the monitor skipped lines of the game's packets"
    );

    let map = view.map().expect("the monitor put the map together");
    assert_eq!(
        (map.width, map.height),
        (field.grid.width(), field.grid.height())
    );
    assert_eq!(map.sites.len(), 2);

    let game = last_state.expect("a state");
    let shown = view.state().expect("the monitor holds the state");
    assert_eq!(shown.mode, game.mode);
    assert!((shown.time - game.time).abs() < 1e-6);
    assert_eq!(shown.robots.len(), game.robots.len());
    for (s, g) in shown.robots.iter().zip(&game.robots) {
        assert_eq!((s.id, &s.team, &s.squad), (g.id, &g.team, &g.squad));
        assert_eq!((s.alive, &s.behaviour), (g.alive, &g.behaviour));
        assert!((s.health - g.health).abs() < 1e-6);
        assert!((s.pose.x - g.pose.x).abs() < 0.01 && (s.pose.y - g.pose.y).abs() < 0.01);
    }
    assert_eq!(shown.squads.len(), game.squads.len());
    for (s, g) in shown.squads.iter().zip(&game.squads) {
        assert_eq!((&s.name, &s.order), (&g.name, &g.order));
        assert_eq!(s.path.len(), g.path.len());
    }
    assert!(view.events().count() > 0);
}
