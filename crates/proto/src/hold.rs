//! The operator-override hold rule: which wheel command is in force for each robot.
//!
//! The hub's minimum priority is global (the Broker paper), so raising it to take one robot would
//! silence every controller. A world therefore keeps, per robot, the command in force: a command
//! holds its robot for `hold` control steps, the step it arrived at counted (with `hold` 10, one
//! arriving at step 1 holds through step 10), and while it holds, a
//! command of lower priority for that robot is ignored. Equal or higher priority always replaces
//! it, so a controller's stream of commands at one priority simply follows the newest.

use colony_wire::Packet;

use crate::{radio, DecodeError, WheelCommand};

/// The command in force for each robot of a world.
#[derive(Debug, Clone)]
pub struct CommandHold {
    latest: Vec<Option<Held>>,
    hold: u64,
}

#[derive(Debug, Clone, Copy)]
struct Held {
    cmd: WheelCommand,
    priority: i32,
    step: u64,
}

impl CommandHold {
    /// Commands for robots `0..robots`; each holds for `hold` control steps after it arrives.
    pub fn new(robots: usize, hold: u64) -> CommandHold {
        CommandHold {
            latest: vec![None; robots],
            hold,
        }
    }

    fn fresh(&self, h: &Held, step: u64) -> bool {
        step.saturating_sub(h.step) < self.hold
    }

    /// Takes a command for `robot` that arrived at control step `step`; ignored when a fresh one
    /// of higher priority holds the robot, or when there is no such robot.
    pub fn offer(&mut self, robot: usize, cmd: WheelCommand, priority: i32, step: u64) {
        let Some(Some(h)) = self.latest.get(robot) else {
            if let Some(slot) = self.latest.get_mut(robot) {
                *slot = Some(Held {
                    cmd,
                    priority,
                    step,
                });
            }
            return;
        };
        if priority < h.priority && self.fresh(h, step) {
            return;
        }
        self.latest[robot] = Some(Held {
            cmd,
            priority,
            step,
        });
    }

    /// Takes every command of a `radio` packet that arrived at control step
    /// `step`, at the packet's priority. A packet that does not read is
    /// refused whole ([`radio::decode`]): a robot does not act on half of a
    /// forged packet.
    pub fn offer_radio(&mut self, packet: &Packet<'_>, step: u64) -> Result<(), DecodeError> {
        for c in radio::decode(packet)? {
            self.offer(c.robot as usize, c.wheels, packet.priority().0, step);
        }
        Ok(())
    }

    /// What `robot` does at `step`: its command in force, or stop once that has lapsed.
    pub fn command(&self, robot: usize, step: u64) -> WheelCommand {
        match self.latest.get(robot) {
            Some(Some(h)) if self.fresh(h, step) => h.cmd,
            _ => WheelCommand::STOP,
        }
    }

    /// What every robot does at `step`, in id order.
    pub fn for_step(&self, step: u64) -> Vec<WheelCommand> {
        (0..self.latest.len())
            .map(|i| self.command(i, step))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(text: &str) -> Packet<'_> {
        Packet::parse(text.as_bytes()).unwrap()
    }

    #[test]
    fn a_radio_packet_is_taken_whole_at_its_priority_or_not_at_all() {
        let mut h = CommandHold::new(3, 10);
        h.offer_radio(
            &p("@ <radio> 10\ncmd id 0 forward 1 turn 0\ncmd id 2 forward -1 turn 0.5\n"),
            1,
        )
        .unwrap();
        assert_eq!(h.command(0, 1).forward, 1.0);
        assert_eq!(h.command(2, 1).turn, 0.5);
        // A controller's (priority 0) does not displace the operator's while it holds...
        h.offer_radio(&p("@ <radio> 0\ncmd id 0 forward 0.2 turn 0\n"), 2)
            .unwrap();
        assert_eq!(h.command(0, 2).forward, 1.0);
        // ...and half a forged packet moves nobody.
        let forged = p("@ <radio> 20\ncmd id 1 forward 1 turn 0\ncmd id 1 forward nan turn 0\n");
        assert!(h.offer_radio(&forged, 3).is_err());
        assert_eq!(h.command(1, 3), WheelCommand::STOP);
    }

    const AI: WheelCommand = WheelCommand {
        forward: 0.5,
        turn: 0.0,
    };
    const OPERATOR: WheelCommand = WheelCommand {
        forward: -1.0,
        turn: 1.0,
    };

    #[test]
    fn an_operator_command_holds_its_robot_against_the_ai_until_it_lapses() {
        let mut c = CommandHold::new(2, 10);
        c.offer(0, AI, 0, 0);
        c.offer(0, OPERATOR, 10, 1);
        c.offer(0, AI, 0, 2);
        c.offer(1, AI, 0, 2);
        assert_eq!(c.for_step(2), [OPERATOR, AI]);
        c.offer(0, AI, 0, 10);
        assert_eq!(c.command(0, 10), OPERATOR, "held for 10 steps after step 1");
        c.offer(0, AI, 0, 11);
        assert_eq!(
            c.command(0, 11),
            AI,
            "the override lapsed: the AI has robot 0 back"
        );
    }

    #[test]
    fn a_command_lapses_to_stop_and_unknown_robots_are_ignored() {
        let mut c = CommandHold::new(1, 3);
        c.offer(0, AI, 0, 5);
        c.offer(9, AI, 0, 5);
        assert_eq!(c.command(0, 7), AI);
        assert_eq!(c.command(0, 8), WheelCommand::STOP);
        assert_eq!(c.command(9, 5), WheelCommand::STOP);
    }
}
