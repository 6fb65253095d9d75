//! A robot's timings and thresholds.

use std::time::Duration;

/// A robot's timings and thresholds.
#[derive(Debug, Clone, PartialEq)]
pub struct AgentConfig {
    /// How often the winner tells the announcer it is still at work.
    pub renew_interval: Duration,
    /// An announcer silent this long is presumed gone, and its task abandoned.
    pub renew_timeout: Duration,
    /// How long after an auction's deadline a bidder waits for the award
    /// before it decides the announcer is gone.
    pub award_grace: Duration,
    /// Below this charge (0 to 1), an idle robot leaves to charge.
    pub low_battery: f64,
    /// How often an idle robot looks at its battery.
    pub battery_check: Duration,
    /// Charge a robot expects to use per second of a task; it does not bid for
    /// a task that would take it below `low_battery`. 0 turns the check off.
    pub drain_per_second: f64,
    /// After finishing, how long the winner keeps answering the announcer with
    /// `done`, in case its first `done` was lost.
    pub linger: Duration,
    /// How often the robot reports its mode, battery, resources and task on
    /// [`ROBOTS`](crate::protocol::ROBOTS) for watchers (it also reports each
    /// change at once); `None`: never.
    pub report_interval: Option<Duration>,
}

impl Default for AgentConfig {
    fn default() -> Self {
        AgentConfig {
            renew_interval: Duration::from_secs(1),
            renew_timeout: Duration::from_secs(3),
            award_grace: Duration::from_millis(500),
            low_battery: 0.2,
            battery_check: Duration::from_secs(1),
            drain_per_second: 0.0,
            linger: Duration::from_secs(3),
            report_interval: Some(Duration::from_secs(1)),
        }
    }
}
