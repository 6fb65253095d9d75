//! The Moving AI scenario reader.

use colony_game::map::Cell;
use colony_game::path::scen::{self, ScenError};
use proptest::prelude::*;

fn err(text: &str) -> (usize, usize, String) {
    match scen::parse(text) {
        Err(e @ ScenError::At { line, column, .. }) => (line, column, e.to_string()),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_scenario_parses_with_tabs_or_spaces() {
    let q = scen::parse("version 1\n0\tmaps/dao/arena.map\t49\t49\t1\t11\t1\t12\t1\n\n3 x.map 10 10 0 0 9 9 12.72792206\n").unwrap();
    assert_eq!(q.len(), 2);
    assert_eq!(q[0].map, "maps/dao/arena.map");
    assert_eq!(
        (q[0].start, q[0].goal),
        (Cell::new(1, 11), Cell::new(1, 12))
    );
    assert_eq!((q[0].line, q[1].line, q[1].bucket), (2, 4, 3));
    assert!((q[1].optimal - 12.72792206).abs() < 1e-12);
    assert!(scen::parse("version 1.0\n").unwrap().is_empty());
}

#[test]
fn errors_name_line_column_and_what_was_expected() {
    let (l, c, m) = err("");
    assert_eq!((l, c), (1, 1), "{m}");
    assert!(m.contains("expected `version 1`, found end of file"), "{m}");
    let (l, _, m) = err("version 2\n");
    assert_eq!(l, 1);
    assert!(m.contains("found 'version 2'"), "{m}");
    let (l, c, m) = err("version 1\n0\ta.map\t4x\t4\t0\t0\t1\t1\t1\n");
    assert_eq!((l, c), (2, 9), "{m}");
    assert!(m.contains("expected the map width, found '4x'"), "{m}");
    let (l, c, m) = err("version 1\n0\ta.map\t4\t4\t0\t0\t1\t1\n");
    assert_eq!((l, c), (2, 20), "{m}");
    assert!(
        m.contains("expected the optimal length, found end of line"),
        "{m}"
    );
    let (_, _, m) = err("version 1\n0\ta.map\t4\t4\t0\t0\t1\t1\tNaN\n");
    assert!(
        m.contains("optimal length (a number >= 0), found 'NaN'"),
        "{m}"
    );
    let (_, c, m) = err("version 1\n0\ta.map\t4\t4\t0\t0\t1\t4\t1\n");
    assert_eq!(c, 17, "{m}");
    assert!(
        m.contains("inside the map's width and height, found (1,4)"),
        "{m}"
    );
    let (_, c, m) = err("version 1\n0\ta.map\t4\t4\t0\t0\t1\t1\t1\t7\n");
    assert_eq!(c, 23, "{m}");
    assert!(m.contains("end of line after 9 fields"), "{m}");
}

#[test]
fn unreadable_files_name_the_path() {
    let e = scen::from_file("/nonexistent/x.scen").unwrap_err();
    assert!(e.to_string().contains("/nonexistent/x.scen"), "{e}");
}

proptest! {
    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let _ = scen::parse_bytes(&bytes);
    }

    #[test]
    fn arbitrary_lines_never_panic(line in "[0-9a-z.\\t -]{0,60}") {
        let _ = scen::parse(&format!("version 1\n{line}\n"));
    }
}
