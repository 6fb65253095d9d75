//! Request and reply through a real hub: `colony serve` processes as
//! providers, killed and stopped mid-way, and `colony call`.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use colony_client::rpc::{CallClient, CallError, Id};
use colony_testkit::cli::{run_bounded, HubProcess, Proc};
use colony_wire::Priority;

/// Generous: every wait here is for an event, not a measure of speed.
const WAIT: Duration = Duration::from_secs(20);

/// How one call ended: its provider and lines, or why not.
type Ended = Result<(Id, Vec<String>), CallError>;

/// Starts `colony serve` and reads the provider id it prints.
fn provider(hub: &HubProcess, args: &[&str]) -> (Proc, Id) {
    let addr = hub.addr.to_string();
    let mut all = vec!["serve", "--hub", addr.as_str()];
    all.extend_from_slice(args);
    let proc = Proc::start(&all);
    proc.when("provider ", WAIT)
        .expect("`colony serve` says which provider it is");
    let text = proc.text();
    let id = text
        .split_whitespace()
        .nth(1)
        .and_then(Id::parse)
        .unwrap_or_else(|| panic!("no provider id in {text:?}"));
    (proc, id)
}

fn poll_until(client: &mut CallClient, mut done: impl FnMut(&CallClient) -> bool) {
    let deadline = Instant::now() + WAIT;
    while !done(client) {
        assert!(Instant::now() < deadline, "gave up waiting");
        client
            .client()
            .wait(Some(Instant::now() + Duration::from_millis(20)))
            .unwrap();
        client.poll(Instant::now()).unwrap();
    }
}

#[test]
fn two_providers_share_a_hundred_calls_and_a_killed_one_ends_its_calls_with_a_clear_error() {
    let hub = HubProcess::start(&[]);
    // Each call takes the provider a moment, so calls queue at both and the
    // kill finds some waiting on the one killed.
    let serve = ["--lease", "5", "work", "--", "sh", "-c", "sleep 0.02; cat"];
    let (mut first, first_id) = provider(&hub, &serve);
    let (_second, second_id) = provider(&hub, &serve);
    let mut client = CallClient::connect(&hub.addr.to_string(), "work").unwrap();
    poll_until(&mut client, |c| c.caller().providers().count() == 2);

    let mut started: HashMap<Id, usize> = HashMap::new();
    let mut ended: HashMap<Id, Vec<Ended>> = HashMap::new();
    let mut killed_after = None;
    let deadline = Instant::now() + Duration::from_secs(180);
    while ended.len() < 100 {
        assert!(Instant::now() < deadline, "calls never ended: {ended:?}");
        while started.len() < 100 && client.caller().in_flight() < 8 {
            let n = started.len();
            let line = format!("n value {n}");
            let id = client
                .start(Priority(0), &[&line], Duration::from_secs(60))
                .unwrap();
            started.insert(id, n);
        }
        client
            .client()
            .wait(Some(Instant::now() + Duration::from_millis(20)))
            .unwrap();
        client.poll(Instant::now()).unwrap();
        while let Some((id, result)) = client.poll_outcome() {
            let result = result.map(|a| (a.provider, a.lines));
            ended.entry(id).or_default().push(result);
        }
        if killed_after.is_none() && ended.len() >= 50 {
            first.kill();
            killed_after = Some(ended.len());
        }
    }

    let mut answered_by: HashMap<Id, usize> = HashMap::new();
    let mut failed = 0;
    for (id, results) in &ended {
        let n = started[id];
        assert_eq!(results.len(), 1, "call {n} ended {} times", results.len());
        match &results[0] {
            Ok((provider, lines)) => {
                assert_eq!(lines, &[format!("n value {n}")], "call {n}'s answer");
                *answered_by.entry(*provider).or_default() += 1;
            }
            Err(e @ CallError::ProviderLapsed { provider, .. }) => {
                assert_eq!(*provider, first_id, "{e}");
                assert!(e.to_string().contains(&first_id.to_string()), "{e}");
                failed += 1;
            }
            Err(e @ CallError::Timeout { .. }) => {
                assert!(e.to_string().contains("did not answer"), "{e}");
                failed += 1;
            }
            Err(e) => panic!("call {n}: unexpected {e}"),
        }
    }
    assert_eq!(ended.len(), 100);
    assert!(answered_by[&first_id] > 0, "{answered_by:?}");
    assert!(answered_by[&second_id] > 50, "{answered_by:?}");
    assert!(
        failed > 0,
        "the kill found no call waiting on the killed provider"
    );
    assert_eq!(client.caller().strays(), 0);
    assert_eq!(client.caller().forged(), 0);
    assert_eq!(client.caller().providers().collect::<Vec<_>>(), [second_id]);
    eprintln!(
        "killed after {:?} calls ended; answered by {answered_by:?}; {failed} ended without an answer",
        killed_after
    );
}

#[test]
fn a_provider_asked_to_stop_refuses_its_calls_at_once_instead_of_leaving_them_to_its_lease() {
    let hub = HubProcess::start(&[]);
    let (proc, id) = provider(
        &hub,
        &[
            "--lease",
            "60",
            "--command-timeout",
            "60",
            "slow",
            "--",
            "sleep",
            "30",
        ],
    );
    let mut client = CallClient::connect(&hub.addr.to_string(), "slow").unwrap();
    poll_until(&mut client, |c| c.caller().providers().count() == 1);
    for _ in 0..2 {
        client
            .start(Priority(0), &["x y 1"], Duration::from_secs(60))
            .unwrap();
    }
    // Let the provider take the first call and start its command.
    let t = Instant::now();
    while t.elapsed() < Duration::from_millis(500) {
        client
            .client()
            .wait(Some(Instant::now() + Duration::from_millis(20)))
            .unwrap();
        client.poll(Instant::now()).unwrap();
    }
    let stopped = std::process::Command::new("kill")
        .args(["-TERM", &proc.pid().to_string()])
        .status()
        .unwrap();
    assert!(stopped.success());
    let mut outcomes = Vec::new();
    poll_until(&mut client, |c| {
        c.caller().in_flight() == 0 || Instant::now() > t + WAIT
    });
    while let Some(o) = client.poll_outcome() {
        outcomes.push(o);
    }
    assert_eq!(outcomes.len(), 2, "{outcomes:?}");
    for (_, result) in outcomes {
        match result {
            Err(CallError::Refused { provider, why }) => {
                assert_eq!(provider, id);
                assert!(why.contains("stopping"), "{why}");
            }
            other => panic!("expected the call refused as the provider stopped, got {other:?}"),
        }
    }
    // It said it was leaving: no new call goes to it.
    poll_until(&mut client, |c| c.caller().providers().count() == 0);
}

#[test]
fn the_command_line_calls_serves_refuses_and_explains() {
    let hub = HubProcess::start(&[]);
    let addr = hub.addr.to_string();
    let (_echo, _) = provider(&hub, &["--echo", "echo"]);
    let (_fail, _) = provider(
        &hub,
        &["fail", "--", "sh", "-c", "echo 'disk on fire' >&2; exit 3"],
    );

    let (code, out, err) = run_bounded(
        &[
            "call",
            "--hub",
            &addr,
            "echo",
            "text value \"hi there\"",
            "n value 3",
        ],
        "warn",
    );
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out, "text value \"hi there\"\nn value 3\n");

    let (code, _, err) = run_bounded(
        &["call", "--hub", &addr, "--timeout", "15", "fail", "x y 1"],
        "warn",
    );
    assert_eq!(code, Some(1));
    assert!(
        err.contains("refused the call") && err.contains("disk on fire"),
        "{err}"
    );

    let (code, _, err) = run_bounded(
        &[
            "call",
            "--hub",
            &addr,
            "--timeout",
            "0.5",
            "nobody",
            "x y 1",
        ],
        "warn",
    );
    assert_eq!(code, Some(1));
    assert!(err.contains("no provider of the service"), "{err}");

    let (code, _, err) = run_bounded(&["call", "--hub", &addr, "echo", "x ("], "warn");
    assert_eq!(code, Some(1));
    assert!(err.contains("line 1, column 3"), "{err}");

    let (code, _, err) = run_bounded(&["call", "--hub", &addr, "no service", "x y 1"], "warn");
    assert_eq!(code, Some(1));
    assert!(err.contains("cannot name a service"), "{err}");

    let (code, _, err) = run_bounded(
        &["call", "--hub", &addr, "--timeout", "1e308", "echo"],
        "warn",
    );
    assert_eq!(code, Some(2), "{err}");
    let (code, _, err) = run_bounded(
        &["serve", "--hub", &addr, "--lease", "nan", "--echo", "x"],
        "warn",
    );
    assert_eq!(code, Some(2), "{err}");
    let (code, _, err) = run_bounded(&["serve", "--hub", &addr, "x"], "warn");
    assert_eq!(code, Some(2), "a provider needs a command or --echo: {err}");

    // What a command leaves running does not hold its answer back, and is killed.
    let (_bg, _) = provider(
        &hub,
        &["bg", "--", "sh", "-c", "sleep 600 & echo 'left x 1'"],
    );
    let (code, out, err) = run_bounded(
        &["call", "--hub", &addr, "--timeout", "15", "bg", "x y 1"],
        "warn",
    );
    assert_eq!((code, out.as_str()), (Some(0), "left x 1\n"), "{err}");

    // A command longer than the lease: the provider keeps announcing while it runs.
    let (_slow, _) = provider(
        &hub,
        &[
            "--lease",
            "0.5",
            "slow",
            "--",
            "sh",
            "-c",
            "sleep 2; echo 'done x 1'",
        ],
    );
    let (code, out, err) = run_bounded(
        &["call", "--hub", &addr, "--timeout", "15", "slow", "x y 1"],
        "warn",
    );
    assert_eq!((code, out.as_str()), (Some(0), "done x 1\n"), "{err}");

    // An answer longer than a packet is refused with the reason.
    let (_big, _) = provider(
        &hub,
        &["big", "--", "sh", "-c", "yes 'x y 1' | head -c 100000"],
    );
    let (code, _, err) = run_bounded(
        &["call", "--hub", &addr, "--timeout", "15", "big", "x y 1"],
        "warn",
    );
    assert_eq!(code, Some(1));
    assert!(err.contains("more than one packet holds"), "{err}");

    // A second call to a service with one provider: answers do not leak between calls.
    let (code, out, _) = run_bounded(
        &["call", "--hub", &addr, "--timeout", "15", "echo", "k v 2"],
        "warn",
    );
    assert_eq!((code, out.as_str()), (Some(0), "k v 2\n"));
}
