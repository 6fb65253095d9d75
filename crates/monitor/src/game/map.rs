//! The battlefield as the game page draws it. The parts of `game.map` are put together by
//! [`colony_proto::game::MapAssembler`]; this module keeps the newest complete map in the shape
//! the page's JSON has (points as `[x, y]`).

use colony_proto::game::{self, MapAssembler};
use colony_wire::Packet;
use serde::Serialize;

pub use colony_proto::game::map::MAX_SIDE;

/// A team's base and flag stand, cm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Site {
    /// The team.
    pub team: String,
    /// Its base, `[x, y]`.
    pub base: (f64, f64),
    /// Its flag's stand, `[x, y]`.
    pub flag: (f64, f64),
}

/// A whole battlefield.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Map {
    /// Cells across.
    pub width: u32,
    /// Cells down.
    pub height: u32,
    /// The side of a cell, cm.
    pub cell: f64,
    /// Top row first, one character per cell.
    pub rows: Vec<String>,
    /// Each team's base and flag.
    pub sites: Vec<Site>,
}

impl From<&game::GameMap> for Map {
    fn from(m: &game::GameMap) -> Map {
        Map {
            width: m.width,
            height: m.height,
            cell: m.cell,
            rows: m.rows.clone(),
            sites: m
                .sites
                .iter()
                .map(|s| Site {
                    team: s.team.clone(),
                    base: (s.base.x, s.base.y),
                    flag: (s.flag.x, s.flag.y),
                })
                .collect(),
        }
    }
}

/// The newest complete map. Feed it with [`on_packet`](Self::on_packet).
#[derive(Debug, Default)]
pub struct MapView {
    parts: MapAssembler,
    map: Option<Map>,
}

impl MapView {
    /// The newest complete map.
    pub fn map(&self) -> Option<&Map> {
        self.map.as_ref()
    }

    /// Changes whenever a different map is complete.
    pub fn version(&self) -> u64 {
        self.parts.version()
    }

    /// Lines that did not read as a map's.
    pub fn bad_lines(&self) -> u64 {
        self.parts.bad_lines()
    }

    /// Takes in one `game.map` packet; true when it completed a new map.
    pub fn on_packet(&mut self, packet: &Packet<'_>) -> bool {
        let new = self.parts.on_packet(packet);
        if new {
            self.map = self.parts.map().map(Map::from);
        }
        new
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_gets_the_map_with_points_as_pairs() {
        let mut m = MapView::default();
        let text = "@ <game.map> 0\nmap width 4 height 2 cell 20 part 0 parts 1\nsite team red base_x 10 base_y 10 flag_x 30 flag_y 10\nrow y 0 cells \"@.TW\"\nrow y 1 cells \"GS.O\"\n";
        assert!(m.on_packet(&Packet::parse(text.as_bytes()).unwrap()));
        let map = m.map().unwrap();
        assert_eq!(map.rows, ["@.TW", "GS.O"]);
        assert_eq!(map.sites[0].flag, (30.0, 10.0));
        let json = serde_json::to_value(map).unwrap();
        assert_eq!(json["sites"][0]["base"], serde_json::json!([10.0, 10.0]));
        assert_eq!(m.version(), 1);
        assert_eq!(m.bad_lines(), 0);
    }
}
