//! One robot's agent as its own process, as the paper deploys MURDOCH: "the
//! same program on every machine", each with its own resources. Its body is
//! either abstract (a task takes its announced length where the robot is) or
//! one robot of a world that publishes `vision` and takes `radio` commands,
//! such as `colony tasks room`: then the robot sees where it is (its bids'
//! `distance` is real), drives to a task's `x`, `y` (steering round the other
//! robots it sees) before the task's length starts, and stops when it ends.
//! Either way each task costs some battery and charging takes a while (where
//! the robot stands). Resources can fail and be repaired at given times, as a
//! sensor would.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_node::{Link, LiveError};
use colony_proto::radio::{self, RadioCommand};
use colony_proto::swarm::{vision, VisionAssembler, VISION};
use colony_proto::{wrap_angle, Pose, Vec2, WheelCommand};
use colony_wire::auth::Key;
use colony_wire::{Priority, Request};

use crate::agent::{Agent, AgentConfig, AgentEvent, StopReason};
use crate::protocol::{ResourceSet, Token};

/// A change to the robot's resources at a time after it starts.
#[derive(Debug, Clone, PartialEq)]
pub struct Fault {
    /// Seconds after the start.
    pub at: Duration,
    /// The resource.
    pub resource: String,
    /// `true`: it fails; `false`: it is repaired.
    pub fails: bool,
}

/// How one robot runs.
#[derive(Debug, Clone)]
pub struct RobotConfig {
    /// The robot's name (its bids carry it).
    pub name: Token,
    /// What it has at the start.
    pub resources: ResourceSet,
    /// Its battery at the start, 0 to 1.
    pub battery: f64,
    /// Battery each task costs.
    pub drain_per_task: f64,
    /// How long charging takes.
    pub charge_for: Duration,
    /// Resources failing and repaired as it runs.
    pub faults: Vec<Fault>,
    /// The body it drives: this robot of the world on `vision` and `radio`
    /// (`None`: an abstract body).
    pub body: Option<u32>,
    /// The agent's timings.
    pub agent: AgentConfig,
    /// The hub's shared key, for a hub that asks every packet to be signed
    /// (`--auth-all`).
    pub key: Option<Key>,
}

impl RobotConfig {
    /// A robot with these resources, full, costing 10 % a task, charging in 3 s.
    pub fn new(name: Token, resources: ResourceSet) -> RobotConfig {
        RobotConfig {
            name,
            resources,
            battery: 1.0,
            drain_per_task: 0.1,
            charge_for: Duration::from_secs(3),
            faults: Vec::new(),
            body: None,
            key: None,
            agent: AgentConfig::default(),
        }
    }
}

/// What a robot did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RobotSummary {
    /// Tasks started.
    pub started: u64,
    /// Tasks finished.
    pub finished: u64,
    /// Tasks stopped before the end (cancelled, announcer gone, resource lost).
    pub stopped: u64,
    /// Trips to the charger.
    pub charges: u64,
}

/// A body is at a task's place within this, cm: a Pioneer's width and a
/// little, so a robot already standing there does not keep it away.
pub const REACH: f64 = 50.0;
/// A body that has not come this much closer in [`NO_HEADWAY`] works from
/// where it is (a robot at work on the very spot, a wall), cm...
const HEADWAY: f64 = 20.0;
/// ...see [`HEADWAY`].
const NO_HEADWAY: Duration = Duration::from_secs(30);
/// A body that cannot see itself on `vision` this long after it took a task
/// gives the task up, so the announcer can give it to another.
const BLIND_AFTER: Duration = Duration::from_secs(5);
/// Other robots closer than this push the driving robot's heading away, cm.
const KEEP_CLEAR: f64 = 100.0;

/// A body driven over the hub: what the robot sees of itself and the others
/// on `vision`, and where it is going.
struct Driver {
    id: u32,
    eyes: UdpClient,
    assembler: VisionAssembler,
    pose: Option<Pose>,
    others: Vec<Vec2>,
    /// Where the current task is, and how long it lasts once there.
    goal: Option<(Vec2, Duration)>,
    /// When it set off, and the closest it has been since it last came
    /// [`HEADWAY`] closer (and when).
    set_off: Instant,
    best: (f64, Instant),
    /// A frame came since the last command.
    fresh: bool,
}

impl Driver {
    fn new(hub: SocketAddr, id: u32, key: Option<&Key>) -> Result<Driver, LiveError> {
        let mut eyes = connect(hub, key)?;
        eyes.subscribe(VISION)?;
        Ok(Driver {
            id,
            eyes,
            assembler: VisionAssembler::new(),
            pose: None,
            others: Vec::new(),
            goal: None,
            set_off: Instant::now(),
            best: (f64::INFINITY, Instant::now()),
            fresh: false,
        })
    }

    /// Takes in what came on `vision`.
    fn look(&mut self, now: Instant) -> Result<(), LiveError> {
        self.eyes.poll(now)?;
        while let Some(packet) = self.eyes.recv()? {
            let Ok(part) = vision::decode(&packet) else {
                continue;
            };
            if let Some(frame) = self.assembler.offer(part) {
                self.pose = frame
                    .robots
                    .iter()
                    .find(|r| r.id == self.id)
                    .map(|r| r.pose);
                self.others = frame
                    .robots
                    .iter()
                    .filter(|r| r.id != self.id)
                    .map(|r| r.pose.position())
                    .collect();
                self.fresh = true;
            }
        }
        Ok(())
    }

    /// Sets off for `goal`, to work there for `length`.
    fn set_off(&mut self, goal: Vec2, length: Duration, now: Instant) {
        self.goal = Some((goal, length));
        self.set_off = now;
        self.best = (f64::INFINITY, now);
    }

    /// Where it stands with its goal, and with a new frame, the next wheel
    /// command towards it.
    fn drive(&mut self, now: Instant) -> Result<Trip, LiveError> {
        let Some((goal, _)) = self.goal else {
            return Ok(Trip::None);
        };
        let Some(me) = self.pose else {
            if now.duration_since(self.set_off) >= BLIND_AFTER {
                return Ok(Trip::Blind);
            }
            return Ok(Trip::Driving);
        };
        let d = me.position().distance(goal);
        if d + HEADWAY <= self.best.0 {
            self.best = (d, now);
        }
        if d <= REACH {
            self.send(WheelCommand::STOP)?;
            return Ok(Trip::There);
        }
        if now.duration_since(self.best.1) >= NO_HEADWAY {
            self.send(WheelCommand::STOP)?;
            return Ok(Trip::AsCloseAsItGets(d));
        }
        if std::mem::take(&mut self.fresh) {
            self.send(steer(me, goal, &self.others))?;
        }
        Ok(Trip::Driving)
    }

    fn send(&mut self, wheels: WheelCommand) -> Result<(), LiveError> {
        let cmd = RadioCommand::new(self.id, wheels.forward, wheels.turn);
        if let Ok(p) = radio::encode(&[cmd], Priority(0)) {
            self.eyes.publish(&p)?;
        }
        Ok(())
    }
}

/// How a body's trip to its task's place stands.
enum Trip {
    /// No trip.
    None,
    /// On its way.
    Driving,
    /// Within [`REACH`].
    There,
    /// No headway for [`NO_HEADWAY`]: this far from the place, cm.
    AsCloseAsItGets(f64),
    /// It has not seen itself on `vision` since it took the task.
    Blind,
}

/// Towards `goal`, the heading pushed away from robots closer than
/// [`KEEP_CLEAR`] (and to the right of one straight ahead, so two robots
/// meeting head-on pass each other).
fn steer(me: Pose, goal: Vec2, others: &[Vec2]) -> WheelCommand {
    let to = goal - me.position();
    let d = to.length().max(1e-6);
    let mut dir = to * (1.0 / d);
    for o in others {
        let away = me.position() - *o;
        let dist = away.length();
        if dist > 1e-6 && dist < KEEP_CLEAR {
            let push = 1.5 * (1.0 - dist / KEEP_CLEAR);
            let right = Vec2::new(dir.y, -dir.x);
            dir = dir + away * (push / dist) + right * (0.5 * push);
        }
    }
    let e = wrap_angle(dir.angle() - me.theta);
    let speed = (d / 60.0 + 0.2).min(1.0);
    WheelCommand::clamped(if e.abs() < 0.6 { speed * e.cos() } else { 0.0 }, 2.0 * e)
}

/// Runs the robot against the hub at `hub` until `stop` is set, passing each
/// line of its report to `say`.
pub fn run(
    hub: SocketAddr,
    config: RobotConfig,
    stop: &AtomicBool,
    mut say: impl FnMut(&str),
) -> Result<RobotSummary, LiveError> {
    let epoch = Instant::now();
    let mut link = Link::new(connect(hub, config.key.as_ref())?, epoch);
    let mut agent = Agent::new(
        config.name.clone(),
        config.resources.clone(),
        config.agent.clone(),
        link.now(),
    );
    agent.set_battery(config.battery);
    // The hub's status report says which client is which robot, and what it has.
    let about =
        |agent: &Agent| Request::About(format!("agent {} {}", agent.id(), agent.resources()));
    link.client_mut().set_standing(vec![about(&agent)])?;
    let mut faults = config.faults.clone();
    faults.sort_by_key(|f| f.at);
    let mut faults = faults.into_iter().peekable();
    let mut busy_until: Option<Instant> = None;
    let mut charging_until: Option<Instant> = None;
    let mut summary = RobotSummary::default();
    let mut driver = config
        .body
        .map(|id| Driver::new(hub, id, config.key.as_ref()))
        .transpose()?;
    let stamp = |now: Instant| format!("{:7.2}", now.duration_since(epoch).as_secs_f64());
    say(&format!(
        "{} {} joins with {} (battery {:.2})",
        stamp(epoch),
        config.name,
        agent.resources(),
        agent.battery()
    ));
    while !stop.load(Ordering::Relaxed) {
        // Woken for the body's own times too: a task's end, a charge, a fault.
        let now_i = Instant::now();
        let body_due = [
            busy_until,
            charging_until,
            faults.peek().map(|f| epoch + f.at),
        ]
        .into_iter()
        .flatten()
        .map(|t| t.saturating_duration_since(now_i))
        .min();
        // A body is steered at the pace its world sends frames (10 a second for a room).
        let tick = Duration::from_millis(if driver.is_some() { 20 } else { 50 });
        let wait = body_due.map_or(tick, |d| d.min(tick));
        link.wait(&agent, Some(wait))?;
        link.pump(&mut agent)?;
        let now_i = Instant::now();
        let now = link.now();
        if let Some(d) = driver.as_mut() {
            let seen = d.pose.is_some();
            d.look(now_i)?;
            if let Some(pose) = d.pose {
                if !seen {
                    say(&format!(
                        "{} sees itself at ({:.0}, {:.0}) on vision",
                        stamp(now_i),
                        pose.x,
                        pose.y
                    ));
                }
                agent.set_position(pose.position());
                agent.set_heading(pose.theta);
            }
            let trip = d.drive(now_i)?;
            let at = d.goal.map(|(at, _)| at);
            match (trip, d.goal) {
                (Trip::There, Some((at, length))) => {
                    d.goal = None;
                    busy_until = Some(now_i + length);
                    say(&format!(
                        "{} at ({:.0}, {:.0}): starts work",
                        stamp(now_i),
                        at.x,
                        at.y
                    ));
                }
                (Trip::AsCloseAsItGets(off), Some((_, length))) => {
                    d.goal = None;
                    busy_until = Some(now_i + length);
                    say(&format!(
                        "{} gets no closer to ({:.0}, {:.0}) than {off:.0} cm: starts work here",
                        stamp(now_i),
                        at.map_or(0.0, |a| a.x),
                        at.map_or(0.0, |a| a.y),
                    ));
                }
                (Trip::Blind, Some(_)) => {
                    d.goal = None;
                    if let Some(task) = agent.abandon(now, "cannot see itself on vision") {
                        summary.stopped += 1;
                        say(&format!(
                            "{} gives task #{task} up: body {} is not on vision",
                            stamp(now_i),
                            d.id
                        ));
                    }
                }
                _ => {}
            }
        }
        while let Some(fault) = faults.next_if(|f| epoch + f.at <= now_i) {
            let mut names: Vec<String> = agent.resources().iter().map(|s| s.to_string()).collect();
            if fault.fails {
                names.retain(|n| *n != fault.resource);
            } else if !names.contains(&fault.resource) {
                names.push(fault.resource.clone());
            }
            let resources: ResourceSet = names.join(",").parse().unwrap_or_default();
            let verb = if fault.fails { "fails" } else { "is repaired" };
            say(&format!(
                "{} {} {}: now {}",
                stamp(now_i),
                fault.resource,
                verb,
                resources
            ));
            if agent.set_resources(now, resources).is_some() {
                busy_until = None;
                if let Some(d) = driver.as_mut() {
                    d.goal = None;
                    d.send(WheelCommand::STOP)?;
                }
            }
            link.client_mut().set_standing(vec![about(&agent)])?;
        }
        while let Some(event) = agent.poll_event() {
            match event {
                AgentEvent::Start(ann) => {
                    summary.started += 1;
                    let length = Duration::try_from_secs_f64(ann.spec.length_s).unwrap_or_default();
                    let place = ann.spec.number("x").zip(ann.spec.number("y"));
                    match (driver.as_mut(), place) {
                        (Some(d), Some((x, y))) => d.set_off(Vec2::new(x, y), length, now_i),
                        _ => busy_until = Some(now_i + length),
                    }
                    let whither = match (&driver, place) {
                        (Some(_), Some((x, y))) => format!(", driving to ({x:.0}, {y:.0}) first"),
                        _ => String::new(),
                    };
                    say(&format!(
                        "{} starts task #{} {} for {:.1} s (from {}){whither}",
                        stamp(now_i),
                        ann.id,
                        ann.spec.name,
                        ann.spec.length_s,
                        ann.announcer
                    ));
                }
                AgentEvent::Stop { task, name, reason } => {
                    summary.stopped += 1;
                    busy_until = None;
                    if let Some(d) = driver.as_mut() {
                        d.goal = None;
                        d.send(WheelCommand::STOP)?;
                    }
                    let why = match reason {
                        StopReason::Cancelled(r) => format!("cancelled: {r}"),
                        StopReason::AnnouncerSilent => "its announcer fell silent".to_owned(),
                        StopReason::LostResource(r) => format!("lost {r}; re-auctioned"),
                    };
                    say(&format!(
                        "{} stops task #{task} {name}: {why}",
                        stamp(now_i)
                    ));
                }
                AgentEvent::Charge => {
                    summary.charges += 1;
                    charging_until = Some(now_i + config.charge_for);
                    say(&format!(
                        "{} battery {:.2}: leaves every channel to charge",
                        stamp(now_i),
                        agent.battery()
                    ));
                }
                AgentEvent::Rejoined => say(&format!("{} charged: listens again", stamp(now_i))),
                _ => {}
            }
        }
        if busy_until.is_some_and(|t| t <= now_i) {
            busy_until = None;
            agent.set_battery(agent.battery() - config.drain_per_task);
            if let Some(task) = agent.finish(now) {
                summary.finished += 1;
                say(&format!("{} done with task #{task}", stamp(now_i)));
            }
        }
        if charging_until.is_some_and(|t| t <= now_i) {
            charging_until = None;
            agent.set_battery(1.0);
            agent.charged(now);
        }
        link.flush(&mut agent)?;
    }
    Ok(summary)
}

/// A client of the hub at `hub`, signing with `key` when there is one.
pub(crate) fn connect(
    hub: SocketAddr,
    key: Option<&Key>,
) -> Result<UdpClient, colony_client::ClientError> {
    let mut client = UdpClient::connect(hub)?;
    if let Some(key) = key {
        client.set_key(key.clone());
    }
    Ok(client)
}
