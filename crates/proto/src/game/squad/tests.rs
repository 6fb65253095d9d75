//! The squad command's round trips: every command the game page can produce (the contract the
//! monitor and the game server once kept by a separate test) and any command at all.

use super::*;
use proptest::prelude::*;

fn decode(bytes: &[u8]) -> Vec<SquadCommand> {
    SquadCommand::decode("red", &Packet::parse(bytes).unwrap()).unwrap()
}

fn command(verb: Verb, formation: Option<Formation>) -> SquadCommand {
    SquadCommand {
        team: "red".into(),
        squad: "alpha".into(),
        verb,
        formation,
    }
}

/// What the game page offers: gather (here or at a point), go to, capture, stop, and attack or
/// defend a robot, a flag or a base (attack also a point).
fn page_verbs() -> Vec<Verb> {
    let targets = [
        Target::Robot(7),
        Target::Flag("blue".into()),
        Target::Base("red".into()),
        Target::Point(Vec2::new(120.5, -33.25)),
    ];
    let mut verbs = vec![
        Verb::Gather(None),
        Verb::Gather(Some(Vec2::new(10.0, 20.13))),
        Verb::GoTo(Vec2::new(1500.0, 0.01)),
        Verb::Capture("blue".into()),
        Verb::Stop,
    ];
    for t in targets {
        verbs.push(Verb::Attack(t.clone()));
        if !matches!(t, Target::Point(_)) {
            verbs.push(Verb::Defend(t));
        }
    }
    verbs
}

#[test]
fn every_command_the_page_can_send_is_read_as_sent_byte_for_byte() {
    let mut checked = 0;
    for verb in page_verbs() {
        for formation in std::iter::once(None).chain(Formation::ALL.map(Some)) {
            let sent = command(verb.clone(), formation);
            let bytes = sent.encode().unwrap();
            let read = decode(&bytes);
            assert_eq!(
                read,
                vec![sent.clone()],
                "{}",
                String::from_utf8_lossy(&bytes)
            );
            assert_eq!(read[0].encode().unwrap(), bytes);
            checked += 1;
        }
    }
    assert_eq!(checked, 12 * 6);
}

#[test]
fn the_packets_are_the_lines_the_game_reads() {
    let cases = [
        (
            command(Verb::Attack(Target::Robot(7)), Some(Formation::Wedge)),
            "squad name alpha do attack robot 7 formation wedge",
        ),
        (
            command(Verb::Gather(None), None),
            "squad name alpha do gather",
        ),
        (
            command(Verb::Gather(Some(Vec2::new(10.0, -2.5))), None),
            "squad name alpha do gather x 10.0 y -2.5",
        ),
        (
            command(
                Verb::GoTo(Vec2::new(310.456, 88.0)),
                Some(Formation::InverseWedge),
            ),
            "squad name alpha do goto x 310.46 y 88.0 formation inverse-wedge",
        ),
        (
            command(
                Verb::Defend(Target::Base("red".into())),
                Some(Formation::HalfCircle),
            ),
            "squad name alpha do defend base red formation half-circle",
        ),
        (
            command(Verb::Capture("blue".into()), Some(Formation::Line)),
            "squad name alpha do capture flag blue formation line",
        ),
        (command(Verb::Stop, None), "squad name alpha do stop"),
    ];
    for (c, line) in cases {
        assert_eq!(
            String::from_utf8(c.encode().unwrap()).unwrap(),
            format!("@ <game.player.red> 0\n{line}\n")
        );
    }
}

#[test]
fn bad_squad_commands_name_the_problem() {
    let p = b"@ <game.player.red> 0\nsquad name a do dance\n";
    let e = SquadCommand::decode("red", &Packet::parse(p).unwrap()).unwrap_err();
    assert!(
        e.to_string().contains("unknown squad command \"dance\""),
        "{e}"
    );
    let p = b"@ <game.player.red> 0\nsquad name a do goto x 1e300 y 0\n";
    assert!(SquadCommand::decode("red", &Packet::parse(p).unwrap()).is_err());
    let p = b"@ <game.player.red> 0\nsquad name a do attack\n";
    assert!(SquadCommand::decode("red", &Packet::parse(p).unwrap()).is_err());
    let p = b"@ <game.player.red> 0\nsquad name a do stop formation square\n";
    assert!(SquadCommand::decode("red", &Packet::parse(p).unwrap()).is_err());
}

fn point() -> impl Strategy<Value = Vec2> {
    (-1e5f64..1e5, -1e5f64..1e5).prop_map(|(x, y)| Vec2::new(r(x), r(y)))
}

fn team() -> impl Strategy<Value = String> {
    "[a-z][a-z0-9_-]{0,31}"
}

fn target() -> impl Strategy<Value = Target> {
    prop_oneof![
        any::<u32>().prop_map(Target::Robot),
        team().prop_map(Target::Flag),
        team().prop_map(Target::Base),
        point().prop_map(Target::Point),
    ]
}

fn verb() -> impl Strategy<Value = Verb> {
    prop_oneof![
        proptest::option::of(point()).prop_map(Verb::Gather),
        point().prop_map(Verb::GoTo),
        target().prop_map(Verb::Defend),
        target().prop_map(Verb::Attack),
        team().prop_map(Verb::Capture),
        Just(Verb::Stop),
    ]
}

proptest! {
    #[test]
    fn any_squad_command_reencodes_to_itself(
        squad in team(),
        verb in verb(),
        formation in proptest::option::of(proptest::sample::select(Formation::ALL.to_vec())),
    ) {
        let c = SquadCommand { team: "red".into(), squad, verb, formation };
        let bytes = c.encode().unwrap();
        prop_assert_eq!(decode(&bytes), vec![c]);
    }

    #[test]
    fn the_squad_decoder_never_panics(text in "[a-z0-9 .\"\n-]{0,200}") {
        let bytes = format!("@ <game.player.red> 0\n{text}");
        if let Ok(p) = Packet::parse(bytes.as_bytes()) {
            let _ = SquadCommand::decode("red", &p);
        }
    }
}
