//! A robot's side of live mode: its controller as a hub client of its own.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_proto::radio::{self, RadioCommand};
use colony_proto::swarm::{camera, debug, CachePoint, Intent, Intentions};
use colony_wire::Priority;
use rand_chacha::rand_core::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{wire_id, LiveError};
use crate::Controller;

/// Runs one robot's controller until `stop`: each camera observation from
/// the world becomes one command on `radio` and one intention on `debug`.
/// Only the newest observation is acted on; older ones waiting behind it are
/// stale by the time they are read.
pub fn run(
    robot: usize,
    controller: &mut dyn Controller,
    client: &mut UdpClient,
    seed: u64,
    stop: &AtomicBool,
) -> Result<(), LiveError> {
    let id = wire_id(robot)?;
    client.subscribe(&camera::camera_channel(id))?;
    let mut rng =
        ChaCha8Rng::seed_from_u64(seed ^ (robot as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    while !stop.load(Ordering::Relaxed) {
        let wake = client
            .next_deadline()
            .map_or(Instant::now() + Duration::from_millis(100), |d| {
                d.min(Instant::now() + Duration::from_millis(100))
            });
        client.wait(Some(wake))?;
        client.poll(Instant::now())?;
        let mut newest = None;
        while let Some(packet) = client.recv()? {
            match camera::decode(&packet) {
                Ok(view) => newest = Some(view.observation),
                Err(e) => tracing::debug!(robot, error = %e, "ignored a bad observation"),
            }
        }
        let Some(obs) = newest else { continue };
        let cmd = controller.step(&obs, &mut rng);
        client.publish(&radio::encode(
            &[RadioCommand {
                robot: id,
                wheels: cmd,
            }],
            Priority(0),
        )?)?;
        let intentions = Intentions {
            intents: vec![Intent {
                robot: id,
                state: controller.state().to_owned(),
                target: controller.target(),
            }],
            caches: controller
                .cache_points()
                .into_iter()
                .map(|(kind, pos)| CachePoint {
                    robot: id,
                    kind,
                    pos,
                })
                .collect(),
        };
        client.publish(&debug::encode(&intentions)?)?;
    }
    Ok(())
}
