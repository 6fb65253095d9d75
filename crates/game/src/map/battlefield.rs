//! A map as the game sees it: terrain, cell size, and the teams' sites, with
//! the conversion between grid cells and the simulator's centimetres.

use std::fmt;
use std::path::Path;

use super::error::MapError;
use super::grid::{Cell, GridMap};
use super::parse;

/// The cell side when a map has no `cell` line, in centimetres.
pub const DEFAULT_CELL_CM: f64 = 20.0;

/// Where one team starts and what it defends.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TeamSite {
    /// Unique within a map (`red`, `blue`).
    pub name: String,
    /// The team's base: where a captured flag is brought.
    pub base: Cell,
    /// Where the team's flag stands at the start.
    pub flag: Cell,
    /// Where the team's robots enter the field.
    pub spawn: Cell,
}

/// A parsed map file: the grid plus the game's extension lines.
#[derive(Debug, Clone, PartialEq)]
pub struct Battlefield {
    /// The terrain.
    pub grid: GridMap,
    /// The side of one cell in centimetres.
    pub cell_cm: f64,
    /// Teams in file order; every site is on the map and on land.
    pub teams: Vec<TeamSite>,
}

impl Battlefield {
    /// Parses a map text; see the [module docs](super) for the format.
    ///
    /// ```
    /// use colony_game::map::{Battlefield, Cell};
    /// let text = "type octile\nheight 2\nwidth 3\nmap\n...\n.T.\nteam red base 0 1 flag 2 1 spawn 0 0\n";
    /// let field = Battlefield::parse(text).unwrap();
    /// assert_eq!(field.teams[0].flag, Cell::new(2, 1));
    /// assert_eq!(field.cell_center(Cell::new(0, 1)), (10.0, 10.0));
    /// ```
    pub fn parse(text: &str) -> Result<Battlefield, MapError> {
        parse::battlefield(text)
    }

    /// [`Battlefield::parse`] for raw bytes; bytes that are not UTF-8 are an
    /// error with their line and column.
    pub fn parse_bytes(bytes: &[u8]) -> Result<Battlefield, MapError> {
        parse::battlefield(parse::utf8(bytes)?)
    }

    /// Reads and parses a map file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Battlefield, MapError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| MapError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Battlefield::parse_bytes(&bytes)
    }

    /// The team called `name`.
    pub fn team(&self, name: &str) -> Option<&TeamSite> {
        self.teams.iter().find(|t| t.name == name)
    }

    /// The field's size in centimetres, `(width, height)`.
    pub fn size_cm(&self) -> (f64, f64) {
        (
            f64::from(self.grid.width()) * self.cell_cm,
            f64::from(self.grid.height()) * self.cell_cm,
        )
    }

    /// The centre of `cell` in world centimetres (y up, origin at the map's
    /// bottom-left corner).
    pub fn cell_center(&self, cell: Cell) -> (f64, f64) {
        self.point_to_world((f64::from(cell.x) + 0.5, f64::from(cell.y) + 0.5))
    }

    /// A point in continuous cell coordinates (the path module's: `x` along
    /// columns, `y` down rows, cell `(x, y)` spanning `[x, x+1] x [y, y+1]`)
    /// in world centimetres.
    pub fn point_to_world(&self, (x, y): (f64, f64)) -> (f64, f64) {
        (
            x * self.cell_cm,
            (f64::from(self.grid.height()) - y) * self.cell_cm,
        )
    }

    /// The cell holding the world point `(x_cm, y_cm)`; `None` off the map
    /// or for a non-finite coordinate. A point on the border between two
    /// cells belongs to the one to its right, or above it.
    pub fn cell_at(&self, x_cm: f64, y_cm: f64) -> Option<Cell> {
        let col = (x_cm / self.cell_cm).floor();
        let row_up = (y_cm / self.cell_cm).floor();
        let (w, h) = (f64::from(self.grid.width()), f64::from(self.grid.height()));
        if !(col >= 0.0 && col < w && row_up >= 0.0 && row_up < h) {
            return None;
        }
        // Both are whole numbers inside the grid, so the casts are exact.
        Some(Cell {
            x: col as u32,
            y: (h - 1.0 - row_up) as u32,
        })
    }
}

/// Writes the map back in the format [`Battlefield::parse`] reads.
impl fmt::Display for Battlefield {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.grid)?;
        writeln!(f, "cell {}", self.cell_cm)?;
        for t in &self.teams {
            writeln!(
                f,
                "team {} base {} {} flag {} {} spawn {} {}",
                t.name, t.base.x, t.base.y, t.flag.x, t.flag.y, t.spawn.x, t.spawn.y
            )?;
        }
        Ok(())
    }
}
