use std::time::{Duration, Instant};

use colony_wire::{ChannelInfo, Packet, StatusReport};

use super::*;

const PAGE: PageId = PageId(1);

fn ms(t0: Instant, ms: u64) -> Instant {
    t0 + Duration::from_millis(ms)
}

/// A link started at `t0`, its first subscriptions taken out.
fn started() -> (HubLink, Instant) {
    let t0 = Instant::now();
    let mut link = HubLink::new(t0, 1_000_000, Vec::new());
    link.start(t0);
    transmits(&mut link);
    (link, t0)
}

fn transmits(link: &mut HubLink) -> Vec<Transmit> {
    std::iter::from_fn(|| link.poll_transmit()).collect()
}

fn outputs(link: &mut HubLink) -> Vec<Output> {
    std::iter::from_fn(|| link.poll_output()).collect()
}

/// What kind each output is, in order.
fn kinds(outputs: &[Output]) -> Vec<&'static str> {
    outputs
        .iter()
        .map(|o| match o {
            Output::World(_) => "world",
            Output::Hub(_) => "hub",
            Output::Game(_) => "game",
            Output::Chat(_) => "chat",
            Output::Map(_) => "map",
            Output::Tasks(_) => "tasks",
            Output::Scene(Scene::Arena) => "arena",
            Output::Scene(Scene::Battlefield) => "battlefield",
            Output::Scene(Scene::Terrain) => "terrain",
        })
        .collect()
}

/// Vision frame number `step`: robots 0 and 1 in a small arena.
fn frame(step: u64) -> String {
    format!(
        "@ <vision> 20\nstep n {step} part 0 parts 1\narena width 187 height 187 corner 15\n\
         sizes robot_length 12.5 robot_width 10.8 gripper_radius 3.6 puck_diameter 6.3\n\
         robot id 1 x 10 y 0 theta 0 carrying 3\nrobot id 0 x -5 y 2.5 theta 1.57\n\
         puck id 3 kind 1 x 17 y 0\n"
    )
}

fn packet(link: &mut HubLink, now: Instant, text: &str) -> bool {
    link.handle_packet(now, &Packet::parse(text.as_bytes()).unwrap())
}

fn report(channels: &[&str]) -> StatusReport {
    StatusReport {
        lease_ms: 10_000,
        channels: channels
            .iter()
            .map(|c| ChannelInfo {
                subjects: (*c).into(),
                packets: 1,
                bytes: 10,
            })
            .collect(),
        ..StatusReport::default()
    }
}

fn subscribes(ts: &[Transmit]) -> Vec<&str> {
    ts.iter()
        .filter_map(|t| match t {
            Transmit::Subscribe(s) => Some(s.as_str()),
            _ => None,
        })
        .collect()
}

#[test]
fn starting_subscribes_to_the_core_and_game_channels_once() {
    let t0 = Instant::now();
    let mut link = HubLink::new(t0, 0, Vec::new());
    assert!(transmits(&mut link).is_empty(), "nothing before start");
    link.start(t0);
    let want: Vec<&str> = CORE_CHANNELS.into_iter().chain(GAME_CHANNELS).collect();
    assert_eq!(subscribes(&transmits(&mut link)), want);
    link.start(t0);
    assert!(transmits(&mut link).is_empty(), "already subscribed");
}

#[test]
fn the_first_timeout_asks_for_status_and_sends_the_hub_view() {
    let (mut link, t0) = started();
    assert_eq!(link.poll_timeout(), t0, "both are due at once");
    link.handle_timeout(t0);
    assert_eq!(transmits(&mut link), [Transmit::AskStatus]);
    assert_eq!(kinds(&outputs(&mut link)), ["hub"]);
    assert_eq!(
        link.poll_timeout(),
        ms(t0, 250),
        "a quiet link next wakes for the world's at-least"
    );
    link.handle_timeout(ms(t0, 100));
    assert!(transmits(&mut link).is_empty() && outputs(&mut link).is_empty());
}

#[test]
fn a_quiet_link_sends_each_view_at_its_slowest_pace() {
    let (mut link, t0) = started();
    let mut sent: Vec<(u64, &str)> = Vec::new();
    let mut now = t0;
    while now <= ms(t0, 1000) {
        link.handle_timeout(now);
        transmits(&mut link);
        for k in kinds(&outputs(&mut link)) {
            sent.push(((now - t0).as_millis() as u64, k));
        }
        let next = link.poll_timeout();
        assert!(next > now, "the deadline moves on: {next:?} at {now:?}");
        now = next;
    }
    assert_eq!(
        sent,
        [
            (0, "hub"),
            (250, "world"),
            (500, "world"),
            (500, "game"),
            (750, "world"),
            (1000, "world"),
            (1000, "game"),
            (1000, "tasks"),
            (1000, "hub"),
        ]
    );
}

#[test]
fn a_new_frame_is_sent_no_sooner_than_33_ms_after_the_last_snapshot() {
    let (mut link, t0) = started();
    link.handle_timeout(t0);
    outputs(&mut link);
    assert!(packet(&mut link, ms(t0, 10), &frame(1)));
    assert_eq!(link.poll_timeout(), ms(t0, 33));
    link.handle_timeout(ms(t0, 10));
    assert!(outputs(&mut link).is_empty());
    link.handle_timeout(ms(t0, 33));
    let out = outputs(&mut link);
    let [Output::World(w)] = &out[..] else {
        panic!("{:?}", kinds(&out))
    };
    assert_eq!(w.frame, 1);
    assert!(!w.bodies.is_empty());
    assert!(w.json.starts_with(r#"{"t":"world""#));
    // The same frame again at the at-least: the bodies are shared, not built again.
    link.handle_timeout(ms(t0, 283));
    let out = outputs(&mut link);
    let [Output::World(again)] = &out[..] else {
        panic!("{:?}", kinds(&out))
    };
    assert_eq!(again.frame, 1);
    assert_eq!(again.bodies.as_ptr(), w.bodies.as_ptr());
}

#[test]
fn the_hub_view_keeps_to_the_channels_subscribed_and_a_status_report_adds_its_channels() {
    let (mut link, t0) = started();
    link.handle_timeout(t0);
    outputs(&mut link);
    transmits(&mut link);
    assert!(
        !packet(&mut link, t0, "@ <extra> 0\nx\n"),
        "tapped, not shown"
    );
    link.handle_status(ms(t0, 5), [report(&["vision", "extra", "a b", "hub"])]);
    assert_eq!(
        link.poll_timeout(),
        ms(t0, 5),
        "a report makes the hub view due"
    );
    assert_eq!(
        subscribes(&transmits(&mut link)),
        ["a", "b", "extra"],
        "the new ones, never the hub's own"
    );
    assert!(packet(&mut link, ms(t0, 6), "@ <extra> 0\nx\n"));
    assert!(packet(&mut link, ms(t0, 6), "@ <a> <b> 0\nx\n"));
    link.handle_timeout(ms(t0, 6));
    assert_eq!(kinds(&outputs(&mut link)), ["hub"]);
    link.handle_status(ms(t0, 7), []);
    assert_eq!(
        link.poll_timeout(),
        ms(t0, 50),
        "no report, nothing due but the game, which heard who listens to its teams"
    );
}

#[test]
fn of_the_reports_read_together_the_newest_names_the_channels() {
    let (mut link, t0) = started();
    link.handle_status(t0, [report(&["old"]), report(&["new"])]);
    assert_eq!(subscribes(&transmits(&mut link)), ["new"]);
}

#[test]
fn extra_channels_stop_at_the_cap_and_a_failed_subscription_is_tried_again() {
    let (mut link, t0) = started();
    let names: Vec<String> = (0..EXTRA_CHANNELS + 10)
        .map(|i| format!("x{i:03}"))
        .collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    link.handle_status(t0, [report(&refs)]);
    let subs = transmits(&mut link);
    assert_eq!(subscribes(&subs), refs[..EXTRA_CHANNELS]);
    link.subscribe_failed("x000");
    assert!(!packet(&mut link, t0, "@ <x000> 0\nx\n"));
    link.handle_status(ms(t0, 1000), [report(&refs)]);
    assert_eq!(subscribes(&transmits(&mut link)), ["x000"]);
}

#[test]
fn a_forged_packet_subscribes_its_subjects_before_it_is_published() {
    let (mut link, t0) = started();
    let bytes = b"@ <hub> <mine> 0\nx\n".to_vec();
    let command = Command::Publish(bytes.clone());
    assert_eq!(link.prepare(&command).unwrap(), Some(bytes.clone()));
    assert_eq!(subscribes(&transmits(&mut link)), ["mine"]);
    assert_eq!(
        link.apply(t0, PAGE, command).unwrap(),
        format!("published {} bytes", bytes.len())
    );
    assert!(matches!(
        link.prepare(&Command::Publish(b"not a packet".to_vec())),
        Err(CommandError::Packet(_))
    ));
    assert!(transmits(&mut link).is_empty());
    assert_eq!(link.prepare(&Command::TakeAll).unwrap(), None);
}

#[test]
fn a_game_order_is_published_as_its_packet() {
    let (mut link, _) = started();
    let order = crate::protocol::parse_message(
        r#"{"t":"chat","team":"red","from":"ada","text":"hold the bridge"}"#,
    )
    .unwrap();
    let bytes = link.prepare(&order).unwrap().expect("a packet");
    let p = Packet::parse(&bytes).unwrap();
    assert!(p.has_subject("game.chat.red"));
    assert!(
        transmits(&mut link).is_empty(),
        "its team's chat is not shown"
    );
}

#[test]
fn held_robots_are_commanded_on_each_new_frame_and_every_80_ms() {
    let (mut link, t0) = started();
    packet(&mut link, t0, &frame(1));
    link.handle_timeout(t0);
    transmits(&mut link);
    link.apply(t0, PAGE, Command::Take(vec![1])).unwrap();
    assert_eq!(
        link.poll_timeout(),
        t0,
        "taken on the frame not yet commanded"
    );
    link.handle_timeout(ms(t0, 1));
    let published = |ts: Vec<Transmit>| {
        ts.into_iter()
            .filter(|t| matches!(t, Transmit::Publish(_)))
            .count()
    };
    assert_eq!(published(transmits(&mut link)), 1);
    assert_eq!(link.poll_timeout(), ms(t0, 33), "the world's new frame");
    link.handle_timeout(ms(t0, 33));
    assert_eq!(published(transmits(&mut link)), 0);
    assert_eq!(link.poll_timeout(), ms(t0, 81));
    link.handle_timeout(ms(t0, 81));
    assert_eq!(published(transmits(&mut link)), 1);
    packet(&mut link, ms(t0, 90), &frame(2));
    assert!(link.poll_timeout() <= ms(t0, 90), "a new frame: at once");
    link.handle_timeout(ms(t0, 90));
    let sent = transmits(&mut link);
    let Some(Transmit::Publish(p)) = sent.iter().find(|t| matches!(t, Transmit::Publish(_))) else {
        panic!("{sent:?}")
    };
    let p = Packet::parse(p).unwrap();
    assert!(p.has_subject("radio"));
    assert_eq!(p.line("cmd").unwrap().i64("id").unwrap(), 1);
    assert_eq!(link.page_closed(PAGE), 1);
    link.handle_timeout(ms(t0, 500));
    assert_eq!(published(transmits(&mut link)), 0, "let go with its page");
}

#[test]
fn the_arena_scene_is_asked_for_only_while_watched_and_within_its_budget() {
    let (mut link, t0) = started();
    packet(&mut link, t0, &frame(1));
    link.handle_timeout(t0);
    assert!(!kinds(&outputs(&mut link)).contains(&"arena"));
    link.set_watched(Watched {
        arena: true,
        battlefield: false,
    });
    link.handle_timeout(ms(t0, 1));
    assert_eq!(kinds(&outputs(&mut link)), ["arena"]);
    let scene = link.scene(Scene::Arena, 5).unwrap();
    assert!(!scene.is_empty());
    // A build of 100 ms keeps the next for 400 ms (a quarter of the thread).
    assert_eq!(link.arena_built(ms(t0, 1), Duration::from_millis(100)), 0);
    for (i, at) in [(2, 100), (3, 300), (4, 400)] {
        packet(&mut link, ms(t0, at), &frame(i));
        link.handle_timeout(ms(t0, at));
        assert!(!kinds(&outputs(&mut link)).contains(&"arena"), "at {at} ms");
    }
    link.handle_timeout(ms(t0, 401));
    assert!(kinds(&outputs(&mut link)).contains(&"arena"));
    assert_eq!(
        link.arena_built(ms(t0, 401), Duration::from_millis(1)),
        2,
        "frames 2 and 3 passed over"
    );
}

#[test]
fn scenes_of_a_game_not_yet_seen_are_not_asked_for() {
    let (mut link, t0) = started();
    link.set_watched(Watched {
        arena: false,
        battlefield: true,
    });
    packet(
        &mut link,
        t0,
        "@ <game.event> 0\nevent kind hit time 1 text \"hit\"\n",
    );
    link.handle_timeout(ms(t0, 50));
    assert_eq!(kinds(&outputs(&mut link)), ["game", "hub"]);
    assert_eq!(link.scene(Scene::Battlefield, 0), None);
    assert_eq!(link.scene(Scene::Terrain, 0), None);
}

#[test]
fn the_deadline_is_never_left_in_the_past() {
    let (mut link, t0) = started();
    link.set_watched(Watched {
        arena: true,
        battlefield: true,
    });
    let mut now = t0;
    for step in 0..400u64 {
        if step % 7 == 0 {
            packet(&mut link, now, &frame(step / 7 + 1));
        }
        if step % 13 == 0 {
            packet(&mut link, now, "@ <game.event> 0\nevent kind hit time 1\n");
        }
        if step % 50 == 0 {
            link.handle_status(now, [report(&["vision", "radio"])]);
        }
        if step == 20 {
            link.apply(now, PAGE, Command::Take(vec![0, 1])).unwrap();
        }
        link.handle_timeout(now);
        transmits(&mut link);
        for o in outputs(&mut link) {
            if let Output::Scene(Scene::Arena) = o {
                link.arena_built(now, Duration::from_millis(2));
            }
        }
        assert!(link.poll_timeout() > now, "step {step}");
        now += Duration::from_millis(3);
    }
}

#[test]
fn the_first_snapshots_show_no_frame_and_shutdown_with_nothing_held_asks_nothing() {
    let (mut link, t0) = started();
    let first = link.snapshots(t0);
    assert_eq!(first.world.frame, 0);
    assert!(first.hub.starts_with(r#"{"t":"hub""#));
    assert!(first.tasks.starts_with(r#"{"t":"tasks""#));
    assert!(link.shutdown().is_empty());
}
