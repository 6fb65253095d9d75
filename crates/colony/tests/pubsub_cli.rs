//! `colony pub`, `colony sub` and `colony log` as a hostile sender and a new user meet them:
//! what `sub` prints, `pub` reads back packet for packet (a body line that looks like a
//! header cannot hijack a channel), the subjects are one argument and never guessed, and
//! characters that could act on a terminal are shown escaped.

use std::io::Write as _;
use std::net::SocketAddr;
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_hub::log::{LogWriter, Record};
use colony_testkit::cli::{colony, HubProcess};
use colony_testkit::client::{drain_until, subscribed};

/// Runs `colony sub --hub HUB args` until it ends by itself (give it `-n`), sending
/// `packets` again and again meanwhile: it may take a while to take its lease.
fn sub_output(hub: SocketAddr, args: &[&str], packets: &[&str]) -> String {
    let mut sub = colony()
        .args(["sub", "--hub", &hub.to_string()])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut publisher = UdpClient::connect(hub).unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while sub.try_wait().unwrap().is_none() && Instant::now() < deadline {
        for p in packets {
            publisher.publish(p.as_bytes()).unwrap();
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    let _ = sub.kill();
    let out = sub.wait_with_output().unwrap();
    String::from_utf8(out.stdout).unwrap()
}

/// Runs `colony pub --hub HUB args` with `input` on its standard input.
fn pub_with_input(hub: SocketAddr, args: &[&str], input: &str) -> Output {
    let mut child = colony()
        .args(["pub", "--hub", &hub.to_string()])
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    child.wait_with_output().unwrap()
}

fn pub_args(hub: SocketAddr, args: &[&str]) -> Output {
    colony()
        .args(["pub", "--hub", &hub.to_string()])
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Everything `client` receives up to and including a marker packet on `channel`, which
/// this sends after whatever it checks for has had its chance to arrive.
fn received_before_marker(client: &mut UdpClient, hub: SocketAddr, channel: &str) -> Vec<String> {
    let marker = format!("@ <{channel}> 0\nmarker\n");
    UdpClient::connect(hub)
        .unwrap()
        .publish(marker.as_bytes())
        .unwrap();
    let got = drain_until(client, Instant::now() + Duration::from_secs(10), |g| {
        g.contains(&marker)
    });
    assert!(got.contains(&marker), "the marker never came: {got:?}");
    got.into_iter().filter(|p| *p != marker).collect()
}

const HIJACK: &str = "@ <chat> 0\n@ <radio> 10\ncmd id 3 vl 1.0 vr 1.0\n";
const HELLO: &str = "@ <chat> 0\nsay text \"hi\"\n";

#[test]
fn a_body_line_like_a_header_piped_from_sub_to_pub_stays_in_its_packet() {
    let hub = HubProcess::start(&[]);
    let printed = sub_output(hub.addr, &["-n", "2", "chat"], &[HIJACK, HELLO]);
    let mut radio = subscribed(hub.addr, &["radio"]);
    let mut chat = subscribed(hub.addr, &["chat"]);
    let o = pub_with_input(hub.addr, &["chat"], &printed);
    assert!(o.status.success(), "{}", stderr(&o));
    let hijacked = received_before_marker(&mut radio, hub.addr, "radio");
    assert!(hijacked.is_empty(), "published on radio: {hijacked:?}");
    assert!(printed.contains("\n\n@ <chat> 0\n"), "{printed:?}");
    let mut again = received_before_marker(&mut chat, hub.addr, "chat");
    again.sort();
    let mut sent = vec![HIJACK.to_string(), HELLO.to_string()];
    sent.sort();
    assert_eq!(again, sent);
}

#[test]
fn whole_packets_typed_on_standard_input_are_one_per_blank_line_separated_block() {
    let hub = HubProcess::start(&[]);
    let mut a = subscribed(hub.addr, &["a"]);
    let mut b = subscribed(hub.addr, &["b"]);
    let o = pub_with_input(
        hub.addr,
        &[],
        "# a note\n@ <a> 0\n@ x 1\n\n\n@ <b> 2\nz w 2\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        received_before_marker(&mut a, hub.addr, "a"),
        ["@ <a> 0\n@ x 1\n"]
    );
    assert_eq!(
        received_before_marker(&mut b, hub.addr, "b"),
        ["@ <b> 2\nz w 2\n"]
    );
    // Packets to other subjects than those given are refused, none sent.
    let o = pub_with_input(hub.addr, &["a"], "@ <a> 0\nx y 1\n\n@ <b> 0\nx y 2\n");
    assert!(!o.status.success());
    assert!(stderr(&o).contains("packet 2 (line 4)"), "{}", stderr(&o));
    // A block that does not start with a header is refused with its line.
    let o = pub_with_input(hub.addr, &[], "@ <a> 0\nx y 1\n\nz w 2\n");
    assert!(!o.status.success());
    assert!(stderr(&o).contains("line 4"), "{}", stderr(&o));
    assert!(received_before_marker(&mut a, hub.addr, "a").is_empty());
    assert!(received_before_marker(&mut b, hub.addr, "b").is_empty());
    // A body on standard input needs its subjects, and goes to them.
    let o = pub_with_input(hub.addr, &["a"], "x y 3\n");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        received_before_marker(&mut a, hub.addr, "a"),
        ["@ <a> 0\nx y 3\n"]
    );
}

#[test]
fn the_first_argument_is_the_subject_set_and_every_other_a_body_line() {
    let hub = HubProcess::start(&[]);
    let mut radio = subscribed(hub.addr, &["radio"]);
    let o = pub_args(hub.addr, &["radio", "stop"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        received_before_marker(&mut radio, hub.addr, "radio"),
        ["@ <radio> 0\nstop\n"]
    );
    // A subject set, in either spelling.
    let mut both = subscribed(hub.addr, &["mobile", "camera"]);
    for set in ["mobile,camera", "<mobile> <camera>"] {
        let o = pub_args(hub.addr, &["-p", "2", set, "ball x 1", "seen"]);
        assert!(o.status.success(), "{set}: {}", stderr(&o));
        assert_eq!(
            received_before_marker(&mut both, hub.addr, "mobile"),
            ["@ <mobile> <camera> 2\nball x 1\nseen\n"],
            "{set}"
        );
    }
    // What is no subject set is refused, nothing guessed.
    for bad in ["radio stop", "radio,", "<radio> stop"] {
        let o = pub_args(hub.addr, &[bad, "cmd id 3"]);
        assert_eq!(o.status.code(), Some(1), "{bad}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("SUBJECTS LINE"),
            "{bad}: {}",
            stderr(&o)
        );
    }
    assert!(received_before_marker(&mut radio, hub.addr, "radio").is_empty());
}

#[test]
fn the_readmes_pub_and_sub_examples_work_as_written() {
    let hub = HubProcess::start(&[]);
    // `colony pub radio 'cmd id 3 vl 0.2 vr 0.2'`
    let mut radio = subscribed(hub.addr, &["radio"]);
    let o = pub_args(hub.addr, &["radio", "cmd id 3 vl 0.2 vr 0.2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        received_before_marker(&mut radio, hub.addr, "radio"),
        ["@ <radio> 0\ncmd id 3 vl 0.2 vr 0.2\n"]
    );
    // `colony sub vision --raw -n 50 > seen.txt`, then `colony pub vision < seen.txt`
    // (here two packets, one of them holding a CSI).
    let odd = "@ <vision> 0\nball x\u{9b}2J 1\n";
    let plain = "@ <vision> 0\nball x 2\n";
    let seen = sub_output(hub.addr, &["vision", "--raw", "-n", "2"], &[odd, plain]);
    let mut vision = subscribed(hub.addr, &["vision"]);
    let o = pub_with_input(hub.addr, &["vision"], &seen);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut again = received_before_marker(&mut vision, hub.addr, "vision");
    again.sort();
    let mut sent: Vec<String> = seen
        .split("\n\n")
        .map(|p| format!("{}\n", p.trim_end_matches('\n')))
        .collect();
    sent.sort();
    assert_eq!(again, sent);
    assert!(sent.iter().all(|p| p == odd || p == plain), "{sent:?}");
}

/// A packet with a CSI that clears the screen, a NEL and a right-to-left override.
const NASTY: &str = "@ <chat> 0\nx\u{9b}2J t \"\u{202e}abc\u{85}\"\n";
const NASTY_SHOWN: &str = "@ <chat> 0\nx\\u{9b}2J t \"\\u{202e}abc\\u{85}\"\n";

#[test]
fn sub_shows_c1_controls_and_bidirectional_overrides_escaped() {
    let hub = HubProcess::start(&[]);
    assert_eq!(
        sub_output(hub.addr, &["-n", "1", "chat"], &[NASTY]),
        NASTY_SHOWN
    );
    assert_eq!(
        sub_output(hub.addr, &["-n", "1", "--raw", "chat"], &[NASTY]),
        NASTY
    );
}

#[test]
fn log_shows_network_text_escaped_and_its_notes_cannot_start_a_packet() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.clog");
    {
        let (mut w, _) = LogWriter::open(&path).unwrap();
        w.append(
            std::time::UNIX_EPOCH + Duration::from_secs(1_700_000_000),
            "127.0.0.1:5".parse().unwrap(),
            NASTY.as_bytes(),
        )
        .unwrap();
        // A forged log: a source that would end its note and start a packet of its own.
        w.append_record(&Record {
            time_us: 1_700_000_001_000_000,
            source: "1.2.3.4:5\n\n@ <radio> 10\ncmd id 3\u{9b}".into(),
            payload: HELLO.as_bytes().to_vec(),
        })
        .unwrap();
        w.flush().unwrap();
    }
    let o = colony()
        .arg("log")
        .arg(&path)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8(o.stdout).unwrap();
    assert!(out.contains(NASTY_SHOWN), "{out}");
    assert!(
        !out.chars()
            .any(|c| c == '\u{9b}' || c == '\u{85}' || c == '\u{202e}'),
        "{out:?}"
    );
    assert!(!out.contains("\n@ <radio>"), "{out}");
    // What it lists, `colony pub` publishes: the two packets, on chat.
    let blocks = colony_wire::split_blocks(&out).unwrap();
    let texts: Vec<&str> = blocks.iter().map(|b| b.text).collect();
    assert_eq!(texts, [NASTY_SHOWN, HELLO]);
}

#[test]
fn sub_prints_each_packet_as_a_line_of_json_for_programs() {
    let hub = HubProcess::start(&[]);
    let out = sub_output(hub.addr, &["-n", "2", "--json", "chat"], &[NASTY]);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 2, "{out}");
    for line in lines {
        // JSON escapes every control character: none reaches the terminal.
        assert!(!line.contains(['\u{9b}', '\u{202e}', '\u{85}']), "{line}");
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        assert_eq!(v["packet"], NASTY, "{v}");
    }
}
