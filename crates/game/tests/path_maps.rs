//! The shipped battlefield maps are playable, and no input makes the map
//! reader panic.

use colony_game::map::{Battlefield, Cell, GridMap, Terrain};
use colony_game::path::{Mover, Planner};
use proptest::prelude::*;

fn shipped(name: &str) -> Battlefield {
    let path = format!("{}/../../maps/{name}", env!("CARGO_MANIFEST_DIR"));
    Battlefield::from_file(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Every team's spawn reaches every site of every other team by land.
fn assert_sites_reachable(field: &Battlefield) {
    let mut planner = Planner::new(&field.grid, Mover::Land);
    for from in &field.teams {
        for to in &field.teams {
            for site in [to.base, to.flag, to.spawn] {
                assert!(
                    planner.astar(from.spawn, site).is_some(),
                    "{} spawn {} cannot reach {}'s site {}",
                    from.name,
                    from.spawn,
                    to.name,
                    site
                );
            }
        }
    }
}

#[test]
fn ctf_has_two_teams_split_by_a_river_with_crossings() {
    let f = shipped("ctf.map");
    assert_eq!((f.grid.width(), f.grid.height()), (64, 48));
    let (red, blue) = (f.team("red").unwrap(), f.team("blue").unwrap());
    // Red holds the bottom, blue the top.
    assert!(red.base.y > 36 && blue.base.y < 12);
    assert_sites_reachable(&f);

    // The way across is only over the crossings: flood them and land units
    // are cut off, amphibians are not.
    const RIVER_ROWS: std::ops::RangeInclusive<u32> = 17..=28;
    const CROSSINGS: [std::ops::RangeInclusive<u32>; 3] = [9..=11, 30..=33, 52..=54];
    let mut flooded = f.grid.clone();
    for x in CROSSINGS.into_iter().flatten() {
        for y in RIVER_ROWS {
            let c = Cell::new(x, y);
            let t = flooded.terrain(c).unwrap();
            if t.is_land() {
                let beside_water = [x - 3, x + 3]
                    .iter()
                    .any(|&xx| flooded.get(xx, y) == Some(Terrain::Water));
                if beside_water {
                    flooded.set(c, Terrain::Water);
                }
            }
        }
    }
    assert!(Planner::new(&flooded, Mover::Land)
        .astar(red.spawn, blue.spawn)
        .is_none());
    assert!(Planner::new(&flooded, Mover::Amphibious)
        .astar(red.spawn, blue.spawn)
        .is_some());
}

#[test]
fn dm_arena_is_open_between_both_spawns() {
    let f = shipped("dm.map");
    assert_eq!((f.grid.width(), f.grid.height()), (48, 48));
    assert_eq!(f.teams.len(), 2);
    assert_sites_reachable(&f);
}

#[test]
fn shipped_maps_are_valid_moving_ai_grids() {
    // A Moving AI reader stops after `height` rows; ours, given only those
    // lines, must read the same grid.
    for name in ["ctf.map", "dm.map"] {
        let f = shipped(name);
        let text =
            std::fs::read_to_string(format!("{}/../../maps/{name}", env!("CARGO_MANIFEST_DIR")))
                .unwrap();
        let grid_only: String = text
            .lines()
            .take(4 + f.grid.height() as usize)
            .map(|l| format!("{l}\n"))
            .collect();
        assert_eq!(GridMap::parse(&grid_only).unwrap(), f.grid);
    }
}

const VALID: &str = "type octile\nheight 3\nwidth 4\nmap\n@@@@\n@.S@\n@WT@\ncell 20\nteam red base 1 1 flag 2 1 spawn 1 1\n";

fn check_error(r: Result<Battlefield, colony_game::map::MapError>) -> Result<(), TestCaseError> {
    if let Err(e) = r {
        let (line, column) = e.position().expect("parse errors have a position");
        prop_assert!(line >= 1 && column >= 1);
        prop_assert!(e.to_string().contains("expected"), "{e}");
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn arbitrary_text_never_panics(text in ".{0,200}") {
        check_error(Battlefield::parse(&text))?;
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        check_error(Battlefield::parse_bytes(&bytes))?;
    }

    #[test]
    fn mutated_maps_never_panic(
        edits in prop::collection::vec((any::<prop::sample::Index>(), prop::sample::select(
            vec![' ', '\n', '\t', '\r', '0', '9', '-', '.', '@', 'W', 'x', 'é', '#']
        ), 0u8..3), 1..6),
    ) {
        let mut chars: Vec<char> = VALID.chars().collect();
        for (at, c, how) in edits {
            let i = at.index(chars.len() + 1);
            match how {
                0 if i < chars.len() => chars[i] = c,
                1 if i < chars.len() => { chars.remove(i); }
                _ => chars.insert(i, c),
            }
        }
        let text: String = chars.into_iter().collect();
        check_error(Battlefield::parse(&text))?;
    }

    #[test]
    fn written_grids_read_back_the_same(
        (w, h, cells) in (1u32..10, 1u32..10).prop_flat_map(|(w, h)| {
            (Just(w), Just(h), prop::collection::vec(prop::sample::select(
                vec![Terrain::Open, Terrain::Swamp, Terrain::Tree, Terrain::Water, Terrain::OutOfBounds]
            ), (w * h) as usize))
        })
    ) {
        let rows = cells.chunks(w as usize).map(|r| r.to_vec()).collect();
        let g = GridMap::from_rows(rows).unwrap();
        prop_assert_eq!((g.width(), g.height()), (w, h));
        prop_assert_eq!(GridMap::parse(&g.to_string()).unwrap(), g);
    }
}
