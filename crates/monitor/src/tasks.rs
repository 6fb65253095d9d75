//! MURDOCH's auctions as an operator sees them, with no socket and no clock:
//! announcements, everything said on negotiation subjects and the robots'
//! reports go in; the task board (`/tasks`) comes out as JSON.
//!
//! The board reads the messages with [`colony_proto::murdoch`]'s decoders and
//! follows each task through its states: `announced`, `bidding`, `awarded`,
//! `running`, `done`, `unachievable`, or `cancelled` and `abandoned` (after
//! which its announcer auctions it again: the task counts a re-allocation and
//! goes back to `announced` on its new negotiation subject). It keeps each
//! task's bids by round, the winner and why (the lowest score of the bids the
//! announcer heard), renewals and progress, and a timeline; and each robot's
//! mode, battery, resources and task from its reports on
//! [`ROBOTS`](colony_proto::murdoch::ROBOTS).
//!
//! A task is named by its announcer and number, so a board that missed the
//! announcement (it started late, or the hub dropped it) still follows the
//! task from its negotiation subject, without a name until one is heard.
//! Everything kept is bounded: tasks, bids, timeline entries, texts and
//! robots, and the page gets the newest [`MAX_SHOWN`] tasks.
//!
//! A message of an earlier round than the task's newest (a late abandon
//! from the winner the announcer already replaced) goes on the timeline and
//! changes nothing else; `ack` and `done` count only from the round's winner.
//!
//! Seals: the board shows only sealed messages, each from the key its task
//! bound, as agents and announcers take them (`colony_proto::murdoch`'s
//! "Who may say what"): the announcer's from the key that sealed the
//! announcement (or the first announcer's message heard, for a board that came
//! in later), a bidder's from the key of its first message in the round.
//! Anything else is counted (`forged`) and left off, so a forged `done` never
//! shows a task finished.
//!
//! To the page:
//!
//! ```text
//! {"t":"tasks","now":MS,"tasks":[{announcer,id,name,resources:[..],length_s,state,round,
//!   bids:[{round,bidder,score,withdrawn}],bids_missed:N,winner:{bidder,score,bids}|null,
//!   progress,renewals,reallocations,reason,timeline:[{at:MS,text}],first:MS,last:MS}],
//!  "robots":[{name,mode,battery,resources:[..],task,task_name,last:MS,silent}],
//!  "forgotten":N,"robots_forgotten":N,"bad":N,"forged":N}
//! ```
//! Times are milliseconds since the monitor started.

use std::collections::{BTreeMap, VecDeque};
use std::time::{Duration, Instant};

use colony_proto::murdoch::{
    parse_negotiation_subject, Announcement, Message, Negotiation, RobotReport, Signed,
    NEGOTIATION_PREFIX,
};
use colony_proto::DecodeError;
use colony_wire::seal::PublicKey;
use colony_wire::Packet;
use serde::Serialize;

/// Tasks kept; past this the oldest ended task (or, failing one, the oldest) is forgotten.
pub const MAX_TASKS: usize = 256;
/// Tasks sent to the page, the newest first: what a person can read, and a
/// snapshot small enough to build ten times a second whatever is kept.
pub const MAX_SHOWN: usize = 100;
/// Bids kept per task (over every round).
const MAX_BIDS: usize = 64;
/// Timeline entries kept per task: the newest.
const MAX_TIMELINE: usize = 24;
/// Robots kept; past this the one silent longest is forgotten.
const MAX_ROBOTS: usize = 256;
/// The longest reason or timeline text kept, in characters.
const MAX_TEXT: usize = 160;
/// A robot unheard this long (it reports every second) is shown as silent.
pub const ROBOT_SILENT_AFTER: Duration = Duration::from_secs(3);

/// Where a task stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TaskState {
    /// Offered; no bid heard yet.
    Announced,
    /// Bids are coming in.
    Bidding,
    /// The announcer named a winner; it has not acknowledged yet.
    Awarded,
    /// The winner acknowledged and works on it.
    Running,
    /// The winner finished it.
    Done,
    /// Nobody could take it.
    Unachievable,
    /// The announcer withdrew it (and will auction it again, if it still wants it done).
    Cancelled,
    /// The winner gave it up (and the announcer will auction it again).
    Abandoned,
}

impl TaskState {
    fn ended(self) -> bool {
        matches!(self, TaskState::Done | TaskState::Unachievable)
    }
}

/// A bid, as heard.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BidView {
    /// The auction round (1 for the first, one more for each re-allocation).
    pub round: u32,
    /// Who bid.
    pub bidder: String,
    /// Its score (a cost: lowest wins).
    pub score: f64,
    /// Withdrawn by its bidder (beaten, or it took another task).
    pub withdrawn: bool,
}

/// The announcer's choice.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WinnerView {
    /// Who won.
    pub bidder: String,
    /// The winning score: the lowest of the bids the announcer heard.
    pub score: f64,
    /// How many bids the announcer heard.
    pub bids: u32,
}

/// A moment in a task's life.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Moment {
    /// Milliseconds since the monitor started.
    pub at: u64,
    /// What happened.
    pub text: String,
}

/// One task on the board.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TaskView {
    /// Who announced it.
    pub announcer: String,
    /// Its number, the announcer's.
    pub id: u64,
    /// Its name (empty until its announcement is heard).
    pub name: String,
    /// The resources it needs.
    pub resources: Vec<String>,
    /// How long it runs, s.
    pub length_s: f64,
    /// Where it stands.
    pub state: TaskState,
    /// The auction round in progress.
    pub round: u32,
    /// Bids heard, every round.
    pub bids: Vec<BidView>,
    /// Bids past [`MAX_BIDS`], or the announcer heard that this board did not.
    pub bids_missed: u32,
    /// The current round's winner.
    pub winner: Option<WinnerView>,
    /// The winner's progress, 0 to 1, from its renewals.
    pub progress: Option<f64>,
    /// Renewals heard, both ways.
    pub renewals: u64,
    /// Times it was auctioned again after a cancel or an abandon.
    pub reallocations: u32,
    /// The last reason given (cancelled, abandoned, unachievable).
    pub reason: String,
    /// What happened, newest last.
    pub timeline: VecDeque<Moment>,
    /// When it was first heard of, ms.
    pub first: u64,
    /// When it was last heard of, ms.
    pub last: u64,
    /// The key that sealed its announcement (or, when the board came in
    /// later, the first announcer's message it heard): only it speaks for the
    /// announcer.
    #[serde(skip)]
    announcer_key: Option<PublicKey>,
    /// The key that sealed each bidder's first message this round: only it
    /// speaks for that bidder.
    #[serde(skip)]
    bidder_keys: BTreeMap<String, PublicKey>,
}

/// A robot, from its reports.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RobotView {
    /// Its token.
    pub name: String,
    /// `idle`, `working` or `charging`.
    pub mode: &'static str,
    /// Its charge, 0 to 1.
    pub battery: f64,
    /// What it has.
    pub resources: Vec<String>,
    /// The task it executes.
    pub task: Option<u64>,
    /// That task's name.
    pub task_name: Option<String>,
    /// When it last reported, ms.
    pub last: u64,
    /// Unheard for [`ROBOT_SILENT_AFTER`] (set when the board is written).
    pub silent: bool,
}

/// Everything the monitor knows of the auctions.
#[derive(Debug)]
pub struct TaskBoard {
    started: Instant,
    tasks: BTreeMap<(String, u64), TaskView>,
    robots: BTreeMap<String, RobotView>,
    forgotten: u64,
    robots_forgotten: u64,
    bad: u64,
    forged: u64,
    version: u64,
}

#[derive(Serialize)]
struct BoardJson<'a> {
    t: &'static str,
    now: u64,
    tasks: Vec<CardJson<'a>>,
    robots: Vec<RobotView>,
    forgotten: u64,
    robots_forgotten: u64,
    bad: u64,
    forged: u64,
}

/// A task as the board sends it, with what it has to do with the tasks announced before it
/// under the same name: an announcer that retries a task nobody can do
/// makes one unachievable task after another, and a board of dozens of the same failure hides
/// the tasks that matter.
#[derive(Serialize)]
struct CardJson<'a> {
    #[serde(flatten)]
    task: &'a TaskView,
    /// Earlier unachievable tries of this task, folded into this card (the newest try).
    retries: u32,
    /// The newest try's number, when this is an earlier unachievable one folded into it.
    retry_of: Option<u64>,
}

/// Each task (newest first) with its retries: an unachievable task announced again under the
/// same name is folded into the newest one. By name alone, not announcer too: each
/// `colony tasks announce` is a new announcer (`user-XXXX`), and a retry from the command line
/// is as much a duplicate as one from a program.
fn cards<'a>(newest_first: &[&'a TaskView]) -> Vec<CardJson<'a>> {
    let mut newest: BTreeMap<&str, usize> = BTreeMap::new();
    let mut out: Vec<CardJson<'a>> = Vec::with_capacity(newest_first.len());
    for &task in newest_first {
        let key = task.name.as_str();
        let head = newest.get(&key).copied();
        let retry_of = match head {
            Some(i) if !task.name.is_empty() && task.state == TaskState::Unachievable => {
                out[i].retries += 1;
                Some(out[i].task.id)
            }
            _ => None,
        };
        if head.is_none() {
            newest.insert(key, out.len());
        }
        out.push(CardJson {
            task,
            retries: 0,
            retry_of,
        });
    }
    out
}

/// Whether a negotiation message is sealed by the key that speaks for whom it claims to come
/// from: the bidder it names (the first key heard for that bidder this round), or the
/// announcer `announcer`.
fn sealed_by_its_speaker(
    task: &mut TaskView,
    m: &Negotiation,
    announcer: &str,
    key: PublicKey,
) -> bool {
    let bidder = match m {
        Negotiation::Bid(b) => Some(b.bidder.as_str()),
        Negotiation::Ack { bidder, .. }
        | Negotiation::Decline { bidder, .. }
        | Negotiation::Done { bidder, .. }
        | Negotiation::Abandon { bidder, .. } => Some(bidder.as_str()),
        Negotiation::Renew { by, .. } if by.as_str() != announcer => Some(by.as_str()),
        _ => None,
    };
    match bidder {
        Some(b) => match task.bidder_keys.get(b) {
            Some(k) => *k == key,
            // Bounded, with room for the bidders past MAX_BIDS that are
            // only counted as missed.
            None if task.bidder_keys.len() < 2 * MAX_BIDS => {
                task.bidder_keys.insert(b.to_owned(), key);
                true
            }
            None => false,
        },
        None => speaks(&mut task.announcer_key, key),
    }
}

/// What a genuine negotiation message of round `round`, heard at `ms`, does to its task.
fn apply_negotiation(task: &mut TaskView, round: u32, ms: u64, m: Negotiation) {
    let from_winner =
        |task: &TaskView, who: &str| task.winner.as_ref().is_none_or(|w| w.bidder == who);
    match m {
        Negotiation::Bid(b) => {
            let bidder = b.bidder.to_string();
            if let Some(old) = task
                .bids
                .iter_mut()
                .find(|x| x.round == round && x.bidder == bidder)
            {
                old.score = b.score;
                old.withdrawn = false;
            } else if task.bids.len() < MAX_BIDS {
                task.bids.push(BidView {
                    round,
                    bidder: bidder.clone(),
                    score: b.score,
                    withdrawn: false,
                });
            } else {
                task.bids_missed += 1;
            }
            if task.state == TaskState::Announced {
                task.state = TaskState::Bidding;
            }
            note(task, ms, format!("{bidder} bid {}", score_text(b.score)));
        }
        Negotiation::Decline { bidder, .. } => {
            for b in task.bids.iter_mut() {
                if b.round == round && b.bidder == bidder.as_str() {
                    b.withdrawn = true;
                }
            }
            note(task, ms, format!("{bidder} withdrew"));
        }
        Negotiation::Award {
            winner,
            score,
            bids,
            ..
        } => {
            let heard = task.bids.iter().filter(|b| b.round == round).count() as u32;
            task.bids_missed = task.bids_missed.max(bids.saturating_sub(heard));
            let why = if bids == 1 {
                "the only bid".to_owned()
            } else {
                format!("the lowest of {bids} bids")
            };
            note(
                task,
                ms,
                format!("awarded to {winner}: {} is {why}", score_text(score)),
            );
            task.winner = Some(WinnerView {
                bidder: winner.to_string(),
                score,
                bids,
            });
            if !task.state.ended() {
                task.state = TaskState::Awarded;
            }
        }
        Negotiation::Ack { bidder, .. } => {
            if from_winner(task, bidder.as_str()) && !task.state.ended() {
                task.state = TaskState::Running;
            }
            note(task, ms, format!("{bidder} took it and started"));
        }
        Negotiation::Renew { by, progress, .. } => {
            task.renewals += 1;
            let by_winner = task
                .winner
                .as_ref()
                .is_some_and(|w| w.bidder == by.as_str());
            if by_winner {
                if progress.is_some() {
                    task.progress = progress;
                }
                if task.state == TaskState::Awarded {
                    task.state = TaskState::Running;
                }
            }
        }
        Negotiation::Done { bidder, .. } => {
            if task.state != TaskState::Done && from_winner(task, bidder.as_str()) {
                task.state = TaskState::Done;
                task.progress = Some(1.0);
                note(task, ms, format!("{bidder} finished it"));
            }
        }
        Negotiation::Abandon { bidder, reason, .. } => {
            if from_winner(task, bidder.as_str()) && !task.state.ended() {
                task.state = TaskState::Abandoned;
            }
            note(task, ms, format!("{bidder} gave it up: {reason}"));
            task.reason = clip(&reason);
        }
        Negotiation::Cancel { reason, .. } => {
            if !task.state.ended() {
                task.state = TaskState::Cancelled;
            }
            note(task, ms, format!("the announcer withdrew it: {reason}"));
            task.reason = clip(&reason);
        }
        Negotiation::Unachievable { name, reason, .. } => {
            if task.name.is_empty() {
                task.name = name;
            }
            task.state = TaskState::Unachievable;
            note(task, ms, format!("unachievable: {reason}"));
            task.reason = clip(&reason);
        }
    }
}

/// A packet worth decoding: one that starts with a MURDOCH label.
fn is_murdoch(packet: &Packet<'_>) -> bool {
    packet.subjects().any(|s| s.starts_with(NEGOTIATION_PREFIX))
        || packet.lines().next().is_some_and(|l| l.label() == "task")
}

impl TaskBoard {
    /// An empty board started at `now`.
    pub fn new(now: Instant) -> TaskBoard {
        TaskBoard {
            started: now,
            tasks: BTreeMap::new(),
            robots: BTreeMap::new(),
            forgotten: 0,
            robots_forgotten: 0,
            bad: 0,
            forged: 0,
            version: 0,
        }
    }

    /// Changes whenever the board does.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// The tasks, by announcer and number.
    pub fn tasks(&self) -> impl Iterator<Item = &TaskView> {
        self.tasks.values()
    }

    /// One task.
    pub fn task(&self, announcer: &str, id: u64) -> Option<&TaskView> {
        self.tasks.get(&(announcer.to_owned(), id))
    }

    /// The robots, by name.
    pub fn robots(&self) -> impl Iterator<Item = &RobotView> {
        self.robots.values()
    }

    /// MURDOCH packets that did not read.
    pub fn bad(&self) -> u64 {
        self.bad
    }

    /// Messages left off the board: not sealed, or sealed by a key other than
    /// the one the task's announcer or the bidder they name spoke with.
    pub fn forged(&self) -> u64 {
        self.forged
    }

    fn ms(&self, now: Instant) -> u64 {
        now.saturating_duration_since(self.started).as_millis() as u64
    }

    /// Takes in a packet received at `now`; packets that are not MURDOCH's are ignored.
    pub fn on_packet(&mut self, now: Instant, packet: &Packet<'_>) {
        if !is_murdoch(packet) {
            return;
        }
        // The board shows what agents and announcers act on: sealed messages,
        // each from the key its task bound (see `seals`).
        let (message, key) = match Message::open(packet) {
            Ok(Signed { message, key, .. }) => (message, key),
            Err(DecodeError::Seal(_)) => {
                self.forged += 1;
                self.version += 1;
                return;
            }
            Err(_) => {
                self.bad += 1;
                return;
            }
        };
        match message {
            Message::Announce(a) => self.on_announce(now, a, key),
            Message::Negotiation { subject, message } => {
                if let Some((announcer, id, round)) = parse_negotiation_subject(subject.as_str()) {
                    let announcer = announcer.to_owned();
                    self.on_negotiation(now, announcer, id, round, message, key);
                }
            }
            Message::Robot(r) => self.on_robot(now, r),
        }
        self.version += 1;
    }

    /// The task `(announcer, id)`, made if new (forgetting one if the board is full).
    fn entry(&mut self, now: Instant, announcer: String, id: u64) -> &mut TaskView {
        let ms = self.ms(now);
        let key = (announcer, id);
        if !self.tasks.contains_key(&key) && self.tasks.len() >= MAX_TASKS {
            let victim = self
                .tasks
                .iter()
                .filter(|(_, t)| t.state.ended())
                .min_by_key(|(_, t)| t.last)
                .or_else(|| self.tasks.iter().min_by_key(|(_, t)| t.last))
                .map(|(k, _)| k.clone());
            if let Some(k) = victim {
                self.tasks.remove(&k);
                self.forgotten += 1;
            }
        }
        let task = self.tasks.entry(key.clone()).or_insert_with(|| TaskView {
            announcer: key.0,
            id: key.1,
            name: String::new(),
            resources: Vec::new(),
            length_s: 0.0,
            state: TaskState::Announced,
            round: 1,
            bids: Vec::new(),
            bids_missed: 0,
            winner: None,
            progress: None,
            renewals: 0,
            reallocations: 0,
            reason: String::new(),
            timeline: VecDeque::new(),
            first: ms,
            last: ms,
            announcer_key: None,
            bidder_keys: BTreeMap::new(),
        });
        task.last = ms;
        task
    }

    fn on_announce(&mut self, now: Instant, a: Announcement, key: PublicKey) {
        let round = parse_negotiation_subject(a.negotiation.as_str()).map_or(1, |(_, _, r)| r);
        let ms = self.ms(now);
        let task = self.entry(now, a.announcer.to_string(), a.id);
        if !speaks(&mut task.announcer_key, key) {
            self.forged += 1;
            return;
        }
        task.name = a.spec.name.clone();
        task.resources = a.spec.resources.iter().map(|s| s.to_string()).collect();
        task.length_s = a.spec.length_s;
        if round < task.round {
            note(task, ms, format!("(round {round}) announced, late"));
            return;
        }
        let again = round > task.round;
        if again {
            new_round(task, round);
            task.state = TaskState::Announced;
        }
        let text = if round > 1 {
            format!("auctioned again (round {round})")
        } else {
            format!(
                "announced to {} (bids for {} ms)",
                a.spec.resources,
                a.deadline.as_millis()
            )
        };
        note(task, ms, text);
    }

    fn on_negotiation(
        &mut self,
        now: Instant,
        announcer: String,
        id: u64,
        round: u32,
        m: Negotiation,
        key: PublicKey,
    ) {
        if m.task() != id {
            self.bad += 1;
            return;
        }
        let ms = self.ms(now);
        let announcer_token = announcer.clone();
        let task = self.entry(now, announcer, id);
        if round < task.round {
            note(task, ms, format!("(round {round}) {}", describe(&m)));
            return;
        }
        if round > task.round {
            // A new round whose announcement this board did not hear.
            new_round(task, round);
            task.state = TaskState::Bidding;
        }
        if !sealed_by_its_speaker(task, &m, &announcer_token, key) {
            self.forged += 1;
            return;
        }
        apply_negotiation(task, round, ms, m);
    }

    fn on_robot(&mut self, now: Instant, r: RobotReport) {
        let name = r.name.to_string();
        if !self.robots.contains_key(&name) && self.robots.len() >= MAX_ROBOTS {
            let silent = self
                .robots
                .values()
                .min_by_key(|r| r.last)
                .map(|r| r.name.clone());
            if let Some(k) = silent {
                self.robots.remove(&k);
                self.robots_forgotten += 1;
            }
        }
        let last = self.ms(now);
        self.robots.insert(
            name.clone(),
            RobotView {
                name,
                mode: r.mode.as_str(),
                battery: r.battery,
                resources: r.resources.iter().map(|s| s.to_string()).collect(),
                task: r.task.as_ref().map(|(id, _)| *id),
                task_name: r.task.map(|(_, n)| n),
                last,
                silent: false,
            },
        );
    }

    /// The board for the page at `now`: tasks with the most recent first.
    pub fn json(&self, now: Instant) -> String {
        let ms = self.ms(now);
        let mut tasks: Vec<&TaskView> = self.tasks.values().collect();
        tasks.sort_by_key(|t| std::cmp::Reverse(t.first));
        tasks.truncate(MAX_SHOWN);
        let silent_ms = ROBOT_SILENT_AFTER.as_millis() as u64;
        let robots = self
            .robots
            .values()
            .map(|r| RobotView {
                silent: ms.saturating_sub(r.last) >= silent_ms,
                ..r.clone()
            })
            .collect();
        let json = BoardJson {
            t: "tasks",
            now: ms,
            tasks: cards(&tasks),
            robots,
            forgotten: self.forgotten + (self.tasks.len().saturating_sub(MAX_SHOWN) as u64),
            robots_forgotten: self.robots_forgotten,
            bad: self.bad,
            forged: self.forged,
        };
        serde_json::to_string(&json).unwrap_or_else(|_| "{}".into())
    }
}

/// A score as the board writes it.
fn score_text(score: f64) -> String {
    format!("{score:.1}")
}

fn note(task: &mut TaskView, at: u64, text: String) {
    if task.timeline.len() == MAX_TIMELINE {
        task.timeline.pop_front();
    }
    task.timeline.push_back(Moment {
        at,
        text: clip(&text),
    });
}

/// At most [`MAX_TEXT`] characters of `text`.
fn clip(text: &str) -> String {
    text.chars().take(MAX_TEXT).collect()
}

/// The task is auctioned again, as round `round`: every round before it was a re-allocation.
fn new_round(task: &mut TaskView, round: u32) {
    task.round = round;
    task.reallocations = round.saturating_sub(1);
    task.winner = None;
    task.progress = None;
    task.bidder_keys.clear();
}

/// Whether `key` is the task's announcer's: the one bound to it, or the first
/// heard, which is then bound.
fn speaks(bound: &mut Option<PublicKey>, key: PublicKey) -> bool {
    *bound.get_or_insert(key) == key
}

/// A message of an earlier round, as its timeline entry says it.
fn describe(m: &Negotiation) -> String {
    match m {
        Negotiation::Bid(b) => format!("{} bid {}, late", b.bidder, score_text(b.score)),
        Negotiation::Award { winner, .. } => format!("awarded to {winner}, late"),
        Negotiation::Ack { bidder, .. } => format!("{bidder} acknowledged, late"),
        Negotiation::Decline { bidder, .. } => format!("{bidder} withdrew, late"),
        Negotiation::Renew { by, .. } => format!("renewal by {by}, late"),
        Negotiation::Done { bidder, .. } => format!("{bidder} says it finished, late"),
        Negotiation::Abandon { bidder, reason, .. } => {
            format!("{bidder} gave it up, late: {reason}")
        }
        Negotiation::Cancel { reason, .. } => format!("withdrawn, late: {reason}"),
        Negotiation::Unachievable { reason, .. } => format!("unachievable, late: {reason}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_proto::murdoch::{negotiation_subject, Bid, RobotMode, TaskSpec, Token};
    use colony_wire::seal::Identity;

    fn token(s: &str) -> Token {
        Token::new(s).unwrap()
    }

    fn announcement(round: u32) -> Announcement {
        Announcement {
            spec: TaskSpec::new("sentry-duty", "camera laser".parse().unwrap()).length(2.0),
            id: 17,
            negotiation: negotiation_subject(&token("user"), 17, round),
            deadline: Duration::from_millis(200),
            announcer: token("user"),
        }
    }

    thread_local! {
        static KEYS: std::cell::RefCell<BTreeMap<String, Identity>> =
            const { std::cell::RefCell::new(BTreeMap::new()) };
    }

    /// `bytes` sealed by the process called `name` (one key per name per test).
    fn sealed_by(name: &str, bytes: Vec<u8>) -> Vec<u8> {
        KEYS.with(|k| {
            k.borrow_mut()
                .entry(name.to_owned())
                .or_insert_with(Identity::generate)
                .sealed(bytes)
        })
    }

    /// Sealed by whoever a MURDOCH packet says it comes from.
    fn feed(board: &mut TaskBoard, at: Instant, bytes: &[u8]) {
        let p = Packet::parse(bytes).unwrap();
        let who = match Message::decode(&p) {
            Ok(Message::Negotiation { message, .. }) => match message {
                Negotiation::Bid(b) => b.bidder.to_string(),
                Negotiation::Ack { bidder, .. }
                | Negotiation::Decline { bidder, .. }
                | Negotiation::Done { bidder, .. }
                | Negotiation::Abandon { bidder, .. } => bidder.to_string(),
                Negotiation::Renew { by, .. } => by.to_string(),
                _ => "user".to_owned(),
            },
            Ok(Message::Robot(r)) => r.name.to_string(),
            _ => "user".to_owned(),
        };
        feed_as(board, at, &who, bytes);
    }

    fn feed_as(board: &mut TaskBoard, at: Instant, who: &str, bytes: &[u8]) {
        let sealed = sealed_by(who, bytes.to_vec());
        board.on_packet(at, &Packet::parse(&sealed).unwrap());
    }

    fn say(board: &mut TaskBoard, at: Instant, round: u32, m: Negotiation) {
        let subject = negotiation_subject(&token("user"), 17, round);
        feed(board, at, &m.encode(&subject).unwrap());
    }

    #[test]
    fn a_forged_or_unsealed_done_never_shows_a_task_finished() {
        let t0 = Instant::now();
        let ms = |n| t0 + Duration::from_millis(n);
        let mut b = TaskBoard::new(t0);
        feed(&mut b, ms(10), &announcement(1).encode().unwrap());
        say(&mut b, ms(20), 1, bid("r1", 3.0));
        say(&mut b, ms(200), 1, award("r1", 3.0, 1));
        let subject = negotiation_subject(&token("user"), 17, 1);
        let done = Negotiation::Done {
            task: 17,
            bidder: token("r1"),
        }
        .encode(&subject)
        .unwrap();
        feed_as(&mut b, ms(300), "mallory", &done);
        b.on_packet(ms(310), &Packet::parse(&done).unwrap());
        let cancel = Negotiation::Cancel {
            task: 17,
            reason: "forged".into(),
        }
        .encode(&subject)
        .unwrap();
        feed_as(&mut b, ms(320), "mallory", &cancel);
        assert_eq!(state(&b), TaskState::Awarded);
        assert_eq!(b.forged(), 3);
        feed(&mut b, ms(400), &done);
        assert_eq!(state(&b), TaskState::Done);
    }

    fn bid(bidder: &str, score: f64) -> Negotiation {
        Negotiation::Bid(Bid {
            task: 17,
            bidder: token(bidder),
            score,
        })
    }

    fn award(winner: &str, score: f64, bids: u32) -> Negotiation {
        Negotiation::Award {
            task: 17,
            winner: token(winner),
            score,
            bids,
        }
    }

    fn state(board: &TaskBoard) -> TaskState {
        board.task("user", 17).unwrap().state
    }

    #[test]
    fn a_task_moves_from_announced_to_done_with_its_bids_and_winner() {
        let t0 = Instant::now();
        let ms = |n| t0 + Duration::from_millis(n);
        let mut b = TaskBoard::new(t0);
        feed(&mut b, ms(10), &announcement(1).encode().unwrap());
        assert_eq!(state(&b), TaskState::Announced);
        say(&mut b, ms(20), 1, bid("r2", 182.5));
        say(&mut b, ms(25), 1, bid("r5", 90.0));
        say(
            &mut b,
            ms(26),
            1,
            Negotiation::Decline {
                task: 17,
                bidder: token("r2"),
            },
        );
        assert_eq!(state(&b), TaskState::Bidding);
        say(&mut b, ms(210), 1, award("r5", 90.0, 3));
        assert_eq!(state(&b), TaskState::Awarded);
        say(
            &mut b,
            ms(211),
            1,
            Negotiation::Ack {
                task: 17,
                bidder: token("r5"),
            },
        );
        say(
            &mut b,
            ms(1211),
            1,
            Negotiation::Renew {
                task: 17,
                by: token("r5"),
                progress: Some(0.5),
            },
        );
        let t = b.task("user", 17).unwrap();
        assert_eq!(t.state, TaskState::Running);
        assert_eq!(t.progress, Some(0.5));
        assert_eq!(
            (t.name.as_str(), t.resources.len(), t.length_s),
            ("sentry-duty", 2, 2.0)
        );
        assert_eq!(t.bids.len(), 2);
        assert!(t.bids[0].withdrawn && !t.bids[1].withdrawn);
        // The announcer heard three bids; the board two.
        assert_eq!(t.bids_missed, 1);
        assert_eq!(t.winner.as_ref().unwrap().bidder, "r5");
        assert!(t
            .timeline
            .iter()
            .any(|m| m.text == "awarded to r5: 90.0 is the lowest of 3 bids"));
        say(
            &mut b,
            ms(2300),
            1,
            Negotiation::Done {
                task: 17,
                bidder: token("r5"),
            },
        );
        assert_eq!(state(&b), TaskState::Done);
        let json: serde_json::Value = serde_json::from_str(&b.json(ms(2400))).unwrap();
        assert_eq!(json["t"], "tasks");
        assert_eq!(json["tasks"][0]["state"], "done");
        assert_eq!(json["tasks"][0]["bids"][1]["score"], 90.0);
        assert_eq!(json["tasks"][0]["first"], 10);
    }

    #[test]
    fn unachievable_retries_of_a_task_are_folded_into_its_newest_card() {
        let t0 = Instant::now();
        let ms = |n| t0 + Duration::from_millis(n);
        let mut b = TaskBoard::new(t0);
        let fail = |b: &mut TaskBoard, at: Instant, id: u64, name: &str| {
            let a = Announcement {
                spec: TaskSpec::new(name, "laser".parse().unwrap()).length(1.0),
                id,
                negotiation: negotiation_subject(&token("user"), id, 1),
                deadline: Duration::from_millis(200),
                announcer: token("user"),
            };
            feed(b, at, &a.encode().unwrap());
            let m = Negotiation::Unachievable {
                task: id,
                name: name.into(),
                reason: "no robot has {laser}".into(),
            };
            feed(
                b,
                at,
                &m.encode(&negotiation_subject(&token("user"), id, 1))
                    .unwrap(),
            );
        };
        for id in 1..=4 {
            fail(&mut b, ms(id * 100), id, "zap");
        }
        fail(&mut b, ms(500), 5, "other");
        let json: serde_json::Value = serde_json::from_str(&b.json(ms(600))).unwrap();
        let cards: Vec<_> = json["tasks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| {
                (
                    t["id"].as_u64().unwrap(),
                    t["retries"].as_u64().unwrap(),
                    t["retry_of"].as_u64(),
                )
            })
            .collect();
        assert_eq!(
            cards,
            [
                (5, 0, None),
                (4, 3, None),
                (3, 0, Some(4)),
                (2, 0, Some(4)),
                (1, 0, Some(4))
            ],
            "zap's three earlier failures are retries of its newest try; other's is its own"
        );
        assert_eq!(json["tasks"][1]["state"], "unachievable");
    }

    #[test]
    fn a_cancelled_task_auctioned_again_counts_a_reallocation() {
        let t0 = Instant::now();
        let mut b = TaskBoard::new(t0);
        feed(&mut b, t0, &announcement(1).encode().unwrap());
        say(&mut b, t0, 1, bid("r2", 5.0));
        say(&mut b, t0, 1, award("r2", 5.0, 1));
        say(
            &mut b,
            t0,
            1,
            Negotiation::Ack {
                task: 17,
                bidder: token("r2"),
            },
        );
        say(
            &mut b,
            t0,
            1,
            Negotiation::Cancel {
                task: 17,
                reason: "presumed failed: no renewal for 3.0 s".into(),
            },
        );
        assert_eq!(state(&b), TaskState::Cancelled);
        feed(&mut b, t0, &announcement(2).encode().unwrap());
        say(&mut b, t0, 2, bid("r3", 7.0));
        say(&mut b, t0, 2, award("r3", 7.0, 1));
        let t = b.task("user", 17).unwrap();
        assert_eq!(
            (t.state, t.round, t.reallocations),
            (TaskState::Awarded, 2, 1)
        );
        assert_eq!(t.winner.as_ref().unwrap().bidder, "r3");
        assert_eq!(t.reason, "presumed failed: no renewal for 3.0 s");
        assert_eq!(t.bids.iter().map(|b| b.round).collect::<Vec<_>>(), [1, 2]);
    }

    #[test]
    fn late_messages_of_an_earlier_round_and_words_from_others_than_the_winner_change_nothing() {
        let t0 = Instant::now();
        let mut b = TaskBoard::new(t0);
        feed(&mut b, t0, &announcement(2).encode().unwrap());
        say(&mut b, t0, 2, bid("r3", 7.0));
        say(&mut b, t0, 2, award("r3", 7.0, 1));
        say(
            &mut b,
            t0,
            2,
            Negotiation::Ack {
                task: 17,
                bidder: token("r3"),
            },
        );
        // The replaced winner of round 1 gives up late, and says it finished.
        let late = Negotiation::Abandon {
            task: 17,
            bidder: token("r2"),
            reason: "announcer user silent for 3.0 s".into(),
        };
        say(&mut b, t0, 1, late);
        say(
            &mut b,
            t0,
            1,
            Negotiation::Done {
                task: 17,
                bidder: token("r2"),
            },
        );
        // A bystander claims this round.
        say(
            &mut b,
            t0,
            2,
            Negotiation::Done {
                task: 17,
                bidder: token("r9"),
            },
        );
        let t = b.task("user", 17).unwrap();
        assert_eq!(
            (t.state, t.round, t.reallocations),
            (TaskState::Running, 2, 1)
        );
        assert!(t
            .timeline
            .iter()
            .any(|m| m.text.starts_with("(round 1) r2 gave it up, late")));
        // A late announcement of round 1 neither counts nor resets anything.
        feed(&mut b, t0, &announcement(1).encode().unwrap());
        let t = b.task("user", 17).unwrap();
        assert_eq!((t.state, t.reallocations), (TaskState::Running, 1));
    }

    #[test]
    fn a_task_whose_announcement_was_missed_is_followed_from_its_subject() {
        let t0 = Instant::now();
        let mut b = TaskBoard::new(t0);
        say(&mut b, t0, 3, award("r1", 1.0, 1));
        let t = b.task("user", 17).unwrap();
        assert_eq!(
            (t.state, t.round, t.name.as_str()),
            (TaskState::Awarded, 3, "")
        );
        // A message naming another task than its subject is refused.
        let wrong = Negotiation::Done {
            task: 99,
            bidder: token("r1"),
        };
        say(&mut b, t0, 3, wrong);
        assert_eq!(b.bad(), 1);
        assert_eq!(state(&b), TaskState::Awarded);
    }

    #[test]
    fn robots_are_shown_from_their_reports_and_silent_when_unheard() {
        let t0 = Instant::now();
        let mut b = TaskBoard::new(t0);
        let report = RobotReport {
            name: token("r2"),
            mode: RobotMode::Working,
            battery: 0.4,
            resources: "camera".parse().unwrap(),
            task: Some((17, "sentry-duty".into())),
        };
        feed(&mut b, t0, &report.encode().unwrap());
        let json: serde_json::Value = serde_json::from_str(&b.json(t0)).unwrap();
        let r = &json["robots"][0];
        assert_eq!(
            (r["name"].as_str(), r["mode"].as_str()),
            (Some("r2"), Some("working"))
        );
        assert_eq!(
            (r["battery"].as_f64(), r["task"].as_u64()),
            (Some(0.4), Some(17))
        );
        assert_eq!(r["silent"], false);
        let later = t0 + ROBOT_SILENT_AFTER;
        let json: serde_json::Value = serde_json::from_str(&b.json(later)).unwrap();
        assert_eq!(json["robots"][0]["silent"], true);
    }

    #[test]
    fn the_board_stays_bounded_and_forgets_ended_tasks_first() {
        let t0 = Instant::now();
        let mut b = TaskBoard::new(t0);
        let running = negotiation_subject(&token("keep"), 1, 1);
        let ack = Negotiation::Ack {
            task: 1,
            bidder: token("r1"),
        };
        feed(&mut b, t0, &ack.encode(&running).unwrap());
        for id in 0..(MAX_TASKS as u64 * 2) {
            let at = t0 + Duration::from_millis(id + 1);
            let s = negotiation_subject(&token("u"), id, 1);
            let done = Negotiation::Done {
                task: id,
                bidder: token("r1"),
            };
            feed(&mut b, at, &done.encode(&s).unwrap());
            for n in 0..(MAX_BIDS as u32 + 3) {
                let m = Negotiation::Bid(Bid {
                    task: id,
                    bidder: token(&format!("b{n}")),
                    score: 1.0,
                });
                feed(&mut b, at, &m.encode(&s).unwrap());
            }
        }
        assert_eq!(b.tasks().count(), MAX_TASKS);
        let json: serde_json::Value = serde_json::from_str(&b.json(t0)).unwrap();
        assert_eq!(json["tasks"].as_array().unwrap().len(), MAX_SHOWN);
        assert!(
            b.task("keep", 1).is_some(),
            "a running task outlives ended ones"
        );
        let t = b.tasks().last().unwrap();
        assert_eq!(t.bids.len(), MAX_BIDS);
        assert_eq!(t.bids_missed, 3);
        assert!(t.timeline.len() <= MAX_TIMELINE);
    }

    #[test]
    fn other_traffic_and_bad_murdoch_packets_change_nothing_but_the_count() {
        let t0 = Instant::now();
        let mut b = TaskBoard::new(t0);
        feed(&mut b, t0, b"@ <vision> 0\nrobot id 1 x 2 y 3\n");
        assert_eq!((b.version(), b.bad()), (0, 0));
        feed(
            &mut b,
            t0,
            b"@ <murdoch.u.1.1> 0\nbid task 1 bidder r1 score nan\n",
        );
        feed(
            &mut b,
            t0,
            b"@ <murdoch.robots> 0\nrobot name r1 mode idle battery 7 resources \"\"\n",
        );
        assert_eq!((b.version(), b.bad(), b.tasks().count()), (0, 2, 0));
        assert_eq!(parse_negotiation_subject("murdoch..1.1"), None);
        assert_eq!(
            parse_negotiation_subject("murdoch.a.b.1.2"),
            Some(("a.b", 1, 2))
        );
    }
}
