//! What the spy knows, with no socket, no terminal and no clock: every channel with its rate,
//! bandwidth, priority mix and last packet; the open channel's numeric fields over time; what
//! the hub's status reports say was published, to tell packets the spy missed; and where the
//! person looking is (the selected channel, the open one, the chosen field).
//!
//! Time is an argument everywhere, as a [`Duration`] since an origin of the caller's choosing:
//! the spy's start when it taps a hub, the log's first record when it plays a log (so a log's
//! rates are its recorded rates, whatever the playing speed).

use std::collections::{BTreeMap, VecDeque};
use std::ops::Bound;
use std::time::Duration;

use colony_client::rate::RateWindow;
use colony_wire::{Packet, Priority, StatusReport};

use super::fields::{self, printable};
use super::missed::Missed;

/// Channels tracked at most (the hub itself counts at most 1024); packets on more are counted
/// apart.
pub const MAX_CHANNELS: usize = 1024;
/// The longest last packet kept per channel; the open channel keeps its last packet whole.
pub const LAST_KEEP: usize = 16 * 1024;
/// Distinct priorities counted per channel; the rest are counted together.
pub const MAX_PRIORITIES: usize = 4;
/// Numeric fields of the open channel followed at most...
pub const MAX_SERIES: usize = 256;
/// ...and points kept per field.
pub const MAX_POINTS: usize = 600;

/// The longest filter typed after `/`, in characters.
pub const MAX_FILTER: usize = 64;

/// A key, as the spy understands it (the terminal's keys are mapped onto these).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Key {
    Up,
    Down,
    PageUp,
    PageDown,
    /// Home: the first channel or field; with a log, back to its start.
    Home,
    /// `g`: the first channel or field.
    Top,
    End,
    /// Enter: open the selected channel (keep the filter, while typing one).
    Open,
    /// Tab: the next numeric field.
    Next,
    /// Shift-Tab: the previous numeric field.
    Previous,
    /// Left: with a log, 10 s back; else the previous numeric field.
    Left,
    /// Right: with a log, 10 s on; else the next numeric field.
    Right,
    /// `/`: type a filter of the channels.
    Search,
    /// A character typed into the filter.
    Char(char),
    /// Backspace while typing the filter.
    Erase,
    /// Space: pause a log, or freeze the view of a hub; again, go on.
    Pause,
    /// Esc, `q` or Backspace: clear the filter (Esc while typing one), back to the table, or
    /// quit from it.
    Back,
    /// Ctrl-C: quit from anywhere.
    Quit,
}

/// What a key asks of the program around the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    Continue,
    Quit,
    /// Move a log's clock (only a log's spy asks this).
    Seek(Seek),
}

/// Where a seek moves a log's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Seek {
    /// 10 s on, or to the end.
    Forward,
    /// 10 s back, or to the start.
    Back,
    /// To the log's start.
    Start,
}

/// How many packets of each priority a channel carried.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PriorityMix {
    /// The first [`MAX_PRIORITIES`] priorities seen, with their counts.
    pub counts: Vec<(Priority, u64)>,
    /// Packets of any other priority.
    pub others: u64,
}

impl PriorityMix {
    fn add(&mut self, priority: Priority) {
        if let Some(c) = self.counts.iter_mut().find(|(p, _)| *p == priority) {
            c.1 += 1;
        } else if self.counts.len() < MAX_PRIORITIES {
            self.counts.push((priority, 1));
            self.counts.sort_unstable_by_key(|(p, _)| *p);
        } else {
            self.others += 1;
        }
    }

    /// `0` when one priority carries everything, else each with its share (`0:90% 10:10%`),
    /// lowest first, and `+5%` for the priorities not counted apart.
    pub fn summary(&self) -> String {
        let total: u64 = self.counts.iter().map(|c| c.1).sum::<u64>() + self.others;
        match self.counts.as_slice() {
            [] => String::new(),
            [(p, _)] if self.others == 0 => p.to_string(),
            all => {
                let pct = |n: u64| (n as f64 * 100.0 / total as f64).round();
                let mut parts: Vec<String> = all
                    .iter()
                    .map(|(p, n)| format!("{p}:{}%", pct(*n)))
                    .collect();
                if self.others > 0 {
                    parts.push(format!("+{}%", pct(self.others)));
                }
                parts.join(" ")
            }
        }
    }
}

/// One channel (or subject set, its subjects joined by blanks, as the hub's status names it).
#[derive(Debug, Clone)]
pub struct Channel {
    rate: RateWindow,
    /// Packets and bytes seen since the spy started.
    pub packets: u64,
    pub bytes: u64,
    pub priorities: PriorityMix,
    /// When the last packet came.
    pub last_at: Option<Duration>,
    /// The last packet's text, cut to [`LAST_KEEP`] bytes unless the channel is open.
    pub last: String,
    /// The last packet's whole length, in bytes.
    pub last_len: usize,
}

impl Channel {
    fn new(window: Duration) -> Channel {
        Channel {
            rate: RateWindow::new(window),
            packets: 0,
            bytes: 0,
            priorities: PriorityMix::default(),
            last_at: None,
            last: String::new(),
            last_len: 0,
        }
    }

    /// Packets and bytes per second over the window ending at `now`.
    pub fn rates(&self, now: Duration) -> Option<(f64, f64)> {
        self.rate.rates(now)
    }

    /// The last packet's first body line (or its header, for a packet of none).
    pub fn preview(&self) -> &str {
        let mut lines = self.last.lines();
        let header = lines.next().unwrap_or_default();
        lines.next().unwrap_or(header)
    }

    /// Whether the last packet was kept whole.
    pub fn last_whole(&self) -> bool {
        self.last.len() == self.last_len
    }
}

/// Whether this spy taps the hub, as the hub's status report says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tap {
    /// No report has named this spy yet.
    Unknown,
    Tapping,
    /// The hub holds the spy's lease but refused the tap (too many clients tap).
    Refused,
}

/// Where the packets come from, and how that goes; the program around the model keeps it
/// up to date.
#[derive(Debug, Clone, PartialEq)]
pub enum Feed {
    /// A live hub.
    Hub { addr: String, state: HubLink },
    /// A traffic log, played at `speed` times its recorded pace.
    Log {
        file: String,
        speed: f64,
        state: LogState,
    },
}

/// How the spy's link to a hub is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum HubLink {
    /// Nothing heard yet.
    Waiting,
    Alive,
    Unreachable {
        silent_for: Duration,
    },
    /// The socket fails (a route gone, an interface down), as it said.
    Failing(String),
}

/// Where a log's playing is.
#[derive(Debug, Clone, PartialEq)]
pub enum LogState {
    Playing,
    /// Every record was played (the clock stops at the last one); with what a crash cut
    /// short of the log, if anything.
    Ended(Option<String>),
    /// The log could not be read further; what was read is shown.
    Failed(String),
}

/// The channel view's state: which channel, which field is plotted, and the fields' history.
#[derive(Debug, Clone)]
pub struct OpenChannel {
    pub name: String,
    /// The key of the chosen numeric field ([`fields::FieldRow::key`]).
    pub field: Option<String>,
    series: BTreeMap<String, VecDeque<(f64, f64)>>,
}

impl OpenChannel {
    /// The chosen field's points, `(seconds, value)`, oldest first.
    pub fn series(&self) -> Option<&VecDeque<(f64, f64)>> {
        self.series.get(self.field.as_ref()?)
    }

    fn record(&mut self, now: Duration, packet: &Packet<'_>) {
        let t = now.as_secs_f64();
        for (key, value) in fields::numbers(packet) {
            if !self.series.contains_key(&key) && self.series.len() >= MAX_SERIES {
                continue;
            }
            let s = self.series.entry(key).or_default();
            if s.len() >= MAX_POINTS {
                s.pop_front();
            }
            s.push_back((t, value));
        }
    }
}

/// Everything the spy shows.
#[derive(Debug, Clone)]
pub struct Spy {
    window: Duration,
    channels: BTreeMap<String, Channel>,
    /// The selected channel in the table.
    selected: Option<String>,
    open: Option<OpenChannel>,
    /// Packets received and taken in.
    seen: u64,
    /// Packets on channels past [`MAX_CHANNELS`].
    over_cap: u64,
    /// Datagrams that were no packet.
    unparsed: u64,
    missed: Missed,
    tap: Tap,
    pub feed: Feed,
    now: Duration,
    /// Only channels whose name or last packet holds this are listed (all, when empty).
    filter: String,
    /// Keys type into the filter.
    typing: bool,
    /// A log's clock stands; a hub's view is frozen.
    paused: bool,
    /// A hub's view as it was when frozen: drawn, and moved about in, while this one goes on
    /// counting.
    frozen: Option<Box<Spy>>,
    /// Where a log's clock is being moved to, while the records before it are taken.
    seeking: Option<Duration>,
}

impl Spy {
    /// A spy with nothing seen yet, whose rates are over `window`.
    pub fn new(feed: Feed, window: Duration) -> Spy {
        Spy {
            window,
            channels: BTreeMap::new(),
            selected: None,
            open: None,
            seen: 0,
            over_cap: 0,
            unparsed: 0,
            missed: Missed::default(),
            tap: Tap::Unknown,
            feed,
            now: Duration::ZERO,
            filter: String::new(),
            typing: false,
            paused: false,
            frozen: None,
            seeking: None,
        }
    }

    /// Forgets every packet, to play a log again from its start: the channels, the counts and
    /// the clock go; the selection, the open channel (its history emptied), the filter and the
    /// pause stay.
    pub fn restart(&mut self) {
        self.channels.clear();
        self.seen = 0;
        self.over_cap = 0;
        self.unparsed = 0;
        self.missed = Missed::default();
        self.now = Duration::ZERO;
        self.seeking = None;
        if let Some(o) = &mut self.open {
            o.series.clear();
        }
    }

    /// What the screen shows: the view frozen, if it is, else this.
    pub fn shown(&self) -> &Spy {
        self.frozen.as_deref().unwrap_or(self)
    }

    /// Whether a log's clock stands, or a hub's view is frozen.
    pub fn paused(&self) -> bool {
        self.paused
    }

    /// Where a log's clock is being moved to, if it is.
    pub fn seeking(&self) -> Option<Duration> {
        self.seeking
    }

    pub fn set_seeking(&mut self, to: Option<Duration>) {
        self.seeking = to;
    }

    /// The filter, and whether keys type into it.
    pub fn filter(&self) -> (&str, bool) {
        (&self.filter, self.typing)
    }

    /// Whether keys type into the filter (the terminal's keys map onto [`Key::Char`] then).
    pub fn typing(&self) -> bool {
        self.shown().typing
    }

    /// The rates' window.
    pub fn window(&self) -> Duration {
        self.window
    }

    /// The latest time given.
    pub fn now(&self) -> Duration {
        self.now
    }

    /// Moves the clock to `now` (never back).
    pub fn set_now(&mut self, now: Duration) {
        self.now = self.now.max(now);
    }

    /// Takes in a datagram received at `now`: a packet counts on its channel; anything else
    /// counts as unparsed.
    pub fn on_datagram(&mut self, now: Duration, bytes: &[u8]) {
        match Packet::parse(bytes) {
            Ok(p) => self.on_packet(now, &p),
            Err(_) => self.unparsed += 1,
        }
    }

    /// Counts datagrams found unparsable elsewhere (the hub client skips them itself).
    pub fn set_unparsed_elsewhere(&mut self, n: u64) {
        self.unparsed = self.unparsed.max(n);
    }

    /// Takes in a packet received at `now`.
    pub fn on_packet(&mut self, now: Duration, packet: &Packet<'_>) {
        self.set_now(now);
        self.seen += 1;
        // Named as the hub's status names it: the header's subjects, joined by blanks.
        let key = printable(&packet.subjects().collect::<Vec<_>>().join(" "));
        if !self.channels.contains_key(&key) && self.channels.len() >= MAX_CHANNELS {
            self.over_cap += 1;
            return;
        }
        let window = self.window;
        let c = self
            .channels
            .entry(key.clone())
            .or_insert_with(|| Channel::new(window));
        let text = packet.as_str();
        c.rate.record(now, text.len());
        c.packets += 1;
        c.bytes += text.len() as u64;
        c.priorities.add(packet.priority());
        c.last_at = Some(now);
        c.last_len = text.len();
        let open = self.open.as_mut().filter(|o| o.name == key);
        let keep = if open.is_some() {
            text.len()
        } else {
            floor_char_boundary(text, LAST_KEEP)
        };
        c.last.clear();
        c.last.push_str(&text[..keep]);
        if let Some(o) = open {
            o.record(now, packet);
        }
        if self.selected.is_none() {
            self.selected = Some(key);
        }
    }

    /// Takes in the hub's status report received at `now`; `me` is this spy's address as the
    /// hub sees it, if known, to learn whether the hub lets it tap.
    pub fn on_status(&mut self, now: Duration, report: &StatusReport, me: Option<&str>) {
        self.set_now(now);
        if let Some(c) = me.and_then(|me| report.clients.iter().find(|c| c.addr == me)) {
            self.tap = if c.tap { Tap::Tapping } else { Tap::Refused };
        }
        let tapping = match self.tap {
            Tap::Tapping => true,
            Tap::Refused => false,
            Tap::Unknown => self.seen > 0,
        };
        self.missed.on_status(now, report, self.seen, tapping);
    }

    /// What a key does.
    pub fn on_key(&mut self, key: Key) -> Action {
        if key == Key::Quit {
            return Action::Quit;
        }
        if let Some(frozen) = self.frozen.as_deref_mut() {
            if key == Key::Pause && !frozen.typing {
                self.thaw();
                return Action::Continue;
            }
            // Frozen, the keys move about the view as it was.
            return frozen.on_key(key);
        }
        if self.typing {
            self.on_key_typing(key);
            return Action::Continue;
        }
        let log = matches!(self.feed, Feed::Log { .. });
        let key = match key {
            Key::Left if log => return Action::Seek(Seek::Back),
            Key::Right if log => return Action::Seek(Seek::Forward),
            Key::Home if log => return Action::Seek(Seek::Start),
            Key::Left => Key::Previous,
            Key::Right => Key::Next,
            Key::Home => Key::Top,
            k => k,
        };
        match key {
            Key::Pause if log => self.paused = !self.paused,
            Key::Pause => self.freeze(),
            Key::Search => {
                self.open = None;
                self.typing = true;
                self.filter.clear();
            }
            _ if self.open.is_some() => self.on_key_open(key),
            Key::Back if self.filter.is_empty() => return Action::Quit,
            Key::Back => self.filter.clear(),
            Key::Up => self.move_selection(-1),
            Key::Down => self.move_selection(1),
            Key::PageUp => self.move_selection(-20),
            Key::PageDown => self.move_selection(20),
            Key::Top => self.move_selection(isize::MIN),
            Key::End => self.move_selection(isize::MAX),
            Key::Open | Key::Next => self.open_selected(),
            _ => {}
        }
        Action::Continue
    }

    fn on_key_typing(&mut self, key: Key) {
        match key {
            Key::Char(c) if !c.is_control() && self.filter.chars().count() < MAX_FILTER => {
                self.filter.push(c);
            }
            Key::Erase => {
                self.filter.pop();
            }
            Key::Open => self.typing = false,
            Key::Back => {
                self.filter.clear();
                self.typing = false;
            }
            Key::Up => self.move_selection(-1),
            Key::Down => self.move_selection(1),
            Key::PageUp => self.move_selection(-20),
            Key::PageDown => self.move_selection(20),
            _ => {}
        }
    }

    fn on_key_open(&mut self, key: Key) {
        match key {
            Key::Back => self.open = None,
            Key::Up | Key::Previous => self.move_field(-1),
            Key::Down | Key::Next => self.move_field(1),
            Key::PageUp => self.move_field(-10),
            Key::PageDown => self.move_field(10),
            Key::Top => self.move_field(isize::MIN),
            Key::End => self.move_field(isize::MAX),
            _ => {}
        }
    }

    /// Freezes a hub's view: a copy of it is drawn from now on, and the keys move about in it,
    /// while this one goes on counting.
    fn freeze(&mut self) {
        let mut frozen = self.clone();
        frozen.paused = true;
        self.frozen = Some(Box::new(frozen));
        self.paused = true;
    }

    /// Back to the live view, where the frozen one was looking: its selection, filter and
    /// open channel and field.
    fn thaw(&mut self) {
        let Some(frozen) = self.frozen.take() else {
            return;
        };
        let frozen = *frozen;
        self.paused = false;
        self.selected = frozen.selected;
        self.filter = frozen.filter;
        self.typing = frozen.typing;
        self.open = match (frozen.open, self.open.take()) {
            (Some(was), Some(mut open)) if open.name == was.name => {
                open.field = was.field;
                Some(open)
            }
            (Some(was), _) => {
                let mut open = self.open_named(was.name);
                open.field = was.field.or(open.field);
                Some(open)
            }
            (None, _) => None,
        };
    }

    /// Whether a channel is listed: its name or its last packet (as much as was kept) holds
    /// the filter.
    fn listed_channel(&self, name: &str, c: &Channel) -> bool {
        self.filter.is_empty() || name.contains(&self.filter) || c.last.contains(&self.filter)
    }

    /// The channels the filter lets through, by name.
    pub fn listed(&self) -> impl Iterator<Item = (&String, &Channel)> {
        self.channels
            .iter()
            .filter(|(n, c)| self.listed_channel(n, c))
    }

    /// Moves the selection `by` rows of the listed channels, stopping at either end.
    fn move_selection(&mut self, by: isize) {
        let names: Vec<&String> = self.listed().map(|(n, _)| n).collect();
        if names.is_empty() {
            return;
        }
        let at = self.selected().map_or(0, |(i, _)| i);
        let to = at.saturating_add_signed(by).min(names.len() - 1);
        self.selected = Some(names[to].clone());
    }

    fn open_selected(&mut self) {
        let Some(name) = self.selected().map(|(_, n)| n.to_string()) else {
            return;
        };
        self.selected = Some(name.clone());
        self.open = Some(self.open_named(name));
    }

    /// The channel view of `name`, starting from its last packet.
    fn open_named(&self, name: String) -> OpenChannel {
        let mut open = OpenChannel {
            name,
            field: None,
            series: BTreeMap::new(),
        };
        // The last packet starts the history, and the first numeric field is chosen.
        if let Some(c) = self.channels.get(&open.name) {
            if let (Ok(p), Some(at)) = (Packet::parse(c.last.as_bytes()), c.last_at) {
                open.record(at, &p);
                open.field = fields::numbers(&p).into_iter().next().map(|(k, _)| k);
            }
        }
        open
    }

    /// The numeric fields of the open channel's last packet, by key, in order.
    fn numeric_keys(&self) -> Vec<String> {
        let Some((_, p)) = self.open_packet_text() else {
            return Vec::new();
        };
        Packet::parse(p.as_bytes())
            .map(|p| fields::numbers(&p).into_iter().map(|(k, _)| k).collect())
            .unwrap_or_default()
    }

    fn move_field(&mut self, by: isize) {
        let keys = self.numeric_keys();
        let Some(open) = self.open.as_mut() else {
            return;
        };
        if keys.is_empty() {
            return;
        }
        let at = open
            .field
            .as_ref()
            .and_then(|f| keys.iter().position(|k| k == f));
        let next = match at {
            None => 0,
            Some(i) => i.saturating_add_signed(by).min(keys.len() - 1),
        };
        open.field = Some(keys[next].clone());
    }

    /// The open channel's name and last packet (whole, or as much as was kept).
    pub fn open_packet_text(&self) -> Option<(&str, &str)> {
        let open = self.open.as_ref()?;
        let c = self.channels.get(&open.name)?;
        Some((&open.name, &c.last))
    }

    /// The channel view, when a channel is open.
    pub fn open(&self) -> Option<&OpenChannel> {
        self.open.as_ref()
    }

    /// Every channel, by name.
    #[cfg(test)]
    pub fn channels(&self) -> impl ExactSizeIterator<Item = (&String, &Channel)> {
        self.channels.iter()
    }

    /// A channel by name.
    pub fn channel(&self, name: &str) -> Option<&Channel> {
        self.channels.get(name)
    }

    pub fn channel_count(&self) -> usize {
        self.channels.len()
    }

    /// The selected channel's name and its place among the listed channels: the first
    /// listed when the one selected is not (or none is).
    pub fn selected(&self) -> Option<(usize, &str)> {
        let chosen = self.selected.as_deref();
        if self.filter.is_empty() {
            if let Some(name) = chosen.filter(|n| self.channels.contains_key(*n)) {
                let i = self
                    .channels
                    .range::<str, _>((Bound::Unbounded, Bound::Excluded(name)))
                    .count();
                return Some((i, name));
            }
        }
        let mut first = None;
        for (i, (name, _)) in self.listed().enumerate() {
            if Some(name.as_str()) == chosen {
                return Some((i, name));
            }
            first.get_or_insert((0, name.as_str()));
        }
        first
    }

    /// How many channels the filter lets through.
    pub fn listed_count(&self) -> usize {
        if self.filter.is_empty() {
            self.channels.len()
        } else {
            self.listed().count()
        }
    }

    pub fn seen(&self) -> u64 {
        self.seen
    }

    pub fn unparsed(&self) -> u64 {
        self.unparsed
    }

    pub fn over_cap(&self) -> u64 {
        self.over_cap
    }

    /// Packets the hub published that never reached the spy, by its status reports (only a
    /// live hub's).
    pub fn missed(&self) -> u64 {
        self.missed.count()
    }

    pub fn tap(&self) -> Tap {
        self.tap
    }
}

fn floor_char_boundary(text: &str, at: usize) -> usize {
    let mut end = at.min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    end
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_wire::{ChannelInfo, ClientInfo};

    fn secs(s: f64) -> Duration {
        Duration::from_secs_f64(s)
    }

    fn spy() -> Spy {
        Spy::new(
            Feed::Hub {
                addr: "127.0.0.1:7400".into(),
                state: HubLink::Alive,
            },
            Duration::from_secs(1),
        )
    }

    fn report(uptime_ms: u64, packets: u64, me_tapping: bool) -> StatusReport {
        StatusReport {
            uptime_ms,
            channels: vec![ChannelInfo {
                subjects: "vision".into(),
                packets,
                bytes: packets * 10,
            }],
            clients: vec![ClientInfo {
                addr: "127.0.0.1:5000".into(),
                idle_ms: 0,
                subscriptions: vec![],
                about: String::new(),
                tap: me_tapping,
                batch: 0,
            }],
            ..StatusReport::default()
        }
    }

    #[test]
    fn every_channel_has_its_rate_bandwidth_priorities_and_last_packet() {
        let mut s = spy();
        for i in 0..40 {
            let prio = if i % 4 == 0 { 10 } else { 0 };
            let text = format!("@ <vision> {prio}\nrobot id {i} x 1.5\n");
            s.on_datagram(secs(i as f64 * 0.05), text.as_bytes());
            s.on_datagram(
                secs(i as f64 * 0.05),
                b"@ <camera.0> <camera.1> 0\nsees n 1\n",
            );
        }
        let now = secs(2.0);
        s.set_now(now);
        let names: Vec<String> = s.channels().map(|(n, _)| n.clone()).collect();
        assert_eq!(names, ["camera.0 camera.1", "vision"]);
        let v = s.channel("vision").unwrap();
        let (rate, bw) = v.rates(now).unwrap();
        assert!((rate - 20.0).abs() < 1.5, "{rate}");
        assert!(bw > 20.0 * 30.0, "{bw}");
        assert_eq!(v.priorities.summary(), "0:75% 10:25%");
        assert_eq!(v.preview(), "robot id 39 x 1.5");
        assert_eq!(s.seen(), 80);
        // The first channel seen is selected.
        assert_eq!(s.selected(), Some((1, "vision")));
    }

    #[test]
    fn priorities_beyond_the_few_counted_apart_are_lumped() {
        let mut m = PriorityMix::default();
        assert_eq!(m.summary(), "");
        m.add(Priority(5));
        assert_eq!(m.summary(), "5");
        for p in [1, 2, 3, 4, 6, 7] {
            m.add(Priority(p));
        }
        assert_eq!(m.counts.len(), MAX_PRIORITIES);
        assert_eq!(m.others, 3);
        assert_eq!(m.summary(), "1:14% 2:14% 3:14% 5:14% +43%");
    }

    #[test]
    fn hostile_datagrams_count_as_unparsed_and_thousands_of_channels_stay_bounded() {
        let mut s = spy();
        s.on_datagram(secs(0.0), b"\xff\xfe not a packet");
        s.on_datagram(secs(0.0), b"");
        for i in 0..(MAX_CHANNELS + 50) {
            let text = format!("@ <c{i}> 0\nx v {i}\n");
            s.on_datagram(secs(0.1), text.as_bytes());
        }
        assert_eq!(s.unparsed(), 2);
        assert_eq!(s.channel_count(), MAX_CHANNELS);
        assert_eq!(s.over_cap(), 50);
        // A huge packet keeps only its first LAST_KEEP bytes, unless its channel is open.
        let mut big = String::from("@ <big> 0\n");
        while big.len() < 60_000 {
            big.push_str("p é 1\n");
        }
        let mut s = spy();
        s.on_datagram(secs(0.0), big.as_bytes());
        let c = s.channel("big").unwrap();
        assert!(c.last.len() <= LAST_KEEP && !c.last_whole());
        s.on_key(Key::Open);
        s.on_datagram(secs(0.1), big.as_bytes());
        assert!(s.channel("big").unwrap().last_whole());
    }

    #[test]
    fn random_datagrams_never_panic_the_model() {
        // A small xorshift: the same bytes every run.
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let mut s = spy();
        s.on_datagram(secs(0.0), b"@ <a> 0\nv x 1\n");
        s.on_key(Key::Open);
        let alphabet = b"@<> ()\"\\0123456789.-eEnaxyz\n\t\xff\xc3";
        for i in 0..20_000 {
            let len = (next() % 200) as usize;
            let mut d: Vec<u8> = (0..len)
                .map(|_| alphabet[(next() % alphabet.len() as u64) as usize])
                .collect();
            if i % 2 == 0 {
                d.splice(0..0, b"@ <a> 0\n".iter().copied());
            }
            s.on_datagram(secs(i as f64 * 0.001), &d);
            if i % 1000 == 0 {
                s.on_key(Key::Next);
            }
        }
        assert_eq!(s.seen() + s.unparsed(), 20_001);
        assert!(s.seen() > 0 && s.unparsed() > 0);
    }

    #[test]
    fn keys_select_open_pick_a_field_and_go_back() {
        let mut s = spy();
        for (i, ch) in ["a", "b", "c"].into_iter().enumerate() {
            let text = format!("@ <{ch}> 0\nrobot id 0 x {i}.5 name \"r\"\nrobot id 1 x 2 y 3\n");
            s.on_datagram(secs(0.0), text.as_bytes());
        }
        assert_eq!(s.selected(), Some((0, "a")));
        s.on_key(Key::Down);
        s.on_key(Key::Down);
        s.on_key(Key::Down);
        assert_eq!(s.selected(), Some((2, "c")));
        s.on_key(Key::Up);
        assert_eq!(s.on_key(Key::Open), Action::Continue);
        let open = s.open().unwrap();
        assert_eq!(open.name, "b");
        assert_eq!(open.field.as_deref(), Some("robot[0].id"));
        s.on_key(Key::Next);
        s.on_key(Key::Next);
        assert_eq!(s.open().unwrap().field.as_deref(), Some("robot[1].id"));
        s.on_key(Key::End);
        assert_eq!(s.open().unwrap().field.as_deref(), Some("robot[1].y"));
        s.on_key(Key::Next);
        assert_eq!(s.open().unwrap().field.as_deref(), Some("robot[1].y"));
        // The chosen field's history grows with each packet on the open channel.
        s.on_datagram(secs(1.0), b"@ <b> 0\nrobot id 0 x 7\nrobot id 1 x 2 y 4\n");
        s.on_datagram(secs(1.0), b"@ <a> 0\nrobot id 1 x 2 y 99\n");
        let points: Vec<(f64, f64)> = s
            .open()
            .unwrap()
            .series()
            .unwrap()
            .iter()
            .copied()
            .collect();
        assert_eq!(points, [(0.0, 3.0), (1.0, 4.0)]);
        assert_eq!(s.on_key(Key::Back), Action::Continue);
        assert!(s.open().is_none());
        assert_eq!(s.on_key(Key::Back), Action::Quit);
        assert_eq!(s.on_key(Key::Quit), Action::Quit);
    }

    #[test]
    fn a_field_history_is_bounded() {
        let mut s = spy();
        s.on_datagram(secs(0.0), b"@ <a> 0\nv x 1\n");
        s.on_key(Key::Open);
        let mut text = String::from("@ <a> 0\n");
        for i in 0..(MAX_SERIES + 20) {
            text.push_str(&format!("v x {i}\n"));
        }
        for i in 0..(MAX_POINTS + 30) {
            s.on_datagram(secs(i as f64), text.as_bytes());
        }
        let open = s.open().unwrap();
        assert_eq!(open.series.len(), MAX_SERIES);
        assert!(open.series.values().all(|s| s.len() <= MAX_POINTS));
    }

    #[test]
    fn packets_the_hub_published_but_the_spy_never_got_are_missed() {
        let mut s = spy();
        let me = Some("127.0.0.1:5000");
        s.on_datagram(secs(0.5), b"@ <vision> 0\nx v 1\n");
        s.on_status(secs(1.0), &report(1000, 10, true), me);
        assert_eq!(s.tap(), Tap::Tapping);
        for i in 0..5 {
            s.on_datagram(secs(1.1 + i as f64 * 0.1), b"@ <vision> 0\nx v 1\n");
        }
        // The hub published 8 more, of which the spy got 5.
        s.on_status(secs(2.0), &report(2000, 18, true), me);
        assert_eq!(s.missed(), 3);
        // A report from the hub's cache (built 80 ms before it came) is not believed...
        s.on_status(secs(2.5), &report(2420, 30, true), me);
        assert_eq!(s.missed(), 3);
        // ...and a restarted hub starts the count again.
        s.on_status(secs(3.0), &report(10, 1, true), me);
        s.on_datagram(secs(3.5), b"@ <vision> 0\nx v 1\n");
        s.on_status(secs(4.0), &report(1010, 2, true), me);
        assert_eq!(s.missed(), 0);
    }

    #[test]
    fn a_refused_tap_shows_and_counts_nothing_as_missed() {
        let mut s = spy();
        let me = Some("127.0.0.1:5000");
        s.on_status(secs(1.0), &report(1000, 10, false), me);
        s.on_status(secs(2.0), &report(2000, 50, false), me);
        assert_eq!(s.tap(), Tap::Refused);
        assert_eq!(s.missed(), 0);
    }

    fn log_spy() -> Spy {
        Spy::new(
            Feed::Log {
                file: "t.clog".into(),
                speed: 1.0,
                state: LogState::Playing,
            },
            Duration::from_secs(1),
        )
    }

    fn three(s: &mut Spy) {
        s.on_datagram(secs(0.0), b"@ <vision> 0\nrobot id 0 x 1\n");
        s.on_datagram(secs(0.0), b"@ <radio> 0\ncmd id 3 forward 0.5\n");
        s.on_datagram(secs(0.0), b"@ <camera.0> 0\nblob x 1 robot 2\n");
    }

    fn listed(s: &Spy) -> Vec<String> {
        s.listed().map(|(n, _)| n.clone()).collect()
    }

    fn type_in(s: &mut Spy, text: &str) {
        for c in text.chars() {
            s.on_key(Key::Char(c));
        }
    }

    #[test]
    fn a_filter_lists_the_channels_whose_name_or_last_packet_holds_it() {
        let mut s = spy();
        three(&mut s);
        assert_eq!(s.selected(), Some((2, "vision")));
        s.on_key(Key::Search);
        assert!(s.typing());
        // Typed keys are the filter's, whatever they mean otherwise.
        type_in(&mut s, "q");
        assert_eq!(s.filter(), ("q", true));
        assert_eq!(listed(&s), Vec::<String>::new());
        s.on_key(Key::Erase);
        type_in(&mut s, "robot");
        // vision by its packet, camera.0 by its packet; radio not.
        assert_eq!(listed(&s), ["camera.0", "vision"]);
        assert_eq!(s.listed_count(), 2);
        assert_eq!(s.selected(), Some((1, "vision")));
        s.on_key(Key::Up);
        assert_eq!(s.selected(), Some((0, "camera.0")));
        // Enter keeps it; the keys move about the listed channels only.
        s.on_key(Key::Open);
        assert_eq!(s.filter(), ("robot", false));
        s.on_key(Key::End);
        assert_eq!(s.selected(), Some((1, "vision")));
        s.on_key(Key::Up);
        s.on_key(Key::Up);
        assert_eq!(s.selected(), Some((0, "camera.0")));
        s.on_key(Key::Open);
        assert_eq!(s.open().unwrap().name, "camera.0");
        s.on_key(Key::Back);
        // Esc clears a kept filter before it quits.
        assert_eq!(s.on_key(Key::Back), Action::Continue);
        assert_eq!(listed(&s).len(), 3);
        assert_eq!(s.selected(), Some((0, "camera.0")));
        assert_eq!(s.on_key(Key::Back), Action::Quit);
        // By name, and Esc while typing clears it.
        s.on_key(Key::Search);
        type_in(&mut s, "cam");
        assert_eq!(listed(&s), ["camera.0"]);
        s.on_key(Key::Back);
        assert_eq!(s.filter(), ("", false));
        assert_eq!(listed(&s).len(), 3);
        // The selected channel, filtered out, selects the first listed; back, it is again.
        s.on_key(Key::End);
        s.on_key(Key::Search);
        type_in(&mut s, "cmd");
        assert_eq!(s.selected(), Some((0, "radio")));
        s.on_key(Key::Back);
        assert_eq!(s.selected(), Some((2, "vision")));
    }

    #[test]
    fn a_filter_is_bounded_and_any_key_sequence_is_safe() {
        let mut s = spy();
        three(&mut s);
        s.on_key(Key::Search);
        type_in(&mut s, &"é".repeat(500));
        assert_eq!(s.filter().0.chars().count(), MAX_FILTER);
        // Control characters are not typed.
        s.on_key(Key::Back);
        s.on_key(Key::Search);
        type_in(&mut s, "a\u{1b}\n\u{9b}b");
        assert_eq!(s.filter().0, "ab");
        let keys = [
            Key::Up,
            Key::Down,
            Key::PageUp,
            Key::PageDown,
            Key::Home,
            Key::Top,
            Key::End,
            Key::Open,
            Key::Next,
            Key::Previous,
            Key::Left,
            Key::Right,
            Key::Search,
            Key::Char('o'),
            Key::Char('x'),
            Key::Char(' '),
            Key::Erase,
            Key::Pause,
            Key::Back,
        ];
        let mut x: u64 = 0x2545_f491_4f6c_dd1d;
        for feed in [spy(), log_spy()] {
            let mut s = feed;
            for i in 0..20_000u64 {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let _ = s.on_key(keys[(x % keys.len() as u64) as usize]);
                if i % 7 == 0 {
                    let text = format!("@ <c{}> 0\nrobot x {i}\n", x % 5);
                    s.on_datagram(secs(i as f64 * 0.01), text.as_bytes());
                }
                assert!(s.filter().0.chars().count() <= MAX_FILTER);
                if let Some((i, name)) = s.shown().selected() {
                    assert!(i < s.shown().listed_count());
                    assert!(s.shown().channel(name).is_some());
                }
            }
        }
    }

    #[test]
    fn a_frozen_hub_view_stays_as_it_was_while_the_spy_counts_on() {
        let mut s = spy();
        three(&mut s);
        s.on_key(Key::Pause);
        assert!(s.paused() && s.shown().paused());
        for i in 0..10 {
            s.on_datagram(secs(1.0 + i as f64 * 0.1), b"@ <new> 0\nx n 1\n");
        }
        assert_eq!((s.seen(), s.shown().seen()), (13, 3));
        assert!(s.shown().channel("new").is_none());
        // The keys move about the frozen view: its channels, its last packets.
        s.on_key(Key::Home);
        assert_eq!(s.shown().selected(), Some((0, "camera.0")));
        s.on_key(Key::Open);
        assert_eq!(s.shown().open().unwrap().name, "camera.0");
        assert!(s.open().is_none());
        s.on_datagram(secs(3.0), b"@ <camera.0> 0\nblob x 9\n");
        assert_eq!(
            s.shown().open_packet_text().unwrap().1,
            "@ <camera.0> 0\nblob x 1 robot 2\n"
        );
        // Going on, the live view is where the frozen one was.
        assert_eq!(s.on_key(Key::Pause), Action::Continue);
        assert!(!s.paused());
        assert_eq!(s.shown().seen(), 14);
        let open = s.open().unwrap();
        assert_eq!(
            (open.name.as_str(), open.field.as_deref()),
            ("camera.0", Some("blob[0].x"))
        );
        assert_eq!(
            s.open_packet_text().unwrap().1,
            "@ <camera.0> 0\nblob x 9\n"
        );
        // Space types into a filter, frozen or not.
        s.on_key(Key::Pause);
        s.on_key(Key::Search);
        s.on_key(Key::Char(' '));
        assert!(s.paused() && s.typing());
        assert_eq!(s.shown().filter(), (" ", true));
    }

    #[test]
    fn with_a_log_space_pauses_and_left_right_and_home_seek() {
        let mut s = log_spy();
        three(&mut s);
        assert_eq!(s.on_key(Key::Pause), Action::Continue);
        assert!(s.paused() && s.frozen.is_none());
        assert_eq!(s.on_key(Key::Right), Action::Seek(Seek::Forward));
        assert_eq!(s.on_key(Key::Left), Action::Seek(Seek::Back));
        assert_eq!(s.on_key(Key::Home), Action::Seek(Seek::Start));
        s.on_key(Key::Pause);
        assert!(!s.paused());
        // In a channel too; Tab picks fields, and `g` goes to the first.
        s.on_key(Key::Top);
        assert_eq!(s.selected(), Some((0, "camera.0")));
        s.on_key(Key::Open);
        assert_eq!(s.on_key(Key::Right), Action::Seek(Seek::Forward));
        s.on_key(Key::Next);
        assert_eq!(s.open().unwrap().field.as_deref(), Some("blob[0].robot"));
        s.on_key(Key::Top);
        assert_eq!(s.open().unwrap().field.as_deref(), Some("blob[0].x"));
        // A hub's Left and Right pick fields, and Home the first.
        let mut h = spy();
        three(&mut h);
        h.on_key(Key::Top);
        h.on_key(Key::Right);
        assert_eq!(h.open().unwrap().name, "camera.0");
        h.on_key(Key::Right);
        assert_eq!(h.open().unwrap().field.as_deref(), Some("blob[0].robot"));
        h.on_key(Key::Home);
        assert_eq!(h.open().unwrap().field.as_deref(), Some("blob[0].x"));
    }

    #[test]
    fn a_restart_forgets_the_packets_and_keeps_where_the_person_looks() {
        let mut s = log_spy();
        three(&mut s);
        s.on_key(Key::Top);
        s.on_key(Key::Open);
        s.on_datagram(secs(5.0), b"@ <camera.0> 0\nblob x 2 robot 2\n");
        s.on_key(Key::Pause);
        s.restart();
        assert_eq!(
            (s.seen(), s.channel_count(), s.now()),
            (0, 0, Duration::ZERO)
        );
        let open = s.open().unwrap();
        assert_eq!(open.name, "camera.0");
        assert!(open.series().is_none_or(VecDeque::is_empty));
        assert!(s.paused());
        s.on_datagram(secs(0.0), b"@ <camera.0> 0\nblob x 1 robot 2\n");
        assert_eq!(s.open().unwrap().series().unwrap().len(), 1);
    }
}
