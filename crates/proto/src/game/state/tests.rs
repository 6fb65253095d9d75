//! The game state's round trips, and what a viewer's lenient reading skips.

use super::*;
use proptest::prelude::*;

/// A state as the game writes one (the monitor's own test packet).
const STATE_PACKET: &str = "@ <game.state> 0\n\
game mode ctf status running time 12.4 winner - reason \"\"\n\
team name red score 0 kills 1\n\
team name blue score 1 kills 0\n\
flag team blue x 800 y 900 home 0 carrier 3\n\
flag team red x 100 y 90 home 1\n\
robot id 4 team blue squad alpha kind scout x 700 y 800 theta 3.1 health 45 alive 1 behaviour goto reason \"following the path\"\n\
robot id 3 team red squad alpha kind tank x 310.5 y 88.2 theta 1.57 health 120 alive 1 behaviour shoot reason \"enemy 4 in range\"\n\
squad team red name alpha formation wedge order \"attack robot 4\" behaviour attack path \"310,88 400,120 700,800\"\n";

fn sample() -> GameState {
    GameState::decode(&Packet::parse(STATE_PACKET.as_bytes()).unwrap()).unwrap()
}

#[test]
fn a_state_is_read_whole_and_reencodes_to_itself() {
    let s = sample();
    assert_eq!(
        (s.mode.as_str(), s.status, s.time),
        ("ctf", Status::Running, 12.4)
    );
    assert_eq!(s.winner, None);
    assert_eq!(s.teams[1].score, 1);
    assert_eq!(s.flags[0].carrier, Some(3));
    assert!(s.flags[1].home);
    assert_eq!(s.robots[1].kind, RobotKind::Tank);
    assert_eq!(s.robots[1].reason, "enemy 4 in range");
    assert_eq!(s.squads[0].formation, Formation::Wedge);
    assert_eq!(
        s.squads[0].path,
        [
            Vec2::new(310.0, 88.0),
            Vec2::new(400.0, 120.0),
            Vec2::new(700.0, 800.0)
        ]
    );
    let again = GameState::decode(&Packet::parse(&s.encode().unwrap()).unwrap()).unwrap();
    assert_eq!(again, s);
    let lenient = GameState::decode_lenient(&Packet::parse(STATE_PACKET.as_bytes()).unwrap());
    assert_eq!(
        lenient,
        Ok(Skimmed {
            message: s,
            bad_lines: 0
        })
    );
}

#[test]
fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
    let mut s = sample();
    s.winner = Some("red".into());
    s.status = Status::Over;
    crate::table::check::codec(&TABLE, &[s.encode().unwrap()], |p| {
        GameState::decode(p).is_ok()
    });
}

#[test]
fn a_viewer_skips_and_counts_what_a_node_refuses() {
    let text = "@ <game.state> 0\n\
game mode ctf status running time 1 winner red reason \"flag home\" future (a 1)\n\
robot id -1 team red squad a kind tank x 0 y 0 theta 0 health 1 alive 1\n\
robot id 2 team \"red team\" squad a kind tank x 0 y 0 theta 0 health 1 alive 1\n\
robot id 3 team red squad a kind tank x nan y 0 theta 0 health 1 alive 1\n\
robot id 4 team red squad a kind tank x 0 y 0 theta 0 health 1 alive 2\n\
robot id 5 team red squad a kind tank x 1e7 y 0 theta 0 health 1 alive 1\n\
robot id 6 team red squad a kind tank x 5 y 6 theta 0 health 1 alive 1 colour green\n\
squad team red name a formation wedge order \"\" behaviour \"\" path \"1,2 3\"\n\
squad team red name b formation line\n\
flag team red x 1 y 2 carrier 99999999999\n\
ufo x 1\n";
    let p = Packet::parse(text.as_bytes()).unwrap();
    assert!(GameState::decode(&p).is_err());
    let read = GameState::decode_lenient(&p).unwrap();
    assert_eq!(read.bad_lines, 5 + 1 + 1);
    let s = read.message;
    assert_eq!(s.winner.as_deref(), Some("red"));
    assert_eq!(s.robots.iter().map(|r| r.id).collect::<Vec<_>>(), [6]);
    assert_eq!(s.robots[0].behaviour, "", "a missing text reads as empty");
    assert_eq!(s.squads.len(), 1);
    assert_eq!(s.squads[0].name, "b");
    assert!(s.squads[0].path.is_empty());
    assert!(s.flags.is_empty());
    let headless = Packet::parse(b"@ <game.state> 0\nteam name red score 0 kills 0\n").unwrap();
    assert_eq!(
        GameState::decode_lenient(&headless),
        Err(DecodeError::Missing("game"))
    );
    let bad_status =
        Packet::parse(b"@ <game.state> 0\ngame mode ctf status paused time 1 winner -\n").unwrap();
    assert!(GameState::decode_lenient(&bad_status).is_err());
}

fn name_strategy() -> impl Strategy<Value = String> {
    "[a-z][a-z0-9_]{0,12}"
}

fn robot() -> impl Strategy<Value = RobotState> {
    (
        any::<u32>(),
        name_strategy(),
        proptest::sample::select(RobotKind::ALL.to_vec()),
        (-1e5f64..1e5, -1e5f64..1e5, -4f64..4.0),
        0f64..500.0,
        any::<bool>(),
        "[a-z -]{0,20}",
    )
        .prop_map(
            |(id, squad, kind, (x, y, theta), health, alive, why)| RobotState {
                id,
                team: "red".into(),
                squad,
                kind,
                pose: Pose {
                    x: r(x),
                    y: r(y),
                    theta: r(theta),
                },
                health: r(health),
                max_health: r(health + 10.0),
                power: 15.0,
                alive,
                behaviour: "goto".into(),
                reason: why,
            },
        )
}

fn squad() -> impl Strategy<Value = SquadState> {
    (
        name_strategy(),
        proptest::sample::select(Formation::ALL.to_vec()),
        proptest::collection::vec((-100_000i32..100_000, -100_000i32..100_000), 0..10),
    )
        .prop_map(|(name, formation, path)| SquadState {
            team: "blue".into(),
            name,
            formation,
            order: "attack robot 4".into(),
            behaviour: "attack".into(),
            path: path
                .into_iter()
                .map(|(x, y)| Vec2::new(f64::from(x), f64::from(y)))
                .collect(),
        })
}

proptest! {
    #[test]
    fn any_state_reencodes_to_itself(
        over: bool,
        winner in proptest::option::of(name_strategy()),
        time in 0f64..1e5,
        robots in proptest::collection::vec(robot(), 0..8),
        squads in proptest::collection::vec(squad(), 0..4),
        carrier in proptest::option::of(any::<u32>()),
    ) {
        let s = GameState {
            mode: "dm".into(),
            status: if over { Status::Over } else { Status::Running },
            time: r(time),
            winner,
            reason: "time is up".into(),
            teams: vec![TeamState { name: "red".into(), score: 2, kills: 7 }],
            flags: vec![FlagState { team: "red".into(), at: Vec2::new(1.5, 2.0), carrier, home: carrier.is_none() }],
            robots,
            squads,
        };
        let bytes = s.encode().unwrap();
        let p = Packet::parse(&bytes).unwrap();
        prop_assert_eq!(GameState::decode(&p).unwrap(), s.clone());
        prop_assert_eq!(GameState::decode_lenient(&p).unwrap(), Skimmed { message: s, bad_lines: 0 });
    }

    #[test]
    fn the_state_decoders_never_panic(text in "[a-z0-9 .,\"\n-]{0,300}") {
        let bytes = format!("@ <game.state> 0\ngame mode ctf status running time 1 winner -\n{text}");
        if let Ok(p) = Packet::parse(bytes.as_bytes()) {
            let strict = GameState::decode(&p);
            let lenient = GameState::decode_lenient(&p);
            if let Ok(s) = strict {
                prop_assert_eq!(lenient.unwrap(), Skimmed { message: s, bad_lines: 0 });
            }
        }
    }
}

#[test]
fn as_json_a_state_writes_poses_and_places_as_x_y_and_paths_as_pairs() {
    assert_eq!(
        serde_json::to_string(&sample()).unwrap(),
        r#"{"mode":"ctf","status":"running","time":12.4,"winner":null,"reason":"","teams":[{"name":"red","score":0,"kills":1},{"name":"blue","score":1,"kills":0}],"flags":[{"team":"blue","x":800.0,"y":900.0,"home":false,"carrier":3},{"team":"red","x":100.0,"y":90.0,"home":true,"carrier":null}],"robots":[{"id":4,"team":"blue","squad":"alpha","kind":"scout","x":700.0,"y":800.0,"theta":3.1,"health":45.0,"max_health":45.0,"power":0.0,"alive":true,"behaviour":"goto","reason":"following the path"},{"id":3,"team":"red","squad":"alpha","kind":"tank","x":310.5,"y":88.2,"theta":1.57,"health":120.0,"max_health":120.0,"power":0.0,"alive":true,"behaviour":"shoot","reason":"enemy 4 in range"}],"squads":[{"team":"red","name":"alpha","formation":"wedge","order":"attack robot 4","behaviour":"attack","path":[[310.0,88.0],[400.0,120.0],[700.0,800.0]]}]}"#
    );
}
