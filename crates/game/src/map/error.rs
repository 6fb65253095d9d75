//! What can be wrong with a map file, and where.

use std::path::PathBuf;

/// A map that could not be read or parsed.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// The file could not be read.
    #[error("cannot read map {path}", path = .path.display())]
    Read {
        /// The file that could not be read.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The text is not a valid map. Displayed as
    /// `line 7, column 13: expected one of . G @ O T S W, found 'x'`.
    #[error("line {line}, column {column}: {problem}")]
    At {
        /// 1-based line.
        line: usize,
        /// 1-based column, in characters.
        column: usize,
        /// What was expected there, and what was found.
        problem: Problem,
    },
}

impl MapError {
    /// The 1-based line and column of a parse error; `None` for a read error.
    pub fn position(&self) -> Option<(usize, usize)> {
        match self {
            MapError::At { line, column, .. } => Some((*line, *column)),
            MapError::Read { .. } => None,
        }
    }
}

/// What was wrong at a position in a map file: each message says what was
/// expected and quotes what was found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Problem {
    /// The bytes are not UTF-8.
    #[error("expected UTF-8 text, found a byte that is not")]
    NotUtf8,
    /// A header line, or a keyword within a line, is wrong or missing.
    #[error("expected {expected}, found {found}")]
    Expected {
        /// What should have been there.
        expected: &'static str,
        /// What was there (quoted), or `end of line` / `end of file`.
        found: String,
    },
    /// A number is malformed or out of range.
    #[error("expected {what}, found {found}")]
    Number {
        /// Which number, and of what kind.
        what: &'static str,
        /// The text found (quoted).
        found: String,
    },
    /// A character in a map row is not a terrain character.
    #[error("expected one of . G @ O T S W, found {found:?}")]
    Terrain {
        /// The character found.
        found: char,
    },
    /// A map row ends early.
    #[error("expected {width} cells in this row (the header's width), found {found}")]
    ShortRow {
        /// The header's width.
        width: u32,
        /// Cells in the row.
        found: usize,
    },
    /// A map row goes on past the header's width.
    #[error("expected the row to end after {width} cells (the header's width), found {found:?}")]
    LongRow {
        /// The header's width.
        width: u32,
        /// The first character too many.
        found: char,
    },
    /// The file ends before the header's height in rows.
    #[error("expected {height} map rows (the header's height), found {found}")]
    MissingRows {
        /// The header's height.
        height: u32,
        /// Rows present.
        found: u32,
    },
    /// More map rows follow than the header's height.
    #[error("expected {height} map rows (the header's height), found another map row")]
    ExtraRow {
        /// The header's height.
        height: u32,
    },
    /// Something given twice that may be given once.
    #[error("expected {what} once, found it again")]
    Duplicate {
        /// What was repeated (`a cell line`, `team name 'red'`).
        what: String,
    },
    /// A team site off the map.
    #[error("expected the {site} inside the {width} x {height} map, found ({x}, {y})")]
    OffMap {
        /// Which site (`red base`).
        site: String,
        /// Its column.
        x: u32,
        /// Its row.
        y: u32,
        /// The map's width.
        width: u32,
        /// The map's height.
        height: u32,
    },
    /// A team site on terrain no land unit can stand on.
    #[error("expected the {site} on open or swamp ground, found {terrain} at ({x}, {y})")]
    NotLand {
        /// Which site (`red flag`).
        site: String,
        /// Its column.
        x: u32,
        /// Its row.
        y: u32,
        /// The terrain there, in words.
        terrain: &'static str,
    },
}
