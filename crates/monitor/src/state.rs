//! What the monitor knows, with no socket and no clock: packets and status
//! reports go in with the time they arrived, JSON snapshots and the
//! operator's radio commands come out.
//!
//! Every packet is read with [`colony_proto`]'s decoders (the viewer's `skim`, which skips and
//! counts a bad line); the monitor keeps no codec of its own. Its ideas, one module each:
//!
//! - [`world`]: the world as `vision` shows it (the parts of a big swarm's frame put back
//!   together: a frame is shown only once all its parts are in), the robots' intentions and cache
//!   points from `debug`, and sorting progress from `metrics`.
//! - [`hub`]: every channel with its rate (from the packet counts of two status reports) and its
//!   last packet, clients, drops, minimum priority; staleness: no word from the hub, or no vision,
//!   for [`STALE_AFTER`].
//! - [`operator`]: the operator's override: which robots are held and how each is driven
//!   (stopped, by keys, or steered to a point by [`steer()`]), and the hub's minimum priority for
//!   "take control of all".
//! - [`command`]: what the browser may ask, already checked, and why a request could not be done.
//! - [`forge`]: checking a packet the operator typed.

use std::time::{Duration, Instant};

use colony_proto::swarm::{self, DEBUG, METRICS, VISION};
use colony_proto::RADIO;
use colony_wire::{Packet, Request, StatusReport};
use serde::Serialize;

pub mod bodies;
pub mod command;
pub mod forge;
pub mod hub_view;
pub mod operator;
pub mod steer;
pub mod world_view;

pub use command::{Command, CommandError};
pub use forge::{check_forged, ForgeError};
pub use operator::{Mode, PageId, MAX_COORD, MAX_HELD, OVERRIDE_PRIORITY};
pub use steer::{steer, ARRIVED_CM};
pub use world_view::{Progress, WorldView};

use hub_view::HubView;
use operator::Override;

/// The channels the monitor always subscribes to.
pub const CORE_CHANNELS: [&str; 4] = [VISION, DEBUG, METRICS, RADIO];

/// With nothing heard for this long, the hub or the vision is shown as stale.
pub const STALE_AFTER: Duration = Duration::from_secs(2);
/// A world silent this long has ended (a finished run, a stopped simulator) rather than
/// stalled: the page says so and dims it instead of raising an alarm for ever.
pub const ENDED_AFTER: Duration = Duration::from_secs(10);

/// Where the world on `vision` stands, for the page.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum WorldPhase {
    /// Nothing was ever seen on `vision`: there is no world (a task board, a game), so no
    /// world panel and nothing to call stale.
    None,
    /// Vision is arriving.
    Live,
    /// Vision stopped for longer than [`STALE_AFTER`].
    Stale,
    /// Vision stopped for longer than [`ENDED_AFTER`].
    Ended,
}

/// Everything the monitor knows. Feed it with [`on_packet`](Self::on_packet),
/// [`on_status`](Self::on_status) and [`apply`](Self::apply); read it with
/// the snapshot methods and [`override_packets`](Self::override_packets).
#[derive(Debug)]
pub struct MonitorState {
    started: Instant,
    /// Wall-clock milliseconds since the Unix epoch at `started`.
    wall_start_ms: u64,
    world: WorldView,
    hub: HubView,
    operator: Override,
    bad_lines: u64,
}

/// The world as the page draws it (sent as JSON).
#[derive(Serialize)]
struct WorldJson<'a> {
    t: &'static str,
    now: u64,
    #[serde(flatten)]
    world: world_view::WorldJson<'a>,
    #[serde(flatten)]
    operator: operator::OverrideJson,
    hub_stale_since: Option<u64>,
    vision_stale_since: Option<u64>,
    world_phase: WorldPhase,
}

impl MonitorState {
    /// A monitor started at `now`, when the wall clock read `wall_ms` (Unix milliseconds).
    pub fn new(now: Instant, wall_ms: u64) -> MonitorState {
        MonitorState {
            started: now,
            wall_start_ms: wall_ms,
            world: WorldView::default(),
            hub: HubView::default(),
            operator: Override::default(),
            bad_lines: 0,
        }
    }

    fn wall(&self, t: Instant) -> u64 {
        self.wall_start_ms + t.saturating_duration_since(self.started).as_millis() as u64
    }

    /// Since when (wall-clock ms) `last` has been silent, if for longer than [`STALE_AFTER`]
    /// (never heard counts from the monitor's start).
    fn stale_since(&self, last: Option<Instant>, now: Instant) -> Option<u64> {
        let since = last.unwrap_or(self.started);
        (now.saturating_duration_since(since) > STALE_AFTER).then(|| self.wall(since))
    }

    /// The world: the newest complete frame, intentions, cache points, progress.
    pub fn world(&self) -> &WorldView {
        &self.world
    }

    /// The newest complete frame.
    pub fn frame(&self) -> &swarm::VisionFrame {
        self.world.frame()
    }

    /// Counts complete frames; changes whenever a new one is in.
    pub fn frame_version(&self) -> u64 {
        self.world.frame_version()
    }

    /// Frames dropped with some of their parts missing (never shown).
    pub fn frames_missing(&self) -> u64 {
        self.world.frames_missing()
    }

    /// The held robots and how each is driven.
    pub fn held(&self) -> &std::collections::BTreeMap<u32, Mode> {
        self.operator.held()
    }

    /// Whether "take control of all" is in force.
    pub fn all_held(&self) -> bool {
        self.operator.all_held()
    }

    /// Lines in received packets that did not read as what their channel carries.
    pub fn bad_lines(&self) -> u64 {
        self.bad_lines
    }

    /// The last packet received on a channel (as text, possibly cut short).
    pub fn last_packet(&self, channel: &str) -> Option<&str> {
        self.hub.last_packet(channel)
    }

    /// Packets per second on a channel, from the last two status reports.
    pub fn rate(&self, channel: &str) -> Option<f64> {
        self.hub.rate(channel)
    }

    /// The newest status report.
    pub fn status(&self) -> Option<&StatusReport> {
        self.hub.status()
    }

    /// Since when (wall-clock ms) the hub has been silent, if for longer than [`STALE_AFTER`].
    pub fn hub_stale_since(&self, now: Instant) -> Option<u64> {
        self.stale_since(self.hub.last_heard(), now)
    }

    /// Since when (wall-clock ms) no vision has arrived, if for longer than [`STALE_AFTER`]
    /// after some had (a monitor that never saw a world has none to be stale).
    pub fn vision_stale_since(&self, now: Instant) -> Option<u64> {
        self.world.vision_at()?;
        self.stale_since(self.world.vision_at(), now)
    }

    /// Whether a world was ever seen, and how long ago it was last heard from.
    pub fn world_phase(&self, now: Instant) -> WorldPhase {
        match self.world.vision_at() {
            None => WorldPhase::None,
            Some(t) => {
                let idle = now.saturating_duration_since(t);
                if idle > ENDED_AFTER {
                    WorldPhase::Ended
                } else if idle > STALE_AFTER {
                    WorldPhase::Stale
                } else {
                    WorldPhase::Live
                }
            }
        }
    }

    /// Takes in a packet received at `now` on a subscribed channel.
    pub fn on_packet(&mut self, now: Instant, packet: &Packet<'_>) {
        self.hub.on_packet(now, packet);
        if packet.subject_count() != 1 {
            return;
        }
        let bad = if packet.has_subject(VISION) {
            let (bad, frame) = self.world.on_vision(now, packet);
            if frame {
                self.operator.on_frame(self.world.frame());
            }
            bad
        } else if packet.has_subject(DEBUG) {
            self.world.on_debug(packet)
        } else if packet.has_subject(METRICS) {
            self.world.on_metrics(packet)
        } else {
            0
        };
        self.bad_lines += bad;
    }

    /// Takes in a status report received at `now`: rates, channels, and the
    /// minimum-priority step of "take control of all".
    pub fn on_status(&mut self, now: Instant, report: StatusReport) {
        self.operator
            .on_min_priority(now, report.min_priority, report.lease_ms);
        self.hub.on_status(now, report);
    }

    /// Subjects seen in status reports, for the bridge to subscribe to so
    /// their last packet can be shown (the hub and the overflow bucket excepted).
    pub fn channels_seen(&self) -> Vec<String> {
        self.hub.channels_seen()
    }

    /// Requests for the hub that the override wants sent (minimum priority).
    pub fn take_requests(&mut self) -> Vec<Request> {
        self.operator.take_requests()
    }

    /// Whether a status report is wanted now (to learn the minimum priority).
    pub fn wants_status(&self) -> bool {
        self.operator.wants_status()
    }

    /// Carries out a checked request from the browser page `page` at `now`; the answer
    /// (or the reason it could not be done) is for the operator to read.
    /// Publishing is the bridge's part: here it only answers.
    pub fn apply(
        &mut self,
        now: Instant,
        page: PageId,
        command: Command,
    ) -> Result<String, CommandError> {
        self.operator.apply(now, page, command, self.world.frame())
    }

    /// Page `page` went away: what it held is let go (see [`operator`]); how many robots.
    pub fn page_closed(&mut self, page: PageId) -> usize {
        self.operator.page_closed(page)
    }

    /// Which page holds robot `id`, if it is held.
    pub fn holder(&self, id: u32) -> Option<PageId> {
        self.operator.holder(id)
    }

    /// Time passes: requests that are due (refreshing a raised minimum priority) are queued
    /// for [`take_requests`](Self::take_requests).
    pub fn poll(&mut self, now: Instant) {
        self.operator.poll(now);
    }

    /// When [`poll`](Self::poll) next has something to do, if ever.
    pub fn next_deadline(&self) -> Option<Instant> {
        self.operator.next_deadline()
    }

    /// Lets every robot go and puts the hub's minimum priority back (when the monitor stops).
    pub fn shutdown(&mut self) -> Vec<Request> {
        self.operator.shutdown()
    }

    /// Each held robot's command at `now`.
    pub fn override_commands(&mut self, now: Instant) -> Vec<colony_proto::RadioCommand> {
        self.operator.commands(now, self.world.frame())
    }

    /// The radio packets that hold the held robots at `now`, at [`OVERRIDE_PRIORITY`].
    pub fn override_packets(&mut self, now: Instant) -> Vec<Vec<u8>> {
        self.operator.packets(now, self.world.frame())
    }

    /// The world as JSON for the page.
    pub fn world_json(&self, now: Instant) -> String {
        let w = WorldJson {
            t: "world",
            now: self.wall(now),
            world: self.world.json(),
            operator: self.operator.json(),
            hub_stale_since: self.hub_stale_since(now),
            vision_stale_since: self.vision_stale_since(now),
            world_phase: self.world_phase(now),
        };
        serde_json::to_string(&w).unwrap_or_else(|_| "{}".into())
    }

    /// The newest whole frame's robots and pucks for the page ([`bodies`]).
    pub fn world_bodies(&self) -> Vec<u8> {
        self.world.bodies()
    }

    /// The hub view as JSON for the page.
    pub fn hub_json(&self, now: Instant) -> String {
        let h = self
            .hub
            .json(now, self.wall(now), self.bad_lines, self.world.pc_series());
        serde_json::to_string(&h).unwrap_or_else(|_| "{}".into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_proto::swarm::Arena;
    use colony_proto::RadioCommand;
    use colony_wire::{ChannelInfo, Priority};

    fn parse(text: &str) -> Packet<'_> {
        Packet::parse(text.as_bytes()).unwrap()
    }

    fn state() -> (MonitorState, Instant) {
        let t0 = Instant::now();
        (MonitorState::new(t0, 1_000_000), t0)
    }

    fn ms(t0: Instant, ms: u64) -> Instant {
        t0 + Duration::from_millis(ms)
    }

    /// The page most tests speak for.
    const PAGE: PageId = PageId(1);

    const ONE_PART: &str = "@ <vision> 20\nstep n 7 part 0 parts 1\narena width 187 height 187 corner 15\nsizes robot_length 12.5 robot_width 10.8 gripper_radius 3.6 puck_diameter 6.3\nrobot id 1 x 10 y 0 theta 0 carrying 3\nrobot id 0 x -5 y 2.5 theta 1.57\npuck id 3 kind 1 x 17 y 0\n";

    #[test]
    fn a_one_part_frame_shows_robots_pucks_and_the_arena() {
        let (mut s, t0) = state();
        s.on_packet(ms(t0, 10), &parse(ONE_PART));
        let f = s.frame();
        assert_eq!((f.step, f.robots.len(), f.pucks.len()), (7, 2, 1));
        assert_eq!(f.robots[0].id, 0, "sorted by id");
        assert_eq!(f.robots[1].carrying, Some(3));
        assert_eq!(
            s.world().arena(),
            Some(Arena {
                width: 187.0,
                height: 187.0,
                corner: 15.0
            })
        );
        assert_eq!(s.frame_version(), 1);
        assert_eq!(s.bad_lines(), 0);
    }

    #[test]
    fn a_split_frame_is_shown_only_once_every_part_is_in() {
        let (mut s, t0) = state();
        let p1 = "@ <vision> 0\nstep n 9 part 1 parts 2\npuck id 0 kind 0 x 1 y 1\n";
        let p0 = "@ <vision> 0\nstep n 9 part 0 parts 2\nrobot id 0 x 0 y 0 theta 0\n";
        s.on_packet(ms(t0, 1), &parse(p1));
        assert_eq!(s.frame_version(), 0);
        s.on_packet(ms(t0, 2), &parse(p1));
        assert_eq!(s.frame_version(), 0, "a duplicate part completes nothing");
        s.on_packet(ms(t0, 3), &parse(p0));
        assert_eq!(s.frame_version(), 1);
        assert_eq!((s.frame().robots.len(), s.frame().pucks.len()), (1, 1));
        // A lost part: the next step's parts replace the unfinished frame.
        s.on_packet(
            ms(t0, 4),
            &parse("@ <vision> 0\nstep n 10 part 0 parts 2\nrobot id 0 x 5 y 0 theta 0\n"),
        );
        s.on_packet(
            ms(t0, 5),
            &parse("@ <vision> 0\nstep n 11 part 1 parts 2\npuck id 0 kind 0 x 2 y 2\n"),
        );
        s.on_packet(
            ms(t0, 6),
            &parse("@ <vision> 0\nstep n 11 part 0 parts 2\nrobot id 0 x 6 y 0 theta 0\n"),
        );
        assert_eq!(s.frame().step, 11);
        assert_eq!(s.frame().robots[0].pose.x, 6.0);
        assert_eq!(s.frame().pucks[0].pos.x, 2.0);
        // Step 10 lost its second part: never shown, and counted for the page.
        assert_eq!((s.frame_version(), s.frames_missing()), (2, 1));
        let json: serde_json::Value = serde_json::from_str(&s.world_json(ms(t0, 7))).unwrap();
        assert_eq!(
            (&json["frames"], &json["frames_missing"], &json["nrobots"]),
            (&2.into(), &1.into(), &1.into())
        );
        let bodies = s.world_bodies();
        assert_eq!(&bodies[..4], bodies::MAGIC);
        assert_eq!(
            bodies.len(),
            bodies::HEADER + 20 + 13,
            "one robot, one puck"
        );
    }

    #[test]
    fn nonsense_in_vision_lines_is_counted_and_skipped() {
        let (mut s, t0) = state();
        s.on_packet(
            t0,
            &parse("@ <vision> 0\nstep n 1\nrobot id -4 x 0 y 0 theta 0\nrobot id 2 x nan y 0 theta 0\npuck id 1 kind 0 x 1\nrobot id 3 x 1 y 2 theta 0\n"),
        );
        assert_eq!(s.frame().robots.len(), 1);
        assert_eq!(s.bad_lines(), 3);
        s.on_packet(
            t0,
            &parse("@ <vision> 0\nstep n 2 part 5 parts 2\nrobot id 3 x 1 y 2 theta 0\n"),
        );
        s.on_packet(t0, &parse("@ <vision> 0\nstep n x\n"));
        s.on_packet(t0, &parse("@ <vision> 0\nball x 1\n"));
        assert_eq!(s.frame().step, 1);
        assert_eq!(s.bad_lines(), 6);
    }

    #[test]
    fn bad_debug_and_metrics_lines_are_counted_too() {
        let (mut s, t0) = state();
        s.on_packet(
            t0,
            &parse("@ <debug> 0\nrobot id -1 state A\ncache id 1 kind 0 x inf y 0\n"),
        );
        s.on_packet(t0, &parse("@ <metrics> 0\nsort step 1 pc nan\n"));
        s.on_packet(t0, &parse("@ <metrics> 0\nother x 1\n"));
        assert_eq!(s.bad_lines(), 3);
    }

    fn report(uptime_ms: u64, vision_packets: u64, min: i32) -> StatusReport {
        StatusReport {
            uptime_ms,
            lease_ms: 10_000,
            min_priority: Priority(min),
            client_count: 1,
            clients: vec![],
            channels: vec![
                ChannelInfo {
                    subjects: "vision".into(),
                    packets: vision_packets,
                    bytes: vision_packets * 100,
                },
                ChannelInfo {
                    subjects: "a b".into(),
                    packets: 1,
                    bytes: 10,
                },
            ],
            drops: vec![("below min priority".into(), 3)],
            truncated: false,
        }
    }

    #[test]
    fn rates_come_from_two_status_reports_and_restart_with_the_hub() {
        let (mut s, t0) = state();
        s.on_status(t0, report(1000, 100, i32::MIN));
        assert_eq!(s.rate("vision"), None);
        s.on_status(ms(t0, 1000), report(3000, 160, i32::MIN));
        assert_eq!(s.rate("vision"), Some(30.0));
        s.on_status(ms(t0, 2000), report(500, 10, i32::MIN));
        assert_eq!(s.rate("vision"), None, "a restarted hub has no rate yet");
        assert_eq!(s.channels_seen(), ["a", "b", "vision"]);
        let json: serde_json::Value = serde_json::from_str(&s.hub_json(ms(t0, 2000))).unwrap();
        assert_eq!(json["t"], "hub");
        assert_eq!(json["drops"][0][0], "below min priority");
        assert_eq!(json["min_priority"], serde_json::Value::Null);
    }

    #[test]
    fn the_last_packet_of_each_channel_is_kept_readable_and_short() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse("@ <test.chan> 3\nhello who \"operator\"\n"));
        assert_eq!(
            s.last_packet("test.chan"),
            Some("@ <test.chan> 3\nhello who \"operator\"\n")
        );
        let big = format!("@ <big> 0\n{}", "x v é\n".repeat(1000));
        s.on_packet(t0, &parse(&big));
        let kept = s.last_packet("big").unwrap();
        assert!(kept.len() <= hub_view::LAST_TEXT_LIMIT && kept.starts_with("@ <big> 0"));
        s.on_packet(t0, &parse("@ <a> <b> 0\nx v 1\n"));
        assert!(s.last_packet("a b").is_some());
    }

    #[test]
    fn with_no_world_ever_seen_nothing_is_stale_and_a_silent_world_ends() {
        let (mut s, t0) = state();
        s.on_status(ms(t0, 0), report(1, 0, 0));
        assert_eq!(
            s.vision_stale_since(ms(t0, 9000)),
            None,
            "no world: nothing to be stale"
        );
        assert_eq!(s.world_phase(ms(t0, 9000)), WorldPhase::None);
        let json: serde_json::Value = serde_json::from_str(&s.world_json(ms(t0, 9000))).unwrap();
        assert_eq!(json["world_phase"], "none");
        assert_eq!(json["vision_stale_since"], serde_json::Value::Null);
        s.on_packet(ms(t0, 10_000), &parse(ONE_PART));
        assert_eq!(s.world_phase(ms(t0, 11_000)), WorldPhase::Live);
        assert_eq!(s.world_phase(ms(t0, 13_000)), WorldPhase::Stale);
        assert_eq!(s.world_phase(ms(t0, 20_500)), WorldPhase::Ended);
        let json: serde_json::Value = serde_json::from_str(&s.world_json(ms(t0, 20_500))).unwrap();
        assert_eq!(json["world_phase"], "ended");
        assert_eq!(
            json["vision_stale_since"], 1_010_000,
            "ended says since when"
        );
        s.on_packet(ms(t0, 21_000), &parse(ONE_PART));
        assert_eq!(
            s.world_phase(ms(t0, 21_000)),
            WorldPhase::Live,
            "a new run is live again"
        );
    }

    #[test]
    fn hub_and_vision_go_stale_after_two_silent_seconds_and_recover() {
        let (mut s, t0) = state();
        assert_eq!(s.hub_stale_since(ms(t0, 1000)), None);
        assert_eq!(s.hub_stale_since(ms(t0, 2500)), Some(1_000_000));
        s.on_packet(ms(t0, 3000), &parse(ONE_PART));
        assert_eq!(s.hub_stale_since(ms(t0, 3100)), None);
        assert_eq!(s.vision_stale_since(ms(t0, 3100)), None);
        assert_eq!(s.vision_stale_since(ms(t0, 5100)), Some(1_003_000));
        s.on_status(ms(t0, 5000), report(1, 1, 0));
        assert_eq!(s.hub_stale_since(ms(t0, 5100)), None);
        assert!(s.vision_stale_since(ms(t0, 5100)).is_some());
        let json: serde_json::Value = serde_json::from_str(&s.world_json(ms(t0, 5100))).unwrap();
        assert_eq!(json["vision_stale_since"], 1_003_000);
        assert_eq!(json["hub_stale_since"], serde_json::Value::Null);
    }

    #[test]
    fn a_held_robot_is_stopped_driven_or_steered_and_released() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        assert!(
            s.override_packets(t0).is_empty(),
            "nobody held: nothing sent"
        );
        s.apply(t0, PAGE, Command::Take(vec![1])).unwrap();
        assert_eq!(s.override_commands(t0), [RadioCommand::new(1, 0.0, 0.0)]);
        s.apply(
            t0,
            PAGE,
            Command::Drive {
                ids: None,
                forward: 0.5,
                turn: -0.2,
            },
        )
        .unwrap();
        assert_eq!(
            s.override_commands(ms(t0, 100)),
            [RadioCommand::new(1, 0.5, -0.2)]
        );
        assert_eq!(
            s.override_commands(ms(t0, 600)),
            [RadioCommand::new(1, 0.0, 0.0)],
            "key commands lapse"
        );
        // Robot 1 is at (10, 0) facing +x: a point ahead means drive.
        s.apply(
            t0,
            PAGE,
            Command::Goto {
                ids: Some(vec![1]),
                x: 60.0,
                y: 0.0,
            },
        )
        .unwrap();
        let cmds = s.override_commands(t0);
        assert_eq!(cmds[0].robot, 1);
        assert!(cmds[0].wheels.forward > 0.9);
        let packets = s.override_packets(t0);
        let p = Packet::parse(&packets[0]).unwrap();
        assert_eq!(p.priority(), Priority(OVERRIDE_PRIORITY));
        assert!(p.has_subject("radio"));
        assert_eq!(p.line("cmd").unwrap().i64("id").unwrap(), 1);
        assert_eq!(colony_proto::radio::decode(&p).unwrap()[0].robot, 1);
        let e = s
            .apply(
                t0,
                PAGE,
                Command::Goto {
                    ids: Some(vec![0]),
                    x: 0.0,
                    y: 0.0,
                },
            )
            .unwrap_err();
        assert_eq!(e.to_string(), "no held robot to send: take control first");
        s.apply(t0, PAGE, Command::Release(vec![1])).unwrap();
        assert!(
            s.override_packets(t0).is_empty(),
            "released: the AI has it back"
        );
        let e = s.apply(t0, PAGE, Command::Release(vec![1])).unwrap_err();
        assert_eq!(e.to_string(), "robot 1 not held");
        assert!(
            s.take_requests().is_empty(),
            "single robots leave the hub alone"
        );
    }

    #[test]
    fn several_robots_sent_to_one_point_are_spread_around_it() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        s.apply(t0, PAGE, Command::Take(vec![0, 1])).unwrap();
        s.apply(
            t0,
            PAGE,
            Command::Goto {
                ids: None,
                x: 0.0,
                y: 0.0,
            },
        )
        .unwrap();
        let targets: Vec<_> = s.held().values().copied().collect();
        assert_ne!(targets[0], targets[1]);
    }

    #[test]
    fn taking_all_raises_the_minimum_priority_and_release_restores_the_old_one() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        s.apply(t0, PAGE, Command::TakeAll).unwrap();
        assert_eq!(s.held().len(), 2);
        assert!(s.wants_status());
        assert!(
            s.take_requests().is_empty(),
            "not before the old value is known"
        );
        s.on_status(t0, report(1, 1, 3));
        assert_eq!(
            s.take_requests(),
            [Request::MinPriority(Priority(OVERRIDE_PRIORITY))]
        );
        // The hub restarted and forgot: raise it again.
        s.on_status(t0, report(1, 1, i32::MIN));
        assert_eq!(
            s.take_requests(),
            [Request::MinPriority(Priority(OVERRIDE_PRIORITY))]
        );
        s.apply(t0, PAGE, Command::ReleaseAll).unwrap();
        assert_eq!(s.take_requests(), [Request::MinPriority(Priority(3))]);
        assert!(s.held().is_empty() && !s.all_held());
        // Already high: left alone, and nothing to restore.
        s.apply(t0, PAGE, Command::TakeAll).unwrap();
        s.on_status(t0, report(1, 1, 50));
        assert!(s.take_requests().is_empty());
        assert!(s.shutdown().is_empty());
    }

    #[test]
    fn closing_the_page_that_took_robots_releases_them_and_no_other_pages() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        let (a, b) = (PageId(1), PageId(2));
        s.apply(t0, a, Command::Take(vec![1])).unwrap();
        s.apply(t0, b, Command::Take(vec![0])).unwrap();
        assert_eq!((s.holder(1), s.holder(0)), (Some(a), Some(b)));
        assert_eq!(s.page_closed(PageId(3)), 0, "a page that held nothing");
        assert_eq!(s.held().len(), 2);
        assert_eq!(s.page_closed(a), 1);
        assert_eq!(s.held().keys().copied().collect::<Vec<_>>(), [0]);
        assert_eq!(
            s.override_commands(t0),
            [RadioCommand::new(0, 0.0, 0.0)],
            "only page b's robot is still commanded"
        );
        // Taking a robot another page holds makes it the taker's.
        s.apply(t0, a, Command::Take(vec![0])).unwrap();
        assert_eq!(s.page_closed(b), 0);
        assert_eq!(s.page_closed(a), 1);
        assert!(s.held().is_empty() && s.override_packets(t0).is_empty());
        assert!(
            s.take_requests().is_empty(),
            "single robots leave the hub alone"
        );
    }

    #[test]
    fn closing_the_page_that_took_all_restores_the_minimum_priority() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        let (a, b) = (PageId(1), PageId(2));
        s.apply(t0, a, Command::TakeAll).unwrap();
        s.on_status(t0, report(1, 1, 3));
        assert_eq!(
            s.take_requests(),
            [Request::MinPriority(Priority(OVERRIDE_PRIORITY))]
        );
        // Another page watching (or driving) does not end it when it closes.
        s.apply(
            t0,
            b,
            Command::Drive {
                ids: None,
                forward: 1.0,
                turn: 0.0,
            },
        )
        .unwrap();
        assert_eq!(s.page_closed(b), 0);
        assert!(s.all_held() && s.take_requests().is_empty());
        assert_eq!(s.page_closed(a), 2);
        assert!(s.held().is_empty() && !s.all_held());
        assert_eq!(
            s.take_requests(),
            [Request::MinPriority(Priority(3))],
            "as if release had been pressed"
        );
        // And new robots are no longer taken.
        s.on_packet(t0, &parse(ONE_PART));
        assert!(s.held().is_empty());
        assert!(s.shutdown().is_empty(), "nothing left to restore");
    }

    #[test]
    fn a_raised_minimum_priority_is_sent_again_every_third_of_the_lease() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        s.apply(t0, PAGE, Command::TakeAll).unwrap();
        assert_eq!(s.next_deadline(), None, "nothing raised yet");
        let mut r = report(1, 1, 0);
        r.lease_ms = 3_000;
        s.on_status(t0, r);
        assert_eq!(s.take_requests().len(), 1);
        assert_eq!(s.next_deadline(), Some(ms(t0, 1000)));
        s.poll(ms(t0, 900));
        assert!(s.take_requests().is_empty(), "not due yet");
        s.poll(ms(t0, 1000));
        assert_eq!(
            s.take_requests(),
            [Request::MinPriority(Priority(OVERRIDE_PRIORITY))]
        );
        assert_eq!(s.next_deadline(), Some(ms(t0, 2000)));
        s.poll(ms(t0, 1900));
        assert!(s.take_requests().is_empty());
        // A long lease is still refreshed every 3 s at most.
        let mut r = report(2, 1, OVERRIDE_PRIORITY);
        r.lease_ms = 60_000;
        s.on_status(ms(t0, 1900), r);
        assert_eq!(s.next_deadline(), Some(ms(t0, 4000)));
        s.apply(ms(t0, 2000), PAGE, Command::ReleaseAll).unwrap();
        assert_eq!(s.take_requests(), [Request::MinPriority(Priority(0))]);
        assert_eq!(s.next_deadline(), None, "released: no more refreshes");
        s.poll(ms(t0, 10_000));
        assert!(s.take_requests().is_empty());
    }

    #[test]
    fn robots_appearing_while_all_are_held_are_held_too() {
        let (mut s, t0) = state();
        s.apply(t0, PAGE, Command::TakeAll).unwrap();
        assert!(s.held().is_empty());
        s.on_packet(t0, &parse(ONE_PART));
        assert_eq!(s.held().len(), 2);
        s.on_status(t0, report(1, 1, i32::MIN));
        s.take_requests();
        assert_eq!(
            s.shutdown(),
            [Request::MinPriority(Priority(i32::MIN))],
            "stopping the monitor lets go"
        );
    }

    #[test]
    fn the_world_snapshot_is_compact_json() {
        let (mut s, t0) = state();
        s.on_packet(t0, &parse(ONE_PART));
        s.on_packet(t0, &parse("@ <debug> 0\nrobot id 0 state \"SEARCH\"\n"));
        s.on_packet(t0, &parse("@ <debug> 0\ncache id 0 kind 2 x 1.5 y -2\n"));
        s.on_packet(t0, &parse("@ <metrics> 0\nsort step 7 pc 12.5\n"));
        s.apply(t0, PAGE, Command::Take(vec![0])).unwrap();
        s.apply(
            t0,
            PAGE,
            Command::Goto {
                ids: None,
                x: 5.0,
                y: 6.0,
            },
        )
        .unwrap();
        let text = s.world_json(t0);
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(json["t"], "world");
        assert_eq!(json["step"], 7);
        assert_eq!(json["robots"][1], serde_json::json!([1, 10.0, 0.0, 0.0, 3]));
        assert_eq!(json["robots"][0][4], -1);
        assert_eq!(json["pucks"][0], serde_json::json!([3, 1, 17.0, 0.0]));
        assert_eq!(
            json["intents"][0],
            serde_json::json!([0, "SEARCH", null, null])
        );
        assert_eq!(json["caches"][0], serde_json::json!([0, 2, 1.5, -2.0]));
        assert_eq!(json["pc"], serde_json::json!([7, 12.5]));
        assert_eq!(json["held"], serde_json::json!([0]));
        assert_eq!(json["targets"], serde_json::json!([[0, 5.0, 6.0]]));
        assert_eq!(json["arena"]["corner"], 15.0);
        assert_eq!(json["sizes"]["gripper_radius"], 3.6);
        let keys: Vec<&str> = json
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .collect();
        assert!(text.starts_with(r#"{"t":"world","now":"#), "{text}");
        // The 19 keys of old, and the frame's counts: nrobots, npucks, frames, frames_missing.
        assert_eq!(keys.len(), 23, "{keys:?}");
        assert_eq!(
            (&json["nrobots"], &json["npucks"], &json["frames_missing"]),
            (&2.into(), &1.into(), &0.into())
        );
        // No box and no goal in a sorting arena.
        assert_eq!(json["boxes"], serde_json::json!([]));
        assert_eq!(json["goal"], serde_json::Value::Null);
        s.on_packet(
            t0,
            &parse("@ <vision> 20\nstep n 8\nbox id 0 x 1 y 2 theta 0.5 length 60 width 8\ngoal x 3 y 4\n"),
        );
        let json: serde_json::Value = serde_json::from_str(&s.world_json(t0)).unwrap();
        assert_eq!(
            json["boxes"][0],
            serde_json::json!([0, 1.0, 2.0, 0.5, 60.0, 8.0])
        );
        assert_eq!(json["goal"], serde_json::json!([3.0, 4.0]));
    }
}
