//! `game.map`: the battlefield for players' screens, every few seconds (for players who join
//! late), in parts when large so every part fits one datagram.
//!
//! ```text
//! @ <game.map> 0
//! map width 64 height 48 cell 20 part 0 parts 1
//! site team red base_x 110 base_y 90 flag_x 130 flag_y 70
//! row y 0 cells "@@@@@@@@..."
//! ```
//!
//! Rows use the Moving AI characters (`.GSTWO@`); row 0 is the top. Sites come with part 0. The
//! game writes a [`GameMap`] with [`GameMap::encode`]; a viewer puts the parts back together with
//! a [`MapAssembler`], which skips and counts what does not read and refuses a map larger than
//! [`MAX_SIDE`] cells a side before allocating anything for it.

use std::ops::Range;

use colony_wire::{Line, Packet, PacketBuilder, ParseError, Priority};
use serde::Serialize;

use super::MAP;
use crate::fields::{coord, plain_name, r};
use crate::table::{int, line, num, text, MessageTable};
use crate::{DecodeError, Vec2};

/// What a map part holds.
pub const TABLE: MessageTable = MessageTable {
    channel: MAP,
    lines: &[
        line(
            "map",
            &[
                int("width"),
                int("height"),
                num("cell"),
                int("part").optional(),
                int("parts").optional(),
            ],
        ),
        line(
            "site",
            &[
                text("team"),
                num("base_x"),
                num("base_y"),
                num("flag_x"),
                num("flag_y"),
            ],
        ),
        line("row", &[int("y"), text("cells")]),
    ],
};

/// The widest and tallest map accepted, cells (the Moving AI maps go to 1024).
pub const MAX_SIDE: u32 = 4096;
/// Parts per map accepted at most.
const MAX_PARTS: u32 = 4096;
/// Team sites kept at most.
const MAX_SITES: usize = 64;
/// The largest cell accepted, cm.
const MAX_CELL: f64 = 10_000.0;
/// The characters a row may hold: open, swamp, trees, out of bounds, water.
const TERRAIN: &[u8] = b".GSTWO@";
/// Map rows per part are limited to about this many bytes, so every part fits one datagram.
const MAP_PART_BYTES: usize = 48_000;

/// A team's base and flag stand, cm. As JSON each point is an `[x, y]` pair.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Site {
    /// The team.
    pub team: String,
    /// The centre of its base cell.
    #[serde(serialize_with = "crate::geometry::point_as_pair")]
    pub base: Vec2,
    /// The centre of its flag's cell.
    #[serde(serialize_with = "crate::geometry::point_as_pair")]
    pub flag: Vec2,
}

/// A whole battlefield as the map packets carry it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GameMap {
    /// Cells across.
    pub width: u32,
    /// Cells down.
    pub height: u32,
    /// The side of a cell, cm.
    pub cell: f64,
    /// Top row first, one Moving AI character per cell.
    pub rows: Vec<String>,
    /// Each team's base and flag.
    pub sites: Vec<Site>,
}

impl GameMap {
    /// The map as `game.map` packets, as many as keep each under a datagram.
    pub fn encode(&self) -> Result<Vec<Vec<u8>>, ParseError> {
        let chunks = chunks(&self.rows);
        let parts = chunks.len();
        chunks
            .into_iter()
            .enumerate()
            .map(|(k, range)| {
                let mut p = PacketBuilder::new([MAP], Priority(0));
                p.line("map")
                    .field("width", self.width)
                    .field("height", self.height)
                    .field("cell", self.cell)
                    .field("part", k)
                    .field("parts", parts);
                if k == 0 {
                    for s in &self.sites {
                        p.line("site")
                            .bare("team", &s.team)
                            .field("base_x", r(s.base.x))
                            .field("base_y", r(s.base.y))
                            .field("flag_x", r(s.flag.x))
                            .field("flag_y", r(s.flag.y));
                    }
                }
                for y in range {
                    p.line("row")
                        .field("y", y)
                        .field("cells", self.rows[y].as_str());
                }
                p.finish()
            })
            .collect()
    }
}

/// The rows of each part: a new part starts where the rows so far would pass
/// [`MAP_PART_BYTES`] (counting a line's own bytes too).
fn chunks(rows: &[String]) -> Vec<Range<usize>> {
    let mut chunks = Vec::new();
    let mut start = 0;
    let mut bytes = 0;
    for (i, r) in rows.iter().enumerate() {
        if bytes + r.len() > MAP_PART_BYTES && i > start {
            chunks.push(start..i);
            start = i;
            bytes = 0;
        }
        bytes += r.len() + 24;
    }
    chunks.push(start..rows.len());
    chunks
}

/// What identifies one map's set of parts.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Header {
    width: u32,
    height: u32,
    cell: f64,
    parts: u32,
}

#[derive(Debug)]
struct Assembly {
    header: Header,
    seen: Vec<bool>,
    rows: Vec<Option<String>>,
    sites: Vec<Site>,
}

/// Puts `game.map` parts together for a viewer. Feed it with [`on_packet`](Self::on_packet).
#[derive(Debug, Default)]
pub struct MapAssembler {
    map: Option<GameMap>,
    version: u64,
    assembly: Option<Assembly>,
    bad_lines: u64,
}

fn header(line: &Line<'_>) -> Option<(Header, u32)> {
    let side = |n| {
        u32::try_from(line.i64(n).ok()?)
            .ok()
            .filter(|v| (1..=MAX_SIDE).contains(v))
    };
    let width = side("width")?;
    let height = side("height")?;
    let cell = line
        .f64("cell")
        .ok()
        .filter(|c| c.is_finite() && *c > 0.0 && *c <= MAX_CELL)?;
    // One part is the common case: a writer may leave part and parts out.
    let part = match line.get("part") {
        None => 0,
        Some(_) => u32::try_from(line.i64("part").ok()?).ok()?,
    };
    let parts = match line.get("parts") {
        None => 1,
        Some(_) => u32::try_from(line.i64("parts").ok()?).ok()?,
    };
    if parts == 0 || parts > MAX_PARTS || part >= parts {
        return None;
    }
    Some((
        Header {
            width,
            height,
            cell,
            parts,
        },
        part,
    ))
}

/// A `row` line of a map `width` wide and `height` tall.
fn row(line: &Line<'_>, width: u32, height: usize) -> Option<(usize, String)> {
    let y = usize::try_from(line.i64("y").ok()?).ok()?;
    let cells = line.str("cells").ok()?;
    let ok =
        y < height && cells.len() == width as usize && cells.bytes().all(|b| TERRAIN.contains(&b));
    ok.then(|| (y, cells.into_owned()))
}

/// A `site` line.
fn site(line: &Line<'_>) -> Result<Site, DecodeError> {
    Ok(Site {
        team: plain_name(line, "team")?,
        base: Vec2::new(coord(line, "base_x")?, coord(line, "base_y")?),
        flag: Vec2::new(coord(line, "flag_x")?, coord(line, "flag_y")?),
    })
}

impl MapAssembler {
    /// The newest complete map.
    pub fn map(&self) -> Option<&GameMap> {
        self.map.as_ref()
    }

    /// Changes whenever a different map is complete.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Lines that did not read as a map's (a missing row counts as one).
    pub fn bad_lines(&self) -> u64 {
        self.bad_lines
    }

    /// Takes in one `game.map` packet; true when it completed a new map.
    pub fn on_packet(&mut self, packet: &Packet<'_>) -> bool {
        let Some((head, part)) = packet.line("map").as_ref().and_then(header) else {
            self.bad_lines += 1;
            return false;
        };
        // Another map, or a part seen already (the game's next broadcast
        // after a lost part): start over, so one lost datagram costs one
        // broadcast, never the map.
        let fresh = match &self.assembly {
            Some(a) => a.header != head || a.seen[part as usize],
            None => true,
        };
        if fresh {
            self.assembly = Some(Assembly {
                header: head,
                seen: vec![false; head.parts as usize],
                rows: vec![None; head.height as usize],
                sites: Vec::new(),
            });
        }
        let Some(a) = self.assembly.as_mut() else {
            return false;
        };
        a.seen[part as usize] = true;
        let mut bad = 0;
        for line in packet.lines() {
            match line.label() {
                "row" => match row(&line, head.width, a.rows.len()) {
                    Some((y, cells)) => a.rows[y] = Some(cells),
                    None => bad += 1,
                },
                "site" => match site(&line) {
                    Ok(s) => {
                        if let Some(old) = a.sites.iter_mut().find(|o| o.team == s.team) {
                            *old = s;
                        } else if a.sites.len() < MAX_SITES {
                            a.sites.push(s);
                        }
                    }
                    Err(_) => bad += 1,
                },
                _ => {}
            }
        }
        self.bad_lines += bad;
        if !a.seen.iter().all(|s| *s) {
            return false;
        }
        let Some(done) = self.assembly.take() else {
            return false;
        };
        let missing = done.rows.iter().filter(|r| r.is_none()).count();
        self.bad_lines += missing as u64;
        // A row that never came (or did not read) is shown as out of bounds:
        // the rest of the map is still worth drawing.
        let blank = "@".repeat(head.width as usize);
        let map = GameMap {
            width: head.width,
            height: head.height,
            cell: head.cell,
            rows: done
                .rows
                .into_iter()
                .map(|r| r.unwrap_or_else(|| blank.clone()))
                .collect(),
            sites: done.sites,
        };
        if self.map.as_ref() == Some(&map) {
            return false;
        }
        self.map = Some(map);
        self.version += 1;
        true
    }
}

#[cfg(test)]
mod tests;
