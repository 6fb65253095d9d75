//! The `.map` reader: the Moving AI header and rows, then our extension lines.
//!
//! Written by hand rather than with a parser library so that every error can
//! say exactly where it is and what should have been there, and so no input
//! (however large its header claims the map is) can make it panic or
//! allocate more than the text itself justifies.

use super::error::{MapError, Problem};
use super::grid::{Cell, GridMap, Terrain};
use super::{Battlefield, TeamSite, DEFAULT_CELL_CM};

/// The longest side we accept; Moving AI's largest maps are far smaller.
const MAX_SIDE: u32 = 1 << 16;
/// The most cells we accept (a quarter of a gigabyte of terrain).
const MAX_CELLS: u64 = 1 << 28;

type Result<T> = std::result::Result<T, MapError>;

fn at(line: usize, column: usize, problem: Problem) -> MapError {
    MapError::At {
        line,
        column,
        problem,
    }
}

/// Quotes found text for a message, cut short if long.
fn quote(s: &str) -> String {
    const MAX: usize = 24;
    if s.chars().count() > MAX {
        let cut: String = s.chars().take(MAX).collect();
        format!("'{cut}...'")
    } else {
        format!("'{s}'")
    }
}

/// Whitespace-separated words of a line with their 1-based columns.
fn words(line: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut start: Option<(usize, usize)> = None; // (byte, column)
    let mut column = 0;
    for (byte, c) in line.char_indices() {
        column += 1;
        if c.is_whitespace() {
            if let Some((b, col)) = start.take() {
                out.push((col, &line[b..byte]));
            }
        } else if start.is_none() {
            start = Some((byte, column));
        }
    }
    if let Some((b, col)) = start {
        out.push((col, &line[b..]));
    }
    out
}

/// The lines of one text, numbered from 1, with a cursor over their words.
struct Reader<'a> {
    lines: Vec<&'a str>,
    next: usize,
}

impl<'a> Reader<'a> {
    fn new(text: &'a str) -> Reader<'a> {
        Reader {
            lines: text.lines().collect(),
            next: 0,
        }
    }

    /// The next line and its 1-based number.
    fn line(&mut self) -> Option<(usize, &'a str)> {
        let l = *self.lines.get(self.next)?;
        self.next += 1;
        Some((self.next, l))
    }

    /// The number the next line would have (for "end of file" errors).
    fn next_number(&self) -> usize {
        self.next + 1
    }
}

/// Words of one line, consumed left to right.
struct Words<'a> {
    line: usize,
    /// Column just past the line, for "end of line" errors.
    end: usize,
    words: std::vec::IntoIter<(usize, &'a str)>,
}

impl<'a> Words<'a> {
    fn new(line: usize, text: &'a str) -> Words<'a> {
        Words {
            line,
            end: text.chars().count() + 1,
            words: words(text).into_iter(),
        }
    }

    /// The next word, or an error saying `expected` was wanted.
    fn word(&mut self, expected: &'static str) -> Result<(usize, &'a str)> {
        self.words.next().ok_or_else(|| {
            at(
                self.line,
                self.end,
                Problem::Expected {
                    expected,
                    found: "end of line".into(),
                },
            )
        })
    }

    /// The next word, which must be `keyword`.
    fn keyword(&mut self, keyword: &'static str, expected: &'static str) -> Result<()> {
        let (col, w) = self.word(expected)?;
        if w == keyword {
            Ok(())
        } else {
            Err(at(
                self.line,
                col,
                Problem::Expected {
                    expected,
                    found: quote(w),
                },
            ))
        }
    }

    /// The next word as a whole number, and its column.
    fn number(&mut self, what: &'static str) -> Result<(usize, u32)> {
        let (col, w) = self.word(what)?;
        match w.parse::<u32>() {
            Ok(n) => Ok((col, n)),
            Err(_) => Err(at(
                self.line,
                col,
                Problem::Number {
                    what,
                    found: quote(w),
                },
            )),
        }
    }

    /// Nothing may follow.
    fn end(mut self) -> Result<()> {
        match self.words.next() {
            None => Ok(()),
            Some((col, w)) => Err(at(
                self.line,
                col,
                Problem::Expected {
                    expected: "end of line",
                    found: quote(w),
                },
            )),
        }
    }
}

/// Parses a whole map file: header, rows, and extension lines.
pub(super) fn battlefield(text: &str) -> Result<Battlefield> {
    let mut reader = Reader::new(text);
    let (width, height) = header(&mut reader)?;
    let grid = rows(&mut reader, width, height)?;
    let mut field = Battlefield {
        grid,
        cell_cm: DEFAULT_CELL_CM,
        teams: Vec::new(),
    };
    extension(&mut reader, &mut field)?;
    Ok(field)
}

/// A header line that must be there.
fn header_line<'a>(reader: &mut Reader<'a>, expected: &'static str) -> Result<Words<'a>> {
    match reader.line() {
        Some((n, l)) => Ok(Words::new(n, l)),
        None => Err(at(
            reader.next_number(),
            1,
            Problem::Expected {
                expected,
                found: "end of file".into(),
            },
        )),
    }
}

/// `type octile`, `height H` and `width W` in either order, `map`.
fn header(reader: &mut Reader<'_>) -> Result<(u32, u32)> {
    const TYPE: &str = "`type octile`";
    let mut w = header_line(reader, TYPE)?;
    w.keyword("type", TYPE)?;
    w.keyword("octile", TYPE)?;
    w.end()?;

    const SIZE: &str = "`height H` or `width W`";
    const SIDE: &str = "a whole number of cells from 1 to 65536";
    let mut height = None;
    let mut width = None;
    for _ in 0..2 {
        let mut w = header_line(reader, SIZE)?;
        let (col, key) = w.word(SIZE)?;
        let slot = match key {
            "height" if height.is_none() => &mut height,
            "width" if width.is_none() => &mut width,
            "height" | "width" => {
                return Err(at(
                    w.line,
                    col,
                    Problem::Duplicate {
                        what: format!("`{key}`"),
                    },
                ))
            }
            other => {
                return Err(at(
                    w.line,
                    col,
                    Problem::Expected {
                        expected: SIZE,
                        found: quote(other),
                    },
                ))
            }
        };
        let (ncol, n) = w.number(SIDE)?;
        if n == 0 || n > MAX_SIDE {
            return Err(at(
                w.line,
                ncol,
                Problem::Number {
                    what: SIDE,
                    found: format!("'{n}'"),
                },
            ));
        }
        *slot = Some((w.line, ncol, n));
        w.end()?;
    }
    let ((_, _, h), (wl, wc, wd)) = match (height, width) {
        (Some(h), Some(w)) => (h, w),
        // Each pass of the loop fills a different slot or returns an error.
        _ => {
            return Err(at(
                reader.next_number(),
                1,
                Problem::Expected {
                    expected: SIZE,
                    found: "neither".into(),
                },
            ))
        }
    };
    if u64::from(h) * u64::from(wd) > MAX_CELLS {
        return Err(at(
            wl,
            wc,
            Problem::Number {
                what: "a width that keeps the map within 2^28 cells",
                found: format!("'{wd}'"),
            },
        ));
    }

    let mut w = header_line(reader, "`map`")?;
    w.keyword("map", "`map`")?;
    w.end()?;
    Ok((wd, h))
}

fn rows(reader: &mut Reader<'_>, width: u32, height: u32) -> Result<GridMap> {
    // Grow with the text rather than trusting the header's size up front.
    let mut cells = Vec::new();
    for r in 0..height {
        let Some((n, line)) = reader.line() else {
            return Err(at(
                reader.next_number(),
                1,
                Problem::MissingRows { height, found: r },
            ));
        };
        let mut count = 0usize;
        for (i, c) in line.chars().enumerate() {
            if count == width as usize {
                return Err(at(n, i + 1, Problem::LongRow { width, found: c }));
            }
            let t =
                Terrain::from_char(c).ok_or_else(|| at(n, i + 1, Problem::Terrain { found: c }))?;
            cells.push(t);
            count += 1;
        }
        if count < width as usize {
            return Err(at(
                n,
                count + 1,
                Problem::ShortRow {
                    width,
                    found: count,
                },
            ));
        }
    }
    Ok(GridMap::from_parts(width, height, cells))
}

fn extension(reader: &mut Reader<'_>, field: &mut Battlefield) -> Result<()> {
    let mut cell_seen = false;
    while let Some((n, line)) = reader.line() {
        let mut w = Words::new(n, line);
        let Some(&(col, first)) = words(line).first() else {
            continue;
        };
        if first.starts_with('#') {
            continue;
        }
        match first {
            "cell" => {
                if cell_seen {
                    return Err(at(
                        n,
                        col,
                        Problem::Duplicate {
                            what: "a `cell` line".into(),
                        },
                    ));
                }
                cell_seen = true;
                w.word("`cell`")?;
                const SIDE: &str = "a positive cell side in centimetres";
                let (c, side) = w.word(SIDE)?;
                match side.parse::<f64>() {
                    Ok(v) if v.is_finite() && v > 0.0 => field.cell_cm = v,
                    _ => {
                        return Err(at(
                            n,
                            c,
                            Problem::Number {
                                what: SIDE,
                                found: quote(side),
                            },
                        ))
                    }
                }
                w.end()?;
            }
            "team" => {
                w.word("`team`")?;
                let (name_col, team) = team(w, &field.grid)?;
                if field.teams.iter().any(|t| t.name == team.name) {
                    return Err(at(
                        n,
                        name_col,
                        Problem::Duplicate {
                            what: format!("team name '{}'", team.name),
                        },
                    ));
                }
                field.teams.push(team);
            }
            _ => {
                let width = field.grid.width() as usize;
                let looks_like_row = line.chars().count() == width
                    && line.chars().all(|c| Terrain::from_char(c).is_some());
                let problem = if looks_like_row {
                    Problem::ExtraRow {
                        height: field.grid.height(),
                    }
                } else {
                    Problem::Expected {
                        expected:
                            "`cell`, `team`, a `#` comment or a blank line after the map rows",
                        found: quote(first),
                    }
                };
                return Err(at(n, col, problem));
            }
        }
    }
    Ok(())
}

/// The rest of a `team` line, after the keyword.
fn team(mut w: Words<'_>, grid: &GridMap) -> Result<(usize, TeamSite)> {
    const NAME: &str = "a team name (letters, digits, _ or -)";
    let (col, name) = w.word(NAME)?;
    if !name
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        return Err(at(
            w.line,
            col,
            Problem::Expected {
                expected: NAME,
                found: quote(name),
            },
        ));
    }
    let base = site(&mut w, grid, name, "base", "`base X Y`")?;
    let flag = site(&mut w, grid, name, "flag", "`flag X Y`")?;
    let spawn = site(&mut w, grid, name, "spawn", "`spawn X Y`")?;
    w.end()?;
    let site = TeamSite {
        name: name.to_string(),
        base,
        flag,
        spawn,
    };
    Ok((col, site))
}

/// `KEYWORD X Y`, checked to be on the map and on land.
fn site(
    w: &mut Words<'_>,
    grid: &GridMap,
    team: &str,
    keyword: &'static str,
    expected: &'static str,
) -> Result<Cell> {
    w.keyword(keyword, expected)?;
    let (col, x) = w.number("a column number (a whole number)")?;
    let (_, y) = w.number("a row number (a whole number)")?;
    let cell = Cell { x, y };
    let name = format!("{team} {keyword}");
    match grid.terrain(cell) {
        None => Err(at(
            w.line,
            col,
            Problem::OffMap {
                site: name,
                x,
                y,
                width: grid.width(),
                height: grid.height(),
            },
        )),
        Some(t) if !t.is_land() => Err(at(
            w.line,
            col,
            Problem::NotLand {
                site: name,
                x,
                y,
                terrain: match t {
                    Terrain::Tree => "trees",
                    Terrain::Water => "water",
                    _ => "out of bounds",
                },
            },
        )),
        Some(_) => Ok(cell),
    }
}

/// Decodes bytes, reporting the first invalid byte's line and column.
pub(super) fn utf8(bytes: &[u8]) -> Result<&str> {
    std::str::from_utf8(bytes).map_err(|e| {
        let good = &bytes[..e.valid_up_to()];
        // The prefix is valid UTF-8 by definition of `valid_up_to`.
        let good = std::str::from_utf8(good).unwrap_or("");
        let line = good.matches('\n').count() + 1;
        let column = good.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        at(line, column, Problem::NotUtf8)
    })
}
