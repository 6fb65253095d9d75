use super::*;
use crate::fixtures::{client, report};
use crate::keys::Site;
use crate::stats::Stats;
use crate::wants::PER_SITE;

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn subject(name: &str) -> Subject {
    Subject::new(name).unwrap()
}

fn relay(now: Instant) -> Relay {
    let config = BridgeConfig::new("127.0.0.1:7400", Site::new("lab").unwrap());
    Relay::new(config, "127.0.0.1:7400".parse().unwrap(), now)
}

fn drain(r: &mut Relay) -> Vec<Output> {
    std::iter::from_fn(|| r.poll_output()).collect()
}

fn hub(op: ToHub) -> Output {
    Output::Hub(op)
}

fn zenoh(op: ToZenoh) -> Output {
    Output::Zenoh(op)
}

fn want(site: &str, channel: &str, alive: bool) -> Want {
    Want {
        key: keys::want_key(&Site::new(site).unwrap(), channel),
        alive,
        again: false,
    }
}

/// A relay whose clients want `channels`, its declarations taken.
fn importing(now: Instant, channels: &[&str]) -> Relay {
    let mut r = relay(now);
    r.handle_status(&report(vec![client("", channels)]));
    drain(&mut r);
    r
}

/// A relay exporting `channels` to site `far`, its outputs taken.
fn exporting(now: Instant, channels: &[&str]) -> Relay {
    let mut r = relay(now);
    for c in channels {
        r.handle_want(want("far", c, true));
    }
    r.handle_timeout(now, HubState::Alive);
    drain(&mut r);
    r
}

fn about(outputs: &[Output]) -> Option<&str> {
    outputs.iter().find_map(|o| match o {
        Output::Hub(ToHub::Standing(requests)) => match requests.as_slice() {
            [Request::NoLocal, Request::About(text)] => Some(text.as_str()),
            _ => None,
        },
        _ => None,
    })
}

fn subscribes(outputs: &[Output]) -> Vec<&str> {
    outputs
        .iter()
        .filter_map(|o| match o {
            Output::Hub(ToHub::Subscribe(s)) => Some(s.as_str()),
            _ => None,
        })
        .collect()
}

fn sample(key: &str, payload: &str, seq: Option<u64>) -> Sample {
    Sample {
        key: key.into(),
        payload: payload.as_bytes().to_vec(),
        priority: 5,
        stamp: seq.map(|seq| Stamp { run: 7, seq }),
    }
}

#[test]
fn it_says_what_it_is_at_once_then_asks_for_status_every_poll_and_reports_every_second() {
    let t0 = Instant::now();
    let mut r = relay(t0);
    let first = drain(&mut r);
    assert_eq!(first.len(), 1);
    let text = about(&first).expect("the about text first");
    assert!(text.starts_with(&r.marker()), "{text}");
    assert!(text.contains("exports nothing; imports nothing"), "{text}");
    assert_eq!(r.own_channel().as_str(), "bridge.lab");
    assert_eq!(r.poll_timeout(), t0);

    r.handle_timeout(t0, HubState::Unknown);
    let out = drain(&mut r);
    assert_eq!(out[0], hub(ToHub::AskStatus));
    assert!(about(&out).is_some() && out.len() == 2, "{out:?}");
    assert_eq!(r.poll_timeout(), t0 + ms(250));

    r.handle_timeout(t0 + ms(100), HubState::Alive);
    assert!(drain(&mut r).is_empty(), "nothing is due before its time");
    r.handle_timeout(t0 + ms(250), HubState::Alive);
    assert_eq!(drain(&mut r), [hub(ToHub::AskStatus)]);
    assert_eq!(r.poll_timeout(), t0 + ms(500));
    r.handle_timeout(t0 + ms(1000), HubState::Alive);
    let out = drain(&mut r);
    assert_eq!(out[0], hub(ToHub::AskStatus));
    assert!(about(&out).is_some(), "{out:?}");
    assert_eq!(r.poll_timeout(), t0 + ms(1250));
}

#[test]
fn a_status_report_declares_a_token_per_channel_and_a_subscriber_per_set() {
    let t0 = Instant::now();
    let mut r = relay(t0);
    drain(&mut r);
    let me = format!("{} zenoh peer", r.marker());
    let seen = report(vec![
        client("", &["mobile", "camera"]),
        client(&me, &["radio"]),
    ]);
    r.handle_status(&seen);
    let token = |c: &str| {
        zenoh(ToZenoh::DeclareToken {
            channel: subject(c),
            key: format!("colony/lab/want/{c}"),
        })
    };
    let sub = |e: &str| zenoh(ToZenoh::DeclareSubscriber(e.into()));
    assert_eq!(
        drain(&mut r),
        [
            token("camera"),
            token("mobile"),
            sub("colony/*/ch/camera"),
            sub("colony/*/ch/camera/mobile"),
            sub("colony/*/ch/mobile"),
        ],
        "the bridge's own subscriptions are other sites' wants, never this site's"
    );
    r.handle_status(&seen);
    assert!(drain(&mut r).is_empty(), "the same wants declare nothing");

    let cut = StatusReport {
        truncated: true,
        ..report(vec![])
    };
    r.handle_status(&cut);
    assert!(
        drain(&mut r).is_empty(),
        "a report cut short withdraws nothing"
    );

    r.handle_status(&report(vec![client("", &["mobile"])]));
    assert_eq!(
        drain(&mut r),
        [
            zenoh(ToZenoh::UndeclareToken(subject("camera"))),
            zenoh(ToZenoh::UndeclareSubscriber("colony/*/ch/camera".into())),
            zenoh(ToZenoh::UndeclareSubscriber(
                "colony/*/ch/camera/mobile".into()
            )),
        ]
    );
}

#[test]
fn other_sites_wants_are_subscribed_on_the_hub_ten_at_a_time_every_100_ms() {
    let t0 = Instant::now();
    let mut r = relay(t0);
    r.handle_timeout(t0, HubState::Alive);
    drain(&mut r);
    assert_eq!(r.poll_timeout(), t0 + ms(250), "no wants: status is next");

    for i in 0..25 {
        r.handle_want(want("far", &format!("c{i:02}"), true));
    }
    r.handle_want(want("lab", "mine", true));
    r.handle_want(want("far", "bridge.lab", true));
    assert_eq!(r.poll_timeout(), t0, "changed wants are due at once");

    r.handle_timeout(t0 + ms(10), HubState::Alive);
    let first = drain(&mut r);
    let names: Vec<String> = (0..10).map(|i| format!("c{i:02}")).collect();
    assert_eq!(subscribes(&first), names);
    assert_eq!(r.poll_timeout(), t0 + ms(110));
    r.handle_timeout(t0 + ms(60), HubState::Alive);
    assert!(drain(&mut r).is_empty(), "at most every 100 ms");
    r.handle_timeout(t0 + ms(110), HubState::Alive);
    assert_eq!(subscribes(&drain(&mut r)).len(), 10);
    r.handle_timeout(t0 + ms(210), HubState::Alive);
    assert_eq!(subscribes(&drain(&mut r)).len(), 5);
    assert_eq!(
        r.poll_timeout(),
        t0 + ms(250),
        "all subscribed: status is next"
    );

    r.handle_want(want("far", "c03", false));
    r.handle_want(want("far", "c99", false));
    assert_eq!(r.poll_timeout(), t0 + ms(250));
    r.handle_timeout(t0 + ms(310), HubState::Alive);
    let out = drain(&mut r);
    assert!(
        out.contains(&hub(ToHub::Unsubscribe(subject("c03")))),
        "{out:?}"
    );
    assert!(subscribes(&out).is_empty());
}

#[test]
fn channels_beyond_the_hub_s_limit_are_left_out_and_counted_once() {
    let t0 = Instant::now();
    let names: Vec<String> = (0..MAX_EXPORTS + 45).map(|i| format!("c{i:03}")).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let mut r = exporting(t0, &names);
    for k in 1..40 {
        r.handle_timeout(t0 + ms(100 * k), HubState::Alive);
    }
    let subscribed = r.exported.len();
    assert_eq!(subscribed, MAX_EXPORTS);
    assert_eq!(Stats::get(&r.stats().refused_wants), 45);
}

#[test]
fn a_packet_is_put_only_when_other_sites_want_every_subject_numbered_per_key_and_priority() {
    let t0 = Instant::now();
    let mut r = exporting(t0, &["vision", "radio"]);
    let put = |r: &mut Relay, text: &str| {
        r.handle_packet(&Packet::parse(text.as_bytes()).unwrap());
        match drain(r).as_slice() {
            [] => None,
            [Output::Zenoh(ToZenoh::Put(p))] => Some(p.clone()),
            other => panic!("{other:?}"),
        }
    };
    let first = put(&mut r, "@ <vision> 0\nx\n").unwrap();
    assert_eq!(first.key, "colony/lab/ch/vision");
    assert_eq!(first.payload, b"@ <vision> 0\nx\n");
    assert_eq!(first.stamp.seq, 1);
    assert_eq!(
        (first.priority, first.congestion, first.express),
        (ZPriority::Data, CongestionControl::Drop, false)
    );
    let second = put(&mut r, "@ <vision> 0\ny\n").unwrap();
    assert_eq!(
        second.stamp,
        Stamp {
            seq: 2,
            ..first.stamp
        }
    );

    let urgent = put(&mut r, "@ <vision> 10\nstop\n").unwrap();
    assert_eq!(
        (urgent.priority, urgent.express),
        (ZPriority::RealTime, true)
    );
    assert_eq!(urgent.stamp.seq, 1, "each Zenoh priority is numbered apart");

    let set = put(&mut r, "@ <vision> <radio> 0\nz\n").unwrap();
    assert_eq!(set.key, "colony/lab/ch/radio/vision");
    assert_eq!(put(&mut r, "@ <vision> <camera> 0\nz\n"), None);
    assert_eq!(put(&mut r, "@ <camera> 0\nz\n"), None);
}

#[test]
fn a_sample_is_published_only_if_this_site_asked_for_all_of_it_and_only_once() {
    let t0 = Instant::now();
    let mut r = importing(t0, &["vision"]);
    let stats = r.stats();
    let text = "@ <vision> 0\nx\n";
    let key = "colony/far/ch/vision";
    let published = |r: &mut Relay, s: Sample| {
        r.handle_sample(t0, s);
        match drain(r).as_slice() {
            [] => false,
            [Output::Hub(ToHub::Publish(p))] => p == text.as_bytes(),
            other => panic!("{other:?}"),
        }
    };
    assert!(published(&mut r, sample(key, text, Some(1))));
    assert!(!published(&mut r, sample(key, text, Some(1))), "a repeat");
    assert_eq!(Stats::get(&stats.duplicates), 1);
    assert!(published(&mut r, sample(key, text, Some(4))));
    assert_eq!(Stats::get(&stats.lost), 2);
    assert!(
        published(&mut r, sample(key, text, Some(3))),
        "late, not lost"
    );
    assert_eq!(Stats::get(&stats.lost), 1);
    assert!(
        published(&mut r, sample(key, text, None)),
        "no stamp: passed on"
    );

    assert!(!published(
        &mut r,
        sample("colony/lab/ch/vision", text, Some(9))
    ));
    assert_eq!(
        Stats::get(&stats.rejected),
        0,
        "its own site's: dropped uncounted"
    );
    let radio = "@ <radio> 0\nx\n";
    assert!(!published(
        &mut r,
        sample("colony/far/ch/radio", radio, Some(1))
    ));
    assert!(!published(
        &mut r,
        sample("colony/far/ch/radio", text, Some(1))
    ));
    assert!(!published(&mut r, sample(key, "not a packet", Some(1))));
    assert_eq!(Stats::get(&stats.rejected), 3);

    r.handle_timeout(t0 + ms(1000), HubState::Alive);
    let out = drain(&mut r);
    let text = about(&out).unwrap();
    assert!(
        text.contains("imports 1 (vision); lost 1 dup 1 suspect 0 rejected 3"),
        "{text}"
    );
}

#[test]
fn what_became_of_each_output_is_counted() {
    let r = relay(Instant::now());
    let stats = r.stats();
    r.hub_done(&ToHub::Publish(b"@ <a> 0\n".to_vec()), Ok(()));
    r.hub_done(&ToHub::Subscribe(subject("a")), Ok(()));
    r.hub_done(
        &ToHub::Publish(b"@ <a> 0\n".to_vec()),
        Err("refused".into()),
    );
    r.hub_done(&ToHub::AskStatus, Err("unreachable".into()));
    r.hub_error("receive", &"refused");
    r.put_done(Ok(()));
    r.put_done(Err("closed".into()));
    assert_eq!(Stats::get(&stats.imported), 1);
    assert_eq!(Stats::get(&stats.hub_errors), 3);
    assert_eq!(Stats::get(&stats.exported), 1);
    assert_eq!(Stats::get(&stats.put_failed), 1);
}

#[test]
fn a_hub_that_stops_answering_has_this_site_s_wants_withdrawn() {
    let t0 = Instant::now();
    let mut r = importing(t0, &["vision"]);
    r.handle_timeout(t0, HubState::Alive);
    drain(&mut r);
    let silent = HubState::Unreachable {
        silent_for: Duration::from_secs(3),
    };
    r.handle_timeout(t0 + ms(100), silent);
    assert!(drain(&mut r).is_empty(), "only when status is due");
    r.handle_timeout(t0 + ms(250), silent);
    assert_eq!(
        drain(&mut r),
        [
            hub(ToHub::AskStatus),
            zenoh(ToZenoh::UndeclareToken(subject("vision"))),
            zenoh(ToZenoh::UndeclareSubscriber("colony/*/ch/vision".into())),
        ]
    );
    r.handle_timeout(t0 + ms(500), silent);
    assert_eq!(drain(&mut r), [hub(ToHub::AskStatus)], "withdrawn once");
}

#[test]
fn lost_want_tokens_are_listed_again_and_the_table_rebuilt_from_the_list() {
    let t0 = Instant::now();
    let mut r = exporting(t0, &["a"]);
    assert_eq!(r.exported, [subject("a")].into());
    r.handle_wants_lost();
    assert_eq!(drain(&mut r), [zenoh(ToZenoh::ListWants)]);
    let far = Site::new("far").unwrap();
    r.handle_want_list([keys::want_key(&far, "b"), "nonsense".to_owned()]);
    assert_eq!(r.poll_timeout(), t0 + ms(100));
    r.handle_timeout(t0 + ms(100), HubState::Alive);
    let out = drain(&mut r);
    assert_eq!(out[0], hub(ToHub::Unsubscribe(subject("a"))));
    assert_eq!(subscribes(&out), ["b"]);
}

#[test]
fn a_refused_want_is_looked_at_again_once_room_frees_at_most_every_second() {
    let t0 = Instant::now();
    let mut r = relay(t0);
    for i in 0..=PER_SITE {
        r.handle_want(want("far", &format!("c{i:04}"), true));
    }
    assert_eq!(Stats::get(&r.stats().refused_wants), 1);
    r.handle_want(Want {
        again: true,
        ..want("far", "c9999", true)
    });
    assert_eq!(Stats::get(&r.stats().refused_wants), 1, "counted once");
    r.handle_timeout(t0, HubState::Alive);
    let out = drain(&mut r);
    assert!(!out.contains(&zenoh(ToZenoh::Relook)), "no room yet");

    r.handle_want(want("far", "c0000", false));
    let at = t0 + ms(50);
    assert!(r.poll_timeout() <= at);
    r.handle_timeout(at, HubState::Alive);
    assert!(drain(&mut r).contains(&zenoh(ToZenoh::Relook)));
    // The re-look's answer finds room; then the site is full again, and refuses one more.
    r.handle_want(Want {
        again: true,
        ..want("far", &format!("c{PER_SITE:04}"), true)
    });
    r.handle_want(want("far", "c0001", false));
    r.handle_want(want("far", "c9998", true));
    r.handle_want(want("far", "c9997", true));
    r.handle_timeout(t0 + ms(500), HubState::Alive);
    let out = drain(&mut r);
    assert!(
        !out.contains(&zenoh(ToZenoh::Relook)),
        "at most every second"
    );
    assert_eq!(r.poll_timeout(), t0 + ms(600));
    r.handle_timeout(at + RELOOK_EVERY, HubState::Alive);
    assert!(drain(&mut r).contains(&zenoh(ToZenoh::Relook)));
}
