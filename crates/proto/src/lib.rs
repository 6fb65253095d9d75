//! colony's message vocabulary: every message that crosses the hub, as a plain type with one
//! encoder and one decoder, used by the process that writes it, the process that reads it and the
//! monitor that shows it.
//!
//! This crate sits between [`colony_wire`] (the packet format) and the crates that speak over the
//! hub (sorting, the game, task allocation, the monitor). It does no I/O and holds no behaviour
//! beyond the rules a message carries with it (a clamp, an angle wrap, how long an override holds).
//!
//! | module | what it holds |
//! |---|---|
//! | [`geometry`] | [`Vec2`], [`Pose`], [`WheelCommand`] with its one clamp rule, [`wrap_angle`], the go-to-point law [`Steer`] |
//! | [`radio`] | the `radio` channel's wheel commands |
//! | [`hold`] | the operator-override hold rule: which command is in force for each robot |
//! | [`swarm`] | the swarm channels: `camera.N`, `vision` (in parts, with a reassembler), `debug`, `metrics` |
//! | [`fields`] | field readers with their range rules ([`fields::MAX_COORD`]) |
//! | [`error`] | [`DecodeError`], what every decoder returns; [`Skimmed`], what a viewer's returns |
//! | [`game`] | the strategy game's messages, one module per channel (`game.*`) |
//! | [`murdoch`] | MURDOCH's task-allocation messages, with its resource sets and tokens |
//! | [`table`] | each message's field table ([`table::MessageTable`]), written beside its codec, read by `colony-schema` |
//!
//! Units everywhere: centimetres, seconds, radians (counter-clockwise from +x).

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod error;
pub mod fields;
pub mod game;
pub mod geometry;
pub mod hold;
pub mod murdoch;
pub mod radio;
pub mod swarm;
pub mod table;

pub use error::{DecodeError, Skimmed};
pub use geometry::{wrap_angle, Pose, Speed, Steer, Vec2, WheelCommand};
pub use hold::CommandHold;
pub use radio::{RadioCommand, RADIO};
