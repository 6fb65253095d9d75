//! Squads at work on open ground.

use super::*;
use crate::map::Battlefield;

/// 40 x 20 cells of open ground inside a wall, 25 cm cells.
fn nav() -> Nav {
    let mut text = format!(
        "type octile\nheight 20\nwidth 40\nmap\n{}\n",
        "@".repeat(40)
    );
    for _ in 0..18 {
        text.push_str(&format!("@{}@\n", ".".repeat(38)));
    }
    text.push_str(&"@".repeat(40));
    text.push_str("\ncell 25\nteam red base 2 2 flag 2 3 spawn 3 3\nteam blue base 37 17 flag 37 16 spawn 36 16\n");
    Nav::new(Arc::new(Battlefield::parse(&text).unwrap()))
}

fn robot(id: u32, team: &str, kind: RobotKind, x: f64, y: f64) -> SeenRobot {
    SeenRobot {
        id,
        team: team.into(),
        kind,
        at: Vec2::new(x, y),
        alive: true,
        driven: false,
    }
}

fn last_goto(cmds: &[Command]) -> Option<Vec2> {
    cmds.iter().rev().find_map(|c| match c {
        Command::GoTo { to, .. } => Some(*to),
        _ => None,
    })
}

#[test]
fn a_goto_sends_every_member_a_sequence_ending_in_formation_at_the_goal() {
    let mut squad = Squad::new("red", "a", vec![0, 1, 2], 22.0, nav());
    let view = View {
        robots: vec![
            robot(0, "red", RobotKind::Tank, 100.0, 100.0),
            robot(1, "red", RobotKind::Infantry, 130.0, 100.0),
            robot(2, "red", RobotKind::Infantry, 100.0, 130.0),
        ],
        ..View::default()
    };
    // A cell's centre: plans end on cell centres.
    let goal = Vec2::new(812.5, 362.5);
    squad.command(Verb::GoTo(goal), Some(Formation::Line));
    let orders = squad.tick(Arc::new(view));
    assert_eq!(squad.active(), Some("order"));
    assert_eq!(orders.len(), 3);
    let ends: Vec<Vec2> = orders.iter().map(|(_, c)| last_goto(c).unwrap()).collect();
    for e in &ends {
        assert!(
            e.distance(goal) <= 23.0,
            "{e:?} is off the line through {goal:?}"
        );
    }
    // A line of three, d apart: the ends are 22 and 44 cm from each other.
    let mut gaps: Vec<f64> = vec![
        ends[0].distance(ends[1]),
        ends[1].distance(ends[2]),
        ends[0].distance(ends[2]),
    ];
    gaps.sort_by(f64::total_cmp);
    assert!(
        (gaps[0] - 22.0).abs() < 0.5 && (gaps[2] - 44.0).abs() < 0.5,
        "{gaps:?}"
    );
    assert!(!squad.state().path.is_empty());
}

#[test]
fn members_with_an_enemy_in_range_shoot_and_the_rest_hold() {
    let mut squad = Squad::new("red", "a", vec![0, 1], 22.0, nav());
    let view = View {
        robots: vec![
            robot(0, "red", RobotKind::Tank, 100.0, 100.0),
            robot(1, "red", RobotKind::Scout, 400.0, 100.0),
            robot(2, "blue", RobotKind::Scout, 180.0, 100.0),
        ],
        ..View::default()
    };
    squad.command(Verb::GoTo(Vec2::new(800.0, 300.0)), None);
    let orders = squad.tick(Arc::new(view.clone()));
    assert_eq!(squad.active(), Some("shoot"));
    assert!(squad
        .state()
        .behaviour
        .contains("enemy robot 2 in range of robot 0"));
    assert!(orders.contains(&(
        0,
        vec![Command::Shoot {
            target: 2,
            at: Vec2::new(180.0, 100.0)
        }]
    )));
    assert!(orders.contains(&(1, vec![Command::Stop])));
    // Nothing changed: nothing is sent again.
    assert!(squad.tick(Arc::new(view.clone())).is_empty());
    // The enemy is destroyed: the order takes over and replans.
    let mut calm = view;
    calm.robots[2].alive = false;
    let orders = squad.tick(Arc::new(calm));
    assert_eq!(squad.active(), Some("order"));
    assert_eq!(orders.len(), 2, "both robots get the path again");
}

fn motion(name: &str, c: Vec2, v: Vec2) -> SquadMotion {
    SquadMotion {
        team: "red".into(),
        name: name.into(),
        centroid: c,
        velocity: v,
        radius: 30.0,
    }
}

#[test]
fn of_two_squads_on_a_collision_course_the_later_named_sidesteps() {
    let robots = vec![
        robot(0, "red", RobotKind::Infantry, 300.0, 250.0),
        robot(1, "red", RobotKind::Infantry, 450.0, 250.0),
    ];
    let head_on = vec![
        motion("a", Vec2::new(450.0, 250.0), Vec2::new(-20.0, 0.0)),
        motion("b", Vec2::new(300.0, 250.0), Vec2::new(20.0, 0.0)),
    ];
    let view = |squads| {
        Arc::new(View {
            time: 10.0,
            robots: robots.clone(),
            squads,
            ..View::default()
        })
    };
    let mut b = Squad::new("red", "b", vec![0], 22.0, nav());
    let orders = b.tick(view(head_on.clone()));
    assert_eq!(b.active(), Some("avoid-squads"));
    let to = last_goto(&orders[0].1).unwrap();
    assert!(
        (to.x - 300.0).abs() < 1e-9 && (to.y - 250.0).abs() > 30.0,
        "sidestep sideways: {to:?}"
    );
    let mut a = Squad::new("red", "a", vec![1], 22.0, nav());
    a.tick(view(head_on));
    assert_ne!(
        a.active(),
        Some("avoid-squads"),
        "the earlier-named squad keeps going"
    );
    // A parked squad ahead is an obstacle for the path, not an inbound collision.
    let parked = vec![
        motion("a", Vec2::new(450.0, 250.0), Vec2::ZERO),
        motion("b", Vec2::new(300.0, 250.0), Vec2::new(20.0, 0.0)),
    ];
    let mut b = Squad::new("red", "b", vec![0], 22.0, nav());
    b.tick(view(parked));
    assert_ne!(b.active(), Some("avoid-squads"));
}
