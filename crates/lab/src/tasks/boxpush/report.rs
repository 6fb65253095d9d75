//! What a box-pushing run reports: the summary, the box's track, the events.

use colony_proto::Pose;
use serde::Serialize;

/// How a run went.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct BoxPushReport {
    /// The box reached the goal.
    pub reached: bool,
    /// When (or when the run stopped), s.
    pub time_s: f64,
    /// The box's centre's distance from the goal at the end, cm.
    pub final_distance_cm: f64,
    /// Pushing tasks announced.
    pub announced: u64,
    /// Pushes finished, by task: left, right.
    pub pushes_left: u64,
    /// See `pushes_left`.
    pub pushes_right: u64,
    /// Pushes finished by each pusher.
    pub pushes_by: Vec<u64>,
    /// Push tasks no pusher could take.
    pub unachievable: u64,
    /// Push tasks auctioned again after their pusher failed.
    pub reallocated: u64,
    /// Times the pusher doing a push changed from the one before it on that end.
    pub role_swaps: u64,
    /// Packets published.
    pub messages: u64,
}

/// A run: its report, and the box's pose each second.
#[derive(Debug, Clone)]
pub struct BoxPushOutcome {
    /// The summary.
    pub report: BoxPushReport,
    /// Time (s) and box pose, once a second.
    pub track: Vec<(f64, Pose)>,
    /// Notable events as text, with their time.
    pub events: Vec<(f64, String)>,
}

impl BoxPushReport {
    /// The summary as pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}

impl BoxPushOutcome {
    /// The box's track as CSV.
    pub fn track_csv(&self) -> String {
        let mut out = String::from("time_s,x,y,theta\n");
        for (t, p) in &self.track {
            out.push_str(&format!("{t:.1},{:.2},{:.2},{:.4}\n", p.x, p.y, p.theta));
        }
        out
    }
}
