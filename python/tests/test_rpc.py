"""Request and reply: the sans-IO Caller and Provider on their own, then
through the real Rust hub against `colony serve` and `colony call`.

Standard library only; run with the rest: python3 -m unittest discover -s python/tests -v
"""

import os
import subprocess
import sys
import time
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, HERE)

import colony_client as cc  # noqa: E402
from test_client import _HubCase, _child_env, _die_with_parent, colony_bin, run_colony  # noqa: E402

LEASE = 3.0


def identity(i):
    return cc.Identity(bytes([i]) * 32)


def pid(i):
    return "%016x" % identity(i).fingerprint


def drain(side):
    got = []
    d = side.poll_transmit()
    while d is not None:
        got.append(d)
        d = side.poll_transmit()
    return got


class Net:
    """Delivers what each side publishes to the sides subscribed to its
    subject, as a hub would, until nothing more is sent. Provider i seals
    with the key of seed byte i + 1."""

    def __init__(self, providers, now, ack_wait=cc.ACK_WAIT):
        self.caller = cc.Caller("echo", "0000000000000007", ack_wait=ack_wait)
        self.providers = [cc.Provider("echo", now, LEASE, identity(i + 1)) for i in range(providers)]
        self.dead = [False] * providers
        # Providers that take calls (and say so) but never answer them.
        self.stuck = [False] * providers
        self.taken = [[] for _ in range(providers)]
        self.heard = []

    def run(self, now):
        while True:
            sent = drain(self.caller)
            for i, p in enumerate(self.providers):
                out = drain(p)
                if not self.dead[i]:
                    sent.extend(out)
            if not sent:
                return
            for data in sent:
                packet = cc.parse(data)
                self.heard.append(packet)
                if set(packet.subjects) & set(self.caller.subjects()):
                    self.caller.handle_packet(now, packet)
                for i, p in enumerate(self.providers):
                    if self.dead[i] or not set(packet.subjects) & set(p.subjects()):
                        continue
                    call = p.handle_packet(now, packet)
                    if call is None:
                        continue
                    self.taken[i].append(call.id)
                    if self.stuck[i]:
                        continue
                    if call.lines and call.lines[0].startswith("fail"):
                        p.refuse(call, "asked to fail")
                    else:
                        p.answer(call, call.lines)

    def tick(self, until, step=0.01, start=0.0):
        """Runs the clock from ``start`` to ``until``, every side's timers kept."""
        now = start
        while now < until:
            now = round(now + step, 6)
            self.caller.handle_timeout(now)
            for i, p in enumerate(self.providers):
                if not self.dead[i]:
                    p.handle_timeout(now)
            self.run(now)
        return now

    def outcomes(self):
        got = []
        o = self.caller.poll_outcome()
        while o is not None:
            got.append(o)
            o = self.caller.poll_outcome()
        return got


class SansIO(unittest.TestCase):
    def test_a_providers_id_is_its_keys_fingerprint_and_all_it_says_is_sealed(self):
        p = cc.Provider("echo", 0.0, LEASE, identity(1))
        self.assertEqual(p.id, pid(1))
        self.assertEqual(p.inbox, "svc.echo." + pid(1))
        self.assertNotEqual(cc.Provider("echo", 0.0).id, cc.Provider("echo", 0.0).id)
        with self.assertRaises(TypeError):
            cc.Provider("echo", 0.0, LEASE, "0000000000000001")
        net = Net(1, 0.0)
        net.run(0.0)
        net.caller.call(0.0, ["x y 1"])
        net.caller.call(0.0, ["fail now 1"])
        net.run(0.0)
        net.providers[0].leave()
        net.run(0.0)
        said = [p for p in net.heard if p.labels()[0] in ("provider", "leaving", "accepted", "reply", "refused")]
        self.assertEqual(sorted({p.labels()[0] for p in said}),
                         ["accepted", "leaving", "provider", "refused", "reply"])
        counts = []
        for packet in said:
            body, key, n = cc.open_seal(packet.text.encode())
            self.assertEqual(key, identity(1).key)
            counts.append(n)
        # Sealed as they leave, so the counts rise in the order sent.
        self.assertEqual(counts, list(range(1, len(said) + 1)))
        for packet in net.heard:
            if packet.labels()[0] in ("who", "call"):
                with self.assertRaises(cc.SealError):
                    cc.open_seal(packet.text.encode())

    def test_calls_go_to_proven_providers_and_are_spread_over_them_once_accepted(self):
        net = Net(2, 0.0)
        net.run(0.0)
        self.assertEqual(len(net.caller.providers()), 2)
        first = net.caller.call(0.0, ["n value 0"])
        # Only announced: the caller asks `who nonce` and both echo at once.
        net.run(0.0)
        whos = [p for p in net.heard if p.labels()[0] == "who"]
        self.assertEqual(len(whos), 1)
        nonce = whos[0].line("who")["nonce"]
        echoes = [p for p in net.heard if p.labels()[0] == "provider" and p.line("provider").get("nonce") == nonce]
        self.assertEqual(len(echoes), 2)
        self.assertEqual([i for i, _ in net.outcomes()], [first])
        ids = [net.caller.call(0.0, ["n value %d" % i]) for i in range(10)]
        net.run(0.0)
        outcomes = net.outcomes()
        self.assertEqual(sorted(i for i, _ in outcomes), sorted(ids))
        for call_id, answer in outcomes:
            self.assertIsInstance(answer, cc.Answer)
            self.assertEqual(answer.lines, ["n value %d" % ids.index(call_id)])
        self.assertEqual(sorted(len(t) for t in net.taken), [5, 6])
        self.assertEqual(net.caller.in_flight, 0)
        self.assertEqual((net.caller.strays, net.caller.forged), (0, 0))

    def test_a_provider_that_does_not_accept_within_the_ack_wait_is_skipped_and_tried_last(self):
        net = Net(2, 0.0)
        net.run(0.0)
        net.caller.call(0.0, ["warm up 1"])
        net.run(0.0)
        net.outcomes()
        net.dead[0] = True  # alive by its lease, but gone
        ids = [net.caller.call(0.0, ["n value %d" % i], timeout=10.0) for i in range(4)]
        net.run(0.0)
        self.assertEqual(len(net.outcomes()), 2)
        net.tick(0.3)
        # After 250 ms without `accepted`, the calls went to the other provider.
        ended = net.outcomes()
        self.assertEqual(len(ended), 2)
        self.assertTrue(set(dict(ended)) <= set(ids))
        self.assertTrue(all(isinstance(a, cc.Answer) and a.provider == pid(2) for _, a in ended))
        self.assertEqual(net.caller.providers(), [pid(2), pid(1)])
        # The silent one is tried last from now on: new calls go to the live one at once.
        net.caller.call(0.3, ["again x 1"])
        net.run(0.3)
        (_, a), = net.outcomes()
        self.assertEqual(a.provider, pid(2))

    def test_the_ack_wait_is_at_most_a_quarter_of_the_time_left(self):
        net = Net(2, 0.0)
        net.run(0.0)
        net.caller.call(0.0, ["warm up 1"])
        net.run(0.0)
        net.outcomes()
        net.dead[0] = True
        net.caller._turn = 0  # the next call goes to provider 1 first
        net.caller.call(0.0, ["quick x 1"], timeout=0.2)
        net.run(0.0)
        net.tick(0.06)
        (_, a), = net.outcomes()
        self.assertEqual(a.provider, pid(2))

    def test_an_accepted_call_is_never_sent_elsewhere(self):
        net = Net(2, 0.0)
        net.run(0.0)
        net.caller.call(0.0, ["warm up 1"])
        net.run(0.0)
        net.outcomes()
        net.stuck = [True, True]
        call_id = net.caller.call(0.0, ["slow x 1"], timeout=2.0)
        net.run(0.0)
        net.tick(1.99)
        self.assertEqual(net.outcomes(), [])
        self.assertEqual(sum(len(t) for t in net.taken), 2)  # the warm-up and this one, once
        net.tick(2.0, start=1.99)
        (got, err), = net.outcomes()
        self.assertEqual((got, err.kind), (call_id, "timeout"))

    def test_a_caller_waits_for_echoes_before_trying_providers_only_announced(self):
        caller = cc.Caller("echo", "0000000000000007")
        stale = cc.Provider("echo", 0.0, LEASE, identity(9))
        caller.handle_packet(0.0, cc.parse(drain(stale)[0]))
        self.assertEqual(caller.providers(), [stale.id])
        caller.call(0.0, ["x y 1"])
        sent = [cc.parse(d) for d in drain(caller)]
        self.assertEqual([p.labels()[0] for p in sent], ["who"])
        self.assertRegex(sent[0].text, r"who nonce [0-9a-f]{16}\n")
        self.assertEqual(caller.poll_timeout(), 0.25)
        caller.handle_timeout(0.2)
        self.assertEqual(drain(caller), [])
        caller.handle_timeout(0.25)
        (call,) = [cc.parse(d) for d in drain(caller)]
        self.assertEqual(call.subjects, [stale.inbox])
        # A who answered at once makes a provider proven: the next call goes at once.
        fresh = cc.Provider("echo", 0.0, LEASE, identity(10))
        drain(fresh)
        caller.call(0.3, ["x y 2"])
        for d in drain(caller):
            fresh.handle_packet(0.3, cc.parse(d))
        for d in drain(fresh):
            caller.handle_packet(0.3, cc.parse(d))
        (call,) = [cc.parse(d) for d in drain(caller)]
        self.assertEqual(call.subjects, [fresh.inbox])

    def test_a_call_not_accepted_moves_at_once_to_a_provider_proven_meanwhile(self):
        caller = cc.Caller("echo", "0000000000000007")
        a, b = cc.Provider("echo", 0.0, LEASE, identity(1)), cc.Provider("echo", 0.0, LEASE, identity(2))
        caller.handle_packet(0.0, cc.parse(drain(a)[0]))
        caller.call(0.0, ["x y 1"], timeout=10.0)
        (who,) = drain(caller)
        a.handle_packet(0.0, cc.parse(who))
        for d in drain(a):
            caller.handle_packet(0.0, cc.parse(d))
        (call,) = [cc.parse(d) for d in drain(caller)]
        self.assertEqual(call.subjects, [a.inbox])  # and a, stopped, never takes it
        caller.handle_packet(0.1, cc.parse(drain(b)[0]))
        caller.handle_timeout(0.25)
        (who,) = [cc.parse(d) for d in drain(caller)]
        self.assertEqual(who.labels(), ["who"])
        b.handle_packet(0.26, who)
        caller.handle_packet(0.26, cc.parse(drain(b)[0]))
        (call,) = [cc.parse(d) for d in drain(caller)]
        self.assertEqual(call.subjects, [b.inbox])
        self.assertEqual(caller.providers(), [b.id, a.id])

    def test_a_silent_provider_ends_its_accepted_calls_at_its_lease(self):
        net = Net(2, 0.0)
        net.run(0.0)
        net.caller.call(0.0, ["warm up 1"])
        net.run(0.0)
        net.outcomes()
        net.stuck[0] = True
        for _ in range(4):
            net.caller.call(0.0, ["x y 1"])
        net.run(0.0)
        self.assertEqual(len(net.outcomes()), 2)
        net.dead[0] = True
        net.tick(LEASE + 0.1)
        ended = net.outcomes()
        self.assertEqual([e.kind for _, e in ended], ["provider_lapsed"] * 2)
        self.assertTrue(all(e.provider == pid(1) for _, e in ended))
        self.assertEqual(net.caller.providers(), [pid(2)])

    def test_no_provider_refusal_and_leaving_end_calls_with_their_reason(self):
        caller = cc.Caller("nobody")
        caller.call(0.0, ["x y 1"], timeout=1.0)
        caller.handle_timeout(1.0)
        (_, err), = [caller.poll_outcome()]
        self.assertEqual(err.kind, "no_provider")
        self.assertIn("no provider", str(err))

        net = Net(1, 0.0)
        net.run(0.0)
        net.caller.call(0.0, ["fail why now"])
        net.run(0.0)
        (_, err), = net.outcomes()
        self.assertEqual((err.kind, str(err).endswith("asked to fail")), ("refused", True))

        # A provider that says it is leaving gets no new calls; the ones it
        # took may still be answered, so they end with its lease.
        net.stuck[0] = True
        net.caller.call(0.0, ["x y 1"])
        net.run(0.0)
        net.providers[0].leave()
        net.run(0.0)
        self.assertEqual(net.outcomes(), [])
        self.assertEqual(net.caller.providers(), [])
        net.dead[0] = True
        net.tick(LEASE + 0.05)
        (_, err), = net.outcomes()
        self.assertEqual(err.kind, "provider_left")

    def test_a_call_sent_to_a_provider_that_leaves_before_taking_it_goes_elsewhere(self):
        net = Net(2, 0.0)
        net.run(0.0)
        net.caller.call(0.0, ["warm up 1"])
        net.run(0.0)
        net.outcomes()
        net.dead[0] = True
        net.caller._turn = 0
        call_id = net.caller.call(0.0, ["x y 1"])
        net.run(0.0)
        net.dead[0] = False
        net.providers[0].leave()
        net.run(0.0)
        (got, answer), = net.outcomes()
        self.assertEqual((got, answer.provider), (call_id, pid(2)))

    def test_a_provider_passed_over_may_still_take_the_call_it_was_sent(self):
        net = Net(2, 0.0)
        net.run(0.0)
        net.caller.call(0.0, ["warm up 1"])
        net.run(0.0)
        net.outcomes()
        net.caller._turn = 0
        net.dead = [True, True]
        call_id = net.caller.call(0.0, ["x y 1"], timeout=10.0)
        net.run(0.0)
        net.caller.handle_timeout(0.25)  # passed over: sent to the second
        net.run(0.25)
        sent = [p.subjects[0] for p in net.heard if p.labels()[0] == "call" and ("call id " + call_id) in p.text]
        self.assertEqual(sent, [net.providers[0].inbox, net.providers[1].inbox])
        # The first one's `accepted` comes late: the call is its, and only its answer ends it.
        late = net.providers[0]
        call = cc.Call(call_id, net.caller.inbox, 0, ["x y 1"], None)
        late._outbox.append(cc._rpc_packet(net.caller.inbox, 0, "accepted id %s from %s" % (call_id, late.id), ()))
        for d in drain(late):
            net.caller.handle_packet(0.3, cc.parse(d))
        net.providers[1].answer(call, ["x y 2"])
        for d in drain(net.providers[1]):
            net.caller.handle_packet(0.3, cc.parse(d))
        self.assertEqual(net.outcomes(), [])
        late.answer(call, ["x y 1"])
        for d in drain(late):
            net.caller.handle_packet(0.3, cc.parse(d))
        (got, answer), = net.outcomes()
        self.assertEqual((got, answer.provider, answer.lines), (call_id, pid(1), ["x y 1"]))

    def test_forged_and_repeated_answers_are_not_taken(self):
        net = Net(1, 0.0)
        net.run(0.0)
        net.stuck[0] = True
        call_id = net.caller.call(0.0, ["x y 1"])
        net.run(0.0)
        inbox, real = net.caller.inbox, pid(1)
        first = "reply id %s from %s" % (call_id, real)
        forger = identity(66)
        forged = [
            # Unsealed, in the provider's name.
            "@ <%s> 0\n%s\nx y 666\n" % (inbox, first),
            # Sealed by another key, in the provider's name.
            forger.seal("@ <%s> 0\n%s\nx y 666\n" % (inbox, first)).decode(),
            # Sealed by another key in its own name: not the provider the call went to.
            forger.seal("@ <%s> 0\nreply id %s from %016x\n" % (inbox, call_id, forger.fingerprint)).decode(),
            # The provider's real seal, over another answer (an edited copy).
            identity(1).seal("@ <%s> 0\n%s\nx y 1\n" % (inbox, first)).decode().replace("x y 1", "x y 6"),
            # A seal on a packet naming the real provider only after the sealed part.
            forger.seal("@ <%s> 0\nreply id %s\n" % (inbox, call_id)).decode().replace(
                "reply id %s" % call_id, first, 1),
            # A refusal and a `leaving` in its name, unsealed and sealed by another.
            "@ <%s> 0\nrefused id %s from %s text no\n" % (inbox, call_id, real),
            forger.seal("@ <svc.echo> 0\nleaving id %s\n" % real).decode(),
            "@ <svc.echo> 0\nleaving id %s\n" % real,
            forger.seal("@ <svc.echo> 0\nprovider id %s lease_ms 100\n" % real).decode(),
        ]
        for text in forged:
            net.caller.handle_packet(0.0, cc.parse(text.encode()))
        self.assertEqual(net.outcomes(), [])
        self.assertEqual(net.caller.in_flight, 1)
        self.assertEqual(net.caller.providers(), [real])
        self.assertGreaterEqual(net.caller.forged, 7)
        # The real provider still answers, once; a copy of its answer is a stray.
        net.providers[0].answer(cc.Call(call_id, inbox, 0, ["x y 1"], None), ["x y 1"])
        answer = drain(net.providers[0])[-1]
        net.caller.handle_packet(0.0, cc.parse(answer))
        net.caller.handle_packet(0.0, cc.parse(answer))
        (_, got), = net.outcomes()
        self.assertEqual((got.provider, got.lines), (real, ["x y 1"]))
        # Two strays: the answer sealed by a provider the call is not with, and the copy.
        self.assertEqual(net.caller.strays, 2)

    def test_a_provider_answers_every_who_at_once_within_its_bucket(self):
        p = cc.Provider("echo", 0.0, LEASE, identity(1))
        drain(p)
        aimed = "@ <%s> 0\ncall id 0000000000000001 reply_to radio\ncmd id 1\n" % p.inbox
        self.assertIsNone(p.handle_packet(0.0, cc.parse(aimed.encode())))
        self.assertEqual(drain(p), [])
        nonces = []
        for ms in range(1, 2001):
            nonce = "%016x" % ms
            p.handle_packet(ms / 1000.0, cc.parse(("@ <svc.echo> 0\nwho nonce %s\n" % nonce).encode()))
            for d in drain(p):
                body, key, _ = cc.open_seal(d)
                self.assertEqual(key, identity(1).key)
                nonces.append(body.decode().split("nonce ")[1].split()[0])
        # A burst of 10, then 10 a second: each echo at once, with its own nonce.
        self.assertEqual(nonces[:10], ["%016x" % ms for ms in range(1, 11)])
        self.assertTrue(28 <= len(nonces) <= 31, len(nonces))
        # A malformed nonce gets no answer; a bare `who` a plain announcement.
        p2 = cc.Provider("echo", 0.0, LEASE, identity(2))
        drain(p2)
        for bad in ("who nonce 12", "who nonce ZZZZZZZZZZZZZZZZ", 'who nonce "0000000000000001"'):
            p2.handle_packet(1.0, cc.parse(("@ <svc.echo> 0\n%s\n" % bad).encode()))
        self.assertEqual(drain(p2), [])
        p2.handle_packet(1.0, cc.parse(b"@ <svc.echo> 0\nwho\n"))
        (d,) = drain(p2)
        self.assertEqual(cc.parse(cc.open_seal(d).body).labels(), ["provider"])

    def test_forged_notices_neither_crash_nor_cut_a_providers_lease_nor_fill_memory(self):
        net = Net(1, 0.0)
        net.run(0.0)
        net.caller.call(0.0, ["warm up 1"])
        net.run(0.0)
        net.outcomes()
        # `leaving` for an id nobody knows.
        net.caller.handle_packet(0.0, cc.parse(b"@ <svc.echo> 0\nleaving id 0123456789abcdef\n"))
        net.stuck[0] = True
        net.caller.call(0.0, ["x y 1"], timeout=60.0)
        net.run(0.0)
        net.dead[0] = True
        # Its own announcements, sent again: a copy is refused, and a lease is never cut.
        copy = next(p for p in net.heard if p.labels()[0] == "provider")
        forged = net.caller.forged
        net.caller.handle_packet(0.0, copy)
        self.assertEqual(net.caller.forged, forged + 1)
        short = identity(1)
        short.n = 1000
        short = short.seal("@ <svc.echo> 0\nprovider id %s lease_ms 0\n" % pid(1)).decode()
        net.caller.handle_packet(0.0, cc.parse(short.encode()))
        net.caller.handle_timeout(1.0)
        self.assertEqual(net.outcomes(), [])
        flood = cc.Identity(bytes([77]) * 32)
        for i in range(2000):
            p = "@ <svc.echo> 0\nprovider id %016x lease_ms 3600000\n" % (1000 + i)
            net.caller.handle_packet(0.0, cc.parse(p.encode()))
            if i % 100 == 0:
                net.caller.handle_packet(0.0, cc.parse(flood.seal(p)))
        self.assertEqual(net.caller.providers(), [pid(1)])
        self.assertGreaterEqual(net.caller.forged, 2000)
        # Real keys of their own fill the table to 64 at most.
        for i in range(80):
            other = cc.Provider("echo", 0.0, 60.0)
            net.caller.handle_packet(0.0, cc.parse(drain(other)[0]))
        self.assertEqual(len(net.caller.providers()), 64)
        net.caller.handle_timeout(61.0)
        self.assertEqual(net.caller.providers(), [])

    def test_hostile_packets_never_raise(self):
        caller = cc.Caller("echo", "0000000000000007")
        p = cc.Provider("echo", 0.0, LEASE, identity(1))
        caller.handle_packet(0.0, cc.parse(drain(p)[0]))
        call_id = caller.call(0.0, ["x y 1"])
        drain(caller)
        key, sig = identity(1).key_hex, "ab" * 64
        for first in ["provider id %s lease_ms %s" % (pid(1), "9" * 5000),
                      "provider id %s lease_ms -5" % pid(1),
                      "provider id %s lease_ms (a 1)" % pid(1),
                      "provider id %s lease_ms 1e400" % pid(1),
                      "provider id %s" % pid(1),
                      "provider id (x %s) lease_ms 1" % pid(1),
                      "leaving", "provider", "who nonce " + "f" * 5000]:
            for seal in ["", "seal n 1 key %s sig %s\n" % (key, sig),
                         "seal n %s key %s sig %s\n" % ("9" * 30, key, sig),
                         "seal n 1 key %s sig %s\n" % (key.upper(), sig),
                         "seal n 1 key %s sig %s\n" % ("zz" * 32, sig)]:
                for text in ("@ <svc.echo> 0\n%s\n%s" % (first, seal),
                             identity(1).seal("@ <svc.echo> 0\n%s\n" % first).decode()):
                    caller.handle_packet(0.0, cc.parse(text.encode()))
                    p.handle_packet(0.0, cc.parse(text.encode()))
        for first in ["reply id %s from %s" % (call_id, pid(1)), "accepted id %s from %s" % (call_id, pid(1)),
                      "refused id %s from %s text (a 1)" % (call_id, pid(1)),
                      "refused id %s from %s" % (call_id, pid(1)), "reply", "reply id 5 from 6"]:
            for text in ("@ <reply.0000000000000007> 0\n%s\nseal n 1 key %s sig %s\n" % (first, key, sig),
                         identity(1).seal("@ <reply.0000000000000007> 0\n%s\n" % first).decode()):
                caller.handle_packet(0.0, cc.parse(text.encode()))
        self.assertGreaterEqual(caller.in_flight + len([caller.poll_outcome()]), 1)

    def test_ids_are_bare_and_a_reason_is_no_group(self):
        p = cc.Provider("echo", 0.0, LEASE, identity(1))
        caller = cc.Caller("echo", "0000000000000007")
        quoted = identity(1).seal('@ <svc.echo> 0\nprovider id "%s" lease_ms 3000\n' % p.id)
        caller.handle_packet(0.0, cc.parse(quoted))
        self.assertEqual(caller.providers(), [])
        caller.handle_packet(0.0, cc.parse(drain(p)[0]))
        self.assertEqual(caller.providers(), [p.id])
        me = identity(1)
        cases = [("007", "007"), ("1e5", "1e5"), ('"disk \\"full\\""', 'disk "full"'), ("(a 1)", None)]
        for i, (text, want) in enumerate(cases):
            now = i * 0.3
            call_id = caller.call(now, ["x y 1"], timeout=60.0)
            caller.handle_timeout(now + 0.26)  # an unproven provider is tried once the who wait is over
            drain(caller)
            answer = "@ <reply.0000000000000007> 0\nrefused id %s from %s text %s\n" % (call_id, p.id, text)
            caller.handle_packet(now + 0.26, cc.parse(me.seal(answer)))
            got = caller.poll_outcome()
            if want is None:
                self.assertIsNone(got)
            else:
                self.assertTrue(str(got[1]).endswith(": " + want), str(got[1]))

    def test_bad_names_and_lines_are_refused_at_once(self):
        for bad in ["a b", "x" * (cc.MAX_SERVICE_LEN + 1), "", 5, "a.0123456789abcdef"]:
            with self.assertRaises(ValueError):
                cc.Caller(bad)
        cc.Caller("x" * cc.MAX_SERVICE_LEN)
        cc.Caller("a.v2")
        with self.assertRaises(ValueError):
            cc.Caller("echo").call(0.0, ["x y 1"], timeout=0)
        with self.assertRaises(ValueError):
            cc.Caller("echo", ack_wait=0)
        caller = cc.Caller("echo")
        with self.assertRaises(cc.ParseError):
            caller.call(0.0, ["x ("])
        self.assertEqual(caller.in_flight, 0)

    def test_ids_that_look_like_numbers_stay_ids(self):
        # A provider id of decimal digits must not be read as an integer:
        # find a key whose fingerprint is all decimal digits (about 1 in 1800).
        seed = 0
        while True:
            seed += 1
            me = cc.Identity(seed.to_bytes(32, "little"))
            if ("%016x" % me.fingerprint).isdigit():
                break
        net = Net(0, 0.0)
        net.providers.append(cc.Provider("echo", 0.0, LEASE, me))
        net.dead.append(False)
        net.stuck.append(False)
        net.taken.append([])
        net.run(0.0)
        self.assertEqual(net.caller.providers(), ["%016x" % me.fingerprint])
        net.caller.call(0.0, ["x y 1"])
        net.run(0.0)
        (_, answer), = net.outcomes()
        self.assertEqual(answer.provider, "%016x" % me.fingerprint)


class ThroughTheRustHub(_HubCase):
    def serve(self, *args):
        path, _ = colony_bin()
        proc = subprocess.Popen(
            [path, "serve", "--hub", self.hub.addr_text] + list(args),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            env=_child_env(),
            preexec_fn=_die_with_parent if sys.platform.startswith("linux") else None,
        )

        def stop():
            if proc.poll() is None:
                proc.kill()
            proc.wait(timeout=5.0)
            proc.stdout.close()

        self.addCleanup(stop)
        first = proc.stdout.readline().decode()
        self.assertTrue(first.startswith("provider "), first)
        return proc, first.split()[1]

    def test_python_calls_a_rust_provider_and_the_rust_cli_calls_a_python_one(self):
        self.serve("--echo", "echo")
        with cc.CallClient(self.hub.addr, "echo") as c:
            answer = c.call(['text value "hi there"', "n value 3"], timeout=10.0)
        self.assertEqual(answer.lines, ['text value "hi there"', "n value 3"])

        server = cc.ServeClient(self.hub.addr, "upper", lease=3.0)
        self.addCleanup(server.close)
        path, _ = colony_bin()
        call = subprocess.Popen(
            [path, "call", "--hub", self.hub.addr_text, "--timeout", "10", "upper", 'text value "abc"'],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env=_child_env(),
        )
        deadline = time.monotonic() + 20.0
        while call.poll() is None and time.monotonic() < deadline:
            server.poll(lambda c: [l.upper() for l in c.lines])
            time.sleep(0.005)
        out, err = call.communicate(timeout=5.0)
        self.assertEqual(call.returncode, 0, err)
        self.assertEqual(out.decode(), 'TEXT VALUE "ABC"\n')

    def test_a_python_handler_that_raises_refuses_the_call_with_its_message(self):
        server = cc.ServeClient(self.hub.addr, "broken")
        self.addCleanup(server.close)
        with cc.CallClient(self.hub.addr, "broken") as c:
            call_id = c.start(["x y 1"], timeout=10.0)

            def handler(call):
                raise RuntimeError("no such thing")

            deadline = time.monotonic() + 20.0
            outcome = None
            while outcome is None and time.monotonic() < deadline:
                server.poll(handler)
                c.poll()
                outcome = c.poll_outcome()
                time.sleep(0.005)
        self.assertIsNotNone(outcome)
        self.assertEqual(outcome[0], call_id)
        self.assertEqual(outcome[1].kind, "refused")
        self.assertIn("RuntimeError: no such thing", str(outcome[1]))

    def test_calls_spread_over_two_providers_end_once_when_one_is_killed(self):
        slow = ["--lease", "5", "work", "--", "sh", "-c", "sleep 0.02; cat"]
        first, first_id = self.serve(*slow)
        self.serve(*slow)
        ended = {}
        with cc.CallClient(self.hub.addr, "work") as c:
            deadline = time.monotonic() + 20.0
            while len(c.caller.providers()) < 2 and time.monotonic() < deadline:
                c.poll()
                time.sleep(0.01)
            started = {}
            killed = False
            deadline = time.monotonic() + 120.0
            while len(ended) < 40 and time.monotonic() < deadline:
                while len(started) < 40 and c.caller.in_flight < 6:
                    n = len(started)
                    started[c.start(["n value %d" % n], timeout=60.0)] = n
                c.poll()
                got = c.poll_outcome()
                while got is not None:
                    self.assertNotIn(got[0], ended, "a call ended twice")
                    ended[got[0]] = got[1]
                    got = c.poll_outcome()
                if not killed and len(ended) >= 20:
                    first.kill()
                    killed = True
                time.sleep(0.005)
        self.assertEqual(len(ended), 40)
        for call_id, result in ended.items():
            if isinstance(result, cc.Answer):
                self.assertEqual(result.lines, ["n value %d" % started[call_id]])
            else:
                self.assertIn(result.kind, ("provider_lapsed", "timeout"), str(result))
                self.assertEqual(result.provider, first_id)

    def provider_on_hub(self, service):
        """A sans-IO provider on a client of its own, driven by the test."""
        client = self.client()
        provider = cc.Provider(service, time.monotonic(), LEASE)
        for subject in provider.subjects():
            client.subscribe(subject)
        deadline = time.monotonic() + 5.0
        while client.lease_ms is None and time.monotonic() < deadline:
            client.poll()
            list(client)
            time.sleep(0.01)
        return client, provider

    def flush(self, client, side):
        for d in drain(side):
            client.publish_raw(d)

    def test_a_forged_answer_through_the_hub_is_not_taken(self):
        pclient, provider = self.provider_on_hub("slow")
        forger = self.client()
        forger.subscribe(provider.inbox)  # sees every call and where its answer goes
        taken = []
        seen = []
        with cc.CallClient(self.hub.addr, "slow") as c:
            call_id = c.start(["x y 1"], timeout=10.0)
            deadline = time.monotonic() + 10.0
            while not (taken and seen) and time.monotonic() < deadline:
                c.poll()
                pclient.poll()
                for packet in pclient:
                    call = provider.handle_packet(time.monotonic(), packet)
                    if call is not None:
                        taken.append(call)
                self.flush(pclient, provider)
                forger.poll()
                seen.extend(p for p in forger if p.labels()[0] == "call")
                time.sleep(0.005)
            self.assertTrue(taken and seen, "the call never reached the provider")
            inbox = seen[0].line("call")["reply_to"]
            self.assertEqual(inbox, c.caller.inbox)
            text = "@ <%s> 0\nreply id %s from %s\nx y 666\n" % (inbox, call_id, provider.id)
            forger.publish_raw(text)
            forger.publish_raw(cc.Identity().seal(text))
            wait = time.monotonic() + 0.5
            while time.monotonic() < wait:
                c.poll()
                self.assertIsNone(c.poll_outcome())
                time.sleep(0.01)
            self.assertEqual(c.caller.forged, 2)
            provider.answer(taken[0], ["x y 2"])
            self.flush(pclient, provider)
            outcome = None
            deadline = time.monotonic() + 5.0
            while outcome is None and time.monotonic() < deadline:
                c.poll()
                outcome = c.poll_outcome()
                time.sleep(0.005)
        self.assertIsInstance(outcome[1], cc.Answer)
        self.assertEqual((outcome[1].provider, outcome[1].lines), (provider.id, ["x y 2"]))

    def test_a_provider_that_never_accepts_is_skipped_within_the_ack_wait(self):
        zclient, zombie = self.provider_on_hub("work")
        live = cc.ServeClient(self.hub.addr, "work", lease=LEASE)
        self.addCleanup(live.close)
        answers = []
        with cc.CallClient(self.hub.addr, "work") as c:
            started = time.monotonic()
            for i in range(6):
                call_id = c.start(["n value %d" % i], timeout=10.0)
                outcome = None
                deadline = time.monotonic() + 10.0
                while outcome is None and time.monotonic() < deadline:
                    c.poll()
                    live.poll(lambda call: call.lines)
                    # The zombie answers `who` (and announces) but takes no call.
                    zclient.poll()
                    for packet in zclient:
                        if packet.subjects == [zombie.channel]:
                            zombie.handle_packet(time.monotonic(), packet)
                    zombie.handle_timeout(time.monotonic())
                    self.flush(zclient, zombie)
                    outcome = c.poll_outcome()
                    time.sleep(0.002)
                self.assertIsNotNone(outcome, "call %d never ended" % i)
                self.assertEqual(outcome[0], call_id)
                answers.append(outcome[1])
            elapsed = time.monotonic() - started
            order = c.caller.providers()
        self.assertTrue(all(isinstance(a, cc.Answer) for a in answers), answers)
        self.assertEqual({a.provider for a in answers}, {live.provider.id})
        # The live provider first; the zombie last, or already forgotten for its silence.
        self.assertEqual(order[0], live.provider.id)
        self.assertIn(order[1:], ([], [zombie.id]))
        # How long it took is measured, not asserted: a busy machine may be slow.
        print("six calls past a zombie provider took %.2f s" % elapsed, file=sys.stderr)


if __name__ == "__main__":
    unittest.main()
