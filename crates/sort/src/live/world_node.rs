//! The simulated world as a sans-IO node: commands in on `radio`, one step
//! per control period, and what every robot senses out.

use std::borrow::BorrowMut;
use std::collections::{BTreeSet, VecDeque};
use std::time::Duration;

use colony_client::ClientError;
use colony_node::{Node, Time};
use colony_proto::radio::RADIO;
use colony_proto::swarm::{
    camera, metrics, vision, Arena, Progress, Sizes, VisionFrame, VisionPuck, VisionRobot,
};
use colony_proto::CommandHold;
use colony_sim::{RobotId, SceneConfig, WheelCommand, World};
use colony_wire::{Packet, Subject};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::world::{command_hold, WorldOptions};
use super::{wire_id, LiveError};
use crate::swarm::ROBOTS_PER_TASK;
use crate::Controller;

/// The live world: it subscribes to `radio` and holds each robot's command
/// by the hold rule ([`command_hold`]); its timer steps the world once per
/// control period (divided by the speed), and each step publishes the
/// `vision` parts, every robot's `camera.N` and, every
/// [`metrics_every`](WorldOptions::metrics_every) steps, the percentage
/// completion on `metrics`.
///
/// Step `k` (counting the steps this node ran from 0) is due at
/// `k · period` after [`Time::ZERO`], so a late step does not delay the
/// ones after it. One call of [`handle_timeout`](Node::handle_timeout) runs
/// one step, so commands that arrived meanwhile are taken between two late
/// steps. `W` is the world, owned or borrowed.
pub struct WorldNode<W> {
    world: W,
    options: WorldOptions,
    period: Duration,
    commands: CommandHold,
    /// The commands the last step drove the robots with.
    applied: Vec<WheelCommand>,
    done: u64,
    subs: BTreeSet<Subject>,
    outbox: VecDeque<Vec<u8>>,
    /// What stopped the world: a step it could not publish.
    error: Option<LiveError>,
    /// Controllers stepped here, one per robot, when they run in the world's own step rather
    /// than as hub clients ([`with_controllers`](Self::with_controllers)).
    inline: Vec<(Box<dyn Controller>, ChaCha8Rng)>,
}

impl<W: BorrowMut<World>> WorldNode<W> {
    /// A node that runs `world` as `options` say; the speed must be a
    /// positive number.
    pub fn new(world: W, options: &WorldOptions) -> Result<WorldNode<W>, LiveError> {
        if !(options.speed.is_finite() && options.speed > 0.0) {
            return Err(LiveError::Options(format!(
                "speed must be a positive number, not {}",
                options.speed
            )));
        }
        let period =
            Duration::try_from_secs_f64(options.step_seconds / options.speed).map_err(|_| {
                LiveError::Options(format!(
                    "speed {} makes a control step of {} s last longer than colony can wait",
                    options.speed, options.step_seconds
                ))
            })?;
        let n = world.borrow().robots().len();
        // As the hub client's subscribe would refuse it.
        let subs = [Subject::new(RADIO).map_err(ClientError::from)?].into();
        Ok(WorldNode {
            world,
            period,
            commands: command_hold(n, options.command_timeout_steps),
            applied: vec![WheelCommand::STOP; n],
            done: 0,
            options: options.clone(),
            subs,
            outbox: VecDeque::new(),
            error: None,
            inline: Vec::new(),
        })
    }

    /// Runs every robot's controller in the world's own step, `controllers[i]` for robot `i`
    /// with the random numbers a hub client of its own would draw (from `seed` and the id):
    /// after each step every controller is given its robot's observation, and its command is
    /// offered to the hold rule at priority 0, as its `radio` packet would be. So an operator's
    /// command on `radio` still outranks it. Nothing goes on `camera.N` or `debug` for these
    /// robots: at thousands of robots those packets (one each per robot per step, through the
    /// hub and back) cost more than the world's step, and no one else reads them.
    pub fn with_controllers(
        mut self,
        controllers: Vec<Box<dyn Controller>>,
        seed: u64,
    ) -> WorldNode<W> {
        self.inline = controllers
            .into_iter()
            .enumerate()
            .map(|(robot, c)| (c, super::robot_node::robot_rng(seed, robot)))
            .collect();
        self
    }

    /// The world as it stands.
    pub fn world(&self) -> &World {
        self.world.borrow()
    }

    /// The commands the last step drove each robot with (all stopped before
    /// the first step): what the hold rule made of the `radio` traffic.
    pub fn applied(&self) -> &[WheelCommand] {
        &self.applied
    }

    /// How many steps this node has run.
    pub fn steps_done(&self) -> u64 {
        self.done
    }

    /// Whether the world has stopped: it ran its
    /// [`max_steps`](WorldOptions::max_steps), or failed.
    pub fn finished(&self) -> bool {
        self.error.is_some() || self.options.max_steps.is_some_and(|m| self.done >= m)
    }

    /// What stopped the world, if a step failed; taken once.
    pub fn take_error(&mut self) -> Option<LiveError> {
        self.error.take()
    }

    /// One step: drive every robot by the command in force, then queue what
    /// the step publishes.
    fn step(&mut self) -> Result<(), LiveError> {
        let world = self.world.borrow_mut();
        let step = world.step_count();
        self.applied = self.commands.for_step(step);
        world.step(&self.applied);
        let world = self.world.borrow();
        // A swarm's lines are written on rayon's threads (in order, so the packets are the same).
        let frame = vision_frame(world)?;
        let robots = frame.robots.par_iter().map(vision::robot_line).collect();
        let pucks = frame.pucks.par_iter().map(vision::puck_line).collect();
        self.outbox
            .extend(vision::encode_with_lines(&frame, robots, pucks)?);
        let step = world.step_count();
        // Controllers in the world sense and decide on rayon's threads, as in a batch trial:
        // each from the same world and with its own stream, so the threads change nothing;
        // their commands are offered in robot order.
        let decided: Vec<WheelCommand> = self
            .inline
            .par_iter_mut()
            .enumerate()
            .with_min_len(ROBOTS_PER_TASK)
            .map(|(i, (controller, rng))| controller.step(&world.observe(RobotId(i)), rng))
            .collect();
        for (i, cmd) in decided.into_iter().enumerate() {
            self.commands.offer(i, cmd, 0, step);
        }
        for i in self.inline.len()..world.robot_count() {
            let obs = world.observe(RobotId(i));
            self.outbox
                .push_back(camera::encode(wire_id(i)?, step, &obs)?);
        }
        if step % self.options.metrics_every.max(1) == 0 {
            let pc = crate::metrics::percentage_completion(
                &world.pucks(),
                self.options.cluster_threshold,
            );
            self.outbox
                .push_back(metrics::encode(Progress { step, pc })?);
        }
        Ok(())
    }
}

impl<W: BorrowMut<World>> Node for WorldNode<W> {
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, _: Time, packet: &Packet<'_>) {
        if !packet.has_subject(RADIO) {
            return;
        }
        let step = self.world.borrow().step_count();
        if let Err(e) = self.commands.offer_radio(packet, step) {
            tracing::debug!(error = %e, "ignored a bad radio packet");
        }
    }

    fn handle_timeout(&mut self, now: Time) {
        if self.poll_timeout().is_some_and(|due| due <= now) {
            if let Err(e) = self.step() {
                self.error = Some(e);
            }
            self.done += 1;
        }
    }

    fn poll_timeout(&self) -> Option<Time> {
        if self.finished() {
            return None;
        }
        Some(Time::ZERO + self.period.mul_f64(self.done as f64))
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }
}

/// The world as the overhead camera sees it (also what colony-env's sorting environment
/// publishes for a monitor).
pub fn vision_frame(world: &World) -> Result<VisionFrame, LiveError> {
    let scene: &SceneConfig = world.config();
    let robots = world
        .robots()
        .iter()
        .map(|rb| {
            Ok(VisionRobot {
                id: wire_id(rb.id.0)?,
                pose: rb.pose,
                carrying: rb.carrying.map(|c| puck_id(c.0)).transpose()?,
            })
        })
        .collect::<Result<_, LiveError>>()?;
    let pucks = world
        .pucks()
        .iter()
        .map(|pk| {
            Ok(VisionPuck {
                id: puck_id(pk.id.0)?,
                kind: pk.kind,
                pos: pk.pos,
            })
        })
        .collect::<Result<_, LiveError>>()?;
    Ok(VisionFrame {
        step: world.step_count(),
        arena: Some(Arena {
            width: scene.arena.width,
            height: scene.arena.height,
            corner: scene.arena.corner_radius,
        }),
        sizes: Some(Sizes {
            robot_length: scene.robots.length,
            robot_width: scene.robots.width,
            gripper_radius: scene.robots.gripper_radius,
            puck_diameter: scene.pucks.diameter,
        }),
        robots,
        pucks,
        ..VisionFrame::default()
    })
}

/// A puck id as the `u32` messages write it (the same rule as a robot's).
fn puck_id(puck: usize) -> Result<u32, LiveError> {
    wire_id(puck)
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_proto::radio;
    use colony_wire::Priority;

    fn options(max_steps: Option<u64>) -> WorldOptions {
        WorldOptions {
            step_seconds: 0.1,
            speed: 2.0,
            command_timeout_steps: 10,
            max_steps,
            metrics_every: 2,
            cluster_threshold: 10.0,
        }
    }

    fn drain(node: &mut WorldNode<World>) -> Vec<Vec<u8>> {
        std::iter::from_fn(|| node.poll_transmit()).collect()
    }

    #[test]
    fn the_vision_frame_carries_every_robot_and_puck_with_the_scene() {
        let scene = SceneConfig::default();
        let world = World::new(&scene, 3).unwrap();
        let frame = vision_frame(&world).unwrap();
        assert_eq!(frame.robots.len(), world.robot_count());
        assert_eq!(frame.pucks.len(), world.pucks().len());
        assert_eq!(frame.arena.unwrap().corner, scene.arena.corner_radius);
        assert_eq!(frame.sizes.unwrap().puck_diameter, scene.pucks.diameter);
    }

    #[test]
    fn a_speed_that_is_not_positive_is_refused() {
        let mut world = World::new(&SceneConfig::default(), 3).unwrap();
        for speed in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e-310] {
            let o = WorldOptions {
                speed,
                ..options(None)
            };
            let refused = WorldNode::new(&mut world, &o);
            assert!(matches!(refused, Err(LiveError::Options(_))), "{speed}");
        }
    }

    #[test]
    fn each_step_is_due_a_period_after_the_last_and_publishes_what_the_robots_sense() {
        let world = World::new(&SceneConfig::default(), 3).unwrap();
        let n = world.robot_count();
        let mut node = WorldNode::new(world, &options(Some(2))).unwrap();
        assert_eq!(node.poll_timeout(), Some(Time::ZERO));
        node.handle_timeout(Time::ZERO);
        assert_eq!(node.poll_timeout(), Some(Time::from_micros(50_000)));
        let first = drain(&mut node);
        let cameras = first
            .iter()
            .filter(|p| Packet::parse(p).unwrap().has_subject("camera.0"))
            .count();
        assert_eq!(cameras, 1);
        assert!(first.len() > n, "vision parts and {n} cameras");
        // Not due yet: nothing happens.
        node.handle_timeout(Time::from_micros(49_999));
        assert_eq!(node.steps_done(), 1);
        node.handle_timeout(Time::from_micros(50_000));
        let second = drain(&mut node);
        let metrics = second
            .iter()
            .filter_map(|p| metrics::decode(&Packet::parse(p).unwrap()).ok())
            .collect::<Vec<_>>();
        assert_eq!(metrics.len(), 1, "step 2 of every 2");
        assert_eq!(metrics[0].step, 2);
        assert!(node.finished());
        assert_eq!(node.poll_timeout(), None);
    }

    #[test]
    fn controllers_in_the_world_drive_it_with_no_camera_packets_and_yield_to_an_operator() {
        let scene = SceneConfig::default();
        let world = World::new(&scene, 3).unwrap();
        let n = world.robot_count();
        let controllers = (0..n)
            .map(|_| {
                crate::methods::build(
                    crate::methods::Method::CacheCons,
                    &crate::params::SortParams::default(),
                    scene.pucks.kinds,
                    scene.arena.width,
                )
            })
            .collect();
        let mut node = WorldNode::new(world, &options(None))
            .unwrap()
            .with_controllers(controllers, 1);
        let op = radio::encode(&[radio::RadioCommand::new(0, -0.5, 0.0)], Priority(10)).unwrap();
        node.handle_packet(Time::ZERO, &Packet::parse(&op).unwrap());
        for k in 0..3 {
            node.handle_timeout(Time::from_micros(50_000 * k));
            let sent = drain(&mut node);
            assert!(sent
                .iter()
                .all(|p| !Packet::parse(p).unwrap().has_subject("camera.1")));
            assert!(sent
                .iter()
                .any(|p| Packet::parse(p).unwrap().has_subject("vision")));
        }
        assert_eq!(
            node.applied()[0].forward,
            -0.5,
            "the operator holds robot 0"
        );
        assert!(
            node.applied()[1..].iter().all(|c| *c != WheelCommand::STOP),
            "every other robot is driven by its controller: {:?}",
            node.applied()
        );
    }

    #[test]
    fn commands_on_radio_drive_the_next_step_by_the_hold_rule() {
        let world = World::new(&SceneConfig::default(), 3).unwrap();
        let mut node = WorldNode::new(world, &options(None)).unwrap();
        let send = |node: &mut WorldNode<World>, robot, forward, priority| {
            let bytes = radio::encode(
                &[radio::RadioCommand::new(robot, forward, 0.0)],
                Priority(priority),
            )
            .unwrap();
            node.handle_packet(Time::ZERO, &Packet::parse(&bytes).unwrap());
        };
        send(&mut node, 0, 0.5, 10);
        send(&mut node, 0, 0.2, 0);
        send(&mut node, 1, 0.3, 0);
        node.handle_timeout(Time::ZERO);
        assert_eq!(node.applied()[0].forward, 0.5, "the operator holds robot 0");
        assert_eq!(node.applied()[1].forward, 0.3);
        assert_eq!(node.applied()[2], WheelCommand::STOP, "no command: stopped");
        // A packet on another subject is not a command.
        let other = Packet::parse(b"@ <debug> 0\ncmd id 2 forward 1 turn 0\n").unwrap();
        node.handle_packet(Time::ZERO, &other);
        node.handle_timeout(Time::from_secs_f64(1.0));
        assert_eq!(node.applied()[2], WheelCommand::STOP);
    }
}
