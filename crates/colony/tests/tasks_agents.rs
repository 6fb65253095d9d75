//! MURDOCH as the paper deploys it, on loopback: a hub, one `colony tasks
//! agent` process per robot, tasks introduced with `colony tasks announce`;
//! a winner killed mid-task and replaced, a sensor failing on another; and
//! agents driving bodies of a `colony tasks room` to where a task is.

use std::time::{Duration, Instant};

use colony_testkit::cli::{
    colony, tasks_agent as agent, tasks_announce as announce, HubProcess, Proc,
};

/// The subscriptions of the client whose about text is `agent NAME ...`.
fn subscriptions_of(hub: &str, name: &str) -> Option<String> {
    let out = colony().args(["status", "--hub", hub]).output().ok()?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let lines: Vec<&str> = text.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.trim_start().starts_with(&format!("agent {name} ")))?;
    Some(lines[at - 1].to_owned())
}

#[test]
fn agents_as_processes_take_tasks_from_anyone_survive_a_killed_winner_and_follow_a_failed_sensor() {
    let hub = HubProcess::start(&[]);
    let h = hub.addr.to_string();
    let _r1 = agent(&h, "r1", "mobile,laser", &[]);
    let _r2 = agent(&h, "r2", "mobile,camera", &[]);
    let _r3 = agent(&h, "r3", "mobile,laser,camera", &[]);
    let mut r4 = agent(&h, "r4", "mobile,gripper", &[]);
    let r5 = agent(
        &h,
        "r5",
        "mobile,laser,camera",
        &["--fail", "laser", "--at", "2"],
    );

    // Tasks from the command line, each done by a robot that has what it needs.
    for (name, needs) in [
        ("look", "camera"),
        ("scan", "laser"),
        ("both", "laser,camera"),
    ] {
        let mut t = announce(&h, name, needs, "0.5");
        assert_eq!(
            t.exit(Duration::from_secs(60)),
            Some(0),
            "{name}:\n{}",
            t.text()
        );
    }

    // A long task only r4 can do; kill r4 once it starts, and start r6 in its place.
    let mut long = announce(&h, "carry", "gripper", "4");
    assert!(
        r4.when("starts task", Duration::from_secs(30)).is_some(),
        "r4 never started carry:\n{}",
        long.text()
    );
    r4.kill();
    let killed = Instant::now();
    let _r6 = agent(&h, "r6", "mobile,gripper", &[]);
    let awarded = long.when("awarded to r6", Duration::from_secs(60));
    assert!(
        awarded.is_some(),
        "carry was never re-allocated to r6:\n{}",
        long.text()
    );
    let took = awarded.unwrap().duration_since(killed);
    // Two renewal timeouts (3 s each) detect the loss and re-auction; the
    // rest is r6 joining. Generous for a loaded machine.
    assert!(
        took < Duration::from_secs(20),
        "re-allocated after {took:?}:\n{}",
        long.text()
    );
    eprintln!("# carry re-allocated to r6 {took:?} after r4 was killed");
    assert_eq!(
        long.exit(Duration::from_secs(60)),
        Some(0),
        "carry:\n{}",
        long.text()
    );

    // r5's laser failed at 2 s: it no longer subscribes to laser, so no laser
    // announcement reaches it, and it does no laser task.
    assert!(r5.when("laser fails", Duration::from_secs(30)).is_some());
    let start = Instant::now();
    loop {
        let subs = subscriptions_of(&h, "r5").unwrap_or_default();
        if subs.contains("camera") && !subs.contains("laser") {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "r5 still subscribes: {subs}"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    let before = r5.text().matches("starts task").count();
    for i in 0..3 {
        let mut t = announce(&h, &format!("sweep{i}"), "laser", "0.2");
        assert_eq!(t.exit(Duration::from_secs(60)), Some(0), "{}", t.text());
        assert!(
            !t.text().contains("bid from r5"),
            "r5 bid for a laser task:\n{}",
            t.text()
        );
    }
    assert_eq!(
        r5.text().matches("starts task").count(),
        before,
        "{}",
        r5.text()
    );
}

#[test]
fn agents_with_bodies_in_a_room_bid_by_where_they_are_and_drive_to_the_task() {
    let hub = HubProcess::start(&[]);
    let h = hub.addr.to_string();
    // Two bodies in a row across the middle of a 10 m room: robot 0 on the left, robot 1 on the right.
    let room = Proc::start(&["tasks", "room", "--hub", &h, "--bodies", "2"]);
    assert!(room.when("2 bodies", Duration::from_secs(20)).is_some());
    let left = agent(&h, "left", "mobile", &["--body", "0"]);
    let right = agent(&h, "right", "mobile", &["--body", "1"]);
    // Each must know where it is before it can bid its distance.
    for a in [&left, &right] {
        assert!(
            a.when("sees itself at", Duration::from_secs(30)).is_some(),
            "{}",
            a.text()
        );
    }
    // A place up and to the right: the right-hand robot is nearer, wins, and drives there.
    let mut visit = Proc::start(&[
        "tasks",
        "announce",
        "--hub",
        &h,
        "--name",
        "visit",
        "--needs",
        "mobile",
        "--length",
        "1",
        "--at",
        "300,250",
        "--deadline",
        "60",
    ]);
    assert_eq!(
        visit.exit(Duration::from_secs(120)),
        Some(0),
        "{}",
        visit.text()
    );
    assert!(visit.text().contains("done by right"), "{}", visit.text());
    let started = right
        .when("driving to (300, 250) first", Duration::from_secs(5))
        .expect("the winner drives to the place");
    let arrived = right
        .when("at (300, 250): starts work", Duration::from_secs(5))
        .expect("and works once there");
    assert!(arrived > started);
    assert!(
        right
            .when("done with task", Duration::from_secs(5))
            .is_some(),
        "{}",
        right.text()
    );
    assert!(!left.text().contains("starts task"), "{}", left.text());
}
