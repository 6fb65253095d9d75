//! The roster: every robot of every team placed near its spawn point, the same in every process.

use std::collections::VecDeque;

use colony_sim::{Pose, Vec2};

use crate::map::{Battlefield, Cell, Terrain};
use crate::rules::{RobotBuild, RuleError, Rules, TeamSetup};

/// One robot of the game, as set up at the start.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotEntry {
    /// Its id: its index in the roster, the same in every process.
    pub id: u32,
    /// Its team.
    pub team: String,
    /// Its squad.
    pub squad: String,
    /// Its type, with the health and power its player bought.
    pub build: RobotBuild,
    /// Where it starts.
    pub spawn: Pose,
}

/// Why a game can't be set up.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// The rules refuse a team.
    #[error(transparent)]
    Rules(#[from] RuleError),
    /// The map has no such team.
    #[error("the map has no team {0:?} (it has {1})")]
    UnknownTeam(String, String),
    /// Two setups for one team.
    #[error("team {0} is set up twice")]
    DuplicateTeam(String),
    /// Not enough room around a spawn point.
    #[error("team {team}: only {room} free cells near its spawn point for {robots} robots")]
    NoRoom {
        /// Which team.
        team: String,
        /// Cells found.
        room: usize,
        /// Robots to place.
        robots: usize,
    },
}

/// Places every robot of every team near its team's spawn point: one free
/// land cell each, the nearest first, keeping a free cell around each so
/// they don't start touching. The result is the same in every process that
/// computes it from the same map and setups, which is how the world, the
/// robots and the game logic agree on ids without a handshake.
pub fn roster(
    field: &Battlefield,
    rules: &Rules,
    teams: &[TeamSetup],
) -> Result<Vec<RobotEntry>, SetupError> {
    let mut out = Vec::new();
    let centre = Vec2::new(
        field.grid.width() as f64 * field.cell_cm / 2.0,
        field.grid.height() as f64 * field.cell_cm / 2.0,
    );
    for (i, team) in teams.iter().enumerate() {
        team.check(rules)?;
        if teams[..i].iter().any(|t| t.name == team.name) {
            return Err(SetupError::DuplicateTeam(team.name.clone()));
        }
        let site = field
            .teams
            .iter()
            .find(|t| t.name == team.name)
            .ok_or_else(|| {
                let names: Vec<&str> = field.teams.iter().map(|t| t.name.as_str()).collect();
                SetupError::UnknownTeam(team.name.clone(), names.join(", "))
            })?;
        let robots = team.squads.iter().map(|s| s.robots.len()).sum::<usize>();
        let cells = spawn_cells(field, site.spawn, robots);
        if cells.len() < robots {
            return Err(SetupError::NoRoom {
                team: team.name.clone(),
                room: cells.len(),
                robots,
            });
        }
        let mut next = cells.into_iter();
        for squad in &team.squads {
            for &build in &squad.robots {
                let cell = next.next().expect("counted above");
                let (x, y) = field.cell_center(cell);
                let at = Vec2::new(x, y);
                out.push(RobotEntry {
                    id: out.len() as u32,
                    team: team.name.clone(),
                    squad: squad.name.clone(),
                    build,
                    spawn: Pose {
                        x,
                        y,
                        theta: (centre - at).angle(),
                    },
                });
            }
        }
    }
    Ok(out)
}

fn land(field: &Battlefield, x: i64, y: i64) -> bool {
    if x < 0 || y < 0 {
        return false;
    }
    matches!(
        field.grid.get(x as u32, y as u32),
        Some(Terrain::Open | Terrain::Swamp)
    )
}

/// Free land cells in breadth-first order from `spawn`, every other one so
/// robots start a cell apart, each with all eight neighbours on land.
fn spawn_cells(field: &Battlefield, spawn: Cell, want: usize) -> Vec<Cell> {
    let (w, h) = (field.grid.width() as usize, field.grid.height() as usize);
    let mut seen = vec![false; w * h];
    let mut queue = VecDeque::from([spawn]);
    seen[spawn.y as usize * w + spawn.x as usize] = true;
    let mut out: Vec<Cell> = Vec::new();
    while let Some(c) = queue.pop_front() {
        if out.len() >= want {
            break;
        }
        let (x, y) = (c.x as i64, c.y as i64);
        let roomy = (-1..=1).all(|dy| (-1..=1).all(|dx| land(field, x + dx, y + dy)));
        let apart = out
            .iter()
            .all(|o| (o.x as i64 - x).abs() > 1 || (o.y as i64 - y).abs() > 1);
        if roomy && apart {
            out.push(c);
        }
        for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let (nx, ny) = (x + dx, y + dy);
            if land(field, nx, ny) && !seen[ny as usize * w + nx as usize] {
                seen[ny as usize * w + nx as usize] = true;
                queue.push_back(Cell::new(nx as u32, ny as u32));
            }
        }
    }
    out
}
