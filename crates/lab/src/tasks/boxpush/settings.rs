//! A box-pushing run's settings and the names of its tasks.

use colony_proto::{Pose, Vec2};

/// The high-level task the user introduces.
pub const MOVE_BOX: &str = "move-box";
/// Push the end on the left, looking from behind the box towards the goal.
pub const PUSH_LEFT: &str = "push-left-end";
/// Push the end on the right.
pub const PUSH_RIGHT: &str = "push-right-end";

/// A run's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxPushConfig {
    /// Where the box starts: centre and heading of its length, cm and rad.
    pub box_start: Pose,
    /// Where it must go, cm.
    pub goal: Vec2,
    /// The goal moves at this time, s, to this place, cm.
    pub move_goal: Option<(f64, Vec2)>,
    /// Close enough, cm from the box's centre.
    pub tolerance_cm: f64,
    /// Switch one pusher off at this time, s.
    pub off_at: Option<f64>,
    /// Switch it on again at this time, s.
    pub on_at: Option<f64>,
    /// Give up after this long, s.
    pub max_s: f64,
    /// How long each push lasts once a pusher is in place, s.
    pub push_s: f64,
    /// Box turned further than this from facing the goal gets a one-ended push, rad.
    pub align_tolerance: f64,
}

impl Default for BoxPushConfig {
    fn default() -> Self {
        BoxPushConfig {
            box_start: Pose {
                x: 300.0,
                y: 120.0,
                theta: 0.0,
            },
            goal: Vec2::new(360.0, 400.0),
            move_goal: None,
            tolerance_cm: 25.0,
            off_at: None,
            on_at: None,
            max_s: 900.0,
            push_s: 2.0,
            align_tolerance: 0.15,
        }
    }
}
