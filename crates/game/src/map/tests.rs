//! Every parse error, and the coordinate conversions.

use super::*;

const HEADER: &str = "type octile\nheight 3\nwidth 4\nmap\n";
const ROWS: &str = "@@@@\n@.S@\n@WT@\n";

fn err(text: &str) -> (usize, usize, String) {
    match Battlefield::parse(text) {
        Ok(_) => panic!("parsed: {text:?}"),
        Err(e) => {
            let (l, c) = e.position().expect("a position");
            (l, c, e.to_string())
        }
    }
}

fn assert_err(text: &str, line: usize, column: usize, contains: &str) {
    let (l, c, msg) = err(text);
    assert_eq!((l, c), (line, column), "{msg}");
    assert!(msg.contains(contains), "{msg:?} lacks {contains:?}");
    assert!(
        msg.starts_with(&format!("line {line}, column {column}: expected ")),
        "{msg}"
    );
}

#[test]
fn a_plain_moving_ai_map_parses() {
    let field = Battlefield::parse(&format!("{HEADER}{ROWS}")).unwrap();
    let g = &field.grid;
    assert_eq!((g.width(), g.height()), (4, 3));
    assert_eq!(g.get(1, 1), Some(Terrain::Open));
    assert_eq!(g.get(2, 1), Some(Terrain::Swamp));
    assert_eq!(g.get(1, 2), Some(Terrain::Water));
    assert_eq!(g.get(2, 2), Some(Terrain::Tree));
    assert_eq!(g.get(0, 0), Some(Terrain::OutOfBounds));
    assert_eq!(g.get(4, 0), None);
    assert_eq!(field.cell_cm, DEFAULT_CELL_CM);
    assert!(field.teams.is_empty());
}

#[test]
fn g_and_o_are_open_and_out_of_bounds() {
    let g = GridMap::parse("type octile\nheight 1\nwidth 2\nmap\nGO\n").unwrap();
    assert_eq!(g.cells(), &[Terrain::Open, Terrain::OutOfBounds]);
}

#[test]
fn crlf_line_ends_and_width_before_height_are_accepted() {
    let text = "type octile\r\nwidth 2\r\nheight 1\r\nmap\r\n..\r\n";
    let g = GridMap::parse(text).unwrap();
    assert_eq!((g.width(), g.height()), (2, 1));
}

#[test]
fn extension_lines_give_cell_size_and_teams() {
    let text = format!(
        "{HEADER}{ROWS}\n# teams\ncell 25.5\nteam red base 1 1 flag 2 1 spawn 1 1\n\nteam blue-2 base 2 1 flag 1 1 spawn 2 1\n"
    );
    let f = Battlefield::parse(&text).unwrap();
    assert_eq!(f.cell_cm, 25.5);
    assert_eq!(f.teams.len(), 2);
    assert_eq!(f.team("red").unwrap().flag, Cell::new(2, 1));
    assert_eq!(f.team("blue-2").unwrap().base, Cell::new(2, 1));
    // And back: Display writes what parse reads.
    assert_eq!(Battlefield::parse(&f.to_string()).unwrap(), f);
}

#[test]
fn missing_or_wrong_header_lines_are_errors() {
    assert_err("", 1, 1, "expected `type octile`, found end of file");
    assert_err("type tile\n", 1, 6, "found 'tile'");
    assert_err(
        "type octile extra\n",
        1,
        13,
        "expected end of line, found 'extra'",
    );
    assert_err(
        "type octile\n",
        2,
        1,
        "`height H` or `width W`, found end of file",
    );
    assert_err("type octile\nsize 3\n", 2, 1, "found 'size'");
    assert_err(
        "type octile\nheight 3\nheight 3\n",
        3,
        1,
        "expected `height` once",
    );
    assert_err(
        "type octile\nheight 3\nwidth 4\n",
        4,
        1,
        "expected `map`, found end of file",
    );
    assert_err(
        "type octile\nheight 3\nwidth 4\nmaps\n",
        4,
        1,
        "expected `map`, found 'maps'",
    );
}

#[test]
fn bad_numbers_in_the_header_are_errors() {
    assert_err(
        "type octile\nheight x3\n",
        2,
        8,
        "whole number of cells from 1 to 65536, found 'x3'",
    );
    assert_err("type octile\nheight -3\n", 2, 8, "found '-3'");
    assert_err("type octile\nheight 0\n", 2, 8, "found '0'");
    assert_err("type octile\nheight 70000\n", 2, 8, "found '70000'");
    assert_err("type octile\nheight\n", 2, 7, "found end of line");
    assert_err(
        "type octile\nheight 65536\nwidth 65536\n",
        3,
        7,
        "within 2^28 cells",
    );
}

#[test]
fn a_bad_terrain_character_names_its_column() {
    assert_err(
        &format!("{HEADER}@@@@\n@.x@\n@@@@\n"),
        6,
        3,
        "expected one of . G @ O T S W, found 'x'",
    );
}

#[test]
fn rows_of_the_wrong_length_are_errors() {
    assert_err(
        &format!("{HEADER}@@@@\n@.@\n@@@@\n"),
        6,
        4,
        "expected 4 cells in this row",
    );
    assert_err(
        &format!("{HEADER}@@@@\n@..@@\n@@@@\n"),
        6,
        5,
        "expected the row to end after 4 cells",
    );
}

#[test]
fn height_mismatches_are_errors() {
    assert_err(
        &format!("{HEADER}@@@@\n@..@\n"),
        7,
        1,
        "expected 3 map rows (the header's height), found 2",
    );
    assert_err(
        &format!("{HEADER}{ROWS}@@@@\n"),
        8,
        1,
        "expected 3 map rows (the header's height), found another map row",
    );
}

#[test]
fn unknown_extension_lines_are_errors() {
    assert_err(
        &format!("{HEADER}{ROWS}  flag 1 1\n"),
        8,
        3,
        "expected `cell`, `team`",
    );
}

#[test]
fn bad_cell_lines_are_errors() {
    assert_err(
        &format!("{HEADER}{ROWS}cell 0\n"),
        8,
        6,
        "positive cell side in centimetres, found '0'",
    );
    assert_err(&format!("{HEADER}{ROWS}cell inf\n"), 8, 6, "found 'inf'");
    assert_err(&format!("{HEADER}{ROWS}cell\n"), 8, 5, "found end of line");
    assert_err(
        &format!("{HEADER}{ROWS}cell 20 cm\n"),
        8,
        9,
        "expected end of line, found 'cm'",
    );
    assert_err(
        &format!("{HEADER}{ROWS}cell 20\ncell 30\n"),
        9,
        1,
        "expected a `cell` line once",
    );
}

#[test]
fn bad_team_lines_are_errors() {
    let t = |rest: &str| format!("{HEADER}{ROWS}team {rest}\n");
    assert_err(&t(""), 8, 6, "expected a team name");
    assert_err(&t("r:d base 1 1 flag 1 1 spawn 1 1"), 8, 6, "found 'r:d'");
    assert_err(
        &t("red bas 1 1 flag 1 1 spawn 1 1"),
        8,
        10,
        "expected `base X Y`, found 'bas'",
    );
    assert_err(
        &t("red base one 1 flag 1 1 spawn 1 1"),
        8,
        15,
        "expected a column number",
    );
    assert_err(
        &t("red base 1 -1 flag 1 1 spawn 1 1"),
        8,
        17,
        "expected a row number",
    );
    assert_err(
        &t("red base 1 1 flag 1 1"),
        8,
        27,
        "expected `spawn X Y`, found end of line",
    );
    assert_err(
        &t("red base 1 1 flag 1 1 spawn 1 1 extra"),
        8,
        38,
        "expected end of line",
    );
    assert_err(
        &t("red base 1 1 flag 9 1 spawn 1 1"),
        8,
        24,
        "expected the red flag inside the 4 x 3 map, found (9, 1)",
    );
    assert_err(
        &t("red base 1 1 flag 1 1 spawn 1 2"),
        8,
        34,
        "expected the red spawn on open or swamp ground, found water at (1, 2)",
    );
    assert_err(
        &t("red base 2 2 flag 1 1 spawn 1 1"),
        8,
        15,
        "found trees at (2, 2)",
    );
    assert_err(
        &t("red base 0 0 flag 1 1 spawn 1 1"),
        8,
        15,
        "found out of bounds at (0, 0)",
    );
    let twice = format!(
        "{HEADER}{ROWS}team red base 1 1 flag 1 1 spawn 1 1\nteam red base 1 1 flag 1 1 spawn 1 1\n"
    );
    assert_err(&twice, 9, 6, "expected team name 'red' once");
}

#[test]
fn bytes_that_are_not_utf8_are_an_error_with_position() {
    let mut bytes = format!("{HEADER}@@").into_bytes();
    bytes.push(0xff);
    let e = Battlefield::parse_bytes(&bytes).unwrap_err();
    assert_eq!(e.position(), Some((5, 3)));
    assert!(e.to_string().contains("expected UTF-8 text"), "{e}");
}

#[test]
fn a_missing_file_is_a_read_error_naming_it() {
    let e = GridMap::from_file("/nonexistent/colony.map").unwrap_err();
    assert!(matches!(e, MapError::Read { .. }));
    assert!(e.to_string().contains("/nonexistent/colony.map"), "{e}");
}

#[test]
fn cell_centres_use_world_centimetres_with_y_up() {
    let f = Battlefield::parse(&format!("{HEADER}{ROWS}cell 10\n")).unwrap();
    // Row 0 is the top row: its centre is half a cell below the top edge.
    assert_eq!(f.cell_center(Cell::new(0, 0)), (5.0, 25.0));
    assert_eq!(f.cell_center(Cell::new(3, 2)), (35.0, 5.0));
    assert_eq!(f.size_cm(), (40.0, 30.0));
    for y in 0..3 {
        for x in 0..4 {
            let c = Cell::new(x, y);
            let (cx, cy) = f.cell_center(c);
            assert_eq!(f.cell_at(cx, cy), Some(c));
            assert_eq!(f.cell_at(cx - 4.9, cy + 4.9), Some(c));
        }
    }
    assert_eq!(f.cell_at(-0.1, 5.0), None);
    assert_eq!(f.cell_at(5.0, 30.0), None);
    assert_eq!(f.cell_at(40.0, 5.0), None);
    assert_eq!(f.cell_at(f64::NAN, 5.0), None);
    assert_eq!(f.cell_at(0.0, 0.0), Some(Cell::new(0, 2)));
}
