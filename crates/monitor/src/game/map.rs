//! The battlefield from `game.map`: parts put back together, the newest
//! complete map kept, and a version that changes only when the map does
//! (the game repeats it every few seconds for players who join late).
//!
//! ```text
//! @ <game.map> 0
//! map width 64 height 48 cell 20 part 0 parts 1
//! site team red base_x 110 base_y 90 flag_x 130 flag_y 70
//! row y 0 cells "@@@@..."
//! ```
//!
//! Rows use the Moving AI characters; row 0 is the top. Anything that does
//! not read is counted and skipped; a map larger than [`MAX_SIDE`] cells a
//! side is refused before anything is allocated for it.

use colony_wire::{Line, Packet};
use serde::Serialize;

use super::squad::{is_token, MAX_GAME_COORD};

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

/// A team's base and flag stand, cm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Site {
    pub team: String,
    pub base: (f64, f64),
    pub flag: (f64, f64),
}

/// A whole battlefield.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Map {
    pub width: u32,
    pub height: u32,
    /// The side of a cell, cm.
    pub cell: f64,
    /// Top row first, one character per cell.
    pub rows: Vec<String>,
    pub sites: Vec<Site>,
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

/// Puts `game.map` parts together. Feed it with [`on_packet`](Self::on_packet).
#[derive(Debug, Default)]
pub struct MapAssembler {
    map: Option<Map>,
    version: u64,
    assembly: Option<Assembly>,
    bad_lines: u64,
}

fn coord(line: &Line<'_>, name: &str) -> Option<f64> {
    line.f64(name)
        .ok()
        .filter(|v| v.is_finite() && v.abs() <= MAX_GAME_COORD)
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
    // One part is the common case: the game may leave part and parts out.
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

impl MapAssembler {
    /// The newest complete map.
    pub fn map(&self) -> Option<&Map> {
        self.map.as_ref()
    }

    /// Changes whenever a different map is complete.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Lines that did not read as a map's.
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
                "row" => {
                    let row = (|| {
                        let y = usize::try_from(line.i64("y").ok()?).ok()?;
                        let cells = line.str("cells").ok()?;
                        let ok = y < a.rows.len()
                            && cells.len() == head.width as usize
                            && cells.bytes().all(|b| TERRAIN.contains(&b));
                        ok.then(|| (y, cells.into_owned()))
                    })();
                    match row {
                        Some((y, cells)) => a.rows[y] = Some(cells),
                        None => bad += 1,
                    }
                }
                "site" => {
                    let site = (|| {
                        let team = line.str("team").ok().filter(|t| is_token(t))?;
                        Some(Site {
                            team: team.into_owned(),
                            base: (coord(&line, "base_x")?, coord(&line, "base_y")?),
                            flag: (coord(&line, "flag_x")?, coord(&line, "flag_y")?),
                        })
                    })();
                    match site {
                        Some(s) => {
                            if let Some(old) = a.sites.iter_mut().find(|o| o.team == s.team) {
                                *old = s;
                            } else if a.sites.len() < MAX_SITES {
                                a.sites.push(s);
                            }
                        }
                        None => bad += 1,
                    }
                }
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
        let map = Map {
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
mod tests {
    use super::*;

    fn feed(m: &mut MapAssembler, text: &str) -> bool {
        m.on_packet(&Packet::parse(text.as_bytes()).unwrap())
    }

    const SMALL: &str = "@ <game.map> 0\nmap width 4 height 2 cell 20 part 0 parts 1\nsite team red base_x 10 base_y 10 flag_x 30 flag_y 10\nsite team blue base_x 70 base_y 30 flag_x 50 flag_y 30\nrow y 0 cells \"@.TW\"\nrow y 1 cells \"GS.O\"\n";

    #[test]
    fn a_one_part_map_is_kept_and_a_repeat_changes_nothing() {
        let mut m = MapAssembler::default();
        assert!(feed(&mut m, SMALL));
        let map = m.map().unwrap();
        assert_eq!((map.width, map.height, map.cell), (4, 2, 20.0));
        assert_eq!(map.rows, ["@.TW", "GS.O"]);
        assert_eq!(map.sites[1].team, "blue");
        assert_eq!(map.sites[1].flag, (50.0, 30.0));
        assert_eq!(m.version(), 1);
        assert!(!feed(&mut m, SMALL), "the same map again is no news");
        assert_eq!(m.version(), 1);
        assert_eq!(m.bad_lines(), 0);
    }

    #[test]
    fn parts_are_put_together_and_a_lost_part_costs_one_broadcast() {
        let mut m = MapAssembler::default();
        let p0 = "@ <game.map> 0\nmap width 2 height 3 cell 10 part 0 parts 2\nsite team red base_x 5 base_y 5 flag_x 5 flag_y 15\nrow y 0 cells \"..\"\nrow y 1 cells \"TT\"\n";
        let p1 =
            "@ <game.map> 0\nmap width 2 height 3 cell 10 part 1 parts 2\nrow y 2 cells \"WW\"\n";
        assert!(!feed(&mut m, p0));
        assert!(feed(&mut m, p1));
        assert_eq!(m.map().unwrap().rows, ["..", "TT", "WW"]);
        // Part 1 of the next broadcast is lost; the one after completes.
        let q0 = p0.replace("\"TT\"", "\"SS\"");
        let q1 = p1.replace("\"WW\"", "\"..\"");
        assert!(!feed(&mut m, &q0));
        assert!(!feed(&mut m, &q0), "a repeated part starts afresh");
        assert!(feed(&mut m, &q1));
        assert_eq!(m.map().unwrap().rows, ["..", "SS", ".."]);
        assert_eq!(m.version(), 2);
    }

    #[test]
    fn garbage_is_counted_and_never_kept() {
        let mut m = MapAssembler::default();
        for bad in [
            "@ <game.map> 0\nrow y 0 cells \"..\"\n",
            "@ <game.map> 0\nmap width 5000 height 2 cell 20\n",
            "@ <game.map> 0\nmap width 4096 height 4097 cell 20\n",
            "@ <game.map> 0\nmap width -1 height 2 cell 20\n",
            "@ <game.map> 0\nmap width 2 height 2 cell nan\n",
            "@ <game.map> 0\nmap width 2 height 2 cell 0\n",
            "@ <game.map> 0\nmap width 2 height 2 cell 20 part 3 parts 2\n",
            "@ <game.map> 0\nmap width 2 height 2 cell 20 part 0 parts 99999\n",
        ] {
            assert!(!feed(&mut m, bad), "{bad}");
        }
        assert!(m.map().is_none());
        assert_eq!(m.bad_lines(), 8);
        // Rows of the wrong length, out of range, or with strange characters
        // become out-of-bounds rows; a bad site is skipped.
        let text = "@ <game.map> 0\nmap width 2 height 4 cell 20 extra (a 1)\nrow y 0 cells \"...\"\nrow y 9 cells \"..\"\nrow y 1 cells \"é\"\nrow y 2 cells \"x.\"\nrow y 3 cells \"..\"\nsite team \"a b\" base_x 1 base_y 1 flag_x 1 flag_y 1\nsite team red base_x 1e9 base_y 1 flag_x 1 flag_y 1\n";
        assert!(feed(&mut m, text));
        let map = m.map().unwrap();
        assert_eq!(map.rows, ["@@", "@@", "@@", ".."]);
        assert!(map.sites.is_empty());
        assert_eq!(m.bad_lines(), 8 + 6 + 3);
    }
}
