//! The game's messages, whose home is [`colony_proto::game`] (one module per channel); re-exported
//! here so the game's parts name them in one place. What only the game can build from its own
//! types lives here: the map message from a [`Battlefield`].

pub use colony_proto::game::*;
pub use colony_proto::radio::{self, RadioCommand, RADIO};
pub use colony_proto::DecodeError;

use std::collections::BTreeSet;

use colony_wire::Subject;

use crate::map::Battlefield;

/// The subjects a part of the game listens to, from their names. A name that
/// is no subject (a team named with a space in a hand-written map, say) is
/// left out with a warning: nothing can be published on it either.
pub fn subjects<S: AsRef<str>>(names: impl IntoIterator<Item = S>) -> BTreeSet<Subject> {
    names
        .into_iter()
        .filter_map(|n| match Subject::new(n.as_ref()) {
            Ok(s) => Some(s),
            Err(e) => {
                tracing::warn!(error = %e, "cannot listen to a channel with this name");
                None
            }
        })
        .collect()
}

/// The battlefield as the `game.map` packets carry it: the grid's rows in the Moving AI
/// characters (row 0 on top), and each team's base and flag at their cells' centres.
pub fn map_message(field: &Battlefield) -> GameMap {
    let g = &field.grid;
    let rows = (0..g.height())
        .map(|y| {
            (0..g.width())
                .map(|x| g.get(x, y).map_or('@', |t| t.to_char()))
                .collect()
        })
        .collect();
    let centre = |c| {
        let (x, y) = field.cell_center(c);
        colony_sim::Vec2::new(x, y)
    };
    GameMap {
        width: g.width(),
        height: g.height(),
        cell: field.cell_cm,
        rows,
        sites: field
            .teams
            .iter()
            .map(|t| Site {
                team: t.name.clone(),
                base: centre(t.base),
                flag: centre(t.flag),
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_wire::Packet;

    #[test]
    fn the_map_packets_carry_the_battlefield() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/ctf.map");
        let field = Battlefield::from_file(&path).unwrap();
        let map = map_message(&field);
        let mut m = MapAssembler::default();
        for p in map.encode().unwrap() {
            m.on_packet(&Packet::parse(&p).unwrap());
        }
        let got = m.map().unwrap();
        assert_eq!(
            (got.width, got.height),
            (field.grid.width(), field.grid.height())
        );
        assert_eq!(got.sites.len(), field.teams.len());
        assert_eq!(got, &map);
        assert_eq!(m.bad_lines(), 0);
    }
}
