//! Live mode with no network: the world and four robot controllers as
//! colony-node nodes on the in-memory bus, which routes every packet through
//! the real sans-IO hub on simulated time, so a live swarm is deterministic
//! and runs as fast as the computation goes.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

use colony_node::{Bus, Node, Time};
use colony_proto::radio::{self, RadioCommand, RADIO};
use colony_proto::swarm::metrics::{self, METRICS};
use colony_proto::swarm::Progress;
use colony_sim::{SceneConfig, WheelCommand, World};
use colony_sort::live::world::WorldOptions;
use colony_sort::live::{RobotNode, WorldNode};
use colony_sort::{build, Controller, Method, SortParams};
use colony_wire::{Packet, Priority, Subject};

const SEED: u64 = 7;

/// A hub client that listens to `radio` and `metrics`, as a monitor does.
#[derive(Default)]
struct Ear {
    subs: BTreeSet<Subject>,
    /// Every command seen: when, for which robot, at which priority.
    commands: Vec<(Time, u32, i32, WheelCommand)>,
    progress: Vec<Progress>,
}

impl Ear {
    fn new() -> Ear {
        Ear {
            subs: [RADIO, METRICS].map(|s| Subject::new(s).unwrap()).into(),
            ..Ear::default()
        }
    }

    /// The robots commanded at `priority` since `since`, with how often.
    fn commanded(&self, since: Time, priority: i32) -> BTreeMap<u32, usize> {
        let mut seen = BTreeMap::new();
        for &(t, robot, p, _) in &self.commands {
            if t >= since && p == priority {
                *seen.entry(robot).or_default() += 1;
            }
        }
        seen
    }
}

impl Node for Ear {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }
    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
        if packet.has_subject(RADIO) {
            for c in radio::decode(packet).unwrap() {
                let p = packet.priority().0;
                self.commands.push((now, c.robot, p, c.wheels));
            }
        } else {
            self.progress.push(metrics::decode(packet).unwrap());
        }
    }
    fn handle_timeout(&mut self, _: Time) {}
    fn poll_timeout(&self) -> Option<Time> {
        None
    }
    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        None
    }
}

type Robot = RobotNode<Box<dyn Controller>>;

/// The standard scene's world and four PROBSEEK robots on one bus.
struct Swarm {
    bus: Bus,
    period: Duration,
    world: WorldNode<World>,
    /// `None`: that robot's controller is dead.
    robots: Vec<Option<Robot>>,
    ear: Ear,
}

impl Swarm {
    fn new() -> Swarm {
        let scene = SceneConfig::default();
        let params = SortParams::default();
        let options = WorldOptions {
            step_seconds: scene.physics.dt * f64::from(scene.physics.substeps),
            speed: 1.0,
            command_timeout_steps: 10,
            max_steps: None,
            metrics_every: 10,
            cluster_threshold: params.perception.cluster_threshold_cm,
        };
        let world = World::new(&scene, SEED).unwrap();
        assert_eq!(world.robot_count(), 4);
        let robots = (0..4).map(|id| Some(Swarm::robot(id))).collect();
        Swarm {
            bus: Bus::new(Duration::from_millis(1)),
            period: Duration::from_secs_f64(options.step_seconds),
            world: WorldNode::new(world, &options).unwrap(),
            robots,
            ear: Ear::new(),
        }
    }

    fn robot(id: usize) -> Robot {
        let scene = SceneConfig::default();
        let controller = build(
            Method::ProbSeek,
            &SortParams::default(),
            scene.pucks.kinds,
            scene.arena.width,
        );
        RobotNode::new(id, controller, SEED).unwrap()
    }

    /// Runs until the world has taken `n` steps, and the robots have
    /// answered the last one.
    fn run_to_step(&mut self, n: u64) {
        let until = Time::ZERO + self.period.mul_f64(n as f64 - 0.5);
        let mut nodes: Vec<&mut dyn Node> = vec![&mut self.world];
        for r in self.robots.iter_mut().flatten() {
            nodes.push(r);
        }
        nodes.push(&mut self.ear);
        self.bus.run_until(&mut nodes, until);
        assert_eq!(self.world.steps_done(), n);
    }

    /// An operator's command for `robot` on `radio`, as `colony radio` sends it.
    fn operator(&mut self, robot: u32, cmd: WheelCommand, priority: i32) {
        let packet =
            radio::encode(&[RadioCommand { robot, wheels: cmd }], Priority(priority)).unwrap();
        self.bus.publish(packet);
    }
}

#[test]
fn every_robot_is_commanded_and_an_operator_at_priority_10_holds_its_robot() {
    let mut s = Swarm::new();
    s.run_to_step(20);
    let ai = s.ear.commanded(Time::ZERO, 0);
    assert_eq!(
        ai.keys().copied().collect::<Vec<_>>(),
        [0, 1, 2, 3],
        "{ai:?}"
    );
    // Each robot answers each step's observation once.
    assert!(ai.values().all(|&n| n == 20), "{ai:?}");

    // The operator takes robot 0 and keeps sending, as a joystick does.
    let held = WheelCommand {
        forward: 0.0,
        turn: 0.37,
    };
    let since = s.bus.now();
    for step in (25..=60).step_by(5) {
        s.operator(0, held, 10);
        s.run_to_step(step);
        assert_eq!(
            s.world.applied()[0],
            held,
            "step {step}: the operator holds robot 0"
        );
        assert_ne!(
            s.world.applied()[1],
            held,
            "step {step}: robot 1 is the AI's"
        );
    }
    let ai = s.ear.commanded(since, 0);
    assert!(
        ai.get(&0).is_some_and(|&n| n >= 35),
        "robot 0's controller kept commanding, and was outranked: {ai:?}"
    );
    assert!(s.ear.commanded(since, 10).contains_key(&0));

    // The operator lets go: the hold lapses after the command timeout and
    // the controller has robot 0 back.
    s.run_to_step(72);
    assert_ne!(s.world.applied()[0], held, "the hold lapsed");
    // The newest of the controller's commands before the last step (step 71).
    let last_step = Time::ZERO + s.period.mul_f64(71.0);
    let last_ai = s
        .ear
        .commands
        .iter()
        .rev()
        .find(|&&(t, robot, p, _)| robot == 0 && p == 0 && t < last_step)
        .map(|&(.., c)| c);
    assert_eq!(Some(s.world.applied()[0]), last_ai);
}

#[test]
fn the_sorting_progresses_and_its_completion_is_published_on_metrics() {
    let mut s = Swarm::new();
    s.run_to_step(600);
    let steps: Vec<u64> = s.ear.progress.iter().map(|p| p.step).collect();
    assert_eq!(steps, (1..=60).map(|k| k * 10).collect::<Vec<_>>());
    let pcs: Vec<f64> = s.ear.progress.iter().map(|p| p.pc).collect();
    assert!(pcs.iter().all(|pc| (0.0..=100.0).contains(pc)), "{pcs:?}");
    let (first, last) = (pcs[0], pcs[pcs.len() - 1]);
    assert!(last > first, "PC went from {first} to {last}: {pcs:?}");
    assert_eq!(s.bus.stats().malformed, 0);
}

#[test]
fn a_dead_controller_stops_its_robot_and_a_restarted_one_picks_up() {
    let mut s = Swarm::new();
    s.run_to_step(30);
    s.robots[2] = None;
    let killed = s.bus.now();
    s.run_to_step(50);
    assert_eq!(
        s.world.applied()[2],
        WheelCommand::STOP,
        "no fresh command: stopped"
    );
    let seen = s.ear.commanded(killed + s.period, 0);
    assert_eq!(
        seen.keys().copied().collect::<Vec<_>>(),
        [0, 1, 3],
        "{seen:?}"
    );

    s.robots[2] = Some(Swarm::robot(2));
    let restarted = s.bus.now();
    s.run_to_step(60);
    let seen = s.ear.commanded(restarted, 0);
    assert_eq!(
        seen.keys().copied().collect::<Vec<_>>(),
        [0, 1, 2, 3],
        "{seen:?}"
    );
    assert_ne!(
        s.world.applied()[2],
        WheelCommand::STOP,
        "robot 2 drives again"
    );
}

#[test]
fn the_same_swarm_runs_the_same_way_twice() {
    let run = || {
        let mut s = Swarm::new();
        s.run_to_step(150);
        let poses: Vec<_> = s.world.world().robots().iter().map(|r| r.pose).collect();
        (s.ear.commands, s.ear.progress, poses)
    };
    assert_eq!(run(), run());
}
