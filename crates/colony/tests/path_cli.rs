//! `colony path`: the Moving AI benchmark sets pass, and bad input fails
//! with a clear message.

use std::path::PathBuf;
use std::process::{Command, Output};

fn colony(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_colony"))
        .args(args)
        .output()
        .expect("run colony")
}

/// The in-repo copies of the benchmark files.
fn movingai(file: &str) -> String {
    let p: PathBuf = [
        env!("CARGO_MANIFEST_DIR"),
        "..",
        "..",
        "maps",
        "movingai",
        file,
    ]
    .iter()
    .collect();
    p.to_string_lossy().into_owned()
}

const PAIRS: [(&str, &str, usize); 3] = [
    ("arena.map", "arena.map.scen", 160),
    ("random-32-32-10.map", "random-32-32-10-random-1.scen", 461),
    ("maze512-32-9.map", "maze512-32-9.map.scen", 8010),
];

#[test]
fn every_benchmark_query_finds_the_published_length() {
    for (map, scen, n) in PAIRS {
        let o = colony(&["path", &movingai(map), &movingai(scen), "--quiet"]);
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{map}: {out}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let summary = out.lines().last().unwrap_or_default();
        assert!(
            summary.starts_with(&format!("{n} queries, {n} optimal, 0 mismatches")),
            "{summary}"
        );
        // --quiet prints only the summary when all is well.
        assert_eq!(out.lines().count(), 1, "{out}");
    }
}

#[test]
fn astar_prints_one_line_per_query() {
    let o = colony(&[
        "path",
        &movingai("arena.map"),
        &movingai("arena.map.scen"),
        "--algorithm",
        "astar",
    ]);
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.lines().count(), 161);
    assert_eq!(
        out.lines().next().unwrap(),
        "query 0: (1,11)->(1,12) found 1.00000 expected 1.00000 ok"
    );
    assert!(out.lines().last().unwrap().contains("AStar"), "{out}");
}

#[test]
fn a_wrong_expected_length_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let scen = dir.path().join("bad.scen");
    std::fs::write(
        &scen,
        "version 1\n0\tarena.map\t49\t49\t1\t11\t1\t12\t1\n0\tarena.map\t49\t49\t1\t11\t1\t12\t2.5\n",
    )
    .unwrap();
    let o = colony(&[
        "path",
        &movingai("arena.map"),
        scen.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("query 1: (1,11)->(1,12) found 1.00000 expected 2.50000 MISMATCH"),
        "{out}"
    );
    assert!(!out.contains("query 0"), "{out}");
    assert!(out.contains("2 queries, 1 optimal, 1 mismatches"), "{out}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("1 of 2 queries"), "{err}");
}

#[test]
fn an_unreachable_query_is_a_mismatch() {
    let dir = tempfile::tempdir().unwrap();
    let scen = dir.path().join("x.scen");
    // (0,0) is a tree on the arena map.
    std::fs::write(&scen, "version 1\n0\tarena.map\t49\t49\t0\t0\t1\t12\t3\n").unwrap();
    let o = colony(&["path", &movingai("arena.map"), scen.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("found unreachable expected 3.00000 MISMATCH"),
        "{out}"
    );
}

#[test]
fn a_garbage_map_names_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("garbage.map");
    std::fs::write(&map, "type octile\nheight 2\nwidth 3\nmap\n...\n.?.\n").unwrap();
    let o = colony(&["path", map.to_str().unwrap(), &movingai("arena.map.scen")]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("garbage.map") && err.contains("line 6, column 2: expected one of"),
        "{err}"
    );
    std::fs::write(&map, [0x00, 0xff, 0xfe, b'\n']).unwrap();
    let o = colony(&["path", map.to_str().unwrap(), &movingai("arena.map.scen")]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("line 1, column 2"), "{err}");
}

#[test]
fn a_scenario_for_another_map_size_is_refused() {
    let o = colony(&[
        "path",
        &movingai("arena.map"),
        &movingai("random-32-32-10-random-1.scen"),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("is for a 32 x 32 map") && err.contains("49 x 49"),
        "{err}"
    );
}

#[test]
fn missing_files_and_bad_arguments_fail_cleanly() {
    let o = colony(&["path", "/nonexistent/a.map", &movingai("arena.map.scen")]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/a.map"));
    let o = colony(&["path", &movingai("arena.map"), "/nonexistent/a.scen"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/a.scen"));
    let o = colony(&[
        "path",
        &movingai("arena.map"),
        &movingai("arena.map.scen"),
        "--algorithm",
        "dijkstra",
    ]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn in_repo_copies_match_the_shared_originals() {
    // The shared directory sits beside the repository; skip where it is absent.
    let shared: PathBuf = [
        env!("CARGO_MANIFEST_DIR"),
        "..",
        "..",
        "..",
        "shared",
        "benchmarks",
        "movingai",
    ]
    .iter()
    .collect();
    if !shared.is_dir() {
        return;
    }
    for (map, scen, _) in PAIRS {
        for f in [map, scen] {
            let ours = std::fs::read(movingai(f)).unwrap();
            let theirs = std::fs::read(shared.join(f)).unwrap();
            assert!(
                ours == theirs,
                "maps/movingai/{f} differs from the shared copy"
            );
        }
    }
}

#[test]
fn an_error_names_its_cause_once() {
    let o = colony(&["path", "/nonexistent/a.map", &movingai("arena.map.scen")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
}

#[test]
fn a_reader_that_stops_early_ends_the_run_quietly() {
    use std::io::{BufRead as _, BufReader};
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_colony"))
        .args([
            "path",
            &movingai("maze512-32-9.map"),
            &movingai("maze512-32-9.map.scen"),
            "--algorithm",
            "astar",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run colony");
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    assert!(first.starts_with("query 0:"), "{first}");
    // The pipe's reading end is dropped here, as `| head -1` would.
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{:?} {err}", o.status);
    assert!(err.is_empty(), "{err}");
}
