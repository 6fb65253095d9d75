//! The battlefield as the game page draws it. The parts of `game.map` are put together by
//! [`colony_proto::game::MapAssembler`]; this module keeps the newest complete map, which the
//! page gets as proto's [`GameMap`](colony_proto::game::GameMap) writes it (points as `[x, y]`).

use colony_proto::game::MapAssembler;
use colony_wire::Packet;

pub use colony_proto::game::map::MAX_SIDE;

/// A whole battlefield, under the name the game view and the Foxglove scene know it by.
pub use colony_proto::game::GameMap as Map;

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
            self.map = self.parts.map().cloned();
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
        assert_eq!(map.sites[0].flag, colony_proto::Vec2::new(30.0, 10.0));
        let json = serde_json::to_value(map).unwrap();
        assert_eq!(json["sites"][0]["base"], serde_json::json!([10.0, 10.0]));
        assert_eq!(m.version(), 1);
        assert_eq!(m.bad_lines(), 0);
    }
}
