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
//! {"t":"game","now":MS,"age":S|null,"stale":B,"state":{mode,status,time,winner,reason,
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

pub mod map;
pub mod orders;

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::time::{Duration, Instant};

use colony_proto::game::{valid_name, ChatLine, Event, GameState, LobbyState};
use colony_wire::Packet;
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
/// With no state for this long the page shows the game as stale.
pub const GAME_STALE_AFTER: Duration = Duration::from_secs(2);
/// The longest behaviour, reason, order or event text kept (characters).
const MAX_TEXT: usize = 200;
const MAX_TEAMS: usize = 64;
const MAX_FLAGS: usize = 64;
const MAX_ROBOTS: usize = 4096;
const MAX_SQUADS: usize = 1024;
const MAX_PATH: usize = 512;

/// A team's standing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TeamView {
    /// Its name.
    pub name: String,
    /// Flags captured (CTF) or robots destroyed (DM).
    pub score: i64,
    /// Enemy robots destroyed.
    pub kills: i64,
}

/// A flag.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlagView {
    /// Whose flag.
    pub team: String,
    /// Where it is, cm.
    pub x: f64,
    /// Where it is, cm.
    pub y: f64,
    /// On its stand at its base.
    pub home: bool,
    /// The robot carrying it.
    pub carrier: Option<u32>,
}

/// A robot.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RobotView {
    /// Its id.
    pub id: u32,
    /// Its team.
    pub team: String,
    /// Its squad.
    pub squad: String,
    /// Its type (`scout`, `tank`, `infantry`, `amphibian`).
    pub kind: String,
    /// Where it is, cm.
    pub x: f64,
    /// Where it is, cm.
    pub y: f64,
    /// Its heading, rad.
    pub theta: f64,
    /// Health left.
    pub health: f64,
    /// The health it started with.
    pub max_health: f64,
    /// The damage one of its shots does.
    pub power: f64,
    /// Not destroyed.
    pub alive: bool,
    /// The robot's active behaviour, and why it has control.
    pub behaviour: String,
    /// Why that behaviour has control.
    pub reason: String,
}

/// A squad.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SquadView {
    /// Its team.
    pub team: String,
    /// Its name.
    pub name: String,
    /// Its formation's name.
    pub formation: String,
    /// The player's command it carries out, as the game words it.
    pub order: String,
    /// The squad behaviour in control.
    pub behaviour: String,
    /// Planned turn points, cm.
    pub path: Vec<(f64, f64)>,
}

/// One `game.state` packet, as the page shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GameStateView {
    /// `ctf` or `dm`.
    pub mode: String,
    /// `running` or `over`.
    pub status: String,
    /// Game time, s.
    pub time: f64,
    /// The winner, when over (None: a draw or not over).
    pub winner: Option<String>,
    /// Why it ended.
    pub reason: String,
    /// The teams.
    pub teams: Vec<TeamView>,
    /// The flags.
    pub flags: Vec<FlagView>,
    /// The robots, in id order.
    pub robots: Vec<RobotView>,
    /// The squads.
    pub squads: Vec<SquadView>,
}

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
    state: Option<GameStateView>,
    state_at: Option<Instant>,
    map: MapView,
    events: VecDeque<EventView>,
    next_seq: u64,
    refusal: Option<EventView>,
    bad_lines: u64,
    version: u64,
    chat: BTreeMap<String, VecDeque<ChatView>>,
    chat_version: u64,
    chat_dropped: u64,
    lobby: Option<LobbyState>,
}

#[derive(Serialize)]
struct GameJson<'a> {
    t: &'static str,
    now: u64,
    age: Option<f64>,
    stale: bool,
    state: Option<&'a GameStateView>,
    events: &'a VecDeque<EventView>,
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
fn state_view(s: GameState) -> GameStateView {
    let mut robots: Vec<RobotView> = s
        .robots
        .into_iter()
        .take(MAX_ROBOTS)
        .map(|r| RobotView {
            id: r.id,
            team: r.team,
            squad: r.squad,
            kind: r.kind.name().to_string(),
            x: r.pose.x,
            y: r.pose.y,
            theta: r.pose.theta,
            health: r.health,
            max_health: r.max_health,
            power: r.power,
            alive: r.alive,
            behaviour: cut(r.behaviour),
            reason: cut(r.reason),
        })
        .collect();
    robots.sort_by_key(|r| r.id);
    GameStateView {
        mode: s.mode,
        status: s.status.name().to_string(),
        time: s.time,
        winner: s.winner,
        reason: cut(s.reason),
        teams: s
            .teams
            .into_iter()
            .take(MAX_TEAMS)
            .map(|t| TeamView {
                name: t.name,
                score: i64::from(t.score),
                kills: i64::from(t.kills),
            })
            .collect(),
        flags: s
            .flags
            .into_iter()
            .take(MAX_FLAGS)
            .map(|f| FlagView {
                team: f.team,
                x: f.at.x,
                y: f.at.y,
                home: f.home,
                carrier: f.carrier,
            })
            .collect(),
        robots,
        squads: s
            .squads
            .into_iter()
            .take(MAX_SQUADS)
            .map(|q| SquadView {
                team: q.team,
                name: q.name,
                formation: q.formation.name().to_string(),
                order: cut(q.order),
                behaviour: cut(q.behaviour),
                path: q.path.iter().take(MAX_PATH).map(|p| (p.x, p.y)).collect(),
            })
            .collect(),
    }
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
    pub fn state(&self) -> Option<&GameStateView> {
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
        self.events.iter()
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
        let s = state_view(read.message);
        // Game time going back is a new game: the old one's log is history.
        if self
            .state
            .as_ref()
            .is_some_and(|old| s.time + 1.0 < old.time)
        {
            self.events.clear();
            self.refusal = None;
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
            if e.kind == "refused" {
                self.refusal = Some(e.clone());
            }
            if self.events.len() >= MAX_EVENTS {
                self.events.pop_front();
            }
            self.events.push_back(e);
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

    /// State, events and the map's version as JSON for the game page.
    pub fn game_json(&self, now: Instant) -> String {
        let stale = self
            .state_at
            .is_none_or(|t| now.saturating_duration_since(t) > GAME_STALE_AFTER);
        let j = GameJson {
            t: "game",
            now: self.wall(now),
            age: self.age(now),
            stale,
            state: self.state.as_ref(),
            events: &self.events,
            refusal: self.refusal.as_ref(),
            map_version: self.map.version(),
            bad_lines: self.bad_lines(),
            chat_dropped: self.chat_dropped,
            lobby: self.lobby.as_ref(),
        };
        serde_json::to_string(&j).unwrap_or_else(|_| "{}".into())
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
            (s.mode.as_str(), s.status.as_str(), s.time),
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
            [(310.0, 88.0), (400.0, 120.0), (700.0, 800.0)]
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
