//! Every message written and read back; malformed ones refused with the line
//! and field at fault; arbitrary bytes never panic the decoder.

use std::time::Duration;

use colony_proto::murdoch::{
    negotiation_subject, Announcement, Bid, Message, Negotiation, Param, ParamValue, ResourceSet,
    RobotMode, RobotReport, TaskSpec, Token, MAX_MAGNITUDE,
};
use colony_proto::DecodeError;
use colony_wire::Packet;
use proptest::prelude::*;

fn token(s: &str) -> Token {
    Token::new(s).unwrap()
}

fn sentry() -> Announcement {
    Announcement {
        spec: TaskSpec::new("sentry-duty", "camera laser mobile".parse().unwrap())
            .length(120.0)
            .param("x", 350.0)
            .text_param("color", "red \"bright\"")
            .metric("distance", 1.0)
            .metric("battery", 200.0),
        id: 17,
        negotiation: negotiation_subject(&token("user"), 17, 1),
        deadline: Duration::from_millis(200),
        announcer: token("user"),
    }
}

#[test]
fn an_announcement_is_addressed_to_its_resources_and_idle() {
    let bytes = sentry().encode().unwrap();
    let text = String::from_utf8(bytes.clone()).unwrap();
    assert!(
        text.starts_with("@ <camera> <laser> <mobile> <idle> 0\ntask name sentry-duty id 17 negotiation murdoch.user.17.1 deadline_ms 200 length_s 120.0 announcer user\n"),
        "{text}"
    );
    assert!(
        text.contains("param name color value \"red \\\"bright\\\"\"\n"),
        "{text}"
    );
    assert!(
        text.contains("metric name battery weight 200.0\n"),
        "{text}"
    );
    assert_eq!(
        Message::decode_bytes(&bytes).unwrap(),
        Message::Announce(sentry())
    );
}

#[test]
fn the_documented_examples_read() {
    let docs = [
        "@ <murdoch.user.17.1> 0\nbid task 17 bidder r2 score 182.5\n",
        "@ <murdoch.user.17.1> 0\naward task 17 winner r2 score 182.5 bids 3\n",
        "@ <murdoch.user.17.1> 0\nack task 17 bidder r2\n",
        "@ <murdoch.user.17.1> 0\ndecline task 17 bidder r5\n",
        "@ <murdoch.user.17.1> 0\nrenew task 17 by r2 progress 0.4\n",
        "@ <murdoch.user.17.1> 0\nrenew task 17 by user\n",
        "@ <murdoch.user.17.1> 0\ndone task 17 bidder r2\n",
        "@ <murdoch.user.17.1> 0\nabandon task 17 bidder r2 reason \"announcer user silent for 3.0 s\"\n",
        "@ <murdoch.user.17.1> 0\ncancel task 17 reason \"presumed failed: no renewal for 3.0 s\"\n",
        "@ <murdoch.user.17.2> 0\nunachievable task 17 name sentry-duty reason \"no robot with {camera laser mobile} is available\"\n",
        "@ <camera> <laser> <mobile> <idle> 0\ntask name sentry-duty id 17 negotiation murdoch.user.17.1 deadline_ms 200 length_s 120 announcer user\nparam name x value 350.0\nparam name color value \"red\"\nmetric name distance weight 1.0\nmetric name battery weight 200.0\n",
    ];
    for text in docs {
        let m = Message::decode_bytes(text.as_bytes()).unwrap_or_else(|e| panic!("{text}: {e}"));
        // Writing it again gives the same text (numbers aside, which print canonically).
        let again = m.encode().unwrap();
        assert_eq!(Message::decode_bytes(&again).unwrap(), m);
    }
    let m = Message::decode_bytes(docs[0].as_bytes()).unwrap();
    assert_eq!(
        m,
        Message::Negotiation {
            subject: negotiation_subject(&token("user"), 17, 1),
            message: Negotiation::Bid(Bid {
                task: 17,
                bidder: token("r2"),
                score: 182.5
            })
        }
    );
}

fn error_of(text: &str) -> String {
    match Message::decode_bytes(text.as_bytes()) {
        Ok(m) => panic!("{text:?} should be refused, read as {m:?}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn malformed_messages_name_their_line_and_field() {
    let cases = [
        (
            "@ <murdoch.u.1.1> 0\nbid task 1 bidder r1 score lots\n",
            ["line 2", "`score`", "`lots` is not a number"],
        ),
        (
            "@ <murdoch.u.1.1> 0\nbid task 1 score 3\n",
            ["line 2", "`bidder`", "missing"],
        ),
        (
            "@ <murdoch.u.1.1> 0\nbid task -4 bidder r1 score 3\n",
            ["line 2", "`task`", "-4 is not a task number"],
        ),
        (
            "@ <murdoch.u.1.1> 0\nbid task 1 bidder \"r 1\" score 3\n",
            ["line 2", "`bidder`", "not a token"],
        ),
        (
            "@ <murdoch.u.1.1> 0\nbid task 1 bidder r1 score inf\n",
            ["line 2", "`score`", "not a finite number"],
        ),
        (
            "@ <murdoch.u.1.1> 0\nrenew task 1 by r1 progress 1.5\n",
            ["line 2", "`progress`", "not between 0 and 1"],
        ),
        (
            "@ <murdoch.u.1.1> 0\nhello task 1\n",
            ["line 2", "unknown message `hello`", "bid"],
        ),
        (
            "@ <camera> 0\nbid task 1 bidder r1 score 3\n",
            ["line 1", "one `murdoch.` subject", "<camera>"],
        ),
        (
            "@ <camera> <idle> 0\ntask name look id 1 negotiation murdoch.u.1.1 deadline_ms 0 length_s 3 announcer u\n",
            ["line 2", "`deadline_ms`", "not between 1 and"],
        ),
        (
            "@ <camera> 0\ntask name look id 1 negotiation murdoch.u.1.1 deadline_ms 100 length_s 3 announcer u\n",
            ["line 1", "<idle>", "as well as its resources"],
        ),
        (
            "@ <camera> <idle> 0\ntask name look id 1 negotiation camera deadline_ms 100 length_s 3 announcer u\n",
            ["line 2", "`negotiation`", "murdoch."],
        ),
        (
            "@ <camera> <idle> 0\ntask name look id 1 negotiation murdoch.u.1.1 deadline_ms 100 length_s 3 announcer u\nmetric name distance weight x\n",
            ["line 3", "`weight`", "not a number"],
        ),
        (
            "@ <camera> <idle> 0\ntask name look id 1 negotiation murdoch.u.1.1 deadline_ms 100 length_s 3 announcer u\nparam name x value 1\nparam name x value 2\n",
            ["line 4", "`name`", "appears twice"],
        ),
        (
            "@ <camera> <idle> 0\ntask name look id 1 negotiation murdoch.u.1.1 deadline_ms 100 length_s -3 announcer u\n",
            ["line 2", "`length_s`", "not between 0"],
        ),
        (
            "@ <camera> <idle> 0\ntask name look id 1 negotiation murdoch.u.1.1 deadline_ms 100 length_s 3 announcer u\nwhat x 1\n",
            ["line 3", "`what` lines do not belong", "param"],
        ),
        ("@ <murdoch.u.1.1> 0\n", ["no message", "", ""]),
        ("@ <murdoch.u.1.1> 0\nbid task 1 task 2\n", ["line 2", "duplicate name `task`", ""]),
    ];
    for (text, wants) in cases {
        let e = error_of(text);
        for want in wants {
            assert!(e.contains(want), "{text:?}: `{e}` does not say {want:?}");
        }
    }
}

#[test]
fn a_spec_that_no_reader_would_accept_is_refused_before_it_is_sent() {
    let bad = [
        TaskSpec::new("has space", ResourceSet::new()),
        TaskSpec::new("t", ResourceSet::new()).length(f64::NAN),
        TaskSpec::new("t", ResourceSet::new()).param("x", f64::INFINITY),
        TaskSpec::new("t", ResourceSet::new())
            .metric("m", 1.0)
            .metric("m", 2.0),
        TaskSpec::new("t", ResourceSet::new()).metric("m", 1e300),
    ];
    for spec in bad {
        assert!(spec.validate().is_err(), "{spec:?}");
    }
    let too_many: ResourceSet = (0..16)
        .map(|i| format!("r{i}"))
        .collect::<Vec<_>>()
        .join(" ")
        .parse()
        .unwrap();
    let e = TaskSpec::new("t", too_many)
        .validate()
        .unwrap_err()
        .to_string();
    assert!(e.contains("16 resources"), "{e}");
    assert!("idle".parse::<ResourceSet>().is_err());
    assert!("murdoch.x".parse::<ResourceSet>().is_err());
}

fn arb_token() -> impl Strategy<Value = Token> {
    "[A-Za-z0-9_-]{1,24}".prop_map(|s| Token::new(&s).unwrap())
}

fn arb_name() -> impl Strategy<Value = String> {
    "[A-Za-z0-9_./:-]{1,64}"
}

fn arb_number() -> impl Strategy<Value = f64> {
    prop_oneof![
        -MAX_MAGNITUDE..MAX_MAGNITUDE,
        (-1000i64..1000).prop_map(|v| v as f64),
        Just(0.0),
        Just(1e-300),
    ]
}

fn arb_text() -> impl Strategy<Value = String> {
    prop_oneof![
        "[ -~]{0,40}",
        any::<String>().prop_map(|s| s
            .chars()
            .filter(|c| !c.is_control() || matches!(c, '\n' | '\t' | '\r'))
            .take(100)
            .collect()),
    ]
}

fn arb_spec() -> impl Strategy<Value = TaskSpec> {
    (
        arb_name(),
        proptest::collection::btree_set("[a-z][a-z0-9-]{0,12}", 0..6),
        0.0..1e5f64,
        proptest::collection::btree_map(
            arb_name(),
            prop_oneof![
                arb_number().prop_map(ParamValue::Number),
                arb_text().prop_map(ParamValue::Text)
            ],
            0..5,
        ),
        proptest::collection::btree_map(arb_name(), arb_number(), 0..5),
    )
        .prop_filter_map("valid resources", |(name, res, length, params, metrics)| {
            let resources = ResourceSet::from_names(res).ok()?;
            let mut spec = TaskSpec::new(&name, resources).length(length);
            for (n, v) in params {
                spec.params.push(Param { name: n, value: v });
            }
            for (n, w) in metrics {
                spec = spec.metric(&n, w);
            }
            Some(spec)
        })
}

fn arb_negotiation() -> impl Strategy<Value = Negotiation> {
    let task = any::<u64>().prop_map(|t| t >> 1);
    prop_oneof![
        (task.clone(), arb_token(), arb_number()).prop_map(|(task, bidder, score)| {
            Negotiation::Bid(Bid {
                task,
                bidder,
                score,
            })
        }),
        (task.clone(), arb_token(), arb_number(), any::<u32>()).prop_map(
            |(task, winner, score, bids)| Negotiation::Award {
                task,
                winner,
                score,
                bids
            }
        ),
        (task.clone(), arb_token()).prop_map(|(task, bidder)| Negotiation::Ack { task, bidder }),
        (task.clone(), arb_token())
            .prop_map(|(task, bidder)| Negotiation::Decline { task, bidder }),
        (
            task.clone(),
            arb_token(),
            proptest::option::of(0.0..=1.0f64)
        )
            .prop_map(|(task, by, progress)| Negotiation::Renew { task, by, progress }),
        (task.clone(), arb_token()).prop_map(|(task, bidder)| Negotiation::Done { task, bidder }),
        (task.clone(), arb_token(), arb_text()).prop_map(|(task, bidder, reason)| {
            Negotiation::Abandon {
                task,
                bidder,
                reason,
            }
        }),
        (task.clone(), arb_text()).prop_map(|(task, reason)| Negotiation::Cancel { task, reason }),
        (task, arb_name(), arb_text()).prop_map(|(task, name, reason)| Negotiation::Unachievable {
            task,
            name,
            reason
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn announcements_round_trip(spec in arb_spec(), id in any::<u64>().prop_map(|t| t >> 1),
                                who in arb_token(), ms in 1u64..600_000) {
        let ann = Announcement {
            negotiation: negotiation_subject(&who, id, 1),
            spec,
            id,
            deadline: Duration::from_millis(ms),
            announcer: who,
        };
        let bytes = ann.encode().unwrap();
        prop_assert_eq!(Message::decode_bytes(&bytes).unwrap(), Message::Announce(ann));
    }

    #[test]
    fn negotiation_messages_round_trip(m in arb_negotiation(), who in arb_token(),
                                       task in any::<u64>(), attempt in any::<u32>()) {
        let subject = negotiation_subject(&who, task, attempt);
        let bytes = m.encode(&subject).unwrap();
        let back = Message::decode_bytes(&bytes).unwrap();
        prop_assert_eq!(back, Message::Negotiation { subject, message: m });
    }

    #[test]
    fn robot_reports_round_trip(name in arb_token(), mode in 0..3u8, battery in 0.0..=1.0f64,
                                res in proptest::collection::btree_set("[a-z][a-z0-9-]{0,12}", 0..6),
                                task in proptest::option::of((any::<u64>().prop_map(|t| t >> 1), arb_name()))) {
        let report = RobotReport {
            name,
            mode: [RobotMode::Idle, RobotMode::Working, RobotMode::Charging][usize::from(mode)],
            battery,
            resources: ResourceSet::from_names(res).unwrap(),
            task,
        };
        let bytes = report.encode().unwrap();
        prop_assert_eq!(Message::decode_bytes(&bytes).unwrap(), Message::Robot(report));
    }

    #[test]
    fn arbitrary_bytes_never_panic_the_decoder(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = Message::decode_bytes(&bytes);
    }

    #[test]
    fn packet_shaped_garbage_never_panics_and_errors_say_where(
        header in prop_oneof![Just("@ <murdoch.u.1.1> 0\n"), Just("@ <camera> <idle> 0\n"), Just("@ <idle> 0\n")],
        label in prop_oneof![Just("task"), Just("bid"), Just("award"), Just("renew"), Just("param"), Just("metric"), Just("x")],
        fields in proptest::collection::vec(
            (prop_oneof![Just("task"), Just("bidder"), Just("score"), Just("name"), Just("id"),
                         Just("negotiation"), Just("deadline_ms"), Just("length_s"), Just("announcer"),
                         Just("value"), Just("weight"), Just("by"), Just("progress"), Just("winner"), Just("bids")],
             prop_oneof![Just("1".to_string()), Just("-1".into()), Just("nan".into()), Just("1e400".into()),
                         Just("murdoch.u.1.1".into()), Just("\"q\"".into()), Just("(a 1)".into()),
                         "[a-z0-9.]{1,8}"]),
            0..8),
        extra in proptest::collection::vec("(param|metric|task) name [a-z]{1,3} (value|weight) [0-9a-z]{1,3}", 0..3),
    ) {
        let mut text = format!("{header}{label}");
        let mut seen = std::collections::BTreeSet::new();
        for (n, v) in fields {
            if seen.insert(n) {
                text.push_str(&format!(" {n} {v}"));
            }
        }
        text.push('\n');
        for l in extra {
            text.push_str(&l);
            text.push('\n');
        }
        match Message::decode_bytes(text.as_bytes()) {
            Ok(m) => {
                let again = m.encode().unwrap();
                prop_assert_eq!(Message::decode_bytes(&again).unwrap(), m);
            }
            Err(DecodeError::Empty) => {}
            Err(e) => prop_assert!(e.to_string().contains("line "), "{}", e),
        }
        prop_assert!(Packet::parse(text.as_bytes()).is_ok() || Message::decode_bytes(text.as_bytes()).is_err());
    }
}
