//! The maps colony ships, one per mode: the environment's default battlefield and the one a
//! live match is played on when no map is given.

use crate::rules::Mode;

/// The text of the map shipped for a mode (`maps/ctf.map`, `maps/dm.map`), built into the
/// library so a wheel installed anywhere has it.
pub fn shipped_map(mode: Mode) -> &'static str {
    match mode {
        Mode::CaptureTheFlag => include_str!("../../../../maps/ctf.map"),
        Mode::DeathMatch => include_str!("../../../../maps/dm.map"),
    }
}
