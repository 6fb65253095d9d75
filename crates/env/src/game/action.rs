//! Actions and squad orders, and the packets they become (how they reach the game is told in
//! the module docs of `colony_env::game`).

use colony_game::protocol::{Action, PlayerCommand, SquadCommand, Target, Verb};
use colony_proto::WheelCommand;
use colony_sim::Vec2;

/// A shot a robot asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Fire {
    /// No shot.
    #[default]
    Hold,
    /// At the nearest living enemy, wherever it is (the referee refuses one out of range).
    Nearest,
    /// At the robot in this slot of the agent's latest `nearby` observation (an ally there is
    /// refused by the referee; an empty slot is counted as invalid and sends nothing).
    Slot(usize),
}

impl Fire {
    /// A shot from a discrete action: 0 holds, 1 fires at the nearest enemy, `2 + k` at slot
    /// `k` of `nearby`; anything else (negative, too large) holds. The action space is
    /// `2 + nearby` wide.
    pub fn from_code(code: i64, nearby: usize) -> Fire {
        match code {
            1 => Fire::Nearest,
            c if c >= 2 && ((c - 2) as u64) < nearby as u64 => Fire::Slot((c - 2) as usize),
            _ => Fire::Hold,
        }
    }
}

/// One agent's action for one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RobotAction {
    /// Forward wheel fraction, -1 (full reverse) to 1 (full ahead) of the type's top speed.
    pub forward: f64,
    /// Turn fraction, -1 (full right) to 1 (full left) of the type's top turn rate.
    pub turn: f64,
    /// The shot it asks for.
    pub fire: Fire,
    /// Asks to pick up the enemy flag (Capture the Flag; the referee checks the reach).
    pub pickup: bool,
}

/// One order for one of the learner's squads, carried out by the game's squad behaviours.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SquadOrder {
    /// Stop where it stands (`stop`); its members still shoot enemies in range.
    #[default]
    Hold,
    /// Gather in formation at the squad's centroid (`gather`).
    Gather,
    /// Close in on the living enemy nearest the squad's centroid (`attack robot N`), the target
    /// chosen anew each step.
    AttackNearest,
    /// Take the enemy flag home (`capture flag ENEMY`; refused in Death Match, with no flags).
    CaptureFlag,
    /// Chase our own flag wherever it is, its carrier included (`attack flag OURS`).
    RecoverFlag,
    /// Surround our base and hold it (`defend base OURS`).
    DefendBase,
    /// Advance on the enemy base (`attack base ENEMY`).
    AttackBase,
}

impl SquadOrder {
    /// Every order, in the order of [`SquadOrder::from_code`].
    pub const ALL: [SquadOrder; 7] = [
        SquadOrder::Hold,
        SquadOrder::Gather,
        SquadOrder::AttackNearest,
        SquadOrder::CaptureFlag,
        SquadOrder::RecoverFlag,
        SquadOrder::DefendBase,
        SquadOrder::AttackBase,
    ];

    /// The order of a discrete action, 0 to 6; anything else holds.
    pub fn from_code(code: i64) -> SquadOrder {
        usize::try_from(code)
            .ok()
            .and_then(|i| SquadOrder::ALL.get(i).copied())
            .unwrap_or_default()
    }

    /// The game's verb for this order; `nearest` is the living enemy nearest the squad.
    pub(super) fn verb(self, own: &str, enemy: &str, nearest: Option<u32>) -> Verb {
        match self {
            SquadOrder::Hold => Verb::Stop,
            SquadOrder::Gather => Verb::Gather(None),
            SquadOrder::AttackNearest => {
                nearest.map_or(Verb::Stop, |id| Verb::Attack(Target::Robot(id)))
            }
            SquadOrder::CaptureFlag => Verb::Capture(enemy.to_string()),
            SquadOrder::RecoverFlag => Verb::Attack(Target::Flag(own.to_string())),
            SquadOrder::DefendBase => Verb::Defend(Target::Base(own.to_string())),
            SquadOrder::AttackBase => Verb::Attack(Target::Base(enemy.to_string())),
        }
    }
}

/// The packets for one agent's action: a drive, and the shot and pick-up it asks for.
pub(super) fn robot_packets(
    team: &str,
    robot: u32,
    action: &RobotAction,
    target: Option<u32>,
    enemy_flag: &str,
    out: &mut Vec<Vec<u8>>,
) {
    let wheels = WheelCommand::clamped(action.forward, action.turn);
    let drive = PlayerCommand::Drive {
        team: team.to_string(),
        robot,
        forward: wheels.forward,
        turn: wheels.turn,
    };
    let fire = target.map(|target| Action::Fire { robot, target });
    let pickup = action.pickup.then(|| Action::PickUp {
        robot,
        flag: enemy_flag.to_string(),
    });
    // Every value here is a checked id, a name of the map or a clamped fraction, so none fails
    // to encode; one that did would only cost this agent its step.
    out.extend(drive.encode().ok());
    out.extend(
        fire.iter()
            .chain(pickup.iter())
            .filter_map(|a| a.encode().ok()),
    );
}

/// The packet for one squad's command.
pub(super) fn squad_packet(team: &str, squad: &str, verb: Verb) -> Option<Vec<u8>> {
    SquadCommand {
        team: team.to_string(),
        squad: squad.to_string(),
        verb,
        formation: None,
    }
    .encode()
    .ok()
}

/// The centroid of some points, or `None` for none.
pub(super) fn centroid(points: impl Iterator<Item = Vec2>) -> Option<Vec2> {
    let (sum, n) = points.fold((Vec2::ZERO, 0usize), |(s, n), p| (s + p, n + 1));
    (n > 0).then(|| sum * (1.0 / n as f64))
}
