//! The game's lab: a whole live match over a hub, watched by its supervisor ([`live_match`]),
//! and the paper's Tables 3 and 4 measured on one ([`measure`]). The parts of the match they
//! start are colony-game's.

pub mod live_match;
pub mod measure;
