//! The world's side of live mode: step in real time (or faster), publish
//! what every robot senses, drive each robot by its newest command. The
//! world itself is a [`WorldNode`]; this runs it over a real hub.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use colony_client::UdpClient;
use colony_node::Link;
use colony_proto::CommandHold;
use colony_sim::World;

use super::{go_on, LiveError, WorldNode};

/// How the live world runs.
#[derive(Debug, Clone)]
pub struct WorldOptions {
    /// Simulated seconds per control step (the scene's control period).
    pub step_seconds: f64,
    /// How many times faster than real time.
    pub speed: f64,
    /// A robot whose newest command is older than this many steps stops:
    /// a dead controller must not leave its robot driving into a wall.
    pub command_timeout_steps: u64,
    /// Stop after this many steps (`None`: until `stop` is set).
    pub max_steps: Option<u64>,
    /// Percentage completion is published on `metrics` every this many steps.
    pub metrics_every: u64,
    /// The cluster threshold PC is computed with (cm).
    pub cluster_threshold: f64,
}

/// The command in force for each of `robots` robots, lapsing once it is older than
/// `timeout_steps`: [`CommandHold`] holds a command while its age is below its hold, so a
/// command that may still act at age `timeout_steps` holds for one step more than that.
pub fn command_hold(robots: usize, timeout_steps: u64) -> CommandHold {
    CommandHold::new(robots, timeout_steps.saturating_add(1))
}

/// Runs `world` over the hub until `stop` (or `max_steps`); calls `each_step`
/// after every step (for metrics or a progress line).
pub fn run(
    world: &mut World,
    client: &mut UdpClient,
    options: &WorldOptions,
    stop: &AtomicBool,
    each_step: impl FnMut(&World),
) -> Result<(), LiveError> {
    run_with_controllers(world, client, options, Vec::new(), 0, stop, each_step)
}

/// [`run`], with `controllers` (one per robot, in id order; none: every robot's controller is
/// a hub client) stepped in the world's own step as [`WorldNode::with_controllers`] says.
pub fn run_with_controllers(
    world: &mut World,
    client: &mut UdpClient,
    options: &WorldOptions,
    controllers: Vec<Box<dyn crate::Controller>>,
    seed: u64,
    stop: &AtomicBool,
    mut each_step: impl FnMut(&World),
) -> Result<(), LiveError> {
    let mut node = WorldNode::new(world, options)?.with_controllers(controllers, seed);
    let mut seen = 0;
    let mut link = Link::new(client, Instant::now());
    colony_node::run(&mut node, &mut link, stop, |node, _| {
        // The runtime runs at most one timer, so one step, per round.
        if node.steps_done() > seen {
            seen = node.steps_done();
            each_step(node.world());
        }
        go_on(!node.finished())
    })?;
    node.take_error().map_or(Ok(()), Err)
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_sim::WheelCommand;

    fn cmd(f: f64) -> WheelCommand {
        WheelCommand {
            forward: f,
            turn: 0.0,
        }
    }

    #[test]
    fn an_operator_command_holds_its_robot_against_the_ai_until_it_lapses() {
        let mut c = command_hold(2, 10);
        c.offer(0, cmd(0.1), 0, 0);
        c.offer(1, cmd(0.2), 0, 0);
        c.offer(0, cmd(-1.0), 10, 1);
        c.offer(0, cmd(0.3), 0, 2);
        c.offer(1, cmd(0.4), 0, 2);
        assert_eq!(
            c.for_step(3),
            [cmd(-1.0), cmd(0.4)],
            "robot 0 held, robot 1 still the AI's"
        );
        c.offer(0, cmd(0.5), 0, 11);
        assert_eq!(
            c.for_step(11),
            [cmd(-1.0), cmd(0.4)],
            "10 steps old: the override still holds"
        );
        c.offer(0, cmd(0.5), 0, 12);
        assert_eq!(
            c.for_step(12),
            [cmd(0.5), cmd(0.4)],
            "the override lapsed: the AI has robot 0 back"
        );
    }

    #[test]
    fn a_robot_with_no_fresh_command_stops() {
        let mut c = command_hold(1, 5);
        c.offer(0, cmd(1.0), 0, 0);
        assert_eq!(c.for_step(5), [cmd(1.0)], "5 steps old: still in force");
        assert_eq!(c.for_step(6), [WheelCommand::STOP]);
        c.offer(7, cmd(1.0), 0, 0);
    }
}
