//! The monitor reads and writes the game's packets with `colony-wire` alone,
//! not through the game crate (it stays a plain hub client). These tests
//! hold the two to one format: what the game page sends is what the game
//! server reads, and everything a real match publishes is what the page
//! shows.

use std::sync::Arc;
use std::time::Instant;

use colony_game::map::Battlefield;
use colony_game::matches::Match;
use colony_game::protocol::{GameState, SquadCommand};
use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_monitor::game::squad::SquadMsg;
use colony_monitor::game::GameView;
use colony_wire::Packet;

fn ctf_map() -> Arc<Battlefield> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/ctf.map");
    Arc::new(Battlefield::from_file(&path).expect("maps/ctf.map"))
}

#[test]
fn every_squad_command_the_page_can_send_is_read_by_the_game_server_as_sent() {
    let targets = [
        r#""robot":7"#,
        r#""flag":"blue""#,
        r#""base":"red""#,
        r#""x":120.5,"y":-33.25"#,
    ];
    let mut bodies = vec![
        r#""do":"gather""#.to_string(),
        r#""do":"gather","x":10,"y":20.125"#.to_string(),
        r#""do":"goto","x":1500,"y":0.01"#.to_string(),
        r#""do":"capture","flag":"blue""#.to_string(),
        r#""do":"stop""#.to_string(),
    ];
    for t in targets {
        bodies.push(format!(r#""do":"attack",{t}"#));
        if !t.starts_with(r#""x""#) {
            bodies.push(format!(r#""do":"defend",{t}"#));
        }
    }
    let formations = [
        "",
        r#","formation":"line""#,
        r#","formation":"circle""#,
        r#","formation":"half-circle""#,
        r#","formation":"wedge""#,
        r#","formation":"inverse-wedge""#,
    ];
    let mut checked = 0;
    for body in &bodies {
        for formation in formations {
            let json = format!(r#"{{"t":"squad","team":"red","squad":"alpha",{body}{formation}}}"#);
            let msg: SquadMsg = serde_json::from_str(&json).expect(&json);
            let order = msg.check().unwrap_or_else(|e| panic!("{json}: {e}"));
            let sent = order.packet().expect("the page's packet builds");
            let packet = Packet::parse(&sent).expect("the page's packet parses");
            let read = SquadCommand::decode("red", &packet)
                .unwrap_or_else(|e| panic!("the game refuses {json}: {e}"));
            assert_eq!(read.len(), 1, "{json}");
            // The game, writing the command it read, writes the same bytes.
            assert_eq!(
                read[0].encode().expect("the game re-encodes it"),
                sent,
                "{json}: {}",
                String::from_utf8_lossy(&sent)
            );
            assert_eq!(read[0].squad, "alpha");
            checked += 1;
        }
    }
    assert_eq!(checked, 12 * 6);
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
        assert!((s.x - g.pose.x).abs() < 0.01 && (s.y - g.pose.y).abs() < 0.01);
    }
    assert_eq!(shown.squads.len(), game.squads.len());
    for (s, g) in shown.squads.iter().zip(&game.squads) {
        assert_eq!((&s.name, &s.order), (&g.name, &g.order));
        assert_eq!(s.path.len(), g.path.len());
    }
    assert!(view.events().count() > 0);
}
