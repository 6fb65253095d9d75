//! What a long-term run reports: the summary and the event log.

use std::collections::BTreeMap;

use serde::Serialize;

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
    /// Of those, tasks no robot of the roster has the resources for.
    pub unachievable_no_robot: u64,
    /// Of those, tasks whose capable robots were all charging (or on the way).
    pub unachievable_charging: u64,
    /// Of those, tasks whose capable robots had all failed (or lay flat).
    pub unachievable_failed: u64,
    /// Of those, tasks whose capable robots were busy (or some busy and the
    /// rest charging or failed, or too low on battery to bid).
    pub unachievable_busy: u64,
    /// Requests the user agent gave up on.
    pub gave_up: u64,
    /// Achievable requests given up.
    pub gave_up_achievable: u64,
    /// Requests still open (waiting, in an auction or at work) when the hours ran out.
    pub open_at_end: u64,
    /// Trips to a charger.
    pub recharges: u64,
    /// Failures injected.
    pub failures: u64,
    /// Trips a robot ended short of its target because it made no headway
    /// (a crowded charger, a place taken by a robot at work).
    pub stuck_arrivals: u64,
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
