//! The world's side of live mode: step in real time (or faster), publish
//! what every robot senses, drive each robot by its newest command.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_proto::radio::{self, RADIO};
use colony_proto::swarm::{
    camera, metrics, vision, Arena, Progress, Sizes, VisionFrame, VisionPuck, VisionRobot,
};
use colony_proto::CommandHold;
use colony_sim::{RobotId, SceneConfig, World};

use super::{wire_id, LiveError};

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
    mut each_step: impl FnMut(&World),
) -> Result<(), LiveError> {
    if !(options.speed.is_finite() && options.speed > 0.0) {
        return Err(LiveError::Options(format!(
            "speed must be a positive number, not {}",
            options.speed
        )));
    }
    client.subscribe(RADIO)?;
    let n = world.robots().len();
    let mut commands = command_hold(n, options.command_timeout_steps);
    let period = Duration::from_secs_f64(options.step_seconds / options.speed);
    let start = Instant::now();
    let mut done = 0u64;
    while !stop.load(Ordering::Relaxed) && options.max_steps.is_none_or(|m| done < m) {
        let due = start + period.mul_f64(done as f64);
        // Take commands until the step is due.
        loop {
            let now = Instant::now();
            client.poll(now)?;
            while let Some(packet) = client.recv()? {
                if !packet.has_subject(RADIO) {
                    continue;
                }
                match radio::decode(&packet) {
                    Ok(cmds) => {
                        for c in cmds {
                            commands.offer(
                                c.robot as usize,
                                c.wheels,
                                packet.priority().0,
                                world.step_count(),
                            );
                        }
                    }
                    Err(e) => tracing::debug!(error = %e, "ignored a bad radio packet"),
                }
            }
            if now >= due {
                break;
            }
            let wake = client.next_deadline().map_or(due, |d| d.min(due));
            client.wait(Some(wake))?;
        }
        let step = world.step_count();
        world.step(&commands.for_step(step));
        publish_step(world, client)?;
        if world.step_count() % options.metrics_every.max(1) == 0 {
            let pc =
                crate::metrics::percentage_completion(&world.pucks(), options.cluster_threshold);
            client.publish(&metrics::encode(Progress {
                step: world.step_count(),
                pc,
            })?)?;
        }
        each_step(world);
        done += 1;
    }
    Ok(())
}

fn publish_step(world: &World, client: &mut UdpClient) -> Result<(), LiveError> {
    let step = world.step_count();
    let robots = world.robots();
    for part in vision::encode(&vision_frame(world)?)? {
        client.publish(&part)?;
    }
    for rb in robots.iter() {
        let obs = world.observe(RobotId(rb.id.0));
        client.publish(&camera::encode(wire_id(rb.id.0)?, step, &obs)?)?;
    }
    Ok(())
}

/// The world as the overhead camera sees it.
fn vision_frame(world: &World) -> Result<VisionFrame, LiveError> {
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
    })
}

/// A puck id as the `u32` messages write it (the same rule as a robot's).
fn puck_id(puck: usize) -> Result<u32, LiveError> {
    wire_id(puck)
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
}
