//! A player's commands beyond whole squads, in fast-forwarded matches on the Capture the Flag
//! map: single-robot orders, drawn paths, splitting and merging squads, direct control, and
//! the referee's refusals.

use std::sync::Arc;

use colony_game::map::{Battlefield, Cell, Terrain};
use colony_game::matches::Match;
use colony_game::protocol::{GameState, PlayerCommand, SquadCommand, Target, Verb};
use colony_game::rules::{Mode, Rules, TeamSetup};
use colony_sim::field::FieldRobotId;
use colony_sim::Vec2;

fn map() -> Arc<Battlefield> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/ctf.map");
    Arc::new(Battlefield::from_file(&path).unwrap())
}

fn game(red: &str, blue: &str, bots: &[&str]) -> Match {
    let teams = [
        TeamSetup::parse("red", red).unwrap(),
        TeamSetup::parse("blue", blue).unwrap(),
    ];
    Match::new(map(), Rules::new(Mode::CaptureTheFlag), &teams, bots).unwrap()
}

fn steps(m: &mut Match, n: u64) {
    for _ in 0..n {
        m.step(&mut |_, _| {});
    }
}

fn send(m: &mut Match, c: PlayerCommand) {
    m.send(c.encode().unwrap());
}

fn squad_cmd(squad: &str, verb: Verb) -> PlayerCommand {
    PlayerCommand::Squad(SquadCommand {
        team: "red".into(),
        squad: squad.into(),
        verb,
        formation: None,
    })
}

fn at(m: &Match, id: u32) -> Vec2 {
    m.world()
        .field()
        .robot_pose(FieldRobotId(id as usize))
        .unwrap()
        .position()
}

fn state(m: &Match) -> &GameState {
    m.state().expect("a state was published")
}

fn squad_of(m: &Match, id: u32) -> String {
    state(m)
        .robots
        .iter()
        .find(|r| r.id == id)
        .unwrap()
        .squad
        .clone()
}

fn refusals(m: &Match) -> Vec<String> {
    m.events()
        .iter()
        .filter(|e| e.kind == "refused")
        .map(|e| e.text.clone())
        .collect()
}

/// A point on open ground, the centre of cell (x, y) (y counted down from the top row).
fn cell(x: u32, y: u32) -> Vec2 {
    let (x, y) = map().cell_center(Cell::new(x, y));
    Vec2::new(x, y)
}

#[test]
fn one_robot_ordered_alone_leaves_its_squad_which_keeps_its_own_order() {
    let mut m = game("alpha:infantry,infantry,infantry", "alpha:scout", &[]);
    steps(&mut m, 2);
    let east = cell(30, 40);
    let north = cell(8, 33);
    send(&mut m, squad_cmd("alpha", Verb::GoTo(north)));
    send(
        &mut m,
        PlayerCommand::Robot {
            team: "red".into(),
            robot: 2,
            verb: Verb::GoTo(east),
        },
    );
    steps(&mut m, 600);
    assert_eq!(squad_of(&m, 2), "robot-2");
    assert_eq!(squad_of(&m, 0), "alpha");
    let s = state(&m);
    let alpha = s.squads.iter().find(|q| q.name == "alpha").unwrap();
    assert!(alpha.order.starts_with("goto"), "{alpha:?}");
    let solo = s.squads.iter().find(|q| q.name == "robot-2").unwrap();
    assert!(solo.order.starts_with("goto"), "{solo:?}");
    assert!(
        at(&m, 2).distance(east) < 40.0,
        "robot 2 at {:?}",
        at(&m, 2)
    );
    for id in [0, 1] {
        assert!(
            at(&m, id).distance(north) < 80.0,
            "robot {id} at {:?}",
            at(&m, id)
        );
    }
    assert!(refusals(&m).is_empty(), "{:?}", refusals(&m));
}

#[test]
fn a_drawn_path_across_the_river_is_followed_by_the_nearest_passable_route() {
    let mut m = game("alpha:infantry,infantry", "alpha:scout", &[]);
    steps(&mut m, 2);
    // Straight north from red's spawn, through the river's widest water.
    let drawn = vec![cell(5, 36), cell(5, 24), cell(5, 14)];
    send(&mut m, squad_cmd("alpha", Verb::Path(drawn.clone())));
    steps(&mut m, 6);
    let field = map();
    let planned = state(&m).squads[0].path.clone();
    assert!(planned.len() >= 3, "a route was planned: {planned:?}");
    for p in &planned {
        let c = field.cell_at(p.x, p.y).unwrap();
        assert_ne!(
            field.grid.terrain(c).unwrap(),
            Terrain::Water,
            "the route keeps out of the water: {planned:?}"
        );
    }
    assert!(planned.last().unwrap().distance(drawn[2]) < 1.0);
    let goal = drawn[2];
    let mut waded = false;
    for _ in 0..4000 {
        m.step(&mut |_, _| {});
        for id in [0, 1] {
            let p = at(&m, id);
            waded |= field.grid.terrain(field.cell_at(p.x, p.y).unwrap()) == Some(Terrain::Water);
        }
        if [0, 1].iter().all(|&id| at(&m, id).distance(goal) < 60.0) {
            break;
        }
    }
    for id in [0, 1] {
        assert!(
            at(&m, id).distance(goal) < 60.0,
            "robot {id} reached the path's end: {:?}",
            at(&m, id)
        );
    }
    assert!(!waded, "no robot entered the water");
}

#[test]
fn a_split_squad_goes_two_ways_and_merges_back() {
    let mut m = game(
        "alpha:infantry,infantry,infantry,infantry",
        "alpha:scout",
        &[],
    );
    steps(&mut m, 2);
    send(
        &mut m,
        PlayerCommand::Split {
            team: "red".into(),
            squad: "alpha".into(),
            robots: vec![2, 3],
            into: "bravo".into(),
        },
    );
    let (west, east) = (cell(4, 44), cell(24, 40));
    send(&mut m, squad_cmd("alpha", Verb::GoTo(west)));
    send(&mut m, squad_cmd("bravo", Verb::GoTo(east)));
    steps(&mut m, 700);
    assert_eq!(
        (0..4).map(|id| squad_of(&m, id)).collect::<Vec<_>>(),
        ["alpha", "alpha", "bravo", "bravo"]
    );
    for (id, goal) in [(0, west), (1, west), (2, east), (3, east)] {
        assert!(
            at(&m, id).distance(goal) < 70.0,
            "robot {id} at {:?}, wanted near {goal:?}",
            at(&m, id)
        );
    }
    send(
        &mut m,
        PlayerCommand::Merge {
            team: "red".into(),
            squad: "bravo".into(),
            into: "alpha".into(),
        },
    );
    steps(&mut m, 500);
    let s = state(&m);
    assert!(s.squads.iter().all(|q| q.name != "bravo"), "{:?}", s.squads);
    assert!((0..4).all(|id| squad_of(&m, id) == "alpha"));
    // Merged, the newcomers join alpha at the west point.
    for id in 0..4 {
        assert!(
            at(&m, id).distance(west) < 90.0,
            "robot {id} at {:?}",
            at(&m, id)
        );
    }
    assert!(refusals(&m).is_empty(), "{:?}", refusals(&m));
}

#[test]
fn a_driven_robot_obeys_its_player_not_its_squad_until_released() {
    let mut m = game("alpha:infantry,infantry", "alpha:scout", &[]);
    steps(&mut m, 2);
    let home = at(&m, 1);
    send(&mut m, squad_cmd("alpha", Verb::Gather(None)));
    let drive = |m: &mut Match, forward| {
        send(
            m,
            PlayerCommand::Drive {
                team: "red".into(),
                robot: 1,
                forward,
                turn: 0.0,
            },
        )
    };
    // The player holds a key for 3 s: a drive every 0.2 s.
    for _ in 0..15 {
        drive(&mut m, 1.0);
        steps(&mut m, 2);
    }
    let driven = at(&m, 1);
    assert!(
        driven.distance(home) > 20.0,
        "the robot was driven: {home:?} to {driven:?}"
    );
    // The key is let go: the robot stops within the drive's half second, and stands.
    steps(&mut m, 6);
    let stopped = at(&m, 1);
    steps(&mut m, 10);
    assert!(
        at(&m, 1).distance(stopped) < 1.0,
        "a robot no one drives stands (it moved from {stopped:?} to {:?})",
        at(&m, 1)
    );
    // Its player never gave it back (a closed page): after 2 s it is its squad's again.
    steps(&mut m, 400);
    assert!(
        at(&m, 1).distance(at(&m, 0)) < 3.0 * 22.0,
        "it rejoined its squad: {:?} and {:?}",
        at(&m, 1),
        at(&m, 0)
    );
    // Driven again and given back at once: an order for it works again.
    drive(&mut m, 1.0);
    steps(&mut m, 1);
    let solo = PlayerCommand::Robot {
        team: "red".into(),
        robot: 1,
        verb: Verb::Stop,
    };
    send(&mut m, solo.clone());
    steps(&mut m, 1);
    assert_eq!(
        refusals(&m),
        ["red robot 1: you are driving it; release it first"]
    );
    send(
        &mut m,
        PlayerCommand::Release {
            team: "red".into(),
            robot: 1,
        },
    );
    send(&mut m, solo);
    steps(&mut m, 4);
    assert_eq!(refusals(&m).len(), 1, "{:?}", refusals(&m));
    assert_eq!(squad_of(&m, 1), "robot-1");
}

#[test]
fn a_packet_of_many_refused_lines_gets_one_refusal() {
    let mut m = game("alpha:infantry,infantry", "alpha:scout", &[]);
    steps(&mut m, 2);
    let mut text = String::from("@ <game.player.red> 0\n");
    for _ in 0..500 {
        text.push_str("release robot 0\n");
    }
    m.send(text.into_bytes());
    steps(&mut m, 1);
    assert_eq!(
        refusals(&m),
        ["red robot 0: it is not being driven (and 499 more lines refused)"]
    );
}

#[test]
fn orders_for_an_enemy_or_a_destroyed_robot_are_refused_and_change_nothing() {
    // Both sides scripted, so robots fall; then red's player speaks up for one of them.
    let setup = "alpha:tank,infantry,infantry bravo:scout,scout,amphibian";
    let mut m = game(setup, setup, &["red", "blue"]);
    let mut dead = None;
    for _ in 0..8000 {
        m.step(&mut |_, _| {});
        if let Some(s) = m.state() {
            dead = s
                .robots
                .iter()
                .find(|r| !r.alive && r.team == "red")
                .map(|r| r.id);
        }
        if dead.is_some() || m.is_over() {
            break;
        }
    }
    let Some(dead) = dead else {
        panic!("no red robot fell in the scripted match")
    };
    let blue = state(&m)
        .robots
        .iter()
        .find(|r| r.team == "blue")
        .unwrap()
        .id;
    let before = refusals(&m).len();
    for c in [
        PlayerCommand::Robot {
            team: "red".into(),
            robot: blue,
            verb: Verb::Stop,
        },
        PlayerCommand::Robot {
            team: "red".into(),
            robot: dead,
            verb: Verb::GoTo(cell(10, 40)),
        },
        PlayerCommand::Drive {
            team: "red".into(),
            robot: dead,
            forward: 1.0,
            turn: 0.0,
        },
        PlayerCommand::Drive {
            team: "red".into(),
            robot: blue,
            forward: 1.0,
            turn: 0.0,
        },
        PlayerCommand::Robot {
            team: "red".into(),
            robot: 0,
            verb: Verb::Attack(Target::Robot(1)),
        },
    ] {
        send(&mut m, c);
    }
    m.step(&mut |_, _| {});
    let said = refusals(&m)[before..].to_vec();
    if m.is_over() {
        assert!(
            said.iter().all(|s| s.ends_with("the game is over")),
            "{said:?}"
        );
        return;
    }
    assert_eq!(said.len(), 5, "{said:?}");
    assert_eq!(
        said[0],
        format!("red robot {blue}: it is not yours (it plays for blue)")
    );
    assert_eq!(said[1], format!("red robot {dead}: it is destroyed"));
    assert_eq!(said[2], format!("red robot {dead}: it is destroyed"));
    assert_eq!(
        said[3],
        format!("red robot {blue}: it is not yours (it plays for blue)")
    );
    assert!(
        said[4] == "red robot 0: it is destroyed"
            || said[4] == "red robot 0: robot 1 is on your own team",
        "{said:?}"
    );
    assert!(state(&m)
        .squads
        .iter()
        .all(|q| !q.name.starts_with("robot-")));
}

#[test]
fn bad_splits_and_merges_are_refused_with_a_reason() {
    let mut m = game("alpha:infantry,infantry bravo:scout", "alpha:scout", &[]);
    steps(&mut m, 2);
    let split = |robots: Vec<u32>, into: &str| PlayerCommand::Split {
        team: "red".into(),
        squad: "alpha".into(),
        robots,
        into: into.into(),
    };
    let merge = |squad: &str, into: &str| PlayerCommand::Merge {
        team: "red".into(),
        squad: squad.into(),
        into: into.into(),
    };
    for c in [
        split(vec![0, 1], "charlie"),
        split(vec![2], "charlie"),
        split(vec![0], "bravo"),
        split(vec![0, 0], "charlie"),
        merge("alpha", "alpha"),
        merge("delta", "alpha"),
        PlayerCommand::Release {
            team: "red".into(),
            robot: 0,
        },
    ] {
        send(&mut m, c);
    }
    steps(&mut m, 1);
    assert_eq!(
        refusals(&m),
        [
            "red split of alpha: keep at least one robot in alpha",
            "red split of alpha: robot 2 is not in alpha",
            "red split of alpha: there is a squad bravo already",
            "red split of alpha: robot 0 is named twice",
            "red merge of alpha into alpha: a squad cannot merge into itself",
            "red merge of delta into alpha: team red has no squad delta",
            "red robot 0: it is not being driven",
        ]
    );
    let s = state(&m);
    assert_eq!(s.squads.len(), 3, "nothing changed: {:?}", s.squads);
}

#[test]
fn a_dense_stroke_drawn_past_robots_standing_at_the_spawn_is_followed_by_every_robot() {
    // As the game page sends it: a point every few pixels, starting among the idle bravo.
    let mut m = game(
        "alpha:infantry,infantry,infantry,infantry bravo:scout,scout",
        "alpha:tank",
        &[],
    );
    steps(&mut m, 2);
    let mut stroke: Vec<Vec2> = (0..12)
        .map(|k| Vec2::new(94.0 + 12.5 * k as f64, 212.0 - 5.2 * k as f64))
        .collect();
    stroke.extend((0..12).map(|k| Vec2::new(244.0 + 21.4 * k as f64, 150.0)));
    stroke.extend((0..13).map(|k| Vec2::new(500.0 + 16.7 * k as f64, 150.0 + 8.3 * k as f64)));
    let end = *stroke.last().unwrap();
    send(
        &mut m,
        PlayerCommand::Squad(SquadCommand {
            team: "red".into(),
            squad: "alpha".into(),
            verb: Verb::Path(stroke),
            formation: Some(colony_game::protocol::Formation::Line),
        }),
    );
    steps(&mut m, 1200);
    for id in 0..4 {
        assert!(
            at(&m, id).distance(end) < 60.0,
            "robot {id} followed the stroke to its end {end:?}: it is at {:?}",
            at(&m, id)
        );
    }
}
