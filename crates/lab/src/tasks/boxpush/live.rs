//! A box-pushing run watched live: paced to the wall clock, it publishes the
//! field on `vision` (the robots, the box and the goal, for the monitor to
//! draw) and every MURDOCH message of the run on the hub, so the monitor's
//! task board shows the pushing auctions as they happen.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_proto::swarm::{vision, Arena, Sizes, VisionBox, VisionFrame, VisionRobot};
use colony_proto::Pose;

use super::control::{BOX, PUSHER};
use super::{BoxPush, BoxPushConfig, BoxPushError, BoxPushOutcome};
use crate::tasks::Progress;

/// The field is drawn at most this often (wall time).
const FRAME_EVERY: Duration = Duration::from_millis(100);

/// Why a live run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum LiveBoxPushError {
    /// The run itself could not go on.
    #[error(transparent)]
    Run(#[from] BoxPushError),
    /// The hub client could not be made.
    #[error(transparent)]
    Client(#[from] colony_client::ClientError),
}

impl BoxPush {
    /// The field as the overhead view draws it: vision's arena is centred on
    /// the origin, so every position is shifted by half the field.
    pub fn vision_frame(&self) -> VisionFrame {
        let size = self.field.map().size_cm();
        let pose = |p: Pose| self.field.centred(p);
        let robots = self
            .pushers
            .iter()
            .map(|p| p.robot)
            .chain([self.watcher_robot])
            .filter_map(|r| {
                self.field.robot_pose(r).map(|p| VisionRobot {
                    id: r.0 as u32,
                    pose: pose(p),
                    carrying: None,
                })
            })
            .collect();
        VisionFrame {
            step: self.step,
            arena: Some(Arena {
                width: size.x,
                height: size.y,
                corner: 0.0,
            }),
            sizes: Some(Sizes {
                robot_length: 2.0 * PUSHER.radius,
                robot_width: 2.0 * PUSHER.radius,
                gripper_radius: 2.0,
                puck_diameter: 4.0,
            }),
            robots,
            pucks: Vec::new(),
            boxes: vec![VisionBox {
                id: 0,
                pose: pose(self.box_pose()),
                length: 2.0 * BOX.half_length,
                width: 2.0 * BOX.half_width,
            }],
            goal: Some(
                pose(Pose {
                    x: self.goal.x,
                    y: self.goal.y,
                    theta: 0.0,
                })
                .position(),
            ),
        }
    }
}

/// Runs `cfg` against the hub at `hub`, `speed` times faster than real time,
/// until the run ends or `stop` is set; each of the run's events goes to `say`
/// as it happens.
pub fn run_live(
    hub: SocketAddr,
    cfg: &BoxPushConfig,
    speed: f64,
    stop: &AtomicBool,
    mut say: impl FnMut(f64, &str),
) -> Result<BoxPushOutcome, LiveBoxPushError> {
    let mut client = UdpClient::connect(hub)?;
    let mut run = BoxPush::new(cfg)?;
    run.bus.record();
    let speed = if speed.is_finite() && speed > 0.0 {
        speed
    } else {
        1.0
    };
    let start = Instant::now();
    let mut next_frame = start;
    let mut told = 0;
    while !stop.load(Ordering::Relaxed) {
        let progress = run.step()?;
        for (_, packet) in run.bus.take_recorded() {
            if let Err(e) = client.publish(&packet) {
                tracing::debug!(error = %e, "cannot publish a MURDOCH message");
            }
        }
        for (t, e) in &run.events()[told..] {
            say(*t, e);
        }
        told = run.events().len();
        let now = Instant::now();
        if now >= next_frame || progress == Progress::Done {
            next_frame = now + FRAME_EVERY;
            publish_frame(&mut client, &run.vision_frame());
        }
        if progress == Progress::Done {
            break;
        }
        // Paced: simulated time runs `speed` times the wall clock's.
        let due = start + Duration::from_secs_f64(run.now_s() / speed);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        let _ = client.poll(Instant::now());
    }
    Ok(run.finish())
}

fn publish_frame(client: &mut UdpClient, frame: &VisionFrame) {
    match vision::encode(frame) {
        Ok(parts) => {
            for p in parts {
                if let Err(e) = client.publish(&p) {
                    tracing::debug!(error = %e, "cannot publish the field");
                }
            }
        }
        Err(e) => tracing::warn!(error = %e, "cannot write the field"),
    }
}
