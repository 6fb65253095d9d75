//! One robot's agent as its own process, as the paper deploys MURDOCH: "the
//! same program on every machine", each with its own resources. The body is
//! abstract: a task takes its announced length, each costs some battery, and
//! charging takes a while. Resources can fail and be repaired at given times,
//! as a sensor would.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_node::{Link, LiveError};
use colony_wire::Request;

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
    /// The agent's timings.
    pub agent: AgentConfig,
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

/// Runs the robot against the hub at `hub` until `stop` is set, passing each
/// line of its report to `say`.
pub fn run(
    hub: SocketAddr,
    config: RobotConfig,
    stop: &AtomicBool,
    mut say: impl FnMut(&str),
) -> Result<RobotSummary, LiveError> {
    let epoch = Instant::now();
    let mut link = Link::new(UdpClient::connect(hub)?, epoch);
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
        let wait = body_due.map_or(Duration::from_millis(50), |d| {
            d.min(Duration::from_millis(50))
        });
        link.wait(&agent, Some(wait))?;
        link.pump(&mut agent)?;
        let now_i = Instant::now();
        let now = link.now();
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
            }
            link.client_mut().set_standing(vec![about(&agent)])?;
        }
        while let Some(event) = agent.poll_event() {
            match event {
                AgentEvent::Start(ann) => {
                    summary.started += 1;
                    let length = Duration::try_from_secs_f64(ann.spec.length_s).unwrap_or_default();
                    busy_until = Some(now_i + length);
                    say(&format!(
                        "{} starts task #{} {} for {:.1} s (from {})",
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
