//! The strategy game's messages, one module per channel (the game's Event Channel).
//!
//! | channel | from → to | module |
//! |---|---|---|
//! | `game.sense.N` | world → robot N: its sensors | [`sense`] |
//! | `radio` | robot → world: its wheels (the swarm's format, so the monitor's override works) | [`crate::radio`] |
//! | `game.world` | world → game logic: every robot's pose, each step | [`world`] |
//! | `game.robot.N` | swarm intelligence → robot N: a sequence command, newest `seq` wins | [`order`] |
//! | `game.action` | robot → game logic: fire, pick up, beep | [`action`] |
//! | `game.debug` | robot → game logic, monitor: its active behaviour and why | [`debug`] |
//! | `game.player.TEAM` | player, bot, game page → game logic: squad and robot commands, split, merge, direct control | [`player`], [`squad`] |
//! | `game.chat.TEAM` | player ↔ players of the same team: chat lines | [`chat`] |
//! | `game.state` | game logic → players, monitor: everything a player sees | [`state`] |
//! | `game.event` | game logic → players, monitor: hits, kills, flags, refusals, the end | [`event`] |
//! | `game.map` | game logic → players, monitor: the battlefield, in parts if large | [`map`] |
//! | `game.lobby` | the pre-match → players, monitor: budget, robot types, setups, readiness | [`lobby`] |
//!
//! The words the messages carry (names, robot types, formations) are in [`names`]. Every decoder
//! refuses what it can't read with an error naming the line and field; nothing from the network
//! can panic it. Viewers that would rather show what they can read use the `decode_lenient`
//! decoders and the [`MapAssembler`], which skip and count bad lines.

pub mod action;
pub mod chat;
pub mod debug;
pub mod event;
pub mod lobby;
pub mod map;
pub mod names;
pub mod order;
pub mod player;
pub mod sense;
pub mod squad;
pub mod state;
pub mod world;

pub use action::Action;
pub use chat::ChatLine;
pub use debug::RobotDebug;
pub use event::Event;
pub use lobby::{KindOffer, LobbyState, LobbyStatus, LobbyTeam};
pub use map::{GameMap, MapAssembler, Site};
pub use names::{valid_name, Formation, RobotKind, UnknownFormation, UnknownKind, MAX_NAME};
pub use order::{Command, Order, MAX_COMMANDS};
pub use player::{PlayerCommand, DRIVE_HOLD_S};
pub use sense::Sense;
pub use squad::{SquadCommand, Target, Verb, MAX_DRAWN_POINTS};
pub use state::{FlagState, GameState, RobotState, SquadState, Status, TeamState};
pub use world::{RobotPose, WorldFrame};

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
/// The battlefield, for players' screens.
pub const MAP: &str = "game.map";
/// The pre-match: budget, robot types, each team's setup and readiness.
pub const LOBBY: &str = "game.lobby";

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

/// The channel team `team`'s players chat on.
pub fn chat_channel(team: &str) -> String {
    format!("game.chat.{team}")
}
