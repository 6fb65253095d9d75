//! MURDOCH against a process that tries to act for others, on loopback: a
//! hub, a `colony tasks agent`, a `colony tasks announce`, and an attacker
//! that hears everything (it subscribes as anyone may) and forges the
//! award, cancel, done and bids the others would send, sealed with a key of
//! its own or copied from theirs.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use colony_client::UdpClient;
use colony_tasks::protocol::{Bid, Message, Negotiation, Token};
use colony_testkit::cli::{tasks_agent, tasks_announce as announce, HubProcess, Proc};
use colony_testkit::client::subscribed;
use colony_wire::seal::Identity;
use colony_wire::{Packet, Subject};

/// An attacker that hears every announcement for `resources` and every
/// message of the auctions it hears of, with a key of its own.
struct Attacker {
    client: UdpClient,
    identity: Identity,
    heard: Vec<Vec<u8>>,
}

impl Attacker {
    fn new(hub: SocketAddr, resources: &[&str]) -> Attacker {
        let mut subjects = resources.to_vec();
        subjects.push("idle");
        Attacker {
            client: subscribed(hub, &subjects),
            identity: Identity::generate(),
            heard: Vec::new(),
        }
    }

    /// Listens until `until` says it has what it waits for, or the wait ends.
    fn listen(&mut self, within: Duration, mut until: impl FnMut(&[Vec<u8>]) -> bool) -> bool {
        let end = Instant::now() + within;
        while Instant::now() < end {
            let _ = self
                .client
                .wait(Some(Instant::now() + Duration::from_millis(20)));
            self.client.poll(Instant::now()).unwrap();
            while let Some(p) = self.client.recv().unwrap() {
                let bytes = p.as_str().as_bytes().to_vec();
                // Follow every auction heard of onto its subject.
                if let Ok(Message::Announce(ann)) = Message::decode(&p) {
                    self.client.subscribe(ann.negotiation.as_str()).unwrap();
                }
                self.heard.push(bytes);
            }
            if until(&self.heard) {
                return true;
            }
        }
        false
    }

    /// The first negotiation message heard with this label, and its subject.
    fn first(&self, label: &str) -> Option<(Subject, Negotiation, Vec<u8>)> {
        self.heard
            .iter()
            .find_map(|b| match Message::decode(&Packet::parse(b).ok()?).ok()? {
                Message::Negotiation { subject, message } if message.label() == label => {
                    Some((subject, message, b.clone()))
                }
                _ => None,
            })
    }

    /// Publishes `m` on `subject`, sealed with the attacker's own key.
    fn forge(&mut self, subject: &Subject, m: &Negotiation) {
        let bytes = self.identity.sealed(m.encode(subject).unwrap());
        self.client.publish(&bytes).unwrap();
    }

    /// Sends a packet someone else sealed again.
    fn replay(&mut self, bytes: &[u8]) {
        self.client.publish(bytes).unwrap();
    }
}

fn has(label: &'static str) -> impl FnMut(&[Vec<u8>]) -> bool {
    move |heard| {
        heard.iter().any(|b| {
            Packet::parse(b)
                .ok()
                .and_then(|p| Message::decode(&p).ok())
                .is_some_and(|m| matches!(m, Message::Negotiation { message, .. } if message.label() == label))
        })
    }
}

#[test]
fn forged_done_cancel_and_award_change_nothing_and_a_rogue_bid_does_not_win() {
    let hub = HubProcess::start(&[]);
    let h = hub.addr.to_string();
    let mut attacker = Attacker::new(hub.addr, &["gripper", "camera"]);
    let r1 = tasks_agent(&h, "r1", "mobile,gripper", &[]);
    let _r2 = tasks_agent(&h, "r2", "mobile,camera", &[]);

    // A 30 s task: the attacker says it is done, and cancels it on the
    // announcer's behalf, as soon as r1 has it.
    let mut long = announce(&h, "patrol", "gripper", "30");
    assert!(
        attacker.listen(Duration::from_secs(30), has("ack")),
        "the attacker never heard the ack:\n{}",
        long.text()
    );
    let (subject, award, _) = attacker.first("award").expect("the award was heard");
    let task = award.task();
    let r1_token = Token::new("r1").unwrap();
    for _ in 0..5 {
        attacker.forge(
            &subject,
            &Negotiation::Done {
                task,
                bidder: r1_token.clone(),
            },
        );
        attacker.forge(
            &subject,
            &Negotiation::Cancel {
                task,
                reason: "forged".into(),
            },
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    // A copy of r1's own ack, and of the announcer's award, sent again.
    let (_, _, ack) = attacker.first("ack").unwrap();
    let (_, _, award_bytes) = attacker.first("award").unwrap();
    attacker.replay(&ack);
    attacker.replay(&award_bytes);
    // Give forgeries every chance to be acted on; the task still runs.
    attacker.listen(Duration::from_secs(3), |_| false);
    assert!(
        !long.text().contains("done by"),
        "the announcer took a forged done:\n{}",
        long.text()
    );
    assert!(
        !r1.text().contains("stops task"),
        "r1 took a forged cancel:\n{}",
        r1.text()
    );
    assert!(r1.text().contains("starts task"), "{}", r1.text());
    long.kill();

    // A rogue bids a score no metric can reach, under its own name and
    // under r2's: r2 still wins the next task.
    let mut look = announce(&h, "look", "camera", "0.5");
    assert!(attacker.listen(Duration::from_secs(30), |heard| {
        heard
            .iter()
            .filter(|b| {
                Packet::parse(b)
                    .ok()
                    .and_then(|p| Message::decode(&p).ok())
                    .is_some_and(|m| matches!(m, Message::Announce(a) if a.spec.name == "look"))
            })
            .count()
            > 0
    }));
    let ann = attacker
        .heard
        .iter()
        .rev()
        .find_map(|b| match Message::decode(&Packet::parse(b).ok()?).ok()? {
            Message::Announce(a) if a.spec.name == "look" => Some(a),
            _ => None,
        })
        .unwrap();
    for bidder in ["rogue", "r2"] {
        attacker.forge(
            &ann.negotiation,
            &Negotiation::Bid(Bid {
                task: ann.id,
                bidder: Token::new(bidder).unwrap(),
                score: -1e12,
            }),
        );
    }
    assert_eq!(
        look.exit(Duration::from_secs(60)),
        Some(0),
        "{}",
        look.text()
    );
    assert!(look.text().contains("done by r2"), "{}", look.text());
    assert!(!look.text().contains("rogue"), "{}", look.text());
}

#[test]
fn agents_and_announcers_take_the_hubs_key() {
    let dir = tempfile::tempdir().unwrap();
    let key = dir.path().join("colony.key");
    std::fs::write(&key, "a shared key of thirty-two bytes!\n").unwrap();
    let key = key.to_str().unwrap();
    let hub = HubProcess::start(&["--key", key, "--auth-all"]);
    let h = hub.addr.to_string();
    let r1 = Proc::start(&[
        "tasks",
        "agent",
        "--hub",
        &h,
        "--key",
        key,
        "--name",
        "r1",
        "--resources",
        "mobile",
    ]);
    assert!(r1.when("joins with", Duration::from_secs(20)).is_some());
    let mut t = Proc::start(&[
        "tasks",
        "announce",
        "--hub",
        &h,
        "--key",
        key,
        "--name",
        "look",
        "--needs",
        "mobile",
        "--length",
        "0.2",
        "--deadline",
        "60",
    ]);
    assert_eq!(t.exit(Duration::from_secs(60)), Some(0), "{}", t.text());
    assert!(t.text().contains("done by r1"), "{}", t.text());
}
