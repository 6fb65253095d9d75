//! The terrain grid itself, independent of any team or game data.

use std::fmt;
use std::path::Path;

use super::error::MapError;
use super::Battlefield;

/// One cell of a grid: `x` is the column, `y` the row (row 0 is the first
/// row in the file), as in Moving AI `.scen` files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Cell {
    /// Column, from 0 at the left.
    pub x: u32,
    /// Row, from 0 at the top (the first row in the file).
    pub y: u32,
}

impl Cell {
    /// The cell at column `x`, row `y`.
    pub const fn new(x: u32, y: u32) -> Cell {
        Cell { x, y }
    }
}

impl fmt::Display for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "({},{})", self.x, self.y)
    }
}

/// What covers one cell. Which kinds a unit may cross is decided by the path
/// finder's `Mover`, not here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Terrain {
    /// `.` or `G`: open ground.
    Open,
    /// `S`: swamp; passable on land, at the same cost as open ground.
    Swamp,
    /// `T`: trees; nothing passes.
    Tree,
    /// `@` or `O`: outside the playing field.
    OutOfBounds,
    /// `W`: water; only amphibious units cross it.
    Water,
}

impl Terrain {
    /// The terrain a Moving AI map character stands for.
    pub fn from_char(c: char) -> Option<Terrain> {
        Some(match c {
            '.' | 'G' => Terrain::Open,
            'S' => Terrain::Swamp,
            'T' => Terrain::Tree,
            '@' | 'O' => Terrain::OutOfBounds,
            'W' => Terrain::Water,
            _ => return None,
        })
    }

    /// The character this terrain is written as (`.` for open, `@` for out
    /// of bounds).
    pub fn to_char(self) -> char {
        match self {
            Terrain::Open => '.',
            Terrain::Swamp => 'S',
            Terrain::Tree => 'T',
            Terrain::OutOfBounds => '@',
            Terrain::Water => 'W',
        }
    }

    /// Open ground or swamp: where land units drive and where team sites may
    /// stand.
    pub fn is_land(self) -> bool {
        matches!(self, Terrain::Open | Terrain::Swamp)
    }
}

/// A rectangular terrain grid, row-major.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GridMap {
    width: u32,
    height: u32,
    cells: Vec<Terrain>,
}

impl GridMap {
    /// A `width` x `height` grid filled with `fill`. Either side may be 0.
    pub fn new(width: u32, height: u32, fill: Terrain) -> GridMap {
        GridMap {
            width,
            height,
            cells: vec![fill; width as usize * height as usize],
        }
    }

    /// A grid from its rows; `None` if rows differ in length.
    pub fn from_rows(rows: Vec<Vec<Terrain>>) -> Option<GridMap> {
        let height = u32::try_from(rows.len()).ok()?;
        let width = u32::try_from(rows.first().map_or(0, Vec::len)).ok()?;
        if rows.iter().any(|r| r.len() != width as usize) {
            return None;
        }
        Some(GridMap {
            width,
            height,
            cells: rows.into_iter().flatten().collect(),
        })
    }

    /// A grid from row-major cells the parser has already sized.
    pub(super) fn from_parts(width: u32, height: u32, cells: Vec<Terrain>) -> GridMap {
        debug_assert_eq!(cells.len(), width as usize * height as usize);
        GridMap {
            width,
            height,
            cells,
        }
    }

    /// Parses a Moving AI `.map` text (with or without the battlefield
    /// extension, which is checked and then dropped).
    pub fn parse(text: &str) -> Result<GridMap, MapError> {
        Battlefield::parse(text).map(|b| b.grid)
    }

    /// [`GridMap::parse`] for raw bytes, which must be UTF-8.
    pub fn parse_bytes(bytes: &[u8]) -> Result<GridMap, MapError> {
        Battlefield::parse_bytes(bytes).map(|b| b.grid)
    }

    /// Reads and parses a `.map` file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<GridMap, MapError> {
        Battlefield::from_file(path).map(|b| b.grid)
    }

    /// Columns.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Whether `cell` lies on the grid.
    pub fn contains(&self, cell: Cell) -> bool {
        cell.x < self.width && cell.y < self.height
    }

    /// The terrain at column `x`, row `y`; `None` off the grid.
    pub fn get(&self, x: u32, y: u32) -> Option<Terrain> {
        if x < self.width && y < self.height {
            Some(self.cells[y as usize * self.width as usize + x as usize])
        } else {
            None
        }
    }

    /// The terrain of `cell`; `None` off the grid.
    pub fn terrain(&self, cell: Cell) -> Option<Terrain> {
        self.get(cell.x, cell.y)
    }

    /// Changes one cell; returns false (and changes nothing) off the grid.
    pub fn set(&mut self, cell: Cell, terrain: Terrain) -> bool {
        if !self.contains(cell) {
            return false;
        }
        self.cells[cell.y as usize * self.width as usize + cell.x as usize] = terrain;
        true
    }

    /// All cells, row by row.
    pub fn cells(&self) -> &[Terrain] {
        &self.cells
    }
}

/// Writes the grid in the Moving AI format (header and rows, no extension).
impl fmt::Display for GridMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "type octile")?;
        writeln!(f, "height {}", self.height)?;
        writeln!(f, "width {}", self.width)?;
        writeln!(f, "map")?;
        if self.width == 0 {
            return Ok(());
        }
        for row in self.cells.chunks(self.width as usize) {
            let line: String = row.iter().map(|t| t.to_char()).collect();
            writeln!(f, "{line}")?;
        }
        Ok(())
    }
}
