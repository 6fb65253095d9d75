//! The world's side of live mode: step in real time (or faster), publish
//! what every robot senses, drive each robot by its newest command.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_sim::{RobotId, WheelCommand, World};

use super::{codec, LiveError};

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

/// The command in force for each robot: the newest one, unless a fresher
/// command of higher priority holds the robot (an operator's override).
pub struct Commands {
    latest: Vec<Option<Held>>,
    timeout: u64,
}

#[derive(Debug, Clone, Copy)]
struct Held {
    cmd: WheelCommand,
    priority: i32,
    step: u64,
}

impl Commands {
    /// Commands for `robots` robots; one older than `timeout` steps lapses.
    pub fn new(robots: usize, timeout: u64) -> Commands {
        Commands {
            latest: vec![None; robots],
            timeout,
        }
    }

    /// Takes a command that arrived at `step`. A command of lower priority
    /// than the one in force is ignored until that one lapses.
    pub fn offer(&mut self, robot: usize, cmd: WheelCommand, priority: i32, step: u64) {
        let timeout = self.timeout;
        let Some(slot) = self.latest.get_mut(robot) else {
            return;
        };
        let replace = match slot {
            Some(h) => priority >= h.priority || step.saturating_sub(h.step) > timeout,
            None => true,
        };
        if replace {
            *slot = Some(Held {
                cmd,
                priority,
                step,
            });
        }
    }

    /// What each robot does at `step`: its command in force, or stop.
    pub fn for_step(&self, step: u64) -> Vec<WheelCommand> {
        self.latest
            .iter()
            .map(|c| match c {
                Some(h) if step.saturating_sub(h.step) <= self.timeout => h.cmd,
                _ => WheelCommand::STOP,
            })
            .collect()
    }
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
    client.subscribe(codec::RADIO)?;
    let n = world.robots().len();
    let mut commands = Commands::new(n, options.command_timeout_steps);
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
                if !packet.has_subject(codec::RADIO) {
                    continue;
                }
                match codec::parse_commands(&packet) {
                    Ok(cmds) => {
                        for (id, cmd) in cmds {
                            commands.offer(id, cmd, packet.priority().0, world.step_count());
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
            client.publish(&codec::metrics_packet(world.step_count(), pc)?)?;
        }
        each_step(world);
        done += 1;
    }
    Ok(())
}

fn publish_step(world: &World, client: &mut UdpClient) -> Result<(), LiveError> {
    let step = world.step_count();
    let robots = world.robots();
    for part in codec::vision_packets(step, world.config(), &robots, &world.pucks())? {
        client.publish(&part)?;
    }
    for rb in robots.iter() {
        let obs = world.observe(RobotId(rb.id.0));
        client.publish(&codec::observation_packet(rb.id.0, step, &obs)?)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cmd(f: f64) -> WheelCommand {
        WheelCommand {
            forward: f,
            turn: 0.0,
        }
    }

    #[test]
    fn an_operator_command_holds_its_robot_against_the_ai_until_it_lapses() {
        let mut c = Commands::new(2, 10);
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
        c.offer(0, cmd(0.5), 0, 12);
        assert_eq!(
            c.for_step(12),
            [cmd(0.5), cmd(0.4)],
            "the override lapsed: the AI has robot 0 back"
        );
    }

    #[test]
    fn a_robot_with_no_fresh_command_stops() {
        let mut c = Commands::new(1, 5);
        c.offer(0, cmd(1.0), 0, 0);
        assert_eq!(c.for_step(5), [cmd(1.0)]);
        assert_eq!(c.for_step(6), [WheelCommand::STOP]);
        c.offer(7, cmd(1.0), 0, 0);
    }
}
