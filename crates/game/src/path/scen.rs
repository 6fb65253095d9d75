//! Moving AI scenario files: benchmark queries with their known optimal
//! lengths, so our planners can be checked against the published answers.
//!
//! ```text
//! version 1
//! 0→maps/dao/arena.map→49→49→1→11→1→12→1
//! ```
//!
//! (`→` stands for a tab.)
//!
//! After the `version 1` line, each line holds tab-separated: bucket, map
//! name, map width, map height, start x, start y, goal x, goal y, optimal
//! length. Lines without tabs are split on spaces instead (some copies lose
//! their tabs), and blank lines are skipped.

use std::path::{Path, PathBuf};

use crate::map::Cell;

/// One benchmark query.
#[derive(Debug, Clone, PartialEq)]
pub struct Query {
    /// 1-based line in the file, for reports.
    pub line: usize,
    /// Difficulty bucket (roughly the optimal length divided by four).
    pub bucket: u32,
    /// The map file the query was made for, as written.
    pub map: String,
    /// The map's width the query was made for.
    pub width: u32,
    /// The map's height the query was made for.
    pub height: u32,
    /// Where the path starts.
    pub start: Cell,
    /// Where it ends.
    pub goal: Cell,
    /// The published optimal length.
    pub optimal: f64,
}

/// A scenario file that could not be read or parsed.
#[derive(Debug, thiserror::Error)]
pub enum ScenError {
    /// The file could not be read.
    #[error("cannot read scenario {path}", path = .path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The text is not a valid scenario.
    #[error("line {line}, column {column}: expected {expected}, found {found}")]
    At {
        /// 1-based line.
        line: usize,
        /// 1-based column, in characters.
        column: usize,
        /// What should have been there.
        expected: &'static str,
        /// What was there (quoted), or `end of line` / `end of file`.
        found: String,
    },
}

fn at(line: usize, column: usize, expected: &'static str, found: String) -> ScenError {
    ScenError::At {
        line,
        column,
        expected,
        found,
    }
}

fn quote(s: &str) -> String {
    if s.chars().count() > 24 {
        format!("'{}...'", s.chars().take(24).collect::<String>())
    } else {
        format!("'{s}'")
    }
}

/// Fields of a line with their 1-based columns.
fn fields(line: &str) -> Vec<(usize, &str)> {
    // Tabs separate fields (and empty ones count); without tabs, runs of
    // spaces do.
    let tabs = line.contains('\t');
    let sep = |c: char| if tabs { c == '\t' } else { c.is_whitespace() };
    let mut out = Vec::new();
    let mut start = 0;
    let mut start_col = 1;
    for (col, (i, c)) in (1..).zip(line.char_indices()) {
        if sep(c) {
            if i > start || tabs {
                out.push((start_col, &line[start..i]));
            }
            start = i + c.len_utf8();
            start_col = col + 1;
        }
    }
    if start < line.len() || tabs {
        out.push((start_col, &line[start..]));
    }
    out
}

/// Parses a scenario text.
pub fn parse(text: &str) -> Result<Vec<Query>, ScenError> {
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    const VERSION: &str = "`version 1`";
    match lines.next() {
        None => return Err(at(1, 1, VERSION, "end of file".into())),
        Some((n, l)) => {
            let words: Vec<&str> = l.split_whitespace().collect();
            let ok = matches!(words.as_slice(), ["version", v] if *v == "1" || *v == "1.0");
            if !ok {
                return Err(at(n, 1, VERSION, quote(l.trim())));
            }
        }
    }
    let mut queries = Vec::new();
    for (n, l) in lines {
        if l.trim().is_empty() {
            continue;
        }
        queries.push(query(n, l)?);
    }
    Ok(queries)
}

/// [`parse`] for raw bytes, which must be UTF-8.
pub fn parse_bytes(bytes: &[u8]) -> Result<Vec<Query>, ScenError> {
    match std::str::from_utf8(bytes) {
        Ok(text) => parse(text),
        Err(e) => {
            let good = std::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or("");
            let line = good.matches('\n').count() + 1;
            let column = good.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
            Err(at(line, column, "UTF-8 text", "a byte that is not".into()))
        }
    }
}

/// Reads and parses a scenario file.
pub fn from_file(path: impl AsRef<Path>) -> Result<Vec<Query>, ScenError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| ScenError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    parse_bytes(&bytes)
}

fn query(n: usize, line: &str) -> Result<Query, ScenError> {
    let line = line.trim_end();
    let f = fields(line);
    let end = line.chars().count() + 1;
    const NAMES: [&str; 9] = [
        "a bucket number",
        "a map name",
        "the map width",
        "the map height",
        "the start x",
        "the start y",
        "the goal x",
        "the goal y",
        "the optimal length",
    ];
    if let Some(&(col, extra)) = f.get(9) {
        return Err(at(n, col, "end of line after 9 fields", quote(extra)));
    }
    let field = |i: usize| -> Result<(usize, &str), ScenError> {
        f.get(i)
            .copied()
            .ok_or_else(|| at(n, end, NAMES[i], "end of line".into()))
    };
    let whole = |i: usize| -> Result<u32, ScenError> {
        let (col, s) = field(i)?;
        s.parse::<u32>().map_err(|_| at(n, col, NAMES[i], quote(s)))
    };
    let bucket = whole(0)?;
    let (_, map) = field(1)?;
    let (width, height) = (whole(2)?, whole(3)?);
    let start = Cell::new(whole(4)?, whole(5)?);
    let goal = Cell::new(whole(6)?, whole(7)?);
    let (col, s) = field(8)?;
    let optimal = match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => v,
        _ => return Err(at(n, col, "the optimal length (a number >= 0)", quote(s))),
    };
    for (i, c) in [(4, start), (6, goal)] {
        if c.x >= width || c.y >= height {
            let (col, _) = field(i)?;
            return Err(at(
                n,
                col,
                "a cell inside the map's width and height",
                format!("{c}"),
            ));
        }
    }
    Ok(Query {
        line: n,
        bucket,
        map: map.to_string(),
        width,
        height,
        start,
        goal,
        optimal,
    })
}
