//! A live demonstration over a real hub: the long-term experiment's seven
//! agents, each with its own hub client, and a user agent introducing short
//! random tasks; every allocation is reported as it happens.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_proto::Vec2;
use colony_wire::{Packet, Subject};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::agent::{Agent, AgentConfig, AgentEvent};
use crate::announcer::{AnnouncerEvent, AuctionConfig};
use crate::experiment::longterm::{roster, task_spec, IMPOSSIBLE_TASK, PAPER_TASKS};
use crate::protocol::Token;
use crate::user::{Backoff, UserAgent, UserEvent};
use colony_node::Node;
use colony_node::Time;
use colony_node::{Link, LiveError, Mux};

/// How the demonstration runs.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoConfig {
    /// Stop after this long.
    pub duration: Duration,
    /// Seeds the tasks and the robots' places.
    pub seed: u64,
    /// Mean time between task introductions.
    pub mean_gap: Duration,
}

impl Default for DemoConfig {
    fn default() -> Self {
        DemoConfig {
            duration: Duration::from_secs(20),
            seed: 1,
            mean_gap: Duration::from_millis(700),
        }
    }
}

/// Counts printed at the end.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DemoSummary {
    /// Tasks introduced.
    pub introduced: u64,
    /// Tasks started by a robot.
    pub allocated: u64,
    /// Tasks done.
    pub completed: u64,
    /// Unachievable reports.
    pub unachievable: u64,
    /// Trips to the charger.
    pub recharges: u64,
}

enum Part {
    Robot {
        agent: Agent,
        busy_until: Option<Instant>,
        charging_until: Option<Instant>,
        robot: bool,
    },
    User(UserAgent),
}

impl Part {
    fn node(&self) -> &dyn Node {
        match self {
            Part::Robot { agent, .. } => agent,
            Part::User(u) => u,
        }
    }
    fn node_mut(&mut self) -> &mut dyn Node {
        match self {
            Part::Robot { agent, .. } => agent,
            Part::User(u) => u,
        }
    }
}

impl Node for Part {
    fn subscriptions(&self) -> &std::collections::BTreeSet<Subject> {
        self.node().subscriptions()
    }
    fn handle_packet(&mut self, now: Time, packet: &Packet<'_>) {
        self.node_mut().handle_packet(now, packet)
    }
    fn handle_timeout(&mut self, now: Time) {
        self.node_mut().handle_timeout(now)
    }
    fn poll_timeout(&self) -> Option<Time> {
        self.node().poll_timeout()
    }
    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.node_mut().poll_transmit()
    }
}

/// Runs the demonstration against the hub at `hub` until `config.duration`
/// passes or `stop` is set, passing each line of its report to `say`.
pub fn run(
    hub: SocketAddr,
    config: &DemoConfig,
    stop: &AtomicBool,
    mut say: impl FnMut(&str),
) -> Result<DemoSummary, LiveError> {
    let epoch = Instant::now();
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let mut mux = Mux::new()?;
    let fast = AgentConfig {
        renew_interval: Duration::from_millis(250),
        renew_timeout: Duration::from_millis(1000),
        award_grace: Duration::from_millis(300),
        low_battery: 0.3,
        battery_check: Duration::from_millis(100),
        ..AgentConfig::default()
    };
    let auction = AuctionConfig {
        bid_window: Duration::from_millis(100),
        ack_timeout: Duration::from_millis(500),
        renew_interval: Duration::from_millis(250),
        renew_timeout: Duration::from_millis(1000),
        max_attempts: 8,
    };
    let mut names = Vec::new();
    for spec in roster() {
        let link = Link::new(UdpClient::connect(hub)?, epoch);
        let token = Token::new(spec.name).map_err(|e| std::io::Error::other(e.to_string()))?;
        let resources = spec.resources.parse().unwrap_or_default();
        let mut agent = Agent::new(token, resources, fast.clone(), link.now());
        agent.set_position(Vec2::new(
            rng.random_range(0.0..2000.0),
            rng.random_range(0.0..2000.0),
        ));
        agent.set_battery(rng.random_range(0.5..1.0));
        say(&format!(
            "{:>6} agent {} joins with {}",
            "",
            spec.name,
            agent.resources()
        ));
        names.push(spec.name);
        mux.add(
            link,
            Part::Robot {
                agent,
                busy_until: None,
                charging_until: None,
                robot: spec.robot,
            },
        )?;
    }
    let user_link = Link::new(UdpClient::connect(hub)?, epoch);
    let backoff = Backoff {
        initial: Duration::from_millis(500),
        max: Duration::from_secs(4),
        give_up_after: Duration::from_secs(15),
    };
    let token = Token::new("user").map_err(|e| std::io::Error::other(e.to_string()))?;
    let user = mux.add(
        user_link,
        Part::User(UserAgent::new(token, auction, backoff, config.seed)),
    )?;
    let mut summary = DemoSummary::default();
    let mut next_task = epoch + Duration::from_millis(300);
    let mut names_of_requests = std::collections::BTreeMap::new();
    let end = epoch + config.duration;
    while !stop.load(Ordering::Relaxed) && Instant::now() < end {
        mux.pump()?;
        let now_i = Instant::now();
        let now = Time::from_micros(now_i.duration_since(epoch).as_micros() as u64);
        let stamp = format!("{:6.1}", now.as_secs_f64());
        if now_i >= next_task {
            let kind = if rng.random_bool(0.1) {
                IMPOSSIBLE_TASK
            } else {
                PAPER_TASKS[rng.random_range(0..PAPER_TASKS.len())]
            };
            let at = Vec2::new(rng.random_range(0.0..2000.0), rng.random_range(0.0..2000.0));
            let spec = task_spec(&kind, at, rng.random_range(1.0..6.0f64).round());
            if let Some((_, Part::User(u))) = mux.member_mut(user) {
                if let Ok(r) = u.introduce(now, spec.clone()) {
                    summary.introduced += 1;
                    names_of_requests.insert(r, kind.name);
                    say(&format!("{stamp} introduce #{r} {spec}"));
                }
            }
            let gap = -rng.random_range(f64::EPSILON..1.0f64).ln() * config.mean_gap.as_secs_f64();
            // A mean gap too long for a clock means no more tasks in this run.
            next_task = Duration::try_from_secs_f64(gap)
                .ok()
                .and_then(|d| now_i.checked_add(d))
                .unwrap_or(end);
        }
        for (i, _, part) in mux.iter_mut() {
            match part {
                Part::Robot {
                    agent,
                    busy_until,
                    charging_until,
                    robot,
                } => {
                    let name = names.get(i).copied().unwrap_or("?");
                    while let Some(e) = agent.poll_event() {
                        match e {
                            AgentEvent::Start(ann) => {
                                *busy_until =
                                    Some(now_i + Duration::from_secs_f64(ann.spec.length_s));
                            }
                            AgentEvent::Stop { name: task, .. } => {
                                *busy_until = None;
                                say(&format!("{stamp} {name} stops {task}"));
                            }
                            AgentEvent::Charge => {
                                summary.recharges += 1;
                                *charging_until = Some(now_i + Duration::from_secs(3));
                                say(&format!(
                                    "{stamp} {name} battery {:.2}: unsubscribes from everything to charge",
                                    agent.battery()
                                ));
                            }
                            AgentEvent::Rejoined => {
                                say(&format!("{stamp} {name} charged: subscribes again"))
                            }
                            _ => {}
                        }
                    }
                    if busy_until.is_some_and(|t| t <= now_i) {
                        *busy_until = None;
                        if *robot {
                            agent.set_battery(agent.battery() - 0.12);
                        }
                        agent.finish(now);
                    }
                    if charging_until.is_some_and(|t| t <= now_i) {
                        *charging_until = None;
                        agent.set_battery(1.0);
                        agent.charged(now);
                    }
                }
                Part::User(u) => {
                    while let Some(e) = u.poll_event() {
                        let line = match e {
                            UserEvent::Auction {
                                request,
                                event: AnnouncerEvent::Awarded { winner, score, bids, name, .. },
                            } => Some(format!(
                                "{stamp} #{request} {name} awarded to {winner} (score {score:.0}, {bids} bids)"
                            )),
                            UserEvent::Auction {
                                request,
                                event: AnnouncerEvent::WinnerLost { winner, reason, name, .. },
                            } => Some(format!("{stamp} #{request} {name}: {winner} lost ({reason})")),
                            UserEvent::Allocated { .. } => {
                                summary.allocated += 1;
                                None
                            }
                            UserEvent::Completed { request, winner } => {
                                summary.completed += 1;
                                let n = names_of_requests.get(&request).copied().unwrap_or("");
                                Some(format!("{stamp} #{request} {n} done by {winner}"))
                            }
                            UserEvent::Unachievable { request, reason, retry_in } => {
                                summary.unachievable += 1;
                                Some(format!(
                                    "{stamp} #{request} unachievable: {reason}; retry in {:.1} s",
                                    retry_in.as_secs_f64()
                                ))
                            }
                            UserEvent::GaveUp { request, reason } => {
                                Some(format!("{stamp} #{request} given up: {reason}"))
                            }
                            UserEvent::Auction { .. } => None,
                        };
                        if let Some(l) = line {
                            say(&l);
                        }
                    }
                }
            }
        }
        mux.pump_all()?;
        mux.wait(Duration::from_millis(20))?;
    }
    Ok(summary)
}
