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
}

/// The newest command for each robot and the step it arrived at.
struct Commands {
    latest: Vec<Option<(WheelCommand, u64)>>,
}

impl Commands {
    fn for_step(&self, step: u64, timeout: u64) -> Vec<WheelCommand> {
        self.latest
            .iter()
            .map(|c| match c {
                Some((cmd, at)) if step.saturating_sub(*at) <= timeout => *cmd,
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
    let mut commands = Commands {
        latest: vec![None; n],
    };
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
                            if let Some(slot) = commands.latest.get_mut(id) {
                                *slot = Some((cmd, world.step_count()));
                            }
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
        world.step(&commands.for_step(step, options.command_timeout_steps));
        publish_step(world, client)?;
        each_step(world);
        done += 1;
    }
    Ok(())
}

fn publish_step(world: &World, client: &mut UdpClient) -> Result<(), LiveError> {
    let step = world.step_count();
    let robots = world.robots();
    client.publish(&codec::vision_packet(step, &robots, &world.pucks())?)?;
    for rb in robots.iter() {
        let obs = world.observe(RobotId(rb.id.0));
        client.publish(&codec::observation_packet(rb.id.0, step, &obs)?)?;
    }
    Ok(())
}
