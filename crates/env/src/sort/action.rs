//! Actions: continuous wheel commands brought into range by the one clamp rule
//! colony has ([`WheelCommand::clamped`]), or an index into a fixed table.

use colony_sim::WheelCommand;

/// The discrete actions, by index: a name and the wheel command it stands for.
/// Turns are half the full turn rate when driving forward (a curve of about
/// twice the paper's turning radius), the full rate on the spot.
pub const DISCRETE_ACTIONS: [(&str, WheelCommand); 7] = [
    ("stop", command(0.0, 0.0)),
    ("forward", command(1.0, 0.0)),
    ("forward-left", command(1.0, 0.5)),
    ("forward-right", command(1.0, -0.5)),
    ("turn-left", command(0.0, 1.0)),
    ("turn-right", command(0.0, -1.0)),
    ("reverse", command(-1.0, 0.0)),
];

const fn command(forward: f64, turn: f64) -> WheelCommand {
    WheelCommand { forward, turn }
}

/// The command of discrete action `index`, or `None` past the table.
pub fn discrete_command(index: u32) -> Option<WheelCommand> {
    DISCRETE_ACTIONS
        .get(usize::try_from(index).ok()?)
        .map(|(_, c)| *c)
}

/// A command as the world will apply it: each part clamped to [-1, 1], NaN
/// as 0 and ±∞ as ±1 (full speed that way), by proto's `unit` rule — the
/// rule `World::step` applies itself, so clamping here changes nothing the
/// world does and only makes the clamped command visible to the caller.
pub fn clamp(c: WheelCommand) -> WheelCommand {
    WheelCommand::clamped(c.forward, c.turn)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn env_action_table_is_in_range_and_ends_in_none() {
        for (i, (name, c)) in DISCRETE_ACTIONS.iter().enumerate() {
            assert_eq!(discrete_command(i as u32), Some(*c), "{name}");
            assert_eq!(clamp(*c), *c);
        }
        assert_eq!(discrete_command(7), None);
        assert_eq!(discrete_command(u32::MAX), None);
    }

    #[test]
    fn env_action_clamp_is_protos_rule() {
        let c = clamp(command(f64::NAN, f64::NEG_INFINITY));
        assert_eq!(c, command(0.0, -1.0));
        assert_eq!(clamp(command(2.5, -0.25)), command(1.0, -0.25));
    }
}
