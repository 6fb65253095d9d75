//! Whole matches in the simulator, fast-forwarded.

use std::sync::Arc;

use colony_game::map::Battlefield;
use colony_game::matches::Match;
use colony_game::protocol::Status;
use colony_game::rules::{Mode, Rules, TeamSetup};

fn map(name: &str) -> Arc<Battlefield> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../maps")
        .join(name);
    Arc::new(Battlefield::from_file(&path).unwrap())
}

#[test]
fn a_scripted_capture_the_flag_match_runs_to_a_result() {
    let teams = [
        TeamSetup::parse(
            "red",
            "alpha:tank,infantry,infantry bravo:scout,scout,amphibian",
        )
        .unwrap(),
        TeamSetup::parse(
            "blue",
            "alpha:tank,infantry,infantry bravo:scout,scout,amphibian",
        )
        .unwrap(),
    ];
    let mut rules = Rules::new(Mode::CaptureTheFlag);
    rules.time_limit_s = 600.0;
    let mut m = Match::new(map("ctf.map"), rules, &teams, &["red", "blue"]).unwrap();
    let t0 = std::time::Instant::now();
    m.run(7000, &mut |_, _| {});
    let state = m.state().expect("a state was published");
    for e in m.events().iter().filter(|e| e.kind != "hit") {
        eprintln!("{:7.1} {} {}", e.time, e.kind, e.text);
    }
    eprintln!(
        "{:?} {:?} in {:?}",
        state.winner,
        state.reason,
        t0.elapsed()
    );
    assert_eq!(state.status, Status::Over);
}

/// Steps until `done` says so or `max` steps pass.
fn run_until(m: &mut Match, max: u64, mut done: impl FnMut(&Match) -> bool) {
    for _ in 0..max {
        m.step(&mut |_, _| {});
        if done(m) {
            break;
        }
    }
}

#[test]
fn an_amphibian_crosses_the_river_where_others_must_use_a_crossing() {
    use colony_game::map::Terrain;
    use colony_game::protocol::{SquadCommand, Verb};
    use colony_sim::Vec2;

    let field = map("ctf.map");
    let teams = [
        TeamSetup::parse("red", "swim:amphibian walk:infantry").unwrap(),
        TeamSetup::parse("blue", "alpha:scout").unwrap(),
    ];
    let mut m = Match::new(field.clone(), Rules::new(Mode::CaptureTheFlag), &teams, &[]).unwrap();
    // Across the river from red's spawn, straight north.
    let (x, y) = field.cell_center(colony_game::map::Cell::new(6, 12));
    let goal = Vec2::new(x, y);
    for squad in ["swim", "walk"] {
        m.send(
            SquadCommand {
                team: "red".into(),
                squad: squad.into(),
                verb: Verb::GoTo(goal),
                formation: None,
            }
            .encode()
            .unwrap(),
        );
    }
    let terrain_under = |m: &Match, id: usize| {
        let p = m
            .world()
            .field()
            .robot_pose(colony_sim::field::FieldRobotId(id))
            .unwrap();
        let c = field.cell_at(p.x, p.y).unwrap();
        (p.position(), field.grid.terrain(c).unwrap())
    };
    let (mut swam, mut waded) = (false, false);
    let mut arrived = [false; 2];
    run_until(&mut m, 3000, |m| {
        for (id, arrived) in arrived.iter_mut().enumerate() {
            let (at, t) = terrain_under(m, id);
            if t == Terrain::Water {
                if id == 0 {
                    swam = true;
                } else {
                    waded = true;
                }
            }
            *arrived |= at.distance(goal) < 30.0;
        }
        arrived.iter().all(|a| *a)
    });
    assert!(arrived[0], "the amphibian got across");
    assert!(arrived[1], "the infantry got across");
    assert!(swam, "the amphibian took the short way, through the water");
    assert!(!waded, "the infantry never entered the water");
}

#[test]
fn illegal_squad_commands_are_refused_with_a_reason_and_change_nothing() {
    use colony_game::protocol::{SquadCommand, Target, Verb};
    let teams = [
        TeamSetup::parse("red", "alpha:tank").unwrap(),
        TeamSetup::parse("blue", "alpha:scout").unwrap(),
    ];
    let mut m = Match::new(
        map("ctf.map"),
        Rules::new(Mode::CaptureTheFlag),
        &teams,
        &[],
    )
    .unwrap();
    let cmd = |squad: &str, verb| SquadCommand {
        team: "red".into(),
        squad: squad.into(),
        verb,
        formation: None,
    };
    for c in [
        cmd("nosuch", Verb::Stop),
        cmd("alpha", Verb::Attack(Target::Robot(0))),
        cmd("alpha", Verb::Attack(Target::Robot(77))),
        cmd("alpha", Verb::Capture("red".into())),
        cmd("alpha", Verb::GoTo(colony_sim::Vec2::new(-500.0, 10.0))),
    ] {
        m.send(c.encode().unwrap());
    }
    m.send(b"@ <game.player.red> 0\nsquad name alpha do dance\n".to_vec());
    m.step(&mut |_, _| {});
    let refused: Vec<&str> = m
        .events()
        .iter()
        .filter(|e| e.kind == "refused")
        .map(|e| e.text.as_str())
        .collect();
    assert_eq!(
        refused,
        [
            "red squad nosuch: team red has no squad nosuch",
            "red squad alpha: robot 0 is on your own team",
            "red squad alpha: there is no robot 77",
            "red squad alpha: that is your own flag",
            "red squad alpha: (-500, 10) is off the map",
            "a bad command from red: line 2: unknown squad command \"dance\" (expected gather, goto, defend, attack, capture, path or stop)",
        ]
    );
    for _ in 0..20 {
        m.step(&mut |_, _| {});
    }
    let s = m.state().unwrap();
    assert_eq!(s.squads[0].order, "none", "nothing was ordered");
}

#[test]
fn a_squad_attacking_a_moving_robot_sets_off_rather_than_re_forming_each_time_it_stirs() {
    use colony_game::formation::Formation;
    use colony_game::protocol::{SquadCommand, Target, Verb};

    let setup = "alpha:tank,infantry,infantry bravo:scout,scout,amphibian";
    let teams = [
        TeamSetup::parse("red", setup).unwrap(),
        TeamSetup::parse("blue", setup).unwrap(),
    ];
    // Blue is scripted, so its alpha squad (robots 6, 7, 8) is on the move.
    let mut m = Match::new(
        map("ctf.map"),
        Rules::new(Mode::CaptureTheFlag),
        &teams,
        &["blue"],
    )
    .unwrap();
    run_until(&mut m, 40, |_| false);
    m.send(
        SquadCommand {
            team: "red".into(),
            squad: "alpha".into(),
            verb: Verb::Attack(Target::Robot(7)),
            formation: Some(Formation::Wedge),
        }
        .encode()
        .unwrap(),
    );
    let centroid = |m: &Match| {
        let s = m.state().expect("a state");
        let mine: Vec<_> = s
            .robots
            .iter()
            .filter(|r| r.team == "red" && r.squad == "alpha" && r.alive)
            .map(|r| r.pose.position())
            .collect();
        mine.iter().fold(colony_sim::Vec2::ZERO, |a, p| a + *p) * (1.0 / mine.len() as f64)
    };
    run_until(&mut m, 5, |_| false);
    let c0 = centroid(&m);
    // 20 s of game time: the squad's slowest member (the tank) covers well
    // over a metre if it is let go.
    run_until(&mut m, 200, |_| false);
    let moved = centroid(&m).distance(c0);
    assert!(moved > 80.0, "the squad moved only {moved:.0} cm in 20 s");
}
