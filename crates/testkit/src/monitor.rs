//! A monitor joined to a hub on a thread, and the override as its pages see it.

use std::time::{Duration, Instant};

use colony_monitor::{Monitor, MonitorConfig};
use serde_json::Value;

use crate::web::Ws;
use crate::HubOnThread;

/// A monitor joined to `hub`, on a free loopback port, needing its token.
pub fn monitor(hub: &HubOnThread) -> Monitor {
    Monitor::start(&MonitorConfig {
        hub: hub.addr.to_string(),
        bind: "127.0.0.1:0".into(),
        ..MonitorConfig::default()
    })
    .unwrap()
}

/// `path` on `m` with its token (`path` may have a query already).
pub fn with_token(m: &Monitor, path: &str) -> String {
    let sep = if path.contains('?') { '&' } else { '?' };
    format!("{path}{sep}token={}", m.token().expect("a token"))
}

/// A monitor joined to `hub` that drops pages and viewers as `liveness` says.
pub fn monitor_with(hub: &HubOnThread, liveness: colony_monitor::Liveness) -> Monitor {
    Monitor::start_with_liveness(
        &MonitorConfig {
            hub: hub.addr.to_string(),
            bind: "127.0.0.1:0".into(),
            ..MonitorConfig::default()
        },
        liveness,
    )
    .unwrap()
}

/// The override as a page sees it: the robots held, whether "take control of all" is in
/// force, whether the monitor has raised the hub's minimum priority, and that minimum as the
/// hub's newest status report gives it.
#[derive(Default, Clone, PartialEq)]
pub struct OverrideView {
    pub held: Vec<u64>,
    pub all: bool,
    pub min_raised: bool,
    pub hub_min: Option<i64>,
}

impl std::fmt::Debug for OverrideView {
    // A thousand held robots would bury the rest.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let shown: Vec<u64> = self.held.iter().copied().take(8).collect();
        write!(
            f,
            "{} held (first {shown:?}), all: {}, min raised: {}, hub minimum: {:?}",
            self.held.len(),
            self.all,
            self.min_raised,
            self.hub_min
        )
    }
}

impl OverrideView {
    pub fn update(&mut self, m: &Value) {
        if m["t"] == "world" {
            self.held = m["held"]
                .as_array()
                .map(|a| a.iter().filter_map(Value::as_u64).collect())
                .unwrap_or_default();
            self.all = m["all"] == true;
            self.min_raised = m["min_raised"] == true;
        } else if m["t"] == "hub" {
            self.hub_min = m["min_priority"].as_i64();
        }
    }

    /// Robots 5 and 6 held, all taken, and the hub's minimum at the override's priority.
    pub fn in_force(&self) -> bool {
        self.held.contains(&5)
            && self.held.contains(&6)
            && self.all
            && self.min_raised
            && self.hub_min == Some(10)
    }

    /// Nothing held, and the hub's minimum back below the override's priority.
    pub fn released(&self) -> bool {
        self.held.is_empty() && !self.all && !self.min_raised && self.hub_min.is_none_or(|m| m < 10)
    }
}

/// Reads `watcher` until its view of the override satisfies `want`, for at most `within`;
/// `holder`, if given, is read meanwhile too, so it answers its pings as a live page does.
pub fn watch_override(
    watcher: &mut Ws,
    mut holder: Option<&mut Ws>,
    view: &mut OverrideView,
    within: Duration,
    what: &str,
    want: impl Fn(&OverrideView) -> bool,
) {
    let deadline = Instant::now() + within;
    while Instant::now() < deadline {
        for m in watcher.pump(Duration::from_millis(100)) {
            view.update(&m);
        }
        if want(view) {
            return;
        }
        if let Some(h) = holder.as_deref_mut() {
            h.pump(Duration::from_millis(50));
        }
    }
    panic!("no {what} within {within:?}: {view:?}");
}
