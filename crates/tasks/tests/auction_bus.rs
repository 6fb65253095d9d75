//! The protocol on the in-memory bus, on simulated time: who hears what, who
//! wins, what happens when robots or announcers fail, and bad input.

use std::time::Duration;

use colony_proto::Vec2;
use colony_tasks::{
    Agent, AgentConfig, AgentEvent, AgentMode, Announcer, AnnouncerEvent, AuctionConfig, Backoff,
    Bus, Node, StopReason, TaskSpec, Time, Token, UserAgent, UserEvent,
};

fn t(s: f64) -> Time {
    Time::from_secs_f64(s)
}

fn robot(name: &str, resources: &str, at: (f64, f64)) -> Agent {
    let mut a = Agent::new(
        Token::new(name).unwrap(),
        resources.parse().unwrap(),
        AgentConfig::default(),
        Time::ZERO,
    );
    a.set_position(Vec2::new(at.0, at.1));
    a
}

fn announcer() -> Announcer {
    Announcer::new(Token::new("user").unwrap(), AuctionConfig::default())
}

fn goto(resources: &str, x: f64, y: f64, length: f64) -> TaskSpec {
    TaskSpec::new("goto", resources.parse().unwrap())
        .length(length)
        .param("x", x)
        .param("y", y)
        .metric("distance", 1.0)
}

fn events(a: &mut Announcer) -> Vec<AnnouncerEvent> {
    std::iter::from_fn(|| a.poll_event()).collect()
}

fn agent_events(a: &mut Agent) -> Vec<AgentEvent> {
    std::iter::from_fn(|| a.poll_event()).collect()
}

fn nodes<'a>(agents: &'a mut [Agent], extra: &'a mut dyn Node) -> Vec<&'a mut dyn Node> {
    let mut v: Vec<&mut dyn Node> = agents.iter_mut().map(|a| a as &mut dyn Node).collect();
    v.push(extra);
    v
}

#[test]
fn only_robots_with_every_resource_hear_an_announcement() {
    let mut bus = Bus::new(Duration::from_millis(2));
    let mut robots = vec![
        robot("r1", "camera laser mobile", (0.0, 0.0)),
        robot("r2", "camera mobile", (0.0, 0.0)),
        robot("r3", "laser mobile bumpers", (0.0, 0.0)),
        robot("r4", "camera laser mobile gripper", (0.0, 0.0)),
    ];
    let mut user = announcer();
    user.announce(Time::ZERO, goto("camera laser mobile", 5.0, 5.0, 10.0))
        .unwrap();
    bus.run_until(&mut nodes(&mut robots, &mut user), t(0.1));
    let heard: Vec<u64> = robots.iter().map(|r| r.stats().heard).collect();
    // r1 and r4 heard the announcement (and each other's bids); r2 and r3 heard nothing.
    assert!(heard[0] >= 1 && heard[3] >= 1, "{heard:?}");
    assert_eq!((heard[1], heard[2]), (0, 0), "{heard:?}");
    assert_eq!(
        robots.iter().map(|r| r.stats().bids).collect::<Vec<_>>(),
        [1, 0, 0, 1]
    );
}

#[test]
fn the_best_bid_wins_and_the_losers_go_back_to_listening() {
    let mut bus = Bus::new(Duration::from_millis(2));
    let mut robots = vec![
        robot("far", "camera mobile", (100.0, 0.0)),
        robot("near", "camera mobile", (10.0, 0.0)),
        robot("mid", "camera mobile", (50.0, 0.0)),
    ];
    let mut user = announcer();
    let id = user
        .announce(Time::ZERO, goto("camera mobile", 0.0, 0.0, 10.0))
        .unwrap();
    bus.run_until(&mut nodes(&mut robots, &mut user), t(0.1));
    // Before the deadline the losers have heard the better bid and dropped out.
    assert_eq!(robots[0].open_bids(), 0);
    assert_eq!(robots[2].open_bids(), 0);
    assert_eq!(robots[1].open_bids(), 1);
    bus.run_until(&mut nodes(&mut robots, &mut user), t(1.0));
    assert_eq!(user.winner(id).unwrap().as_str(), "near");
    let ev = events(&mut user);
    assert!(ev.iter().any(|e| matches!(e,
        AnnouncerEvent::Awarded { winner, score, bids: 3, .. } if winner.as_str() == "near" && *score == 10.0)));
    assert!(matches!(
        agent_events(&mut robots[1])[..],
        [AgentEvent::Start(_)]
    ));
    assert_eq!(robots[1].mode(), AgentMode::Working);
    assert_eq!(robots[0].mode(), AgentMode::Idle);
    // Working, it no longer listens for tasks.
    assert!(!robots[1].subscriptions().contains("idle"));
}

#[test]
fn ties_break_the_same_way_whatever_the_order() {
    let mut winners = Vec::new();
    for order in [[0, 1, 2], [2, 1, 0], [1, 2, 0]] {
        let names = ["bravo", "alpha", "charlie"];
        let mut robots: Vec<Agent> = order
            .iter()
            .map(|&i| robot(names[i], "camera mobile", (3.0, 4.0)))
            .collect();
        let mut bus = Bus::new(Duration::from_millis(2));
        let mut user = announcer();
        let id = user
            .announce(Time::ZERO, goto("camera mobile", 0.0, 0.0, 10.0))
            .unwrap();
        bus.run_until(&mut nodes(&mut robots, &mut user), t(1.0));
        winners.push(user.winner(id).unwrap().to_string());
    }
    assert_eq!(winners, ["alpha", "alpha", "alpha"]);
}

/// Steps the bus, finishing each robot's task `length_s` after it starts;
/// `kill` takes robots out (they stop answering) at a time.
struct Run {
    bus: Bus,
    robots: Vec<Agent>,
    alive: Vec<bool>,
    started: Vec<Option<(Time, f64)>>,
}

impl Run {
    fn new(robots: Vec<Agent>) -> Run {
        let n = robots.len();
        Run {
            bus: Bus::new(Duration::from_millis(2)),
            robots,
            alive: vec![true; n],
            started: vec![None; n],
        }
    }

    fn until(&mut self, end: Time, user: &mut dyn Node) {
        while self.bus.now() < end {
            let next = (self.bus.now() + Duration::from_millis(100)).min(end);
            let mut nodes: Vec<&mut dyn Node> = self
                .robots
                .iter_mut()
                .zip(&self.alive)
                .filter(|(_, a)| **a)
                .map(|(r, _)| r as &mut dyn Node)
                .collect();
            nodes.push(&mut *user);
            self.bus.run_until(&mut nodes, next);
            let now = self.bus.now();
            for (i, r) in self.robots.iter_mut().enumerate() {
                if !self.alive[i] {
                    continue;
                }
                while let Some(e) = r.poll_event() {
                    if let AgentEvent::Start(ann) = e {
                        self.started[i] = Some((now, ann.spec.length_s));
                    }
                }
                if let Some((at, len)) = self.started[i] {
                    if now.since(at).as_secs_f64() >= len {
                        r.finish(now);
                        self.started[i] = None;
                    }
                }
            }
        }
    }
}

#[test]
fn a_finished_task_is_reported_complete() {
    let mut run = Run::new(vec![robot("r1", "mobile", (0.0, 0.0))]);
    let mut user = announcer();
    let id = user
        .announce(Time::ZERO, goto("mobile", 1.0, 1.0, 2.0))
        .unwrap();
    run.until(t(4.0), &mut user);
    let ev = events(&mut user);
    assert!(
        ev.iter().any(|e| matches!(e, AnnouncerEvent::Completed { task, winner, .. } if *task == id && winner.as_str() == "r1")),
        "{ev:?}"
    );
    assert_eq!(user.open_tasks().count(), 0);
    assert_eq!(run.robots[0].stats().finished, 1);
    assert_eq!(run.robots[0].mode(), AgentMode::Idle);
}

#[test]
fn a_winner_killed_mid_task_is_replaced_within_two_renewal_timeouts() {
    let mut run = Run::new(vec![
        robot("r1", "camera mobile", (1.0, 0.0)),
        robot("r2", "camera mobile", (9.0, 0.0)),
    ]);
    let mut user = announcer();
    let timeout = user.config().renew_timeout;
    let id = user
        .announce(Time::ZERO, goto("camera mobile", 0.0, 0.0, 60.0))
        .unwrap();
    run.until(t(5.0), &mut user);
    assert_eq!(user.winner(id).unwrap().as_str(), "r1");
    let killed = run.bus.now();
    run.alive[0] = false;
    let mut replaced = None;
    while run.bus.now() < killed + timeout * 3 {
        let next = run.bus.now() + Duration::from_millis(100);
        run.until(next, &mut user);
        if user.winner(id).is_some_and(|w| w.as_str() == "r2") {
            replaced = Some(run.bus.now());
            break;
        }
    }
    let replaced = replaced.expect("the task goes to r2");
    assert!(
        replaced.since(killed) <= timeout * 2,
        "re-allocated {:?} after the kill",
        replaced.since(killed)
    );
    let ev = events(&mut user);
    assert!(ev.iter().any(|e| matches!(e,
        AnnouncerEvent::WinnerLost { winner, reason, .. } if winner.as_str() == "r1" && reason.contains("no renewal"))));
    assert!(ev
        .iter()
        .any(|e| matches!(e, AnnouncerEvent::Announced { attempt: 2, .. })));
}

#[test]
fn a_task_whose_announcer_disappears_is_abandoned_by_its_winner() {
    let mut bus = Bus::new(Duration::from_millis(2));
    let mut robots = vec![robot("r1", "mobile", (0.0, 0.0))];
    let mut user = announcer();
    user.announce(Time::ZERO, goto("mobile", 0.0, 0.0, 600.0))
        .unwrap();
    bus.run_until(&mut nodes(&mut robots, &mut user), t(2.0));
    assert_eq!(robots[0].mode(), AgentMode::Working);
    // The announcer is gone: only the robot runs on.
    let timeout = AgentConfig::default().renew_timeout;
    bus.run_until(
        &mut [&mut robots[0]],
        t(2.0) + timeout + Duration::from_millis(100),
    );
    assert_eq!(robots[0].mode(), AgentMode::Idle);
    let ev = agent_events(&mut robots[0]);
    assert!(
        ev.iter().any(|e| matches!(
            e,
            AgentEvent::Stop {
                reason: StopReason::AnnouncerSilent,
                ..
            }
        )),
        "{ev:?}"
    );
    assert!(bus.stats().by_label.contains_key("abandon"));
}

#[test]
fn an_unachievable_task_is_reported_and_the_user_agent_allocates_it_once_a_capable_robot_appears() {
    let mut user = UserAgent::new(
        Token::new("user").unwrap(),
        AuctionConfig::default(),
        Backoff {
            initial: Duration::from_secs(1),
            max: Duration::from_secs(8),
            give_up_after: Duration::from_secs(120),
        },
        42,
    );
    let mut run = Run::new(vec![
        robot("r1", "camera mobile", (0.0, 0.0)),
        robot("r2", "camera laser mobile", (0.0, 0.0)),
    ]);
    // r2 is not there yet.
    run.alive[1] = false;
    let spec = goto("camera laser mobile", 0.0, 0.0, 5.0);
    let request = user.introduce(Time::ZERO, spec).unwrap();
    run.until(t(20.0), &mut user);
    let ev: Vec<UserEvent> = std::iter::from_fn(|| user.poll_event()).collect();
    let retries: Vec<Duration> = ev
        .iter()
        .filter_map(|e| match e {
            UserEvent::Unachievable {
                request: r,
                reason,
                retry_in,
            } if *r == request => {
                assert_eq!(reason, "no robot with {camera laser mobile} is available");
                Some(*retry_in)
            }
            _ => None,
        })
        .collect();
    assert!(retries.len() >= 3, "{ev:?}");
    // Randomized exponential backoff: each wait within [0.5, 1.5) of 1, 2, 4, 8 (capped) s.
    for (k, w) in retries.iter().enumerate() {
        let base = (1u64 << k).min(8) as f64;
        let s = w.as_secs_f64();
        assert!(s >= 0.5 * base && s < 1.5 * base, "wait {k} is {s} s");
    }
    // A capable robot comes along.
    run.alive[1] = true;
    run.until(t(60.0), &mut user);
    let ev: Vec<UserEvent> = std::iter::from_fn(|| user.poll_event()).collect();
    assert!(
        ev.iter().any(|e| matches!(e, UserEvent::Allocated { request: r, winner, .. } if *r == request && winner.as_str() == "r2")),
        "{ev:?}"
    );
    assert!(ev
        .iter()
        .any(|e| matches!(e, UserEvent::Completed { request: r, .. } if *r == request)));
    assert_eq!(user.open_requests(), 0);
}

#[test]
fn the_user_agent_gives_up_at_the_deadline() {
    let mut user = UserAgent::new(
        Token::new("user").unwrap(),
        AuctionConfig::default(),
        Backoff {
            initial: Duration::from_secs(1),
            max: Duration::from_secs(4),
            give_up_after: Duration::from_secs(10),
        },
        1,
    );
    let request = user
        .introduce(
            Time::ZERO,
            TaskSpec::new("open-door", "gripper".parse().unwrap()),
        )
        .unwrap();
    let mut bus = Bus::new(Duration::from_millis(2));
    bus.run_until(&mut [&mut user], t(30.0));
    let ev: Vec<UserEvent> = std::iter::from_fn(|| user.poll_event()).collect();
    assert!(ev.iter().any(|e| matches!(e, UserEvent::GaveUp { request: r, reason } if *r == request && reason.contains("{gripper}"))));
    assert_eq!(user.open_requests(), 0);
    assert_eq!(user.poll_timeout(), None);
}

#[test]
fn a_charging_robot_hears_nothing_and_rejoins_when_charged() {
    let mut bus = Bus::new(Duration::from_millis(2));
    let mut robots = vec![robot("r1", "camera mobile", (0.0, 0.0))];
    robots[0].set_battery(0.1);
    let mut user = announcer();
    bus.run_until(&mut nodes(&mut robots, &mut user), t(1.5));
    assert_eq!(robots[0].mode(), AgentMode::Charging);
    assert!(robots[0].subscriptions().is_empty());
    assert_eq!(agent_events(&mut robots[0]), [AgentEvent::Charge]);
    let id = user
        .announce(bus.now(), goto("camera mobile", 0.0, 0.0, 1.0))
        .unwrap();
    bus.run_until(&mut nodes(&mut robots, &mut user), t(3.0));
    assert_eq!(robots[0].stats().heard, 0);
    assert!(events(&mut user)
        .iter()
        .any(|e| matches!(e, AnnouncerEvent::Unachievable { task, .. } if *task == id)));
    robots[0].set_battery(1.0);
    robots[0].charged(bus.now());
    let id = user
        .announce(bus.now(), goto("camera mobile", 0.0, 0.0, 1.0))
        .unwrap();
    bus.run_until(&mut nodes(&mut robots, &mut user), t(4.0));
    assert_eq!(user.winner(id).unwrap().as_str(), "r1");
}

#[test]
fn a_robot_does_not_bid_for_a_task_its_battery_cannot_last() {
    let mut bus = Bus::new(Duration::from_millis(2));
    let mut r = Agent::new(
        Token::new("r1").unwrap(),
        "mobile".parse().unwrap(),
        AgentConfig {
            drain_per_second: 0.001,
            ..AgentConfig::default()
        },
        Time::ZERO,
    );
    r.set_battery(0.5);
    let mut user = announcer();
    user.announce(
        Time::ZERO,
        TaskSpec::new("long", "mobile".parse().unwrap()).length(400.0),
    )
    .unwrap();
    let short = user
        .announce(
            Time::ZERO,
            TaskSpec::new("short", "mobile".parse().unwrap()).length(100.0),
        )
        .unwrap();
    bus.run_until(&mut [&mut r, &mut user], t(1.0));
    assert_eq!(user.winner(short).unwrap().as_str(), "r1");
    assert!(agent_events(&mut r).iter().any(|e| matches!(e, AgentEvent::Skipped { name, why, .. } if name == "long" && why.contains("battery"))));
}

#[test]
fn a_robot_that_wins_two_auctions_at_once_keeps_one_and_the_other_goes_to_the_next_best() {
    let mut bus = Bus::new(Duration::from_millis(2));
    let mut robots = vec![
        robot("good", "mobile", (0.0, 0.0)),
        robot("fair", "mobile", (50.0, 0.0)),
    ];
    let mut user = announcer();
    let a = user
        .announce(Time::ZERO, goto("mobile", 1.0, 0.0, 30.0))
        .unwrap();
    let b = user
        .announce(Time::ZERO, goto("mobile", 2.0, 0.0, 30.0))
        .unwrap();
    bus.run_until(&mut nodes(&mut robots, &mut user), t(2.0));
    let winners = [
        user.winner(a).unwrap().as_str(),
        user.winner(b).unwrap().as_str(),
    ];
    assert_eq!(winners, ["good", "fair"]);
    assert_eq!(robots[0].mode(), AgentMode::Working);
    assert_eq!(robots[1].mode(), AgentMode::Working);
}

#[test]
fn malformed_tasks_and_bids_are_rejected_and_do_not_disturb_an_auction() {
    let mut bus = Bus::new(Duration::from_millis(2));
    let mut robots = vec![
        robot("r1", "mobile", (10.0, 0.0)),
        robot("r2", "mobile", (20.0, 0.0)),
    ];
    let mut user = announcer();
    let id = user
        .announce(Time::ZERO, goto("mobile", 0.0, 0.0, 30.0))
        .unwrap();
    bus.run_until(&mut nodes(&mut robots, &mut user), t(0.05));
    let subject = format!("murdoch.user.{id}.1");
    let mut mallory = colony_wire::seal::Identity::from_seed([13; 32]);
    for bad in [
        format!("@ <{subject}> 0\nbid task {id} bidder r9 score lots\n"),
        format!("@ <{subject}> 0\nbid task {id} bidder \"r 9\" score -100\n"),
        format!("@ <{subject}> 0\naward task {id} winner r2\n"),
        format!("@ <{subject}> 0\ncancel task {id}\n"),
        "@ <mobile> <idle> 0\ntask name x id 1 negotiation murdoch.evil.1.1 deadline_ms -5 length_s 3 announcer evil\n".to_string(),
        "@ <mobile> <idle> 0\ntask name x id 1\n".to_string(),
        "@ <mobile> <idle> 0\nnot a packet ((\n".to_string(),
    ] {
        // Sealed, so that what is refused is what they say.
        bus.publish(mallory.sealed(bad.into_bytes()));
    }
    // And one well-formed bid that no seal vouches for.
    bus.publish(format!("@ <{subject}> 0\nbid task {id} bidder r9 score 0\n").into_bytes());
    bus.run_until(&mut nodes(&mut robots, &mut user), t(1.0));
    assert_eq!(user.winner(id).unwrap().as_str(), "r1");
    assert!(user.stats().rejected >= 5, "{:?}", user.stats());
    assert!(robots[1].stats().rejected >= 2);
    assert!(agent_events(&mut robots[1])
        .iter()
        .any(|e| matches!(e, AgentEvent::Rejected(err) if err.to_string().contains("line 2"))));
    assert_eq!(robots[0].mode(), AgentMode::Working);
    assert_eq!(bus.stats().malformed, 1);
}
