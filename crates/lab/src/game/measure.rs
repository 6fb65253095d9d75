//! The paper's Tables 3 and 4 measured on a live match over the real hub: a scripted player
//! sends squad commands, the server turns them into robot orders, the robots take them, every
//! part on its own hub client and thread, in real time. The server and the robots record when
//! each command and order came and went ([`colony_game::server::CommandTiming`],
//! [`colony_game::robot_node::OrderTiming`]) on one shared clock, so each hop is measured on
//! its own:
//!
//! | hop | from | to |
//! |---|---|---|
//! | player → swarm intelligence | the player sends | the server takes it |
//! | swarm intelligence | the server takes it | the squad's orders leave (the batching wait included) |
//! | swarm intelligence → robot squad | the orders leave | the last robot of the squad has its order |
//! | robot intelligence | a robot has its order | its brain first acts on it (its next sensor reading) |
//!
//! Table 3 is the paper's Capture the Flag command (a squad of three takes the enemy flag);
//! Table 4 a squad of three in line formation sent a GoTo at fixed intervals.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_game::live::{self, LiveError};
use colony_game::protocol::{Formation, SquadCommand, Verb};
use colony_game::robot_node::RobotNode;
use colony_game::server::{Server, THINK_EVERY};
use colony_game::world::GameWorld;
use colony_node::Time;
use colony_sim::field::FieldConfig;
use colony_sim::Vec2;

use crate::game::live_match::{LiveMatchError, MatchPlan};

/// Mean, standard deviation and range of some durations, ms.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Stats {
    /// How many.
    pub n: usize,
    /// Mean, ms.
    pub mean: f64,
    /// Sample standard deviation, ms.
    pub sd: f64,
    /// Smallest, ms.
    pub min: f64,
    /// Largest, ms.
    pub max: f64,
}

impl Stats {
    /// Of these values, ms; all zero when there are none.
    pub fn of(values: &[f64]) -> Stats {
        let n = values.len();
        if n == 0 {
            return Stats::default();
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let var = if n > 1 {
            values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64
        } else {
            0.0
        };
        Stats {
            n,
            mean,
            sd: var.sqrt(),
            min: values.iter().copied().fold(f64::INFINITY, f64::min),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

/// One command's way through the parts, ms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Player to server.
    pub to_server: f64,
    /// In the server: its batching wait and the squad's arbitration.
    pub server: f64,
    /// Of which the squad's arbitration computed.
    pub compute: f64,
    /// Server to the last robot of the squad.
    pub to_robots: f64,
    /// The slowest robot's brain, from its order to acting on it.
    pub robot: f64,
    /// Player to the last robot.
    pub end_to_end: f64,
}

/// The samples of one series of commands, and how many could not be followed to the robots.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// One for each command followed all the way.
    pub samples: Vec<Sample>,
    /// Commands sent.
    pub sent: usize,
}

impl Series {
    /// Commands that were sent and not followed to every robot (lost, or superseded by a newer
    /// one before the server's next think, so their orders never left).
    pub fn lost(&self) -> usize {
        self.sent - self.samples.len()
    }

    /// The statistics of one hop.
    pub fn stats(&self, hop: impl Fn(&Sample) -> f64) -> Stats {
        Stats::of(&self.samples.iter().map(hop).collect::<Vec<_>>())
    }
}

/// What one series sends, to red's squad `alpha`.
#[derive(Debug, Clone)]
pub struct SeriesSpec {
    /// The server's batching wait, in world frames (0.1 s each).
    pub think_every: u64,
    /// The gap between commands.
    pub interval: Duration,
    /// How many commands.
    pub commands: usize,
    /// Capture blue's flag (Table 3); otherwise a GoTo in line formation (Table 4).
    pub capture: bool,
    /// Spread the commands evenly over the server's think period (a player's clicks are not in
    /// step with the world's frames); otherwise exactly `interval` apart, as the paper's Table 4.
    pub spread: bool,
}

/// Why a measurement could not be made.
#[derive(Debug, thiserror::Error)]
pub enum MeasureError {
    /// The match could not be set up or started.
    #[error(transparent)]
    Match(#[from] LiveMatchError),
    /// A part failed.
    #[error(transparent)]
    Live(#[from] LiveError),
    /// The player's hub client failed.
    #[error("the measuring player's hub client: {0}")]
    Client(#[from] colony_client::ClientError),
    /// A part's thread ended with a panic.
    #[error("a part of the match panicked")]
    Panicked,
}

/// Time since `epoch` on the parts' shared clock.
fn since(epoch: Instant) -> Time {
    Time::from_micros(epoch.elapsed().as_micros() as u64)
}

fn ms(later: Time, earlier: Time) -> f64 {
    (later - earlier).as_secs_f64() * 1000.0
}

/// Runs one series on a fresh live match over the hub at `hub`: world, server and the squad's
/// robots as threads with hub clients of their own, the player here.
pub fn run_series(plan: &MatchPlan, hub: &str, spec: &SeriesSpec) -> Result<Series, MeasureError> {
    let epoch = Instant::now();
    let stop = Arc::new(AtomicBool::new(false));
    let connect = || UdpClient::connect_to(hub).map_err(LiveMatchError::from);

    let mut world = GameWorld::new(&plan.field, &plan.roster).map_err(LiveMatchError::from)?;
    let step = FieldConfig::default().control_step;
    let world_part: JoinHandle<Result<(), LiveError>> = {
        let (mut client, stop) = (connect()?, stop.clone());
        std::thread::spawn(move || live::run_world(&mut world, &mut client, step, 1.0, None, &stop))
    };
    let server_part: JoinHandle<Result<Server, LiveError>> = {
        let mut server = Server::new(plan.field.clone(), plan.rules.clone(), plan.roster.clone())
            .with_think_every(spec.think_every);
        let (mut client, stop) = (connect()?, stop.clone());
        std::thread::spawn(move || {
            live::run_node_since(&mut server, &mut client, epoch, &stop).map(|()| server)
        })
    };
    let squad: Vec<u32> = plan
        .roster
        .iter()
        .filter(|e| e.team == "red" && e.squad == "alpha")
        .map(|e| e.id)
        .collect();
    let mut robot_parts: Vec<JoinHandle<Result<RobotNode, LiveError>>> = Vec::new();
    for e in plan.roster.iter().filter(|e| squad.contains(&e.id)) {
        let mut node = RobotNode::new(e.id, e.build.kind);
        let (mut client, stop) = (connect()?, stop.clone());
        robot_parts.push(std::thread::spawn(move || {
            live::run_node_since(&mut node, &mut client, epoch, &stop).map(|()| node)
        }));
    }

    let mut player = UdpClient::connect_to(hub).map_err(LiveMatchError::from)?;
    // The world's first frames reach the server, and every client has registered.
    std::thread::sleep(Duration::from_secs(2));
    let goal = |k: usize| {
        // Each command names its own point, so the server's record of it is told apart.
        let side = if k % 2 == 0 { 0.0 } else { 1.0 };
        Vec2::new(
            300.0 + 500.0 * side + (k % 50) as f64,
            150.0 + (k % 7) as f64,
        )
    };
    let mut sent = Vec::new();
    let mut next = Instant::now();
    let period = Duration::from_millis(100 * spec.think_every);
    for k in 0..spec.commands {
        // With `spread`, command k lands (k * 7 mod 20) twentieths into the think period.
        let offset = if spec.spread {
            period.mul_f64(((k * 7) % 20) as f64 / 20.0)
        } else {
            Duration::ZERO
        };
        std::thread::sleep((next + offset).saturating_duration_since(Instant::now()));
        next += spec.interval;
        let verb = if spec.capture {
            Verb::Capture("blue".into())
        } else {
            Verb::GoTo(goal(k))
        };
        let command = SquadCommand {
            team: "red".into(),
            squad: "alpha".into(),
            verb: verb.clone(),
            formation: Some(if spec.capture {
                Formation::Wedge
            } else {
                Formation::Line
            }),
        };
        let Ok(bytes) = command.encode() else {
            continue;
        };
        let at = since(epoch);
        player.publish(&bytes)?;
        sent.push((verb.to_string(), at));
    }
    // The last orders reach the robots and their next sensor reading comes.
    std::thread::sleep(Duration::from_secs(2));
    stop.store(true, Ordering::Relaxed);

    let join = |h: JoinHandle<Result<(), LiveError>>| h.join().map_err(|_| MeasureError::Panicked);
    join(world_part)??;
    let server = server_part.join().map_err(|_| MeasureError::Panicked)??;
    let mut robots = Vec::new();
    for h in robot_parts {
        robots.push(h.join().map_err(|_| MeasureError::Panicked)??);
    }

    let mut series = Series {
        samples: Vec::new(),
        sent: sent.len(),
    };
    for (k, (text, at)) in sent.iter().enumerate() {
        // Its record came after it was sent and before the next command was: a command lost on
        // the way is not mistaken for the one after it.
        let before = sent.get(k + 1).map(|n| n.1);
        let found = server.timings().find(|t| {
            t.squad == "alpha"
                && &t.order == text
                && t.received >= *at
                && before.is_none_or(|b| t.received < b)
        });
        let Some(t) = found else { continue };
        let mut to_robots: f64 = 0.0;
        let mut robot: f64 = 0.0;
        let mut complete = !t.orders.is_empty();
        for &(id, seq) in &t.orders {
            let got = robots
                .iter()
                .find(|r| r.id() == id)
                .and_then(|r| r.timings().find(|o| o.seq == seq).copied());
            match got {
                Some(o) => {
                    to_robots = to_robots.max(ms(o.received, t.answered));
                    if let Some(acted) = o.acted {
                        robot = robot.max(ms(acted, o.received));
                    }
                }
                None => complete = false,
            }
        }
        if !complete {
            continue;
        }
        series.samples.push(Sample {
            to_server: ms(t.received, *at),
            server: ms(t.answered, t.received),
            compute: t.compute.as_secs_f64() * 1000.0,
            to_robots,
            robot,
            end_to_end: ms(t.answered, *at) + to_robots,
        });
    }
    Ok(series)
}

/// The server's batching wait of the paper, 300 ms, in world frames.
pub const PAPER_THINK_EVERY: u64 = 3;
/// Ours.
pub const OUR_THINK_EVERY: u64 = THINK_EVERY;
