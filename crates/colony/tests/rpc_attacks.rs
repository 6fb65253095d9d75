//! Request and reply against a process that tries to speak for a provider,
//! on loopback: a hub, `colony serve`, `colony call`, and a forger that
//! hears what anyone may hear (it subscribes like any client) and answers
//! calls or announces providers of its own before the real one can.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_testkit::cli::{run_bounded, HubProcess, Proc};
use colony_testkit::client::{drain_until, subscribed};
use colony_wire::seal::Identity;
use colony_wire::Packet;

/// Generous: every wait here is for an event, not a measure of speed.
const WAIT: Duration = Duration::from_secs(20);

/// One test at a time: a forger's flood must not slow another test's calls.
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// Starts `colony serve` and reads the provider id it prints.
fn provider(hub: &HubProcess, args: &[&str]) -> (Proc, String) {
    let addr = hub.addr.to_string();
    let mut all = vec!["serve", "--hub", addr.as_str()];
    all.extend_from_slice(args);
    let proc = Proc::start(&all);
    proc.when("provider ", WAIT)
        .expect("`colony serve` says which provider it is");
    let id = proc
        .text()
        .split_whitespace()
        .nth(1)
        .expect("a provider id")
        .to_owned();
    (proc, id)
}

fn call(hub: &HubProcess, args: &[&str]) -> (Option<i32>, String, String) {
    let addr = hub.addr.to_string();
    let mut all = vec!["call", "--hub", addr.as_str()];
    all.extend_from_slice(args);
    run_bounded(&all, "warn")
}

/// A client that hears `subjects` and, on each packet, publishes what
/// `answer` makes of it, until stopped; returns how many packets it answered.
struct Forger {
    stop: Arc<AtomicBool>,
    thread: thread::JoinHandle<usize>,
}

impl Forger {
    fn start(
        hub: SocketAddr,
        subjects: &[&str],
        mut answer: impl FnMut(&Packet<'_>) -> Vec<Vec<u8>> + Send + 'static,
    ) -> Forger {
        let mut client = subscribed(hub, subjects);
        let stop = Arc::new(AtomicBool::new(false));
        let stopped = stop.clone();
        let thread = thread::spawn(move || {
            let mut answered = 0;
            while !stopped.load(Ordering::Relaxed) {
                let _ = client.wait(Some(Instant::now() + Duration::from_millis(20)));
                client.poll(Instant::now()).unwrap();
                let mut out = Vec::new();
                while let Some(packet) = client.recv().unwrap() {
                    let said = answer(&packet);
                    answered += usize::from(!said.is_empty());
                    out.extend(said);
                }
                for bytes in out {
                    publish(&mut client, &bytes);
                }
            }
            answered
        });
        Forger { stop, thread }
    }

    fn stop(self) -> usize {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.join().unwrap()
    }
}

fn publish(client: &mut UdpClient, bytes: &[u8]) {
    client.publish(bytes).expect("publish");
}

fn first_line(packet: &Packet<'_>) -> String {
    packet
        .lines()
        .next()
        .map_or(String::new(), |l| l.as_str().to_owned())
}

/// The value of `name` on a line of bare tokens.
fn field<'a>(line: &'a str, name: &str) -> Option<&'a str> {
    let words: Vec<&str> = line.split_whitespace().collect();
    words.windows(2).find(|w| w[0] == name).map(|w| w[1])
}

#[test]
fn a_forger_on_the_providers_inbox_cannot_answer_a_call_for_it() {
    let _one = serial();
    let hub = HubProcess::start(&[]);
    // Slow, so the forger is surely first.
    let (_serve, id) = provider(
        &hub,
        &["slow", "--", "sh", "-c", "sleep 0.5; sed 's/^/real_/'"],
    );
    let inbox = format!("svc.slow.{id}");
    let mut identity = Identity::generate();
    let real = id.clone();
    let forger = Forger::start(hub.addr, &[&inbox], move |packet| {
        let line = first_line(packet);
        let (Some(call), Some(reply_to)) = (field(&line, "id"), field(&line, "reply_to")) else {
            return Vec::new();
        };
        let to = |body: &str| format!("@ <{reply_to}> 0\n{body}\n").into_bytes();
        vec![
            // As the hostile review did: the provider's id, no seal.
            to(&format!("reply id {call} from {real}\nforged x 1")),
            // Sealed, by a key that is not the provider's.
            identity.sealed(to(&format!("accepted id {call} from {real}"))),
            identity.sealed(to(&format!("reply id {call} from {real}\nforged x 2"))),
            to(&format!("refused id {call} from {real} text forged")),
        ]
    });
    for i in 0..3 {
        let line = format!("n value {i}");
        let (code, out, err) = call(&hub, &["--timeout", "15", "slow", &line]);
        assert!(
            !out.contains("forged"),
            "the forger's answer was taken: {out}"
        );
        assert_eq!(code, Some(0), "{err}");
        assert_eq!(out, format!("real_{line}\n"));
    }
    assert!(forger.stop() >= 3, "the forger never saw the calls");
}

#[test]
fn two_hundred_forged_providers_keep_no_call_from_the_real_one() {
    let _one = serial();
    let hub = HubProcess::start(&[]);
    let (_serve, _) = provider(&hub, &["--echo", "echo"]);
    // Each a valid seal under a key of its own, with nobody behind it: they
    // answer every `who` at once, and every 200 ms besides.
    let mut ghosts: Vec<Identity> = (0..200).map(|_| Identity::generate()).collect();
    let mut last = Instant::now() - Duration::from_secs(1);
    let forger = Forger::start(hub.addr, &["svc.echo"], move |packet| {
        let asked = first_line(packet).starts_with("who");
        if !asked && last.elapsed() < Duration::from_millis(200) {
            return Vec::new();
        }
        last = Instant::now();
        ghosts
            .iter_mut()
            .map(|g| {
                let id = format!("{:016x}", g.public().fingerprint());
                g.sealed(format!("@ <svc.echo> 0\nprovider id {id} lease_ms 60000\n").into_bytes())
            })
            .collect()
    });
    for i in 0..6 {
        let line = format!("n value {i}");
        let (code, out, err) = call(&hub, &["echo", &line]);
        assert_eq!(
            (code, out.as_str()),
            (Some(0), format!("{line}\n").as_str()),
            "{err}"
        );
    }
    assert!(forger.stop() > 0, "the forger never announced");
}

#[test]
fn six_new_callers_in_a_row_each_hear_of_the_provider_at_once_and_get_their_answer() {
    let _one = serial();
    let hub = HubProcess::start(&[]);
    let (_serve, id) = provider(&hub, &["--lease", "6", "--echo", "echo"]);

    // The provider answers each `who` at once, echoing its nonce.
    let mut asker = subscribed(hub.addr, &["svc.echo"]);
    let nonces: Vec<String> = (1..=6).map(|i| format!("{i:016x}")).collect();
    for nonce in &nonces {
        publish(
            &mut asker,
            format!("@ <svc.echo> 0\nwho nonce {nonce}\n").as_bytes(),
        );
    }
    let heard = drain_until(&mut asker, Instant::now() + WAIT, |got| {
        nonces.iter().all(|n| {
            got.iter()
                .any(|p| p.contains(&format!("nonce {n}")) && p.contains(&id))
        })
    });
    for n in &nonces {
        assert!(
            heard
                .iter()
                .any(|p| p.contains(&format!("provider id {id}"))
                    && p.contains(&format!("nonce {n}"))),
            "no answer to `who nonce {n}`: {heard:?}"
        );
    }

    // Those six questions spent most of the provider's burst: let it refill
    // (10 a second), so each caller below is answered at once.
    thread::sleep(Duration::from_secs(1));

    // So a new caller need not wait for the next announcement: six in a row
    // each get their answer (their times are printed, not asserted: speed is
    // measured, not tested; the nonces above are what failed before).
    let started = Instant::now();
    let mut times = Vec::new();
    for i in 0..6 {
        let line = format!("n value {i}");
        let t = Instant::now();
        let (code, out, err) = call(&hub, &["--timeout", "10", "echo", &line]);
        times.push(t.elapsed());
        assert_eq!(
            (code, out.as_str()),
            (Some(0), format!("{line}\n").as_str()),
            "call {i}: {err}"
        );
    }
    eprintln!(
        "six `colony call` processes took {times:?} ({:?} in all)",
        started.elapsed()
    );
}
