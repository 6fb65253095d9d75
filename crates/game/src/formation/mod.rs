//! Formations (paper sec. 4.2): where each robot of a squad stands, which
//! robot takes which place, and how the shape follows a path.
//!
//! - [`Formation`]: line, circle (defend), half circle (attack), wedge and
//!   inverse wedge, as slot positions around a centre, rotated to a facing.
//! - [`assign`]: which robot goes to which slot, minimising the total distance
//!   travelled (the gather step of sec. 4.3).
//! - [`along_path`]: the formation placed at every turn point of a path,
//!   squeezed where it would not fit, as one waypoint list per robot.
//!
//! Units and frame are those of `colony_sim`: centimetres, x right, y up,
//! angles in radians counter-clockwise from +x. The *facing* of a formation is
//! the direction the squad travels or attacks in. The spacing `d` is the
//! paper's "robot diameter": pass the footprint's diameter plus whatever
//! clearance the robots need between them.
//!
//! This module plans positions only; it does not move robots or find paths.
//!
//! # Example
//!
//! Gathering three scattered robots into a wedge heading east at (100, 50):
//!
//! ```
//! use colony_game::formation::{assign, Formation, Slots};
//! use colony_sim::Vec2;
//!
//! let robots = [Vec2::new(0.0, 0.0), Vec2::new(0.0, 100.0), Vec2::new(200.0, 50.0)];
//! let formation: Formation = "wedge".parse().unwrap();
//! let slots = formation.slots(Vec2::new(100.0, 50.0), 0.0, robots.len(), 30.0);
//! let slot_of = assign(&robots, &slots);
//! // The robot already east of the centre leads.
//! assert_eq!(slot_of[2], 0);
//! assert!(slots[0].x > 100.0);
//! ```

mod assign;
mod bend;
mod shape;

pub use assign::assign;
pub use bend::along_path;
pub use shape::{Formation, Slots, UnknownFormation};
