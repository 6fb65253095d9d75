//! What the game's fuzz targets do with arbitrary bytes: every decoder of
//! the game's packets, and the map and scenario parsers; whatever decodes
//! must encode and decode again to the same value. Shared with
//! `crates/game/tests/fuzz_corpus.rs`, which runs the seed corpus in plain
//! `cargo test`.

use colony_proto::game::{
    Action, ChatLine, Event, GameState, LobbyState, MapAssembler, Order, PlayerCommand, RobotDebug,
    Sense, SquadCommand, WorldFrame,
};
use colony_wire::Packet;

/// Feeds a datagram to every game decoder.
pub fn walk_messages(data: &[u8]) {
    let Ok(p) = Packet::parse(data) else { return };
    if let Ok(s) = Sense::decode(&p) {
        if let Ok(b) = s.encode(0) {
            let again = Sense::decode(&Packet::parse(&b).unwrap()).unwrap();
            assert_eq!(again.step, s.step);
        }
    }
    if let Ok(o) = Order::decode(&p) {
        let b = o.encode().unwrap();
        let again = Order::decode(&Packet::parse(&b).unwrap()).unwrap();
        assert_eq!(again.commands.len(), o.commands.len());
    }
    if let Ok(cmds) = SquadCommand::decode("red", &p) {
        for c in cmds {
            let b = c.encode().unwrap();
            let again = SquadCommand::decode("red", &Packet::parse(&b).unwrap()).unwrap();
            assert_eq!(again.len(), 1);
        }
    }
    if let Ok(cmds) = PlayerCommand::decode("red", &p) {
        for c in cmds {
            let b = c.encode().unwrap();
            let again = PlayerCommand::decode("red", &Packet::parse(&b).unwrap()).unwrap();
            assert_eq!(again.len(), 1);
        }
    }
    if let Ok(lines) = ChatLine::decode("red", &p) {
        for l in lines {
            let b = l.encode().unwrap();
            assert_eq!(
                ChatLine::decode("red", &Packet::parse(&b).unwrap()).unwrap(),
                vec![l]
            );
        }
    }
    if let Ok(l) = LobbyState::decode(&p) {
        let b = l.encode().unwrap();
        let again = LobbyState::decode(&Packet::parse(&b).unwrap()).unwrap();
        // Numbers are written to 0.01: compare what is exact.
        assert_eq!((again.teams, again.kinds.len()), (l.teams, l.kinds.len()));
    }
    let _ = WorldFrame::decode(&p);
    let _ = Action::decode(&p);
    let _ = RobotDebug::decode(&p);
    let _ = Event::decode(&p);
    let _ = Event::decode_lenient(&p);
    let _ = colony_proto::radio::decode(&p);
    MapAssembler::default().on_packet(&p);
    if let Ok(s) = GameState::decode(&p) {
        let b = s.encode().unwrap();
        let again = GameState::decode(&Packet::parse(&b).unwrap()).unwrap();
        assert_eq!(again.robots.len(), s.robots.len());
    }
    if let Ok(lenient) = GameState::decode_lenient(&p) {
        let b = lenient.message.encode().unwrap();
        let again = GameState::decode(&Packet::parse(&b).unwrap()).unwrap();
        assert_eq!(again.robots.len(), lenient.message.robots.len());
    }
}

/// Feeds a file to the map and scenario parsers.
pub fn walk_map(data: &[u8]) {
    if let Ok(field) = colony_game::map::Battlefield::parse_bytes(data) {
        for t in &field.teams {
            assert!(field.grid.contains(t.base) && field.grid.contains(t.flag));
        }
    }
    let _ = colony_game::map::GridMap::parse_bytes(data);
    let _ = colony_game::path::scen::parse_bytes(data);
}
