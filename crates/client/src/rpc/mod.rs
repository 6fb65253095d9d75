//! Request and reply over publish/subscribe (the Broker paper, III.E): a
//! provider publishes its existence on a service's channel, callers send
//! each call to one live provider's inbox and get its answer in their own.
//!
//! [`Caller`] and [`Provider`] are the protocol alone, sans I/O, like
//! [`Session`](crate::Session); [`CallClient`] and [`ServeClient`] put a
//! [`UdpClient`](crate::UdpClient) under each, for programs that just want
//! to call or serve. The packets are in [`message`].
//!
//! What a caller can count on: every call ends exactly once, with the
//! answer of the provider it was sent to, or with a [`CallError`] that says
//! why not (no provider, the deadline, the provider leaving or falling
//! silent for its lease, a refusal). A call is sent once, to one provider,
//! and never again to another (the first may have acted on it): after a
//! lost datagram it times out.

mod caller;
mod endpoint;
pub mod message;
mod provider;

use std::fmt;
use std::time::Duration;

pub use caller::{Answer, Caller, Outcome};
pub use endpoint::{Asked, CallClient, ServeClient};
pub use message::{Id, Service};
pub use provider::{Call, Provider, Ticket};

/// The longest provider lease a caller believes: a forged announcement
/// holds a place among its providers for at most this long.
const LONGEST_LEASE: Duration = Duration::from_secs(60);
/// The longest a call may wait for its answer.
pub const LONGEST_TIMEOUT: Duration = Duration::from_secs(86_400);

/// Why a call ended without an answer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CallError {
    /// No provider announced itself before the deadline.
    NoProvider {
        /// How long the call waited.
        waited: Duration,
    },
    /// The provider did not answer before the deadline.
    Timeout {
        /// The provider the call went to.
        provider: Id,
        /// How long the call waited.
        waited: Duration,
    },
    /// The provider said it was stopping, and its lease lapsed before it answered.
    ProviderLeft {
        /// The provider.
        provider: Id,
    },
    /// The provider fell silent for longer than its lease (it died, or lost the hub).
    ProviderLapsed {
        /// The provider.
        provider: Id,
        /// Its lease.
        lease: Duration,
        /// How long it had been silent.
        silent: Duration,
    },
    /// The provider could not serve the call.
    Refused {
        /// The provider.
        provider: Id,
        /// Its reason.
        why: String,
    },
    /// The call could not be written as a packet to the provider chosen.
    Unsendable(String),
}

impl fmt::Display for CallError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CallError::NoProvider { waited } => write!(
                f,
                "no provider of the service answered within {:.1} s (is one running on this hub?)",
                waited.as_secs_f64()
            ),
            CallError::Timeout { provider, waited } => write!(
                f,
                "provider {provider} did not answer within {:.1} s",
                waited.as_secs_f64()
            ),
            CallError::ProviderLeft { provider } => {
                write!(f, "provider {provider} stopped before answering")
            }
            CallError::ProviderLapsed {
                provider,
                lease,
                silent,
            } => write!(
                f,
                "provider {provider} fell silent for {:.1} s, past its {:.1} s lease, before answering",
                silent.as_secs_f64(),
                lease.as_secs_f64()
            ),
            CallError::Refused { provider, why } => {
                write!(f, "provider {provider} refused the call: {why}")
            }
            CallError::Unsendable(why) => write!(f, "the call cannot be sent: {why}"),
        }
    }
}

impl std::error::Error for CallError {}

/// What stops a caller or provider from working at all.
#[derive(Debug, thiserror::Error)]
pub enum RpcError {
    /// A service name that cannot make a channel.
    #[error(
        "`{0}` cannot name a service: use letters, digits and `_-.:/`, 1 to {max} bytes",
        max = message::MAX_SERVICE_LEN
    )]
    BadService(String),
    /// A call's timeout that is zero or longer than [`LONGEST_TIMEOUT`].
    #[error("a call's timeout must be more than 0 and at most a day, not {0:?}")]
    BadTimeout(Duration),
    /// Lines that do not make a valid packet (numbered from the call's first line).
    #[error("the call's lines are not a valid packet: {0}")]
    BadLines(colony_wire::ParseError),
    /// The call ended without an answer.
    #[error(transparent)]
    Call(#[from] CallError),
    /// The hub's address or the socket.
    #[error(transparent)]
    Client(#[from] crate::ClientError),
    /// The hub's address could not be resolved.
    #[error(transparent)]
    Connect(#[from] crate::ConnectError),
    /// The socket failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

#[cfg(test)]
mod tests {
    use super::message::{AnswerHeader, CallHeader, Notice};
    use super::*;
    use colony_wire::{Packet, Priority};
    use std::time::Instant;

    const LEASE: Duration = Duration::from_secs(3);
    const TIMEOUT: Duration = Duration::from_secs(5);

    /// Delivers what each side sends to the sides subscribed to its subject,
    /// as a hub would, until nothing more is sent. Returns the calls each
    /// provider took (answered by `answer` when it gives lines).
    struct Net {
        caller: Caller,
        providers: Vec<Provider>,
        /// Providers that no longer take anything (dead).
        dead: Vec<bool>,
        taken: Vec<Vec<Id>>,
    }

    impl Net {
        fn new(providers: usize, now: Instant) -> Net {
            let providers: Vec<Provider> = (0..providers)
                .map(|i| Provider::with_id("echo", Id(100 + i as u64), LEASE, now).unwrap())
                .collect();
            Net {
                caller: Caller::with_id("echo", Id(7)).unwrap(),
                dead: vec![false; providers.len()],
                taken: vec![Vec::new(); providers.len()],
                providers,
            }
        }

        fn run(&mut self, now: Instant) {
            loop {
                let mut sent = Vec::new();
                while let Some(p) = self.caller.poll_transmit() {
                    sent.push(p);
                }
                for (i, prov) in self.providers.iter_mut().enumerate() {
                    while let Some(p) = prov.poll_transmit() {
                        if !self.dead[i] {
                            sent.push(p);
                        }
                    }
                }
                if sent.is_empty() {
                    return;
                }
                for bytes in &sent {
                    let packet = Packet::parse(bytes).unwrap();
                    if self
                        .caller
                        .subjects()
                        .iter()
                        .any(|s| packet.has_subject(s.as_str()))
                    {
                        self.caller.handle_packet(now, &packet);
                    }
                    for (i, prov) in self.providers.iter_mut().enumerate() {
                        let wants = prov
                            .subjects()
                            .iter()
                            .any(|s| packet.has_subject(s.as_str()));
                        if self.dead[i] || !wants {
                            continue;
                        }
                        if let Some(call) = prov.handle_packet(now, &packet) {
                            self.taken[i].push(call.id());
                            let lines: Vec<String> =
                                call.lines().map(|l| l.as_str().to_owned()).collect();
                            let ticket = call.ticket();
                            if lines.first().is_some_and(|l| l.starts_with("fail")) {
                                prov.refuse(&ticket, "asked to fail");
                            } else {
                                prov.answer(&ticket, &lines).unwrap();
                            }
                        }
                    }
                }
            }
        }

        fn tick(&mut self, now: Instant) {
            self.caller.handle_timeout(now);
            for (i, p) in self.providers.iter_mut().enumerate() {
                if !self.dead[i] {
                    p.handle_timeout(now);
                }
            }
            self.run(now);
        }

        fn outcomes(&mut self) -> Vec<Outcome> {
            std::iter::from_fn(|| self.caller.poll_outcome()).collect()
        }
    }

    #[test]
    fn calls_are_spread_over_the_providers_and_each_is_answered_once_with_its_lines() {
        let t0 = Instant::now();
        let mut net = Net::new(2, t0);
        net.run(t0);
        assert_eq!(net.caller.providers().count(), 2);
        let ids: Vec<Id> = (0..10)
            .map(|i| {
                let line = format!("n value {i}");
                net.caller.call(t0, Priority(0), &[&line], TIMEOUT).unwrap()
            })
            .collect();
        net.run(t0);
        let outcomes = net.outcomes();
        assert_eq!(outcomes.len(), 10);
        for (id, result) in &outcomes {
            let answer = result.as_ref().unwrap();
            let i = ids.iter().position(|x| x == id).unwrap();
            assert_eq!(answer.id, *id);
            assert_eq!(answer.lines, [format!("n value {i}")]);
        }
        let mut ended: Vec<Id> = outcomes.iter().map(|(id, _)| *id).collect();
        ended.sort();
        ended.dedup();
        assert_eq!(ended.len(), 10);
        assert_eq!(net.taken[0].len(), 5);
        assert_eq!(net.taken[1].len(), 5);
        assert_eq!(net.caller.in_flight(), 0);
    }

    #[test]
    fn a_call_before_any_provider_asks_who_provides_and_is_sent_once_one_answers() {
        let t0 = Instant::now();
        let mut net = Net::new(1, t0);
        // The provider's first announcement is lost, as when its hub lease is not yet there.
        while net.providers[0].poll_transmit().is_some() {}
        let id = net.caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
        net.run(t0);
        let outcomes = net.outcomes();
        assert_eq!(outcomes.len(), 1);
        assert_eq!(outcomes[0].0, id);
        assert!(outcomes[0].1.is_ok());
    }

    #[test]
    fn with_no_provider_a_call_ends_at_its_deadline_and_who_is_asked_every_250_ms() {
        let t0 = Instant::now();
        let mut caller = Caller::with_id("nobody", Id(1)).unwrap();
        caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
        let mut asked = 0;
        let mut now = t0;
        while now < t0 + TIMEOUT {
            while let Some(p) = caller.poll_transmit() {
                assert_eq!(Notice::read(&Packet::parse(&p).unwrap()), Some(Notice::Who));
                asked += 1;
            }
            now = caller.poll_timeout().unwrap();
            caller.handle_timeout(now);
        }
        assert!((19..=21).contains(&asked), "asked {asked} times in 5 s");
        let (_, result) = caller.poll_outcome().unwrap();
        assert!(matches!(result, Err(CallError::NoProvider { .. })));
        assert_eq!(caller.poll_timeout(), None);
    }

    #[test]
    fn a_silent_provider_ends_its_calls_at_its_lease_and_the_rest_go_to_the_other() {
        let t0 = Instant::now();
        let mut net = Net::new(2, t0);
        net.run(t0);
        net.dead[0] = true;
        let ids: Vec<Id> = (0..4)
            .map(|_| net.caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap())
            .collect();
        net.run(t0);
        // Provider 1 answered its two; provider 0's two wait.
        assert_eq!(net.outcomes().len(), 2);
        let mut now = t0;
        while now < t0 + LEASE {
            now += Duration::from_millis(100);
            net.tick(now);
        }
        let ended = net.outcomes();
        assert_eq!(ended.len(), 2);
        for (id, result) in &ended {
            assert!(ids.contains(id));
            match result {
                Err(CallError::ProviderLapsed { provider, .. }) => assert_eq!(*provider, Id(100)),
                other => panic!("expected a lapsed provider, got {other:?}"),
            }
        }
        assert_eq!(net.caller.providers().collect::<Vec<_>>(), [Id(101)]);
        net.caller.call(now, Priority(0), &["y"], TIMEOUT).unwrap();
        net.run(now);
        assert!(net.outcomes()[0].1.is_ok());
    }

    #[test]
    fn a_provider_that_leaves_gets_no_new_calls_and_its_own_end_with_its_lease() {
        let t0 = Instant::now();
        let mut net = Net::new(2, t0);
        net.run(t0);
        net.dead[0] = true;
        net.caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
        net.run(t0);
        net.dead[0] = false;
        net.providers[0].leave();
        net.run(t0);
        // A `leaving` anyone could forge ends nothing at once...
        assert!(net.outcomes().is_empty());
        // ...but new calls go elsewhere,
        for _ in 0..4 {
            net.caller.call(t0, Priority(0), &["y"], TIMEOUT).unwrap();
        }
        net.run(t0);
        assert_eq!(net.taken[1].len(), 4);
        assert!(net.outcomes().iter().all(|(_, r)| r.is_ok()));
        // and the call it held ends when its lease does, saying it left.
        let mut now = t0;
        while now < t0 + LEASE {
            now += Duration::from_millis(100);
            net.caller.handle_timeout(now);
            net.providers[1].handle_timeout(now);
            net.run(now);
        }
        let ended = net.outcomes();
        assert!(
            matches!(
                ended[..],
                [(_, Err(CallError::ProviderLeft { provider: Id(100) }))]
            ),
            "{ended:?}"
        );
        assert_eq!(net.caller.providers().collect::<Vec<_>>(), [Id(101)]);
    }

    #[test]
    fn a_forged_short_lease_does_not_end_a_providers_calls_sooner() {
        let t0 = Instant::now();
        let mut net = Net::new(1, t0);
        net.run(t0);
        net.dead[0] = true;
        net.caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
        net.run(t0);
        let forged = Notice::Provider {
            id: Id(100),
            lease: Duration::ZERO,
        }
        .to_packet(&Service::new("echo").unwrap());
        net.caller
            .handle_packet(t0, &Packet::parse(&forged).unwrap());
        net.caller.handle_timeout(t0 + Duration::from_secs(1));
        assert!(net.outcomes().is_empty());
        assert_eq!(net.caller.providers().count(), 1);
    }

    #[test]
    fn an_answer_keeps_a_busy_provider_alive_though_it_has_no_time_to_announce() {
        let t0 = Instant::now();
        let mut caller = Caller::with_id("echo", Id(7)).unwrap();
        let mut provider = Provider::with_id("echo", Id(100), LEASE, t0).unwrap();
        let announce = provider.poll_transmit().unwrap();
        caller.handle_packet(t0, &Packet::parse(&announce).unwrap());
        // Answers every 0.5 s for 10 s, never announcing.
        let mut now = t0;
        for _ in 0..20 {
            caller.call(now, Priority(0), &["x"], TIMEOUT).unwrap();
            let call = caller.poll_transmit().unwrap();
            let ticket = provider
                .handle_packet(now, &Packet::parse(&call).unwrap())
                .unwrap()
                .ticket();
            now += Duration::from_millis(500);
            provider.answer(&ticket, &[]).unwrap();
            let answer = provider.poll_transmit().unwrap();
            caller.handle_timeout(now);
            caller.handle_packet(now, &Packet::parse(&answer).unwrap());
            assert!(caller.poll_outcome().unwrap().1.is_ok());
        }
        assert_eq!(caller.providers().count(), 1);
    }

    #[test]
    fn forged_announcements_with_fresh_ids_hold_at_most_64_places() {
        let t0 = Instant::now();
        let mut caller = Caller::with_id("echo", Id(7)).unwrap();
        let service = Service::new("echo").unwrap();
        for i in 0..10_000u64 {
            let p = Notice::Provider {
                id: Id(i),
                lease: Duration::from_secs(3600),
            }
            .to_packet(&service);
            caller.handle_packet(t0, &Packet::parse(&p).unwrap());
        }
        assert_eq!(caller.providers().count(), 64);
        // Believed for a minute at most, whatever they claim.
        caller.handle_timeout(t0 + Duration::from_secs(61));
        assert_eq!(caller.providers().count(), 0);
    }

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
        let service = Service::new("echo").unwrap();
        let read = |text: &str| {
            Packet::parse(text.as_bytes())
                .map(|p| Notice::read(&p))
                .unwrap()
        };
        assert_eq!(
            read("@ <svc.echo> 0\nprovider id \"00000000000000aa\" lease_ms 3000\n"),
            None
        );
        let inbox = service.inbox(Id(1));
        let call = |reply: &str| {
            let text = format!("@ <{inbox}> 0\ncall id 0000000000000001 reply_to {reply}\n");
            CallHeader::read(&Packet::parse(text.as_bytes()).unwrap())
        };
        assert!(call("reply.0000000000000007").is_some());
        assert!(call("\"reply.0000000000000007\"").is_none());
        let refused = |text: &str| {
            let p = format!("@ <reply.0000000000000007> 0\nrefused id 0000000000000001 from 0000000000000064 text {text}\n");
            AnswerHeader::read(&Packet::parse(p.as_bytes()).unwrap()).map(|a| a.refused)
        };
        assert_eq!(refused("007"), Some(Some("007".into())));
        assert_eq!(
            refused("\"disk \\\"full\\\"\""),
            Some(Some("disk \"full\"".into()))
        );
        assert_eq!(refused("(a 1)"), None);
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
    fn repeated_late_and_forged_answers_are_strays_and_never_end_a_call_twice() {
        let t0 = Instant::now();
        let mut caller = Caller::with_id("echo", Id(7)).unwrap();
        let mut provider = Provider::with_id("echo", Id(100), LEASE, t0).unwrap();
        let announce = provider.poll_transmit().unwrap();
        caller.handle_packet(t0, &Packet::parse(&announce).unwrap());
        let id = caller.call(t0, Priority(0), &["x"], TIMEOUT).unwrap();
        let call = caller.poll_transmit().unwrap();
        let call = Packet::parse(&call).unwrap();
        let ticket = provider.handle_packet(t0, &call).unwrap().ticket();
        // Forged: the right call id from a provider it was not sent to.
        let forged = AnswerHeader {
            id,
            from: Id(666),
            refused: None,
        }
        .to_packet(&ticket.reply_to, Priority(0), &[])
        .unwrap();
        caller.handle_packet(t0, &Packet::parse(&forged).unwrap());
        assert_eq!(caller.poll_outcome(), None);
        provider.answer(&ticket, &["a".into()]).unwrap();
        let answer = provider.poll_transmit().unwrap();
        for _ in 0..3 {
            caller.handle_packet(t0, &Packet::parse(&answer).unwrap());
        }
        assert!(caller.poll_outcome().unwrap().1.is_ok());
        assert_eq!(caller.poll_outcome(), None);
        assert_eq!(caller.strays(), 3);
    }

    #[test]
    fn a_provider_answers_only_reply_inboxes_and_who_at_most_once_a_third_of_its_lease() {
        let t0 = Instant::now();
        let mut provider = Provider::with_id("echo", Id(100), LEASE, t0).unwrap();
        while provider.poll_transmit().is_some() {}
        let inbox = provider.subjects()[1].clone();
        let aimed = format!("@ <{inbox}> 0\ncall id 0000000000000001 reply_to radio\ncmd id 1\n");
        assert!(provider
            .handle_packet(t0, &Packet::parse(aimed.as_bytes()).unwrap())
            .is_none());
        let who = Notice::Who.to_packet(&Service::new("echo").unwrap());
        let mut now = t0;
        for _ in 0..1000 {
            now += Duration::from_millis(1);
            provider.handle_packet(now, &Packet::parse(&who).unwrap());
        }
        let announced = std::iter::from_fn(|| provider.poll_transmit()).count();
        assert_eq!(announced, 1, "1 s of `who` at 1 kHz, with a 3 s lease");
    }

    #[test]
    fn a_provider_announces_every_third_of_its_lease() {
        let t0 = Instant::now();
        let mut provider = Provider::with_id("echo", Id(100), LEASE, t0).unwrap();
        assert!(provider.poll_transmit().is_some());
        assert_eq!(provider.poll_timeout(), t0 + LEASE / 3);
        provider.handle_timeout(t0 + LEASE / 3);
        let p = provider.poll_transmit().unwrap();
        assert_eq!(
            Notice::read(&Packet::parse(&p).unwrap()),
            Some(Notice::Provider {
                id: Id(100),
                lease: LEASE
            })
        );
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
}
