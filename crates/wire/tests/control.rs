//! Hub control requests and replies: parse, write, round-trip, errors.

use colony_wire::{
    ChannelInfo, ClientInfo, ControlError, Cookie, FieldError, FieldErrorKind, Packet, Priority,
    Reply, Request, StatusReport, Subject, HUB_SUBJECT, MAX_PACKET,
};

fn requests(text: &str) -> Result<Vec<Request>, ControlError> {
    let p = Packet::parse(text.as_bytes()).expect("the control packet parses");
    Request::parse_all(&p)
}

fn subject(name: &str) -> Subject {
    Subject::new(name).unwrap()
}

#[test]
fn every_request_kind_is_read_in_order() {
    let got = requests(
        "@ <hub> 0\n\
         subscribe ch vision_out\n\
         unsubscribe ch radio\n\
         \n\
         unsubscribe_all\n\
         status\n\
         min_priority value 5\n\
         min_priority value -2147483648\n",
    )
    .unwrap();
    assert_eq!(
        got,
        [
            Request::Subscribe(subject("vision_out")),
            Request::Unsubscribe(subject("radio")),
            Request::UnsubscribeAll,
            Request::Status,
            Request::MinPriority(Priority(5)),
            Request::MinPriority(Priority(i32::MIN)),
        ]
    );
}

#[test]
fn subscribe_accepts_a_quoted_or_bracketed_channel() {
    let got = requests("@ <hub> 0\nsubscribe ch \"task\"\nsubscribe ch <robot:7>\n").unwrap();
    assert_eq!(
        got,
        [
            Request::Subscribe(subject("task")),
            Request::Subscribe(subject("robot:7"))
        ]
    );
}

#[test]
fn empty_control_packet_holds_no_requests() {
    assert_eq!(requests("@ <hub> 0\n").unwrap(), []);
}

#[test]
fn requests_write_the_documented_text() {
    let all = [
        Request::Subscribe(subject("vision_out")),
        Request::Unsubscribe(subject("radio")),
        Request::UnsubscribeAll,
        Request::Status,
        Request::MinPriority(Priority(-5)),
        Request::NoLocal,
        Request::About("bridge \"lab\"".into()),
        Request::Tap,
        Request::Batch(65_000),
    ];
    let bytes = Request::to_packet(&all);
    assert_eq!(
        std::str::from_utf8(&bytes).unwrap(),
        "@ <hub> 0\n\
         subscribe ch vision_out\n\
         unsubscribe ch radio\n\
         unsubscribe_all\n\
         status\n\
         min_priority value -5\n\
         no_local\n\
         about text \"bridge \\\"lab\\\"\"\n\
         tap\n\
         batch bytes 65000\n"
    );
    let p = Packet::parse(&bytes).unwrap();
    assert!(Request::is_control(&p));
    assert_eq!(Request::parse_all(&p).unwrap(), all);
}

#[test]
fn requests_round_trip_through_a_packet() {
    let all = vec![
        Request::MinPriority(Priority(i32::MAX)),
        Request::Subscribe(subject("a/b.c:d-e_f")),
        Request::Status,
        Request::Subscribe(subject("x")),
        Request::UnsubscribeAll,
    ];
    let bytes = Request::to_packet(&all);
    assert_eq!(
        Request::parse_all(&Packet::parse(&bytes).unwrap()).unwrap(),
        all
    );
    assert_eq!(Request::to_packet(&[]), b"@ <hub> 0\n");
}

#[test]
fn a_batch_size_is_kept_within_one_datagram_and_never_negative() {
    let req = |text: &str| requests(&format!("@ <hub> 0\n{text}\n"));
    assert_eq!(req("batch bytes 0").unwrap(), [Request::Batch(0)]);
    assert_eq!(req("batch bytes 1400").unwrap(), [Request::Batch(1400)]);
    assert_eq!(
        req("batch bytes 9223372036854775807").unwrap(),
        [Request::Batch(colony_wire::MAX_PACKET)]
    );
    let e = req("batch bytes -1").unwrap_err().to_string();
    assert!(e.contains("-1"), "{e}");
    assert!(req("batch bytes 1e9").is_err());
    assert!(req("batch").is_err());
}

#[test]
fn cookies_are_sixteen_hex_digits_and_round_trip() {
    let all = vec![
        Request::Cookie(Cookie(0x0123_4567_89ab_cdef)),
        Request::Subscribe(subject("x")),
    ];
    let bytes = Request::to_packet(&all);
    assert!(bytes.starts_with(b"@ <hub> 0\ncookie v 0123456789abcdef\n"));
    assert_eq!(
        Request::parse_all(&Packet::parse(&bytes).unwrap()).unwrap(),
        all
    );
    for bad in [
        "123",
        "0123456789ABCDEF",
        "0123456789abcdefa",
        "g123456789abcdef",
        "\"\"",
    ] {
        let text = format!("@ <hub> 0\ncookie v {bad}\n");
        assert_eq!(
            requests(&text).unwrap_err(),
            ControlError::BadCookie { line: 2 },
            "{bad}"
        );
    }
    let reply = Reply::cookie_packet(Cookie(u64::MAX));
    assert_eq!(reply.len(), 36);
    assert_eq!(
        Reply::parse(&Packet::parse(&reply).unwrap()),
        Some(Ok(Reply::Cookie(Cookie(u64::MAX))))
    );
    // The smallest request that asks for a cookie is never shorter than the answer.
    let ask = Request::to_packet(&[Request::Cookie(Cookie::NONE), Request::Status]);
    assert!(ask.len() >= reply.len());
}

#[test]
fn unknown_request_is_rejected_with_its_label_and_line() {
    let e = requests("@ <hub> 0\nstatus\n\nsubscribe_all ch x\n").unwrap_err();
    assert_eq!(
        e,
        ControlError::Unknown {
            label: "subscribe_all".into(),
            line: 4
        }
    );
    assert_eq!(
        e.to_string(),
        "line 4: unknown request `subscribe_all` (known: subscribe, unsubscribe, unsubscribe_all, status, min_priority, cookie, no_local, about, tap, batch)"
    );
}

#[test]
fn subscribing_to_hub_is_rejected() {
    let e = requests("@ <hub> 0\nsubscribe ch hub\n").unwrap_err();
    assert_eq!(
        e,
        ControlError::BadSubject {
            name: "hub".into(),
            line: 2
        }
    );
    assert_eq!(e.to_string(), "line 2: `hub` cannot be subscribed to");
    let e = requests("@ <hub> 0\nunsubscribe ch <hub>\n").unwrap_err();
    assert_eq!(
        e,
        ControlError::BadSubject {
            name: "<hub>".into(),
            line: 2
        }
    );
}

#[test]
fn subscribing_to_a_name_that_is_no_subject_is_rejected() {
    let e = requests("@ <hub> 0\nstatus\nsubscribe ch \"two words\"\n").unwrap_err();
    assert_eq!(
        e,
        ControlError::BadSubject {
            name: "two words".into(),
            line: 3
        }
    );
    let e = requests("@ <hub> 0\nsubscribe ch \"\"\n").unwrap_err();
    assert!(matches!(e, ControlError::BadSubject { .. }));
}

#[test]
fn subscribe_without_ch_is_a_missing_field() {
    let e = requests("@ <hub> 0\nsubscribe channel x\n").unwrap_err();
    assert_eq!(
        e,
        ControlError::Field(FieldError {
            label: "subscribe".into(),
            field: "ch".into(),
            line: 2,
            column: 1,
            kind: FieldErrorKind::Missing,
        })
    );
    assert_eq!(
        e.to_string(),
        "line 2, column 1: `subscribe` field `ch`: missing"
    );
    let e = requests("@ <hub> 0\n  unsubscribe\n").unwrap_err();
    assert!(matches!(
        e,
        ControlError::Field(FieldError {
            kind: FieldErrorKind::Missing,
            line: 2,
            column: 3,
            ..
        })
    ));
}

#[test]
fn subscribe_with_a_group_for_ch_is_rejected() {
    let e = requests("@ <hub> 0\nsubscribe ch (a 1)\n").unwrap_err();
    assert!(matches!(
        e,
        ControlError::Field(FieldError {
            kind: FieldErrorKind::NotAString,
            column: 14,
            ..
        })
    ));
}

#[test]
fn min_priority_that_is_not_an_integer_names_its_column() {
    let e = requests("@ <hub> 0\nmin_priority value high\n").unwrap_err();
    assert_eq!(
        e,
        ControlError::Field(FieldError {
            label: "min_priority".into(),
            field: "value".into(),
            line: 2,
            column: 20,
            kind: FieldErrorKind::NotAnInteger("high".into()),
        })
    );
    let e = requests("@ <hub> 0\nmin_priority level 3\n").unwrap_err();
    assert!(matches!(
        e,
        ControlError::Field(FieldError {
            kind: FieldErrorKind::Missing,
            ..
        })
    ));
}

#[test]
fn min_priority_beyond_32_bits_names_its_value_and_column() {
    let e = requests("@ <hub> 0\n\nmin_priority  value +2147483648\n").unwrap_err();
    assert_eq!(
        e,
        ControlError::Field(FieldError {
            label: "min_priority".into(),
            field: "value".into(),
            line: 3,
            column: 21,
            kind: FieldErrorKind::NotAnInteger("+2147483648".into()),
        })
    );
    let e = requests("@ <hub> 0\nmin_priority value -2147483649\n").unwrap_err();
    assert!(
        matches!(e, ControlError::Field(FieldError { column: 20, .. })),
        "{e:?}"
    );
}

#[test]
fn packet_to_other_subjects_is_not_control() {
    for text in [
        "@ <vision_out> 0\nstatus\n",
        "@ <hub> <vision_out> 0\nstatus\n",
        "@ <vision_out> <hub> 0\nstatus\n",
    ] {
        let p = Packet::parse(text.as_bytes()).unwrap();
        assert!(!Request::is_control(&p), "{text}");
        assert_eq!(Request::parse_all(&p), Err(ControlError::NotControl));
        assert!(Reply::parse(&p).is_none());
    }
    assert_eq!(
        ControlError::NotControl.to_string(),
        "a control packet must name `<hub>` alone"
    );
    assert_eq!(HUB_SUBJECT, "hub");
}

#[test]
fn control_packet_priority_does_not_matter() {
    assert_eq!(requests("@ <hub> 99\nstatus\n").unwrap(), [Request::Status]);
}

// ---------------------------------------------------------------- replies

#[test]
fn lease_reply_round_trips() {
    let bytes = Reply::lease_packet(5_000);
    assert_eq!(bytes, b"@ <hub> 0\nlease ms 5000\n");
    let p = Packet::parse(&bytes).unwrap();
    assert_eq!(Reply::parse(&p), Some(Ok(Reply::Lease { ms: 5_000 })));
}

#[test]
fn lease_reply_with_a_bad_number_is_an_error() {
    let p = Packet::parse(b"@ <hub> 0\nlease ms soon\n").unwrap();
    match Reply::parse(&p) {
        Some(Err(ControlError::Field(e))) => {
            assert_eq!(e.kind, FieldErrorKind::NotAnInteger("soon".into()));
            assert_eq!((e.line, e.column), (2, 10));
        }
        other => panic!("expected a field error, got {other:?}"),
    }
}

#[test]
fn control_packet_that_is_no_reply_gives_none() {
    for text in ["@ <hub> 0\n", "@ <hub> 0\nsubscribe ch x\n"] {
        let p = Packet::parse(text.as_bytes()).unwrap();
        assert!(Reply::parse(&p).is_none(), "{text}");
    }
}

fn sample_report() -> StatusReport {
    StatusReport {
        uptime_ms: 123_456,
        lease_ms: 5_000,
        min_priority: Priority(-2),
        client_count: 2,
        clients: vec![
            ClientInfo {
                addr: "127.0.0.1:40001".into(),
                idle_ms: 12,
                subscriptions: vec![("vision_out".into(), 4_900), ("radio".into(), 10)],
                about: "bridge site \"lab\"".into(),
                tap: false,
                batch: 0,
            },
            ClientInfo {
                addr: "[::1]:40002".into(),
                idle_ms: 0,
                subscriptions: vec![],
                about: String::new(),
                tap: true,
                batch: 1472,
            },
        ],
        channels: vec![
            ChannelInfo {
                subjects: "vision_out".into(),
                packets: 1_000,
                bytes: 450_000,
            },
            ChannelInfo {
                subjects: "task robot:7".into(),
                packets: 3,
                bytes: 99,
            },
        ],
        drops: vec![
            ("malformed".into(), 4),
            ("below \"min\" priority\\".into(), 7),
        ],
        truncated: false,
    }
}

#[test]
fn status_report_writes_one_line_per_item() {
    let bytes = sample_report().to_packet();
    assert_eq!(
        std::str::from_utf8(&bytes).unwrap(),
        "@ <hub> 0\n\
         status uptime_ms 123456 lease_ms 5000 min_priority -2 clients 2 truncated 0\n\
         drop reason \"malformed\" count 4\n\
         drop reason \"below \\\"min\\\" priority\\\\\" count 7\n\
         client addr \"127.0.0.1:40001\" idle_ms 12 subs (vision_out 4900 radio 10) about \"bridge site \\\"lab\\\"\"\n\
         client addr \"[::1]:40002\" idle_ms 0 subs () tap 1 batch 1472\n\
         channel ch \"vision_out\" packets 1000 bytes 450000\n\
         channel ch \"task robot:7\" packets 3 bytes 99\n"
    );
}

#[test]
fn status_report_round_trips() {
    let report = sample_report();
    let bytes = report.to_packet();
    let p = Packet::parse(&bytes).unwrap();
    assert_eq!(StatusReport::from_packet(&p).unwrap(), report);
    assert_eq!(Reply::parse(&p), Some(Ok(Reply::Status(report))));
}

#[test]
fn empty_status_report_round_trips() {
    let report = StatusReport::default();
    let bytes = report.to_packet();
    let p = Packet::parse(&bytes).unwrap();
    assert_eq!(StatusReport::from_packet(&p).unwrap(), report);
}

fn huge_report(clients: usize) -> StatusReport {
    StatusReport {
        uptime_ms: 1,
        lease_ms: 5_000,
        min_priority: Priority(0),
        client_count: clients as u64,
        clients: (0..clients)
            .map(|i| ClientInfo {
                addr: format!("10.0.{}.{}:{}", i / 256, i % 256, 40_000 + i),
                idle_ms: i as u64,
                subscriptions: (0..4).map(|s| (format!("channel_{s}"), 5_000)).collect(),
                about: String::new(),
                tap: i % 2 == 0,
                batch: i % 3 * 700,
            })
            .collect(),
        channels: vec![ChannelInfo {
            subjects: "vision_out".into(),
            packets: 1,
            bytes: 2,
        }],
        drops: vec![("malformed".into(), 1)],
        truncated: false,
    }
}

#[test]
fn status_report_too_large_for_a_datagram_is_cut_and_marked() {
    let report = huge_report(2_000);
    let bytes = report.to_packet();
    assert!(bytes.len() <= MAX_PACKET, "{} bytes", bytes.len());
    let p = Packet::parse(&bytes).expect("the cut report is a valid packet");
    let back = StatusReport::from_packet(&p).unwrap();
    assert!(back.truncated);
    assert_eq!(back.client_count, 2_000, "the count is the whole count");
    assert!(!back.clients.is_empty());
    assert!(back.clients.len() < 2_000);
    assert_eq!(back.clients[..], report.clients[..back.clients.len()]);
    // Channels come after the clients, and are cut first.
    assert!(back.channels.is_empty());
    assert_eq!(back.drops, report.drops);
    assert!(p.as_str().contains("truncated 1"));
}

#[test]
fn status_report_that_fits_is_not_marked_truncated() {
    let report = huge_report(100);
    let bytes = report.to_packet();
    let back = StatusReport::from_packet(&Packet::parse(&bytes).unwrap()).unwrap();
    assert!(!back.truncated);
    assert_eq!(back, report);
}

#[test]
fn status_report_already_cut_by_the_hub_stays_marked() {
    let mut report = sample_report();
    report.truncated = true;
    let bytes = report.to_packet();
    let back = StatusReport::from_packet(&Packet::parse(&bytes).unwrap()).unwrap();
    assert_eq!(back, report);
}

#[test]
fn status_report_with_a_bad_field_is_an_error() {
    let p = Packet::parse(
        b"@ <hub> 0\nstatus uptime_ms 1 lease_ms x min_priority 0 clients 0 truncated 0\n",
    )
    .unwrap();
    match Reply::parse(&p) {
        Some(Err(ControlError::Field(e))) => {
            assert_eq!((e.label.as_str(), e.field.as_str()), ("status", "lease_ms"));
            assert_eq!(e.kind, FieldErrorKind::NotAnInteger("x".into()));
        }
        other => panic!("expected a field error, got {other:?}"),
    }
}

#[test]
fn an_about_text_longer_than_the_hub_keeps_is_cut_on_a_character_boundary() {
    let long = format!("@ <hub> 0\nabout text \"{}\"\n", "é".repeat(200));
    match &requests(&long).unwrap()[..] {
        [Request::About(text)] => {
            assert!(
                text.len() <= colony_wire::MAX_ABOUT && text.len() >= colony_wire::MAX_ABOUT - 1
            );
            assert!(text.chars().all(|c| c == 'é'));
        }
        other => panic!("{other:?}"),
    }
}
