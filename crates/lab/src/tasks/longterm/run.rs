//! A long-term run: the agents, the user, the bodies and the clock.

use std::collections::BTreeMap;
use std::time::Duration;

use colony_proto::Vec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::bodies::{Bodies, Target};
use super::report::{LogRow, LongtermOutcome, LongtermReport};
use super::settings::{
    roster, task_spec, AgentSpec, LongtermConfig, SettingsError, TaskKind, IMPOSSIBLE_TASK,
    PAPER_TASKS,
};
use crate::tasks::Progress;
use colony_node::Bus;
use colony_node::Node;
use colony_node::Time;
use colony_tasks::protocol::{ResourceError, ResourceSet, SpecError, Token, TokenError};
use colony_tasks::AnnouncerEvent;
use colony_tasks::{Agent, AgentConfig, AgentEvent};
use colony_tasks::{UserAgent, UserEvent};

/// Why a run could not be made or went wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LongtermError {
    /// The settings are refused.
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// An agent's name in the roster is not a token.
    #[error(transparent)]
    Token(#[from] TokenError),
    /// An agent's resources in the roster are not a resource set.
    #[error(transparent)]
    Resources(#[from] ResourceError),
    /// The room or a robot's body could not be made.
    #[error("the room: {0}")]
    Field(String),
    /// A task the user introduces is invalid.
    #[error(transparent)]
    Spec(#[from] SpecError),
}

/// Why an auction found no robot.
enum Why {
    NoRobot,
    Charging,
    Failed,
    Busy,
}

#[derive(Debug, Clone, PartialEq)]
enum Phase {
    Idle,
    Travel { goal: Vec2, length_s: f64 },
    Work { until: Time },
    ToCharger { charger: Vec2 },
    Charging,
    Failed { until: Time },
}

struct Member {
    spec: AgentSpec,
    /// Its body in the field (the desktop has none).
    body: Option<usize>,
    resources: ResourceSet,
    agent: Option<Agent>,
    phase: Phase,
    position: Vec2,
    battery: f64,
    next_failure: Time,
}

struct RequestInfo {
    kind: TaskKind,
    introduced: Time,
    achievable: bool,
}

fn exponential(rng: &mut ChaCha8Rng, mean: f64) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    -u.ln() * mean
}

fn agent_config(cfg: &LongtermConfig) -> AgentConfig {
    AgentConfig {
        low_battery: cfg.low_battery,
        drain_per_second: cfg.work_drain,
        renew_interval: cfg.auction.renew_interval,
        renew_timeout: cfg.auction.renew_timeout,
        linger: cfg.auction.renew_timeout,
        // Nobody watches this run live: reports would only swell the message counts
        // set beside the paper's.
        report_interval: None,
        ..AgentConfig::default()
    }
}

/// A run in progress: built from its settings, advanced a simulated second
/// at a time by [`step`](Longterm::step), so a caller can watch it (its
/// [`report`](Longterm::report) and [`log`](Longterm::log) so far) or stop it
/// part-way; [`finish`](Longterm::finish) gives the outcome.
///
/// ```
/// use colony_lab::tasks::{longterm::{Longterm, LongtermConfig}, Progress};
/// let mut run = Longterm::new(&LongtermConfig { hours: 0.05, ..Default::default() }).unwrap();
/// while run.step().unwrap() == Progress::Running && run.now().as_secs_f64() < 60.0 {}
/// assert!(run.report().introduced <= 1);
/// ```
pub struct Longterm {
    cfg: LongtermConfig,
    rng: ChaCha8Rng,
    bus: Bus,
    user: UserAgent,
    agents_cfg: AgentConfig,
    members: Vec<Member>,
    /// Every agent's resources, to judge whether a task is achievable.
    everyone: Vec<ResourceSet>,
    bodies: Bodies,
    log: Vec<LogRow>,
    report: LongtermReport,
    requests: BTreeMap<u64, RequestInfo>,
    waits: Vec<f64>,
    /// The end of the hours asked for: the run stops there.
    end_of_intro: Time,
    next_intro: Time,
    now: Time,
}

/// The simulated time one [`Longterm::step`] advances.
const STEP: Duration = Duration::from_secs(1);
/// A robot this close to a task's place is there, cm.
const TASK_REACH: f64 = 30.0;
/// A robot this close to a charger is docked, cm (two may share one).
const CHARGER_REACH: f64 = 60.0;

impl Longterm {
    /// Sets a run up: the roster placed, charged and seeded, nothing introduced yet.
    pub fn new(cfg: &LongtermConfig) -> Result<Longterm, LongtermError> {
        cfg.validate()?;
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        let bus = Bus::new(cfg.latency);
        let user = UserAgent::new(
            Token::new("user")?,
            cfg.auction.clone(),
            cfg.backoff.clone(),
            cfg.seed,
        );
        let agents_cfg = agent_config(cfg);
        let field = |e: colony_sim::SimError| LongtermError::Field(e.to_string());
        let mut bodies = Bodies::new(cfg.room_cm).map_err(field)?;
        let mut members: Vec<Member> = Vec::new();
        for spec in roster() {
            let resources: ResourceSet = spec.resources.parse()?;
            let body = if spec.robot {
                Some(bodies.add(cfg.speed_cm_s, &mut rng).map_err(field)?)
            } else {
                None
            };
            let position = match body {
                Some(b) => bodies.position(b),
                None => Vec2::new(cfg.room_cm / 2.0, cfg.room_cm / 2.0),
            };
            let next_failure = Time::from_secs_f64(exponential(&mut rng, cfg.mtbf_s));
            let battery = if spec.robot {
                rng.random_range(0.6..1.0)
            } else {
                1.0
            };
            members.push(Member {
                agent: Some(new_agent(
                    &spec,
                    &resources,
                    &agents_cfg,
                    Time::ZERO,
                    position,
                    battery,
                )?),
                spec,
                body,
                resources,
                phase: Phase::Idle,
                position,
                battery,
                next_failure,
            });
        }
        let everyone: Vec<ResourceSet> = members.iter().map(|m| m.resources.clone()).collect();
        let report = LongtermReport {
            seed: cfg.seed,
            hours: cfg.hours,
            agents: members.len(),
            ..LongtermReport::default()
        };
        let end_of_intro = Time::from_secs_f64(cfg.hours * 3600.0);
        let next_intro = Time::from_secs_f64(exponential(&mut rng, cfg.mean_gap_s));
        Ok(Longterm {
            cfg: cfg.clone(),
            rng,
            bus,
            user,
            agents_cfg,
            members,
            everyone,
            bodies,
            log: Vec::new(),
            report,
            requests: BTreeMap::new(),
            waits: Vec::new(),
            end_of_intro,
            next_intro,
            now: Time::ZERO,
        })
    }

    /// Simulated time so far.
    pub fn now(&self) -> Time {
        self.now
    }

    /// The counts so far (the totals that need the whole run, such as
    /// messages per allocation, are filled in by [`finish`](Longterm::finish)).
    pub fn report(&self) -> &LongtermReport {
        &self.report
    }

    /// Every event so far, in time order.
    pub fn log(&self) -> &[LogRow] {
        &self.log
    }

    /// Whether the run has more to do: it lasts exactly the hours asked for.
    fn running(&self) -> bool {
        self.now < self.end_of_intro
    }

    /// Advances the run by one simulated second: introductions, failures and
    /// repairs, the protocol, the robots' driving, working and charging, and
    /// what the user heard. Does nothing once the run is over.
    pub fn step(&mut self) -> Result<Progress, LongtermError> {
        if !self.running() {
            return Ok(Progress::Done);
        }
        self.now = self.now + STEP;
        self.introduce()?;
        self.fail_and_repair()?;
        advance(&mut self.bus, &mut self.members, &mut self.user, self.now);
        self.move_robots();
        self.hear_user();
        Ok(if self.running() {
            Progress::Running
        } else {
            Progress::Done
        })
    }

    /// Introduces the tasks due by now, each at its own moment.
    fn introduce(&mut self) -> Result<(), LongtermError> {
        // Introduce tasks, each at its own moment.
        while self.next_intro <= self.now && self.next_intro <= self.end_of_intro {
            advance(
                &mut self.bus,
                &mut self.members,
                &mut self.user,
                self.next_intro,
            );
            let kind = if self.rng.random_bool(self.cfg.impossible_share) {
                IMPOSSIBLE_TASK
            } else {
                PAPER_TASKS[self.rng.random_range(0..PAPER_TASKS.len())]
            };
            let at = Vec2::new(
                self.rng.random_range(0.0..self.cfg.room_cm),
                self.rng.random_range(0.0..self.cfg.room_cm),
            );
            let length = self
                .rng
                .random_range(self.cfg.length_s.0..=self.cfg.length_s.1)
                .round();
            let spec = task_spec(&kind, at, length);
            let achievable = self.everyone.iter().any(|r| spec.resources.is_subset(r));
            let request = self.user.introduce(self.bus.now(), spec)?;
            self.requests.insert(
                request,
                RequestInfo {
                    kind,
                    introduced: self.next_intro,
                    achievable,
                },
            );
            self.report.introduced += 1;
            self.report.achievable += u64::from(achievable);
            self.report
                .by_task
                .entry(kind.name.to_owned())
                .or_default()
                .introduced += 1;
            self.log.push(row(
                self.next_intro,
                "introduced",
                Some(request),
                kind.name,
                "",
                format!("length {length} s"),
            ));
            self.next_intro = self.next_intro
                + Duration::from_secs_f64(exponential(&mut self.rng, self.cfg.mean_gap_s));
        }
        Ok(())
    }

    /// Fails agents whose time has come (while tasks are still introduced) and repairs those whose repair is over.
    fn fail_and_repair(&mut self) -> Result<(), LongtermError> {
        // Failures and repairs.
        for m in &mut self.members {
            if let Phase::Failed { until } = m.phase {
                if until <= self.now {
                    m.agent = Some(new_agent(
                        &m.spec,
                        &m.resources,
                        &self.agents_cfg,
                        self.now,
                        m.position,
                        m.battery,
                    )?);
                    m.phase = Phase::Idle;
                    m.next_failure = self.now
                        + Duration::from_secs_f64(exponential(&mut self.rng, self.cfg.mtbf_s));
                    self.log.push(row(
                        self.now,
                        "repaired",
                        None,
                        "",
                        m.spec.name,
                        String::new(),
                    ));
                }
            } else if m.next_failure <= self.now && self.now < self.end_of_intro {
                let task = m
                    .agent
                    .as_ref()
                    .and_then(|a| a.current_task())
                    .map(|t| t.spec.name.clone())
                    .unwrap_or_default();
                self.report.failures += 1;
                self.report.failures_at_work += u64::from(!task.is_empty());
                m.agent = None;
                let repair = self
                    .rng
                    .random_range(self.cfg.repair_s.0..=self.cfg.repair_s.1);
                m.phase = Phase::Failed {
                    until: self.now + Duration::from_secs_f64(repair),
                };
                self.log.push(row(
                    self.now,
                    "failed",
                    None,
                    &task,
                    m.spec.name,
                    format!("repair in {repair:.0} s"),
                ));
            }
        }
        Ok(())
    }

    /// What the robots were told to do, and the physics of it: driving in the
    /// field, working, charging, a flat battery.
    fn move_robots(&mut self) {
        for m in &mut self.members {
            let Some(agent) = m.agent.as_mut() else {
                continue;
            };
            while let Some(e) = agent.poll_event() {
                match e {
                    AgentEvent::Start(ann) => {
                        let goal = match (ann.spec.number("x"), ann.spec.number("y")) {
                            (Some(x), Some(y)) if m.body.is_some() => Vec2::new(x, y),
                            _ => m.position,
                        };
                        m.phase = Phase::Travel {
                            goal,
                            length_s: ann.spec.length_s,
                        };
                    }
                    AgentEvent::Stop { .. } => m.phase = Phase::Idle,
                    AgentEvent::Charge => {
                        let charger = self
                            .cfg
                            .chargers
                            .iter()
                            .copied()
                            .min_by(|a, b| {
                                a.distance(m.position).total_cmp(&b.distance(m.position))
                            })
                            .unwrap_or(m.position);
                        m.phase = Phase::ToCharger { charger };
                        self.report.recharges += 1;
                        self.log.push(row(
                            self.now,
                            "charge",
                            None,
                            "",
                            m.spec.name,
                            format!("battery {:.2}", m.battery),
                        ));
                    }
                    AgentEvent::Rejoined => {
                        self.log.push(row(
                            self.now,
                            "charged",
                            None,
                            "",
                            m.spec.name,
                            String::new(),
                        ));
                    }
                    AgentEvent::Skipped { .. } | AgentEvent::Rejected(_) => {}
                }
            }
        }
        // Where each body is headed; a failed robot stays where it broke down, an obstacle.
        let start_s = self.now.since(Time::ZERO).as_secs_f64() - STEP.as_secs_f64();
        for m in &self.members {
            let Some(body) = m.body else { continue };
            let target = match (&m.phase, m.agent.is_some()) {
                (Phase::Travel { goal, .. }, true) => Some(Target {
                    at: *goal,
                    reach: TASK_REACH,
                }),
                (Phase::ToCharger { charger }, true) => Some(Target {
                    at: *charger,
                    reach: CHARGER_REACH,
                }),
                _ => None,
            };
            self.bodies.go(body, target, start_s);
        }
        let arrived = self.bodies.advance(start_s, STEP.as_secs_f64());
        for m in &mut self.members {
            let Some(agent) = m.agent.as_mut() else {
                continue;
            };
            // A member with no body (the desktop) is wherever its work is.
            let here = m.body.is_none_or(|b| arrived.contains(&b));
            if let Some(body) = m.body {
                m.position = self.bodies.position(body);
            }
            let mut drain = self.cfg.idle_drain;
            match m.phase.clone() {
                Phase::Idle | Phase::Failed { .. } => {}
                Phase::Travel { length_s, .. } => {
                    drain = self.cfg.work_drain;
                    if here {
                        m.phase = Phase::Work {
                            until: self.now + Duration::from_secs_f64(length_s),
                        };
                    }
                }
                Phase::Work { until } => {
                    drain = self.cfg.work_drain;
                    if self.now >= until {
                        agent.finish(self.now);
                        m.phase = Phase::Idle;
                    }
                }
                Phase::ToCharger { .. } => {
                    drain = self.cfg.work_drain;
                    if here {
                        m.phase = Phase::Charging;
                    }
                }
                Phase::Charging => {
                    drain = -self.cfg.charge_rate;
                    if m.battery >= 1.0 {
                        agent.charged(self.now);
                        m.phase = Phase::Idle;
                    }
                }
            }
            if m.spec.robot {
                m.battery = (m.battery - drain * STEP.as_secs_f64()).clamp(0.0, 1.0);
            }
            agent.set_position(m.position);
            agent.set_battery(m.battery);
            if m.spec.robot && m.battery <= 0.0 {
                // Flat in the field: as good as failed until someone carries it to a charger.
                self.report.failures += 1;
                self.report.failures_at_work += u64::from(agent.current_task().is_some());
                m.agent = None;
                m.battery = 1.0;
                m.phase = Phase::Failed {
                    until: self.now + Duration::from_secs_f64(self.cfg.repair_s.1),
                };
                self.log.push(row(
                    self.now,
                    "failed",
                    None,
                    "",
                    m.spec.name,
                    "flat battery".into(),
                ));
            }
        }
        self.report.stuck_arrivals = self.bodies.stuck();
    }

    /// What the user heard: auctions, allocations, completions, give-ups.
    fn hear_user(&mut self) {
        // What the user heard.
        while let Some(e) = self.user.poll_event() {
            match e {
                UserEvent::Auction { request, event } => {
                    let name = self.requests.get(&request).map_or("", |r| r.kind.name);
                    match event {
                        AnnouncerEvent::Announced { attempt, .. } => {
                            self.report.announced += 1;
                            self.log.push(row(
                                self.now,
                                "announced",
                                Some(request),
                                name,
                                "",
                                format!("attempt {attempt}"),
                            ));
                        }
                        AnnouncerEvent::Awarded {
                            winner,
                            score,
                            bids,
                            ..
                        } => {
                            self.report.awarded += 1;
                            self.log.push(row(
                                self.now,
                                "awarded",
                                Some(request),
                                name,
                                winner.as_str(),
                                format!("score {score:.1} of {bids} bids"),
                            ));
                        }
                        AnnouncerEvent::Started { winner, .. } => {
                            self.report.allocated += 1;
                            self.log.push(row(
                                self.now,
                                "started",
                                Some(request),
                                name,
                                winner.as_str(),
                                String::new(),
                            ));
                        }
                        AnnouncerEvent::WinnerLost { winner, reason, .. } => {
                            if reason.contains("presumed failed")
                                || reason.contains("no acknowledgement")
                            {
                                self.report.reallocated_after_failure += 1;
                            } else {
                                self.report.reallocated_other += 1;
                            }
                            self.log.push(row(
                                self.now,
                                "winner-lost",
                                Some(request),
                                name,
                                winner.as_str(),
                                reason,
                            ));
                        }
                        AnnouncerEvent::Unachievable { reason, .. } => {
                            self.report.unachievable_reports += 1;
                            let needs = self.requests.get(&request).map(|r| r.kind.resources);
                            match self.why_unachievable(needs.unwrap_or_default()) {
                                Why::NoRobot => self.report.unachievable_no_robot += 1,
                                Why::Charging => self.report.unachievable_charging += 1,
                                Why::Failed => self.report.unachievable_failed += 1,
                                Why::Busy => self.report.unachievable_busy += 1,
                            }
                            self.log.push(row(
                                self.now,
                                "unachievable",
                                Some(request),
                                name,
                                "",
                                reason,
                            ));
                        }
                        AnnouncerEvent::Bid { .. }
                        | AnnouncerEvent::Completed { .. }
                        | AnnouncerEvent::Cancelled { .. } => {}
                    }
                }
                UserEvent::Allocated { request, .. } => {
                    if let Some(r) = self.requests.get(&request) {
                        self.waits.push(self.now.since(r.introduced).as_secs_f64());
                    }
                }
                UserEvent::Completed { request, winner } => {
                    let Some(r) = self.requests.get(&request) else {
                        continue;
                    };
                    self.report.completed += 1;
                    self.report.completed_achievable += u64::from(r.achievable);
                    self.report
                        .by_task
                        .entry(r.kind.name.to_owned())
                        .or_default()
                        .completed += 1;
                    self.log.push(row(
                        self.now,
                        "completed",
                        Some(request),
                        r.kind.name,
                        winner.as_str(),
                        String::new(),
                    ));
                }
                UserEvent::GaveUp { request, reason } => {
                    let Some(r) = self.requests.get(&request) else {
                        continue;
                    };
                    self.report.gave_up += 1;
                    self.report.gave_up_achievable += u64::from(r.achievable);
                    self.report
                        .by_task
                        .entry(r.kind.name.to_owned())
                        .or_default()
                        .gave_up += 1;
                    self.log.push(row(
                        self.now,
                        "gave-up",
                        Some(request),
                        r.kind.name,
                        "",
                        reason,
                    ));
                }
                UserEvent::Unachievable { .. } => {}
            }
        }
    }

    /// Why no robot took a task needing `needs`, from what every robot of the
    /// roster was doing when its auction closed.
    fn why_unachievable(&self, needs: &str) -> Why {
        let needs: ResourceSet = needs.parse().unwrap_or_default();
        let capable: Vec<&Phase> = self
            .members
            .iter()
            .filter(|m| needs.is_subset(&m.resources))
            .map(|m| &m.phase)
            .collect();
        if capable.is_empty() {
            Why::NoRobot
        } else if capable
            .iter()
            .all(|p| matches!(p, Phase::Charging | Phase::ToCharger { .. }))
        {
            Why::Charging
        } else if capable.iter().all(|p| matches!(p, Phase::Failed { .. })) {
            Why::Failed
        } else {
            Why::Busy
        }
    }

    /// The outcome: the report with its whole-run totals, and the log.
    pub fn finish(self) -> LongtermOutcome {
        let mut report = self.report;
        report.simulated_s = self.now.as_secs_f64();
        report.open_at_end = self.user.open_requests() as u64;
        let stats = self.bus.stats();
        report.messages = stats.sent;
        report.messages_by_kind = stats.by_label.clone();
        let per_award = |n: u64| {
            if report.awarded > 0 {
                n as f64 / report.awarded as f64
            } else {
                0.0
            }
        };
        let negotiation: u64 = ["task", "bid", "award", "ack", "decline"]
            .iter()
            .filter_map(|l| stats.by_label.get(*l))
            .sum();
        report.messages_per_allocation = per_award(stats.sent);
        report.negotiation_per_allocation = per_award(negotiation);
        report.mean_wait_s = if self.waits.is_empty() {
            0.0
        } else {
            self.waits.iter().sum::<f64>() / self.waits.len() as f64
        };
        LongtermOutcome {
            report,
            log: self.log,
        }
    }
}

/// Runs the experiment to its end.
pub fn run(cfg: &LongtermConfig) -> Result<LongtermOutcome, LongtermError> {
    let mut run = Longterm::new(cfg)?;
    while run.step()? == Progress::Running {}
    Ok(run.finish())
}

/// One row of the log.
fn row(
    time: Time,
    kind: &'static str,
    request: Option<u64>,
    task: &str,
    agent: &str,
    detail: String,
) -> LogRow {
    LogRow {
        time_s: time.as_secs_f64(),
        kind,
        request,
        task: task.to_owned(),
        agent: agent.to_owned(),
        detail,
    }
}

/// Runs the protocol up to `t`, among the agents still working and the user.
fn advance(bus: &mut Bus, members: &mut [Member], user: &mut UserAgent, t: Time) {
    let mut nodes: Vec<&mut dyn Node> = members
        .iter_mut()
        .filter_map(|m| m.agent.as_mut().map(|a| a as &mut dyn Node))
        .collect();
    nodes.push(user);
    bus.run_until(&mut nodes, t);
}

fn new_agent(
    spec: &AgentSpec,
    resources: &ResourceSet,
    cfg: &AgentConfig,
    now: Time,
    at: Vec2,
    battery: f64,
) -> Result<Agent, TokenError> {
    let token = Token::new(spec.name)?;
    let mut a = Agent::new(token, resources.clone(), cfg.clone(), now);
    a.set_position(at);
    a.set_battery(battery);
    Ok(a)
}
