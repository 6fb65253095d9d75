//! A live demonstration over a real hub: the long-term experiment's seven
//! agents, each with its own hub client, and a user agent introducing short
//! random tasks; every allocation is reported as it happens.

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_proto::Vec2;
use colony_wire::{Packet, Subject};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::tasks::longterm::{roster, task_spec, IMPOSSIBLE_TASK, PAPER_TASKS};
use colony_node::Node;
use colony_node::Time;
use colony_node::{Link, LiveError, Mux};
use colony_tasks::protocol::Token;
use colony_tasks::{Agent, AgentConfig, AgentEvent};
use colony_tasks::{AnnouncerEvent, AuctionConfig};
use colony_tasks::{Backoff, UserAgent, UserEvent};

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
    Robot(Member),
    User(UserAgent),
}

/// An agent of the roster, with the times its body keeps.
struct Member {
    agent: Agent,
    busy_until: Option<Instant>,
    charging_until: Option<Instant>,
    /// A robot's battery runs down with work; a workstation's does not.
    robot: bool,
}

impl Part {
    fn node(&self) -> &dyn Node {
        match self {
            Part::Robot(m) => &m.agent,
            Part::User(u) => u,
        }
    }
    fn node_mut(&mut self) -> &mut dyn Node {
        match self {
            Part::Robot(m) => &mut m.agent,
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
    let mut demo = Demo::join(hub, config, &mut say)?;
    while !stop.load(Ordering::Relaxed) && Instant::now() < demo.end {
        demo.mux.pump()?;
        let now_i = Instant::now();
        let now = Time::from_micros(now_i.duration_since(demo.epoch).as_micros() as u64);
        let stamp = format!("{:6.1}", now.as_secs_f64());
        if now_i >= demo.next_task {
            demo.introduce(now_i, now, &stamp, &mut say);
        }
        demo.step_parts(now_i, now, &stamp, &mut say);
        demo.mux.pump_all()?;
        demo.mux.wait(Duration::from_millis(20))?;
    }
    Ok(demo.summary)
}

/// The agents of the roster and the user, on one hub, and what the report counts.
struct Demo {
    epoch: Instant,
    end: Instant,
    mean_gap: Duration,
    rng: ChaCha8Rng,
    mux: Mux<Part>,
    /// The roster's names, in the order of their places in `mux`.
    names: Vec<&'static str>,
    /// The user's place in `mux`.
    user: usize,
    summary: DemoSummary,
    next_task: Instant,
    names_of_requests: BTreeMap<u64, &'static str>,
}

impl Demo {
    /// Connects every agent of the roster, at random places and charges, then the user.
    fn join(
        hub: SocketAddr,
        config: &DemoConfig,
        say: &mut impl FnMut(&str),
    ) -> Result<Demo, LiveError> {
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
                Part::Robot(Member {
                    agent,
                    busy_until: None,
                    charging_until: None,
                    robot: spec.robot,
                }),
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
        Ok(Demo {
            epoch,
            end: epoch + config.duration,
            mean_gap: config.mean_gap,
            rng,
            mux,
            names,
            user,
            summary: DemoSummary::default(),
            next_task: epoch + Duration::from_millis(300),
            names_of_requests: BTreeMap::new(),
        })
    }

    /// Has the user introduce a random task (one in ten impossible) at a random place, and
    /// draws when the next one comes: tasks arrive as a Poisson process.
    fn introduce(&mut self, now_i: Instant, now: Time, stamp: &str, say: &mut impl FnMut(&str)) {
        let rng = &mut self.rng;
        let kind = if rng.random_bool(0.1) {
            IMPOSSIBLE_TASK
        } else {
            PAPER_TASKS[rng.random_range(0..PAPER_TASKS.len())]
        };
        let at = Vec2::new(rng.random_range(0.0..2000.0), rng.random_range(0.0..2000.0));
        let spec = task_spec(&kind, at, rng.random_range(1.0..6.0f64).round());
        if let Some((_, Part::User(u))) = self.mux.member_mut(self.user) {
            if let Ok(r) = u.introduce(now, spec.clone()) {
                self.summary.introduced += 1;
                self.names_of_requests.insert(r, kind.name);
                say(&format!("{stamp} introduce #{r} {spec}"));
            }
        }
        let gap = -self.rng.random_range(f64::EPSILON..1.0f64).ln() * self.mean_gap.as_secs_f64();
        // A mean gap too long for a clock means no more tasks in this run.
        self.next_task = Duration::try_from_secs_f64(gap)
            .ok()
            .and_then(|d| now_i.checked_add(d))
            .unwrap_or(self.end);
    }

    /// Lets every agent act on what happened to it, and reports what the user heard.
    fn step_parts(&mut self, now_i: Instant, now: Time, stamp: &str, say: &mut impl FnMut(&str)) {
        for (i, _, part) in self.mux.iter_mut() {
            match part {
                Part::Robot(m) => {
                    let name = self.names.get(i).copied().unwrap_or("?");
                    m.step(name, now_i, now, stamp, &mut self.summary, say);
                }
                Part::User(u) => {
                    report_user_events(u, stamp, &mut self.summary, &self.names_of_requests, say)
                }
            }
        }
    }
}

impl Member {
    /// Starts, stops and charges as its agent says, and ends the work and the charge whose
    /// time has come.
    fn step(
        &mut self,
        name: &str,
        now_i: Instant,
        now: Time,
        stamp: &str,
        summary: &mut DemoSummary,
        say: &mut impl FnMut(&str),
    ) {
        while let Some(e) = self.agent.poll_event() {
            match e {
                AgentEvent::Start(ann) => {
                    self.busy_until = Some(now_i + Duration::from_secs_f64(ann.spec.length_s));
                }
                AgentEvent::Stop { name: task, .. } => {
                    self.busy_until = None;
                    say(&format!("{stamp} {name} stops {task}"));
                }
                AgentEvent::Charge => {
                    summary.recharges += 1;
                    self.charging_until = Some(now_i + Duration::from_secs(3));
                    say(&format!(
                        "{stamp} {name} battery {:.2}: unsubscribes from everything to charge",
                        self.agent.battery()
                    ));
                }
                AgentEvent::Rejoined => say(&format!("{stamp} {name} charged: subscribes again")),
                _ => {}
            }
        }
        if self.busy_until.is_some_and(|t| t <= now_i) {
            self.busy_until = None;
            if self.robot {
                self.agent.set_battery(self.agent.battery() - 0.12);
            }
            self.agent.finish(now);
        }
        if self.charging_until.is_some_and(|t| t <= now_i) {
            self.charging_until = None;
            self.agent.set_battery(1.0);
            self.agent.charged(now);
        }
    }
}

/// Reports what the user heard of its requests, and counts it.
fn report_user_events(
    u: &mut UserAgent,
    stamp: &str,
    summary: &mut DemoSummary,
    names_of_requests: &BTreeMap<u64, &'static str>,
    say: &mut impl FnMut(&str),
) {
    while let Some(e) = u.poll_event() {
        let line = match e {
            UserEvent::Auction {
                request,
                event:
                    AnnouncerEvent::Awarded {
                        winner,
                        score,
                        bids,
                        name,
                        ..
                    },
            } => Some(format!(
                "{stamp} #{request} {name} awarded to {winner} (score {score:.0}, {bids} bids)"
            )),
            UserEvent::Auction {
                request,
                event:
                    AnnouncerEvent::WinnerLost {
                        winner,
                        reason,
                        name,
                        ..
                    },
            } => Some(format!(
                "{stamp} #{request} {name}: {winner} lost ({reason})"
            )),
            UserEvent::Allocated { .. } => {
                summary.allocated += 1;
                None
            }
            UserEvent::Completed { request, winner } => {
                summary.completed += 1;
                let n = names_of_requests.get(&request).copied().unwrap_or("");
                Some(format!("{stamp} #{request} {n} done by {winner}"))
            }
            UserEvent::Unachievable {
                request,
                reason,
                retry_in,
            } => {
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
