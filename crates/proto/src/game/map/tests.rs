//! The map's round trips through its parts, and what the assembler makes of garbage.

use super::*;
use proptest::prelude::*;

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
    assert_eq!(map.sites[1].flag, Vec2::new(50.0, 30.0));
    assert_eq!(m.version(), 1);
    assert!(!feed(&mut m, SMALL), "the same map again is no news");
    assert_eq!(m.version(), 1);
    assert_eq!(m.bad_lines(), 0);
}

#[test]
fn parts_are_put_together_and_a_lost_part_costs_one_broadcast() {
    let mut m = MapAssembler::default();
    let p0 = "@ <game.map> 0\nmap width 2 height 3 cell 10 part 0 parts 2\nsite team red base_x 5 base_y 5 flag_x 5 flag_y 15\nrow y 0 cells \"..\"\nrow y 1 cells \"TT\"\n";
    let p1 = "@ <game.map> 0\nmap width 2 height 3 cell 10 part 1 parts 2\nrow y 2 cells \"WW\"\n";
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

fn sample(width: u32, height: u32) -> GameMap {
    GameMap {
        width,
        height,
        cell: 20.0,
        rows: (0..height)
            .map(|y| {
                (0..width)
                    .map(|x| char::from(TERRAIN[((x * 7 + y * 3) % 7) as usize]))
                    .collect()
            })
            .collect(),
        sites: vec![
            Site {
                team: "red".into(),
                base: Vec2::new(10.0, 10.0),
                flag: Vec2::new(30.5, 10.25),
            },
            Site {
                team: "blue".into(),
                base: Vec2::new(70.0, 30.0),
                flag: Vec2::new(50.0, 30.0),
            },
        ],
    }
}

#[test]
fn the_table_is_what_the_writer_writes_and_the_reader_needs() {
    crate::table::check::codec(&TABLE, &sample(4, 2).encode().unwrap(), |p| {
        let mut m = MapAssembler::default();
        m.on_packet(p) && m.bad_lines() == 0
    });
}

#[test]
fn a_large_map_travels_in_parts_that_fit_a_datagram_and_comes_back_whole() {
    let map = sample(1024, 300);
    let packets = map.encode().unwrap();
    assert!(packets.len() > 1, "{} parts", packets.len());
    assert!(packets.iter().all(|p| p.len() < 60_000));
    let mut m = MapAssembler::default();
    let done: Vec<bool> = packets
        .iter()
        .map(|p| m.on_packet(&Packet::parse(p).unwrap()))
        .collect();
    assert_eq!(done.iter().filter(|d| **d).count(), 1);
    assert!(done[done.len() - 1]);
    assert_eq!(m.map(), Some(&map));
    assert_eq!(m.bad_lines(), 0);
}

#[test]
fn a_small_map_is_one_packet_as_the_game_writes_it() {
    let packets = sample(4, 2).encode().unwrap();
    assert_eq!(packets.len(), 1);
    let text = String::from_utf8(packets[0].clone()).unwrap();
    assert!(
        text.starts_with("@ <game.map> 0\nmap width 4 height 2 cell 20"),
        "{text}"
    );
    assert!(text.contains("site team red base_x 10.0 base_y 10.0 flag_x 30.5 flag_y 10.25\n"));
}

proptest! {
    #[test]
    fn any_map_comes_back_whole(width in 1u32..200, height in 1u32..200) {
        let map = sample(width, height);
        let mut m = MapAssembler::default();
        for p in map.encode().unwrap() {
            m.on_packet(&Packet::parse(&p).unwrap());
        }
        prop_assert_eq!(m.map(), Some(&map));
    }

    #[test]
    fn the_assembler_never_panics(text in "[a-z0-9 .@\"\n-]{0,300}") {
        let bytes = format!("@ <game.map> 0\nmap width 3 height 2 cell 20 part 0 parts 2\n{text}");
        let mut m = MapAssembler::default();
        if let Ok(p) = Packet::parse(bytes.as_bytes()) {
            m.on_packet(&p);
        }
        prop_assert!(m.map().is_none_or(|m| m.rows.len() == m.height as usize));
    }
}

#[test]
fn as_json_a_map_writes_its_points_as_pairs() {
    let map = GameMap {
        width: 2,
        height: 1,
        cell: 20.0,
        rows: vec!["@.".into()],
        sites: vec![Site {
            team: "red".into(),
            base: Vec2::new(10.0, 10.0),
            flag: Vec2::new(30.5, 10.0),
        }],
    };
    assert_eq!(
        serde_json::to_string(&map).unwrap(),
        r#"{"width":2,"height":1,"cell":20.0,"rows":["@."],"sites":[{"team":"red","base":[10.0,10.0],"flag":[30.5,10.0]}]}"#
    );
}
