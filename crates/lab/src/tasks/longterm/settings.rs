//! A long-term run's settings: the task types, the roster, and the numbers
//! a command line can set.

use std::time::Duration;

use colony_proto::Vec2;

use colony_tasks::protocol::TaskSpec;
use colony_tasks::AuctionConfig;
use colony_tasks::Backoff;

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
        if !(ROOM_CM.0..=ROOM_CM.1).contains(&self.room_cm) {
            return Err(SettingsError::Room(self.room_cm));
        }
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
    /// A room too small for the robots or larger than the field's largest map.
    #[error("the room must be {lo} to {hi} cm across, not {0}", lo = ROOM_CM.0, hi = ROOM_CM.1)]
    Room(f64),
}

/// A room's side, cm: room for six Pioneers, up to the field's largest map.
pub const ROOM_CM: (f64, f64) = (500.0, 50_000.0);

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
