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
use colony_node::{Link, LiveError, Time};
use colony_proto::radio::{self, RadioCommand};
use colony_proto::swarm::{vision, VisionAssembler, VISION};
use colony_proto::{wrap_angle, Pose, Speed, Steer, Vec2, WheelCommand};
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

/// A live robot's gains.
const DRIVE: Steer = Steer {
    turn_gain: 2.0,
    align: 0.6,
    speed: Speed::Ramp {
        over_cm: 60.0,
        base: 0.2,
        min: 0.2,
    },
};

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
    DRIVE.wheels(e, DRIVE.speed.at(d))
}

/// Runs the robot against the hub at `hub` until `stop` is set, passing each
/// line of its report to `say`.
pub fn run(
    hub: SocketAddr,
    config: RobotConfig,
    stop: &AtomicBool,
    mut say: impl FnMut(&str),
) -> Result<RobotSummary, LiveError> {
    let mut robot = Robot::join(hub, &config, &mut say)?;
    while !stop.load(Ordering::Relaxed) {
        robot.wait()?;
        let now_i = Instant::now();
        let now = robot.link.now();
        robot.follow_body(now_i, now, &mut say)?;
        robot.apply_faults(now_i, now, &mut say)?;
        robot.act_on_events(now_i, &mut say)?;
        robot.end_work_and_charge(now_i, now, &mut say);
        robot.link.flush(&mut robot.agent)?;
    }
    Ok(robot.summary)
}

/// A running robot: its agent and link, its body, and the times its body keeps (a task's
/// end, a charge, the next fault).
struct Robot<'c> {
    config: &'c RobotConfig,
    epoch: Instant,
    link: Link,
    agent: Agent,
    faults: std::iter::Peekable<std::vec::IntoIter<Fault>>,
    busy_until: Option<Instant>,
    charging_until: Option<Instant>,
    summary: RobotSummary,
    driver: Option<Driver>,
}

/// What the hub's status report says of a robot: which client it is, and what it has.
fn about(agent: &Agent) -> Request {
    Request::About(format!("agent {} {}", agent.id(), agent.resources()))
}

impl<'c> Robot<'c> {
    /// Connects the robot (and its body's eyes) to the hub and says so.
    fn join(
        hub: SocketAddr,
        config: &'c RobotConfig,
        say: &mut impl FnMut(&str),
    ) -> Result<Robot<'c>, LiveError> {
        let epoch = Instant::now();
        let mut link = Link::new(connect(hub, config.key.as_ref())?, epoch);
        let mut agent = Agent::new(
            config.name.clone(),
            config.resources.clone(),
            config.agent.clone(),
            link.now(),
        );
        agent.set_battery(config.battery);
        link.client_mut().set_standing(vec![about(&agent)])?;
        let mut faults = config.faults.clone();
        faults.sort_by_key(|f| f.at);
        let driver = config
            .body
            .map(|id| Driver::new(hub, id, config.key.as_ref()))
            .transpose()?;
        let robot = Robot {
            config,
            epoch,
            link,
            agent,
            faults: faults.into_iter().peekable(),
            busy_until: None,
            charging_until: None,
            summary: RobotSummary::default(),
            driver,
        };
        say(&format!(
            "{} {} joins with {} (battery {:.2})",
            robot.stamp(epoch),
            config.name,
            robot.agent.resources(),
            robot.agent.battery()
        ));
        Ok(robot)
    }

    /// `now` as the report writes it: seconds since the robot started.
    fn stamp(&self, now: Instant) -> String {
        format!("{:7.2}", now.duration_since(self.epoch).as_secs_f64())
    }

    /// Waits for the hub, or for the body's own next time, and takes in what came.
    fn wait(&mut self) -> Result<(), LiveError> {
        let now_i = Instant::now();
        let body_due = [
            self.busy_until,
            self.charging_until,
            self.faults.peek().map(|f| self.epoch + f.at),
        ]
        .into_iter()
        .flatten()
        .map(|t| t.saturating_duration_since(now_i))
        .min();
        // A body is steered at the pace its world sends frames (10 a second for a room).
        let tick = Duration::from_millis(if self.driver.is_some() { 20 } else { 50 });
        let wait = body_due.map_or(tick, |d| d.min(tick));
        self.link.wait(&self.agent, Some(wait))?;
        self.link.pump(&mut self.agent)
    }

    /// Looks at `vision`, tells the agent where the body is, and drives it on its trip; a
    /// trip's end starts the task's work, or gives the task up when the body cannot see itself.
    fn follow_body(
        &mut self,
        now_i: Instant,
        now: Time,
        say: &mut impl FnMut(&str),
    ) -> Result<(), LiveError> {
        let stamp = self.stamp(now_i);
        let Some(d) = self.driver.as_mut() else {
            return Ok(());
        };
        let seen = d.pose.is_some();
        d.look(now_i)?;
        if let Some(pose) = d.pose {
            if !seen {
                say(&format!(
                    "{stamp} sees itself at ({:.0}, {:.0}) on vision",
                    pose.x, pose.y
                ));
            }
            self.agent.set_position(pose.position());
            self.agent.set_heading(pose.theta);
        }
        let trip = d.drive(now_i)?;
        let at = d.goal.map(|(at, _)| at);
        match (trip, d.goal) {
            (Trip::There, Some((at, length))) => {
                d.goal = None;
                self.busy_until = Some(now_i + length);
                say(&format!(
                    "{stamp} at ({:.0}, {:.0}): starts work",
                    at.x, at.y
                ));
            }
            (Trip::AsCloseAsItGets(off), Some((_, length))) => {
                d.goal = None;
                self.busy_until = Some(now_i + length);
                say(&format!(
                    "{stamp} gets no closer to ({:.0}, {:.0}) than {off:.0} cm: starts work here",
                    at.map_or(0.0, |a| a.x),
                    at.map_or(0.0, |a| a.y),
                ));
            }
            (Trip::Blind, Some(_)) => {
                d.goal = None;
                if let Some(task) = self.agent.abandon(now, "cannot see itself on vision") {
                    self.summary.stopped += 1;
                    say(&format!(
                        "{stamp} gives task #{task} up: body {} is not on vision",
                        d.id
                    ));
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// Fails or repairs the resources whose time has come; a task that needed a lost one
    /// stops, and the hub is told what the robot now has.
    fn apply_faults(
        &mut self,
        now_i: Instant,
        now: Time,
        say: &mut impl FnMut(&str),
    ) -> Result<(), LiveError> {
        let epoch = self.epoch;
        while let Some(fault) = self.faults.next_if(|f| epoch + f.at <= now_i) {
            let mut names: Vec<String> = self
                .agent
                .resources()
                .iter()
                .map(|s| s.to_string())
                .collect();
            if fault.fails {
                names.retain(|n| *n != fault.resource);
            } else if !names.contains(&fault.resource) {
                names.push(fault.resource.clone());
            }
            let resources: ResourceSet = names.join(",").parse().unwrap_or_default();
            let verb = if fault.fails { "fails" } else { "is repaired" };
            say(&format!(
                "{} {} {}: now {}",
                self.stamp(now_i),
                fault.resource,
                verb,
                resources
            ));
            if self.agent.set_resources(now, resources).is_some() {
                self.busy_until = None;
                if let Some(d) = self.driver.as_mut() {
                    d.goal = None;
                    d.send(WheelCommand::STOP)?;
                }
            }
            self.link
                .client_mut()
                .set_standing(vec![about(&self.agent)])?;
        }
        Ok(())
    }

    /// Starts and stops tasks and charges as the agent says.
    fn act_on_events(
        &mut self,
        now_i: Instant,
        say: &mut impl FnMut(&str),
    ) -> Result<(), LiveError> {
        while let Some(event) = self.agent.poll_event() {
            let stamp = self.stamp(now_i);
            match event {
                AgentEvent::Start(ann) => {
                    self.summary.started += 1;
                    let length = Duration::try_from_secs_f64(ann.spec.length_s).unwrap_or_default();
                    let place = ann.spec.number("x").zip(ann.spec.number("y"));
                    match (self.driver.as_mut(), place) {
                        (Some(d), Some((x, y))) => d.set_off(Vec2::new(x, y), length, now_i),
                        _ => self.busy_until = Some(now_i + length),
                    }
                    let whither = match (&self.driver, place) {
                        (Some(_), Some((x, y))) => format!(", driving to ({x:.0}, {y:.0}) first"),
                        _ => String::new(),
                    };
                    say(&format!(
                        "{stamp} starts task #{} {} for {:.1} s (from {}){whither}",
                        ann.id, ann.spec.name, ann.spec.length_s, ann.announcer
                    ));
                }
                AgentEvent::Stop { task, name, reason } => {
                    self.summary.stopped += 1;
                    self.busy_until = None;
                    if let Some(d) = self.driver.as_mut() {
                        d.goal = None;
                        d.send(WheelCommand::STOP)?;
                    }
                    let why = match reason {
                        StopReason::Cancelled(r) => format!("cancelled: {r}"),
                        StopReason::AnnouncerSilent => "its announcer fell silent".to_owned(),
                        StopReason::LostResource(r) => format!("lost {r}; re-auctioned"),
                    };
                    say(&format!("{stamp} stops task #{task} {name}: {why}"));
                }
                AgentEvent::Charge => {
                    self.summary.charges += 1;
                    self.charging_until = Some(now_i + self.config.charge_for);
                    say(&format!(
                        "{stamp} battery {:.2}: leaves every channel to charge",
                        self.agent.battery()
                    ));
                }
                AgentEvent::Rejoined => say(&format!("{stamp} charged: listens again")),
                _ => {}
            }
        }
        Ok(())
    }

    /// Finishes the task whose work is done (at a battery's cost) and the charge that is over.
    fn end_work_and_charge(&mut self, now_i: Instant, now: Time, say: &mut impl FnMut(&str)) {
        if self.busy_until.is_some_and(|t| t <= now_i) {
            self.busy_until = None;
            self.agent
                .set_battery(self.agent.battery() - self.config.drain_per_task);
            if let Some(task) = self.agent.finish(now) {
                self.summary.finished += 1;
                say(&format!("{} done with task #{task}", self.stamp(now_i)));
            }
        }
        if self.charging_until.is_some_and(|t| t <= now_i) {
            self.charging_until = None;
            self.agent.set_battery(1.0);
            self.agent.charged(now);
        }
    }
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
