//! The roster and the referee at work on a small field.

use colony_sim::{Pose, Vec2};

use super::*;
use crate::map::{Battlefield, Cell};
use crate::protocol::{Action, Event, RobotPose, Status, WorldFrame};
use crate::rules::{Mode, RobotKind, Rules, TeamSetup};

/// A 20 x 6 field: red on the left, blue on the right, open ground.
fn field() -> Battlefield {
    let row = format!("@{}@", ".".repeat(18));
    let mut text = format!("type octile\nheight 6\nwidth 20\nmap\n{}\n", "@".repeat(20));
    for _ in 0..4 {
        text.push_str(&row);
        text.push('\n');
    }
    text.push_str(&"@".repeat(20));
    text.push_str("\ncell 20\nteam red base 2 2 flag 1 1 spawn 2 3\nteam blue base 17 2 flag 18 1 spawn 17 3\n");
    Battlefield::parse(&text).unwrap()
}

fn game(mode: Mode) -> (Battlefield, Referee, Vec<RobotEntry>) {
    let f = field();
    let rules = Rules::new(mode);
    let teams = [
        TeamSetup::parse("red", "a:tank").unwrap(),
        TeamSetup::parse("blue", "a:scout").unwrap(),
    ];
    let entries = roster(&f, &rules, &teams).unwrap();
    let r = Referee::new(&f, rules, &entries);
    (f, r, entries)
}

fn place(r: &mut Referee, time: f64, at: &[(u32, Vec2)]) {
    r.on_world(&WorldFrame {
        step: 0,
        time,
        robots: at
            .iter()
            .map(|&(id, p)| RobotPose {
                id,
                pose: Pose {
                    x: p.x,
                    y: p.y,
                    theta: 0.0,
                },
                active: true,
            })
            .collect(),
    });
}

fn last(r: &mut Referee) -> Event {
    r.take_events().pop().unwrap()
}

#[test]
fn illegal_shots_are_refused_with_the_reason() {
    let (_, mut r, _) = game(Mode::DeathMatch);
    place(
        &mut r,
        1.0,
        &[(0, Vec2::new(100.0, 60.0)), (1, Vec2::new(300.0, 60.0))],
    );
    r.on_action(&Action::Fire {
        robot: 0,
        target: 1,
    });
    let e = last(&mut r);
    assert_eq!(e.kind, "refused");
    assert!(
        e.text.contains("200 cm away; a tank's range is 100 cm"),
        "{}",
        e.text
    );
    r.on_action(&Action::Fire {
        robot: 0,
        target: 0,
    });
    assert!(last(&mut r).text.contains("same team"));
    place(&mut r, 2.0, &[(1, Vec2::new(180.0, 60.0))]);
    r.on_action(&Action::Fire {
        robot: 0,
        target: 1,
    });
    assert_eq!(last(&mut r).kind, "hit");
    r.on_action(&Action::Fire {
        robot: 0,
        target: 1,
    });
    assert!(last(&mut r).text.contains("fires once every 1.2 s"));
    r.on_action(&Action::Fire {
        robot: 0,
        target: 9,
    });
    assert!(last(&mut r).text.contains("no such robot"));
}

#[test]
fn a_frame_from_before_the_games_time_is_ignored() {
    let (_, mut r, _) = game(Mode::DeathMatch);
    place(&mut r, 50.0, &[(0, Vec2::new(100.0, 60.0))]);
    // A restarted world, still at its spawn points and its own clock.
    place(&mut r, 0.1, &[(0, Vec2::new(50.0, 60.0))]);
    assert_eq!(r.time(), 50.0);
    assert_eq!(r.robot(0).unwrap().0.position(), Vec2::new(100.0, 60.0));
}

#[test]
fn a_death_match_ends_when_one_team_is_left() {
    let (_, mut r, _) = game(Mode::DeathMatch);
    for k in 0..3 {
        place(
            &mut r,
            1.0 + 2.0 * k as f64,
            &[(0, Vec2::new(100.0, 60.0)), (1, Vec2::new(150.0, 60.0))],
        );
        r.on_action(&Action::Fire {
            robot: 0,
            target: 1,
        });
    }
    place(&mut r, 10.0, &[]);
    let s = r.state(Vec::new());
    assert_eq!(s.status, Status::Over);
    assert_eq!(s.winner.as_deref(), Some("red"));
    assert!(!s.robots[1].alive);
    assert_eq!(s.teams[0].kills, 1);
    r.take_events();
    r.on_action(&Action::Fire {
        robot: 0,
        target: 1,
    });
    assert!(
        r.take_events().iter().all(|e| e.kind != "hit"),
        "no shots after the end"
    );
}

#[test]
fn a_flag_is_taken_carried_home_and_captured() {
    let (f, mut r, _) = game(Mode::CaptureTheFlag);
    let at = |x, y| {
        let (x, y) = f.cell_center(Cell::new(x, y));
        Vec2::new(x, y)
    };
    // Too far to reach, then its own flag, then the enemy's.
    place(&mut r, 1.0, &[(0, at(15, 1))]);
    r.on_action(&Action::PickUp {
        robot: 0,
        flag: "blue".into(),
    });
    assert!(last(&mut r).text.contains("reach 30 cm"));
    r.on_action(&Action::PickUp {
        robot: 0,
        flag: "red".into(),
    });
    assert!(last(&mut r).text.contains("its own team's flag"));
    place(&mut r, 2.0, &[(0, at(18, 1))]);
    r.on_action(&Action::PickUp {
        robot: 0,
        flag: "blue".into(),
    });
    assert_eq!(last(&mut r).kind, "flag-taken");
    place(&mut r, 3.0, &[(0, at(10, 2))]);
    assert_eq!(
        r.flag_at("blue"),
        Some((at(10, 2), Some(0))),
        "the flag rides along"
    );
    assert!(!r.is_over());
    place(&mut r, 4.0, &[(0, at(2, 2))]);
    let s = r.state(Vec::new());
    assert_eq!((s.status, s.winner.as_deref()), (Status::Over, Some("red")));
    assert_eq!(s.teams[0].score, 1);
}

#[test]
fn a_dropped_flag_goes_home_when_its_team_touches_it() {
    let (f, mut r, _) = game(Mode::CaptureTheFlag);
    let at = |x, y| {
        let (x, y) = f.cell_center(Cell::new(x, y));
        Vec2::new(x, y)
    };
    place(&mut r, 1.0, &[(0, at(18, 1)), (1, at(17, 4))]);
    r.on_action(&Action::PickUp {
        robot: 0,
        flag: "blue".into(),
    });
    place(&mut r, 1.5, &[(0, at(15, 2))]);
    // A destroyed carrier drops the flag where it stands.
    r.destroy(0, 1);
    assert_eq!(r.flag_at("blue"), Some((at(15, 2), None)));
    place(&mut r, 2.0, &[(1, at(15, 3))]);
    assert_eq!(r.flag_at("blue"), Some((at(18, 1), None)), "home again");
    assert!(r.take_events().iter().any(|e| e.kind == "flag-returned"));
}

#[test]
fn the_roster_is_the_same_every_time_and_refuses_what_does_not_fit() {
    let f = field();
    let rules = Rules::new(Mode::CaptureTheFlag);
    let teams = [TeamSetup::parse("red", "a:tank,scout b:infantry").unwrap()];
    let a = roster(&f, &rules, &teams).unwrap();
    assert_eq!(a, roster(&f, &rules, &teams).unwrap());
    assert_eq!(a.iter().map(|e| e.id).collect::<Vec<_>>(), [0, 1, 2]);
    let green = [TeamSetup::parse("green", "a:tank").unwrap()];
    assert!(matches!(
        roster(&f, &rules, &green),
        Err(SetupError::UnknownTeam(..))
    ));
    let crowd = [TeamSetup {
        name: "red".into(),
        squads: vec![crate::rules::SquadSetup {
            name: "a".into(),
            robots: vec![crate::rules::RobotBuild::plain(RobotKind::Scout); 40],
        }],
    }];
    let mut rich = rules.clone();
    rich.budget = 1000;
    assert!(matches!(
        roster(&f, &rich, &crowd),
        Err(SetupError::NoRoom { .. })
    ));
}

#[test]
fn the_tally_counts_damage_kills_flags_captures_and_refusals() {
    let (_, mut r, _) = game(Mode::CaptureTheFlag);
    // The tank (red, 0) next to the scout (blue, 1), at blue's flag.
    let flag = r.flag_at("blue").unwrap().0;
    place(&mut r, 1.0, &[(0, flag), (1, flag + Vec2::new(40.0, 0.0))]);
    let fire = Action::Fire {
        robot: 0,
        target: 1,
    };
    r.on_action(&fire);
    r.on_action(&fire); // too soon: refused
    assert_eq!(r.reload_left(0), Some(1.2));
    r.on_action(&Action::PickUp {
        robot: 0,
        flag: "blue".into(),
    });
    let mut time = 1.0;
    // A scout has 40 health: three tank shots of 15 destroy it, the last taking only 10.
    for _ in 0..2 {
        time += 1.3;
        place(&mut r, time, &[(0, flag), (1, flag + Vec2::new(40.0, 0.0))]);
        r.on_action(&fire);
    }
    let (tank, scout) = (r.tally(0).unwrap(), r.tally(1).unwrap());
    assert_eq!((tank.damage_dealt, scout.damage_taken), (40.0, 40.0));
    assert_eq!((tank.kills, tank.flags_taken, tank.refused), (1, 1, 1));
    assert_eq!(r.health(1), Some(0.0));
    // Home with the flag: a capture, and red wins.
    let base = r.base("red").unwrap();
    place(&mut r, time + 0.1, &[(0, base)]);
    assert_eq!(r.tally(0).unwrap().captures, 1);
    assert_eq!(r.winner(), Some("red"));
    assert_eq!(r.teams()[0].score, 1);
}
