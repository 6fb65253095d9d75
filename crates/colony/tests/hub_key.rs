//! Every command that talks to a hub takes its key (`--key FILE` or
//! `COLONY_KEY`), against a hub that asks every packet to be signed; and one
//! without the key is told why the hub does not answer.

use std::time::{Duration, Instant};

use colony_testkit::cli::{colony, HubProcess};
use colony_testkit::client::drain_until;

fn key_file(dir: &tempfile::TempDir) -> String {
    let key = dir.path().join("colony.key");
    std::fs::write(&key, "a shared key of thirty-two bytes!\n").unwrap();
    key.to_str().unwrap().to_owned()
}

#[test]
fn status_pub_and_sub_take_the_key_and_say_why_without_it() {
    let dir = tempfile::tempdir().unwrap();
    let key = key_file(&dir);
    let hub = HubProcess::start(&["--key", &key, "--auth-all"]);
    let h = hub.addr.to_string();

    // Without the key: no answer, and the error says what may be missing.
    let o = colony()
        .args(["status", "--hub", &h, "--timeout", "1"])
        .env_remove("COLONY_KEY")
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("--key"), "{e}");

    // `pub` without it says so rather than lose the packet.
    let o = colony()
        .args(["pub", "--hub", &h, "radio", "cmd id 3"])
        .env_remove("COLONY_KEY")
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("--key") && e.contains("not sent"), "{e}");

    // With it, by flag and by environment.
    let o = colony()
        .args(["status", "--hub", &h, "--key", &key])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = colony()
        .args(["status", "--hub", &h, "--json"])
        .env("COLONY_KEY", &key)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(report["uptime_ms"].is_u64(), "{report}");

    // A signed subscriber hears a signed publisher.
    let mut sub = colony_client::UdpClient::connect(hub.addr).unwrap();
    sub.set_key(colony_wire::auth::Key::new(std::fs::read(&key).unwrap().as_slice()).unwrap());
    sub.subscribe("radio").unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    while sub.session().lease().is_none() && Instant::now() < deadline {
        let _ = sub.wait(Some(Instant::now() + Duration::from_millis(20)));
        sub.poll(Instant::now()).unwrap();
        while sub.recv_reply().unwrap().is_some() {}
    }
    let o = colony()
        .args([
            "pub",
            "--hub",
            &h,
            "--key",
            &key,
            "radio",
            "cmd id 3 vl 0.2 vr 0.2",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got = drain_until(&mut sub, Instant::now() + Duration::from_secs(5), |g| {
        !g.is_empty()
    });
    assert_eq!(got.len(), 1, "{got:?}");
    assert!(got[0].contains("cmd id 3"), "{got:?}");
}

#[test]
fn a_command_that_cannot_sign_refuses_a_key_rather_than_ignore_it() {
    let dir = tempfile::tempdir().unwrap();
    let key = key_file(&dir);
    let o = colony()
        .args(["tasks", "room", "--hub", "127.0.0.1:9", "--key", &key])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("does not sign"), "{e}");
}
