//! Every floating-point flag is range-checked: an absurd value is a usage
//! error naming the flag (exit 2), never a panic (101), a spin or a hang.
//! Other absurd arguments (a key file that never ends) fail cleanly too.

use colony_testkit::cli;

/// Runs `colony args`, killing it if it has not ended within a generous
/// wait, and returns its exit code (None: it had to be killed) and stderr.
fn run_bounded(args: &[&str]) -> (Option<i32>, String) {
    let (code, _, err) = cli::run_bounded(args, "warn");
    (code, err)
}

fn refused(args: &[&str], flag: &str) {
    let (code, err) = run_bounded(args);
    assert_eq!(code, Some(2), "colony {}: {err}", args.join(" "));
    assert!(
        err.contains(flag) && err.contains("must be from"),
        "colony {}: {err}",
        args.join(" ")
    );
}

#[test]
fn a_timeout_beyond_a_day_or_not_a_number_is_refused() {
    for t in ["1e308", "nan", "inf", "0", "1e-300"] {
        refused(
            &["status", "--hub", "127.0.0.1:9", "--timeout", t],
            "--timeout",
        );
    }
}

#[test]
fn a_speed_too_small_or_too_large_is_refused_everywhere() {
    for speed in ["1e-300", "0", "nan", "1e300"] {
        refused(&["replay", "--speed", speed, "no-such.clog"], "--speed");
        refused(&["sort", "live", "--speed", speed], "--speed");
        refused(&["demo", "--speed", speed], "--speed");
        refused(&["game", "ctf", "--speed", speed], "--speed");
        refused(&["game", "part", "world", "--speed", speed], "--speed");
    }
}

#[test]
fn run_lengths_beyond_what_the_clock_holds_are_refused() {
    for s in ["1e300", "nan", "0"] {
        refused(&["demo", "--seconds", s], "--seconds");
        refused(&["game", "ctf", "--seconds", s], "--seconds");
        refused(&["tasks", "demo", "--seconds", s], "--seconds");
    }
}

#[test]
fn a_lease_below_a_tenth_of_a_second_or_above_a_day_is_refused() {
    for lease in ["1e-12", "0.01", "1e300", "nan", "-1"] {
        let (code, err) = run_bounded(&["hub", "--bind", "127.0.0.1:0", "--lease", lease]);
        assert_eq!(code, Some(2), "--lease {lease}: {err}");
        assert!(err.contains("--lease") || err.contains("'-1'"), "{err}");
    }
}

#[test]
fn a_game_time_limit_too_long_to_count_is_refused_not_a_panic() {
    refused(
        &["game", "ctf", "--fast", "--time-limit", "1e300"],
        "--time-limit",
    );
    refused(
        &["game", "dm", "--fast", "--time-limit", "nan"],
        "--time-limit",
    );
}

#[test]
fn experiment_times_out_of_range_are_refused() {
    refused(&["tasks", "longterm", "--hours", "1e300"], "--hours");
    refused(
        &["tasks", "boxpush", "--max-seconds", "1e300"],
        "--max-seconds",
    );
    refused(&["tasks", "boxpush", "--off-at", "nan"], "--off-at");
    refused(&["tasks", "boxpush", "--on-at", "1e300"], "--on-at");
}

#[test]
fn log_offsets_that_are_no_time_are_refused() {
    refused(&["log", "--from", "nan", "x.clog"], "--from");
    refused(&["log", "--to", "1e300", "x.clog"], "--to");
}

#[test]
fn sane_values_are_still_taken() {
    // A short lease at the minimum starts a hub (it reports its address).
    let hub = cli::HubProcess::start(&["--lease", "0.1"]);
    drop(hub);
    let (code, err) = run_bounded(&["status", "--hub", "127.0.0.1:9", "--timeout", "0.2"]);
    assert_eq!(code, Some(1), "{err}");
}

#[test]
fn a_key_file_that_never_ends_is_refused_not_read_into_memory() {
    let (code, _, err) = cli::run_bounded(
        &["hub", "--bind", "127.0.0.1:0", "--key", "/dev/zero"],
        "warn",
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("longer than"), "{err}");
}
