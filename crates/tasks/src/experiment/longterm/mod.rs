//! The loosely coupled experiment of section 6.2: seven agents (six robots
//! with different sensors and a desktop computer with an overhead camera), the
//! paper's four task types, tasks of random length introduced at random times
//! for hours, batteries and chargers, and failures injected at random.
//!
//! The robots here are abstract: points on a plane that drive at a fixed speed
//! to where a task is and spend the task's length there, with a battery that
//! drains as they work and fills at a charger. What is real is everything
//! MURDOCH does: every agent is an [`Agent`] and the user an [`UserAgent`]
//! exchanging the same packets as over the hub, on the in-memory [`Bus`] on
//! simulated time.

mod report;
mod settings;

use std::collections::BTreeMap;
use std::time::Duration;

use colony_proto::Vec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub use report::{KindCounts, LogRow, LongtermOutcome, LongtermReport};
pub use settings::{
    roster, task_spec, AgentSpec, LongtermConfig, SettingsError, TaskKind, IMPOSSIBLE_TASK,
    PAPER_TASKS,
};

use super::Progress;
use crate::agent::{Agent, AgentConfig, AgentEvent};
use crate::announcer::AnnouncerEvent;
use crate::protocol::{ResourceError, ResourceSet, SpecError, Token, TokenError};
use crate::user::{UserAgent, UserEvent};
use colony_node::Bus;
use colony_node::Node;
use colony_node::Time;

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
        ..AgentConfig::default()
    }
}

/// A run in progress: built from its settings, advanced a simulated second
/// at a time by [`step`](Longterm::step), so a caller can watch it (its
/// [`report`](Longterm::report) and [`log`](Longterm::log) so far) or stop it
/// part-way; [`finish`](Longterm::finish) gives the outcome.
///
/// ```
/// use colony_tasks::experiment::{longterm::{Longterm, LongtermConfig}, Progress};
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
    log: Vec<LogRow>,
    report: LongtermReport,
    requests: BTreeMap<u64, RequestInfo>,
    waits: Vec<f64>,
    end_of_intro: Time,
    hard_end: Time,
    next_intro: Time,
    now: Time,
}

/// The simulated time one [`Longterm::step`] advances.
const STEP: Duration = Duration::from_secs(1);

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
        let mut members: Vec<Member> = Vec::new();
        for spec in roster() {
            let resources: ResourceSet = spec.resources.parse()?;
            let position = Vec2::new(
                rng.random_range(0.0..cfg.room_cm),
                rng.random_range(0.0..cfg.room_cm),
            );
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
        let hard_end = end_of_intro + Duration::from_secs_f64(cfg.wind_down_s);
        let next_intro = Time::from_secs_f64(exponential(&mut rng, cfg.mean_gap_s));
        Ok(Longterm {
            cfg: cfg.clone(),
            rng,
            bus,
            user,
            agents_cfg,
            members,
            everyone,
            log: Vec::new(),
            report,
            requests: BTreeMap::new(),
            waits: Vec::new(),
            end_of_intro,
            hard_end,
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

    /// Whether the run has more to do: tasks are still introduced, or some
    /// are open and the wind-down has time left.
    fn running(&self) -> bool {
        self.now < self.hard_end && (self.now < self.end_of_intro || self.user.open_requests() > 0)
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

    /// What the robots were told to do, and the physics of it: driving, working, charging, a flat battery.
    fn move_robots(&mut self) {
        // What the robots were told to do, and the physics of it.
        for m in &mut self.members {
            let Some(agent) = m.agent.as_mut() else {
                continue;
            };
            while let Some(e) = agent.poll_event() {
                match e {
                    AgentEvent::Start(ann) => {
                        let goal = match (ann.spec.number("x"), ann.spec.number("y")) {
                            (Some(x), Some(y)) if m.spec.robot => Vec2::new(x, y),
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
            let dt = STEP.as_secs_f64();
            let drive = |pos: &mut Vec2, goal: Vec2| -> bool {
                let d = goal - *pos;
                let len = d.length();
                let stride = self.cfg.speed_cm_s * dt;
                if len <= stride {
                    *pos = goal;
                    true
                } else {
                    *pos = *pos + d * (stride / len);
                    false
                }
            };
            let mut drain = self.cfg.idle_drain;
            match m.phase.clone() {
                Phase::Idle | Phase::Failed { .. } => {}
                Phase::Travel { goal, length_s } => {
                    drain = self.cfg.work_drain;
                    if drive(&mut m.position, goal) {
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
                Phase::ToCharger { charger } => {
                    drain = self.cfg.work_drain;
                    if drive(&mut m.position, charger) {
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
                m.battery = (m.battery - drain * dt).clamp(0.0, 1.0);
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
