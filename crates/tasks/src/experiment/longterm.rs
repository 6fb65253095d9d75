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

use std::collections::BTreeMap;
use std::time::Duration;

use colony_proto::Vec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::Progress;
use crate::agent::{Agent, AgentConfig, AgentEvent};
use crate::announcer::{AnnouncerEvent, AuctionConfig};
use crate::bus::Bus;
use crate::node::Node;
use crate::protocol::{ResourceError, ResourceSet, SpecError, TaskSpec, Token, TokenError};
use crate::time::Time;
use crate::user::{Backoff, UserAgent, UserEvent};

/// One kind of task: its name, resources and whether it happens somewhere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TaskKind {
    /// The task's name.
    pub name: &'static str,
    /// The resources it needs, blank-separated.
    pub resources: &'static str,
    /// Whether it has a place the robot must drive to.
    pub placed: bool,
}

/// The paper's four task types (section 6.2).
pub const PAPER_TASKS: [TaskKind; 4] = [
    TaskKind {
        name: "object-tracking",
        resources: "camera mobile",
        placed: true,
    },
    TaskKind {
        name: "sentry-duty",
        resources: "camera laser mobile",
        placed: true,
    },
    TaskKind {
        name: "cleanup",
        resources: "camera bumpers mobile",
        placed: true,
    },
    TaskKind {
        name: "monitor-object",
        resources: "overhead-camera",
        placed: false,
    },
];

/// A task no agent of the roster can do (no robot has a gripper): it is
/// reported unachievable every time, and the user agent backs off and gives up.
pub const IMPOSSIBLE_TASK: TaskKind = TaskKind {
    name: "open-door",
    resources: "gripper mobile",
    placed: true,
};

/// One agent of the experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct AgentSpec {
    /// Its name.
    pub name: &'static str,
    /// Its resources, blank-separated.
    pub resources: &'static str,
    /// A robot moves and runs on a battery; the desktop does neither.
    pub robot: bool,
}

/// The seven agents: six robots configured differently (the paper's Pioneers
/// had lasers, colour cameras and bumpers in different combinations) and the
/// desktop computer with the overhead camera.
pub fn roster() -> Vec<AgentSpec> {
    let robot = |name, resources| AgentSpec {
        name,
        resources,
        robot: true,
    };
    vec![
        robot("pioneer1", "camera laser mobile"),
        robot("pioneer2", "camera laser mobile"),
        robot("pioneer3", "camera bumpers mobile"),
        robot("pioneer4", "camera bumpers mobile"),
        robot("pioneer5", "camera laser bumpers mobile"),
        robot("pioneer6", "camera mobile"),
        AgentSpec {
            name: "desktop",
            resources: "overhead-camera",
            robot: false,
        },
    ]
}

/// Everything that shapes a run; the seed fixes it.
#[derive(Debug, Clone, PartialEq)]
pub struct LongtermConfig {
    /// How long tasks are introduced for, simulated hours.
    pub hours: f64,
    /// Seeds every random choice.
    pub seed: u64,
    /// Mean time between task introductions, s (exponential gaps).
    pub mean_gap_s: f64,
    /// Task lengths, s, drawn uniformly from this range.
    pub length_s: (f64, f64),
    /// Share of introduced tasks that no agent can do.
    pub impossible_share: f64,
    /// The room's side, cm (tasks happen uniformly inside it).
    pub room_cm: f64,
    /// Robot speed, cm/s.
    pub speed_cm_s: f64,
    /// Charge used per second of travel or work (a full battery lasts an hour).
    pub work_drain: f64,
    /// Charge used per second idle.
    pub idle_drain: f64,
    /// Charge gained per second at a charger.
    pub charge_rate: f64,
    /// Below this, an idle robot goes to charge.
    pub low_battery: f64,
    /// Where the chargers are, cm.
    pub chargers: Vec<Vec2>,
    /// Mean time between failures of each agent, s (exponential).
    pub mtbf_s: f64,
    /// Time to repair a failed agent, s, uniform in this range.
    pub repair_s: (f64, f64),
    /// After the last introduction, how long to let open tasks finish, s.
    pub wind_down_s: f64,
    /// The user agent's backoff.
    pub backoff: Backoff,
    /// The auctions' timings.
    pub auction: AuctionConfig,
    /// Latency of the bus.
    pub latency: Duration,
}

impl Default for LongtermConfig {
    fn default() -> Self {
        LongtermConfig {
            hours: 3.0,
            seed: 1,
            mean_gap_s: 120.0,
            length_s: (60.0, 600.0),
            impossible_share: 0.05,
            room_cm: 2000.0,
            speed_cm_s: 30.0,
            work_drain: 1.0 / 3600.0,
            idle_drain: 1.0 / 14400.0,
            charge_rate: 1.0 / 1200.0,
            low_battery: 0.3,
            chargers: vec![Vec2::new(100.0, 100.0), Vec2::new(1900.0, 1900.0)],
            mtbf_s: 7200.0,
            repair_s: (300.0, 900.0),
            wind_down_s: 4.0 * 3600.0,
            backoff: Backoff {
                initial: Duration::from_secs(10),
                max: Duration::from_secs(300),
                give_up_after: Duration::from_secs(3 * 3600),
            },
            // Tasks last minutes: renewing every 5 s finds a dead robot within 15 s
            // at a tenth of the traffic of the default 1 s.
            auction: AuctionConfig {
                renew_interval: Duration::from_secs(5),
                renew_timeout: Duration::from_secs(15),
                ..AuctionConfig::default()
            },
            latency: Duration::from_millis(5),
        }
    }
}

impl LongtermConfig {
    /// Checks the numbers a command line can set.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let positive = |what: &'static str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(SettingsError::NotPositive { what, value })
            }
        };
        positive("hours", self.hours)?;
        if self.hours > 24.0 * 30.0 {
            return Err(SettingsError::TooLong(self.hours));
        }
        positive("mean gap", self.mean_gap_s)?;
        positive("speed", self.speed_cm_s)?;
        positive("room", self.room_cm)?;
        positive("mtbf", self.mtbf_s)?;
        if !(self.length_s.0 >= 0.0
            && self.length_s.1 >= self.length_s.0
            && self.length_s.1.is_finite())
        {
            return Err(SettingsError::Lengths(self.length_s));
        }
        if !(0.0..=1.0).contains(&self.impossible_share) {
            return Err(SettingsError::ImpossibleShare(self.impossible_share));
        }
        if self.chargers.is_empty() {
            return Err(SettingsError::NoCharger);
        }
        Ok(())
    }
}

/// Settings a run cannot be made with.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SettingsError {
    /// A number that must be positive (hours, mean gap, speed, room, mtbf) is not.
    #[error("{what} must be a positive number, not {value}")]
    NotPositive {
        /// Which setting.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// More hours of introductions than a run is for.
    #[error("hours {0} is more than 30 days")]
    TooLong(f64),
    /// Task lengths that are not a range of non-negative seconds.
    #[error("task lengths {0:?} are not a range")]
    Lengths((f64, f64)),
    /// A share outside 0 to 1.
    #[error("impossible share must be between 0 and 1, not {0}")]
    ImpossibleShare(f64),
    /// No charger to go to.
    #[error("there must be a charger")]
    NoCharger,
}

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

/// What happened, one row per event, for the CSV.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LogRow {
    /// Simulated time, s.
    pub time_s: f64,
    /// What: `introduced`, `announced`, `awarded`, `started`, `completed`,
    /// `winner-lost`, `unachievable`, `gave-up`, `charge`, `charged`, `failed`, `repaired`.
    pub kind: &'static str,
    /// The user's request, if the event is about one.
    pub request: Option<u64>,
    /// The task's name, if any.
    pub task: String,
    /// The agent concerned, if any.
    pub agent: String,
    /// Anything else (a score, a reason).
    pub detail: String,
}

/// Counts for one task type.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct KindCounts {
    /// Introduced by the user.
    pub introduced: u64,
    /// Done.
    pub completed: u64,
    /// Given up by the user agent.
    pub gave_up: u64,
}

/// The summary of a run.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct LongtermReport {
    /// The seed.
    pub seed: u64,
    /// Hours of task introductions.
    pub hours: f64,
    /// Simulated time until the last task was resolved, s.
    pub simulated_s: f64,
    /// Agents in the experiment.
    pub agents: usize,
    /// Tasks the user introduced.
    pub introduced: u64,
    /// Of those, ones some agent of the roster could do.
    pub achievable: u64,
    /// Auctions opened (first tries, retries and re-auctions).
    pub announced: u64,
    /// Auctions closed with a winner.
    pub awarded: u64,
    /// Tasks a winner acknowledged and started (re-allocations included).
    pub allocated: u64,
    /// Tasks done.
    pub completed: u64,
    /// Achievable tasks done.
    pub completed_achievable: u64,
    /// Tasks auctioned again after their winner failed (no renewal or no ack).
    pub reallocated_after_failure: u64,
    /// Winners that declined or abandoned (re-auctioned too).
    pub reallocated_other: u64,
    /// Unachievable reports the user agent received.
    pub unachievable_reports: u64,
    /// Requests the user agent gave up on.
    pub gave_up: u64,
    /// Achievable requests given up.
    pub gave_up_achievable: u64,
    /// Trips to a charger.
    pub recharges: u64,
    /// Failures injected.
    pub failures: u64,
    /// Of those, failures of an agent at work.
    pub failures_at_work: u64,
    /// Packets published on the bus.
    pub messages: u64,
    /// Packets per award.
    pub messages_per_allocation: f64,
    /// Packets per award, counting only announcements, bids, awards,
    /// acknowledgements and declines (renewals and reports left out).
    pub negotiation_per_allocation: f64,
    /// Mean time from introduction to the start of work, s.
    pub mean_wait_s: f64,
    /// Packets by message.
    pub messages_by_kind: BTreeMap<String, u64>,
    /// Counts by task type.
    pub by_task: BTreeMap<String, KindCounts>,
}

/// A finished run: its summary and its event log.
#[derive(Debug, Clone)]
pub struct LongtermOutcome {
    /// The summary.
    pub report: LongtermReport,
    /// Every event, in time order.
    pub log: Vec<LogRow>,
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

/// The task a user introduces: placed tasks score by distance, then by charge
/// left and by how many resources the robot would tie up (a specialist is
/// preferred over a generalist who may be needed later).
pub fn task_spec(kind: &TaskKind, at: Vec2, length_s: f64) -> TaskSpec {
    let resources = kind.resources.parse().unwrap_or_default();
    let spec = TaskSpec::new(kind.name, resources).length(length_s);
    if kind.placed {
        spec.param("x", at.x)
            .param("y", at.y)
            .metric("distance", 1.0)
            .metric("battery", 500.0)
            .metric("resources", 100.0)
    } else {
        spec.metric("resources", 1.0)
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
        advance(&mut self.bus, &mut self.members, &mut self.user, self.now);
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
        Ok(if self.running() {
            Progress::Running
        } else {
            Progress::Done
        })
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

impl LongtermReport {
    /// The summary as pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}

impl LongtermOutcome {
    /// The event log as CSV.
    pub fn log_csv(&self) -> String {
        let mut out = String::from("time_s,kind,request,task,agent,detail\n");
        for r in &self.log {
            out.push_str(&format!(
                "{:.3},{},{},{},{},{}\n",
                r.time_s,
                r.kind,
                r.request.map_or(String::new(), |q| q.to_string()),
                csv_field(&r.task),
                csv_field(&r.agent),
                csv_field(&r.detail)
            ));
        }
        out
    }
}

/// A CSV field, quoted if it needs to be.
pub(crate) fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}
