//! The strategy game as a player sees it, with no socket and no clock:
//! `game.state`, `game.map` and `game.event` packets go in, JSON for the
//! game page (`/game`) comes out, and the page's squad commands go back to
//! the game as `game.player.<team>` packets ([`squad`]).
//!
//! The monitor reads the game's packets with the game's own decoders from
//! [`colony_proto::game`] (their lenient forms: a line it cannot read is
//! skipped and counted, never fatal) and stays a plain hub client that does
//! not depend on the game crate. Everything kept is bounded: names are
//! tokens, texts are cut short, lists are capped, and the map is refused past
//! [`map::MAX_SIDE`] cells a side.
//!
//! To the page:
//!
//! ```text
//! {"t":"game","now":MS,"age":S|null,"stale":B,"prematch":B,"heard":B|null,"state":{mode,status,time,winner,reason,
//!   teams:[{name,score,kills}], flags:[{team,x,y,home,carrier}],
//!   robots:[{id,team,squad,kind,x,y,theta,health,max_health,power,alive,behaviour,reason}],
//!   squads:[{team,name,formation,order,behaviour,path:[[x,y],..]}]}|null,
//!   "events":[{seq,kind,time,text}],"refusal":{seq,kind,time,text}|null,
//!   "map_version":N,"bad_lines":N,"chat_dropped":N,
//!   "lobby":{status,budget,max_squads,upgrade,max_upgrade,kinds:[{kind,cost,health,power,speed,
//!     range,amphibious}],teams:[{name,ready,bot,cost,setup}]}|null}
//! {"t":"map","version":N,"map":{width,height,cell,rows:["@..T",..],
//!   sites:[{team,base:[x,y],flag:[x,y]}]}|null}
//! {"t":"chat","team":T,"lines":[{seq,from,text}]}     only to the pages playing team T
//! ```
//!
//! A page playing a team (`team=` in its socket's address) is sent a [`GameFrame`] cut for
//! that team ([`GameFrame::json`]): another team's squads (names, orders, paths), its robots'
//! squads, behaviours and reasons, its refusals (which quote its orders) and its pre-match
//! setup are left out on the server, so a competitive player cannot read them in the page's
//! data. A page with no team (a spectator, the operator) is sent everything.
//!
//! `heard` says whether the game is listening to the page's orders: whether the hub's newest
//! status shows a client other than this monitor subscribed to `game.player.<team>` (for a
//! page with no team, to any team's). A replayed log (`colony replay`) publishes the game's
//! state but nothing on the wire marks it as a replay, and no game server is there to read
//! orders: `false` is how the page tells it from a live match. `null`: not known (no status
//! yet, or a status cut short before naming a listener).

pub mod map;
pub mod orders;

use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_proto::game::{
    valid_name, ChatLine, Event, GameState, LobbyState, LobbyStatus, RobotState,
};
use colony_wire::{Packet, StatusReport};
use serde::Serialize;

use self::map::MapView;

pub use colony_proto::game::{EVENT, LOBBY, MAP, STATE};
/// The game channels the monitor always subscribes to.
pub const GAME_CHANNELS: [&str; 4] = [STATE, MAP, EVENT, LOBBY];

/// Events kept for the page's log.
pub const MAX_EVENTS: usize = 50;
/// Chat lines kept for each team.
pub const MAX_CHAT_LINES: usize = 50;
/// The prefix of a team's chat channel.
const CHAT_PREFIX: &str = "game.chat.";
/// The prefix of a team's order channel.
const PLAYER_PREFIX: &str = "game.player.";
/// With no state for this long the page shows the game as stale.
pub const GAME_STALE_AFTER: Duration = Duration::from_secs(2);
/// The longest behaviour, reason, order or event text kept (characters).
const MAX_TEXT: usize = 200;
const MAX_TEAMS: usize = 64;
const MAX_FLAGS: usize = 64;
const MAX_ROBOTS: usize = 4096;
const MAX_SQUADS: usize = 1024;
const MAX_PATH: usize = 512;

/// An event for the page's log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EventView {
    /// Counts events since the monitor started, so the page can tell new from seen.
    pub seq: u64,
    /// `hit`, `destroyed`, `refused`, ...
    pub kind: String,
    /// Game time, s.
    pub time: f64,
    /// The text a person reads.
    pub text: String,
}

/// The pre-match as the page gets it: the lobby as the game publishes it, its lists capped.
fn lobby_view(mut s: LobbyState) -> LobbyState {
    s.kinds.truncate(16);
    s.teams.truncate(MAX_TEAMS);
    s
}

/// A chat line for the pages of its team.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChatView {
    /// Counts chat lines since the monitor started, so a page can tell new from seen.
    pub seq: u64,
    /// Who wrote it.
    pub from: String,
    /// What they wrote.
    pub text: String,
}

/// Each team's chat lines, for the pages playing that team and no other.
pub type Chats = BTreeMap<String, Arc<[ChatView]>>;

#[derive(Serialize)]
struct ChatJson<'a> {
    t: &'static str,
    team: &'a str,
    backlog: bool,
    lines: &'a [ChatView],
}

/// A team's chat for one page, `{"t":"chat","team":T,"backlog":B,"lines":[{seq,from,text}]}`:
/// `backlog` when these are the lines a page finds as it connects rather than news.
pub fn chat_message(team: &str, backlog: bool, lines: &[ChatView]) -> String {
    let j = ChatJson {
        t: "chat",
        team,
        backlog,
        lines,
    };
    serde_json::to_string(&j).unwrap_or_else(|_| "{}".into())
}

/// Everything the monitor knows of the game.
#[derive(Debug)]
pub struct GameView {
    started: Instant,
    wall_start_ms: u64,
    state: Option<GameState>,
    state_at: Option<Instant>,
    map: MapView,
    events: VecDeque<(EventView, Option<String>)>,
    next_seq: u64,
    refusal: Option<EventView>,
    bad_lines: u64,
    version: u64,
    chat: BTreeMap<String, VecDeque<ChatView>>,
    chat_version: u64,
    chat_dropped: u64,
    lobby: Option<LobbyState>,
    lobby_at: Option<Instant>,
    listeners: Listeners,
    /// The newest refusal of each team (by [`owner`]), and of no team under `None`.
    refusals: BTreeMap<Option<String>, EventView>,
}

/// Which teams' orders a game is listening to, from the hub's status.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Listeners {
    /// Teams with a listener on `game.player.<team>`.
    pub teams: BTreeSet<String>,
    /// The status listed every client, so a team not in `teams` has none.
    pub complete: bool,
}

impl Listeners {
    /// Reads a status report: `ours` are the monitor's own clients, which subscribe to every
    /// channel they see and so would otherwise count as the game.
    pub fn from_status(report: &StatusReport, ours: &[SocketAddr]) -> Listeners {
        let mine = |addr: &str| {
            addr.parse::<SocketAddr>().is_ok_and(|a| {
                ours.iter()
                    .any(|o| o.port() == a.port() && (o.ip().is_unspecified() || o.ip() == a.ip()))
            })
        };
        let mut teams = BTreeSet::new();
        for c in &report.clients {
            // A tap is another monitor or a spy: it reads orders but never obeys them.
            if c.tap || mine(&c.addr) {
                continue;
            }
            for (sub, _) in &c.subscriptions {
                if let Some(team) = sub.strip_prefix(PLAYER_PREFIX) {
                    if valid_name(team) && teams.len() < MAX_TEAMS {
                        teams.insert(team.to_owned());
                    }
                }
            }
        }
        Listeners {
            teams,
            complete: !report.truncated && report.clients.len() as u64 >= report.client_count,
        }
    }

    fn heard(&self, team: Option<&str>) -> Option<bool> {
        let found = match team {
            Some(t) => self.teams.contains(t),
            None => !self.teams.is_empty(),
        };
        (found || self.complete).then_some(found)
    }
}

/// The team whose order a refusal answers, when its text says: the game words a player's
/// refusal `<team> ...` or `<team>: ...` (`a bad command from <team>: ...`), and a robot's
/// `robot <id> ...`. Only `refused` events have owners; the rest are what everyone sees on
/// the battlefield.
fn owner(kind: &str, text: &str, teams: &[&str], robots: &[RobotState]) -> Option<String> {
    if kind != "refused" {
        return None;
    }
    let text = text.strip_prefix("a bad command from ").unwrap_or(text);
    let first = text.split([' ', ':']).next().unwrap_or("");
    if first == "robot" {
        let id: u32 = text.split([' ', ':']).nth(1)?.parse().ok()?;
        return robots
            .binary_search_by_key(&id, |r| r.id)
            .ok()
            .map(|i| robots[i].team.clone());
    }
    teams.contains(&first).then(|| first.to_owned())
}

/// What a game page is sent, before it is cut for its viewer ([`GameFrame::json`]).
#[derive(Debug, Clone)]
pub struct GameFrame {
    now: u64,
    age: Option<f64>,
    stale: bool,
    prematch: bool,
    state: Option<GameState>,
    events: Vec<(EventView, Option<String>)>,
    refusals: BTreeMap<Option<String>, EventView>,
    map_version: u64,
    bad_lines: u64,
    chat_dropped: u64,
    lobby: Option<LobbyState>,
    listeners: Listeners,
}

impl GameFrame {
    /// The JSON for a page playing `viewer` (None: a spectator, sent everything).
    pub fn json(&self, viewer: Option<&str>) -> String {
        let mine = |owner: &Option<String>| {
            viewer.is_none() || owner.is_none() || owner.as_deref() == viewer
        };
        let state = match (viewer, &self.state) {
            (Some(team), Some(s)) => Some(Cow::Owned(for_team(s, team))),
            (_, s) => s.as_ref().map(Cow::Borrowed),
        };
        let lobby = match (viewer, &self.lobby) {
            (Some(team), Some(l)) => {
                let mut l = l.clone();
                for t in l.teams.iter_mut().filter(|t| t.name != team) {
                    t.setup.clear();
                }
                Some(Cow::Owned(l))
            }
            (_, l) => l.as_ref().map(Cow::Borrowed),
        };
        let events: Vec<&EventView> = self
            .events
            .iter()
            .filter(|(_, o)| mine(o))
            .map(|(e, _)| e)
            .collect();
        let refusal = self
            .refusals
            .iter()
            .filter(|(o, _)| mine(o))
            .map(|(_, e)| e)
            .max_by_key(|e| e.seq);
        let j = GameJson {
            t: "game",
            now: self.now,
            age: self.age,
            stale: self.stale,
            prematch: self.prematch,
            heard: self.listeners.heard(viewer),
            state: state.as_deref(),
            events,
            refusal,
            map_version: self.map_version,
            bad_lines: self.bad_lines,
            chat_dropped: self.chat_dropped,
            lobby: lobby.as_deref(),
        };
        serde_json::to_string(&j).unwrap_or_else(|_| "{}".into())
    }
}

/// A state as `team`'s player may see it: where every robot is and how it fares (the
/// battlefield shows that), but only its own team's squads, orders, paths and reasons.
fn for_team(s: &GameState, team: &str) -> GameState {
    let mut s = s.clone();
    s.squads.retain(|q| q.team == team);
    for r in s.robots.iter_mut().filter(|r| r.team != team) {
        r.squad.clear();
        r.behaviour.clear();
        r.reason.clear();
    }
    s
}

#[derive(Serialize)]
struct GameJson<'a> {
    t: &'static str,
    now: u64,
    age: Option<f64>,
    stale: bool,
    prematch: bool,
    heard: Option<bool>,
    state: Option<&'a GameState>,
    events: Vec<&'a EventView>,
    refusal: Option<&'a EventView>,
    map_version: u64,
    bad_lines: u64,
    chat_dropped: u64,
    lobby: Option<&'a LobbyState>,
}

#[derive(Serialize)]
struct MapJson<'a> {
    t: &'static str,
    version: u64,
    map: Option<&'a map::Map>,
}

/// Text cut to [`MAX_TEXT`] characters.
fn cut(text: String) -> String {
    if text.chars().count() <= MAX_TEXT {
        text
    } else {
        text.chars().take(MAX_TEXT).collect()
    }
}

/// What the page shows of a state: texts cut short, lists capped, robots in id order.
fn page_state(mut s: GameState) -> GameState {
    s.reason = cut(s.reason);
    s.teams.truncate(MAX_TEAMS);
    s.flags.truncate(MAX_FLAGS);
    s.robots.truncate(MAX_ROBOTS);
    for r in &mut s.robots {
        r.behaviour = cut(std::mem::take(&mut r.behaviour));
        r.reason = cut(std::mem::take(&mut r.reason));
    }
    s.robots.sort_by_key(|r| r.id);
    s.squads.truncate(MAX_SQUADS);
    for q in &mut s.squads {
        q.order = cut(std::mem::take(&mut q.order));
        q.behaviour = cut(std::mem::take(&mut q.behaviour));
        q.path.truncate(MAX_PATH);
    }
    s
}

impl GameView {
    /// A view started at `now`, when the wall clock read `wall_ms` (Unix milliseconds).
    pub fn new(now: Instant, wall_ms: u64) -> GameView {
        GameView {
            started: now,
            wall_start_ms: wall_ms,
            state: None,
            state_at: None,
            map: MapView::default(),
            events: VecDeque::new(),
            next_seq: 0,
            refusal: None,
            bad_lines: 0,
            version: 0,
            chat: BTreeMap::new(),
            chat_version: 0,
            chat_dropped: 0,
            lobby: None,
            lobby_at: None,
            listeners: Listeners::default(),
            refusals: BTreeMap::new(),
        }
    }

    /// Takes in who listens to the teams' orders, from the hub's newest status.
    pub fn set_listeners(&mut self, listeners: Listeners) {
        if self.listeners != listeners {
            self.listeners = listeners;
            self.version += 1;
        }
    }

    /// Changes whenever a chat line arrives.
    pub fn chat_version(&self) -> u64 {
        self.chat_version
    }

    /// Chat lines that could not be kept: unreadable, or for a team past the first
    /// [`MAX_TEAMS`] that chatted (a forger inventing teams).
    pub fn chat_dropped(&self) -> u64 {
        self.chat_dropped
    }

    /// Each team's chat lines.
    pub fn chats(&self) -> Chats {
        self.chat
            .iter()
            .map(|(team, lines)| (team.clone(), lines.iter().cloned().collect()))
            .collect()
    }

    fn on_chat(&mut self, team: &str, packet: &Packet<'_>) {
        let lines = match ChatLine::decode(team, packet) {
            Ok(lines) if valid_name(team) => lines,
            _ => {
                self.chat_dropped += 1;
                return;
            }
        };
        if !self.chat.contains_key(team) && self.chat.len() >= MAX_TEAMS {
            self.chat_dropped += lines.len() as u64;
            return;
        }
        let log = self.chat.entry(team.to_string()).or_default();
        for l in lines {
            if log.len() >= MAX_CHAT_LINES {
                log.pop_front();
            }
            log.push_back(ChatView {
                seq: self.next_seq,
                from: l.from,
                text: l.text,
            });
            self.next_seq += 1;
            self.chat_version += 1;
        }
    }

    /// The newest game state.
    pub fn state(&self) -> Option<&GameState> {
        self.state.as_ref()
    }

    /// The newest complete map.
    pub fn map(&self) -> Option<&map::Map> {
        self.map.map()
    }

    /// Changes whenever a different map is complete.
    pub fn map_version(&self) -> u64 {
        self.map.version()
    }

    /// The last [`MAX_EVENTS`] events, oldest first.
    pub fn events(&self) -> impl Iterator<Item = &EventView> {
        self.events.iter().map(|(e, _)| e)
    }

    fn owner_of(&self, e: &EventView) -> Option<String> {
        let mut teams: Vec<&str> = Vec::new();
        if let Some(s) = &self.state {
            teams.extend(s.teams.iter().map(|t| t.name.as_str()));
        }
        if let Some(l) = &self.lobby {
            teams.extend(l.teams.iter().map(|t| t.name.as_str()));
        }
        let robots = self.state.as_ref().map_or(&[][..], |s| &s.robots[..]);
        owner(&e.kind, &e.text, &teams, robots)
    }

    /// The newest `refused` event: the game said no to a player.
    pub fn refusal(&self) -> Option<&EventView> {
        self.refusal.as_ref()
    }

    /// Changes whenever the state or the events do.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Lines of game packets that did not read.
    pub fn bad_lines(&self) -> u64 {
        self.bad_lines + self.map.bad_lines()
    }

    /// Takes in a packet received at `now`; packets of other channels are ignored.
    pub fn on_packet(&mut self, now: Instant, packet: &Packet<'_>) {
        if packet.subject_count() != 1 {
            return;
        }
        if packet.has_subject(STATE) {
            self.on_state(now, packet);
        } else if packet.has_subject(MAP) {
            self.map.on_packet(packet);
        } else if packet.has_subject(EVENT) {
            self.on_event(packet);
        } else if packet.has_subject(LOBBY) {
            match LobbyState::decode(packet) {
                Ok(l) => {
                    self.lobby = Some(lobby_view(l));
                    self.lobby_at = Some(now);
                    self.version += 1;
                }
                Err(_) => self.bad_lines += 1,
            }
        } else if let Some(team) = packet.subjects().find_map(|s| s.strip_prefix(CHAT_PREFIX)) {
            let team = team.to_string();
            self.on_chat(&team, packet);
        }
    }

    fn on_state(&mut self, now: Instant, packet: &Packet<'_>) {
        let Ok(read) = GameState::decode_lenient(packet) else {
            self.bad_lines += 1;
            return;
        };
        self.bad_lines += read.bad_lines;
        let s = page_state(read.message);
        // Game time going back is a new game: the old one's log is history.
        if self
            .state
            .as_ref()
            .is_some_and(|old| s.time + 1.0 < old.time)
        {
            self.events.clear();
            self.refusal = None;
            self.refusals.clear();
        }
        self.state = Some(s);
        self.state_at = Some(now);
        self.version += 1;
    }

    fn on_event(&mut self, packet: &Packet<'_>) {
        let read = Event::decode_lenient(packet);
        self.bad_lines += read.bad_lines;
        for e in read.message {
            let mut e = EventView {
                seq: 0,
                kind: e.kind,
                time: e.time,
                text: cut(e.text),
            };
            e.seq = self.next_seq;
            self.next_seq += 1;
            let who = self.owner_of(&e);
            if e.kind == "refused" {
                self.refusal = Some(e.clone());
                // Owners are teams of the game, so this holds at most one more than there are.
                if self.refusals.contains_key(&who) || self.refusals.len() <= MAX_TEAMS {
                    self.refusals.insert(who.clone(), e.clone());
                }
            }
            if self.events.len() >= MAX_EVENTS {
                self.events.pop_front();
            }
            self.events.push_back((e, who));
            self.version += 1;
        }
    }

    fn wall(&self, t: Instant) -> u64 {
        self.wall_start_ms + t.saturating_duration_since(self.started).as_millis() as u64
    }

    /// Seconds since the newest state arrived.
    pub fn age(&self, now: Instant) -> Option<f64> {
        self.state_at
            .map(|t| (now.saturating_duration_since(t).as_secs_f64() * 10.0).round() / 10.0)
    }

    /// The match is being set up: a lobby is drafting and no state has come.
    pub fn prematch(&self) -> bool {
        self.state.is_none()
            && self
                .lobby
                .as_ref()
                .is_some_and(|l| l.status == LobbyStatus::Drafting)
    }

    /// What game pages are sent now, before it is cut for each ([`GameFrame::json`]).
    pub fn frame(&self, now: Instant) -> GameFrame {
        let prematch = self.prematch();
        // Before the match the lobby is what comes (ten times a second), not states.
        let heard_at = if prematch {
            self.lobby_at
        } else {
            self.state_at
        };
        let stale = heard_at.is_none_or(|t| now.saturating_duration_since(t) > GAME_STALE_AFTER);
        GameFrame {
            now: self.wall(now),
            age: self.age(now),
            stale,
            prematch,
            state: self.state.clone(),
            events: self.events.iter().cloned().collect(),
            refusals: self.refusals.clone(),
            map_version: self.map.version(),
            bad_lines: self.bad_lines(),
            chat_dropped: self.chat_dropped,
            lobby: self.lobby.clone(),
            listeners: self.listeners.clone(),
        }
    }

    /// State, events and the map's version as JSON for a page with no team (a spectator).
    pub fn game_json(&self, now: Instant) -> String {
        self.frame(now).json(None)
    }

    /// The map as JSON for the game page (sent only when it changes).
    pub fn map_json(&self) -> String {
        let j = MapJson {
            t: "map",
            version: self.map.version(),
            map: self.map.map(),
        };
        serde_json::to_string(&j).unwrap_or_else(|_| "{}".into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_proto::Vec2;

    fn parse(text: &str) -> Packet<'_> {
        Packet::parse(text.as_bytes()).unwrap()
    }

    fn view() -> (GameView, Instant) {
        let t0 = Instant::now();
        (GameView::new(t0, 1_000_000), t0)
    }

    pub(crate) const STATE_PACKET: &str = "@ <game.state> 0\n\
game mode ctf status running time 12.4 winner - reason \"\"\n\
team name red score 0 kills 1\n\
team name blue score 1 kills 0\n\
flag team blue x 800 y 900 home 0 carrier 3\n\
flag team red x 100 y 90 home 1\n\
robot id 4 team blue squad alpha kind scout x 700 y 800 theta 3.1 health 45 alive 1 behaviour goto reason \"following the path\"\n\
robot id 3 team red squad alpha kind tank x 310.5 y 88.2 theta 1.57 health 120 alive 1 behaviour shoot reason \"enemy 4 in range\"\n\
squad team red name alpha formation wedge order \"attack robot 4\" behaviour attack path \"310,88 400,120 700,800\"\n";

    #[test]
    fn a_state_packet_is_read_whole() {
        let (mut g, t0) = view();
        g.on_packet(t0, &parse(STATE_PACKET));
        let s = g.state().unwrap();
        assert_eq!(
            (s.mode.as_str(), s.status.name(), s.time),
            ("ctf", "running", 12.4)
        );
        assert_eq!(s.winner, None);
        assert_eq!(s.teams[1].score, 1);
        assert_eq!(s.flags[0].carrier, Some(3));
        assert!(s.flags[1].home);
        assert_eq!(s.robots[0].id, 3, "sorted by id");
        assert_eq!(s.robots[0].reason, "enemy 4 in range");
        assert_eq!(s.squads[0].order, "attack robot 4");
        assert_eq!(
            s.squads[0].path,
            [
                Vec2::new(310.0, 88.0),
                Vec2::new(400.0, 120.0),
                Vec2::new(700.0, 800.0)
            ]
        );
        assert_eq!(g.bad_lines(), 0);
        assert_eq!(g.version(), 1);
        let json: serde_json::Value = serde_json::from_str(&g.game_json(t0)).unwrap();
        assert_eq!(json["t"], "game");
        assert_eq!(json["stale"], false);
        assert_eq!(
            json["state"]["squads"][0]["path"][1],
            serde_json::json!([400.0, 120.0])
        );
        assert_eq!(
            json["state"]["flags"][1]["carrier"],
            serde_json::Value::Null
        );
        assert_eq!(json["state"]["robots"][1]["alive"], true);
    }

    #[test]
    fn unreadable_lines_are_skipped_and_the_rest_kept() {
        let (mut g, t0) = view();
        g.on_packet(
            t0,
            &parse("@ <game.state> 0\nteam name red score 0 kills 0\n"),
        );
        assert!(g.state().is_none(), "no game line: not a state");
        let text = "@ <game.state> 0\n\
game mode ctf status running time 1 winner red reason \"flag home\" future (a 1)\n\
robot id -1 team red squad a kind tank x 0 y 0 theta 0 health 1 alive 1\n\
robot id 2 team \"red team\" squad a kind tank x 0 y 0 theta 0 health 1 alive 1\n\
robot id 3 team red squad a kind tank x nan y 0 theta 0 health 1 alive 1\n\
robot id 4 team red squad a kind tank x 0 y 0 theta 0 health 1 alive 2\n\
robot id 5 team red squad a kind tank x 1e7 y 0 theta 0 health 1 alive 1\n\
robot id 6 team red squad a kind tank x 5 y 6 theta 0 health 1 alive 1 colour green\n\
squad team red name a formation wedge order \"\" behaviour \"\" path \"1,2 3\"\n\
squad team red name b formation line\n\
flag team red x 1 y 2 carrier 99999999999\n\
ufo x 1\n";
        g.on_packet(t0, &parse(text));
        let s = g.state().unwrap();
        assert_eq!(s.winner.as_deref(), Some("red"));
        assert_eq!(s.robots.iter().map(|r| r.id).collect::<Vec<_>>(), [6]);
        assert_eq!(s.squads.len(), 1);
        assert_eq!(s.squads[0].name, "b");
        assert!(s.flags.is_empty());
        assert_eq!(g.bad_lines(), 1 + 5 + 1 + 1);
    }

    #[test]
    fn the_last_fifty_events_are_kept_and_the_last_refusal_stays_visible() {
        let (mut g, t0) = view();
        g.on_packet(
            t0,
            &parse(
                "@ <game.event> 0\nevent kind refused time 1 text \"squad zulu: no such squad\"\n",
            ),
        );
        for i in 0..60 {
            g.on_packet(
                t0,
                &parse(&format!(
                    "@ <game.event> 0\nevent kind hit time {i} text \"hit {i}\"\n"
                )),
            );
        }
        g.on_packet(
            t0,
            &parse("@ <game.event> 0\nevent kind \"two words\" time 1\nevent time 1\n"),
        );
        let events: Vec<_> = g.events().collect();
        assert_eq!(events.len(), MAX_EVENTS);
        assert_eq!(events[0].text, "hit 10");
        assert_eq!(events.last().unwrap().seq, 60);
        assert_eq!(g.refusal().unwrap().text, "squad zulu: no such squad");
        assert_eq!(g.bad_lines(), 2);
        // A new game (time went back) starts a new log.
        g.on_packet(t0, &parse(STATE_PACKET));
        g.on_packet(t0, &parse(&STATE_PACKET.replace("time 12.4", "time 0.2")));
        assert_eq!(g.events().count(), 0);
        assert!(g.refusal().is_none());
    }

    #[test]
    fn the_game_goes_stale_without_state_and_the_map_is_its_own_message() {
        let (mut g, t0) = view();
        let json: serde_json::Value = serde_json::from_str(&g.game_json(t0)).unwrap();
        assert_eq!(json["stale"], true);
        assert_eq!(json["state"], serde_json::Value::Null);
        g.on_packet(t0, &parse(STATE_PACKET));
        let later = t0 + Duration::from_millis(2500);
        let json: serde_json::Value = serde_json::from_str(&g.game_json(later)).unwrap();
        assert_eq!(json["stale"], true);
        assert_eq!(json["age"], 2.5);
        g.on_packet(
            t0,
            &parse("@ <game.map> 0\nmap width 2 height 1 cell 20 part 0 parts 1\nrow y 0 cells \".W\"\n"),
        );
        assert_eq!(g.map_version(), 1);
        let json: serde_json::Value = serde_json::from_str(&g.map_json()).unwrap();
        assert_eq!(json["t"], "map");
        assert_eq!(json["map"]["rows"][0], ".W");
        let game: serde_json::Value = serde_json::from_str(&g.game_json(t0)).unwrap();
        assert_eq!(game["map_version"], 1);
        assert!(
            game.get("map").is_none(),
            "the map is not in every game message"
        );
    }

    const BLUE_PLANS: &str = "squad team blue name bravo formation line order \"capture the red flag\" behaviour goto path \"700,800 300,200 100,90\"\n";
    const LOBBY_PACKET: &str =
        "@ <game.lobby> 0\nlobby status drafting budget 100 squads 4 upgrade 0.2 max_upgrade 5\n\
kind name amphibian cost 12 health 60 power 8 speed 30 range 120 amphibious 1\n\
team name red ready 0 bot 0 cost 24 setup \"alpha:tank,scout\"\n\
team name blue ready 1 bot 1 cost 36 setup \"raiders:amphibian,amphibian,amphibian\"\n";

    fn json(text: &str) -> serde_json::Value {
        serde_json::from_str(text).unwrap()
    }

    #[test]
    fn a_team_page_is_never_sent_another_teams_plans_orders_or_refusals() {
        let (mut g, t0) = view();
        g.on_packet(t0, &parse(LOBBY_PACKET));
        g.on_packet(t0, &parse(&format!("{STATE_PACKET}{BLUE_PLANS}")));
        g.on_packet(
            t0,
            &parse(
                "@ <game.event> 0\n\
event kind refused time 12 text \"blue robot 4: it is not being driven\"\n\
event kind refused time 12 text \"a bad command from blue: squad bravo: capture needs a flag\"\n\
event kind refused time 12 text \"robot 4 fires at robot 3: the target is 900 cm away\"\n\
event kind refused time 12 text \"red split of alpha: too few robots\"\n\
event kind hit time 12 text \"robot 4 hit robot 3\"\n",
            ),
        );
        let frame = g.frame(t0);

        let red = json(&frame.json(Some("red")));
        let squads = red["state"]["squads"].as_array().unwrap();
        assert!(
            squads.iter().all(|q| q["team"] == "red") && squads.len() == 1,
            "red's page got blue's squads: {squads:?}"
        );
        let text = red.to_string();
        for secret in [
            "bravo",
            "capture",
            "300,200",
            "300.0,200.0",
            "raiders",
            "goto",
            "following the path",
            "900 cm",
        ] {
            assert!(
                !text.contains(secret),
                "red's page was sent {secret:?}: {text}"
            );
        }
        let blue_robot = &red["state"]["robots"][1];
        assert_eq!(
            (blue_robot["id"].as_u64(), blue_robot["x"].as_f64()),
            (Some(4), Some(700.0)),
            "where it stands is on the battlefield"
        );
        assert_eq!(red["refusal"]["text"], "red split of alpha: too few robots");
        let events: Vec<_> = red["events"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["text"].as_str().unwrap().to_owned())
            .collect();
        assert_eq!(
            events,
            ["red split of alpha: too few robots", "robot 4 hit robot 3"]
        );
        assert_eq!(
            red["lobby"]["teams"][0]["setup"], "alpha:tank,scout",
            "its own setup stays"
        );
        assert_eq!(red["lobby"]["teams"][1]["cost"], 36);

        let blue = json(&frame.json(Some("blue")));
        assert!(blue["state"]["squads"]
            .as_array()
            .unwrap()
            .iter()
            .all(|q| q["team"] == "blue"));
        assert_eq!(
            blue["state"]["robots"][0]["reason"], "",
            "red's reasons name its target"
        );
        assert_eq!(
            blue["refusal"]["text"],
            "robot 4 fires at robot 3: the target is 900 cm away"
        );

        // A team not in the game sees no one's plans.
        let green = json(&frame.json(Some("green")));
        assert_eq!(green["state"]["squads"], serde_json::json!([]));

        let all = json(&frame.json(None));
        assert_eq!(
            all["state"]["squads"].as_array().unwrap().len(),
            2,
            "a spectator sees both"
        );
        assert_eq!(all["events"].as_array().unwrap().len(), 5);
        assert_eq!(
            all["lobby"]["teams"][1]["setup"],
            "raiders:amphibian,amphibian,amphibian"
        );
        assert_eq!(all, json(&g.game_json(t0)));
    }

    #[test]
    fn the_lobby_is_not_stale_and_a_match_goes_stale_without_state() {
        let (mut g, t0) = view();
        g.on_packet(t0, &parse(LOBBY_PACKET));
        let j = json(&g.game_json(t0 + Duration::from_millis(500)));
        assert_eq!(
            (j["prematch"].as_bool(), j["stale"].as_bool()),
            (Some(true), Some(false))
        );
        // A lobby that stopped being published is stale all the same.
        let j = json(&g.game_json(t0 + Duration::from_secs(3)));
        assert_eq!(j["stale"], true);
        g.on_packet(t0 + Duration::from_secs(3), &parse(STATE_PACKET));
        let j = json(&g.game_json(t0 + Duration::from_secs(3)));
        assert_eq!(
            (j["prematch"].as_bool(), j["stale"].as_bool()),
            (Some(false), Some(false))
        );
    }

    #[test]
    fn orders_are_heard_only_when_a_client_other_than_a_monitor_reads_them() {
        use colony_wire::{ClientInfo, Priority};
        let client = |addr: &str, subs: &[&str], tap: bool| ClientInfo {
            addr: addr.into(),
            idle_ms: 0,
            subscriptions: subs.iter().map(|s| (s.to_string(), 5000)).collect(),
            about: String::new(),
            tap,
            batch: 0,
        };
        let report = |clients: Vec<ClientInfo>, count: u64| StatusReport {
            uptime_ms: 1,
            lease_ms: 10_000,
            min_priority: Priority(0),
            client_count: count,
            clients,
            channels: vec![],
            drops: vec![],
            truncated: false,
        };
        let ours: [SocketAddr; 2] = [
            "0.0.0.0:4000".parse().unwrap(),
            "0.0.0.0:4001".parse().unwrap(),
        ];
        // A replay: the monitor's own clients and another monitor's tap read game.player.red.
        let replay = report(
            vec![
                client("127.0.0.1:4000", &["vision", "game.player.red"], false),
                client("127.0.0.1:4001", &["game.player.blue"], false),
                client("127.0.0.1:5000", &["game.player.red"], true),
                client("127.0.0.1:5001", &[], false),
            ],
            4,
        );
        let (mut g, t0) = view();
        g.on_packet(t0, &parse(STATE_PACKET));
        assert_eq!(
            json(&g.frame(t0).json(Some("red")))["heard"],
            serde_json::Value::Null,
            "no status yet"
        );
        g.set_listeners(Listeners::from_status(&replay, &ours));
        assert_eq!(json(&g.frame(t0).json(Some("red")))["heard"], false);
        assert_eq!(json(&g.frame(t0).json(None))["heard"], false);
        // The live game server reads both teams' orders.
        let live = report(
            vec![client(
                "127.0.0.1:6000",
                &["game.player.red", "game.player.blue", "game.action"],
                false,
            )],
            1,
        );
        g.set_listeners(Listeners::from_status(&live, &ours));
        assert_eq!(json(&g.frame(t0).json(Some("red")))["heard"], true);
        assert_eq!(json(&g.frame(t0).json(Some("green")))["heard"], false);
        // A status cut short may have left the game server out: not known.
        let cut = report(vec![client("127.0.0.1:5001", &[], false)], 40);
        g.set_listeners(Listeners::from_status(&cut, &ours));
        assert_eq!(
            json(&g.frame(t0).json(Some("red")))["heard"],
            serde_json::Value::Null
        );
    }

    /// A tiny generator, so the test needs no crate and repeats exactly.
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> u64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            self.0 >> 33
        }
    }

    #[test]
    fn mangled_game_packets_never_panic_and_stay_bounded() {
        let (mut g, t0) = view();
        let seeds = [
            STATE_PACKET.to_owned(),
            "@ <game.map> 0\nmap width 3 height 2 cell 20 part 0 parts 2\nsite team red base_x 1 base_y 2 flag_x 3 flag_y 4\nrow y 0 cells \"..T\"\n".to_owned(),
            "@ <game.event> 0\nevent kind refused time 3 text \"no\"\n".to_owned(),
        ];
        let alphabet = b" \n\"\\()-.,0123456789eEnaxyidtTW@<>game.stwrpoflqu";
        let mut rng = Lcg(7);
        let mut read = 0;
        for round in 0..20_000 {
            let mut bytes = seeds[round % seeds.len()].clone().into_bytes();
            for _ in 0..(1 + rng.next() % 6) {
                let at = (rng.next() as usize) % bytes.len();
                match rng.next() % 3 {
                    0 => bytes[at] = alphabet[(rng.next() as usize) % alphabet.len()],
                    1 => {
                        bytes.remove(at);
                    }
                    _ => bytes.insert(at, alphabet[(rng.next() as usize) % alphabet.len()]),
                }
                if bytes.is_empty() {
                    bytes.push(b'@');
                }
            }
            if let Ok(p) = Packet::parse(&bytes) {
                read += 1;
                g.on_packet(t0, &p);
                let _ = g.game_json(t0);
            }
        }
        assert!(
            read > 1000,
            "the mangling left enough packets to read ({read})"
        );
        assert!(g.events().count() <= MAX_EVENTS);
        assert!(g.map().is_none_or(|m| m.rows.len() == m.height as usize));
    }
}
