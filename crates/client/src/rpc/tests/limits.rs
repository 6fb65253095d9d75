//! Limits and refusals: timeouts, names, ids, lines, answers too long, the provider's rates.

use super::*;

#[test]
fn a_timeout_of_zero_or_past_a_day_is_refused() {
    let mut caller = Caller::with_id("echo", Id(7)).unwrap();
    for t in [
        Duration::ZERO,
        Duration::MAX,
        LONGEST_TIMEOUT + Duration::from_secs(1),
    ] {
        let e = caller
            .call(Instant::now(), Priority(0), &["x"], t)
            .unwrap_err();
        assert!(matches!(e, RpcError::BadTimeout(_)), "{e}");
    }
    assert_eq!(caller.in_flight(), 0);
}

#[test]
fn ids_and_inboxes_are_bare_tokens_and_a_reason_is_no_group() {
    let service = service();
    let read = |text: &str| {
        Packet::parse(text.as_bytes())
            .map(|p| Notice::read(&p))
            .unwrap()
    };
    assert_eq!(
        read("@ <svc.echo> 0\nprovider id \"00000000000000aa\" lease_ms 3000\n"),
        None
    );
    assert_eq!(
        read("@ <svc.echo> 0\nprovider id 00000000000000aa lease_ms 3000 nonce 12\n"),
        None
    );
    assert_eq!(
        read("@ <svc.echo> 0\nwho nonce \"00000000000000aa\"\n"),
        None
    );
    assert_eq!(
        read("@ <svc.echo> 0\nwho nonce 00000000000000aa\n"),
        Some(Notice::Who {
            nonce: Some(Id(0xaa))
        })
    );
    let inbox = service.inbox(Id(1));
    let call = |reply: &str| {
        let text = format!("@ <{inbox}> 0\ncall id 0000000000000001 reply_to {reply}\n");
        CallHeader::read(&Packet::parse(text.as_bytes()).unwrap())
    };
    assert!(call("reply.0000000000000007").is_some());
    assert!(call("\"reply.0000000000000007\"").is_none());
    let said = |text: &str| {
        let p = format!("@ <reply.0000000000000007> 0\n{text}\n");
        AnswerHeader::read(&Packet::parse(p.as_bytes()).unwrap()).map(|a| a.said)
    };
    let refused = |why: &str| {
        said(&format!(
            "refused id 0000000000000001 from 0000000000000064 text {why}"
        ))
    };
    assert_eq!(refused("007"), Some(Said::Refused("007".into())));
    assert_eq!(
        refused("\"disk \\\"full\\\"\""),
        Some(Said::Refused("disk \"full\"".into()))
    );
    assert_eq!(refused("(a 1)"), None);
    assert_eq!(
        said("accepted id 0000000000000001 from 0000000000000064"),
        Some(Said::Accepted)
    );
}

#[test]
fn a_refusal_ends_the_call_with_the_providers_reason() {
    let t0 = Instant::now();
    let mut net = Net::new(1, t0);
    net.run(t0);
    net.caller
        .call(t0, Priority(0), &["fail why now"], TIMEOUT)
        .unwrap();
    net.run(t0);
    match &net.outcomes()[0].1 {
        Err(CallError::Refused { why, .. }) => assert_eq!(why, "asked to fail"),
        other => panic!("expected a refusal, got {other:?}"),
    }
}

#[test]
fn a_provider_answers_only_reply_inboxes_and_each_who_at_once_up_to_ten_a_second() {
    let t0 = Instant::now();
    let mut provider = provider(1, t0);
    while provider.poll_transmit().is_some() {}
    let inbox = provider.subjects()[1].clone();
    let aimed = format!("@ <{inbox}> 0\ncall id 0000000000000001 reply_to radio\ncmd id 1\n");
    assert!(provider
        .handle_packet(t0, &parse(aimed.as_bytes()))
        .is_none());
    assert_eq!(provider.poll_transmit(), None);
    // Six new callers in a row each hear back at once, echoing their own nonce.
    for i in 0..6 {
        let who = Notice::Who { nonce: Some(Id(i)) }.to_packet(&service());
        provider.handle_packet(t0, &parse(&who));
        let echo = provider.poll_transmit().expect("answered at once");
        match Notice::read(&parse(&echo)) {
            Some(Notice::Provider { nonce, .. }) => assert_eq!(nonce, Some(Id(i))),
            other => panic!("expected an announcement, got {other:?}"),
        }
    }
    // A flood is answered 10 a second (after what is left of the burst).
    let mut now = t0;
    for i in 0..1000 {
        now += Duration::from_millis(1);
        let who = Notice::Who { nonce: Some(Id(i)) }.to_packet(&service());
        provider.handle_packet(now, &parse(&who));
    }
    let announced = std::iter::from_fn(|| provider.poll_transmit()).count();
    assert!(
        (4 + 9..=4 + 11).contains(&announced),
        "{announced} answers to 1 s of `who` at 1 kHz"
    );
}

#[test]
fn a_provider_announces_every_third_of_its_lease() {
    let t0 = Instant::now();
    let mut provider = provider(1, t0);
    assert!(provider.poll_transmit().is_some());
    assert_eq!(provider.poll_timeout(), t0 + LEASE / 3);
    provider.handle_timeout(t0 + LEASE / 3);
    let p = provider.poll_transmit().unwrap();
    assert_eq!(
        Notice::read(&parse(&p)),
        Some(Notice::Provider {
            id: provider.id(),
            lease: LEASE,
            nonce: None,
        })
    );
}

#[test]
fn an_answer_too_long_to_seal_in_one_datagram_is_refused_by_the_provider() {
    let t0 = Instant::now();
    let mut p = provider(1, t0);
    let ticket = Ticket {
        id: Id(1),
        reply_to: message::reply_inbox(Id(7)),
        priority: Priority(0),
    };
    let line = "x".repeat(colony_wire::MAX_PACKET - 100);
    assert!(p.answer(&ticket, &[line]).is_err());
    let line = "x".repeat(colony_wire::MAX_PACKET - 1000);
    p.answer(&ticket, &[line]).unwrap();
    while let Some(sealed) = p.poll_transmit() {
        assert!(sealed.len() <= colony_wire::MAX_PACKET);
    }
}

#[test]
fn bad_service_names_and_bad_lines_are_refused_with_a_reason() {
    assert!(matches!(Caller::new("a b"), Err(RpcError::BadService(_))));
    assert!(matches!(Caller::new(""), Err(RpcError::BadService(_))));
    assert!(matches!(
        Caller::new(&"x".repeat(message::MAX_SERVICE_LEN + 1)),
        Err(RpcError::BadService(_))
    ));
    assert!(Caller::new(&"x".repeat(message::MAX_SERVICE_LEN)).is_ok());
    // Service `a.P`'s channel would be provider P's inbox of service `a`.
    assert!(matches!(
        Caller::new("a.0123456789abcdef"),
        Err(RpcError::BadService(_))
    ));
    assert!(Caller::new("a.v2").is_ok());
    let mut caller = Caller::new("echo").unwrap();
    let e = caller
        .call(Instant::now(), Priority(0), &["x (unclosed"], TIMEOUT)
        .unwrap_err();
    assert!(matches!(&e, RpcError::BadLines(p) if p.line == 1), "{e}");
    assert_eq!(caller.in_flight(), 0);
}

#[test]
fn ids_read_back_and_odd_ones_are_refused() {
    for id in [Id(0), Id(1), Id(u64::MAX), Id::fresh()] {
        assert_eq!(Id::parse(&id.to_string()), Some(id));
    }
    for bad in [
        "",
        "1",
        "ABCDEF0123456789",
        "0123456789abcdef0",
        "-123456789abcdef",
    ] {
        assert_eq!(Id::parse(bad), None, "{bad}");
    }
}
