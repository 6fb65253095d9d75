//! Every message of the game as a hub packet: the game's Event Channel.
//!
//! ```text
//! @ <game.sense.3> 0            the world: what robot 3's sensors report (Table 1's sensors)
//! sense step 120 time 12 x 310.5 y 88.2 theta 1.57 bump_front 0 bump_rear 1 contact 3.1 sonar 14.2 bearing -0.2 border 0
//!
//! @ <radio> 0                   a robot's wheels (the sorting swarm's format, so the monitor's override works)
//! cmd id 3 forward 0.8 turn -0.25
//!
//! @ <game.world> 0              the world: every robot's pose, each step
//! step n 120 time 12
//! robot id 3 x 310.5 y 88.2 theta 1.57 active 1
//!
//! @ <game.robot.3> 0            swarm intelligence: a (sequence) command for robot 3; newest seq wins
//! order seq 17
//! goto x 300 y 120 speed 14
//! shoot target 9 x 350 y 130
//!
//! @ <game.action> 0             a robot asks the game logic to act on the world
//! fire id 3 target 9
//! pickup id 3 flag blue
//!
//! @ <game.debug> 0              a robot's active behaviour and why, for the monitor
//! robot id 3 behaviour avoid-bump reason "bumper front pressed"
//!
//! @ <game.player.red> 0         a player's squad command
//! squad name alpha do attack robot 9 formation half-circle
//!
//! @ <game.state> 0              the game logic: everything a player sees
//! game mode ctf status running time 12 winner - reason ""
//! team name red score 0 kills 1
//! flag team blue x 800 y 900 carrier 3 home 0
//! robot id 3 team red squad alpha kind tank x 310.5 y 88.2 theta 1.57 health 120 alive 1 behaviour goto reason "..."
//! squad team red name alpha formation wedge order "attack robot 9" behaviour shoot path "310,88 400,120"
//!
//! @ <game.event> 0              what happened
//! event kind hit time 12 text "robot 3 hits robot 9 for 15 (health 45)"
//!
//! @ <game.map> 0                the battlefield, every few seconds, in parts if large
//! map width 64 height 48 cell 20 part 0 parts 1
//! site team red base_x 110 base_y 90 flag_x 130 flag_y 70
//! row y 0 cells "@@@@@@@@..."
//! ```
//!
//! Every decoder refuses what it can't read with an error naming the line
//! and field; nothing from the network can panic it.

use std::fmt;

use colony_sim::{Pose, Vec2};
use colony_wire::{Line, Packet, PacketBuilder, ParseError, Priority};

use crate::formation::Formation;
use crate::rules::{valid_name, RobotKind};

/// The world's per-step poses.
pub const WORLD: &str = "game.world";
/// Robot actions for the game logic.
pub const ACTION: &str = "game.action";
/// Robots' active behaviours.
pub const DEBUG: &str = "game.debug";
/// The game logic's view of the game.
pub const STATE: &str = "game.state";
/// Events: hits, kills, flags, refusals, the end.
pub const EVENT: &str = "game.event";
/// Wheel commands, shared with the sorting swarm and the monitor's override.
pub const RADIO: &str = "radio";
/// The battlefield, for players' screens.
pub const MAP: &str = "game.map";

/// The channel robot `id`'s sensors are published on.
pub fn sense_channel(id: u32) -> String {
    format!("game.sense.{id}")
}

/// The channel robot `id`'s commands are published on.
pub fn robot_channel(id: u32) -> String {
    format!("game.robot.{id}")
}

/// The channel team `team`'s player publishes squad commands on.
pub fn player_channel(team: &str) -> String {
    format!("game.player.{team}")
}

/// A message that couldn't be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DecodeError {
    /// The packet's text isn't a packet.
    #[error(transparent)]
    Packet(#[from] ParseError),
    /// A field is missing or of the wrong type.
    #[error("{0}")]
    Field(String),
    /// The packet has no line this message needs.
    #[error("no `{0}` line")]
    Missing(&'static str),
    /// A value is out of its range or not a known word.
    #[error("line {line}: {what}")]
    Bad {
        /// 1-based line number.
        line: u32,
        /// What was wrong.
        what: String,
    },
}

impl From<colony_wire::FieldError> for DecodeError {
    fn from(e: colony_wire::FieldError) -> Self {
        DecodeError::Field(e.to_string())
    }
}

fn bad(line: &Line<'_>, what: impl Into<String>) -> DecodeError {
    DecodeError::Bad {
        line: line.number(),
        what: what.into(),
    }
}

/// Coordinates beyond this (cm) are refused: the largest map is 4096 cells of a metre.
pub const MAX_COORD: f64 = 1.0e6;

fn coord(line: &Line<'_>, name: &str) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if v.is_finite() && v.abs() <= MAX_COORD {
        Ok(v)
    } else {
        Err(bad(line, format!("{name} {v} is out of range")))
    }
}

fn finite(line: &Line<'_>, name: &str) -> Result<f64, DecodeError> {
    let v = line.f64(name)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(bad(line, format!("{name} must be a finite number")))
    }
}

fn flag(line: &Line<'_>, name: &str) -> Result<bool, DecodeError> {
    match line.i64(name)? {
        0 => Ok(false),
        1 => Ok(true),
        v => Err(bad(line, format!("{name} must be 0 or 1, not {v}"))),
    }
}

fn id(line: &Line<'_>, name: &str) -> Result<u32, DecodeError> {
    let v = line.i64(name)?;
    u32::try_from(v).map_err(|_| bad(line, format!("{name} {v} is not a robot id")))
}

fn name(line: &Line<'_>, field: &str) -> Result<String, DecodeError> {
    let s = line.str(field)?;
    if valid_name(&s) {
        Ok(s.into_owned())
    } else {
        Err(bad(line, format!("{field} {s:?} is not a name")))
    }
}

/// Rounds to 0.01 (cm or rad): finer than any sensor, keeps packets short.
fn r(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

fn b(v: bool) -> i64 {
    i64::from(v)
}

/// What a robot's sensors report (the paper's touch sensors, sonar and
/// infrared border detector, plus the overhead tracker's pose).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sense {
    /// The world's step.
    pub step: u64,
    /// Game time, s.
    pub time: f64,
    /// Where the overhead tracker sees the robot.
    pub pose: Pose,
    /// The front touch sensor.
    pub bump_front: bool,
    /// The rear touch sensor.
    pub bump_rear: bool,
    /// Robot-frame bearing of the contact point, rad.
    pub contact: Option<f64>,
    /// The nearest echo in the sonar's cone: distance from the robot's edge (cm), bearing (rad).
    pub sonar: Option<(f64, f64)>,
    /// The border detector sees a line it must not cross just ahead.
    pub border: bool,
}

impl Sense {
    /// The packet for robot `id`.
    pub fn encode(&self, id: u32) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([sense_channel(id)], Priority(0));
        let mut l = p.line("sense");
        l.field("step", self.step)
            .field("time", r(self.time))
            .field("x", r(self.pose.x))
            .field("y", r(self.pose.y))
            .field("theta", r(self.pose.theta))
            .field("bump_front", b(self.bump_front))
            .field("bump_rear", b(self.bump_rear))
            .field("border", b(self.border));
        if let Some(c) = self.contact {
            l.field("contact", r(c));
        }
        if let Some((d, a)) = self.sonar {
            l.field("sonar", r(d)).field("bearing", r(a));
        }
        p.finish()
    }

    /// Reads a `sense` packet.
    pub fn decode(packet: &Packet<'_>) -> Result<Sense, DecodeError> {
        let l = packet.line("sense").ok_or(DecodeError::Missing("sense"))?;
        let step = l.i64("step")?;
        Ok(Sense {
            step: u64::try_from(step).map_err(|_| bad(&l, "step must not be negative"))?,
            time: finite(&l, "time")?,
            pose: Pose {
                x: coord(&l, "x")?,
                y: coord(&l, "y")?,
                theta: finite(&l, "theta")?,
            },
            bump_front: flag(&l, "bump_front")?,
            bump_rear: flag(&l, "bump_rear")?,
            border: flag(&l, "border")?,
            contact: match l.get("contact") {
                Some(_) => Some(finite(&l, "contact")?),
                None => None,
            },
            sonar: match l.get("sonar") {
                Some(_) => Some((finite(&l, "sonar")?, finite(&l, "bearing")?)),
                None => None,
            },
        })
    }
}

/// A wheel command on `radio`.
pub fn wheel_packet(id: u32, forward: f64, turn: f64) -> Result<Vec<u8>, ParseError> {
    let mut p = PacketBuilder::new([RADIO], Priority(0));
    p.line("cmd")
        .field("id", id)
        .field("forward", r(forward.clamp(-1.0, 1.0)))
        .field("turn", r(turn.clamp(-1.0, 1.0)));
    p.finish()
}

/// The `cmd` lines of a radio packet: (robot, forward, turn), clamped to [-1, 1].
pub fn decode_wheels(packet: &Packet<'_>) -> Result<Vec<(u32, f64, f64)>, DecodeError> {
    packet
        .lines_labelled("cmd")
        .map(|l| {
            Ok((
                id(&l, "id")?,
                finite(&l, "forward")?.clamp(-1.0, 1.0),
                finite(&l, "turn")?.clamp(-1.0, 1.0),
            ))
        })
        .collect()
}

/// One robot in a world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotPose {
    /// Its id.
    pub id: u32,
    /// Where it is.
    pub pose: Pose,
    /// Still in the world (not destroyed).
    pub active: bool,
}

/// Every robot's pose after one step of the world.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WorldFrame {
    /// The world's step.
    pub step: u64,
    /// Game time, s.
    pub time: f64,
    /// The robots.
    pub robots: Vec<RobotPose>,
}

impl WorldFrame {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([WORLD], Priority(0));
        p.line("step")
            .field("n", self.step)
            .field("time", r(self.time));
        for rb in &self.robots {
            p.line("robot")
                .field("id", rb.id)
                .field("x", r(rb.pose.x))
                .field("y", r(rb.pose.y))
                .field("theta", r(rb.pose.theta))
                .field("active", b(rb.active));
        }
        p.finish()
    }

    /// Reads a world frame.
    pub fn decode(packet: &Packet<'_>) -> Result<WorldFrame, DecodeError> {
        let l = packet.line("step").ok_or(DecodeError::Missing("step"))?;
        let step = u64::try_from(l.i64("n")?).map_err(|_| bad(&l, "n must not be negative"))?;
        let time = finite(&l, "time")?;
        let robots = packet
            .lines_labelled("robot")
            .map(|l| {
                Ok(RobotPose {
                    id: id(&l, "id")?,
                    pose: Pose {
                        x: coord(&l, "x")?,
                        y: coord(&l, "y")?,
                        theta: finite(&l, "theta")?,
                    },
                    active: flag(&l, "active")?,
                })
            })
            .collect::<Result<_, DecodeError>>()?;
        Ok(WorldFrame { step, time, robots })
    }
}

/// One robot command (the paper's Table 2, plus PickUp from its Capture the
/// Flag run and Stop).
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// A short beep.
    Beep,
    /// Turn on the spot by this many degrees (counter-clockwise positive).
    Rotate {
        /// Degrees.
        deg: f64,
    },
    /// Turn toward the point and drive to it in a straight line.
    GoTo {
        /// Where, cm.
        to: Vec2,
        /// Top speed, cm/s (a squad moves at its slowest member's speed).
        speed: Option<f64>,
    },
    /// Face the enemy and fire at the type's rate until told otherwise.
    Shoot {
        /// The enemy robot.
        target: u32,
        /// Where it was last seen, cm.
        at: Vec2,
    },
    /// Pick up a team's flag (it must be within reach).
    PickUp {
        /// Whose flag.
        flag: String,
    },
    /// Stand still.
    Stop,
}

impl Command {
    fn write(&self, p: &mut PacketBuilder) {
        match self {
            Command::Beep => {
                p.line("beep");
            }
            Command::Rotate { deg } => {
                p.line("rotate").field("deg", r(*deg));
            }
            Command::GoTo { to, speed } => {
                let mut l = p.line("goto");
                l.field("x", r(to.x)).field("y", r(to.y));
                if let Some(s) = speed {
                    l.field("speed", r(*s));
                }
            }
            Command::Shoot { target, at } => {
                p.line("shoot")
                    .field("target", *target)
                    .field("x", r(at.x))
                    .field("y", r(at.y));
            }
            Command::PickUp { flag } => {
                p.line("pickup").bare("flag", flag);
            }
            Command::Stop => {
                p.line("stop");
            }
        }
    }

    fn read(l: &Line<'_>) -> Result<Option<Command>, DecodeError> {
        Ok(Some(match l.label() {
            "beep" => Command::Beep,
            "rotate" => Command::Rotate {
                deg: finite(l, "deg")?,
            },
            "goto" => Command::GoTo {
                to: Vec2::new(coord(l, "x")?, coord(l, "y")?),
                speed: match l.get("speed") {
                    Some(_) => {
                        let s = finite(l, "speed")?;
                        if s <= 0.0 {
                            return Err(bad(l, "speed must be positive"));
                        }
                        Some(s)
                    }
                    None => None,
                },
            },
            "shoot" => Command::Shoot {
                target: id(l, "target")?,
                at: Vec2::new(coord(l, "x")?, coord(l, "y")?),
            },
            "pickup" => Command::PickUp {
                flag: name(l, "flag")?,
            },
            "stop" => Command::Stop,
            _ => return Ok(None),
        }))
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Command::Beep => f.write_str("beep"),
            Command::Rotate { deg } => write!(f, "rotate {deg:.0}"),
            Command::GoTo { to, .. } => write!(f, "goto {:.0} {:.0}", to.x, to.y),
            Command::Shoot { target, .. } => write!(f, "shoot {target}"),
            Command::PickUp { flag } => write!(f, "pickup {flag}"),
            Command::Stop => f.write_str("stop"),
        }
    }
}

/// Commands sent at most in one order (a sequence command).
pub const MAX_COMMANDS: usize = 256;

/// A (sequence) command for one robot. The robot keeps only the newest: an
/// order whose `seq` is not above the one it holds is stale (UDP may reorder).
#[derive(Debug, Clone, PartialEq)]
pub struct Order {
    /// The robot.
    pub robot: u32,
    /// Increases with every order the swarm intelligence sends this robot.
    pub seq: u64,
    /// Done in order; a single command is a sequence of one.
    pub commands: Vec<Command>,
}

impl Order {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([robot_channel(self.robot)], Priority(0));
        p.line("order")
            .field("robot", self.robot)
            .field("seq", self.seq);
        for c in self.commands.iter().take(MAX_COMMANDS) {
            c.write(&mut p);
        }
        p.finish()
    }

    /// Reads an order; unknown command lines are an error, so a typo can't
    /// silently drop a step of the sequence.
    pub fn decode(packet: &Packet<'_>) -> Result<Order, DecodeError> {
        let head = packet.line("order").ok_or(DecodeError::Missing("order"))?;
        let robot = id(&head, "robot")?;
        let seq =
            u64::try_from(head.i64("seq")?).map_err(|_| bad(&head, "seq must not be negative"))?;
        let mut commands = Vec::new();
        for l in packet.lines() {
            if l.label() == "order" {
                continue;
            }
            match Command::read(&l)? {
                Some(c) if commands.len() < MAX_COMMANDS => commands.push(c),
                Some(_) => return Err(bad(&l, format!("more than {MAX_COMMANDS} commands"))),
                None => {
                    return Err(bad(
                        &l,
                        format!(
                        "unknown command {:?} (expected beep, rotate, goto, shoot, pickup or stop)",
                        l.label()
                    ),
                    ))
                }
            }
        }
        Ok(Order {
            robot,
            seq,
            commands,
        })
    }
}

/// What a robot asks the game logic to do to the world.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// One shot at an enemy.
    Fire {
        /// The shooter.
        robot: u32,
        /// The enemy.
        target: u32,
    },
    /// Take a flag.
    PickUp {
        /// Who.
        robot: u32,
        /// Whose flag.
        flag: String,
    },
    /// A beep (heard by the logger).
    Beep {
        /// Who.
        robot: u32,
    },
}

impl Action {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([ACTION], Priority(0));
        match self {
            Action::Fire { robot, target } => {
                p.line("fire").field("id", *robot).field("target", *target);
            }
            Action::PickUp { robot, flag } => {
                p.line("pickup").field("id", *robot).bare("flag", flag);
            }
            Action::Beep { robot } => {
                p.line("beep").field("id", *robot);
            }
        }
        p.finish()
    }

    /// Reads every action in the packet.
    pub fn decode(packet: &Packet<'_>) -> Result<Vec<Action>, DecodeError> {
        packet
            .lines()
            .map(|l| {
                Ok(match l.label() {
                    "fire" => Action::Fire {
                        robot: id(&l, "id")?,
                        target: id(&l, "target")?,
                    },
                    "pickup" => Action::PickUp {
                        robot: id(&l, "id")?,
                        flag: name(&l, "flag")?,
                    },
                    "beep" => Action::Beep {
                        robot: id(&l, "id")?,
                    },
                    other => {
                        return Err(bad(
                            &l,
                            format!("unknown action {other:?} (expected fire, pickup or beep)"),
                        ))
                    }
                })
            })
            .collect()
    }
}

/// A robot's active behaviour and the reason it has control.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotDebug {
    /// The robot.
    pub robot: u32,
    /// The active behaviour's name.
    pub behaviour: String,
    /// Why it is active.
    pub reason: String,
}

impl RobotDebug {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([DEBUG], Priority(0));
        p.line("robot")
            .field("id", self.robot)
            .field("behaviour", self.behaviour.as_str())
            .field("reason", self.reason.as_str());
        p.finish()
    }

    /// Reads one.
    pub fn decode(packet: &Packet<'_>) -> Result<RobotDebug, DecodeError> {
        let l = packet.line("robot").ok_or(DecodeError::Missing("robot"))?;
        Ok(RobotDebug {
            robot: id(&l, "id")?,
            behaviour: l.str("behaviour")?.into_owned(),
            reason: l.str("reason")?.into_owned(),
        })
    }
}

/// What a squad command is about.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// A robot (to attack or defend).
    Robot(u32),
    /// A team's flag.
    Flag(String),
    /// A team's base.
    Base(String),
    /// A point on the map, cm.
    Point(Vec2),
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Target::Robot(id) => write!(f, "robot {id}"),
            Target::Flag(t) => write!(f, "flag {t}"),
            Target::Base(t) => write!(f, "base {t}"),
            Target::Point(p) => write!(f, "point {:.0} {:.0}", p.x, p.y),
        }
    }
}

/// A player's squad command (the paper's Squad Behaviours).
#[derive(Debug, Clone, PartialEq)]
pub enum Verb {
    /// Gather in formation at a point, or at the squad's centroid.
    Gather(Option<Vec2>),
    /// Move there in formation.
    GoTo(Vec2),
    /// Surround the object in a circle (half circle if it moves) and hold.
    Defend(Target),
    /// Close in on the object in a half circle, following it as it moves.
    Attack(Target),
    /// Take the flag and bring it to the squad's own base.
    Capture(String),
    /// Stop where you are.
    Stop,
}

impl fmt::Display for Verb {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Verb::Gather(None) => f.write_str("gather"),
            Verb::Gather(Some(p)) => write!(f, "gather {:.0} {:.0}", p.x, p.y),
            Verb::GoTo(p) => write!(f, "goto {:.0} {:.0}", p.x, p.y),
            Verb::Defend(t) => write!(f, "defend {t}"),
            Verb::Attack(t) => write!(f, "attack {t}"),
            Verb::Capture(t) => write!(f, "capture flag {t}"),
            Verb::Stop => f.write_str("stop"),
        }
    }
}

/// A player's command to one of their squads.
#[derive(Debug, Clone, PartialEq)]
pub struct SquadCommand {
    /// The player's team (from the channel it came on).
    pub team: String,
    /// The squad.
    pub squad: String,
    /// What to do.
    pub verb: Verb,
    /// In which formation (the squad keeps its current one when absent).
    pub formation: Option<Formation>,
}

impl SquadCommand {
    /// The packet, on the team's player channel.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([player_channel(&self.team)], Priority(0));
        let mut l = p.line("squad");
        l.bare("name", &self.squad);
        match &self.verb {
            Verb::Gather(at) => {
                l.bare("do", "gather");
                if let Some(at) = at {
                    l.field("x", r(at.x)).field("y", r(at.y));
                }
            }
            Verb::GoTo(at) => {
                l.bare("do", "goto").field("x", r(at.x)).field("y", r(at.y));
            }
            Verb::Defend(t) | Verb::Attack(t) => {
                l.bare(
                    "do",
                    if matches!(self.verb, Verb::Defend(_)) {
                        "defend"
                    } else {
                        "attack"
                    },
                );
                match t {
                    Target::Robot(id) => {
                        l.field("robot", *id);
                    }
                    Target::Flag(team) => {
                        l.bare("flag", team);
                    }
                    Target::Base(team) => {
                        l.bare("base", team);
                    }
                    Target::Point(at) => {
                        l.field("x", r(at.x)).field("y", r(at.y));
                    }
                }
            }
            Verb::Capture(team) => {
                l.bare("do", "capture").bare("flag", team);
            }
            Verb::Stop => {
                l.bare("do", "stop");
            }
        }
        if let Some(f) = self.formation {
            l.bare("formation", f.name());
        }
        p.finish()
    }

    /// Reads the squad commands of a packet that came on `team`'s channel.
    pub fn decode(team: &str, packet: &Packet<'_>) -> Result<Vec<SquadCommand>, DecodeError> {
        packet
            .lines_labelled("squad")
            .map(|l| {
                let verb = match &*l.str("do")? {
                    "gather" => Verb::Gather(match l.get("x") {
                        Some(_) => Some(Vec2::new(coord(&l, "x")?, coord(&l, "y")?)),
                        None => None,
                    }),
                    "goto" => Verb::GoTo(Vec2::new(coord(&l, "x")?, coord(&l, "y")?)),
                    v @ ("defend" | "attack") => {
                        let target = if l.get("robot").is_some() {
                            Target::Robot(id(&l, "robot")?)
                        } else if l.get("flag").is_some() {
                            Target::Flag(name(&l, "flag")?)
                        } else if l.get("base").is_some() {
                            Target::Base(name(&l, "base")?)
                        } else if l.get("x").is_some() {
                            Target::Point(Vec2::new(coord(&l, "x")?, coord(&l, "y")?))
                        } else {
                            return Err(bad(&l, format!("{v} needs robot, flag, base or x y")));
                        };
                        if v == "defend" {
                            Verb::Defend(target)
                        } else {
                            Verb::Attack(target)
                        }
                    }
                    "capture" => Verb::Capture(name(&l, "flag")?),
                    "stop" => Verb::Stop,
                    other => {
                        return Err(bad(
                            &l,
                            format!(
                                "unknown squad command {other:?} (expected gather, goto, defend, attack, capture or stop)"
                            ),
                        ))
                    }
                };
                let formation = match l.get("formation") {
                    Some(_) => Some(
                        l.str("formation")?
                            .parse::<Formation>()
                            .map_err(|e| bad(&l, e.to_string()))?,
                    ),
                    None => None,
                };
                Ok(SquadCommand {
                    team: team.to_string(),
                    squad: name(&l, "name")?,
                    verb,
                    formation,
                })
            })
            .collect()
    }
}

/// Where a game stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Being played.
    Running,
    /// Finished.
    Over,
}

/// A team's standing.
#[derive(Debug, Clone, PartialEq)]
pub struct TeamState {
    /// Its name.
    pub name: String,
    /// Flags captured (CTF) or robots destroyed (DM).
    pub score: u32,
    /// Enemy robots destroyed.
    pub kills: u32,
}

/// A flag as the game logic knows it.
#[derive(Debug, Clone, PartialEq)]
pub struct FlagState {
    /// Whose flag.
    pub team: String,
    /// Where it is, cm.
    pub at: Vec2,
    /// The robot carrying it.
    pub carrier: Option<u32>,
    /// It is on its stand at its base.
    pub home: bool,
}

/// A robot as the game logic knows it.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotState {
    /// Its id.
    pub id: u32,
    /// Its team.
    pub team: String,
    /// Its squad.
    pub squad: String,
    /// Its type.
    pub kind: RobotKind,
    /// Where it is.
    pub pose: Pose,
    /// Health left.
    pub health: f64,
    /// Not destroyed.
    pub alive: bool,
    /// Its active behaviour and why.
    pub behaviour: String,
    /// Why that behaviour has control.
    pub reason: String,
}

/// A squad as the game logic knows it.
#[derive(Debug, Clone, PartialEq)]
pub struct SquadState {
    /// Its team.
    pub team: String,
    /// Its name.
    pub name: String,
    /// Its formation.
    pub formation: Formation,
    /// The player's command it carries out (text).
    pub order: String,
    /// The squad behaviour in control and why.
    pub behaviour: String,
    /// The planned path's turn points, cm.
    pub path: Vec<Vec2>,
}

/// The whole game as a player sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct GameState {
    /// The mode (`ctf` or `dm`).
    pub mode: String,
    /// Running or over.
    pub status: Status,
    /// Game time, s.
    pub time: f64,
    /// The winner, when over (None: a draw).
    pub winner: Option<String>,
    /// Why it ended.
    pub reason: String,
    /// The teams.
    pub teams: Vec<TeamState>,
    /// The flags.
    pub flags: Vec<FlagState>,
    /// The robots.
    pub robots: Vec<RobotState>,
    /// The squads.
    pub squads: Vec<SquadState>,
}

fn path_text(path: &[Vec2]) -> String {
    let mut s = String::new();
    for (i, p) in path.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        s.push_str(&format!("{:.0},{:.0}", p.x, p.y));
    }
    s
}

fn parse_path(l: &Line<'_>, text: &str) -> Result<Vec<Vec2>, DecodeError> {
    text.split_whitespace()
        .map(|pt| {
            let (x, y) = pt
                .split_once(',')
                .ok_or_else(|| bad(l, format!("path point {pt:?} is not x,y")))?;
            match (x.parse::<f64>(), y.parse::<f64>()) {
                (Ok(x), Ok(y)) if x.is_finite() && y.is_finite() => Ok(Vec2::new(x, y)),
                _ => Err(bad(l, format!("path point {pt:?} is not x,y"))),
            }
        })
        .collect()
}

impl GameState {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([STATE], Priority(0));
        p.line("game")
            .bare("mode", &self.mode)
            .bare(
                "status",
                match self.status {
                    Status::Running => "running",
                    Status::Over => "over",
                },
            )
            .field("time", r(self.time))
            .bare("winner", self.winner.as_deref().unwrap_or("-"))
            .field("reason", self.reason.as_str());
        for t in &self.teams {
            p.line("team")
                .bare("name", &t.name)
                .field("score", t.score)
                .field("kills", t.kills);
        }
        for f in &self.flags {
            let mut l = p.line("flag");
            l.bare("team", &f.team)
                .field("x", r(f.at.x))
                .field("y", r(f.at.y))
                .field("home", b(f.home));
            if let Some(c) = f.carrier {
                l.field("carrier", c);
            }
        }
        for rb in &self.robots {
            p.line("robot")
                .field("id", rb.id)
                .bare("team", &rb.team)
                .bare("squad", &rb.squad)
                .bare("kind", rb.kind.name())
                .field("x", r(rb.pose.x))
                .field("y", r(rb.pose.y))
                .field("theta", r(rb.pose.theta))
                .field("health", r(rb.health))
                .field("alive", b(rb.alive))
                .field("behaviour", rb.behaviour.as_str())
                .field("reason", rb.reason.as_str());
        }
        for s in &self.squads {
            p.line("squad")
                .bare("team", &s.team)
                .bare("name", &s.name)
                .bare("formation", s.formation.name())
                .field("order", s.order.as_str())
                .field("behaviour", s.behaviour.as_str())
                .field("path", path_text(&s.path).as_str());
        }
        p.finish()
    }

    /// Reads a game state.
    pub fn decode(packet: &Packet<'_>) -> Result<GameState, DecodeError> {
        let g = packet.line("game").ok_or(DecodeError::Missing("game"))?;
        let status = match &*g.str("status")? {
            "running" => Status::Running,
            "over" => Status::Over,
            other => return Err(bad(&g, format!("unknown status {other:?}"))),
        };
        let winner = match &*g.str("winner")? {
            "-" => None,
            w => Some(w.to_string()),
        };
        let mut state = GameState {
            mode: name(&g, "mode")?,
            status,
            time: finite(&g, "time")?,
            winner,
            reason: g.str("reason")?.into_owned(),
            teams: Vec::new(),
            flags: Vec::new(),
            robots: Vec::new(),
            squads: Vec::new(),
        };
        for l in packet.lines() {
            match l.label() {
                "team" => state.teams.push(TeamState {
                    name: name(&l, "name")?,
                    score: u32::try_from(l.i64("score")?).map_err(|_| bad(&l, "bad score"))?,
                    kills: u32::try_from(l.i64("kills")?).map_err(|_| bad(&l, "bad kills"))?,
                }),
                "flag" => state.flags.push(FlagState {
                    team: name(&l, "team")?,
                    at: Vec2::new(coord(&l, "x")?, coord(&l, "y")?),
                    home: flag(&l, "home")?,
                    carrier: match l.get("carrier") {
                        Some(_) => Some(id(&l, "carrier")?),
                        None => None,
                    },
                }),
                "robot" => state.robots.push(RobotState {
                    id: id(&l, "id")?,
                    team: name(&l, "team")?,
                    squad: name(&l, "squad")?,
                    kind: l
                        .str("kind")?
                        .parse()
                        .map_err(|e: crate::rules::RuleError| bad(&l, e.to_string()))?,
                    pose: Pose {
                        x: coord(&l, "x")?,
                        y: coord(&l, "y")?,
                        theta: finite(&l, "theta")?,
                    },
                    health: finite(&l, "health")?,
                    alive: flag(&l, "alive")?,
                    behaviour: l.str("behaviour")?.into_owned(),
                    reason: l.str("reason")?.into_owned(),
                }),
                "squad" => state.squads.push(SquadState {
                    team: name(&l, "team")?,
                    name: name(&l, "name")?,
                    formation: l
                        .str("formation")?
                        .parse()
                        .map_err(|e: crate::formation::UnknownFormation| bad(&l, e.to_string()))?,
                    order: l.str("order")?.into_owned(),
                    behaviour: l.str("behaviour")?.into_owned(),
                    path: parse_path(&l, &l.str("path")?)?,
                }),
                _ => {}
            }
        }
        Ok(state)
    }
}

/// Something that happened, for players and the log.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    /// Game time, s.
    pub time: f64,
    /// `hit`, `destroyed`, `flag-taken`, `flag-dropped`, `flag-returned`,
    /// `captured`, `refused`, `over`, `beep`.
    pub kind: String,
    /// The text a person reads.
    pub text: String,
}

impl Event {
    /// The packet.
    pub fn encode(&self) -> Result<Vec<u8>, ParseError> {
        let mut p = PacketBuilder::new([EVENT], Priority(0));
        p.line("event")
            .bare("kind", &self.kind)
            .field("time", r(self.time))
            .field("text", self.text.as_str());
        p.finish()
    }

    /// Reads one.
    pub fn decode(packet: &Packet<'_>) -> Result<Event, DecodeError> {
        let l = packet.line("event").ok_or(DecodeError::Missing("event"))?;
        Ok(Event {
            kind: name(&l, "kind")?,
            time: finite(&l, "time")?,
            text: l.str("text")?.into_owned(),
        })
    }
}

/// Map rows per `game.map` part are limited to about this many bytes, so
/// every part fits one datagram.
const MAP_PART_BYTES: usize = 48_000;

/// The battlefield as `game.map` packets: the grid's rows in the Moving AI
/// characters, and each team's base and flag in centimetres.
pub fn map_packets(field: &crate::map::Battlefield) -> Result<Vec<Vec<u8>>, ParseError> {
    let g = &field.grid;
    let rows: Vec<String> = (0..g.height())
        .map(|y| {
            (0..g.width())
                .map(|x| g.get(x, y).map_or('@', |t| t.to_char()))
                .collect()
        })
        .collect();
    let mut chunks: Vec<std::ops::Range<usize>> = Vec::new();
    let mut start = 0;
    let mut bytes = 0;
    for (i, r) in rows.iter().enumerate() {
        if bytes + r.len() > MAP_PART_BYTES && i > start {
            chunks.push(start..i);
            start = i;
            bytes = 0;
        }
        bytes += r.len() + 24;
    }
    chunks.push(start..rows.len());
    let parts = chunks.len();
    chunks
        .into_iter()
        .enumerate()
        .map(|(k, range)| {
            let mut p = PacketBuilder::new([MAP], Priority(0));
            p.line("map")
                .field("width", g.width())
                .field("height", g.height())
                .field("cell", field.cell_cm)
                .field("part", k)
                .field("parts", parts);
            if k == 0 {
                for t in &field.teams {
                    let (bx, by) = field.cell_center(t.base);
                    let (fx, fy) = field.cell_center(t.flag);
                    p.line("site")
                        .bare("team", &t.name)
                        .field("base_x", r(bx))
                        .field("base_y", r(by))
                        .field("flag_x", r(fx))
                        .field("flag_y", r(fy));
                }
            }
            for y in range {
                p.line("row").field("y", y).field("cells", rows[y].as_str());
            }
            p.finish()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round<T>(bytes: Vec<u8>, f: impl Fn(&Packet<'_>) -> Result<T, DecodeError>) -> T {
        f(&Packet::parse(&bytes).unwrap()).unwrap()
    }

    #[test]
    fn every_message_survives_the_trip_through_a_packet() {
        let s = Sense {
            step: 4,
            time: 0.4,
            pose: Pose {
                x: 1.5,
                y: 2.25,
                theta: -0.5,
            },
            bump_front: true,
            bump_rear: false,
            contact: Some(0.25),
            sonar: Some((12.5, -0.1)),
            border: true,
        };
        assert_eq!(round(s.encode(3).unwrap(), Sense::decode), s);
        let o = Order {
            robot: 7,
            seq: 9,
            commands: vec![
                Command::GoTo {
                    to: Vec2::new(10.0, 20.0),
                    speed: Some(14.0),
                },
                Command::Rotate { deg: 90.0 },
                Command::Beep,
                Command::Shoot {
                    target: 2,
                    at: Vec2::new(3.0, 4.0),
                },
                Command::PickUp {
                    flag: "blue".into(),
                },
                Command::Stop,
            ],
        };
        assert_eq!(round(o.encode().unwrap(), Order::decode), o);
        for verb in [
            Verb::Gather(None),
            Verb::Gather(Some(Vec2::new(1.0, 2.0))),
            Verb::GoTo(Vec2::new(5.0, 6.0)),
            Verb::Attack(Target::Robot(4)),
            Verb::Defend(Target::Flag("red".into())),
            Verb::Defend(Target::Base("red".into())),
            Verb::Attack(Target::Point(Vec2::new(7.0, 8.0))),
            Verb::Capture("blue".into()),
            Verb::Stop,
        ] {
            let c = SquadCommand {
                team: "red".into(),
                squad: "alpha".into(),
                verb,
                formation: Some(Formation::Wedge),
            };
            assert_eq!(
                round(c.encode().unwrap(), |p| SquadCommand::decode("red", p)),
                vec![c]
            );
        }
    }

    #[test]
    fn bad_messages_name_the_problem() {
        let p = b"@ <game.robot.1> 0\norder robot 1 seq 3\nfly x 1\n";
        let e = Order::decode(&Packet::parse(p).unwrap()).unwrap_err();
        assert!(
            e.to_string().starts_with("line 3: unknown command \"fly\""),
            "{e}"
        );
        let p = b"@ <game.player.red> 0\nsquad name a do dance\n";
        let e = SquadCommand::decode("red", &Packet::parse(p).unwrap()).unwrap_err();
        assert!(
            e.to_string().contains("unknown squad command \"dance\""),
            "{e}"
        );
        let p = b"@ <game.player.red> 0\nsquad name a do goto x 1e300 y 0\n";
        assert!(SquadCommand::decode("red", &Packet::parse(p).unwrap()).is_err());
        let p = b"@ <game.sense.1> 0\nsense step -1 time 0 x 0 y 0 theta 0 bump_front 0 bump_rear 0 border 0\n";
        assert!(Sense::decode(&Packet::parse(p).unwrap()).is_err());
    }
}
