//! The protocol over a real hub on loopback, every agent with its own UDP client.

use std::time::{Duration, Instant};

use colony_node::Mux;
use colony_proto::Vec2;
use colony_tasks::{
    Agent, AgentConfig, AgentEvent, AgentMode, Announcer, AnnouncerEvent, AuctionConfig, Backoff,
    Node, TaskSpec, Time, Token, UserAgent, UserEvent,
};
use colony_testkit::node::{run_until, settle};
use colony_testkit::HubOnThread as Hub;

/// Short timings, so that tests on loopback take fractions of a second.
fn quick_agent() -> AgentConfig {
    AgentConfig {
        renew_interval: Duration::from_millis(50),
        renew_timeout: Duration::from_millis(300),
        award_grace: Duration::from_millis(300),
        battery_check: Duration::from_millis(20),
        linger: Duration::from_millis(300),
        ..AgentConfig::default()
    }
}

fn quick_auction() -> AuctionConfig {
    AuctionConfig {
        bid_window: Duration::from_millis(80),
        ack_timeout: Duration::from_millis(300),
        renew_interval: Duration::from_millis(50),
        renew_timeout: Duration::from_millis(300),
        max_attempts: 16,
    }
}

/// A robot or a user, side by side in one mux.
enum Part {
    Robot(Agent),
    User(Announcer),
    Persistent(UserAgent),
}

impl Part {
    fn node(&self) -> &dyn Node {
        match self {
            Part::Robot(a) => a,
            Part::User(a) => a,
            Part::Persistent(a) => a,
        }
    }
    fn node_mut(&mut self) -> &mut dyn Node {
        match self {
            Part::Robot(a) => a,
            Part::User(a) => a,
            Part::Persistent(a) => a,
        }
    }
    fn robot(&mut self) -> &mut Agent {
        match self {
            Part::Robot(a) => a,
            _ => panic!("not a robot"),
        }
    }
    fn user(&mut self) -> &mut Announcer {
        match self {
            Part::User(a) => a,
            _ => panic!("not an announcer"),
        }
    }
}

impl Node for Part {
    fn subscriptions(&self) -> &std::collections::BTreeSet<colony_wire::Subject> {
        self.node().subscriptions()
    }
    fn handle_packet(&mut self, now: Time, packet: &colony_wire::Packet<'_>) {
        self.node_mut().handle_packet(now, packet)
    }
    fn handle_timeout(&mut self, now: Time) {
        self.node_mut().handle_timeout(now)
    }
    fn poll_timeout(&self) -> Option<Time> {
        self.node().poll_timeout()
    }
    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.node_mut().poll_transmit()
    }
}

struct Setup {
    _hub: Hub,
    epoch: Instant,
    mux: Mux<Part>,
    hub_addr: std::net::SocketAddr,
}

impl Setup {
    fn new() -> Setup {
        let hub = Hub::start();
        Setup {
            hub_addr: hub.addr,
            _hub: hub,
            epoch: Instant::now(),
            mux: Mux::new().unwrap(),
        }
    }

    fn robot(&mut self, name: &str, resources: &str, at: (f64, f64)) -> usize {
        let link = self._hub.link(self.epoch);
        let mut a = Agent::new(
            Token::new(name).unwrap(),
            resources.parse().unwrap(),
            quick_agent(),
            link.now(),
        );
        a.set_position(Vec2::new(at.0, at.1));
        self.mux.add(link, Part::Robot(a)).unwrap()
    }

    fn user(&mut self) -> usize {
        let link = self._hub.link(self.epoch);
        let a = Announcer::new(Token::new("user").unwrap(), quick_auction());
        self.mux.add(link, Part::User(a)).unwrap()
    }

    fn now(&self) -> Time {
        Time::from_micros(self.epoch.elapsed().as_micros() as u64)
    }

    fn announce(&mut self, user: usize, spec: TaskSpec) -> u64 {
        let now = self.now();
        let (_, part) = self.mux.member_mut(user).unwrap();
        let id = part.user().announce(now, spec).unwrap();
        self.mux.pump_all().unwrap();
        id
    }

    fn robot_mut(&mut self, i: usize) -> &mut Agent {
        self.mux.member_mut(i).unwrap().1.robot()
    }

    fn user_mut(&mut self, i: usize) -> &mut Announcer {
        self.mux.member_mut(i).unwrap().1.user()
    }
}

fn goto(resources: &str, length: f64) -> TaskSpec {
    TaskSpec::new("goto", resources.parse().unwrap())
        .length(length)
        .param("x", 0.0)
        .param("y", 0.0)
        .metric("distance", 1.0)
}

fn winner_of(s: &mut Setup, user: usize, id: u64) -> Option<String> {
    s.user_mut(user).winner(id).map(|w| w.to_string())
}

#[test]
fn only_robots_with_all_required_resources_receive_an_announcement() {
    let mut s = Setup::new();
    let all = s.robot("r1", "camera laser mobile", (1.0, 0.0));
    let more = s.robot("r2", "camera laser mobile gripper", (2.0, 0.0));
    let some = s.robot("r3", "camera mobile", (1.0, 0.0));
    let other = s.robot("r4", "laser bumpers mobile", (1.0, 0.0));
    let user = s.user();
    settle(&mut s.mux);
    let id = s.announce(user, goto("camera laser mobile", 60.0));
    let done = run_until(&mut s.mux, Duration::from_secs(3), |m| {
        m.node(user).is_some_and(|u| match u {
            Part::User(a) => a.winner(id).is_some(),
            _ => false,
        })
    });
    assert!(done, "no award");
    assert_eq!(winner_of(&mut s, user, id).as_deref(), Some("r1"));
    for (i, want) in [(all, true), (more, true), (some, false), (other, false)] {
        let heard = s.robot_mut(i).stats().heard;
        assert_eq!(heard > 0, want, "robot {i} heard {heard} packets");
        assert_eq!(s.robot_mut(i).stats().bids > 0, want);
    }
}

#[test]
fn the_best_bid_wins_and_ties_break_the_same_way_every_time() {
    for round in 0..2 {
        let mut s = Setup::new();
        // Created in a different order each round; two tie for best.
        let names = if round == 0 {
            ["kilo", "echo", "zulu"]
        } else {
            ["zulu", "kilo", "echo"]
        };
        for n in names {
            let at = if n == "zulu" {
                (90.0, 0.0)
            } else {
                (30.0, 40.0)
            };
            s.robot(n, "camera mobile", at);
        }
        let user = s.user();
        settle(&mut s.mux);
        let id = s.announce(user, goto("camera mobile", 60.0));
        let mut events = Vec::new();
        run_until(&mut s.mux, Duration::from_secs(3), |m| {
            if let Some((_, Part::User(a))) = m.member_mut(user) {
                events.extend(std::iter::from_fn(|| a.poll_event()));
            }
            events
                .iter()
                .any(|e| matches!(e, AnnouncerEvent::Started { .. }))
        });
        let awarded = events.iter().find_map(|e| match e {
            AnnouncerEvent::Awarded {
                winner,
                score,
                bids,
                ..
            } => Some((winner.to_string(), *score, *bids)),
            _ => None,
        });
        assert_eq!(
            awarded,
            Some(("echo".to_string(), 50.0, 3)),
            "round {round}: {events:?}"
        );
        assert_eq!(winner_of(&mut s, user, id).as_deref(), Some("echo"));
    }
}

#[test]
fn a_winner_killed_mid_task_is_reallocated_within_two_renewal_timeouts() {
    let mut s = Setup::new();
    let first = s.robot("first", "camera mobile", (1.0, 0.0));
    s.robot("second", "camera mobile", (5.0, 0.0));
    let user = s.user();
    settle(&mut s.mux);
    let id = s.announce(user, goto("camera mobile", 600.0));
    let ok = run_until(
        &mut s.mux,
        Duration::from_secs(3),
        |m| matches!(m.node(first), Some(Part::Robot(a)) if a.mode() == AgentMode::Working),
    );
    assert!(ok, "first never started");
    // Let a few renewals go by, then kill it: its socket closes, it says nothing more.
    settle(&mut s.mux);
    let killed = Instant::now();
    s.mux.remove(first);
    let ok = run_until(&mut s.mux, Duration::from_secs(3), |m| match m.node(user) {
        Some(Part::User(a)) => a.winner(id).is_some_and(|w| w.as_str() == "second"),
        _ => false,
    });
    let took = killed.elapsed();
    assert!(ok, "never re-allocated");
    let timeout = quick_auction().renew_timeout;
    assert!(took <= timeout * 2, "re-allocated after {took:?}");
    let ev: Vec<AnnouncerEvent> = std::iter::from_fn(|| s.user_mut(user).poll_event()).collect();
    assert!(ev.iter().any(
        |e| matches!(e, AnnouncerEvent::WinnerLost { winner, .. } if winner.as_str() == "first")
    ));
}

#[test]
fn an_unachievable_task_is_reported_and_the_backoff_agent_allocates_it_once_a_capable_robot_appears(
) {
    let mut s = Setup::new();
    s.robot("cam", "camera mobile", (0.0, 0.0));
    let link = s._hub.link(s.epoch);
    let persistent = UserAgent::new(
        Token::new("persist").unwrap(),
        quick_auction(),
        Backoff {
            initial: Duration::from_millis(100),
            max: Duration::from_millis(400),
            give_up_after: Duration::from_secs(10),
        },
        3,
    );
    let user = s.mux.add(link, Part::Persistent(persistent)).unwrap();
    settle(&mut s.mux);
    let now = s.now();
    let request = match s.mux.member_mut(user).unwrap().1 {
        Part::Persistent(u) => u.introduce(now, goto("camera laser mobile", 0.2)).unwrap(),
        _ => unreachable!(),
    };
    let mut events = Vec::new();
    let drain = |m: &mut Mux<Part>, events: &mut Vec<UserEvent>| {
        if let Some((_, Part::Persistent(u))) = m.member_mut(user) {
            events.extend(std::iter::from_fn(|| u.poll_event()));
        }
    };
    run_until(&mut s.mux, Duration::from_secs(3), |m| {
        drain(m, &mut events);
        events
            .iter()
            .filter(|e| matches!(e, UserEvent::Unachievable { .. }))
            .count()
            >= 2
    });
    let reasons: Vec<&str> = events
        .iter()
        .filter_map(|e| match e {
            UserEvent::Unachievable { reason, .. } => Some(reason.as_str()),
            _ => None,
        })
        .collect();
    assert!(reasons.len() >= 2, "{events:?}");
    assert!(reasons
        .iter()
        .all(|r| *r == "no robot with {camera laser mobile} is available"));
    // A capable robot appears; the next retry finds it.
    let laser = s.robot("laser", "camera laser mobile", (0.0, 0.0));
    let ok = run_until(&mut s.mux, Duration::from_secs(5), |m| {
        drain(m, &mut events);
        events
            .iter()
            .any(|e| matches!(e, UserEvent::Allocated { request: r, .. } if *r == request))
    });
    assert!(ok, "{events:?}");
    let winner = events.iter().find_map(|e| match e {
        UserEvent::Allocated { winner, .. } => Some(winner.to_string()),
        _ => None,
    });
    assert_eq!(winner.as_deref(), Some("laser"));
    assert!(s.robot_mut(laser).stats().started == 1);
}

#[test]
fn an_agent_that_unsubscribes_while_charging_receives_nothing() {
    let mut s = Setup::new();
    let low = s.robot("low", "camera mobile", (0.0, 0.0));
    let user = s.user();
    s.robot_mut(low).set_battery(0.05);
    let ok = run_until(
        &mut s.mux,
        Duration::from_secs(2),
        |m| matches!(m.node(low), Some(Part::Robot(a)) if a.mode() == AgentMode::Charging),
    );
    assert!(ok);
    // Give the hub time to drop its subscriptions.
    settle(&mut s.mux);
    let heard = s.robot_mut(low).stats().heard;
    let id = s.announce(user, goto("camera mobile", 1.0));
    let mut events = Vec::new();
    run_until(&mut s.mux, Duration::from_secs(2), |m| {
        if let Some((_, Part::User(a))) = m.member_mut(user) {
            events.extend(std::iter::from_fn(|| a.poll_event()));
        }
        events
            .iter()
            .any(|e| matches!(e, AnnouncerEvent::Unachievable { .. }))
    });
    assert!(
        events
            .iter()
            .any(|e| matches!(e, AnnouncerEvent::Unachievable { task, .. } if *task == id)),
        "{events:?}"
    );
    assert_eq!(
        s.robot_mut(low).stats().heard,
        heard,
        "a charging robot heard a packet"
    );
    assert_eq!(
        std::iter::from_fn(|| s.robot_mut(low).poll_event()).collect::<Vec<_>>(),
        [AgentEvent::Charge]
    );
    // Charged, it rejoins and takes the next task.
    let now = s.now();
    s.robot_mut(low).set_battery(1.0);
    s.robot_mut(low).charged(now);
    settle(&mut s.mux);
    let id = s.announce(user, goto("camera mobile", 1.0));
    let ok = run_until(&mut s.mux, Duration::from_secs(2), |m| match m.node(user) {
        Some(Part::User(a)) => a.winner(id).is_some(),
        _ => false,
    });
    assert!(ok);
}

#[test]
fn malformed_tasks_and_bids_over_the_hub_do_not_disturb_an_auction() {
    let mut s = Setup::new();
    let good = s.robot("good", "mobile", (1.0, 0.0));
    s.robot("poor", "mobile", (9.0, 0.0));
    let user = s.user();
    settle(&mut s.mux);
    let id = s.announce(user, goto("mobile", 30.0));
    let mut forger = colony_client::UdpClient::connect(s.hub_addr).unwrap();
    let subject = format!("murdoch.user.{id}.1");
    let bad = [
        format!("@ <{subject}> 0\nbid task {id} bidder forger score lots\n"),
        format!("@ <{subject}> 0\nbid task {id} bidder forger score nan\n"),
        format!("@ <{subject}> 0\naward task {id} winner poor\n"),
        "@ <mobile> <idle> 0\ntask name x id 1 negotiation murdoch.f.1.1 deadline_ms 0 length_s 1 announcer f\n".into(),
    ];
    // The forger sends again every 50 ms until the announcer has seen its
    // bids: the announcer's lease on the negotiation subject may still be on
    // its way (a cookie round trip) when the first ones arrive.
    let mut sent: Option<Instant> = None;
    let ok = run_until(&mut s.mux, Duration::from_secs(10), |m| {
        let rejected = matches!(m.node(user), Some(Part::User(a)) if a.stats().rejected >= 2);
        if !rejected && sent.is_none_or(|t| t.elapsed() >= Duration::from_millis(50)) {
            for b in &bad {
                forger.publish(b.as_bytes()).unwrap();
            }
            sent = Some(Instant::now());
        }
        rejected && matches!(m.node(good), Some(Part::Robot(a)) if a.mode() == AgentMode::Working)
    });
    assert!(ok);
    assert_eq!(winner_of(&mut s, user, id).as_deref(), Some("good"));
    assert!(s.user_mut(user).stats().rejected >= 2);
}
