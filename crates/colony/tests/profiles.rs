//! The test profile names every workspace crate (the workspace's `[profile.dev.package]`): one
//! left out would be built optimised, as the dependencies are, and slowly, with no line tables.

use std::path::Path;
use std::process::Command;

#[test]
fn every_workspace_crate_is_unoptimised_with_line_tables_in_the_test_profile() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let out = Command::new(env!("CARGO"))
        .args([
            "metadata",
            "--no-deps",
            "--format-version",
            "1",
            "--offline",
        ])
        .current_dir(&root)
        .output()
        .expect("run cargo metadata");
    assert!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("metadata is JSON");
    let members: Vec<&str> = meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .filter_map(|p| p["name"].as_str())
        .collect();
    assert!(members.len() > 10, "too few members: {members:?}");
    let manifest = std::fs::read_to_string(root.join("Cargo.toml")).expect("read Cargo.toml");
    let table = manifest
        .split("[profile.dev.package]")
        .nth(1)
        .expect("Cargo.toml has a [profile.dev.package] table");
    let table = table.split("\n[").next().unwrap_or(table);
    for name in members {
        let line = format!("{name} = {{ opt-level = 0, debug = \"line-tables-only\" }}");
        assert!(
            table.lines().any(|l| l.trim() == line),
            "Cargo.toml's [profile.dev.package] lacks `{line}`"
        );
    }
}
